"""Collision statistics over random poses and clearance at the keyframes."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ..errors import (
    PoseError,
    UnknownNameError,
)

if TYPE_CHECKING:
    from ..arm import Arm

from ..arm import random_poses
from .checker import PairDistance, checker
from .pairs import AMBIGUITY_BAND, DISTANCE_ENGINES, Array, DistanceEngine, GeomPair, find_pair


@dataclass(frozen=True)
class PairStatistics:
    """One pair over a sample of poses.

    Attributes:
        pair: The pair.
        poses: Poses in which MuJoCo lists at least one contact for the pair.
        contacts: Contacts MuJoCo lists for the pair, summed over the poses (a capsule pair
            can give two per pose, a box pair up to eight).
        closest: Smallest signed distance over the poses [m] (``nan`` without distances).
        closest_pose: Index of that pose in the sample (-1 without distances).
    """

    pair: GeomPair
    poses: int
    contacts: int
    closest: float
    closest_pose: int


@dataclass(frozen=True)
class KeyframeClearance:
    """Self-collision at one keyframe.

    Attributes:
        keyframe: Keyframe name.
        q: Its pose [rad or m].
        contacts: Number of contacts MuJoCo lists there.
        closest: The pair with the smallest clearance, with its distance (None: no pairs).
    """

    keyframe: str
    q: Array
    contacts: int
    closest: PairDistance | None


@dataclass(frozen=True)
class CollisionStatistics:
    """Self-collision over random poses, as the lesson's table (4), labelled honestly.

    Attributes:
        n_poses: Number of poses drawn.
        seed: Seed of ``np.random.default_rng``.
        distance_engine: Engine of the distances (``None``: contacts only).
        poses_with_contact: Poses in which MuJoCo lists at least one contact.
        pairs: Per pair, in pair-set order.
        keyframes: Clearance at each keyframe.
        disagreements: Poses where the distance engine's touching pairs differ from MuJoCo's
            contact pairs, not counting pairs within :data:`AMBIGUITY_BAND` of their threshold
            (0 expected; -1 without distances).
        seconds: Wall time of the sweep [s].
    """

    n_poses: int
    seed: int | None
    distance_engine: str | None
    poses_with_contact: int
    pairs: tuple[PairStatistics, ...]
    keyframes: tuple[KeyframeClearance, ...]
    disagreements: int
    seconds: float

    @property
    def share_with_contact(self) -> float:
        """Fraction of the poses with at least one contact, in [0, 1]."""
        return self.poses_with_contact / self.n_poses if self.n_poses else 0.0

    def of(self, name1: str, name2: str) -> PairStatistics:
        """The statistics of the pair of geoms so named (either order)."""
        pair = find_pair([p.pair for p in self.pairs], name1, name2)
        return next(p for p in self.pairs if p.pair == pair)

    def ranked(self) -> list[PairStatistics]:
        """Pairs that touched at least once, most poses first (ties: most contacts)."""
        hit = [p for p in self.pairs if p.poses]
        return sorted(hit, key=lambda p: (-p.poses, -p.contacts, p.pair.label))

    def lines(self, top: int | None = None) -> list[str]:
        """The table as text lines: share of poses, then per pair poses and contacts."""
        out = [
            f"{self.n_poses} random poses (seed {self.seed}): {100 * self.share_with_contact:.1f}% "
            f"have at least one self-contact (MuJoCo's contact list)"
        ]
        dist = self.distance_engine is not None
        head = f"  {'pair':<24}{'poses':>7}{'contacts':>10}"
        out.append(head + (f"{'closest (m)':>13}" if dist else ""))
        rows = (
            self.ranked() if not dist else sorted(self.pairs, key=lambda p: (-p.poses, p.closest))
        )
        for p in rows[:top]:
            line = f"  {p.pair.label:<24}{p.poses:>7}{p.contacts:>10}"
            out.append(line + (f"{p.closest:>13.4f}" if dist else ""))
        for k in self.keyframes:
            c = k.closest
            near = f", closest {c.pair.label} at {c.distance:.4f} m" if c is not None else ""
            out.append(f"  at the {k.keyframe} pose: {k.contacts} contacts{near}")
        if dist:
            out.append(
                f"  distances by {self.distance_engine}; poses where its touching pairs differ "
                f"from MuJoCo's contacts: {self.disagreements}"
            )
        return out


def collision_statistics(
    arm: Arm,
    n_poses: int = 10000,
    seed: int | None = 1,
    distances: DistanceEngine | None = "coal",
    poses: ArrayLike | None = None,
) -> CollisionStatistics:
    """Self-collision over random poses: contacts by MuJoCo, closest approach by an engine.

    Contacts are MuJoCo's (``mj_kinematics`` + ``mj_collision`` per pose, as the lesson's
    ``mj_forward`` finds them). With ``distances`` set, every pair's signed distance is also
    computed at every pose, giving the closest approach per pair and a cross-check: the
    engine's touching pairs must equal MuJoCo's contact pairs at every pose (pairs within
    :data:`AMBIGUITY_BAND` of their threshold aside).

    Args:
        arm: The arm.
        n_poses: Number of random poses (ignored when ``poses`` is given).
        seed: Seed; ``seed=1`` with 10000 poses is the lesson's sample.
        distances: ``"coal"``, ``"mujoco"`` or ``None`` (contacts only, fastest).
        poses: Explicit poses, shape (n, nq) [rad or m], instead of random ones.
    """
    ch = checker(arm)
    if poses is None:
        Q = random_poses(arm, n_poses, seed)
    else:
        try:
            Q = np.asarray(poses, dtype=float)
        except (TypeError, ValueError) as err:
            raise PoseError(f"poses must be an array of shape (n, {arm.nq}): {err}") from err
        if Q.ndim != 2 or Q.shape[1] != arm.nq:
            raise PoseError(f"poses must have shape (n, {arm.nq}), got {Q.shape}")
        Q = np.array([arm.pose(q) for q in Q]).reshape(-1, arm.nq)
    if distances is not None and distances not in DISTANCE_ENGINES:
        raise UnknownNameError("distance engine", str(distances), DISTANCE_ENGINES)
    npair = len(ch.pairs)
    thr = np.array([p.threshold for p in ch.pairs])
    pose_hits = np.zeros(npair, dtype=int)
    contact_hits = np.zeros(npair, dtype=int)
    closest = np.full(npair, np.inf)
    closest_at = np.full(npair, -1)
    with_contact = 0
    disagree = 0
    # The poses are validated above: call the engines' scenes directly, without per-pose checks.
    measure = None
    if distances == "coal":
        measure = ch._coal.distance_values
    elif distances == "mujoco":

        def measure(q: Array) -> Array:
            return ch._mj.distances(q)[0]

    t0 = time.perf_counter()
    for i, q in enumerate(Q):
        idx, _ = ch._mj.collide(q)
        if len(idx):
            with_contact += 1
            np.add.at(contact_hits, idx, 1)
            touched = np.zeros(npair, dtype=bool)
            touched[idx] = True
            pose_hits += touched
        if measure is not None:
            d = measure(q)
            better = d < closest
            closest[better] = d[better]
            closest_at[better] = i
            # Cross-check: the engine's touching pairs against MuJoCo's contact pairs.
            fuzzy = np.abs(d - thr) < AMBIGUITY_BAND
            listed = np.zeros(npair, dtype=bool)
            listed[idx] = True
            if (((d < thr) != listed) & ~fuzzy).any():
                disagree += 1
    seconds = time.perf_counter() - t0
    stats = tuple(
        PairStatistics(
            p,
            int(pose_hits[k]),
            int(contact_hits[k]),
            float(closest[k]) if distances is not None and len(Q) else float("nan"),
            int(closest_at[k]),
        )
        for k, p in enumerate(ch.pairs)
    )
    return CollisionStatistics(
        n_poses=len(Q),
        seed=seed if poses is None else None,
        distance_engine=distances,
        poses_with_contact=with_contact,
        pairs=stats,
        keyframes=keyframe_clearance(arm, distances or "coal"),
        disagreements=disagree if distances is not None else -1,
        seconds=seconds,
    )


def keyframe_clearance(arm: Arm, engine: DistanceEngine = "coal") -> tuple[KeyframeClearance, ...]:
    """Contacts and the closest pair at every keyframe of the model."""
    ch = checker(arm)
    out = []
    for name, q in arm.keyframes.items():
        out.append(KeyframeClearance(name, q, len(ch.contacts(q)), ch.distances(q, engine).closest))
    return tuple(out)

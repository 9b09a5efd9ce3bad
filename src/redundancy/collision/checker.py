"""The collision checker of one arm: distances from coal and from MuJoCo, MuJoCo's contacts.

[`CollisionChecker`][redundancy.CollisionChecker] gives, at one pose, the signed distance and
nearest points of every pair of the pair set ([`collision_pairs`][redundancy.collision_pairs]) from
coal (geoms placed by Pinocchio's forward kinematics, `coal_scene`) or from MuJoCo
(``mj_geomDistance``, `mujoco_scene`), and MuJoCo's own contact list (``mj_collision``).

Sign convention: a distance is positive when the geoms are apart and negative when they
overlap [m]. MuJoCo lists a contact for a pair when the distance is below the pair's
``threshold`` (margin + gap, zero unless the model sets them); "touching" here means the same.

Threads: a checker may be used from any number of threads at once. The engines' models are
shared and only read; each thread gets its own scenes (``MjData``, Pinocchio ``Data`` and
``GeometryData``) on first use, so results equal sequential ones bit for bit.
"""

from __future__ import annotations

import weakref
from collections.abc import Sequence
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ..arm import check_arm
from ..arm_coupled import ChainView
from ..caching import PerObject
from ..checks import check_choice
from ..engines.threads import PerThread
from ..errors import GeomPlacementError, MissingMeshError, UnsupportedFeatureError
from .coal_scene import CoalPairs, CoalScene
from .mujoco_scene import Contact, MujocoPairs, MujocoScene
from .pairs import (
    DISTANCE_ENGINES,
    Array,
    DistanceEngine,
    GeomPair,
    NearPair,
    collision_pairs,
    find_pair,
)

if TYPE_CHECKING:
    from ..arm import Arm

__all__ = [
    "CollisionChecker",
    "Contact",
    "Distances",
    "PairDistance",
    "checker",
    "contacts",
    "distances",
]


@dataclass(frozen=True)
class PairDistance(NearPair):
    """Signed distance between the two geoms of a pair at one pose.

    Attributes:
        pair: The pair.
        distance: Signed distance, negative when the geoms overlap [m].
        point1: Nearest (witness) point on ``pair.geom1``, world frame [m].
        point2: Nearest (witness) point on ``pair.geom2``, world frame [m].
    """

    pair: GeomPair
    distance: float
    point1: Array
    point2: Array

    @property
    def clearance(self) -> float:
        """Distance left before contact: distance minus the pair's threshold [m]."""
        return self.distance - self.pair.threshold


@dataclass(frozen=True)
class Distances:
    """Every pair's signed distance at one pose, from one engine.

    Attributes:
        q: The pose [rad or m].
        engine: ``"coal"`` or ``"mujoco"``.
        pairs: One entry per pair of the pair set, in its order.
    """

    q: Array
    engine: str
    pairs: tuple[PairDistance, ...]

    @property
    def values(self) -> Array:
        """The signed distances as an array, in pair order [m]."""
        return np.array([p.distance for p in self.pairs])

    @property
    def closest(self) -> PairDistance | None:
        """The pair with the smallest clearance (None when there are no pairs)."""
        return min(self.pairs, key=lambda p: p.clearance, default=None)

    @property
    def touching(self) -> tuple[PairDistance, ...]:
        """The pairs below their contact threshold."""
        return tuple(p for p in self.pairs if p.touching)

    @property
    def free(self) -> bool:
        """True when no pair touches."""
        return not self.touching

    def of(self, name1: str, name2: str) -> PairDistance:
        """The entry of the pair of geoms so named (either order)."""
        pair = find_pair([p.pair for p in self.pairs], name1, name2)
        return next(p for p in self.pairs if p.pair == pair)


class CollisionChecker:
    """Self-collision queries on one arm: pair set, distances (coal, MuJoCo), contacts.

    Build it once per arm (or let `checker` cache one per arm); it owns private engine data, one set
    per thread, so the arm's own data is left alone and threads never share a workspace.

    Args:
        arm: The loaded arm.
        pairs: The pairs to check; defaults to [`collision_pairs`][redundancy.collision_pairs] of
            the arm's model.

    Keyword Args:
        weak: Hold the arm weakly (for caches kept alongside the arm).

    Attributes:
        arm: The arm.
        pairs: The pair set, shared by both engines.

    Raises:
        MissingMeshError: The file names meshes found nowhere (``arm.missing_meshes``).
        UnsupportedFeatureError: Flex objects, height-field or SDF geoms in a pair, a flat
            mesh, or a geom on an unnamed body.
        GeomPlacementError: Pinocchio's geom placements differ from MuJoCo's (self-check at
            build; a ModelError).
    """

    #: Largest difference allowed between the engines' geom placements in the self-check.
    PLACEMENT_TOL = 1e-9

    def __init__(
        self, arm: Arm, pairs: Sequence[GeomPair] | None = None, *, weak: bool = False
    ) -> None:
        m = arm.mj_model
        if arm.missing_meshes:  # the file's collision geometry is not all there
            raise MissingMeshError(arm.missing_meshes)
        if m.nflex:
            raise UnsupportedFeatureError(
                "flex", f"{m.nflex} in the model", "only rigid geoms are checked"
            )
        #  The cached checker of `checker` lives as long as its arm and must not keep it alive: it
        # holds the arm weakly (everything else it needs, it holds itself).
        self._arm: Arm | None = None if weak else arm
        self._arm_ref = weakref.ref(arm)
        self.pairs: tuple[GeomPair, ...] = tuple(collision_pairs(m) if pairs is None else pairs)
        self._mujoco_pairs = MujocoPairs(m, self.pairs)
        # A coupled arm's scenes hold its chain model (every joint it moves, followers too).
        pin_chain = arm.pinocchio if arm.coupling is None else ChainView(arm).pinocchio
        self._coal_pairs = CoalPairs(m, pin_chain.model, pin_chain.perm, self.pairs)
        #: Pinocchio's engine of the scenes' model (the chain's, for a coupled arm).
        self.scene_pinocchio = pin_chain
        # One scene per engine and thread, built on the thread's first use.
        self._mujoco = PerThread(partial(MujocoScene, self._mujoco_pairs))
        self._coal = PerThread(partial(CoalScene, self._coal_pairs))
        for q in _self_check_poses(arm):
            err = self.placement_error(q)
            if err > self.PLACEMENT_TOL:
                raise GeomPlacementError(
                    f"Pinocchio and MuJoCo place the collision geoms differently at q = "
                    f"{np.round(q, 4).tolist()} (largest difference {err:.3g} in a position [m] "
                    "or a rotation-matrix entry); the engines do not see the same bodies"
                )

    @property
    def arm(self) -> Arm:
        """The arm."""
        arm = self._arm if self._arm is not None else self._arm_ref()
        if arm is None:
            raise ReferenceError("the arm of this collision checker has been freed")
        return arm

    # -- this thread's scenes -------------------------------------------------------------
    def mujoco_scene(self) -> MujocoScene:
        """This thread's MuJoCo scene (built on first use; never shared between threads)."""
        return self._mujoco.get()

    def coal_scene(self) -> CoalScene:
        """This thread's coal scene (built on first use; never shared between threads)."""
        return self._coal.get()

    # -- checks --------------------------------------------------------------------------
    def _q(self, q: ArrayLike) -> Array:
        """The pose the scenes place: the arm's, or a coupled arm's chain pose."""
        arm = self.arm
        return arm.pose(q) if arm.coupling is None else arm.chain_pose(q)

    def scene_poses(self, Q: Array) -> Array:
        """What the scenes place for checked poses ``Q`` (n, nq): ``Q``, or the chain poses.

        Raises:
            PoseError: A coupled arm's loop that cannot close at one of the poses.
        """
        arm = self.arm
        return Q if arm.coupling is None else arm._chain_stack(Q)[0]

    def placement_error(self, q: ArrayLike) -> float:
        """Largest difference between Pinocchio's and MuJoCo's geom poses at ``q``.

        Positions [m] and rotation-matrix entries compared, max over the geoms in the pairs.
        """
        q = self._q(q)
        coal, mj = self.coal_scene(), self.mujoco_scene()
        coal.place(q)
        mj.place(q)
        err = 0.0
        for g in self._coal_pairs.slot:
            p, R = coal.geom_pose(g)
            err = max(
                err,
                float(np.abs(p - mj.data.geom_xpos[g]).max()),
                float(np.abs(R - mj.data.geom_xmat[g].reshape(3, 3)).max()),
            )
        return err

    # -- queries ---------------------------------------------------------------------------
    def distances(self, q: ArrayLike, engine: DistanceEngine = "coal") -> Distances:
        """Signed distance and nearest points of every pair at ``q``.

        Args:
            q: Joint configuration [rad or m].
            engine: ``"coal"`` (geoms placed by Pinocchio) or ``"mujoco"`` (``mj_geomDistance``).
        """
        arm = self.arm
        q = arm.pose(q)
        scene = self.scene(engine)
        # A coupled arm's scene places its chain pose.
        dist, p1, p2 = scene.distances(q if arm.coupling is None else arm.chain_pose(q))
        entries = tuple(
            PairDistance(p, float(dist[k]), p1[k].copy(), p2[k].copy())
            for k, p in enumerate(self.pairs)
        )
        return Distances(q.copy(), engine, entries)

    def distance_values(self, q: ArrayLike, engine: DistanceEngine = "coal") -> Array:
        """Signed distance of every pair at ``q``, in pair order, without nearest points [m]."""
        q = self._q(q)
        return self.scene(engine).distance_values(q)

    def scene(self, engine: DistanceEngine) -> MujocoScene | CoalScene:
        """This thread's scene of a distance engine (``"coal"`` or ``"mujoco"``)."""
        if check_choice("distance engine", engine, DISTANCE_ENGINES) == "coal":
            return self.coal_scene()
        return self.mujoco_scene()

    def contacts(self, q: ArrayLike) -> tuple[Contact, ...]:
        """MuJoCo's contact list at ``q`` (``mj_kinematics`` + ``mj_collision``)."""
        return self.mujoco_scene().contacts(self._q(q))

    def contact_pairs(self, q: ArrayLike) -> frozenset[GeomPair]:
        """The pairs for which MuJoCo lists at least one contact at ``q``."""
        idx, _ = self.mujoco_scene().collide(self._q(q))
        return frozenset(self.pairs[i] for i in idx)

    def touching_pairs(self, q: ArrayLike, engine: DistanceEngine = "coal") -> frozenset[GeomPair]:
        """The pairs below their contact threshold at ``q``, by the engine's distances."""
        dist = self.distance_values(q, engine)
        return frozenset(p for p, d in zip(self.pairs, dist, strict=True) if d < p.threshold)

    def pair(self, name1: str, name2: str) -> GeomPair:
        """The pair of the geoms so named (either order)."""
        return find_pair(self.pairs, name1, name2)

    def __repr__(self) -> str:
        return f"CollisionChecker({self.arm!r}, {len(self.pairs)} pairs)"


def _self_check_poses(arm: Arm) -> list[Array]:
    """The reference pose and `_probe_pose` (a coupled arm's probe where its loops close)."""
    if arm.coupling is None:
        return [arm.mj_model.qpos0.copy(), _probe_pose(arm)]
    probe = _probe_pose(arm)
    return [arm.coupling.q_rest.copy(), *([probe] if arm._closes(probe) else [])]


def _probe_pose(arm: Arm) -> Array:
    """A fixed, unremarkable pose inside the joint ranges (for the placement self-check)."""
    lo = np.where(np.isfinite(arm.lower), arm.lower, -1.0)
    hi = np.where(np.isfinite(arm.upper), arm.upper, 1.0)
    frac = (np.arange(arm.nq) * 0.618034 + 0.3) % 1.0
    return lo + frac * (hi - lo)


_CHECKERS: PerObject[Arm, CollisionChecker] = PerObject(
    lambda arm: CollisionChecker(arm, weak=True)
)


def checker(arm: Arm) -> CollisionChecker:
    """The `CollisionChecker` of an arm with its full pair set, built once and cached.

    The cache never keeps an arm alive and is safe to fill from several threads at once.

    Raises:
        ParameterError: ``arm`` is not an Arm.
    """
    return _CHECKERS.get(check_arm(arm))


def distances(arm: Arm, q: ArrayLike, engine: DistanceEngine = "coal") -> Distances:
    """Signed distance and nearest points of every pair at ``q`` (see `CollisionChecker`)."""
    return checker(arm).distances(q, engine)


def contacts(arm: Arm, q: ArrayLike) -> tuple[Contact, ...]:
    """MuJoCo's contact list at ``q`` (see [`CollisionChecker`][redundancy.CollisionChecker])."""
    return checker(arm).contacts(q)

"""The sections both reports are made of, each computed once: joints, keyframes, gravity, contacts.

The audit judges these and arm7's example tables format them; neither computes them again. The
numbers come from the [`Arm`][redundancy.Arm], [`redundancy.analysis.batch`][redundancy.batch]
and [`redundancy.collision`][redundancy.collision]; what MuJoCo simulates beyond them
(integrator, flags, actuator ranges, servo damping, gravity compensation) from
`redundancy.model.actuators`.

Sweeps over random poses run in chunks of at most `CHUNK` poses drawn from one generator, so memory
stays flat in the number of poses and the chunks are exactly the poses of
[`redundancy.random_poses`][redundancy.random_poses] ``(arm, n, seed)``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .. import kernels, linalg
from ..analysis import batch
from ..analysis.agreement import PairError, largest, merge_pairs, pair_errors
from ..analysis.crosscheck import TOLERANCES, Agreement, merge_worst, quantity_errors, worst
from ..arm import Arm, random_pose_chunks
from ..collision import (
    CollisionStatistics,
    DistanceEngine,
    PairStatistics,
    checker,
    collision_statistics,
    keyframe_clearance,
)
from ..collision.statistics import ContactShare
from ..engines import REFERENCE
from ..errors import GeomPlacementError
from ..model import actuators
from ..model.scales import arm_scales
from .pose_sections import (
    ActuatorLoad,
    JointSection,
    KeyframeRow,
    compared_engines,
    joints,
    keyframes,
    reference_keyframe,
)
from .pose_sections import FollowerRow as FollowerRow  # a coupled arm's followers
from .pose_sections import JointRow as JointRow  # the joint table's rows, named here too

Array = NDArray[np.float64]

#: Poses per chunk of a sweep (a few KB of work arrays per pose).
CHUNK = 10_000

#: Called as a sweep advances: ``(stage, done, total)``, a short label and the poses done of
#: the stage's total (``done == 0`` when the stage starts).
Progress = Callable[[str, int, int], object]


def _quiet(label: str, done: int, total: int) -> None:
    """The default `Progress`: says nothing."""


def pose_chunks(arm: Arm, n: int, seed: int | None, size: int | None = None) -> Iterator[Array]:
    """``n`` random poses in the joint ranges, in chunks of ``size`` (default `CHUNK`) rows.

    Concatenated, the chunks equal [`redundancy.random_poses`][redundancy.random_poses]
    ``(arm, n, seed)``.
    """
    return random_pose_chunks(arm, n, seed, size or CHUNK)


# -- gravity against the actuators ----------------------------------------------------------------
@dataclass(frozen=True)
class GravityBudget:
    """Gravity against the actuators over random poses, per joint and direction.

    Attributes:
        n_poses: Poses drawn.
        seed: Their seed.
        low: Most negative torque the actuators must give, per joint [N m or N].
        high: Most positive [N m or N].
        limit_lower: Most negative torque they can give, per joint; where it depends on the
            pose (servos), its least negative value over the poses [N m or N].
        limit_upper: Most positive torque they can give; where it varies, its smallest [N m].
        varies: Per joint, whether the limits depend on the pose.
        over_low: Per joint, poses needing more negative torque than the actuators give.
        over_high: Per joint, poses needing more positive torque than they give.
        worst_low: Per joint, (need, limit) at the pose with the largest negative shortfall
            (NaN where there is none) [N m or N].
        worst_high: The same for the positive direction [N m or N].
        n_over: Poses where some joint's need is outside its range.
        engine_diff: Largest |Pinocchio - MuJoCo| gravity torque [N m or N].
        gravcomp: Whether gravity compensation is subtracted.
        gravity_enabled: False when the model disables gravity (the needs are then 0).
        agreement: The engines' gravity torques by the cross-check's measure, worst pose
            counted over the sweep: the audit's ``gravity`` row, taken from the torques
            computed here rather than computed again.
    """

    n_poses: int
    seed: int | None
    low: Array
    high: Array
    limit_lower: Array
    limit_upper: Array
    varies: NDArray[np.bool_]
    over_low: NDArray[np.int_]
    over_high: NDArray[np.int_]
    worst_low: Array
    worst_high: Array
    n_over: int
    engine_diff: float
    gravcomp: bool
    gravity_enabled: bool
    agreement: Agreement

    @property
    def peak(self) -> Array:
        """Largest |torque| the actuators must give, per joint [N m or N]."""
        return np.maximum(-self.low, self.high)

    @property
    def ratio(self) -> Array:
        """Per joint, limit / need in the direction that binds (``inf``: never loaded) [-]."""
        with np.errstate(divide="ignore", invalid="ignore"):
            up = np.where(self.high > 1e-9, self.limit_upper / self.high, np.inf)
            down = np.where(self.low < -1e-9, self.limit_lower / self.low, np.inf)
        return np.minimum(up, down)


class _Worst:
    """Per joint, the largest shortfall seen so far and the (need, limit) where it occurred."""

    def __init__(self, nv: int) -> None:
        self.short = np.zeros(nv)
        self.at = np.full((nv, 2), np.nan)

    def add(self, short: Array, need: Array, limit: Array) -> None:
        rows = np.argmax(short, axis=0)
        cols = np.arange(short.shape[1])
        better = short[rows, cols] > self.short
        self.short[better] = short[rows, cols][better]
        self.at[better] = np.stack([need[rows, cols], limit[rows, cols]], axis=1)[better]


def gravity_budget(
    arm: Arm, n_poses: int, seed: int | None = 0, progress: Progress | None = None
) -> GravityBudget:
    """Holding torque over ``n_poses`` random poses against the actuators, in chunks.

    ``progress`` is called with ``("gravity", done, n_poses)`` as the chunks go.
    """
    say = progress or _quiet
    say("gravity", 0, n_poses)
    nv = arm.nq
    load = ActuatorLoad(arm)
    low, high = np.zeros(nv), np.zeros(nv)
    lim_lo, lim_hi = np.full(nv, -np.inf), np.full(nv, np.inf)
    lo_min, hi_max = np.full(nv, np.inf), np.full(nv, -np.inf)
    over_low = np.zeros(nv, dtype=int)
    over_high = np.zeros(nv, dtype=int)
    worst_low, worst_high = _Worst(nv), _Worst(nv)
    n_over, diff = 0, 0.0
    found, offset = (0.0, 0), 0
    scales = arm_scales(arm)
    pairs: tuple[PairError, ...] = ()
    for Q in pose_chunks(arm, n_poses, seed):
        tau = batch.gravities(arm, Q, REFERENCE)
        taus = {REFERENCE: tau}
        for other in compared_engines(arm):
            tau_p = taus[other] = batch.gravities(arm, Q, other)
            diff = max(diff, float(np.max(np.abs(tau - tau_p))))
        each = pair_errors(taus, lambda a, b: quantity_errors("gravity", a, b, scales), list(taus))
        errors = np.maximum.reduce(list(each.values()))
        found = merge_worst(found, worst(errors), offset)
        pairs = merge_pairs(pairs, tuple((a, b, largest(e)) for (a, b), e in each.items()))
        offset += len(Q)
        need, effort = load(Q, tau)
        low, high = np.minimum(low, need.min(axis=0)), np.maximum(high, need.max(axis=0))
        lim_lo = np.maximum(lim_lo, effort.lower.max(axis=0))
        lim_hi = np.minimum(lim_hi, effort.upper.min(axis=0))
        lo_min = np.minimum(lo_min, effort.lower.min(axis=0))
        hi_max = np.maximum(hi_max, effort.upper.max(axis=0))
        with np.errstate(invalid="ignore"):  # inf - inf where unlimited: no shortfall
            worst_low.add(np.nan_to_num(effort.lower - need, nan=0.0), need, effort.lower)
            worst_high.add(np.nan_to_num(need - effort.upper, nan=0.0), need, effort.upper)
        below, above = need < effort.lower, need > effort.upper
        over_low += below.sum(axis=0)
        over_high += above.sum(axis=0)
        n_over += int(np.sum((below | above).any(axis=1)))
        say("gravity", offset, n_poses)
    sim = actuators.simulation(arm.mj_model)
    return GravityBudget(
        n_poses,
        seed,
        low,
        high,
        lim_lo,
        lim_hi,
        (lo_min != lim_lo) | (hi_max != lim_hi),
        over_low,
        over_high,
        worst_low.at,
        worst_high.at,
        n_over,
        diff,
        load.uniform != 0.0,
        sim.gravity_enabled,
        Agreement("gravity", found[0], TOLERANCES["gravity"], found[1], pairs),
    )


# -- self-collision -------------------------------------------------------------------------------
def contacts(
    arm: Arm,
    n_poses: int,
    seed: int | None = 1,
    distances: str | None = "coal",
    progress: Progress | None = None,
) -> CollisionStatistics:
    """Self-collision over random poses (`redundancy.collision_statistics`), in chunks.

    Contacts are MuJoCo's; with ``distances`` (coal by default: the other engine, and the
    faster one) every pair's distance gives its closest approach, and the distance engine's
    touching pairs are checked against MuJoCo's contacts at every pose (``disagreements``).
    Chunk results are merged exactly: counts add, the closest approach is the minimum (its
    pose index counted over the whole sample), the sweep time adds up. ``progress`` is called
    with ``("self-collision", done, n_poses)`` as the chunks go.
    """
    say = progress or _quiet
    say("self-collision", 0, n_poses)
    engine: DistanceEngine | None = distances  # type: ignore[assignment]
    merged: CollisionStatistics | None = None
    offset = 0
    for Q in pose_chunks(arm, n_poses, seed):
        # The keyframes do not depend on the chunk: measured once, below.
        part = collision_statistics(arm, distances=engine, poses=Q, keyframes=False)
        merged = part if merged is None else _merge(merged, part, offset)
        offset += len(Q)
        say("self-collision", offset, n_poses)
    if merged is None:  # no poses: the keyframes alone
        empty = np.zeros((0, arm.nq))
        merged = collision_statistics(arm, distances=engine, poses=empty, keyframes=False)
    keys = keyframe_clearance(arm, engine or "coal")
    return dataclasses.replace(merged, seed=seed, keyframes=keys)


def _merge(a: CollisionStatistics, b: CollisionStatistics, offset: int) -> CollisionStatistics:
    pairs = []
    for p, r in zip(a.pairs, b.pairs, strict=True):
        closer = r.closest < p.closest
        pairs.append(
            dataclasses.replace(
                p,
                poses=p.poses + r.poses,
                contacts=p.contacts + r.contacts,
                closest=r.closest if closer else p.closest,
                closest_pose=r.closest_pose + offset if closer else p.closest_pose,
            )
        )
    return dataclasses.replace(
        a,
        n_poses=a.n_poses + b.n_poses,
        poses_with_contact=a.poses_with_contact + b.poses_with_contact,
        pairs=tuple(pairs),
        disagreements=a.disagreements + b.disagreements if a.disagreements >= 0 else -1,
        seconds=a.seconds + b.seconds,
    )


#: A pair in contact at this share of the poses or more touches "everywhere": almost always
#: two links whose collision shapes overlap where a joint joins them, an exclusion the file
#: lacks rather than a collision the arm can avoid [-].
ALWAYS_TOUCHING = 0.99


@dataclass(frozen=True)
class TouchingEverywhere(ContactShare):
    """Pairs in contact at (nearly) every pose, and how often the others touch.

    Attributes:
        pairs: The pairs in contact at `ALWAYS_TOUCHING` of the poses or more, most first.
        poses_with_contact: Poses in which some other pair is in contact.
        n_poses: Poses swept.
        share_with_contact: Fraction of the poses with a contact of another pair, in [0, 1].
    """

    pairs: tuple[PairStatistics, ...]
    poses_with_contact: int
    n_poses: int


def touching_everywhere(
    arm: Arm, stats: CollisionStatistics, seed: int | None
) -> TouchingEverywhere:
    """The pairs of a sweep in contact at (nearly) every pose, and the contact rate without them.

    The rate is counted again over the sweep's poses (the same ``seed``), with MuJoCo's
    collision pipeline alone: a pose counts when a pair other than these is in contact.

    Args:
        arm: The arm the sweep was made on.
        stats: The sweep (`contacts`), its pairs in the checker's order.
        seed: The sweep's seed.
    """
    n = stats.n_poses
    hit = [k for k, p in enumerate(stats.pairs) if n and p.poses >= ALWAYS_TOUCHING * n]
    if not hit:
        return TouchingEverywhere((), stats.poses_with_contact, n)
    ch = checker(arm)
    excluded = np.zeros(len(ch.pairs), dtype=bool)
    excluded[hit] = True
    scene, others = ch.mujoco_scene(), 0
    for Q in pose_chunks(arm, n, seed):
        for q in Q:
            idx, _ = scene.collide(q)
            others += bool(len(idx)) and not excluded[idx].all()
    ranked = sorted((stats.pairs[k] for k in hit), key=lambda p: (-p.poses, p.pair.label))
    return TouchingEverywhere(tuple(ranked), int(others), n)


# -- all four -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Sections:
    """The four sections, computed once for a report (the audit, arm7's example tables).

    ``touching`` is the self-collision sweep's pairs in contact at (nearly) every pose.
    """

    joints: JointSection
    keyframes: tuple[KeyframeRow, ...]
    gravity: GravityBudget | None  # None: the arm's links lack inertias (arm.missing_inertia)
    contacts: CollisionStatistics | None  # None: meshes found nowhere (arm.missing_meshes)
    touching: TouchingEverywhere | None = None
    #: Why the self-collision sweep was skipped where it was not for missing meshes ("").
    collision_skipped: str = ""


def compute(
    arm: Arm,
    n_poses: int,
    seed: int = 0,
    kd: float | None = None,
    distances: str | None = "coal",
    progress: Progress | None = None,
) -> Sections:
    """Every section: gravity and self-collision over the same ``n_poses`` poses of ``seed``.

    An arm whose links lack inertias (``arm.missing_inertia``) gets no gravity budget
    (None), NaN for M_ii, the timestep bounds and the keyframes' holding torques; one whose
    file names meshes found nowhere (``arm.missing_meshes``) no self-collision sweep (None).

    Args:
        arm: The arm.
        n_poses: Random poses of each sweep.
        seed: Seed of the random poses ([`redundancy.random_poses`][redundancy.random_poses]).
        kd: Controller damping written to ctrl (see `joints`) [N m s/rad].
        distances: Distance engine of the collision sweep (``None``: contacts only).
        progress: Called as each sweep advances (see `Progress`).
    """
    say = progress or _quiet
    joint_section, keys = joints(arm, kd), keyframes(arm)
    gravity = None if arm.missing_inertia else gravity_budget(arm, n_poses, seed, say)
    if arm.missing_meshes:  # collision would need them: the audit notes the sweep skipped
        return Sections(joint_section, keys, gravity, None)
    try:
        collisions = contacts(arm, n_poses, seed, distances, say)
    except GeomPlacementError as err:  # a lenient load: the engines' bodies differ
        return Sections(joint_section, keys, gravity, None, None, str(err))
    touching = touching_everywhere(arm, collisions, seed)
    return Sections(joint_section, keys, gravity, collisions, touching)


# -- the mass a contact at the tool feels ---------------------------------------------------------
@dataclass(frozen=True)
class ContactMass:
    """The effective mass at the tool over random poses, beside ISO/TS 15066's simplified figure.

    TS 15066 (transient contact) takes the robot's share of a collision as half the mass of
    its moving parts plus the payload, because tools rarely give the exact one: the effective
    mass 1 / (u^T J_v M^-1 J_v^T u) along the direction of contact u. Samples are every pose
    along the three axes (the mass along -u equals that along u).

    Attributes:
        n_poses: Poses sampled.
        seed: Their seed.
        with_armature: Min, median, max over the samples, motors' rotor inertia included [kg].
        without_armature: The same without it [kg].
        moving_mass: Mass of the links that move [kg].
        payload: Payload assumed [kg] (0).
        below_estimate: Share of samples (with armature) whose exact mass exceeds the estimate:
            where the simplified figure is too low.
    """

    n_poses: int
    seed: int | None
    with_armature: tuple[float, float, float]
    without_armature: tuple[float, float, float]
    moving_mass: float
    payload: float
    below_estimate: float

    @property
    def estimate(self) -> float:
        """TS 15066's simplified effective mass: half the moving mass plus the payload [kg]."""
        return 0.5 * self.moving_mass + self.payload

    @property
    def estimate_over_median(self) -> float:
        """The estimate divided by the exact median with armature."""
        return self.estimate / self.with_armature[1]

    def lines(self) -> list[str]:
        """The section as text lines."""

        def row(label: str, v: tuple[float, float, float]) -> str:
            return f"  {label:<18}{v[0]:>10.3g}{v[1]:>10.3g}{v[2]:>10.3g}"

        return [
            f"effective mass at the tool (ISO/TS 15066 transient contact) over {self.n_poses} "
            f"random poses (seed {self.seed}), along the three axes:",
            f"  {'':<18}{'min kg':>10}{'median kg':>10}{'max kg':>10}",
            row("with armature", self.with_armature),
            row("without armature", self.without_armature),
            f"  TS 15066 simplified: half the moving mass ({self.moving_mass:.3g} kg) + payload "
            f"{self.payload:g} kg = {self.estimate:.3g} kg, {self.estimate_over_median:.2f}x the "
            f"exact median; too low on {100 * self.below_estimate:.1f}% of the samples",
        ]


def contact_mass(arm: Arm, n_poses: int, seed: int | None = 0) -> ContactMass:
    """The effective mass at the tool over ``seed``'s poses, with and without armature.

    Args:
        arm: The arm.
        n_poses: Random poses (the gravity sweep's, for the same seed).
        seed: Their seed.
    """
    engine = arm.reference
    masses: dict[bool, list[Array]] = {True: [], False: []}
    for Q in pose_chunks(arm, n_poses, seed):
        for armature in (True, False):
            J, X = engine.tool_mobilities(Q, armature)
            masses[armature] += [
                kernels.effective_masses(J, X, u, atol=linalg.motion_floor(arm.length))
                for u in np.eye(3)
            ]
    stats = {}
    for armature, parts in masses.items():
        m = np.concatenate(parts)
        stats[armature] = (float(np.min(m)), float(np.median(m)), float(np.max(m)))
    with_rotors = np.concatenate(masses[True])
    moving = float(np.sum(engine.link_inertias(reference_keyframe(arm)[1])[0]))
    estimate = 0.5 * moving
    return ContactMass(
        n_poses=n_poses,
        seed=seed,
        with_armature=stats[True],
        without_armature=stats[False],
        moving_mass=moving,
        payload=0.0,
        below_estimate=float(np.mean(with_rotors > estimate)),
    )

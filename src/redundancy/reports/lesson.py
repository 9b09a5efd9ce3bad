"""Lesson 5.2's six tables, computed by the library for any arm shaped like arm7.

Each table is a function returning a frozen dataclass (the numbers) and a ``format_*``
function printing it as the lesson does. Where both engines can compute a number, the table
also says how far Pinocchio is from MuJoCo.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from .. import inertia
from ..arm import Arm
from ..collision import CollisionStatistics
from ..lab.control import simulate_hold
from . import sections
from .tables import ms

Array = NDArray[np.float64]

KP, KD = 100.0, 5.0  # the lesson's PD gains [N m/rad], [N m s/rad]
N_POSES = 10_000


# -- (1) joints -----------------------------------------------------------------------------------
def joint_table(arm: Arm, key: str = "home", kd: float = KD) -> sections.JointSection:
    """Axis, range, armature, damping, motor limit, M_ii with and without armature, h_max."""
    return sections.joints(arm, kd, key)


def format_joint_table(t: sections.JointSection) -> list[str]:
    """Table (1) lines."""
    out = [
        f"  {'joint':<5}{'axis':>5}{'range (rad)':>15}{'armature':>10}{'damping':>9}{'limit':>7}"
        f"{'M_ii':>9}{'M_ii bare':>11}{'h_max':>10}{'bare':>11}"
    ]
    for r in t.rows:
        rng = np.array2string(np.array([r.lower, r.upper]), precision=1)
        out.append(
            f"  {r.name:<5}{r.axis:>5}{rng:>15}{r.armature:>10.3f}{r.damping:>9.2f}"
            f"{r.effort_limit:>7.0f}{r.m_ii:>9.4f}{r.m_ii_bare:>11.5f}{ms(r.h_max, ' ms'):>10}"
            f"{ms(r.h_max_bare, ' ms'):>11}"
        )
    out.append(
        "  units: limit N m, M_ii kg m^2 at the home pose; h_max = 2 M_ii / (kd - b) for a "
        "controller"
    )
    kd = t.kd if t.kd is not None else max(r.kd for r in t.rows)
    out.append(
        f"  damping kd = {kd} N m s/rad on top of the joint's own damping b, which Euler "
        "treats implicitly"
    )
    out.append(
        "  Pinocchio's M_ii (with and without armature) differ from MuJoCo's by at most "
        f"{t.engine_diff:.1e}"
    )
    return out


# -- (2) Jacobian singular values -----------------------------------------------------------------
def jacobian_table(
    arm: Arm, keys: Sequence[str] = ("zero", "home")
) -> tuple[sections.KeyframeRow, ...]:
    """SVD of J at each keyframe, with Pinocchio's largest singular-value difference."""
    return sections.keyframes(arm, tuple(keys))


def format_jacobian_table(rows: Sequence[sections.KeyframeRow]) -> list[str]:
    """Table (2) lines."""
    out = []
    for r in rows:
        out.append(
            f"  {r.name:<5} singular values {np.round(r.svd.sigma, 4)}  rank {r.svd.rank}  "
            f"manipulability sqrt(det(J J^T)) = {r.svd.manipulability:.2e}"
        )
    for r in rows:
        lost = r.svd.lost_direction_names()
        if lost:
            out.append(f"  {r.name}: lost tool directions: {', '.join(lost)}")
    diff = max(r.engine_diff for r in rows)
    out.append(f"  Pinocchio's singular values differ from MuJoCo's by at most {diff:.1e}")
    return out


# -- (3) gravity budget ---------------------------------------------------------------------------
def gravity_budget(arm: Arm, n: int = N_POSES, seed: int = 0) -> sections.GravityBudget:
    """Peak |gravity torque| per joint over n random poses, from both engines."""
    return sections.gravity_budget(arm, n, seed)


def format_gravity_budget(g: sections.GravityBudget) -> list[str]:
    """Table (3) lines."""
    ratio = " ".join("-" if not np.isfinite(r) else f"{r:.2f}" for r in g.ratio)
    return [
        f"  {g.n_poses} random poses within the ranges: largest gravity torque per joint (N m) "
        f"{np.round(g.peak, 2)}",
        f"  motor limit / largest gravity torque: {ratio}  (- : vertical axis, gravity never "
        "loads it)",
        f"  poses where some joint's gravity torque exceeds its motor limit: {g.n_over}",
        f"  Pinocchio's gravity torques differ from MuJoCo's by at most {g.engine_diff:.1e} N m",
    ]


# -- (4) self-collision ---------------------------------------------------------------------------
#: What the lesson printed in table (4), 10000 poses of default_rng(1) (lesson 5.2, output (4)).
#: Its script added one per *contact* in data.contact, not one per pose, though it printed
#: "poses"; these are therefore contact counts, shown beside ours.
LESSON_CONTACTS = {
    "link2 / link4": 1550,
    "flange / link2": 282,
    "flange / link1": 250,
    "link2 / link5": 185,
}
LESSON_SHARE = 15.5  # percent of poses with at least one contact


def contact_table(arm: Arm, n_poses: int = N_POSES, seed: int = 1) -> CollisionStatistics:
    """Self-collision over random poses: MuJoCo's contacts through the library's pair set.

    Distances per pair are left out here for speed; ``redundancy audit`` adds them (closest
    approach per pair, and coal against MuJoCo).
    """
    return sections.contacts(arm, n_poses, seed, distances=None)


def format_contact_table(stats: CollisionStatistics, top: int = 4) -> list[str]:
    """Table (4) lines: per pair both poses and contacts, and the lesson's printed count."""
    out = [
        f"  {stats.n_poses} random poses: {100 * stats.share_with_contact:.1f}% have at least one "
        f"self-contact (lesson: {LESSON_SHARE}%)",
        f"    {'pair':<24}{'poses':>7}{'contacts':>10}{'lesson':>8}",
    ]
    ranked = sorted(stats.pairs, key=lambda p: (-p.contacts, -p.poses, p.pair.label))
    for p in ranked[:top]:
        lesson = LESSON_CONTACTS.get(p.pair.label)
        shown = "-" if lesson is None else str(lesson)
        out.append(f"    {p.pair.label:<24}{p.poses:>7}{p.contacts:>10}{shown:>8}")
    out.append('    lesson: its "poses" column counted contacts; compare it with "contacts"')
    for k in stats.keyframes:
        if k.keyframe in ("zero", "home"):
            clear = (
                f" (closest pair {k.closest.pair.label} at {k.closest.distance:.4f} m)"
                if k.closest
                else ""
            )
            out.append(f"  contacts at the {k.keyframe} pose: {k.contacts}{clear}")
    return out


# -- (5) holding the home pose --------------------------------------------------------------------
@dataclass(frozen=True)
class HoldCase:
    """One row of table (5)."""

    label: str
    armature: float
    integrator: str
    pd: bool
    eulerdamp: bool
    peak: float
    joint: str
    warnings: int
    messages: tuple[str, ...]


HOLD_CASES = (
    ("gravity compensation only", 0.0, "Euler", False, True),
    ("  same, eulerdamp disabled", 0.0, "Euler", False, False),
    ("joint PD", 0.05, "Euler", True, True),
    ("joint PD", 0.0, "Euler", True, True),
    ("joint PD", 0.0, "implicitfast", True, True),
)
_INTEGRATORS = {
    "Euler": mujoco.mjtIntegrator.mjINT_EULER,
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
}


def _variant(
    arm: Arm, armature: float, integrator: str = "Euler", eulerdamp: bool = True
) -> mujoco.MjModel:
    m = copy.copy(arm.mj_model)
    m.dof_armature[:] = armature
    m.opt.integrator = _INTEGRATORS[integrator]
    if not eulerdamp:
        m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_EULERDAMP
    return m


def hold_table(arm: Arm, key: str = "home", seconds: float = 2.0) -> tuple[HoldCase, ...]:
    """Hold a keyframe after a 0.01 rad/s nudge under the lesson's five settings."""
    target = arm.keyframe(key)
    rows = []
    for label, arm_value, integ, pd, eulerdamp in HOLD_CASES:
        m = _variant(arm, arm_value, integ, eulerdamp)
        r = simulate_hold(m, target, KP if pd else 0.0, KD if pd else 0.0, seconds)
        j = int(np.argmax(r.peak_speed))
        rows.append(
            HoldCase(
                label,
                arm_value,
                integ,
                pd,
                eulerdamp,
                float(r.peak_speed[j]),
                arm.joint_names[j],
                r.bad_qacc_warnings,
                r.messages,
            )
        )
    return tuple(rows)


def format_hold_table(rows: Sequence[HoldCase]) -> list[str]:
    """Table (5) lines, then MuJoCo's warnings (captured during the runs)."""
    out = [
        f"  {r.label:<28} armature {r.armature:<5} {r.integrator:<13} max |qvel| {r.peak:9.3g} "
        "rad/s "
        f"at {r.joint}, bad-acceleration warnings {r.warnings}"
        for r in rows
    ]
    for r in rows:
        for msg in r.messages:
            out.append(f"  MuJoCo warned during '{r.label.strip()}': {msg}")
    return out


# -- (6) the bare wrist's stability threshold -----------------------------------------------------
@dataclass(frozen=True)
class WristThreshold:
    """Table (6): predicted and simulated kd threshold of the last joint without armature.

    Attributes:
        inertia: Bare inertia of the joint at the keyframe [kg m^2].
        damping: Joint damping b [N m s/rad].
        timestep: h [s].
        bound: Predicted largest stable kd, b + 2 I / h [N m s/rad].
        stable_up_to: kp -> largest kd on the grid that held still [N m s/rad].
    """

    inertia: float
    damping: float
    timestep: float
    bound: float
    stable_up_to: dict[float, float]
    step: float


def wrist_threshold(
    arm: Arm,
    key: str = "home",
    gains: Sequence[float] = (0.0, KP),
    kd_grid: Array | None = None,
    seconds: float = 4.0,
    sweep: bool = False,
) -> WristThreshold:
    """Largest stable kd on a grid for the last joint with no armature anywhere, by simulation.

    A run counts as stable when the last joint's speed stays below 1e-3 rad/s over the last
    quarter of a ``seconds`` hold. Instability is monotone in kd (the per-step factor
    (I - h kd) / (I + h b) grows in magnitude with kd once kd > I / h), so a bisection over
    the grid finds the same threshold as the full sweep with log2(len(grid)) runs instead of
    len(grid); ``sweep=True`` runs every grid point (the slow test checks both agree).
    """
    grid = np.arange(0.50, 0.81, 0.02) if kd_grid is None else np.asarray(kd_grid, float)
    q = arm.keyframe(key)
    last = arm.nq - 1
    i_bare = float(arm.mass_matrix(q, armature=False)[last, last])
    b = float(arm.damping()[last])
    m = _variant(arm, 0.0)
    h = float(m.opt.timestep)

    def stable(kp: float, kd: float) -> bool:
        return bool(simulate_hold(m, q, kp, kd, seconds, record_from=0.75).peak_speed[last] < 1e-3)

    result = {}
    for kp in gains:
        if sweep:
            ok = [kd for kd in grid if stable(kp, kd)]
            result[float(kp)] = float(max(ok)) if ok else float("nan")
            continue
        if not stable(kp, grid[0]):
            result[float(kp)] = float("nan")
            continue
        lo, hi = 0, len(grid)  # grid[lo] is stable; grid[hi] (if inside the grid) is not
        while hi - lo > 1:
            mid = (lo + hi) // 2
            lo, hi = (mid, hi) if stable(kp, grid[mid]) else (lo, mid)
        result[float(kp)] = float(grid[lo])
    step = float(grid[1] - grid[0])
    return WristThreshold(i_bare, b, h, float(inertia.max_stable_kd(i_bare, h, b)), result, step)


def format_wrist_threshold(w: WristThreshold, joint: str = "j7") -> list[str]:
    """Table (6) lines."""
    out = [
        f"  bare {joint}: I = {w.inertia:.6f} kg m^2, b = {w.damping} N m s/rad, h = "
        f"{w.timestep} s "
        f"-> bound predicts kd < b + 2 I / h = {w.bound:.3f}"
    ]
    for kp, kd in w.stable_up_to.items():
        out.append(
            f"  kp {kp:>5g}: stable for kd up to {kd:.2f}, unstable from {kd + w.step:.2f} N m "
            "s/rad"
        )
    return out


# -- all six --------------------------------------------------------------------------------------
def print_tables(
    arm: Arm,
    n_poses: int = N_POSES,
    out: Callable[[str], object] = print,
    computed: sections.Sections | None = None,
) -> None:
    """Print the lesson's six tables for ``arm`` (which must be shaped like arm7).

    Args:
        arm: The arm.
        n_poses: Random poses of tables (3) and (4).
        out: Where each line goes.
        computed: Sections already computed for this arm (joints at kd 5, gravity over
            seed 0's poses, contacts over seed 1's), so tables (1) to (4) only format them;
            by default they are computed here.
    """
    if computed is None:
        computed = sections.Sections(
            joint_table(arm),
            jacobian_table(arm),
            gravity_budget(arm, n_poses, seed=0),
            contact_table(arm, n_poses, seed=1),
        )
    keys = [k for k in computed.keyframes if k.name in ("zero", "home")]
    out("(1) joints, inertia and the explicit-damping timestep bound:")
    for line in format_joint_table(computed.joints):
        out(line)
    out("(2) singular values of the 6x7 Jacobian of the ee site:")
    for line in format_jacobian_table(keys):
        out(line)
    out("(3) gravity torque against motor limits:")
    for line in format_gravity_budget(computed.gravity):
        out(line)
    out("(4) self-collision:")
    for line in format_contact_table(computed.contacts):
        out(line)
    out(
        f"(5) hold the home pose for 2 s at h = 2 ms after a 0.01 rad/s nudge (PD: kp {KP:g}, "
        f"kd {KD:g}):"
    )
    for line in format_hold_table(hold_table(arm)):
        out(line)
    out("(6) the bare wrist's stability threshold in kd (no armature, Euler, h = 2 ms):")
    for line in format_wrist_threshold(wrist_threshold(arm), arm.joint_names[-1]):
        out(line)

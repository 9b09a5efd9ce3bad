"""Lesson 5.2 challenge: self-motion of arm7, its drift, and a way out of a self-contact.

Part 1: from the home pose, move 1 rad of joint motion along the null space of the ee-site
Jacobian, with and without the correction that pulls the tool back to its start pose, and
plot the tool's position and orientation drift and the elbow's height. A table of the
uncorrected drift against the step size shows its order: first order for Euler steps
(O(h^2) per step, 1/h steps), second order for midpoint steps.

Part 2: roll the upper arm (j3) from home and fold the elbow (j4) until MuJoCo lists a
link2 / link4 contact of a given depth, then follow the self-motion that raises the
smallest self-collision clearance until a clearance margin is reached, with the tool
pulled back to its start pose every step.

Run: python scripts/challenge_self_motion.py [--out DIR] [--roll RAD] [--depth M]
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

try:
    import redundancy as rd
except ImportError:  # a fresh clone that was not installed: use its source tree
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))
    import redundancy as rd
from redundancy.analysis.selfmotion import (
    SelfMotionPath,
    collision_objective,
    no_contact,
    self_motion,
)
from redundancy.collision import checker

Array = NDArray[np.float64]


def drift_table(
    arm: rd.Arm, q0: Array, total: float, steps: tuple[float, ...], integrator: str
) -> list[tuple[float, float, float]]:
    """Uncorrected tool drift after ``total`` joint motion, per step size.

    Returns:
        (step [rad], final position drift [m], final orientation drift [rad]) per step.
    """
    out = []
    for h in steps:
        p = self_motion(arm, q0, total, h, correct=False, integrator=integrator)  # type: ignore[arg-type]
        out.append((h, float(p.position_drift[-1]), float(p.orientation_drift[-1])))
    return out


def contact_pose(
    arm: rd.Arm, roll: float, depth: float, pair: tuple[str, str] = ("link2", "link4")
) -> Array:
    """Home with j3 = ``roll`` and j4 raised until ``pair`` overlaps by ``depth``.

    Bisection on j4 between home and its upper limit for the pair's signed distance
    (MuJoCo's ``mj_geomDistance``) equal to ``-depth``, to 1e-12 rad.

    Args:
        arm: arm7.
        roll: Upper-arm roll j3 [rad].
        depth: Penetration wanted [m].
        pair: Geom names.

    Raises:
        rd.RedundancyError: The pair does not overlap that deeply even at j4's upper limit.
    """
    ch = checker(arm)
    k = ch.pairs.index(ch.pair(*pair))
    q = arm.keyframe("home")
    q[arm.joint_index("j3")] = roll
    k4 = arm.joint_index("j4")

    def excess(j4: float) -> float:
        qq = q.copy()
        qq[k4] = j4
        return float(ch.distance_values(qq, "mujoco")[k]) + depth

    lo, hi = float(q[k4]), float(arm.upper[k4])
    if excess(lo) <= 0 or excess(hi) > 0:
        raise rd.RedundancyError(
            f"no j4 in [{lo:g}, {hi:g}] gives a {depth * 1e3:g} mm {pair[0]}/{pair[1]} overlap "
            f"at j3 = {roll:g} rad"
        )
    while hi - lo > 1e-12:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if excess(mid) > 0 else (lo, mid)
    q[k4] = hi
    return q


@dataclass(frozen=True)
class Escape:
    """A self-motion out of a self-contact.

    Attributes:
        start: The contact pose [rad].
        path: The self-motion.
        start_depth: Penetration of the watched pair at the start [m].
        start_contacts: Pairs MuJoCo lists at the start.
        start_clearance: Smallest clearance at the start [m] (negative: overlap).
        free_at: Joint motion after which MuJoCo first lists no contact [rad] (nan: never).
        final_clearance: Smallest clearance at the end [m].
        final_contacts: Pairs MuJoCo lists at the end.
    """

    start: Array
    path: SelfMotionPath
    start_depth: float
    start_contacts: tuple[str, ...]
    start_clearance: float
    free_at: float
    final_clearance: float
    final_contacts: tuple[str, ...]

    @property
    def tool_drift(self) -> float:
        """Largest tool position drift along the escape [m]."""
        return self.path.max_position_drift


def escape(
    arm: rd.Arm,
    q: Array,
    margin: float = 1e-3,
    step: float = 0.01,
    limit: float = 4.0,
    pair: tuple[str, str] = ("link2", "link4"),
    correct: bool = True,
) -> Escape:
    """Follow the self-motion that raises the smallest clearance until it reaches ``margin``.

    Args:
        arm: The arm.
        q: Start pose, in contact [rad].
        margin: Clearance to reach [m].
        step: Null-space step [rad].
        limit: Joint motion allowed at most [rad].
        pair: The pair whose penetration is reported.
        correct: Pull the tool back to its start pose each step.
    """
    ch = checker(arm)
    k = ch.pairs.index(ch.pair(*pair))
    objective = collision_objective(arm, "mujoco")
    path = self_motion(
        arm,
        q,
        limit,
        step,
        correct=correct,
        objective=objective,
        stop=lambda qq: objective(qq) >= margin,
    )
    free = no_contact(arm)
    free_idx = next((i for i, qq in enumerate(path.q) if free(qq)), None)
    return Escape(
        start=q,
        path=path,
        start_depth=-float(ch.distance_values(q, "mujoco")[k]),
        start_contacts=tuple(sorted(p.label for p in ch.contact_pairs(q))),
        start_clearance=float(path.objective[0]),
        free_at=float(path.joint_motion[free_idx]) if free_idx is not None else float("nan"),
        final_clearance=float(path.objective[-1]),
        final_contacts=tuple(sorted(p.label for p in ch.contact_pairs(path.q[-1]))),
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out"), help="output directory")
    parser.add_argument("--total", type=float, default=1.0, help="self-motion from home [rad]")
    parser.add_argument("--step", type=float, default=0.01, help="null-space step [rad]")
    parser.add_argument("--roll", type=float, default=1.0, help="j3 of the contact pose [rad]")
    parser.add_argument("--depth", type=float, default=3e-3, help="link2/link4 overlap [m]")
    parser.add_argument("--margin", type=float, default=1e-3, help="clearance to reach [m]")
    args = parser.parse_args(argv)
    from redundancy.plotting import pyplot

    plt = pyplot()

    arm = rd.load(rd.model_path("arm7"), frame="ee")
    home = arm.keyframe("home")
    runs = {
        "corrected (Euler + J^+ e)": self_motion(arm, home, args.total, args.step),
        "uncorrected, Euler": self_motion(arm, home, args.total, args.step, correct=False),
        "uncorrected, midpoint": self_motion(
            arm, home, args.total, args.step, correct=False, integrator="midpoint"
        ),
    }
    k3, k4 = arm.joint_index("j3"), arm.joint_index("j4")
    print(f"part 1: {args.total:g} rad of self-motion from home in steps of {args.step:g} rad")
    for label, p in runs.items():
        print(
            f"  {label:<26} max tool drift {p.max_position_drift * 1e3:.3e} mm, "
            f"{p.max_orientation_drift * 1e3:.3e} mrad; elbow height {p.elbow_height[0]:.4f} -> "
            f"{p.elbow_height[-1]:.4f} m; j3 {p.q[-1][k3] - p.q[0][k3]:+.3f} rad, "
            f"j4 {p.q[-1][k4] - p.q[0][k4]:+.1e} rad"
        )
    print("  uncorrected drift after the full motion against the step (ratio: halving the step):")
    for integrator in ("euler", "midpoint"):
        table = drift_table(arm, home, args.total, (0.04, 0.02, 0.01, 0.005), integrator)
        cells = []
        for i, (h, dp, _) in enumerate(table):
            ratio = f" (/{table[i - 1][1] / dp:.2f})" if i else ""
            cells.append(f"h {h:g}: {dp * 1e3:.3e} mm{ratio}")
        print(f"    {integrator:<8} " + ", ".join(cells))

    q_c = contact_pose(arm, args.roll, args.depth)
    e = escape(arm, q_c, args.margin, args.step)
    e_raw = escape(arm, q_c, args.margin, args.step, correct=False)
    p = e.path
    print(f"part 2: home with j3 = {args.roll:g} rad, j4 raised to {q_c[k4]:.4f} rad:")
    print(f"  MuJoCo's contacts: {', '.join(e.start_contacts) or 'none'}")
    print(
        f"  starting penetration link2/link4 {e.start_depth * 1e3:.3f} mm "
        f"(smallest clearance {e.start_clearance * 1e3:+.3f} mm)"
    )
    print(
        f"  self-motion raising the smallest clearance: no contact after {e.free_at:.3f} rad "
        f"of joint motion; clearance {e.final_clearance * 1e3:+.3f} mm after {p.total:.3f} rad "
        f"({p.stopped or 'full motion'})"
    )
    print(f"  contacts at the end: {', '.join(e.final_contacts) or 'none'}")
    print(
        f"  tool drift: {e.tool_drift * 1e3:.2e} mm, {p.max_orientation_drift * 1e3:.2e} mrad "
        f"(without the correction: {e_raw.tool_drift * 1e3:.3f} mm); bound 1 mm"
    )
    print(
        f"  joints: j3 {p.q[0][k3]:.3f} -> {p.q[-1][k3]:.3f} rad, j4 changed by "
        f"{p.q[-1][k4] - p.q[0][k4]:+.1e} rad (the elbow angle is fixed by the shoulder-to-wrist "
        "distance;\n  only the roll between link2 and link4 changes: the forearm turns off the "
        "wide side of link2 toward its narrow one)"
    )

    args.out.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(3, 1, figsize=(8, 8.5), sharex=True)
    for label, path in runs.items():
        s = path.joint_motion
        axes[0].semilogy(s[1:], np.maximum(path.position_drift[1:], 1e-18) * 1e3, label=label)
        axes[1].semilogy(s[1:], np.maximum(path.orientation_drift[1:], 1e-18) * 1e3, label=label)
        axes[2].plot(s, path.elbow_height, label=label)
    axes[0].set_ylabel("tool position drift [mm]")
    axes[1].set_ylabel("tool orientation drift [mrad]")
    axes[2].set_ylabel("elbow (j4) height [m]")
    axes[2].set_xlabel("joint motion along the null space [rad]")
    axes[0].set_title(f"arm7 self-motion from home, step {args.step:g} rad")
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    drift_png = args.out / "self_motion_drift.png"
    fig.savefig(drift_png, dpi=120)
    plt.close(fig)

    fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    axes[0].plot(p.joint_motion, p.objective * 1e3, label="smallest clearance")
    axes[0].axhline(0.0, color="0.5", lw=1)
    if np.isfinite(e.free_at):
        axes[0].axvline(e.free_at, color="0.5", ls=":", lw=1, label="MuJoCo lists no contact")
    axes[0].set_ylabel("clearance [mm]")
    axes[0].legend(fontsize=8)
    axes[1].semilogy(
        p.joint_motion[1:], np.maximum(p.position_drift[1:], 1e-18) * 1e3, label="corrected"
    )
    axes[1].semilogy(
        e_raw.path.joint_motion[1:], e_raw.path.position_drift[1:] * 1e3, label="uncorrected"
    )
    axes[1].axhline(1.0, color="r", ls="--", lw=1, label="1 mm")
    axes[1].set_ylabel("tool position drift [mm]")
    axes[1].set_xlabel("joint motion along the null space [rad]")
    axes[1].legend(fontsize=8)
    axes[0].set_title(f"escaping a {e.start_depth * 1e3:.1f} mm link2/link4 overlap")
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.tight_layout()
    escape_png = args.out / "self_motion_escape.png"
    fig.savefig(escape_png, dpi=120)
    plt.close(fig)
    print(f"plots written to {drift_png} and {escape_png}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

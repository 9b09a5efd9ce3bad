"""The poses two arms are compared at, and what MuJoCo gives at them, stacked.

`redundancy.analysis.compare` compares two descriptions of one robot pose by pose over
`shared_poses`: random poses in the ranges both share, and every keyframe of either. At them,
`mujoco_stacks` gives each arm's tool poses, Jacobians, mass matrices and gravity in one stacked
pass, and `passive_forces` what else the simulation adds at random joint velocities, less the
joint damping (`damping_polynomial` gives its terms beyond the linear one), compared on its own;
`passive_listing` is what of it a URDF cannot express.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from ..arm import Arm, sampling_ranges
from ..engines.contract import Stacks
from ..model.actuators import actuator_damping_polynomial
from ..model.names import display_names

Array = NDArray[np.float64]


def shared_poses(a: Arm, b: Arm, ia: list[int], ib: list[int], n: int, seed: int) -> Array:
    """``n`` random poses of A where both ranges allow, then A's and B's keyframes (A's order).

    Args:
        a: Arm A.
        b: Arm B.
        ia: Joints both have, as indices into A's order.
        ib: The same joints, as indices into B's order.
        n: Random poses.
        seed: Their seed.

    Returns:
        A's poses, shape (k, A's nq) [rad or m]; a joint only B's keyframe sets is copied, A's
        others sit at zero clipped into their ranges.
    """
    lo_a, hi_a = sampling_ranges(a)
    lo_b, hi_b = sampling_ranges(b)
    lo, hi = lo_a.copy(), hi_a.copy()
    # Draw where both ranges allow (a range only one file has is a structural difference).
    lo[ia] = np.maximum(lo_a[ia], lo_b[ib])
    hi[ia] = np.minimum(hi_a[ia], hi_b[ib])
    empty = lo > hi
    lo[empty], hi[empty] = lo_a[empty], hi_a[empty]
    qs = [np.random.default_rng(seed).uniform(lo, hi, size=(n, a.nq))]
    qs += [q[None, :] for q in a.keyframes.values()]
    for q in b.keyframes.values():
        qa = np.clip(np.zeros(a.nq), a.lower, a.upper)
        qa[ia] = q[ib]
        qs.append(qa[None, :])
    return np.concatenate(qs) if qs else np.zeros((0, a.nq))


def mujoco_stacks(
    arm: Arm, Q: Array, armature: bool, gravity: bool
) -> tuple[Array, Array, Array, Array, Array | None]:
    """MuJoCo's tool poses, Jacobians, mass matrices and (if asked) gravity over ``Q``."""
    n, nv = len(Q), arm.nq
    X, R, J, M = np.empty((n, 3)), np.empty((n, 3, 3)), np.empty((n, 6, nv)), np.empty((n, nv, nv))
    G = np.empty((n, nv)) if gravity else None
    arm.mujoco.evaluate(Q, Stacks(X=X, R=R, J=J, M=M, G=G, armature=armature))
    return X, R, J, M, G


def damping_polynomial(arm: Arm) -> Array:
    """MuJoCo's joint damping beyond its linear term: per dof, the coefficients of v|v| and v^3.

    MuJoCo reads ``damping="b0 b1 b2"`` on a joint or an actuator as the force
    -(b0 v + b1 v|v| + b2 v^3); b0 is in `Arm.damping`, b1 and b2 here: the joint's own
    (``dof_dampingpoly``) plus gear^2 times its actuators' (``actuator_dampingpoly``), which
    MuJoCo applies to the joint velocity as it does their linear damping (measured on
    MuJoCo 4.0: gear 3, ``damping="1 2 3"``, v = 0.5 rad/s gives 9 x 1.375 N m).

    Returns:
        Shape (nv, 2) [N m s^2/rad^2 and N m s^3/rad^3; N s^2/m^2 and N s^3/m^3 on a slide].
    """
    m = arm.mj_model
    return m.dof_dampingpoly + actuator_damping_polynomial(m)


#: What the compared polynomials' numbers are (their linear terms are rows of their own).
POLY_NOTE = "coefficients of v|v| and v^3 in MuJoCo's damping force, the actuators' included"
STIFFNESS_NOTE = "MuJoCo's jnt_stiffnesspoly: the spring's coefficients beyond its stiffness"


def _terms(coefficients: Array) -> str:
    """A polynomial's higher coefficients as ``[b1 b2]``."""
    return "[" + " ".join(f"{float(c):g}" for c in coefficients) + "]"


def passive_listing(arm: Arm) -> dict[str, tuple[str, dict[str, Any]]]:
    """What URDF cannot express of an MJCF arm's passive forces: quantity -> (where, values).

    Joint springs (with their polynomials), damping polynomials (`damping_polynomial`) and
    gravity compensation, each empty where the arm has none.
    """
    m, names = arm.mj_model, arm.joint_names
    springs = {}
    for i, (n, k, more) in enumerate(zip(names, m.jnt_stiffness, m.jnt_stiffnesspoly, strict=True)):
        if k != 0 or any(more):
            springs[n] = f"stiffness={k:g}, springref={m.qpos_spring[m.jnt_qposadr[i]]:g}"
            springs[n] += f", stiffness polynomial={_terms(more)}" if any(more) else ""
    poly = damping_polynomial(arm)
    dampers = {n: _terms(c) for n, c in zip(names, poly, strict=True) if any(c)}
    bodies = display_names(m, mujoco.mjtObj.mjOBJ_BODY)
    gravcomp = {bodies[k]: float(g) for k, g in enumerate(m.body_gravcomp) if g != 0}
    return {
        "joint spring": ("joints", springs),
        "damping polynomial": ("joints", dampers),
        "gravity compensation": ("bodies", gravcomp),
    }


def passive_forces(
    a: Arm,
    b: Arm,
    qa: Array,
    qb: Array,
    ia: list[int],
    ib: list[int],
    length: float,
    seed: int,
) -> tuple[tuple[Array, Array], ...]:
    """Each arm's passive force less joint damping and gravity compensation, and the latter.

    At the poses ``qa`` (A's) and ``qb`` (the same, B's) with random velocities in +-1 rad/s
    (+-1 arm length per second on a slide), the same for the joints both have. The joint
    damping, its own and its actuators' (`Arm.damping` and `damping_polynomial`, compared on
    their own), and the gravity compensation (the second array) are taken out of the passive
    force, so that no difference is reported twice: what is left is springs, tendons and
    fluid forces.

    Args:
        a: Arm A.
        b: Arm B.
        qa: A's poses, shape (k, A's nq) [rad or m].
        qb: B's poses for them, shape (k, B's nq) [rad or m].
        ia: Joints both have, as indices into A's order.
        ib: The same joints, as indices into B's order.
        length: A's length, the unit of a slide's speed [m].
        seed: Seed of the velocities.

    Returns:
        Per arm, the passive force less damping and compensation, and the compensation
        [N m or N], each shape (k, nq).
    """
    unit = np.where(np.array(a.joint_types) == "hinge", 1.0, length)
    Va = np.random.default_rng([seed, 1]).uniform(-1.0, 1.0, qa.shape) * unit
    Vb = np.zeros((len(qa), b.nq))
    Vb[:, ib] = Va[:, ia]
    out = []
    for arm, Q, V in ((a, qa, Va), (b, qb, Vb)):
        m = arm.mj_model
        P, C = arm.mujoco.passive_forces(Q, V)
        # The compensation is in qfrc_passive except on joints that send it to actuators.
        passive_gc = C * (m.jnt_actgravcomp[m.dof_jntid] == 0)
        poly = damping_polynomial(arm)
        # MuJoCo's damping force is -(b0 v + b1 v|v| + b2 v^3): added back, it is gone.
        damper = arm.damping() * V + poly[:, 0] * V * np.abs(V) + poly[:, 1] * V**3
        out.append((P + damper - passive_gc, C))
    return tuple(out)


__all__ = [
    "POLY_NOTE",
    "STIFFNESS_NOTE",
    "damping_polynomial",
    "mujoco_stacks",
    "passive_forces",
    "passive_listing",
    "shared_poses",
]

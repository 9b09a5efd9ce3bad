"""The poses two arms are compared at, and what MuJoCo gives at them, stacked.

`redundancy.analysis.compare` compares two descriptions of one robot pose by pose over
`shared_poses`: random poses in the ranges both share, and every keyframe of either. At them,
`mujoco_stacks` gives each arm's tool poses, Jacobians, mass matrices and gravity in one stacked
pass, and `passive_forces` what else the simulation adds at random joint velocities.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..arm import Arm, sampling_ranges
from ..engines.contract import Stacks

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
    """Each arm's passive force less damping and gravity compensation, and the latter.

    At the poses ``qa`` (A's) and ``qb`` (the same, B's) with random velocities in +-1 rad/s
    (+-1 arm length per second on a slide), the same for the joints both have. The damping
    (compared on its own) and the gravity compensation (the second array) are taken out of the
    passive force, so that no difference is reported twice.

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
        out.append((P + m.dof_damping * V - passive_gc, C))
    return tuple(out)


__all__ = ["mujoco_stacks", "passive_forces", "shared_poses"]

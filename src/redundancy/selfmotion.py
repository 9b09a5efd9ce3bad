"""Self-motion: moving the joints along the Jacobian's null space so the tool stays put.

Each step recomputes J at the current pose, moves along the unit null-space direction
(continuing the previous step's sign) and, optionally, adds the least-squares correction
J^+ e that pulls the tool back to its start pose; without it the tool drifts at second order
in the step size. Objective-driven moves choose the null-space direction that raises a
scalar objective (manipulability, distance to the joint limits, self-collision distance).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import linalg
from .arm import Arm, EngineName
from .errors import RedundancyError

Array = NDArray[np.float64]


def rotation_log(R: Array) -> Array:
    """Rotation vector (axis times angle) [rad] of a rotation matrix."""
    cos = np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)
    angle = np.arccos(cos)
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if angle < 1e-7:
        return 0.5 * w
    if np.pi - angle < 1e-6:  # near pi: axis from the symmetric part
        axis = np.sqrt(np.maximum((np.diag(R) + 1.0) / 2.0, 0.0))
        axis *= np.sign(w + (w == 0))
        return angle * axis / np.linalg.norm(axis)
    return angle / (2.0 * np.sin(angle)) * w


def pose_error(arm: Arm, q: Array, p0: Array, R0: Array, engine: EngineName) -> Array:
    """Tool error [p0 - p; log(R0 R^T)] [m, rad] at q, world axes."""
    p, R = arm.site_pose(q, engine)
    return np.concatenate([p0 - p, rotation_log(R0 @ R.T)])


@dataclass(frozen=True)
class SelfMotionPath:
    """A sampled self-motion.

    Attributes:
        q: Poses, shape (n + 1, nq) [rad].
        joint_motion: Cumulative joint motion (sum of step norms), shape (n + 1,) [rad].
        position_drift: |p - p0| of the tool, shape (n + 1,) [m].
        orientation_drift: Angle of R R0^T, shape (n + 1,) [rad].
        elbow_height: z of the elbow joint's anchor, shape (n + 1,) [m].
        objective: Objective value per pose when one was used, else empty.
        stopped: Why the motion ended before its total: '' if it did not.
    """

    q: Array
    joint_motion: Array
    position_drift: Array
    orientation_drift: Array
    elbow_height: Array
    objective: Array
    stopped: str


Objective = Callable[[Array], float]


def manipulability_objective(arm: Arm, engine: EngineName = "mujoco") -> Objective:
    """Objective: Yoshikawa's manipulability of the site Jacobian."""
    return lambda q: linalg.yoshikawa(arm.jacobian(q, engine))


def joint_limit_objective(arm: Arm) -> Objective:
    """Objective: the smallest distance of any joint to its nearer limit [rad or m]."""
    return lambda q: float(np.min(np.minimum(q - arm.lower, arm.upper - q)))


def self_motion(
    arm: Arm,
    q0: ArrayLike,
    total: float = 1.0,
    step: float = 0.01,
    direction: int = 1,
    correct: bool = True,
    objective: Objective | None = None,
    elbow: str | None = None,
    engine: EngineName = "mujoco",
    stop: Callable[[Array], bool] | None = None,
) -> SelfMotionPath:
    """Move along the null space of the site Jacobian for ``total`` joint motion.

    Args:
        arm: The arm (its Jacobian must have a one-dimensional null space along the way;
            with a larger one the direction of largest objective gain, or the first basis
            vector, is taken).
        q0: Start pose [rad].
        total: Joint motion to cover, sum of step norms [rad].
        step: Joint motion per step [rad].
        direction: +1 or -1: which way along the null space to start (ignored with an
            objective, which picks the rising direction).
        correct: Add J^+ e each step, removing the second-order tool drift.
        objective: Scalar function of q to raise; the direction each step is the null-space
            direction along which it rises (central difference of ``step`` along it).
        elbow: Joint whose anchor height is reported; default the middle joint.
        engine: Engine for J and the site pose.
        stop: Predicate on q that ends the motion early when true (e.g. "out of contact").

    Raises:
        RedundancyError: ``step`` or ``total`` not positive, or a pose with no null space.
    """
    if not (step > 0 and total > 0):
        raise RedundancyError(f"step and total must be > 0 rad, got step={step!r}, total={total!r}")
    if direction not in (1, -1):
        raise RedundancyError(f"direction must be +1 or -1, got {direction!r}")
    q = arm.pose(q0)
    elbow_idx = arm.nq // 2 if elbow is None else arm.joint_index(elbow)
    p0, R0 = arm.site_pose(q, engine)
    prev: Array | None = None
    qs, motion = [q.copy()], [0.0]
    n = int(np.ceil(total / step - 1e-9))
    stopped = ""
    for _ in range(n):
        if stop is not None and stop(q):
            stopped = "stop condition met"
            break
        J = arm.jacobian(q, engine)
        basis = linalg.nullspace_basis(J)
        if basis.shape[1] == 0:
            stopped = "no null space"
            break
        v = basis[:, 0]
        if objective is not None:
            gain = objective(q + step * v) - objective(q - step * v)
            v = v if gain >= 0 else -v
        elif prev is None:
            v = direction * v
        elif v @ prev < 0:
            v = -v  # keep moving the same way: the basis vector's sign is arbitrary
        h = min(step, total - motion[-1])
        dq = h * v
        if correct:
            q_pred = q + dq
            dq += np.linalg.pinv(arm.jacobian(q_pred, engine)) @ pose_error(arm, q_pred, p0, R0, engine)
        q = q + dq
        prev = v
        qs.append(q.copy())
        motion.append(motion[-1] + h)
    Q = np.stack(qs)
    pos, ori, elb = [], [], []
    for qi in Q:
        p, R = arm.site_pose(qi, engine)
        pos.append(np.linalg.norm(p - p0))
        ori.append(np.linalg.norm(rotation_log(R @ R0.T)))
        elb.append(arm.engine(engine).joint_axes(qi)[1][elbow_idx, 2])
    obj = np.array([objective(qi) for qi in Q]) if objective is not None else np.zeros(0)
    return SelfMotionPath(Q, np.array(motion), np.array(pos), np.array(ori), np.array(elb), obj, stopped)

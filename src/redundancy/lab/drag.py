"""The lab's drag: the targets taken to a dragged tool pose by the library's inverse kinematics."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..arm import Arm
from ..objectives import Objective

Array = NDArray[np.float64]


def solve_ik(
    arm: Arm,
    q0: ArrayLike,
    position: ArrayLike,
    rotation: ArrayLike | None = None,
    rest: ArrayLike | None = None,
) -> tuple[Array, float]:
    """The lab's drag: `Arm.solve_ik` from the current targets.

    No random restarts (a drag must not make the arm jump to another branch), and the
    posture pulled toward ``rest`` in the task's null space (the objective
    -|q - rest|^2 / 2, raised), so the elbow stays where the user left it while the tool follows.

    Args:
        arm: The arm.
        q0: Start pose, the current targets [rad or m].
        position: Tool target position [m].
        rotation: Tool target orientation (3 x 3), or None to keep the orientation at ``q0``.
        rest: Rest posture for the null-space term (default ``q0``).

    Returns:
        The pose (inside the joint ranges) and the tool's remaining position error [m].
    """
    q = arm.pose(q0)
    R_t = arm.site_pose(q)[1] if rotation is None else rotation
    q_rest = q.copy() if rest is None else arm.pose(rest)

    def closeness(x: Array) -> float:
        d = x - q_rest
        return -0.5 * float(d @ d)

    toward_rest = Objective("closeness to rest [rad^2]", closeness, lambda x: q_rest - x)
    result = arm.solve_ik((position, R_t), q, objective=toward_rest, restarts=0)
    return result.q, result.position_error


__all__ = ["solve_ik"]

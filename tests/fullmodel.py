"""The arm's numbers against MuJoCo's model of the whole robot, the held joints at rest."""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np
from numpy.typing import NDArray

from redundancy.engines.mujoco import object_names
from redundancy.model.names import display_names
from redundancy.model.robot import difference_to_whole_robot as largest_difference_to_full_model

__all__ = [
    "arm_moves_pair",
    "largest_difference_to_full_model",
    "library_contacts",
    "whole_robot_contacts",
    "whole_robot_qpos",
]

Array = NDArray[np.float64]


def whole_robot_qpos(arm: object) -> Array:
    """MuJoCo's qpos of the whole robot (``arm.robot_model``) with the held joints at rest."""
    m: mujoco.MjModel = arm.robot_model  # type: ignore[attr-defined]
    names = object_names(m, mujoco.mjtObj.mjOBJ_JOINT)
    shown = display_names(m, mujoco.mjtObj.mjOBJ_JOINT)
    qpos = m.qpos0.copy()
    for name, value in arm.held.items():  # type: ignore[attr-defined]
        j = names.index(name) if name in names else shown.index(name)
        adr = int(m.jnt_qposadr[j])
        qpos[adr : adr + np.size(value)] = value
    return qpos


def arm_moves_pair(arm: object) -> Callable[[int, int], bool]:
    """Whether the arm can change the distance of two geoms of the whole robot.

    Read from the robot's own tree: an arm joint lies on the path between the two bodies.
    """
    m: mujoco.MjModel = arm.robot_model  # type: ignore[attr-defined]
    names = object_names(m, mujoco.mjtObj.mjOBJ_JOINT)
    arm_joints = {names.index(n) for n in arm.joint_names}  # type: ignore[attr-defined]

    def up(b: int) -> list[int]:
        out = [b]
        while b:
            b = int(m.body_parentid[b])
            out.append(b)
        return out

    def moves(g1: int, g2: int) -> bool:
        p1, p2 = up(int(m.geom_bodyid[g1])), up(int(m.geom_bodyid[g2]))
        common = set(p1) & set(p2)
        path = [b for b in p1 + p2 if b not in common]
        return any(
            j in arm_joints
            for b in path
            for j in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b])
        )

    return moves


def whole_robot_contacts(arm: object, Q: Array) -> list[list[tuple[int, int]]]:
    """Raw ``mj_collision`` of the whole robot at each pose, held joints at rest: per pose the
    sorted (geom, geom) of every contact whose distance the arm can change."""
    m: mujoco.MjModel = arm.robot_model  # type: ignore[attr-defined]
    d = mujoco.MjData(m)
    d.qpos[:] = whole_robot_qpos(arm)
    names = object_names(m, mujoco.mjtObj.mjOBJ_JOINT)
    adr = [int(m.jnt_qposadr[names.index(n)]) for n in arm.joint_names]  # type: ignore[attr-defined]
    moves, known = arm_moves_pair(arm), {}
    out = []
    for q in np.asarray(Q, dtype=float):
        d.qpos[adr] = q
        mujoco.mj_kinematics(m, d)
        mujoco.mj_collision(m, d)
        pairs = [tuple(sorted(map(int, g))) for g in d.contact.geom[: d.ncon]]
        for p in pairs:
            if p not in known:
                known[p] = moves(*p)
        out.append(sorted(p for p in pairs if known[p]))
    return out


def library_contacts(arm: object, Q: Array) -> list[list[tuple[int, int]]]:
    """The library's contact list (its collision checker) at each pose, as (geom, geom)."""
    from redundancy.collision import checker

    ch = checker(arm)  # type: ignore[arg-type]
    return [sorted((c.pair.geom1, c.pair.geom2) for c in ch.contacts(q)) for q in Q]

"""Pinocchio's model of the arm: the robot's other joints locked at the rest configuration.

MuJoCo's configuration of the whole robot becomes Pinocchio's (`pinocchio_configuration`:
joints matched by name, quaternions reordered, a free joint made relative to its placement),
and ``buildReducedModel`` locks every joint but the arm's there (`reduce_pinocchio`), with what
it drops carried over (armature: pinocchio#2746).
"""

from __future__ import annotations

import mujoco
import numpy as np

from ..errors import ModelError, UnsupportedFeatureError
from .names import display_names
from .selection import JOINT_NQ, ArmSelection, Array, joint_kind


def pinocchio_joint(pm: object, full: mujoco.MjModel, j: int) -> int | None:
    """Pinocchio's joint id for MuJoCo joint ``j``: by name, else (unnamed) by its body's frame."""
    import pinocchio as pin

    name = mujoco.mj_id2name(full, mujoco.mjtObj.mjOBJ_JOINT, j)
    if name:
        return int(pm.getJointId(name)) if pm.existJointName(name) else None  # type: ignore[attr-defined]
    body = mujoco.mj_id2name(full, mujoco.mjtObj.mjOBJ_BODY, int(full.jnt_bodyid[j]))
    if body and full.body_jntnum[full.jnt_bodyid[j]] == 1:
        if pm.existFrame(body, pin.FrameType.BODY):  # type: ignore[attr-defined]
            frame = pm.frames[pm.getFrameId(body, pin.FrameType.BODY)]  # type: ignore[attr-defined]
            return int(frame.parentJoint) or None
    return None


def pinocchio_configuration(pm: object, full: mujoco.MjModel, qpos: Array) -> Array:
    """Pinocchio's configuration vector for MuJoCo's ``qpos`` of the same robot.

    Joints are matched by name (an unnamed one by its body's frame). Hinge and slide values
    carry over. A ball joint's quaternion w x y z becomes Pinocchio's x y z w. A free joint's
    qpos is the body's world pose, where Pinocchio's free-flyer configuration is the pose
    relative to the joint's placement (the body's pose in the file): it becomes
    ``placement^-1 * pose``, as x y z, qx qy qz qw. A Pinocchio joint MuJoCo does not have
    stays at Pinocchio's neutral configuration.
    """
    import pinocchio as pin

    q = np.array(pin.neutral(pm))
    given = {  # bodies of the trees Pinocchio was given (by name)
        str(f.name)
        for f in pm.frames
        if f.type == pin.FrameType.BODY  # type: ignore[attr-defined]
    }
    for j in range(full.njnt):
        jid = pinocchio_joint(pm, full, j)
        if jid is None:
            body = mujoco.mj_id2name(full, mujoco.mjtObj.mjOBJ_BODY, int(full.jnt_bodyid[j]))
            adr, n = int(full.jnt_qposadr[j]), JOINT_NQ[joint_kind(full, j)]
            at_reference = np.array_equal(qpos[adr : adr + n], full.qpos0[adr : adr + n])
            if body in given and not at_reference:
                # Pinocchio has the body but not this joint (its MJCF parser merges the
                # joints of one body into one): it can only hold it where the file puts it.
                raise UnsupportedFeatureError(
                    "held joint Pinocchio does not read",
                    f"joint {display_names(full, mujoco.mjtObj.mjOBJ_JOINT)[j]!r} (body {body!r})",
                    "Pinocchio merges the joints of one body; it can hold them only at the "
                    "model's reference configuration (rest=None)",
                )
            continue
        joint = pm.joints[jid]  # type: ignore[attr-defined]
        adr, kind = int(full.jnt_qposadr[j]), joint_kind(full, j)
        values = np.asarray(qpos[adr : adr + JOINT_NQ[kind]], dtype=float)
        if kind == "free":
            rot = np.zeros(9)
            mujoco.mju_quat2Mat(rot, values[3:7])
            world = pin.SE3(rot.reshape(3, 3), values[:3].copy())
            rel = pm.jointPlacements[jid].inverse() * world  # type: ignore[attr-defined]
            values = np.asarray(pin.SE3ToXYZQUAT(rel))
        elif kind == "ball":
            values = np.concatenate([values[1:4], values[0:1]])
        if joint.nq != len(values):
            raise UnsupportedFeatureError(
                "joint Pinocchio reads differently",
                f"joint {display_names(full, mujoco.mjtObj.mjOBJ_JOINT)[j]!r}",
                f"MuJoCo gives it {len(values)} coordinate(s), Pinocchio {joint.nq}",
            )
        q[joint.idx_q : joint.idx_q + joint.nq] = values
    return q


#: Per-dof vectors of a Pinocchio model that ``buildReducedModel`` does not carry over.
_PER_DOF = ("armature", "damping", "friction", "effortLimit", "velocityLimit")


_PER_Q = ("lowerPositionLimit", "upperPositionLimit")


def reduce_pinocchio(pm: object, full: mujoco.MjModel, sel: ArmSelection) -> object:
    """Pinocchio's model with every joint but the arm's locked at the rest configuration.

    Raises:
        UnsupportedFeatureError: Pinocchio lacks an arm joint, or has joints MuJoCo does not.
    """
    names = [pm.names[j] for j in range(1, pm.njoints)]  # type: ignore[attr-defined]
    missing = [n for n in sel.joints if n not in names]
    if missing:
        raise UnsupportedFeatureError(
            "arm joint Pinocchio does not read",
            f"joint {missing[0]!r}",
            f"Pinocchio's joints are {names}",
        )
    locked = [pm.getJointId(n) for n in names if n not in sel.joints]  # type: ignore[attr-defined]
    if not locked:
        return pm
    q = pinocchio_configuration(pm, full, sel.qpos)
    reduced = _reduced_model(pm, locked, q)
    for n in sel.joints:  # pinocchio#2746: the reduced model's per-dof vectors restart
        a = pm.joints[pm.getJointId(n)]  # type: ignore[attr-defined]
        b = reduced.joints[reduced.getJointId(n)]
        for attr in _PER_DOF:
            vec = np.array(getattr(reduced, attr))
            vec[b.idx_v] = np.asarray(getattr(pm, attr))[a.idx_v]
            setattr(reduced, attr, vec)
        for attr in _PER_Q:
            vec = np.array(getattr(reduced, attr))
            vec[b.idx_q] = np.asarray(getattr(pm, attr))[a.idx_q]
            setattr(reduced, attr, vec)
    reduced.gravity = pm.gravity  # type: ignore[attr-defined]
    return reduced


def _reduced_model(pm: object, locked: list[int], q: Array) -> object:
    """``buildReducedModel``, with frames that share a name told apart while it runs.

    It finds frames by name alone and fails when a body and a joint share one ("Several
    frames match the filter"): each frame of a shared name gets a unique name for the call,
    and the reduced model gets the names back (a locked joint's frame keeps its own). A
    failure is reported as the library's error, naming the joints it was asked to lock.
    """
    import pinocchio as pin

    work = pin.Model(pm)  # a copy: the whole robot's names stay as they are
    counts: dict[str, int] = {}
    for f in work.frames:
        counts[f.name] = counts.get(f.name, 0) + 1
    original: dict[str, str] = {}
    for i, f in enumerate(work.frames):
        if counts[f.name] > 1:
            unique = f"{f.name}\x00{i}"
            original[unique] = f.name
            if f.type == pin.FrameType.JOINT and work.names[f.parentJoint] == f.name:
                work.names[f.parentJoint] = unique
            f.name = unique
            work.frames[i] = f
    try:
        reduced = pin.buildReducedModel(work, locked, q)
    except (RuntimeError, ValueError) as err:
        held = [pm.names[j] for j in locked]  # type: ignore[attr-defined]
        raise ModelError(f"Pinocchio could not hold the joints {held}: {err}") from err
    for i, f in enumerate(reduced.frames):
        if f.name in original:
            f.name = original[f.name]
            reduced.frames[i] = f
    for j in range(reduced.njoints):
        reduced.names[j] = original.get(reduced.names[j], reduced.names[j])
    return reduced

"""The robot and its arm: the chain from the world to the tool, the rest of the robot held.

A published file describes a robot (a gripper, a second arm, a torso, legs, a floating base); the
library's arm is the chain to the tool. `select_arm` reads MuJoCo's compiled model of the *whole*
robot and returns an `ArmSelection`: the hinge and slide joints on the path from the world (or from
``base``) to the tool, in chain order, and every other joint held at a rest configuration. Both
engines then get the robot with the held joints welded at that configuration:

* MuJoCo: `reduce_mujoco` edits the robot's `mujoco.MjSpec`: each held joint is deleted and its body
  placed where the rest configuration puts it (from MuJoCo's own kinematics of the whole robot), and
  every element that refers to a held joint (actuators, tendons, equality constraints, sensors) is
  set aside, or refused when it reaches an arm joint. Bodies, geoms and sites are all kept, in the
  same order (body ids do not change).
* Pinocchio: `reduce_pinocchio` locks the held joints with ``buildReducedModel`` at the same
  configuration (in Pinocchio's quaternion convention, x y z w, where MuJoCo's is w x y z) and
  carries over what ``buildReducedModel`` drops (armature: pinocchio#2746).

The pieces live in modules of their own: `redundancy.model.selection` (what a selection is),
`redundancy.model.couplings` (equalities, tendons, actuators), `redundancy.model.contact_rules`
(the body pairs MuJoCo tests) and `redundancy.model.reduced_pinocchio`.

Nothing of the whole robot is lost for the arm: a held body keeps its mass where the rest
configuration places it, so the arm's Jacobian, mass matrix and gravity are those of the
whole robot with the held joints still (tested against MuJoCo's full model, rows and columns
of the arm's dofs).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import mujoco
import numpy as np

from ..arm_keyframes import held_value_distance
from ..engines.mujoco import object_names, rest_data, whole_model_quantities
from ..errors import ModelError, ParameterError, UnknownNameError, UnsupportedFeatureError
from ..kernels import scaled_error
from ..quantities import QUANTITY
from .contact_rules import arm_welds, bodies_filtered, keep_contact_rules, moved_bodies
from .coupled_chain import coupled_system
from .couplings import check_couplings, delete_couplings, follow_couplings
from .names import display_names
from .reduced_pinocchio import pinocchio_configuration, pinocchio_joint, reduce_pinocchio
from .scales import arm_scales
from .selection import JOINT_NQ, ArmSelection, Array, RestSpec, SetAside, joint_kind

# The selection's types, the couplings, the contact rules and Pinocchio's reduction live in
# modules of their own; their public names stay importable from here.
__all__ = [
    "ArmSelection",
    "RestSpec",
    "SetAside",
    "arm_welds",
    "bodies_filtered",
    "chain_bodies",
    "difference_to_whole_robot",
    "follow_couplings",
    "held_values",
    "keyframe_moves",
    "moved_bodies",
    "pinocchio_configuration",
    "pinocchio_joint",
    "reduce_mujoco",
    "reduce_pinocchio",
    "select_arm",
    "whole_robot_quantities",
]


def chain_bodies(model: mujoco.MjModel, body: int, base: int = 0) -> list[int]:
    """Bodies from below ``base`` down to ``body``, in chain order (``base`` excluded)."""
    out = []
    while body != base and body != 0:
        out.append(body)
        body = int(model.body_parentid[body])
    if body != base:
        raise ValueError("base not on the chain")
    return out[::-1]


def select_arm(
    model: mujoco.MjModel,
    tool: str,
    tool_body: int,
    base: str | None = None,
    rest: RestSpec = None,
    made_fixed: Mapping[str, str] | None = None,
    follows: Mapping[str, float] | None = None,
) -> ArmSelection:
    """The arm joints on the path to ``tool_body`` and the held joints with their rest values.

    A ball or free joint on the path is held too (the arm's joints are its hinges and
    slides); each is listed in the selection's ``set_aside`` with the reason.

    Args:
        model: MuJoCo's compiled model of the whole robot.
        tool: Tool frame name (for messages).
        tool_body: Body id carrying the tool.
        base: Body name the chain starts below (its own joints are held); None: the world.
        rest: Held joints' values: None for ``qpos0`` (each joint's ``ref``, a free body at
            its pose in the file), a keyframe name, or a dict joint name -> value (a float, or
            4 / 7 numbers for a ball / free joint in MuJoCo's w x y z order).
        made_fixed: Joints of the file the loader made fixed -> why (a ``rest`` value for
            one is refused saying so).
        follows: Held joints whose coupling the loader resolved -> the value it gives (a
            mimic follower of a joint made fixed), unless ``rest`` gives one.

    Raises:
        UnknownNameError: ``base`` is not a body on the chain, ``rest`` names no keyframe or a
            joint that is not held.
        UnsupportedFeatureError: No hinge or slide joint on the chain.
        ParameterError: A rest value of the wrong size or not finite, or for a joint made
            fixed at load.
    """
    bodies = display_names(model, mujoco.mjtObj.mjOBJ_BODY)
    joint_names = object_names(model, mujoco.mjtObj.mjOBJ_JOINT)
    base_id = _base_body(model, tool_body, base, bodies)
    path = chain_bodies(model, tool_body, base_id)
    arm_ids = [
        j
        for b in path
        for j in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b])
        if joint_kind(model, j) in ("hinge", "slide")
    ]
    if not arm_ids:
        where = f"the chain from {bodies[base_id]!r} to {tool!r}"
        raise UnsupportedFeatureError(
            "no joints", where, "an arm needs at least one hinge or slide joint on its chain"
        )
    qpos, rest_name, given = _rest_qpos(model, rest, set(arm_ids), made_fixed or {})
    for name, value in (follows or {}).items():
        j = joint_names.index(name) if name in joint_names else -1  # -1: itself made fixed
        if j >= 0 and j not in given and j not in arm_ids:
            qpos[model.jnt_qposadr[j]] = value
    # Couplings on the chain: the arm moves its followers too (redundancy.model.coupled_chain).
    system = coupled_system(model, arm_ids, qpos)
    moving = list(system.joints) if system is not None else arm_ids
    coupled = set(moving) | (set(system.held) if system is not None else set())
    follow_couplings(model, qpos, coupled, given)
    if system is not None:
        for j in system.held:  # loop joints held at rest, at the value the loop closed with
            qpos[model.jnt_qposadr[j]] = system.rest[model.jnt_qposadr[j]]
    held = held_values(model, qpos, set(moving))
    for j in moving:  # the arm's own joints rest at qpos0 (their ref)
        qpos[model.jnt_qposadr[j]] = model.qpos0[model.jnt_qposadr[j]]
    return ArmSelection(
        tool=tool,
        tool_body=tool_body,
        base=base,
        joints=tuple(joint_names[j] for j in moving),
        held=held,
        rest=rest_name,
        qpos=qpos,
        set_aside=_held_on_chain(model, path),
        coupled=system,
    )


def _base_body(
    model: mujoco.MjModel, tool_body: int, base: str | None, bodies: Sequence[str]
) -> int:
    """Body id the chain starts below: ``base`` on the chain to the tool, 0 (the world) for None."""
    if base is None:
        return 0
    path = chain_bodies(model, tool_body)
    if not isinstance(base, str):
        raise ParameterError("base", base, "a body name (str) on the chain to the tool")
    names = [bodies[b] for b in path[:-1]]
    if base not in names:
        raise UnknownNameError("base body on the chain to the tool", base, names)
    return path[names.index(base)]


def _held_on_chain(model: mujoco.MjModel, path: Sequence[int]) -> tuple[SetAside, ...]:
    """The ball and free joints on the chain, held (the arm's joints are its hinges, slides)."""
    shown = display_names(model, mujoco.mjtObj.mjOBJ_JOINT)
    return tuple(
        SetAside(
            "joint on the chain",
            shown[j],
            f"a {joint_kind(model, j)} joint: held at its rest value (the arm's joints are "
            "the chain's hinges and slides); rest= sets it",
        )
        for b in path
        for j in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b])
        if joint_kind(model, j) not in ("hinge", "slide")
    )


def held_values(
    model: mujoco.MjModel, qpos: Array, arm: set[int]
) -> dict[str, float | tuple[float, ...]]:
    """Held joint name -> its value in the whole robot's ``qpos`` (a tuple for ball, free)."""
    shown = display_names(model, mujoco.mjtObj.mjOBJ_JOINT)
    held: dict[str, float | tuple[float, ...]] = {}
    for j in range(model.njnt):
        if j in arm:
            continue
        adr, kind = int(model.jnt_qposadr[j]), joint_kind(model, j)
        values = qpos[adr : adr + JOINT_NQ[kind]]
        held[shown[j]] = float(values[0]) if len(values) == 1 else tuple(float(v) for v in values)
    return held


def keyframe_moves(
    model: mujoco.MjModel, key: int, joints: Sequence[str], held: Mapping[str, object]
) -> dict[str, float | tuple[float, ...]]:
    """The held joints keyframe ``key`` of the whole robot puts elsewhere than ``held``.

    Args:
        model: MuJoCo's compiled model of the whole robot.
        key: Keyframe index.
        joints: The arm's joint names.
        held: Held joint name -> the value the arm holds it at.

    Returns:
        Held joint name -> the keyframe's value (its couplings followed), for each joint
        more than 1e-9 away from its held value (`held_value_distance`: a quaternion and its
        negation are one rotation).
    """
    names = object_names(model, mujoco.mjtObj.mjOBJ_JOINT)
    arm = {names.index(n) for n in joints}
    qpos = model.key_qpos[key].copy()
    follow_couplings(model, qpos, arm)
    out = {}
    for name, value in held_values(model, qpos, arm).items():
        # A ball or free joint's quaternion as a rotation: q and -q put the robot in one pose.
        if name in held and held_value_distance(value, held[name]) > 1e-9:  # type: ignore[arg-type]
            out[name] = value
    return out


def _rest_qpos(
    model: mujoco.MjModel, rest: RestSpec, arm: set[int], made_fixed: Mapping[str, str]
) -> tuple[Array, str, set[int]]:
    """The whole robot's qpos at rest, where it came from, and the joints the user set."""
    if rest is None:
        return model.qpos0.copy(), "qpos0", set()
    if isinstance(rest, str):
        keys = object_names(model, mujoco.mjtObj.mjOBJ_KEY)
        if rest not in keys or not rest:
            raise UnknownNameError("keyframe", rest, [k for k in keys if k])
        return model.key_qpos[keys.index(rest)].copy(), f"keyframe {rest!r}", set()
    if not isinstance(rest, Mapping):
        raise ParameterError(
            "rest", rest, "None, a keyframe name, or a dict joint name -> value [rad or m]"
        )
    qpos = model.qpos0.copy()
    names = object_names(model, mujoco.mjtObj.mjOBJ_JOINT)
    held_names = [n for j, n in enumerate(names) if j not in arm and n]
    for name, value in rest.items():
        if name in made_fixed and name not in names:
            raise ParameterError(
                f"rest[{name!r}]",
                value,
                f"a held joint's value; joint {name!r} was made fixed at load "
                f"({made_fixed[name]}), so it has no value to set",
            )
        if name not in names or names.index(name) in arm:
            raise UnknownNameError("held joint", str(name), held_names)
        j = names.index(name)
        kind = joint_kind(model, j)
        try:
            arr = np.atleast_1d(np.asarray(value, dtype=float)).ravel()
        except (TypeError, ValueError):
            arr = np.array([])
        if arr.size != JOINT_NQ[kind] or not np.isfinite(arr).all():
            raise ParameterError(
                f"rest[{name!r}]",
                value,
                f"{JOINT_NQ[kind]} finite number(s) for a {kind} joint"
                + (" (w x y z quaternion)" if kind == "ball" else "")
                + (" (x y z, then w x y z quaternion)" if kind == "free" else ""),
            )
        if kind in ("ball", "free"):
            quat = arr[-4:]
            norm = float(np.linalg.norm(quat))
            if norm == 0:
                raise ParameterError(f"rest[{name!r}]", value, "a non-zero quaternion")
            arr = np.concatenate([arr[:-4], quat / norm])
        adr = int(model.jnt_qposadr[j])
        qpos[adr : adr + arr.size] = arr
    return qpos, "given", {names.index(n) for n in rest}


# -- MuJoCo ---------------------------------------------------------------------------------


def reduce_mujoco(
    spec: mujoco.MjSpec, full: mujoco.MjModel, sel: ArmSelection
) -> tuple[mujoco.MjModel, tuple[SetAside, ...]]:
    """MuJoCo's model of the robot with the held joints welded at rest.

    Args:
        spec: The robot's spec (edited in place; it compiles to ``full`` as given).
        full: MuJoCo's compiled model of the whole robot.
        sel: The arm selection.

    Returns:
        The compiled reduced model and what was set aside.

    Raises:
        UnsupportedFeatureError: A coupling (equality, tendon, actuator) that reaches an arm
            joint, or a held joint in a body that also carries an arm joint.
        ModelError: MuJoCo cannot compile the reduced model.
    """
    jnames = object_names(full, mujoco.mjtObj.mjOBJ_JOINT)
    bnames = display_names(full, mujoco.mjtObj.mjOBJ_BODY)
    arm_ids = {jnames.index(n) for n in sel.joints}
    held_ids = [j for j in range(full.njnt) if j not in arm_ids]
    moved = moved_bodies(full, arm_ids)
    set_aside: list[SetAside] = list(sel.set_aside)
    coupled = set(sel.coupled.equalities) if sel.coupled is not None else set()
    check_couplings(full, arm_ids, moved, set_aside, coupled)
    if not sel.held and not set_aside:
        return full, ()
    # The whole robot at rest: each held body is placed relative to its parent from here.
    data = rest_data(full, sel.qpos)
    spec_bodies = list(spec.bodies)  # depth-first, as MuJoCo numbers them; 0 is the world
    spec_joints = list(spec.joints)
    if len(spec_bodies) != full.nbody or len(spec_joints) != full.njnt:
        raise ModelError("the robot's spec and its compiled model differ in bodies or joints")
    held_bodies = sorted({int(full.jnt_bodyid[j]) for j in held_ids})
    for b in held_bodies:
        lo, n = int(full.body_jntadr[b]), int(full.body_jntnum[b])
        mixed = [jnames[j] for j in range(lo, lo + n) if j in arm_ids]
        if mixed:
            raise UnsupportedFeatureError(
                "held and arm joints in one body",
                f"body {bnames[b]!r} (arm joint {mixed[0]!r})",
                "a body on the arm's chain may carry hinge and slide joints only",
            )
        _place_held_body(spec_bodies[b], full, data, b, bnames[b])
    delete_couplings(spec, full, arm_ids)
    for j in held_ids:
        spec.delete(spec_joints[j])
    _reduce_keys(spec, full, sel, arm_ids)
    keep_contact_rules(spec, full, arm_ids, spec_bodies)
    # A body left without joints must stay a body (it may carry the tool, geoms, sites).
    spec.compiler.fusestatic = False
    try:
        from ..engines.mujoco import captured_warnings

        with captured_warnings():
            model = spec.compile()
    except ValueError as err:
        raise ModelError(
            f"MuJoCo could not compile the arm with the rest of the robot held: {err}"
        ) from err
    if model.nbody != full.nbody:
        raise ModelError("holding the joints changed MuJoCo's bodies")
    return model, tuple(set_aside)


def _place_held_body(
    body: mujoco.MjsBody, full: mujoco.MjModel, data: mujoco.MjData, b: int, name: str
) -> None:
    """Give a held body the placement in its parent that the rest configuration gives it.

    A body inside a ``<frame>`` (a ``<replicate>`` makes one) is placed in that frame: the
    frame's pose F in the parent is what the compiled placement adds to the body's own
    (``compiled = F * own``), so the new own placement is ``own * compiled^-1 * rest``.
    """
    p = int(full.body_parentid[b])
    rest_pos = data.xmat[p].reshape(3, 3).T @ (data.xpos[b] - data.xpos[p])
    neg = np.zeros(4)
    mujoco.mju_negQuat(neg, data.xquat[p])
    rest_quat = np.zeros(4)
    mujoco.mju_mulQuat(rest_quat, neg, data.xquat[b])
    if body.frame is not None:
        if body.alt.type != mujoco.mjtOrientation.mjORIENTATION_QUAT:
            raise UnsupportedFeatureError(
                "held body inside a <frame>, oriented by euler, axisangle or xyaxes",
                f"body {name!r}",
                "give the body its orientation as quat, or move it out of the <frame>",
            )
        own_quat = np.asarray(body.quat, dtype=float) / np.linalg.norm(body.quat)
        # (own * compiled^-1) maps the compiled placement back to the body's own.
        inv = np.zeros(4)
        mujoco.mju_negQuat(inv, full.body_quat[b])
        delta = np.zeros(4)
        mujoco.mju_mulQuat(delta, own_quat, inv)
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, delta)
        rest_pos = rot.reshape(3, 3) @ (rest_pos - full.body_pos[b]) + np.asarray(body.pos)
        quat = np.zeros(4)
        mujoco.mju_mulQuat(quat, delta, rest_quat)
        rest_quat = quat
    body.pos = rest_pos
    body.alt.type = mujoco.mjtOrientation.mjORIENTATION_QUAT
    body.quat = rest_quat


def _reduce_keys(
    spec: mujoco.MjSpec, full: mujoco.MjModel, sel: ArmSelection, arm: set[int]
) -> None:
    """Keyframes keep their names and the arm joints' values; held values leave with the joints."""
    qadr = [int(full.jnt_qposadr[j]) for j in sorted(arm)]
    vadr = [int(full.jnt_dofadr[j]) for j in sorted(arm)]
    for k, key in enumerate(spec.keys):
        key.qpos = full.key_qpos[k][qadr]
        key.qvel = full.key_qvel[k][vadr]
        key.act = []
        key.ctrl = []  # the held joints' actuators are gone


# -- the check against the whole robot -------------------------------------------------------


def whole_robot_quantities(arm: object, q: Array) -> dict[str, Array]:
    """The tool's Jacobian, the mass matrix and gravity of MuJoCo's model of the whole robot.

    The whole robot (every joint free, ``arm.robot_model``) at its rest configuration with the
    arm's values ``q`` put in; the arm's dofs' rows and columns read out (with coupled
    joints: the chain pose put in, and the chain's rows and columns reduced by G).
    Independent of how the arm holds its joints (no reduced model is involved): the
    reference the tests and ``scripts/survey_robots.py`` hold both engines' arm models to.

    Returns:
        ``"jacobian"`` (6 x n), ``"mass matrix"`` (n x n), ``"gravity"`` (n) and ``"site
        position"`` (3) [SI units].
    """
    m: mujoco.MjModel = arm.robot_model  # type: ignore[attr-defined]
    qpos = m.qpos0.copy()
    names = object_names(m, mujoco.mjtObj.mjOBJ_JOINT)
    shown = display_names(m, mujoco.mjtObj.mjOBJ_JOINT)
    for name, value in arm.held.items():  # type: ignore[attr-defined]
        j = names.index(name) if name in names else shown.index(name)
        adr = int(m.jnt_qposadr[j])
        qpos[adr : adr + np.size(value)] = value
    # A coupled arm: the whole robot at the chain pose, reduced by G (the chain's couplings).
    chain = arm.chain_joint_names  # type: ignore[attr-defined]
    ids = [names.index(n) for n in chain]
    for j, value in zip(ids, arm.chain_pose(q), strict=True):  # type: ignore[attr-defined]
        qpos[m.jnt_qposadr[j]] = value
    C = arm.coupling_jacobian(q)  # type: ignore[attr-defined]
    dofs = [int(m.jnt_dofadr[j]) for j in ids]
    J, M, G, x = whole_model_quantities(m, qpos, arm.frame)  # type: ignore[attr-defined]
    return {
        "jacobian": J[:, dofs] @ C,
        "mass matrix": C.T @ M[np.ix_(dofs, dofs)] @ C,
        "gravity": C.T @ G[dofs],
        "site position": x,
    }


def difference_to_whole_robot(arm: object, q: Array) -> float:
    """Largest difference of the arm (every engine) to `whole_robot_quantities`.

    The library's one error measure (`redundancy.model.scales`): per quantity of the
    registry, ``max |whole - arm| / max(max |whole|, FLOOR x its size on the arm)``, over the
    Jacobian (linear and angular rows apart), the mass matrix (with armature), gravity and
    the tool position.
    """
    whole = whole_robot_quantities(arm, q)
    scales = arm_scales(arm)  # type: ignore[arg-type]
    worst = 0.0
    for engine in arm.engines:  # type: ignore[attr-defined]
        ours = {
            "jacobian": arm.jacobian(q, engine),  # type: ignore[attr-defined]
            "mass matrix": arm.mass_matrix(q, engine=engine),  # type: ignore[attr-defined]
            "gravity": arm.gravity(q, engine),  # type: ignore[attr-defined]
            "site position": arm.site_pose(q, engine)[0],  # type: ignore[attr-defined]
        }
        for key, value in ours.items():
            for index, size in QUANTITY[key].blocks(scales):
                block = (..., *index)
                worst = max(worst, scaled_error(whole[key][block], value[block], size))
    return worst

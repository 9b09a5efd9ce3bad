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

Nothing of the whole robot is lost for the arm: a held body keeps its mass where the rest
configuration places it, so the arm's Jacobian, mass matrix and gravity are those of the
whole robot with the held joints still (tested against MuJoCo's full model, rows and columns
of the arm's dofs).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence, Set
from dataclasses import dataclass, field

import mujoco
import numpy as np
from numpy.typing import NDArray

from ..engines.mujoco import JOINT_TYPES, object_names, rest_data, whole_model_quantities
from ..errors import ModelError, ParameterError, UnknownNameError, UnsupportedFeatureError
from ..kernels import scaled_error
from ..quantities import QUANTITY
from .actuators import transmission_refusal
from .names import display_names
from .scales import arm_scales

Array = NDArray[np.float64]

#: Coordinates of each MuJoCo joint type in qpos.
_NQ = {"hinge": 1, "slide": 1, "ball": 4, "free": 7}

RestSpec = str | Mapping[str, float | Sequence[float]] | None


@dataclass(frozen=True)
class SetAside:
    """Something in the robot's file that does not reach the arm, and why it does not matter.

    With ``reaches_arm``: something the loader read or mended on the way to both engines.

    Attributes:
        what: The element, e.g. ``"equality constraint"``.
        name: Its name (or display name).
        reason: Why the arm's numbers do not depend on it (or what was done with it).
        reaches_arm: The arm does depend on it (a link the arm moves, a file read in place):
            the audit lists it as read or mended, never as set aside.
    """

    what: str
    name: str
    reason: str
    reaches_arm: bool = False

    def __str__(self) -> str:
        return f"{self.what} {self.name!r}: {self.reason}"


@dataclass(frozen=True)
class ArmSelection:
    """The arm inside a robot: its joints, and the joints held at rest.

    Attributes:
        tool: Name of the tool frame (site, body or link) as the user gave it.
        tool_body: MuJoCo body id that carries the tool.
        base: Body the chain starts below, or None (the world).
        joints: Arm joint names, in chain order (world to tool).
        held: Held joint name -> its rest value (a float for hinge and slide joints, a tuple
            for ball and free joints, MuJoCo's convention: quaternions w x y z) [rad or m].
        rest: Where the held values come from: ``"qpos0"``, ``"keyframe 'name'"`` or
            ``"given"``.
        qpos: The whole robot's configuration at rest (MuJoCo's qpos; the arm joints at their
            ``qpos0``).
        set_aside: Elements of the file the arm does not depend on.
    """

    tool: str
    tool_body: int
    base: str | None
    joints: tuple[str, ...]
    held: dict[str, float | tuple[float, ...]]
    rest: str
    qpos: Array
    set_aside: tuple[SetAside, ...] = field(default=())


def chain_bodies(model: mujoco.MjModel, body: int, base: int = 0) -> list[int]:
    """Bodies from below ``base`` down to ``body``, in chain order (``base`` excluded)."""
    out = []
    while body != base and body != 0:
        out.append(body)
        body = int(model.body_parentid[body])
    if body != base:
        raise ValueError("base not on the chain")
    return out[::-1]


def _joint_kind(model: mujoco.MjModel, j: int) -> str:
    return JOINT_TYPES[mujoco.mjtJoint(model.jnt_type[j])]


def select_arm(
    model: mujoco.MjModel,
    tool: str,
    tool_body: int,
    base: str | None = None,
    rest: RestSpec = None,
    made_fixed: Mapping[str, str] | None = None,
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

    Raises:
        UnknownNameError: ``base`` is not a body on the chain, ``rest`` names no keyframe or a
            joint that is not held.
        UnsupportedFeatureError: No hinge or slide joint on the chain.
        ParameterError: A rest value of the wrong size or not finite, or for a joint made
            fixed at load.
    """
    bodies = display_names(model, mujoco.mjtObj.mjOBJ_BODY)
    joint_names = object_names(model, mujoco.mjtObj.mjOBJ_JOINT)
    base_id = 0
    if base is not None:
        path = chain_bodies(model, tool_body)
        if not isinstance(base, str):
            raise ParameterError("base", base, "a body name (str) on the chain to the tool")
        names = [bodies[b] for b in path[:-1]]
        if base not in names:
            raise UnknownNameError("base body on the chain to the tool", base, names)
        base_id = path[names.index(base)]
    path = chain_bodies(model, tool_body, base_id)
    arm_ids = [
        j
        for b in path
        for j in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b])
        if _joint_kind(model, j) in ("hinge", "slide")
    ]
    if not arm_ids:
        where = f"the chain from {bodies[base_id]!r} to {tool!r}"
        raise UnsupportedFeatureError(
            "no joints", where, "an arm needs at least one hinge or slide joint on its chain"
        )
    shown = display_names(model, mujoco.mjtObj.mjOBJ_JOINT)
    frozen = tuple(
        SetAside(
            "joint on the chain",
            shown[j],
            f"a {_joint_kind(model, j)} joint: held at its rest value (the arm's joints are "
            "the chain's hinges and slides); rest= sets it",
        )
        for b in path
        for j in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b])
        if _joint_kind(model, j) not in ("hinge", "slide")
    )
    qpos, rest_name, given = _rest_qpos(model, rest, set(arm_ids), made_fixed or {})
    follow_couplings(model, qpos, set(arm_ids), given)
    held = held_values(model, qpos, set(arm_ids))
    for j in arm_ids:  # the arm's own joints rest at qpos0 (their ref)
        qpos[model.jnt_qposadr[j]] = model.qpos0[model.jnt_qposadr[j]]
    return ArmSelection(
        tool=tool,
        tool_body=tool_body,
        base=base,
        joints=tuple(joint_names[j] for j in arm_ids),
        held=held,
        rest=rest_name,
        qpos=qpos,
        set_aside=frozen,
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
        adr, kind = int(model.jnt_qposadr[j]), _joint_kind(model, j)
        values = qpos[adr : adr + _NQ[kind]]
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
        more than 1e-9 away from its held value.
    """
    names = object_names(model, mujoco.mjtObj.mjOBJ_JOINT)
    arm = {names.index(n) for n in joints}
    qpos = model.key_qpos[key].copy()
    follow_couplings(model, qpos, arm)
    out = {}
    for name, value in held_values(model, qpos, arm).items():
        if name in held and not np.allclose(value, held[name], rtol=0, atol=1e-9):  # type: ignore[arg-type]
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
        kind = _joint_kind(model, j)
        try:
            arr = np.atleast_1d(np.asarray(value, dtype=float)).ravel()
        except (TypeError, ValueError):
            arr = np.array([])
        if arr.size != _NQ[kind] or not np.isfinite(arr).all():
            raise ParameterError(
                f"rest[{name!r}]",
                value,
                f"{_NQ[kind]} finite number(s) for a {kind} joint"
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


def follow_couplings(
    model: mujoco.MjModel, qpos: Array, arm: set[int], given: Set[int] = frozenset()
) -> None:
    """Held joints coupled to others (a URDF ``<mimic>``, an MJCF joint equality) follow them.

    MuJoCo's joint equality holds ``q1 - ref1 = c0 + c1 x + c2 x^2 + c3 x^3 + c4 x^4`` with
    ``x = q2 - ref2`` (``x = 0`` without a second joint); a URDF mimic is ``c0 = offset``,
    ``c1 = multiplier``. Each held follower (joint1) whose leader is held too is set from its
    leader, in ``qpos`` (in place), a follower of a follower after its leader. Couplings that
    reach an arm joint are left to `reduce_mujoco` (refused there).

    Args:
        model: MuJoCo's compiled model of the whole robot.
        qpos: The whole robot's configuration, edited in place.
        arm: Arm joint ids.
        given: Joints whose values the user set: a follower among them whose value
            contradicts its coupling is refused.

    Raises:
        ParameterError: A value given for a follower that its coupling does not give.
    """
    eqs = [
        k
        for k in range(model.neq)
        if model.eq_type[k] == mujoco.mjtEq.mjEQ_JOINT
        and model.eq_active0[k]
        and int(model.eq_obj1id[k]) not in arm
        and int(model.eq_obj2id[k]) not in arm
    ]
    names = display_names(model, mujoco.mjtObj.mjOBJ_JOINT)
    for _ in range(len(eqs) + 1):  # a chain of n couplings settles in n passes
        moved = False
        for k in eqs:
            j1, j2 = int(model.eq_obj1id[k]), int(model.eq_obj2id[k])
            a1 = int(model.jnt_qposadr[j1])
            x = 0.0
            if j2 >= 0:
                a2 = int(model.jnt_qposadr[j2])
                x = float(qpos[a2] - model.qpos0[a2])
            c = model.eq_data[k][:5]
            value = float(model.qpos0[a1] + sum(c[i] * x**i for i in range(5)))
            if qpos[a1] == value:
                continue
            if j1 in given and abs(qpos[a1] - value) > 1e-9 * max(1.0, abs(value)):
                leader = names[j2] if j2 >= 0 else ""
                rule = _coupling_text(model, k, names)
                raise ParameterError(
                    f"rest[{names[j1]!r}]",
                    float(qpos[a1]),
                    f"{value:.6g}, the value its coupling to joint {leader!r} gives ({rule}); "
                    f"set {leader!r} and {names[j1]!r} follows"
                    if leader
                    else f"{value:.6g}, the value its equality fixes ({rule})",
                )
            qpos[a1] = value
            moved = True
        if not moved:
            return


def _coupling_text(model: mujoco.MjModel, k: int, names: Sequence[str]) -> str:
    """``fb = 0.6 - 1 fa``: joint equality ``k`` as the file's joints see it."""

    def shifted(j: int) -> str:
        ref = float(model.qpos0[model.jnt_qposadr[j]])
        return names[j] if ref == 0 else f"({names[j]} - {ref:.6g})"

    j1, j2 = int(model.eq_obj1id[k]), int(model.eq_obj2id[k])
    x = shifted(j2) if j2 >= 0 else "0"
    terms = []
    for i, c in enumerate(model.eq_data[k][:5]):
        if c == 0 or (i and j2 < 0):
            continue
        mono = "" if i == 0 else f" {x}" if i == 1 else f" {x}^{i}"
        terms.append(f"{'-' if c < 0 else '+'} {abs(c):.6g}{mono}")
    rhs = " ".join(terms).removeprefix("+ ") or "0"
    if rhs.startswith("- "):
        rhs = "-" + rhs[2:]
    return f"{shifted(j1)} = {rhs}"


# -- MuJoCo ---------------------------------------------------------------------------------


def moved_bodies(model: mujoco.MjModel, arm_joints: set[int]) -> set[int]:
    """Bodies an arm joint moves: the bodies of the arm joints and everything below them."""
    out: set[int] = set()
    for b in range(1, model.nbody):
        c = b
        while c != 0:
            lo, n = model.body_jntadr[c], model.body_jntnum[c]
            if any(j in arm_joints for j in range(lo, lo + n)):
                out.add(b)
                break
            c = int(model.body_parentid[c])
    return out


def bodies_filtered(model: mujoco.MjModel, b1: int, b2: int) -> bool:
    """MuJoCo's body-pair filter (filterBodyPair in engine_collision_driver.c).

    Bodies welded together (same ``body_weldid``, which includes a body and itself) never
    collide. With ``filterparent`` on (the default), a body does not collide with its parent,
    where both are taken as weld groups: the parent of a weld group is the weld group of the
    parent of its root body. The world exception: the parent filter only applies when
    neither weld group is the world's, so a body attached to the world by a joint does
    collide with geoms welded to the world (a floor, a base plate).
    """
    w1, w2 = int(model.body_weldid[b1]), int(model.body_weldid[b2])
    if w1 == w2:
        return True
    if model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_FILTERPARENT:
        return False
    if w1 == 0 or w2 == 0:
        return False
    pw1 = int(model.body_weldid[model.body_parentid[w1]])
    pw2 = int(model.body_weldid[model.body_parentid[w2]])
    return w1 == pw2 or w2 == pw1


def arm_welds(model: mujoco.MjModel, arm_joints: set[int]) -> list[int]:
    """Each body's weld group once the held joints are welded.

    A body's nearest ancestor (or itself) carrying an arm joint, 0 (the world) when none
    does. Two bodies of one group never move relative to each other, whatever the arm does.
    """
    welds = [0] * model.nbody
    for b in range(1, model.nbody):  # parents come before children in MuJoCo's body order
        lo, n = int(model.body_jntadr[b]), int(model.body_jntnum[b])
        arm = any(j in arm_joints for j in range(lo, lo + n))
        welds[b] = b if arm else welds[int(model.body_parentid[b])]
    return welds


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
    _check_couplings(full, arm_ids, moved, set_aside)
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
    _delete_couplings(spec, full, arm_ids)
    for j in held_ids:
        spec.delete(spec_joints[j])
    _reduce_keys(spec, full, sel, arm_ids)
    _keep_contact_rules(spec, full, arm_ids, spec_bodies)
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


def _keep_contact_rules(
    spec: mujoco.MjSpec, full: mujoco.MjModel, arm: set[int], spec_bodies: list
) -> None:
    """The whole robot's contact filter in the arm's model (MuJoCo then tests the same pairs).

    Welding the held joints merges weld groups, and MuJoCo's parent filter works on weld
    groups: on the arm's model it would both drop pairs the robot tests (a held finger welded
    into the hand becomes a child of the forearm) and test pairs the robot never does (a
    held free pelvis welded to the world loses its parent rule with the torso, by the world
    exception). So the parent filter is turned off in the arm's model and every body pair the
    robot's own parent filter drops becomes an ``<exclude>``; together with the weld rule, the
    bitmasks and the file's excludes (an SRDF's among them), the arm's model then tests
    exactly the robot's pairs whose distance the arm can change. The file's explicit pairs
    that the arm cannot change (both geoms in one weld group) are dropped with them.
    """
    welds = arm_welds(full, arm)
    names = display_names(full, mujoco.mjtObj.mjOBJ_BODY)
    colliding = [b for b in range(full.nbody) if full.body_contype[b] or full.body_conaffinity[b]]
    excluded = {(int(s) >> 16, int(s) & 0xFFFF) for s in full.exclude_signature}
    for i, b1 in enumerate(colliding):
        for b2 in colliding[i + 1 :]:
            if welds[b1] == welds[b2] or (b1, b2) in excluded:
                continue
            if not (
                full.body_contype[b1] & full.body_conaffinity[b2]
                or full.body_contype[b2] & full.body_conaffinity[b1]
            ):
                continue
            if bodies_filtered(full, b1, b2):
                for b in (b1, b2):  # an exclude names its bodies
                    if not spec_bodies[b].name:
                        spec_bodies[b].name = names[b]
                spec.add_exclude(bodyname1=spec_bodies[b1].name, bodyname2=spec_bodies[b2].name)
    spec.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT)
    geom = mujoco.mjtObj.mjOBJ_GEOM
    for pair in list(spec.pairs):  # by name: the compiler sorts the pairs
        g1 = mujoco.mj_name2id(full, geom, pair.geomname1)
        g2 = mujoco.mj_name2id(full, geom, pair.geomname2)
        if welds[int(full.geom_bodyid[g1])] == welds[int(full.geom_bodyid[g2])]:
            spec.delete(pair)


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


def _check_couplings(
    full: mujoco.MjModel, arm: set[int], moved: set[int], out: list[SetAside]
) -> None:
    """Set aside couplings among held joints; refuse those that reach an arm joint."""
    jnames = display_names(full, mujoco.mjtObj.mjOBJ_JOINT)
    bnames = display_names(full, mujoco.mjtObj.mjOBJ_BODY)
    mjobj = mujoco.mjtObj
    for k in range(full.neq):
        name = mujoco.mj_id2name(full, mjobj.mjOBJ_EQUALITY, k) or f"equality {k}"
        kind = mujoco.mjtEq(full.eq_type[k])
        a, b = int(full.eq_obj1id[k]), int(full.eq_obj2id[k])
        if kind == mujoco.mjtEq.mjEQ_JOINT:
            touching = [jnames[j] for j in (a, b) if j in arm]
            if touching:
                pair = " and ".join(repr(jnames[j]) for j in (a, b) if j >= 0)
                raise UnsupportedFeatureError(
                    "joint coupling on the arm",
                    f"arm joint {touching[0]!r}, coupled by equality {name!r} ({pair})",
                    "an arm joint coupled to another joint (a URDF <mimic>, an MJCF <equality "
                    "joint>) is not a free coordinate, and Pinocchio's parsers ignore the "
                    "coupling; choose a tool or base that leaves it off the chain",
                )
            shown = mujoco.mj_id2name(full, mjobj.mjOBJ_EQUALITY, k) or " = ".join(
                jnames[j] for j in (a, b) if j >= 0
            )
            out.append(
                SetAside(
                    "joint equality",
                    shown,
                    f"couples held joints only; their held values follow it "
                    f"({_coupling_text(full, k, jnames)})",
                )
            )
        elif kind == mujoco.mjtEq.mjEQ_TENDON:
            out.append(SetAside("equality constraint", name, "couples tendons (checked below)"))
        else:
            objs = (a, b)
            if full.eq_objtype[k] == mjobj.mjOBJ_SITE:
                objs = tuple(int(full.site_bodyid[s]) for s in (a, b) if s >= 0)
            between = _joints_between(full, *(objs if len(objs) == 2 else (objs[0], 0)))
            if any(j in arm for j in between):
                bodies = [x for x in objs if x in moved]
                raise UnsupportedFeatureError(
                    "equality constraint on a body the arm moves",
                    f"equality {name!r} (body {bnames[bodies[0]]!r})",
                    "a constraint on the arm's bodies changes its motion; "
                    "the library handles an open chain",
                )
            if any(x in moved for x in objs):
                held = ", ".join(repr(jnames[j]) for j in between) or "none"
                out.append(
                    SetAside(
                        "equality constraint",
                        name,
                        "joins bodies that move with the arm but only relative to each other "
                        f"through held joints ({held}): it cannot change the arm's J, M or "
                        "gravity",
                    )
                )
            else:
                out.append(SetAside("equality constraint", name, "acts on held bodies only"))
    for t in range(full.ntendon):
        name = mujoco.mj_id2name(full, mjobj.mjOBJ_TENDON, t) or f"tendon {t}"
        lo, n = int(full.tendon_adr[t]), int(full.tendon_num[t])
        for w in range(lo, lo + n):
            wtype = mujoco.mjtWrap(full.wrap_type[w])
            obj = int(full.wrap_objid[w])
            if wtype == mujoco.mjtWrap.mjWRAP_JOINT and obj in arm:
                raise UnsupportedFeatureError(
                    "tendon on an arm joint",
                    f"tendon {name!r} (arm joint {jnames[obj]!r})",
                    "Pinocchio has no tendons; the engines would see different arms",
                )
            if wtype == mujoco.mjtWrap.mjWRAP_SITE and int(full.site_bodyid[obj]) in moved:
                raise UnsupportedFeatureError(
                    "tendon through a body the arm moves",
                    f"tendon {name!r} (body {bnames[int(full.site_bodyid[obj])]!r})",
                    "Pinocchio has no tendons; the engines would see different arms",
                )
        out.append(SetAside("tendon", name, "spans held joints or bodies only"))
    for u in range(full.nu):
        name = mujoco.mj_id2name(full, mjobj.mjOBJ_ACTUATOR, u) or f"actuator {u}"
        trn = mujoco.mjtTrn(full.actuator_trntype[u])
        target = int(full.actuator_trnid[u, 0])
        if trn in (mujoco.mjtTrn.mjTRN_JOINT, mujoco.mjtTrn.mjTRN_JOINTINPARENT):
            if target in arm:
                continue
            out.append(SetAside("actuator", name, f"drives held joint {jnames[target]!r}"))
        elif trn == mujoco.mjtTrn.mjTRN_TENDON:
            out.append(SetAside("actuator", name, "drives a tendon of held joints"))
        else:  # site, slider-crank (sites) or body (adhesion) transmissions
            if trn == mujoco.mjtTrn.mjTRN_BODY:
                bodies = [target]
            else:
                bodies = [int(full.site_bodyid[i]) for i in full.actuator_trnid[u] if i >= 0]
            if any(b in moved for b in bodies):
                raise transmission_refusal(int(trn), name)
            out.append(SetAside("actuator", name, "acts on held bodies only"))


def _joints_between(full: mujoco.MjModel, a: int, b: int) -> list[int]:
    """Joints on the tree path between bodies ``a`` and ``b`` (their relative pose's joints)."""

    def up(body: int) -> list[int]:
        out = [body]
        while body != 0:
            body = int(full.body_parentid[body])
            out.append(body)
        return out

    pa, pb = up(a), up(b)
    common = next(x for x in pa if x in pb)
    path = pa[: pa.index(common)] + pb[: pb.index(common)]
    starts = {body: int(full.body_jntadr[body]) for body in path}
    return [j for body in path for j in range(starts[body], starts[body] + full.body_jntnum[body])]


def _delete_couplings(spec: mujoco.MjSpec, full: mujoco.MjModel, arm: set[int]) -> None:
    """Delete what `_check_couplings` set aside, and sensors of deleted elements."""
    mjobj = mujoco.mjtObj
    kept_actuators = {
        u
        for u in range(full.nu)
        if mujoco.mjtTrn(full.actuator_trntype[u])
        in (mujoco.mjtTrn.mjTRN_JOINT, mujoco.mjtTrn.mjTRN_JOINTINPARENT)
        and int(full.actuator_trnid[u, 0]) in arm
    }
    sensors = list(spec.sensors)
    for k in range(full.nsensor):
        kind, obj = int(full.sensor_objtype[k]), int(full.sensor_objid[k])
        gone = (
            (kind == mjobj.mjOBJ_JOINT and obj not in arm)
            or (kind == mjobj.mjOBJ_ACTUATOR and obj not in kept_actuators)
            or kind in (mjobj.mjOBJ_TENDON, mjobj.mjOBJ_EQUALITY)
        )
        if gone:
            spec.delete(sensors[k])
    for u, actuator in enumerate(list(spec.actuators)):
        if u not in kept_actuators:
            spec.delete(actuator)
    for el in [*spec.equalities, *spec.tendons]:
        spec.delete(el)


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


# -- Pinocchio ------------------------------------------------------------------------------


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
            adr, n = int(full.jnt_qposadr[j]), _NQ[_joint_kind(full, j)]
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
        adr, kind = int(full.jnt_qposadr[j]), _joint_kind(full, j)
        values = np.asarray(qpos[adr : adr + _NQ[kind]], dtype=float)
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


# -- the check against the whole robot -------------------------------------------------------


def whole_robot_quantities(arm: object, q: Array) -> dict[str, Array]:
    """The tool's Jacobian, the mass matrix and gravity of MuJoCo's model of the whole robot.

    The whole robot (every joint free, ``arm.robot_model``) at its rest configuration with the
    arm's values ``q`` put in; the arm's dofs' rows and columns read out. Independent of how
    the arm holds its joints (no reduced model is involved): the reference the tests and
    ``scripts/survey_robots.py`` hold both engines' arm models to.

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
    ids = [names.index(n) for n in arm.joint_names]  # type: ignore[attr-defined]
    for j, value in zip(ids, np.asarray(q, dtype=float), strict=True):
        qpos[m.jnt_qposadr[j]] = value
    dofs = [int(m.jnt_dofadr[j]) for j in ids]
    J, M, G, x = whole_model_quantities(m, qpos, arm.frame)  # type: ignore[attr-defined]
    return {
        "jacobian": J[:, dofs],
        "mass matrix": M[np.ix_(dofs, dofs)],
        "gravity": G[dofs],
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

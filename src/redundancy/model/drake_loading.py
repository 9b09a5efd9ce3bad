"""Drake, the third engine: the user's file read by Drake's own parser, or the reason it is not.

Drake (``pip install 'redundancy[drake]'``) takes part when pydrake is importable: `add_drake`
builds a `redundancy.engines.drake.DrakeEngine` for an Arm the loader has made, from the file the
user gave (not the text the library writes for Pinocchio: the point of a third engine is that it
reads the file itself), with the same arm joints, held values, tool frame and base. Where it
cannot, ``arm.absent_engines["drake"]`` says why: pydrake is not installed, Drake's parser refuses
the file (its message) or puts an inertia of its own in place of one it cannot hold (a mass of 0
with a rotational inertia: which link), or Drake's model differs in structure where the library
would have to bridge it (which joint, which frame). Never a crash, never a silent drop.

What Drake reads differently from MuJoCo is bridged the way Pinocchio's reading is, compared first
and copied only where it differs, each copy a `redundancy.model.bridges.Bridge` with ``engine
"drake"`` in ``arm.drake_bridges`` (``arm.bridges`` are Pinocchio's):

* **tool site**: Drake's MJCF parser ignores ``<site>``; an MJCF site tool is a frame fixed to its
  body at MuJoCo's compiled ``site_pos``/``site_quat``. A body or link tool is Drake's body frame.
* **armature**: Drake's reflected rotor inertia (``rotor_inertia x gear_ratio^2`` of the joint's
  actuator, which its MJCF parser reads from a joint's ``armature``) set to the library's where it
  differs (a joint without an actuator gets one, gear ratio 1).
* **body inertia**: MuJoCo's compiled mass, centre and inertia of a body whose inertia MuJoCo
  sets itself (a URDF's ``<mujoco><compiler boundmass=...>``, an MJCF body's geoms), where
  Drake's differ: the bodies Pinocchio's inertia bridge considers.
* **damping, joint range, gravity**: the library's values where Drake's differ.
* **whole model**: where Pinocchio gets MuJoCo's compiled model written out as plain MJCF (a
  ``<frame>``, ``<attach>``, several joints in one body...: `redundancy.model.resolved`), Drake
  reads that text too (measured: Drake's parser turns the slide axes of several joints in one
  rotated body otherwise, 0.49 m at the tool of tests/test_any_file.py's mobile base).
* **URDF root**: Drake makes a parentless link a floating body, MuJoCo and Pinocchio weld it to
  the world at the origin: it is welded (not a bridge: the same reading of URDF).
* **defects the library mends** in a URDF (a massless link's joint made fixed, an invalid inertia)
  are mended for Drake too: it reads the mended text, as both other engines do.

The held joints are not removed from Drake's plant: every context has them at their rest values
(a floating base's quaternion reordered from MuJoCo's x y z, w x y z to Drake's w x y z, x y z; a
ball joint's as Drake's roll-pitch-yaw) and the engine reads the arm's rows and columns.
"""

from __future__ import annotations

import importlib.util
import re
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from ..engines.coupled import CoupledEngine
from ..engines.mujoco import JOINT_TYPES, effective_gravity, object_names, rest_data
from .bridges import Bridge, whole_model
from .drake_parse import DrakeAbsent, DrakeSource, parse
from .names import display_names
from .selection import joint_kind

Array = NDArray[np.float64]

#: What ``arm.absent_engines["drake"]`` says when pydrake cannot be imported.
NOT_INSTALLED = "pydrake is not installed: pip install 'redundancy[drake]'"


def drake_available() -> bool:
    """True when pydrake can be imported (looked up without importing it: no cost)."""
    try:
        return importlib.util.find_spec("pydrake") is not None
    except (ImportError, ValueError):  # a blocked or broken pydrake
        return False


def resolved_robot(full: mujoco.MjModel) -> str:
    """MuJoCo's compiled model of the whole robot as plain MJCF: every tree of the world.

    `redundancy.model.resolved.resolved_mjcf` writes one tree (Pinocchio's parser reads one);
    Drake's reads them all, so a second arm's joints are matched and a table's mass counts.
    """
    from .resolved import resolved_mjcf

    roots = [b for b in range(1, full.nbody) if full.body_parentid[b] == 0]
    whole = ET.fromstring(resolved_mjcf(full, roots[0] if roots else 0))
    world = whole.find("worldbody")
    for r in roots[1:]:
        for body in ET.fromstring(resolved_mjcf(full, r)).find("worldbody") or ():  # type: ignore[union-attr]
            world.append(body)  # type: ignore[union-attr]
    # A massless body's explicit zero inertial fails Drake's unit-inertia check (it divides
    # by the mass); without one, Drake's body has mass 0 too (no geoms are written). A mass
    # of 0 with a rotational inertia stays: Drake cannot hold it, and says so.
    for body in whole.iter("body"):
        for inertial in body.findall("inertial"):
            zero = (float(v) == 0.0 for v in inertial.get("diaginertia", "0").split())
            if float(inertial.get("mass", "0")) == 0.0 and all(zero):
                body.remove(inertial)
    return ET.tostring(whole, encoding="unicode")


def _weld_free_roots(plant: Any) -> None:
    """Weld every URDF link without a parent joint to the world (Drake would let it float)."""
    from pydrake.multibody.tree import BodyIndex

    children = {int(plant.get_joint(j).child_body().index()) for j in plant.GetJointIndices()}
    for b in range(1, plant.num_bodies()):
        body = plant.get_body(BodyIndex(b))
        if b not in children:
            plant.WeldFrames(plant.world_frame(), body.body_frame())


def _arm_joints(plant: Any, names: Sequence[str], types: Sequence[str]) -> list[Any]:
    """Drake's joints of the arm, by name, each of the arm's type; else `DrakeAbsent`."""
    joints = []
    for name, kind in zip(names, types, strict=True):
        if not plant.HasJointNamed(name):
            raise DrakeAbsent(
                f"Drake's parser reads no joint {name!r} (the arm's joints: {list(names)}); "
                "the library would have to bridge the arm's joint structure"
            )
        joint = plant.GetJointByName(name)
        theirs = {"revolute": "hinge", "prismatic": "slide"}.get(joint.type_name())
        if theirs != kind:
            raise DrakeAbsent(
                f"Drake reads joint {name!r} as a {joint.type_name()} joint, MuJoCo as a "
                f"{kind}; the library would have to bridge it"
            )
        joints.append(joint)
    return joints


def _tool_frame(plant: Any, full: mujoco.MjModel, tool: str, frame_type: str) -> tuple[Any, list]:
    """The tool frame in Drake's plant, and the bridge an MJCF site needs."""
    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.math import RigidTransform
    from pydrake.multibody.tree import FixedOffsetFrame

    sid = mujoco.mj_name2id(full, mujoco.mjtObj.mjOBJ_SITE, tool)
    body_id = int(full.site_bodyid[sid])
    body_name = display_names(full, mujoco.mjtObj.mjOBJ_BODY)[body_id]
    name = tool if frame_type == "body" else body_name
    if not plant.HasBodyNamed(name):
        raise DrakeAbsent(
            f"Drake's parser reads no body {name!r} (the tool's); the library would have to "
            "bridge the tool frame"
        )
    body = plant.GetBodyByName(name)
    if frame_type == "body":
        return body.body_frame(), []
    quat = full.site_quat[sid] / np.linalg.norm(full.site_quat[sid])
    X = RigidTransform(Quaternion(quat), full.site_pos[sid].copy())
    frame = plant.AddFrame(FixedOffsetFrame(f"{tool} (site)", body.body_frame(), X))
    bridge = Bridge(
        "site placement",
        tool,
        tuple(float(x) for x in (*full.site_pos[sid], *quat)),
        "site_pos and site_quat in body "
        f"{body_name!r} (pos, then quat w x y z): Drake's MJCF parser does not read sites",
        engine="drake",
    )
    return frame, [bridge]


def _bridge_armature(plant: Any, joints: Sequence[Any], armature: Array) -> list[Bridge]:
    """Make Drake's reflected inertia per arm joint the library's armature where it differs."""
    bridges = []
    by_joint: dict[int, list[Any]] = {}
    for a in plant.GetJointActuatorIndices():
        actuator = plant.get_joint_actuator(a)
        by_joint.setdefault(int(actuator.joint().index()), []).append(actuator)
    for joint, ours in zip(joints, armature, strict=True):
        actuators = by_joint.get(int(joint.index()), [])
        theirs = sum(a.default_reflected_inertia() for a in actuators)
        if theirs == ours:
            continue
        if not actuators:
            actuators = [plant.AddJointActuator(f"{joint.name()} armature", joint)]
            actuators[0].set_default_gear_ratio(1.0)
        for extra in actuators[1:]:
            extra.set_default_rotor_inertia(0.0)
        gear = actuators[0].default_gear_ratio()
        actuators[0].set_default_rotor_inertia(float(ours) / (gear * gear))
        bridges.append(
            Bridge(
                "armature",
                joint.name(),
                float(ours),
                "dof armature + gear^2 x actuator armature, as the reflected inertia "
                "(rotor inertia x gear ratio^2) of the joint's actuator",
                engine="drake",
            )
        )
    return bridges


def _bridge_joint_values(
    joints: Sequence[Any], damping: Array, lower: Array, upper: Array
) -> tuple[list[Bridge], tuple[Array, Array]]:
    """Damping and ranges: the library's, reported where Drake's parser read others."""
    bridges = []
    for joint, d, lo, hi in zip(joints, damping, lower, upper, strict=True):
        theirs = float(np.asarray(joint.default_damping_vector())[0])
        if theirs != d:
            bridges.append(
                Bridge(
                    "damping",
                    joint.name(),
                    float(d),
                    "dof damping + gear^2 x actuator damping",
                    engine="drake",
                )
            )
        rng = (float(joint.position_lower_limits()[0]), float(joint.position_upper_limits()[0]))
        if rng != (float(lo), float(hi)):
            bridges.append(
                Bridge(
                    "joint range",
                    joint.name(),
                    (float(lo), float(hi)),
                    "jnt_range and jnt_limited",
                    engine="drake",
                )
            )
    return bridges, (np.array(lower, dtype=float), np.array(upper, dtype=float))


def _bridge_gravity(plant: Any, full: mujoco.MjModel) -> list[Bridge]:
    """Drake's gravity field set to MuJoCo's where it differs."""
    g = effective_gravity(full)
    if np.array_equal(plant.gravity_field().gravity_vector(), g):
        return []
    plant.mutable_gravity_field().set_gravity_vector(g)
    source = (
        '<flag gravity="disable"/>'
        if full.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_GRAVITY
        else "<option gravity>"
    )
    return [Bridge("gravity", "model", tuple(float(x) for x in g), source, engine="drake")]


def _mujoco_inertia(full: mujoco.MjModel, b: int) -> Any:
    """MuJoCo's compiled spatial inertia of body ``b`` about its origin, in its frame (Drake's)."""
    from pydrake.multibody.tree import RotationalInertia, SpatialInertia

    if full.body_mass[b] <= 0.0:  # Drake aborts making a massless inertia from its parts
        return SpatialInertia.Zero()
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, full.body_iquat[b])
    R = R.reshape(3, 3)
    c = R @ np.diag(full.body_inertia[b]) @ R.T
    central = RotationalInertia(c[0, 0], c[1, 1], c[2, 2], c[0, 1], c[0, 2], c[1, 2])
    return SpatialInertia.MakeFromCentralInertia(
        float(full.body_mass[b]), full.body_ipos[b].copy(), central
    )


def _bridge_inertias(
    plant: Any, full: mujoco.MjModel, causes: dict[int, tuple[str, ...]]
) -> tuple[list[tuple[Any, Any]], list[Bridge]]:
    """MuJoCo's mass, centre and inertia for each body of ``causes`` where Drake's differ.

    The bodies whose masses MuJoCo sets itself (a URDF's ``<mujoco><compiler boundmass...>``,
    an MJCF body's inertia from its geoms): as for Pinocchio, a body read from an explicit
    inertial MuJoCo keeps is never overwritten. Drake keeps a body's inertia in the context:
    the pairs (body, spatial inertia) are set in every context the engine makes.
    """
    names = display_names(full, mujoco.mjtObj.mjOBJ_BODY)
    pairs, bridges = [], []
    for b, reasons in sorted(causes.items()):
        if not 0 < b < full.nbody or not plant.HasBodyNamed(names[b]):
            continue
        body = plant.GetBodyByName(names[b])
        ours = _mujoco_inertia(full, b)
        theirs = body.default_spatial_inertia().CopyToFullMatrix6()
        size = max(1.0, float(np.max(np.abs(ours.CopyToFullMatrix6()))))
        if np.max(np.abs(ours.CopyToFullMatrix6() - theirs)) <= 1e-12 * size:
            continue
        pairs.append((body, ours))
        bridges.append(
            Bridge(
                "body inertia",
                names[b],
                (float(full.body_mass[b]), *(float(x) for x in full.body_ipos[b])),
                "body_mass, body_ipos, body_iquat and body_inertia (mass, then centre of mass "
                "in the body frame); " + ("; ".join(reasons) or "MuJoCo sums the geoms"),
                engine="drake",
            )
        )
    return pairs, bridges


def _rest_positions(plant: Any, full: mujoco.MjModel, qpos: Array) -> Array:
    """Drake's position vector of the whole robot at MuJoCo's ``qpos`` (held values at rest).

    Each of Drake's moving joints is matched to MuJoCo's by name, else (an unnamed MJCF joint,
    a free body's floating joint) by the body it moves; a joint matched to nothing, or read as
    another type, is `DrakeAbsent`.
    """
    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.math import RollPitchYaw, RotationMatrix

    names = object_names(full, mujoco.mjtObj.mjOBJ_JOINT)
    bodies = display_names(full, mujoco.mjtObj.mjOBJ_BODY)
    rest = np.array(plant.GetDefaultPositions(), dtype=float)
    moving = [
        plant.get_joint(j) for j in plant.GetJointIndices() if plant.get_joint(j).num_positions()
    ]
    taken: set[int] = set()
    for j in range(full.njnt):
        kind, adr = joint_kind(full, j), int(full.jnt_qposadr[j])
        body = bodies[int(full.jnt_bodyid[j])]
        match = [d for d in moving if names[j] and d.name() == names[j]]
        if not match:  # unnamed, or a free joint (Drake names a floating joint by its body)
            match = [
                d for d in moving if d.child_body().name() == body and int(d.index()) not in taken
            ]
        if len(match) != 1:
            raise DrakeAbsent(
                f"no joint of Drake's model matches MuJoCo's {kind} joint "
                f"{names[j] or body!r}; the library would have to bridge the joint structure"
            )
        d = match[0]
        taken.add(int(d.index()))
        start, t = d.position_start(), d.type_name()
        if kind in ("hinge", "slide") and t in ("revolute", "prismatic"):
            rest[start] = qpos[adr]
        elif kind == "free" and t == "quaternion_floating":
            rest[start : start + 4] = qpos[adr + 3 : adr + 7]
            rest[start + 4 : start + 7] = qpos[adr : adr + 3]
        elif kind == "ball" and t == "ball_rpy":
            R = RotationMatrix(
                Quaternion(qpos[adr : adr + 4] / np.linalg.norm(qpos[adr : adr + 4]))
            )
            rest[start : start + 3] = RollPitchYaw(R).vector()
        else:
            raise DrakeAbsent(
                f"Drake reads MuJoCo's {kind} joint {names[j] or body!r} as a {t} joint; the "
                "library would have to bridge it"
            )
    extra = [d.name() for d in moving if int(d.index()) not in taken]
    if extra:
        raise DrakeAbsent(
            f"Drake's model has joints MuJoCo's has not: {extra}; the library would have to "
            "bridge the joint structure"
        )
    return rest


def _check_axes(
    plant: Any, full: mujoco.MjModel, qpos: Array, joints: Sequence[Any], rest: Array
) -> None:
    """`DrakeAbsent` where Drake's axis or anchor of an arm joint is not MuJoCo's, at rest.

    Both in the world, the whole robot at its rest configuration (a hinge's anchor; a slide
    has only its axis). Measured (drake 1.51): Drake's MJCF parser leaves a joint of a
    ``<default>`` class without a ``<joint>`` of its own on Drake's axis (0 0 1), not the
    enclosing class's (Menagerie's UR5e: 1.9 in the tool Jacobian).
    """
    data = rest_data(full, qpos)  # the joints' world axes and anchors (xaxis, xanchor)
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, rest)
    for joint in joints:
        j = mujoco.mj_name2id(full, mujoco.mjtObj.mjOBJ_JOINT, joint.name())
        if j < 0:
            continue
        F = joint.frame_on_parent().CalcPoseInWorld(context)
        revolute = joint.type_name() == "revolute"
        local = joint.revolute_axis() if revolute else joint.translation_axis()
        theirs = F.rotation().matrix() @ local
        anchor = joint.frame_on_child().CalcPoseInWorld(context).translation()
        size = max(1.0, float(np.max(np.abs(data.xanchor[j]))))
        if np.max(np.abs(theirs - data.xaxis[j])) > 1e-9 or (
            revolute and np.max(np.abs(anchor - data.xanchor[j])) > 1e-9 * size
        ):
            fmt = lambda v: "(" + " ".join(f"{x + 0.0:.6g}" for x in v) + ")"  # noqa: E731
            raise DrakeAbsent(
                f"Drake reads joint {joint.name()!r} about axis {fmt(theirs)} through "
                f"{fmt(anchor)}, MuJoCo about {fmt(data.xaxis[j])} through "
                f"{fmt(data.xanchor[j])} (world, at rest); the library would have to bridge it"
            )


def build_drake(
    source: DrakeSource,
    full: mujoco.MjModel,
    qpos: Array,
    arm: Any,
    causes: dict[int, tuple[str, ...]] | None = None,
) -> tuple[Any, tuple[Bridge, ...], tuple[str, ...]]:
    """Drake's engine for ``arm`` (built by the loader), its bridges and the parser's warnings.

    Args:
        source: What Drake's parser reads.
        full: MuJoCo's compiled model of the whole robot.
        qpos: The whole robot's rest configuration (MuJoCo's order), held values in it.
        arm: The Arm (its joints, types, tool frame, armature, damping and limits).
        causes: Body id -> why MuJoCo's compiled inertia is not the file's (the bodies
            whose inertia is bridged where Drake's differs).

    Raises:
        DrakeAbsent: Drake cannot take part (the message says why).
    """
    from pydrake.multibody.plant import MultibodyPlant

    from ..engines.drake import DrakeEngine

    plant = MultibodyPlant(0.0)
    warnings = parse(plant, source)
    if source.urdf:
        _weld_free_roots(plant)
    # A coupled arm's engines hold the chain, followers free; the coupling map is applied
    # above them (`CoupledEngine`), for Drake as for the other two.
    mj = arm.mujoco if arm.coupling is None else arm.mujoco.inner
    chain_types = tuple(JOINT_TYPES[mujoco.mjtJoint(t)] for t in mj.model.jnt_type)
    joints = _arm_joints(plant, arm.chain_joint_names, chain_types)
    tool, bridges = _tool_frame(plant, full, arm.frame, arm.frame_type)
    bridges += _bridge_armature(plant, joints, mj.armature)
    lower, upper = mj.limits
    values, limits = _bridge_joint_values(joints, mj.damping, lower, upper)
    bridges += values + _bridge_gravity(plant, full)
    plant.Finalize()
    inertias, inertia_bridges = _bridge_inertias(plant, full, causes or {})
    bridges += inertia_bridges
    rest = _rest_positions(plant, full, qpos)
    _check_axes(plant, full, qpos, joints, rest)
    engine = DrakeEngine(plant, tool, joints, rest, mj.damping, limits, inertias)
    return engine, tuple(bridges), tuple(warnings)


#: Drake's MJCF parser's refusals of a mesh MuJoCo read (drake 1.51): a mesh file not in .obj
#: format, or one it looks for elsewhere (an included file's relative ``meshdir``).
_MESH_REFUSAL = re.compile(
    r'only supports mesh files in \.obj format, but the meshfile "([^"]+)"'
    r'|The mesh asset "([^"]+)" could not be found'
)


def _whole_model(full: mujoco.MjModel, refusal: str) -> Bridge:
    """The bridge of a Drake that reads MuJoCo's compiled model: which mesh Drake refused."""
    found = _MESH_REFUSAL.search(refusal)
    obj = found is not None and found.group(1) is not None
    mesh = Path((found.group(1) or found.group(2)) if found else "").name
    why = "reads .obj meshes only" if obj else "does not find a mesh MuJoCo found"
    return whole_model("world", full.nbody - 1, f"Drake's MuJoCo parser {why} ({mesh})", "drake")


def add_drake(
    arm: Any,
    source: DrakeSource | None,
    full: mujoco.MjModel,
    qpos: Array,
    causes: dict[int, tuple[str, ...]] | None = None,
    bridged: tuple[Bridge, ...] = (),
) -> None:
    """Add Drake to ``arm.engines``, or say in ``arm.absent_engines`` why it is not there.

    ``bridged``: what the loader has bridged for Drake already (MuJoCo's compiled model as the
    text Drake reads, where Pinocchio gets it too).
    """
    if not drake_available():
        arm.absent_engines["drake"] = NOT_INSTALLED
        return
    if source is None:
        arm.absent_engines["drake"] = "no file for Drake's parser to read"
        return
    try:
        try:
            engine, bridges, warnings = build_drake(source, full, qpos, arm, causes)
        except DrakeAbsent as err:
            if source.urdf or not _MESH_REFUSAL.search(str(err)) or bridged:
                raise
            # Its MJCF parser takes .obj meshes only: Drake reads MuJoCo's compiled model (no
            # geoms, explicit inertials), as Pinocchio does where its parser falls short.
            engine, bridges, warnings = build_drake(
                DrakeSource(None, resolved_robot(full)), full, qpos, arm, causes
            )
            bridged = (_whole_model(full, str(err)),)
    except ImportError as err:  # importable by name, broken inside
        arm.absent_engines["drake"] = f"pydrake cannot be imported ({err}): {NOT_INSTALLED}"
        return
    except DrakeAbsent as err:
        arm.absent_engines["drake"] = str(err)
        return
    if arm.coupling is not None:
        engine = CoupledEngine(engine, arm.coupling)
    engine.missing_inertia = arm.missing_inertia
    arm.engines["drake"] = engine
    arm.drake_bridges = (*bridged, *bridges)
    arm.drake_warnings = warnings

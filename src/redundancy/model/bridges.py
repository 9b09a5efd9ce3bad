"""Bridges: values Pinocchio's MJCF parser does not read, copied from MuJoCo's compiled model.

Each value is compared first and copied only when Pinocchio's differs, and each copy is recorded as
a `Bridge`, so reports say exactly where the engines would otherwise have seen different arms.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from ..engines.mujoco import effective_gravity, rest_data
from ..engines.pinocchio import frame_placements, joint_kind, tool_frame_id
from ..errors import UnsupportedFeatureError
from .names import body_name, display_names
from .robot import pinocchio_configuration
from .support import inertia_causes

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Bridge:
    """A value an engine's parser does not read as MuJoCo does, copied from MuJoCo's model.

    Attributes:
        quantity: What was bridged, e.g. ``"effort limit"``.
        joint: Joint it applies to.
        value: The value given to the engine [N m, kg m^2...], or a description of it.
        source: Where in MuJoCo's model it came from.
        engine: The engine it was given to: ``"pinocchio"`` or ``"drake"``.
    """

    quantity: str
    joint: str
    value: float | tuple[float, ...] | str
    source: str
    engine: str = "pinocchio"

    @property
    def value_text(self) -> str:
        """The value, formatted compactly."""
        if isinstance(self.value, str):
            return self.value
        if isinstance(self.value, tuple):
            return "(" + ", ".join(f"{v:g}" for v in self.value) + ")"
        return f"{self.value:g}"


def check_pinocchio(
    pm: pin.Model, joint_names: Sequence[str], site: str, frame_type: str = "site"
) -> None:
    """Refuse a Pinocchio model whose joints or tool frame differ from MuJoCo's.

    Raises:
        UnsupportedFeatureError: Joints missing, of another type, or no frame named ``site``.
    """
    pin_joints = [pm.names[j] for j in range(1, pm.njoints)]
    missing = [n for n in joint_names if n not in pin_joints]
    if missing or pm.nq != len(joint_names) or pm.nv != len(joint_names):
        raise UnsupportedFeatureError(
            "joint structure Pinocchio reads differently",
            f"MuJoCo joints {list(joint_names)}, Pinocchio joints {pin_joints} "
            f"(nq {pm.nq}, nv {pm.nv})",
            "the engines must see the same joints",
        )
    if tool_frame_id(pm, site, frame_type) is None:
        raise UnsupportedFeatureError(
            f"tool {frame_type} Pinocchio does not read",
            f"{frame_type} {site!r}",
            "Pinocchio has no frame of that name",
        )
    for n in joint_names:
        kind = joint_kind(pm.joints[pm.getJointId(n)])
        if kind not in ("hinge", "slide"):
            raise UnsupportedFeatureError(
                f"Pinocchio joint type {kind}",
                f"joint {n!r}",
                "expected a 1-dof revolute or prismatic joint",
            )


def bridge_robot(
    pm: pin.Model,
    mm: mujoco.MjModel,
    site: str,
    frame_type: str = "site",
    xml_root: ET.Element | None = None,
    causes: dict[int, tuple[str, ...]] | None = None,
) -> tuple[Bridge, ...]:
    """Copy into Pinocchio's model of the whole robot what its MJCF parser reads differently.

    Done before the held joints are locked (the values are the robot's, not the arm's): the pose of
    a fixed root body; the mass, centre of mass and inertia of bodies whose inertia Pinocchio
    derives from what it reads differently (see `redundancy.model.support.inertia_causes`, which
    needs ``xml_root``, and ``causes``: body id -> why MuJoCo's masses differ from the file's,
    a URDF's MuJoCo compiler options); a tool site placed by site defaults. Each value is
    compared first and copied only when Pinocchio's differs.
    """
    bridges: list[Bridge] = []
    rest = rest_data(mm)  # MuJoCo's world placements at qpos0, for the bridges below
    # The root pose first: the site bridge below compares frames placed from the root.
    sid = mujoco.mj_name2id(mm, mujoco.mjtObj.mjOBJ_SITE, site)
    bridges += _bridge_root_pose(pm, mm, sid)
    if xml_root is not None:
        causes = {**inertia_causes(xml_root, mm), **(causes or {})}
    bridges += _bridge_inertia(pm, mm, causes or {}, rest)
    bridges += _bridge_site(pm, mm, site, frame_type, rest)
    return tuple(bridges)


def bridge(
    pm: pin.Model,
    mm: mujoco.MjModel,
    joint_names: Sequence[str],
    effort_limit: Array,
    armature: Array,
    damping: Array,
    lower: Array,
    upper: Array,
) -> tuple[Bridge, ...]:
    """Copy into Pinocchio's arm model the per-joint values and gravity its parser leaves out.

    Each value is compared first and copied only when Pinocchio's differs, so the list
    says exactly where the engines would otherwise have seen different arms. Bridged: effort
    limits, armature, damping and joint ranges per dof; gravity (``<option gravity>`` and
    ``<flag gravity="disable"/>``).
    """
    bridges: list[Bridge] = []
    # Per-dof values Pinocchio keeps in a vector of its own: (name, its vector, ours, source).
    per_dof = (
        (
            "effort limit",
            pm.effortLimit,
            effort_limit,
            "actuator ctrlrange/forcerange x gear",
        ),
        (
            "armature",
            pm.armature,
            armature,
            "dof armature + gear^2 x actuator armature",
        ),
        ("damping", pm.damping, damping, "dof damping + gear^2 x actuator damping"),
    )
    for i, name in enumerate(joint_names):
        k = pm.joints[pm.getJointId(name)].idx_v
        for quantity, theirs, ours, source in per_dof:
            if theirs[k] != ours[i]:
                theirs[k] = ours[i]  # Pinocchio's vectors are writable views of its model
                bridges.append(Bridge(quantity, name, float(ours[i]), source))
        rng = (float(lower[i]), float(upper[i]))
        if (pm.lowerPositionLimit[k], pm.upperPositionLimit[k]) != rng:
            bridges.append(Bridge("joint range", name, rng, "jnt_range and jnt_limited"))
            pm.lowerPositionLimit[k], pm.upperPositionLimit[k] = rng
    g = effective_gravity(mm)
    if not np.array_equal(pm.gravity.linear, g):
        source = (
            '<flag gravity="disable"/>'
            if mm.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_GRAVITY
            else "<option gravity>"
        )
        bridges.append(Bridge("gravity", "model", tuple(float(x) for x in g), source))
        pm.gravity = pin.Motion(g, np.zeros(3))
    bridges += _bridge_world_mass(pm, mm)
    return tuple(bridges)


def _bridge_world_mass(pm: pin.Model, mm: mujoco.MjModel) -> list[Bridge]:
    """Give Pinocchio's world the mass MuJoCo welds to the world, where it lacks it.

    Only the whole robot's centre of mass and momentum read it (the dynamics of the arm's
    joints do not). Pinocchio's parser reads one tree (a table or a second robot in the
    file are not in its model) and puts a fixed base link's mass in the world's inertia;
    when its mass or centre differs from MuJoCo's bodies welded to the world (held ones
    included), MuJoCo's is copied. A mocap body (and what is welded to it) is a weld group of
    its own in MuJoCo but moves with no joint: it is counted here, at its pose in the file
    (where a fresh ``MjData`` puts ``mocap_pos`` and ``mocap_quat``).
    """
    data = rest_data(mm)
    still = (mm.body_weldid == 0) | (mm.body_mocapid[mm.body_weldid] >= 0)
    welded = [b for b in range(1, mm.nbody) if still[b] and mm.body_mass[b] > 0]
    ours = pin.Inertia.Zero()
    for b in welded:
        R = data.ximat[b].reshape(3, 3)
        inertia = R @ np.diag(mm.body_inertia[b]) @ R.T
        ours += pin.Inertia(float(mm.body_mass[b]), data.xipos[b].copy(), inertia)
    theirs = pm.inertias[0]
    size = max(1.0, ours.mass)
    if abs(theirs.mass - ours.mass) <= 1e-9 * size and np.allclose(
        theirs.mass * theirs.lever, ours.mass * ours.lever, rtol=0.0, atol=1e-9 * size
    ):
        return []
    pm.inertias[0] = ours
    value = (float(ours.mass), *(float(x) for x in ours.lever))
    return [
        Bridge(
            "world mass",
            "world",
            value,
            "body_mass and xipos of the bodies welded to the world (mocap bodies included)",
        )
    ]


def _bridge_site(
    pm: pin.Model,
    mm: mujoco.MjModel,
    site: str,
    frame_type: str,
    data: mujoco.MjData,
) -> list[Bridge]:
    """Fix the site frame's placement when only the site itself is misplaced.

    Pinocchio's parser ignores site defaults (``<default><site pos=.../>``). When the site's body
    sits where MuJoCo puts it but the site does not, the site's placement in its body is copied from
    MuJoCo; a misplaced body is left alone, for the equivalence report to show. ``data`` is MuJoCo's
    at ``qpos0`` (`redundancy.engines.mujoco.rest_data`).
    """
    pd = frame_placements(pm, pinocchio_configuration(pm, mm, mm.qpos0))
    sid = mujoco.mj_name2id(mm, mujoco.mjtObj.mjOBJ_SITE, site)
    fid = tool_frame_id(pm, site, frame_type)
    if fid is None:
        return []  # check_pinocchio refuses it, naming the frame
    site_mj = pin.SE3(data.site_xmat[sid].reshape(3, 3).copy(), data.site_xpos[sid].copy())
    if np.max(np.abs((site_mj.inverse() * pd.oMf[fid]).homogeneous - np.eye(4))) < 1e-12:
        return []
    body = mm.site_bodyid[sid]
    bname = mujoco.mj_id2name(mm, mujoco.mjtObj.mjOBJ_BODY, body) or ""
    body_mj = pin.SE3(data.xmat[body].reshape(3, 3).copy(), data.xpos[body].copy())
    if not pm.existFrame(bname, pin.FrameType.BODY):
        return []
    bf = pm.getFrameId(bname, pin.FrameType.BODY)
    if np.max(np.abs((body_mj.inverse() * pd.oMf[bf]).homogeneous - np.eye(4))) > 1e-12:
        return []
    frame = pm.frames[fid]
    joint_pose = pd.oMi[frame.parentJoint]
    frame.placement = joint_pose.inverse() * site_mj
    pm.frames[fid] = frame
    return [
        Bridge(
            "site placement",
            site,
            tuple(float(x) for x in mm.site_pos[sid]),
            "site_pos and site_quat (site defaults)",
        )
    ]


def _root_body(mm: mujoco.MjModel, site: int) -> int | None:
    """The root body of the tree that carries the tool (the one Pinocchio's parser reads)."""
    root = int(mm.body_rootid[mm.site_bodyid[site]])
    return root if root > 0 else None


def _pinocchio_root_placement(pm: pin.Model, name: str) -> pin.SE3:
    """Where Pinocchio's parser put the root body ``name`` in the world (identity: not at all).

    Pinocchio's MJCF parser attaches a fixed root body at the identity (``addRootJoint``) and
    drops its ``pos``/``quat``; its URDF parser places a link fixed below a ``world`` link at
    the fixed joint's origin. The frame says which happened.
    """
    for f in range(1, len(pm.frames)):
        frame = pm.frames[f]
        if frame.name == name and frame.parentJoint == 0 and frame.type == pin.FrameType.BODY:
            return pin.SE3(frame.placement)
    return pin.SE3.Identity()


def _bridge_root_pose(pm: pin.Model, mm: mujoco.MjModel, site: int) -> list[Bridge]:
    """Place a posed fixed root body where MuJoCo places it, moving only what is misplaced.

    MuJoCo's root body (a child of the world without joints) sits at its ``pos``/``quat``;
    Pinocchio's parser may have placed its frame there already (a URDF whose root link is
    ``world``, with a fixed joint to the robot's base) or at the identity (an MJCF root body:
    measured, a site 1.65 m off on a UR5e). The correction is the difference between the
    two placements, never the pose itself, so an offset is applied once. Every joint and frame
    attached to Pinocchio's world is moved by it: the joint placements of the root's child
    joints and the frames (bodies, fixed bodies, sites) whose parent joint is the world.
    """
    root = _root_body(mm, site)
    if root is None or mm.body_jntnum[root] > 0:
        return []  # a root with a joint: Pinocchio composes its pose into the joint placement
    pos, quat = mm.body_pos[root].copy(), mm.body_quat[root].copy()
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, quat)
    there = _pinocchio_root_placement(pm, body_name(mm, root))
    fix = pin.SE3(rot.reshape(3, 3), pos) * there.inverse()
    if np.allclose(fix.homogeneous, np.eye(4), rtol=0.0, atol=1e-15):
        return []
    for j in range(1, pm.njoints):
        if pm.parents[j] == 0:
            pm.jointPlacements[j] = fix * pm.jointPlacements[j]
    for f in range(1, len(pm.frames)):
        frame = pm.frames[f]
        if frame.parentJoint == 0:
            frame.placement = fix * frame.placement
            pm.frames[f] = frame
    # The root body's own mass, which the parser adds to the world's inertia where it placed
    # the root (the whole robot's centre of mass counts it).
    pm.inertias[0] = fix.act(pm.inertias[0])
    return [
        Bridge(
            "root pose",
            body_name(mm, root),
            tuple(float(x) for x in (*pos, *quat)),
            "body_pos and body_quat of the fixed root body (pos, then quat w x y z), where "
            "Pinocchio's parser placed it elsewhere",
        )
    ]


def _mujoco_joint_inertias(
    mm: mujoco.MjModel, data: mujoco.MjData | None = None
) -> dict[int, pin.Inertia]:
    """MuJoCo's compiled inertia of each joint's bodies, in Pinocchio's joint frame.

    A joint moves its body and every body welded to it; Pinocchio's joint frame is the body frame
    shifted to the joint's ``pos`` (MJCF joints have no orientation). Computed at ``qpos0`` from
    MuJoCo's world poses (``data``, `_rest_kinematics` when None): the relative placements do not
    depend on the pose.
    """
    if data is None:
        data = rest_data(mm)
    out: dict[int, pin.Inertia] = {}
    for j in range(mm.njnt):
        b = int(mm.jnt_bodyid[j])
        joint_world = pin.SE3(
            data.xmat[b].reshape(3, 3).copy(),
            data.xpos[b] + data.xmat[b].reshape(3, 3) @ mm.jnt_pos[j],
        )
        total = pin.Inertia.Zero()
        for w in range(1, mm.nbody):
            if mm.body_weldid[w] != b:
                continue
            local = pin.Inertia(
                float(mm.body_mass[w]), np.zeros(3), np.diag(mm.body_inertia[w].astype(float))
            )
            inertial_world = pin.SE3(data.ximat[w].reshape(3, 3).copy(), data.xipos[w].copy())
            total += (joint_world.inverse() * inertial_world).act(local)
        out[j] = total
    return out


def _inertia_differs(a: pin.Inertia, b: pin.Inertia, tol: float = 1e-12) -> bool:
    scale = max(1.0, abs(a.mass), abs(b.mass))
    return bool(
        abs(a.mass - b.mass) > tol * scale
        or np.max(np.abs(a.lever - b.lever)) > tol
        or np.max(np.abs(a.inertia - b.inertia)) > tol * scale
    )


def _bridge_inertia(
    pm: pin.Model, mm: mujoco.MjModel, causes: dict[int, tuple[str, ...]], data: mujoco.MjData
) -> list[Bridge]:
    """Copy MuJoCo's mass, centre of mass and inertia where Pinocchio computed its own.

    Only joints carrying a body of ``causes`` (inertia summed from geoms, or changed by a compiler
    option) are considered, and each is copied only when Pinocchio's value differs; a body read from
    an explicit ``<inertial>`` is never overwritten, so an unexplained difference there stays a
    difference in [`redundancy.compare_models`][redundancy.compare_models].
    """
    if not causes:
        return []
    ours = _mujoco_joint_inertias(mm, data)
    names = display_names(mm, mujoco.mjtObj.mjOBJ_BODY)
    bridges: list[Bridge] = []
    for j, mine in ours.items():
        b = int(mm.jnt_bodyid[j])
        welded = [w for w in range(1, mm.nbody) if mm.body_weldid[w] == b]
        if not any(w in causes for w in welded):
            continue
        name = mujoco.mj_id2name(mm, mujoco.mjtObj.mjOBJ_JOINT, j) or ""
        if not pm.existJointName(name):
            continue
        jid = pm.getJointId(name)
        if not _inertia_differs(pm.inertias[jid], mine):
            continue
        pm.inertias[jid] = mine
        reasons = [c for w in welded for c in causes.get(w, ())]
        bodies = ", ".join(names[w] for w in welded)
        bridges.append(
            Bridge(
                "body inertia",
                bodies,
                (float(mine.mass), *(float(x) for x in mine.lever)),
                "body_mass, body_ipos, body_iquat and body_inertia (mass, then centre of mass "
                "in the joint frame); "
                + ("; ".join(reasons) if reasons else "Pinocchio's parser sums the geoms itself"),
            )
        )
    return bridges


def whole_model(root: str, bodies: int, because: str, engine: str = "pinocchio") -> Bridge:
    """The bridge of an engine that reads MuJoCo's compiled model instead of the file.

    Args:
        root: The root the model hangs from (a body's name, or ``"world"``).
        bodies: How many bodies it has.
        because: Why the engine cannot read the file itself.
        engine: ``"pinocchio"`` or ``"drake"``.
    """
    return Bridge(
        "whole model",
        root,
        f"{bodies} bodies",
        "compiled model written out as plain MJCF (placements, joints, explicit inertials, "
        f"sites), because {because}",
        engine,
    )

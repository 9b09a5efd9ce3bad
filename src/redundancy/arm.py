"""Loading one MJCF file into both engines, and the :class:`Arm` that holds them.

The loader refuses what the two engines cannot be shown to agree on (see
:func:`check_supported`) and bridges what Pinocchio's MJCF parser does not read, recording
each bridge so that reports can say so.
"""

from __future__ import annotations

import os
import tempfile
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import linalg
from .errors import (
    ModelError,
    OutOfRangeError,
    PoseError,
    UnknownNameError,
    UnsupportedFeatureError,
)
from .mujoco_engine import (
    MujocoEngine,
    actuator_damping,
    captured_warnings,
    joint_force_limits,
)
from .pinocchio_engine import PinocchioEngine, joint_kind

Array = NDArray[np.float64]
EngineName = Literal["mujoco", "pinocchio"]
ENGINES: tuple[EngineName, ...] = ("mujoco", "pinocchio")

_JOINT_TYPES = {
    mujoco.mjtJoint.mjJNT_HINGE: "hinge",
    mujoco.mjtJoint.mjJNT_SLIDE: "slide",
    mujoco.mjtJoint.mjJNT_BALL: "ball",
    mujoco.mjtJoint.mjJNT_FREE: "free",
}


@dataclass(frozen=True)
class Bridge:
    """A value Pinocchio's MJCF parser does not read, copied from MuJoCo's compiled model.

    Attributes:
        quantity: What was bridged, e.g. ``"effort limit"``.
        joint: Joint it applies to.
        value: The value given to Pinocchio [N m, kg m^2...].
        source: Where in MuJoCo's model it came from.
    """

    quantity: str
    joint: str
    value: float | tuple[float, ...]
    source: str

    @property
    def value_text(self) -> str:
        """The value, formatted compactly."""
        if isinstance(self.value, tuple):
            return "(" + ", ".join(f"{v:g}" for v in self.value) + ")"
        return f"{self.value:g}"


def _names(model: mujoco.MjModel, obj: mujoco.mjtObj, n: int) -> list[str]:
    return [mujoco.mj_id2name(model, obj, i) or "" for i in range(n)]


def check_supported(
    model: mujoco.MjModel, xml_root: ET.Element | None = None, strict: bool = True
) -> None:
    """Raise :class:`UnsupportedFeatureError` for anything the engines may not agree on.

    Supported: one fixed-base serial or branching tree of named hinge and slide joints, one
    joint per body, primitive geoms, sites, actuators on joints (bridged), keyframes.

    Args:
        model: MuJoCo's compiled model.
        xml_root: The parsed MJCF, for features MuJoCo compiles away (``<frame>``).
        strict: Also refuse what Pinocchio's parser reads *differently* (meshes, a posed
            fixed root, ``<frame>``, extrinsic euler sequences, non-unit axisangle, default
            classes it applies differently, compiler mass bounds). With ``strict=False``
            such a model loads and :func:`redundancy.compare_models` shows the differences;
            what Pinocchio cannot represent at all, and invalid values (non-finite numbers,
            negative armature or damping, inverted ranges), are refused either way.

    Raises:
        UnsupportedFeatureError: A feature the engines may not agree on.
        ModelError: Values no arm can have (NaN or infinite numbers, negative armature or
            damping, a range whose lower limit is above its upper limit).
    """
    if xml_root is not None:
        _check_xml(xml_root, strict=False)
    if model.njnt == 0:
        raise UnsupportedFeatureError(
            "no joints", "model", "an arm needs at least one hinge or slide joint"
        )
    names = _names(model, mujoco.mjtObj.mjOBJ_JOINT, model.njnt)
    for j in range(model.njnt):
        kind = _JOINT_TYPES[mujoco.mjtJoint(model.jnt_type[j])]
        where = f"joint {names[j]!r}" if names[j] else f"joint #{j}"
        if kind in ("ball", "free"):
            raise UnsupportedFeatureError(
                f"{kind} joint",
                where,
                "only hinge and slide joints are supported (a fixed-base arm)",
            )
        if not names[j]:
            raise UnsupportedFeatureError(
                "unnamed joint",
                where,
                "joints are matched across engines by name; name every joint",
            )
    bodies = _names(model, mujoco.mjtObj.mjOBJ_BODY, model.nbody)
    # Values no arm can have: MuJoCo compiles some of them (an infinite pos, a NaN axis, a
    # negative armature, range="1 -1") and both engines would then compute nonsense.
    arrays = {
        "body_pos": (model.body_pos, bodies, "body"),
        "body_quat": (model.body_quat, bodies, "body"),
        "body_ipos": (model.body_ipos, bodies, "body"),
        "body_mass": (model.body_mass, bodies, "body"),
        "body_inertia": (model.body_inertia, bodies, "body"),
        "jnt_pos": (model.jnt_pos, names, "joint"),
        "jnt_axis": (model.jnt_axis, names, "joint"),
        "jnt_range": (model.jnt_range, names, "joint"),
        "dof_armature": (model.dof_armature, names, "joint"),
        "dof_damping": (model.dof_damping, names, "joint"),
        "geom_pos": (model.geom_pos, _names(model, mujoco.mjtObj.mjOBJ_GEOM, model.ngeom), "geom"),
        "geom_size": (
            model.geom_size,
            _names(model, mujoco.mjtObj.mjOBJ_GEOM, model.ngeom),
            "geom",
        ),
        "site_pos": (model.site_pos, _names(model, mujoco.mjtObj.mjOBJ_SITE, model.nsite), "site"),
    }
    for field, (values, labels, kind) in arrays.items():
        bad = ~np.isfinite(np.asarray(values, dtype=float).reshape(len(values), -1)).all(axis=1)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise ModelError(
                f"non-finite value in the compiled model: {field} of {kind} "
                f"{labels[i] or f'#{i}'!r} is {np.asarray(values[i]).tolist()}"
            )
    if not np.isfinite(model.opt.gravity).all():
        raise ModelError(
            f"non-finite value in the compiled model: gravity {model.opt.gravity.tolist()}"
        )
    for j in range(model.njnt):
        dof = model.jnt_dofadr[j]
        for what, value, unit in (
            ("armature", model.dof_armature[dof], "kg m^2"),
            ("damping", model.dof_damping[dof], "N m s/rad"),
        ):
            if value < 0:
                raise ModelError(
                    f"joint {names[j]!r} has negative {what} {value:g} [{unit}]; it must be >= 0"
                )
        lo, hi = model.jnt_range[j]
        if lo > hi:  # MuJoCo silently leaves such a joint unlimited
            raise ModelError(
                f"joint {names[j]!r} has range [{lo:g}, {hi:g}]: "
                "the lower limit is above the upper limit"
            )
    for b in range(model.nbody):
        if model.body_jntnum[b] > 1:
            raise UnsupportedFeatureError(
                "several joints in one body",
                f"body {bodies[b]!r}",
                "Pinocchio's MJCF parser merges them into one joint; give each joint its own body",
            )
    roots = {int(model.body_rootid[model.jnt_bodyid[j]]) for j in range(model.njnt)}
    if len(roots) > 1:
        raise UnsupportedFeatureError(
            "several kinematic trees",
            "bodies " + ", ".join(repr(bodies[r]) for r in sorted(roots)),
            "the library handles one arm: a single root body carrying all joints",
        )
    for what, count in (("tendon", model.ntendon), ("equality constraint", model.neq)):
        if count:
            raise UnsupportedFeatureError(
                what, f"{count} in the model", "Pinocchio's MJCF parser does not read it"
            )
    root_bodies = [b for b in range(1, model.nbody) if model.body_parentid[b] == 0]
    if len(root_bodies) > 1:
        raise UnsupportedFeatureError(
            "several root bodies",
            "bodies " + ", ".join(repr(bodies[r]) for r in root_bodies),
            "Pinocchio's MJCF parser reads only the first body in <worldbody>; "
            "nest them in one body",
        )
    if not strict:
        return
    root = root_bodies[0]
    posed = np.any(model.body_pos[root] != 0) or np.any(model.body_quat[root] != [1, 0, 0, 0])
    if model.body_jntnum[root] == 0 and posed:
        raise UnsupportedFeatureError(
            "fixed root body with a pose",
            f"body {bodies[root]!r}",
            "Pinocchio's MJCF parser drops the pose of a root body without joints; "
            "move its pos/quat to its children",
        )
    for g in range(model.ngeom):
        non_primitive = (
            mujoco.mjtGeom.mjGEOM_MESH,
            mujoco.mjtGeom.mjGEOM_SDF,
            mujoco.mjtGeom.mjGEOM_HFIELD,
        )
        if int(model.geom_type[g]) in {int(t) for t in non_primitive}:
            gname = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or f"#{g}"
            raise UnsupportedFeatureError(
                "mesh, sdf or height-field geom",
                f"geom {gname!r}",
                "Pinocchio's MJCF parser gives meshes a placeholder inertia; use primitive geoms",
            )
    if xml_root is not None:
        _check_xml(xml_root)


def _check_xml(root: ET.Element, strict: bool = True) -> None:
    """Refuse MJCF spellings that Pinocchio's parser cannot read or reads differently from MuJoCo.

    Args:
        root: The parsed MJCF.
        strict: Also refuse what Pinocchio reads differently (see :func:`check_supported`);
            with False, only what no engine should be given: a root element other than
            ``<mujoco>``, NaN or infinite numbers, and shell inertia (Pinocchio raises).
    """

    def tag(el: ET.Element, *attrs: str) -> str:
        shown = [f"name={el.get('name')!r}"] if el.get("name") else []
        shown += [f"{a}={el.get(a)!r}" for a in attrs if el.get(a) is not None]
        return f"<{' '.join([el.tag, *shown])}>"

    if root.tag != "mujoco":
        raise UnsupportedFeatureError(
            f"<{root.tag}> root element",
            "model",
            "the library reads MJCF, whose root element is <mujoco> (convert a URDF with MuJoCo: "
            "compile it and save it with mujoco.mj_saveLastXML)",
        )
    # Attributes holding names or keywords, never numbers (a body may be called "inf").
    text_attrs = {
        "name",
        "class",
        "childclass",
        "joint",
        "joint1",
        "joint2",
        "body",
        "body1",
        "body2",
        "site",
        "geom",
        "geom1",
        "geom2",
        "mesh",
        "file",
        "material",
        "texture",
        "hfield",
        "tendon",
        "target",
        "prefix",
        "model",
        "plugin",
        "instance",
        "content_type",
        "key",
        "meshdir",
        "texturedir",
        "assetdir",
        "actuator",
        "objname",
        "cranksite",
        "slidersite",
    }
    for el in root.iter():
        for attr, value in el.attrib.items():
            if attr in text_attrs:
                continue
            try:
                numbers = [float(x) for x in value.split()]
            except ValueError:
                continue  # a keyword, not a number list
            if not all(np.isfinite(numbers)):
                raise ModelError(
                    f"non-finite number in the model: {tag(el)} {attr}={value!r}; "
                    "every number must be finite"
                )
        if el.get("shellinertia", "false") == "true":
            raise UnsupportedFeatureError(
                "shell inertia",
                tag(el, "shellinertia"),
                "Pinocchio's MJCF parser cannot compute it; "
                "use a solid geom or an explicit <inertial>",
            )
    if not strict:
        return
    compiler = root.find("compiler")
    seq = compiler.get("eulerseq", "xyz") if compiler is not None else "xyz"
    if seq != seq.lower():
        raise UnsupportedFeatureError(
            "extrinsic eulerseq",
            f"<compiler eulerseq={seq!r}>",
            "Pinocchio's MJCF parser reads it as intrinsic",
        )
    for el in root.iter("compiler"):
        for attr in ("boundmass", "boundinertia", "settotalmass", "inertiagrouprange"):
            if el.get(attr) is not None:
                raise UnsupportedFeatureError(
                    f"compiler {attr}",
                    f"<compiler {attr}={el.get(attr)!r}>",
                    "Pinocchio's MJCF parser ignores it, so the engines' masses would differ; "
                    "write the masses and inertias out",
                )
    for el in root.iter():
        aa = el.get("axisangle")
        if aa is not None:
            try:
                axis = np.array([float(x) for x in aa.split()[:3]])
            except ValueError:
                continue  # MuJoCo has already rejected it
            if abs(np.linalg.norm(axis) - 1.0) > 1e-9:
                raise UnsupportedFeatureError(
                    "axisangle with a non-unit axis",
                    f"<{el.tag} name={el.get('name', '')!r} axisangle={aa!r}>",
                    "Pinocchio's MJCF parser does not normalise the axis; write a unit axis",
                )
    if root.find(".//frame") is not None:
        raise UnsupportedFeatureError(
            "<frame> element", "worldbody", "Pinocchio's MJCF parser drops the contents of <frame>"
        )
    if root.find(".//replicate") is not None:
        raise UnsupportedFeatureError(
            "<replicate> element",
            "worldbody",
            "Pinocchio's MJCF parser does not expand it; write the copies out",
        )
    for default in root.iter("default"):
        where = f"<default class={default.get('class', 'main')!r}>"
        for geom in default.findall("geom"):
            # mass 0 on visual-only geoms is harmless: Pinocchio leaves those out of the inertia.
            visual = geom.get("contype") == "0" and geom.get("conaffinity") == "0"
            if geom.get("mass") is not None and not (visual and float(geom.get("mass", 1)) == 0):
                raise UnsupportedFeatureError(
                    "geom mass in a default class",
                    where,
                    "Pinocchio's MJCF parser ignores a default geom mass (it reads density); "
                    "give the mass on each geom",
                )
        for joint in default.findall("joint"):
            if joint.get("pos") is not None:
                raise UnsupportedFeatureError(
                    "joint pos in a default class",
                    where,
                    "Pinocchio's MJCF parser does not apply it to every joint; "
                    "give the pos on each joint",
                )

    # Class -> its parent class; an element's class may refine the body's childclass (Pinocchio
    # then merges a class with its own ancestor, which changes nothing), not replace it.
    parent_class: dict[str, str] = {}
    for default in root.iter("default"):
        for sub in default.findall("default"):
            parent_class[sub.get("class", "")] = default.get("class", "main")

    def refines(cls: str, active: str) -> bool:
        seen: set[str] = set()
        while cls != active and cls in parent_class and cls not in seen:
            seen.add(cls)
            cls = parent_class[cls]
        return cls == active

    def walk(el: ET.Element, active: str | None) -> None:
        for child in el:
            cls = child.get("class")
            if active is not None and cls is not None and not refines(cls, active):
                raise UnsupportedFeatureError(
                    "class inside a different childclass",
                    f"{tag(child, 'class')} in a body with childclass {active!r}",
                    "Pinocchio's MJCF parser merges the two classes where MuJoCo uses only "
                    "the element's class; set the attributes on the element or use the body's "
                    "childclass",
                )
            walk(child, child.get("childclass", active) if child.tag == "body" else active)

    for world in root.iter("worldbody"):
        walk(world, None)


class Arm:
    """One MJCF arm loaded into MuJoCo and Pinocchio, with joints matched by name.

    Build it with :func:`load` or :func:`load_string`. Joint order is MuJoCo's.

    Attributes:
        mujoco: The MuJoCo engine wrapper.
        pinocchio: The Pinocchio engine wrapper (with bridged effort limits and armature).
        site: Name of the tool site.
        joint_names: Joint names, in order.
        joint_types: ``"hinge"`` or ``"slide"`` per joint.
        lower: Lower joint limits (``-inf`` where unlimited) [rad or m].
        upper: Upper joint limits (``inf`` where unlimited) [rad or m].
        effort_limit: Motor limit per joint from MuJoCo's actuators [N m or N].
        bridges: What was copied from MuJoCo into Pinocchio, one entry per value.
        source: The file the model came from, or ``"<string>"``.
    """

    def __init__(
        self,
        mj_model: mujoco.MjModel,
        pin_model: object,
        site: str,
        source: str,
    ) -> None:
        sites = _names(mj_model, mujoco.mjtObj.mjOBJ_SITE, mj_model.nsite)
        if site not in sites:
            raise UnknownNameError("site", site, [s for s in sites if s])
        self.source = source
        self.site = site
        self.joint_names = tuple(_names(mj_model, mujoco.mjtObj.mjOBJ_JOINT, mj_model.njnt))
        self.joint_types = tuple(_JOINT_TYPES[mujoco.mjtJoint(t)] for t in mj_model.jnt_type)
        self.nq = mj_model.nq
        limited = mj_model.jnt_limited.astype(bool)
        self.lower = np.where(limited, mj_model.jnt_range[:, 0], -np.inf)
        self.upper = np.where(limited, mj_model.jnt_range[:, 1], np.inf)
        self.effort_limit = joint_force_limits(mj_model)
        self.mujoco = MujocoEngine(mj_model, site)
        self._check_pinocchio(pin_model)
        self.bridges = self._bridge(pin_model, mj_model)
        self.pinocchio = PinocchioEngine(pin_model, site, self.joint_names)  # type: ignore[arg-type]

    # -- construction helpers ------------------------------------------------------------
    def _check_pinocchio(self, pm: object) -> None:
        import pinocchio as pin

        assert isinstance(pm, pin.Model)
        pin_joints = [pm.names[j] for j in range(1, pm.njoints)]
        missing = [n for n in self.joint_names if n not in pin_joints]
        if missing or pm.nq != self.nq or pm.nv != self.nq:
            raise UnsupportedFeatureError(
                "joint structure Pinocchio reads differently",
                f"MuJoCo joints {list(self.joint_names)}, Pinocchio joints {pin_joints} "
                f"(nq {pm.nq}, nv {pm.nv})",
                "the engines must see the same joints",
            )
        if self.site not in [f.name for f in pm.frames]:
            raise UnsupportedFeatureError(
                "site Pinocchio does not read",
                f"site {self.site!r}",
                "Pinocchio has no frame of that name",
            )
        for n in self.joint_names:
            kind = joint_kind(pm.joints[pm.getJointId(n)])
            if kind not in ("hinge", "slide"):
                raise UnsupportedFeatureError(
                    f"Pinocchio joint type {kind}",
                    f"joint {n!r}",
                    "expected a 1-dof revolute or prismatic joint",
                )

    def _bridge(self, pm: object, mm: mujoco.MjModel) -> tuple[Bridge, ...]:
        """Copy into Pinocchio what its MJCF parser leaves out or reads differently.

        Each value is compared first and copied only when Pinocchio's differs, so the list
        says exactly where the engines would otherwise have seen different arms.
        """
        import pinocchio as pin

        assert isinstance(pm, pin.Model)
        bridges: list[Bridge] = []
        # Per-dof values Pinocchio keeps in a vector of its own: (name, its vector, ours, source).
        per_dof = (
            (
                "effort limit",
                pm.effortLimit,
                self.effort_limit,
                "actuator ctrlrange/forcerange x gear",
            ),
            (
                "armature",
                pm.armature,
                self.mujoco.armature,
                "dof armature + gear^2 x actuator armature",
            ),
            ("damping", pm.damping, self.damping(), "dof damping + gear^2 x actuator damping"),
        )
        for i, name in enumerate(self.joint_names):
            k = pm.joints[pm.getJointId(name)].idx_v
            for quantity, theirs, ours, source in per_dof:
                if theirs[k] != ours[i]:
                    theirs[k] = ours[i]  # Pinocchio's vectors are writable views of its model
                    bridges.append(Bridge(quantity, name, float(ours[i]), source))
            rng = (float(self.lower[i]), float(self.upper[i]))
            if (pm.lowerPositionLimit[k], pm.upperPositionLimit[k]) != rng:
                bridges.append(Bridge("joint range", name, rng, "jnt_range and jnt_limited"))
                pm.lowerPositionLimit[k], pm.upperPositionLimit[k] = rng
        g = mm.opt.gravity.copy()
        if not np.array_equal(pm.gravity.linear, g):
            bridges.append(
                Bridge("gravity", "model", tuple(float(x) for x in g), "<option gravity>")
            )
            pm.gravity = pin.Motion(g, np.zeros(3))
        bridges += self._bridge_site(pm, mm)
        return tuple(bridges)

    def _bridge_site(self, pm: object, mm: mujoco.MjModel) -> list[Bridge]:
        """Fix the site frame's placement when only the site itself is misplaced.

        Pinocchio's parser ignores site defaults (``<default><site pos=.../>``). When the
        site's body sits where MuJoCo puts it but the site does not, the site's placement in
        its body is copied from MuJoCo; a misplaced body is left alone, for the equivalence
        report to show.
        """
        import pinocchio as pin

        assert isinstance(pm, pin.Model)
        data = mujoco.MjData(mm)
        mujoco.mj_kinematics(mm, data)
        pd = pm.createData()
        q = np.zeros(pm.nq)
        for i, name in enumerate(self.joint_names):
            q[pm.joints[pm.getJointId(name)].idx_q] = mm.qpos0[i]
        pin.framesForwardKinematics(pm, pd, q)
        sid = mujoco.mj_name2id(mm, mujoco.mjtObj.mjOBJ_SITE, self.site)
        fid = pm.getFrameId(self.site)
        site_mj = pin.SE3(data.site_xmat[sid].reshape(3, 3).copy(), data.site_xpos[sid].copy())
        if np.max(np.abs((site_mj.inverse() * pd.oMf[fid]).homogeneous - np.eye(4))) < 1e-12:
            return []
        body = mm.site_bodyid[sid]
        bname = mujoco.mj_id2name(mm, mujoco.mjtObj.mjOBJ_BODY, body) or ""
        body_mj = pin.SE3(data.xmat[body].reshape(3, 3).copy(), data.xpos[body].copy())
        if not pm.existFrame(bname):
            return []
        bf = pm.getFrameId(bname)
        if np.max(np.abs((body_mj.inverse() * pd.oMf[bf]).homogeneous - np.eye(4))) > 1e-12:
            return []
        frame = pm.frames[fid]
        joint_pose = pd.oMi[frame.parentJoint]
        frame.placement = joint_pose.inverse() * site_mj
        pm.frames[fid] = frame
        return [
            Bridge(
                "site placement",
                self.site,
                tuple(float(x) for x in mm.site_pos[sid]),
                "site_pos and site_quat (site defaults)",
            )
        ]

    # -- names, keyframes and poses --------------------------------------------------------
    @property
    def mj_model(self) -> mujoco.MjModel:
        """MuJoCo's compiled model (shared, do not modify)."""
        return self.mujoco.model

    @property
    def keyframes(self) -> dict[str, Array]:
        """Keyframe name -> joint configuration [rad or m]."""
        m = self.mj_model
        return {
            (mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_KEY, k) or f"key{k}"): m.key_qpos[k].copy()
            for k in range(m.nkey)
        }

    def keyframe(self, name: str) -> Array:
        """Joint configuration of a named keyframe [rad or m]."""
        keys = self.keyframes
        if name not in keys:
            raise UnknownNameError("keyframe", name, list(keys))
        return keys[name]

    def joint_index(self, name: str) -> int:
        """Index of a joint in the library's order."""
        if name not in self.joint_names:
            raise UnknownNameError("joint", name, self.joint_names)
        return self.joint_names.index(name)

    def engine(self, name: EngineName) -> MujocoEngine | PinocchioEngine:
        """The wrapper of one engine, by name."""
        if name == "mujoco":
            return self.mujoco
        if name == "pinocchio":
            return self.pinocchio
        raise UnknownNameError("engine", str(name), ENGINES)

    def pose(self, q: ArrayLike, check_range: bool = False, tol: float = 1e-9) -> Array:
        """Validate a joint configuration and return it as a float64 array of shape (nq,).

        Args:
            q: Joint values in the order of :attr:`joint_names` [rad or m].
            check_range: Also require every value inside its joint's range (within ``tol``).
            tol: Slack on the range check [rad or m].

        Raises:
            PoseError: Wrong shape or type, NaN or infinite values.
            OutOfRangeError: A value outside its range (only with ``check_range``).
        """
        try:
            arr = np.asarray(q)
            if np.iscomplexobj(arr):  # float64 conversion would drop the imaginary part silently
                raise PoseError("pose must be real, got complex values")
            arr = np.asarray(arr, dtype=np.float64)
        except PoseError:
            raise
        except (TypeError, ValueError) as err:
            raise PoseError(f"pose must be numeric, got {type(q).__name__}: {err}") from err
        if arr.shape != (self.nq,):
            raise PoseError(
                f"pose must have shape ({self.nq},) for joints {list(self.joint_names)}, got "
                f"shape {arr.shape}"
            )
        bad = ~np.isfinite(arr)
        if bad.any():
            which = [f"{self.joint_names[i]}={arr[i]}" for i in np.flatnonzero(bad)]
            raise PoseError(f"pose has non-finite values: {', '.join(which)}")
        if check_range:
            for i in range(self.nq):
                if not (self.lower[i] - tol <= arr[i] <= self.upper[i] + tol):
                    raise OutOfRangeError(
                        self.joint_names[i],
                        float(arr[i]),
                        float(self.lower[i]),
                        float(self.upper[i]),
                    )
        return arr

    # -- quantities, from either engine -----------------------------------------------------
    def site_pose(self, q: ArrayLike, engine: EngineName = "mujoco") -> tuple[Array, Array]:
        """Tool site position [m] and rotation matrix, world frame."""
        return self.engine(engine).site_pose(self.pose(q))

    def jacobian(self, q: ArrayLike, engine: EngineName = "mujoco") -> Array:
        """Site Jacobian, shape (6, nq): linear rows [m/rad] then angular [rad/rad], world axes."""
        return self.engine(engine).site_jacobian(self.pose(q))

    def svd(
        self, q: ArrayLike, engine: EngineName = "mujoco", rtol: float = linalg.RANK_RTOL
    ) -> linalg.JacobianSVD:
        """SVD of the site Jacobian, with rank, lost directions and condition number."""
        return linalg.jacobian_svd(self.jacobian(q, engine), rtol)

    def manipulability(
        self, q: ArrayLike, length: float = 1.0, engine: EngineName = "mujoco"
    ) -> linalg.Manipulability:
        """Yoshikawa's measure of J, its blocks, and J with position rows divided by length [m]."""
        return linalg.manipulability(self.jacobian(q, engine), length)

    def manipulability_gradient(self, q: ArrayLike, engine: EngineName = "mujoco") -> Array:
        """Gradient d sqrt(det(J J^T)) / dq from second-order kinematics, shape (nq,)."""
        q = self.pose(q)
        eng = self.engine(engine)
        return linalg.manipulability_gradient(eng.site_jacobian(q), eng.jacobian_derivatives(q))

    def nullspace_projector(self, q: ArrayLike, engine: EngineName = "mujoco") -> Array:
        """N = I - J^+ J at ``q``, shape (nq, nq)."""
        return linalg.nullspace_projector(self.jacobian(q, engine))

    def nullspace_basis(self, q: ArrayLike, engine: EngineName = "mujoco") -> Array:
        """Orthonormal basis of J's null space at ``q``, shape (nq, nq - rank)."""
        return linalg.nullspace_basis(self.jacobian(q, engine))

    def mass_matrix(
        self, q: ArrayLike, armature: bool = True, engine: EngineName = "mujoco"
    ) -> Array:
        """Joint-space mass matrix [kg m^2], with or without armature."""
        return self.engine(engine).mass_matrix(self.pose(q), armature)

    def gravity(self, q: ArrayLike, engine: EngineName = "mujoco") -> Array:
        """Gravity torque the motors must supply to hold ``q`` [N m or N]."""
        return self.engine(engine).gravity(self.pose(q))

    def armature(self, engine: EngineName = "mujoco") -> Array:
        """Armature per joint as the engine's mass matrix sees it [kg m^2]."""
        if engine == "pinocchio":
            return np.asarray(self.pinocchio.model.armature)[self.pinocchio.perm].copy()
        return self.engine(engine).armature.copy()  # type: ignore[union-attr]

    def damping(self) -> Array:
        """Damping b per joint: dof damping plus gear^2 x actuator damping [N m s/rad]."""
        return self.mj_model.dof_damping + actuator_damping(self.mj_model)

    def __repr__(self) -> str:
        return f"Arm({self.source!r}, site={self.site!r}, joints={list(self.joint_names)})"


def sampling_ranges(arm: Arm) -> tuple[Array, Array]:
    """Lower and upper bounds used to draw random poses [rad or m].

    The joint ranges; an unlimited hinge is drawn in [-pi, pi].

    Raises:
        PoseError: An unlimited slide joint (no range to draw from).
    """
    lo, hi = arm.lower.copy(), arm.upper.copy()
    for i, kind in enumerate(arm.joint_types):
        if not (np.isfinite(lo[i]) and np.isfinite(hi[i])):
            if kind != "hinge":
                raise PoseError(
                    f"joint {arm.joint_names[i]!r} is an unlimited slide: no range to sample"
                )
            lo[i], hi[i] = -np.pi, np.pi
    return lo, hi


def random_poses(arm: Arm, n: int, seed: int | None = 1) -> Array:
    """``n`` poses drawn uniformly in the joint ranges, shape (n, nq) [rad or m].

    Draws in the same order as ``rng = np.random.default_rng(seed)`` followed by
    ``rng.uniform(lo, hi)`` once per pose, so a seed reproduces the lesson's sample.
    """
    lo, hi = sampling_ranges(arm)
    return np.random.default_rng(seed).uniform(lo, hi, size=(int(n), arm.nq))


def _read_mujoco(xml: str | None, path: Path | None) -> mujoco.MjModel:
    try:
        # MuJoCo's compile-time warnings (a NaN in the XML, a singular inertia, a deprecated
        # attribute) would be printed and written to MUJOCO_LOG.TXT; check_supported refuses
        # their causes with the library's own message instead.
        with captured_warnings():
            if path is not None:
                return mujoco.MjModel.from_xml_path(str(path))
            return mujoco.MjModel.from_xml_string(xml or "")
    except (ValueError, TypeError) as err:
        raise ModelError(f"MuJoCo could not compile the model: {err}") from err


def _read_pinocchio(path: Path) -> object:
    import pinocchio as pin

    try:
        return pin.buildModelFromMJCF(str(path))
    except Exception as err:  # Pinocchio raises bare RuntimeError/ValueError from C++.
        raise ModelError(f"Pinocchio could not read the model: {err}") from err


def _xml_root(text: str) -> ET.Element:
    try:
        return ET.fromstring(text)
    except ET.ParseError as err:
        raise ModelError(f"not well-formed XML: {err}") from err


def load(path: str | os.PathLike[str], site: str = "ee", strict: bool = True) -> Arm:
    """Load an MJCF file into MuJoCo and Pinocchio.

    Args:
        path: MJCF file.
        site: Name of the tool site.
        strict: Refuse features Pinocchio reads differently (see :func:`check_supported`).

    Raises:
        ModelError: The file is missing, not XML, or an engine cannot compile it.
        UnsupportedFeatureError: The model uses something the engines may not agree on.
        UnknownNameError: ``site`` is not a site of the model (the message lists them).
    """
    p = Path(path)
    if not p.is_file():
        raise ModelError(f"MJCF file not found: {str(p)!r}")
    root = _xml_root(p.read_text())
    if root.find(".//include") is not None:
        raise UnsupportedFeatureError(
            "<include> element",
            str(p),
            "Pinocchio's MJCF parser does not follow includes; inline the file",
        )
    mj = _read_mujoco(None, p)
    check_supported(mj, root, strict)
    return Arm(mj, _read_pinocchio(p), site, str(p))


def load_string(xml: str, site: str = "ee", strict: bool = True) -> Arm:
    """Load MJCF text into MuJoCo and Pinocchio (see :func:`load`).

    The text is written to a temporary file for Pinocchio, whose parser reads files, so it
    must not refer to other files (meshes, includes) by relative path.
    """
    if not isinstance(xml, str):
        raise ModelError(f"MJCF text must be a str, got {type(xml).__name__}")
    root = _xml_root(xml)
    if root.find(".//include") is not None:
        raise UnsupportedFeatureError(
            "<include> element",
            "<string>",
            "Pinocchio's MJCF parser does not follow includes; inline the file",
        )
    mj = _read_mujoco(xml, None)
    check_supported(mj, root, strict)
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "model.xml"
        p.write_text(xml)
        pm = _read_pinocchio(p)
    return Arm(mj, pm, site, "<string>")

"""Refusal rules: what the two engines may not agree on, refused with the reason.

:func:`check_supported` reads MuJoCo's compiled model; :func:`check_xml` reads the MJCF text
for spellings MuJoCo compiles away and Pinocchio's parser reads differently.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import mujoco
import numpy as np

from ..engines.mujoco import JOINT_TYPES as _JOINT_TYPES
from ..engines.mujoco import object_names as _names
from ..errors import ModelError, UnsupportedFeatureError


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
        check_xml(xml_root, strict=False)
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
        check_xml(xml_root)


def check_xml(root: ET.Element, strict: bool = True) -> None:
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

"""The model as MuJoCo resolved it, written out as plain MJCF for Pinocchio's parser.

Pinocchio's MJCF parser reads some valid MJCF differently from MuJoCo or not at all
(``<frame>``, ``<replicate>``, an element's ``class`` inside another ``childclass``,
``<attach>``, a joint ``pos`` in a default class); on such a file the loader gives Pinocchio
`resolved_mjcf` instead: MuJoCo's compiled model of the same tree, written with no
defaults, frames or orientation conventions left to interpret, every number in full
precision. What Pinocchio's model needs is written (bodies, joints, explicit inertials,
sites); geoms are not (Pinocchio's kinematic and dynamic model does not read them once every
inertial is explicit; collision shapes come from MuJoCo's model).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Sequence

import mujoco
import numpy as np

from ..engines.mujoco import JOINT_TYPES

#: Why the loader gives Pinocchio the resolved model: (tag or test, reason).
_CAUSES = {
    "frame": "<frame> (Pinocchio's parser drops its contents)",
    "replicate": "<replicate> (Pinocchio's parser does not expand it)",
    "attach": "<attach> (Pinocchio's parser does not expand it)",
}


def _numbers(values: object) -> str:
    return " ".join(repr(float(v)) for v in np.ravel(values))


def resolve_causes(root: ET.Element) -> list[str]:
    """What in the MJCF text Pinocchio's parser cannot read as MuJoCo does.

    Each cause is a short text naming what the user wrote; none: Pinocchio reads the file.
    """
    causes = [text for tag, text in _CAUSES.items() if root.find(f".//{tag}") is not None]
    for default in root.iter("default"):
        for joint in default.findall("joint"):
            if joint.get("pos") is not None:
                causes.append(
                    f"joint pos in <default class={default.get('class', 'main')!r}> "
                    "(Pinocchio's parser does not apply it)"
                )
                break
    causes += _class_in_childclass(root)
    tags = [child.tag for child in root]
    if "worldbody" in tags:
        later = [t for t in ("compiler", "default") if t in tags[tags.index("worldbody") :]]
        causes += [
            f"<{t}> after <worldbody> (Pinocchio's parser applies it only to what follows)"
            for t in later
        ]
    seq = next((c.get("eulerseq") for c in root.iter("compiler") if c.get("eulerseq")), "xyz")
    if seq != seq.lower():
        causes.append(f"<compiler eulerseq={seq!r}> (Pinocchio's parser reads it as intrinsic)")
    for el in root.iter():
        aa = el.get("axisangle")
        try:
            axis = np.array([float(x) for x in (aa or "").split()[:3]])
        except ValueError:
            continue  # MuJoCo has refused it already
        if aa is not None and len(axis) == 3 and abs(np.linalg.norm(axis) - 1.0) > 1e-9:
            name = f" name={el.get('name')!r}" if el.get("name") else ""
            causes.append(
                f"<{el.tag}{name} axisangle={aa!r}> (Pinocchio's parser does not normalise "
                "the axis)"
            )
            break
    return causes


#: Compiler options that change how angles and orientations in the text are read.
_UNIT_OPTIONS = ("angle", "eulerseq")


def unit_causes(root: ET.Element) -> list[str]:
    """Compiler options set differently in several places (a scene and the robot it includes).

    MuJoCo applies the last value of ``angle`` and ``eulerseq`` to the whole model;
    Pinocchio's parser reads each part with the option in force where it stands. The
    resolved model is given to Pinocchio for these in either mode, so no number is read in
    two units.
    """
    causes = []
    for option in _UNIT_OPTIONS:
        values = [c.get(option) for c in root.iter("compiler") if c.get(option) is not None]
        if len(set(values)) > 1:
            shown = ", then ".join(f"{option}={v!r}" for v in values)
            causes.append(
                f"<compiler> {shown} (MuJoCo reads the whole model with the last, Pinocchio's "
                "parser each part with its own)"
            )
    return causes


def _class_in_childclass(root: ET.Element) -> list[str]:
    """Elements whose ``class`` is not a refinement of their body's ``childclass``.

    MuJoCo uses the element's class alone; Pinocchio's parser (4.1) merges the two.
    """
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

    found: list[str] = []

    def walk(el: ET.Element, active: str | None) -> None:
        for child in el:
            cls = child.get("class")
            if active is not None and cls is not None and not refines(cls, active):
                name = f" name={child.get('name')!r}" if child.get("name") else ""
                found.append(
                    f"<{child.tag}{name} class={cls!r}> inside childclass {active!r} "
                    "(Pinocchio's parser merges the two classes)"
                )
            walk(child, child.get("childclass", active) if child.tag == "body" else active)

    for world in root.iter("worldbody"):
        walk(world, None)
    return found[:3]  # a few examples name the pattern


def resolved_mjcf(model: mujoco.MjModel, root_body: int) -> str:
    """MJCF text of the tree below ``root_body`` exactly as MuJoCo compiled it.

    Bodies with their compiled placement (``<frame>`` and orientation conventions folded
    in), joints with axis, position, range, reference, armature, damping and friction loss,
    each body's compiled inertia as an explicit ``<inertial>`` (zero where MuJoCo's is zero),
    sites. Names are MuJoCo's; an unnamed element stays unnamed.

    Args:
        model: MuJoCo's compiled model of the whole robot.
        root_body: The root body of the tree Pinocchio is to read (a child of the world).
    """
    mj = ET.Element("mujoco", model="resolved")
    ET.SubElement(mj, "compiler", angle="radian", autolimits="false")
    ET.SubElement(mj, "option", gravity=_numbers(model.opt.gravity))
    world = ET.SubElement(mj, "worldbody")
    children: dict[int, list[int]] = {}
    for b in range(1, model.nbody):
        children.setdefault(int(model.body_parentid[b]), []).append(b)
    stack = [(root_body, world)]
    while stack:
        b, parent = stack.pop(0)
        el = _body(model, b, parent)
        stack += [(c, el) for c in children.get(b, [])]
    return ET.tostring(mj, encoding="unicode")


def _name(model: mujoco.MjModel, kind: mujoco.mjtObj, i: int) -> dict[str, str]:
    name = mujoco.mj_id2name(model, kind, i)
    return {"name": name} if name else {}


def _body(model: mujoco.MjModel, b: int, parent: ET.Element) -> ET.Element:
    """Body ``b`` under ``parent``; several joints in it become a chain of bodies.

    MuJoCo applies a body's joints one after the other, each about its own anchor and axis in
    the frame the previous ones moved: a chain of bodies at one origin, one joint each.
    Pinocchio's parser would merge them into one joint, so each joint but the last gets a
    massless body of its own, named ``"<body>/<joint>"``; the last joint, the inertia and the
    sites stay on the body, under its own name.
    """
    pos, quat = _numbers(model.body_pos[b]), _numbers(model.body_quat[b])
    lo, n = int(model.body_jntadr[b]), int(model.body_jntnum[b])
    body = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"body {b}"
    for j in range(lo, lo + n - 1):
        joint = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint {j}"
        parent = ET.SubElement(parent, "body", name=f"{body}/{joint}", pos=pos, quat=quat)
        ET.SubElement(parent, "inertial", pos="0 0 0", mass="0", diaginertia="0 0 0")
        _joint(model, j, parent)
        pos, quat = "0 0 0", "1 0 0 0"
    el = ET.SubElement(
        parent, "body", _name(model, mujoco.mjtObj.mjOBJ_BODY, b), pos=pos, quat=quat
    )
    ET.SubElement(
        el,
        "inertial",
        pos=_numbers(model.body_ipos[b]),
        quat=_numbers(model.body_iquat[b]),
        mass=repr(float(model.body_mass[b])),
        diaginertia=_numbers(model.body_inertia[b]),
    )
    if n:
        _joint(model, lo + n - 1, el)
    for s in range(model.nsite):
        if model.site_bodyid[s] == b:
            ET.SubElement(
                el,
                "site",
                _name(model, mujoco.mjtObj.mjOBJ_SITE, s),
                pos=_numbers(model.site_pos[s]),
                quat=_numbers(model.site_quat[s]),
            )
    return el


def forced_causes(model: mujoco.MjModel, tree_root: int, arm: Sequence[str]) -> list[str]:
    """What in MuJoCo's compiled tree Pinocchio's parser cannot represent from the file.

    Several joints in one body of which one is an arm joint (``arm``: their names): the
    parser would merge them (held ones are locked whole, merged or not). The resolved model is
    given to Pinocchio for these in either mode (``strict`` or not): there is no reading of
    the file to compare.
    """
    bodies = [b for b in range(1, model.nbody) if model.body_rootid[b] == tree_root]
    named = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(model.njnt)}
    ids = [model.joint(n).id for n in arm if n in named]
    several = [b for b in bodies if model.body_jntnum[b] > 1 and b in model.jnt_bodyid[ids]]
    if not several:
        return []
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"body {b}" for b in several]
    shown = ", ".join(repr(n) for n in names[:3]) + (" ..." if len(names) > 3 else "")
    return [
        f"several joints in one body ({shown}; Pinocchio's parser merges them into one joint: "
        "given as a chain of bodies, one joint each)"
    ]


def _joint(model: mujoco.MjModel, j: int, body: ET.Element) -> None:
    kind = JOINT_TYPES[mujoco.mjtJoint(model.jnt_type[j])]
    attrs = _name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
    if kind == "free":
        ET.SubElement(body, "freejoint", attrs)
        return
    dof, adr = int(model.jnt_dofadr[j]), int(model.jnt_qposadr[j])
    attrs.update(
        type=kind,
        pos=_numbers(model.jnt_pos[j]),
        armature=repr(float(model.dof_armature[dof])),
        damping=repr(float(model.dof_damping[dof])),
        frictionloss=repr(float(model.dof_frictionloss[dof])),
    )
    if kind in ("hinge", "slide"):
        attrs.update(axis=_numbers(model.jnt_axis[j]), ref=repr(float(model.qpos0[adr])))
    if model.jnt_limited[j]:
        attrs.update(limited="true", range=_numbers(model.jnt_range[j]))
    ET.SubElement(body, "joint", attrs)

"""Refusal rules: what the two engines may not agree on, refused with the reason.

`check_supported` reads MuJoCo's compiled model and, given the parsed MJCF, its text
for values no engine should be given and names Pinocchio cannot tell apart;
`check_robot_values` the whole robot's joints for values Pinocchio's parser fails on.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Sequence

import mujoco
import numpy as np

from ..checks import check_flag
from ..engines.mujoco import JOINT_TYPES as _JOINT_TYPES
from ..engines.mujoco import object_names as _names
from ..errors import ModelError, UnsupportedFeatureError
from .names import display_names

#: Geom types Pinocchio's MJCF parser cannot read at all (it raises on them).
_UNREADABLE_GEOMS = {int(mujoco.mjtGeom.mjGEOM_SDF), int(mujoco.mjtGeom.mjGEOM_HFIELD)}
#: Joint names Pinocchio gives its own joints: its parser corrupts its heap and aborts the
#: process on a joint of that name (measured with Pinocchio 4.1: ``realloc(): invalid next
#: size``, exit 134), so the name is refused before Pinocchio is called.
RESERVED_JOINT_NAMES = ("universe",)
#: Largest magnitude of a compiled length [m], mass [kg], inertia [kg m^2], armature or damping
#: the library accepts: products of three such values stay far from overflow (a body placed at
#: 1e308 m compiles in MuJoCo, then the Jacobian overflows and its SVD fails).
MAX_MAGNITUDE = 1e10
#: Compiler options that change masses: Pinocchio's parser ignores ``settotalmass`` and
#: applies ``boundmass`` / ``boundinertia`` to ``<inertial>`` elements only; ``inertiagrouprange``
#: it ignores (it counts every geom that is not visual).
_MASS_OPTIONS = ("settotalmass", "boundmass", "boundinertia")


def check_supported(
    model: mujoco.MjModel,
    xml_root: ET.Element | None = None,
    strict: bool = True,
    tool_site: str | None = None,
) -> None:
    """Raise `UnsupportedFeatureError` for anything the engines may not agree on.

    Supported: one fixed-base serial or branching tree of named hinge and slide joints
    (several in one body: Pinocchio gets them as a chain, `redundancy.model.resolved`),
    primitive geoms, sites, actuators on joints (bridged), keyframes.

    Args:
        model: MuJoCo's compiled model.
        xml_root: The parsed MJCF, for features MuJoCo compiles away (``<frame>``).
        strict: The load's mode, checked to be a bool. What Pinocchio's parser reads
            differently is not refused in either mode: the loader gives Pinocchio MuJoCo's
            compiled model in strict mode (`redundancy.model.resolved`) and reports
            the differences otherwise; what Pinocchio cannot represent at all, and invalid
            values (non-finite numbers, negative armature or damping, inverted ranges), are
            refused either way.
        tool_site: The site the loader put on a tool body (named after the body, whose
            frame Pinocchio reads instead): exempt from the site-name check.

    Raises:
        UnsupportedFeatureError: A feature the engines may not agree on.
        ModelError: Values no arm can have (NaN or infinite numbers, negative armature or
            damping, a range whose lower limit is above its upper limit).
    """
    strict = check_flag("strict", strict)
    if xml_root is not None:
        _check_xml_values(xml_root)
    if model.njnt == 0:
        raise UnsupportedFeatureError(
            "no joints", "model", "an arm needs at least one hinge or slide joint"
        )
    names = _names(model, mujoco.mjtObj.mjOBJ_JOINT)
    _check_joint_kinds(model, names)
    bodies = list(display_names(model, mujoco.mjtObj.mjOBJ_BODY))
    geoms = display_names(model, mujoco.mjtObj.mjOBJ_GEOM)
    _check_finite(model, names, bodies, geoms)
    _check_joint_values(model, names)
    _check_structure(model, bodies, geoms)
    if xml_root is not None:  # names as Pinocchio's MJCF parser turns them into frames
        check_names(model, tool_site)


def _check_joint_kinds(model: mujoco.MjModel, names: Sequence[str]) -> None:
    """Refuse ball and free joints, and unnamed joints (joints are matched by name)."""
    joint_labels = display_names(model, mujoco.mjtObj.mjOBJ_JOINT)
    for j in range(model.njnt):
        kind = _JOINT_TYPES[mujoco.mjtJoint(model.jnt_type[j])]
        where = f"joint {joint_labels[j]!r}"
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


def _check_finite(
    model: mujoco.MjModel, names: Sequence[str], bodies: Sequence[str], geoms: Sequence[str]
) -> None:
    """Refuse non-finite or implausibly large values of the compiled model."""
    sites = display_names(model, mujoco.mjtObj.mjOBJ_SITE)
    # Values no arm can have: MuJoCo compiles some of them (an infinite pos, a NaN axis, a
    # negative armature, range="1 -1") and both engines would then compute nonsense.
    fields = {
        "body": (bodies, ("body_pos", "body_quat", "body_ipos", "body_mass", "body_inertia")),
        "joint": (names, ("jnt_pos", "jnt_axis", "jnt_range", "dof_armature", "dof_damping")),
        "geom": (geoms, ("geom_pos", "geom_size")),
        "site": (sites, ("site_pos",)),
    }
    arrays = {
        f: (getattr(model, f), labels, kind) for kind, (labels, fs) in fields.items() for f in fs
    }
    for field, (values, labels, kind) in arrays.items():
        if len(values) == 0:  # a model without geoms or sites
            continue
        bad = ~np.isfinite(np.asarray(values, dtype=float).reshape(len(values), -1)).all(axis=1)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise ModelError(
                f"non-finite value in the compiled model: {field} of {kind} "
                f"{labels[i]!r} is {np.asarray(values[i]).tolist()}"
            )
        big = (
            np.abs(np.asarray(values, dtype=float)).reshape(len(values), -1) > MAX_MAGNITUDE
        ).any(axis=1)
        if field != "jnt_range" and big.any():  # an unlimited range is legitimately large
            i = int(np.flatnonzero(big)[0])
            # A base joint locked by a huge damping (Fetch's slides) is held with base=.
            hold = (
                "; a joint the arm should not move is held by starting the arm below it "
                "(base=BODY, --base BODY)"
                if kind == "joint"
                else ""
            )
            raise ModelError(
                f"implausible value in the compiled model: {field} of {kind} {labels[i]!r} is "
                f"{np.asarray(values[i]).tolist()}; the library handles magnitudes up to "
                f"{MAX_MAGNITUDE:g} (SI units): beyond, the engines' products overflow{hold}"
            )
    if not np.isfinite(model.opt.gravity).all():
        raise ModelError(
            f"non-finite value in the compiled model: gravity {model.opt.gravity.tolist()}"
        )


def _check_joint_values(model: mujoco.MjModel, names: Sequence[str]) -> None:
    """Refuse negative armature or damping and inverted joint ranges."""
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


def _check_structure(model: mujoco.MjModel, bodies: Sequence[str], geoms: Sequence[str]) -> None:
    """Refuse what Pinocchio's parser cannot represent.

    Several kinematic trees, tendons, equality constraints, sdf and
    height-field geoms.
    """
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
    for g in range(model.ngeom):
        if int(model.geom_type[g]) in _UNREADABLE_GEOMS:
            raise UnsupportedFeatureError(
                "sdf or height-field geom",
                f"geom {geoms[g]!r}",
                "Pinocchio's MJCF parser cannot read it; use primitive or mesh geoms",
            )


def check_robot_values(model: mujoco.MjModel) -> None:
    """Refuse values of the whole robot's joints that Pinocchio's parser cannot take.

    Run on the whole robot (held joints included: Pinocchio reads every joint of the file).

    Raises:
        ModelError: A negative ``frictionloss``, naming the joint and the attribute.
    """
    names = display_names(model, mujoco.mjtObj.mjOBJ_JOINT)
    for j in range(model.njnt):
        value = float(model.dof_frictionloss[model.jnt_dofadr[j]])
        if value < 0:
            raise ModelError(
                f"joint {names[j]!r} has negative frictionloss {value:g} [N m or N]; "
                "it must be >= 0 (a friction force opposes motion)"
            )


def _tag(el: ET.Element, *attrs: str) -> str:
    shown = [f"name={el.get('name')!r}"] if el.get("name") else []
    shown += [f"{a}={el.get(a)!r}" for a in attrs if el.get(a) is not None]
    return f"<{' '.join([el.tag, *shown])}>"


def _check_xml_values(root: ET.Element) -> None:
    """Refuse MJCF spellings no engine should be given, strict or not.

    A root element other than ``<mujoco>``, NaN or infinite numbers, shell inertia
    (Pinocchio raises), several ``<worldbody>`` elements.
    """
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
                    f"non-finite number in the model: {_tag(el)} {attr}={value!r}; "
                    "every number must be finite"
                )
        if el.get("shellinertia", "false") == "true":
            raise UnsupportedFeatureError(
                "shell inertia",
                _tag(el, "shellinertia"),
                "Pinocchio's MJCF parser cannot compute it; "
                "use a solid geom or an explicit <inertial>",
            )
    tags = [child.tag for child in root]
    if tags.count("worldbody") > 1:
        raise UnsupportedFeatureError(
            "several <worldbody> elements",
            f"{tags.count('worldbody')} in the model",
            "Pinocchio's MJCF parser reads the first one again for each of them; "
            "merge them into one",
        )


def check_names(model: mujoco.MjModel, tool_site: str | None = None) -> None:
    """Refuse names Pinocchio cannot take, before Pinocchio reads the model.

    A joint named ``universe`` aborts Pinocchio's parser. Bodies, joints and sites may share
    names (common in simulation suites: a site named after its body): Pinocchio makes one
    frame of each type, and the library looks every frame up with its type (the tool site as
    an ``OP_FRAME``, bodies as ``BODY``).

    Args:
        model: MuJoCo's compiled model.
        tool_site: Unused; kept for the callers' signature.

    Raises:
        UnsupportedFeatureError: A reserved joint name.
    """
    joints = _names(model, mujoco.mjtObj.mjOBJ_JOINT)
    for n in joints:
        if n in RESERVED_JOINT_NAMES:
            raise UnsupportedFeatureError(
                f"joint named {n!r}",
                f"joint {n!r}",
                f"Pinocchio reserves the name {n!r} for its world joint (its parser aborts on "
                "it); rename the joint",
            )


class _Defaults:
    """MuJoCo's default classes: an element's attribute as MuJoCo resolves it."""

    def __init__(self, root: ET.Element) -> None:
        self.elements: dict[str, dict[str, dict[str, str]]] = {}
        self.parent: dict[str, str | None] = {}
        for top in root.findall("default"):
            self._add(top, None)

    def _add(self, el: ET.Element, parent: str | None) -> None:
        name = el.get("class", "main")
        self.parent.setdefault(name, parent)
        tags = self.elements.setdefault(name, {})
        for child in el:
            if child.tag == "default":
                self._add(child, name)
            else:
                tags.setdefault(child.tag, {}).update(child.attrib)

    def lookup(self, cls: str, tag: str, attr: str) -> tuple[str, str] | None:
        """(value, class it was found in) for ``attr`` of ``tag`` in ``cls`` or its parents."""
        seen: set[str] = set()
        current: str | None = cls
        while current is not None and current not in seen:
            seen.add(current)
            value = self.elements.get(current, {}).get(tag, {}).get(attr)
            if value is not None:
                return value, current
            current = self.parent.get(current)
        return None


def inertia_causes(root: ET.Element, model: mujoco.MjModel) -> dict[int, tuple[str, ...]]:
    """Bodies whose inertia Pinocchio's parser derives from what it reads differently.

    Pinocchio's MJCF parser (4.1, ``mjcf-graph.cpp``) takes a body's ``<inertial>`` when it
    has one (and ``inertiafromgeom`` is not ``true``); otherwise it sums the body's geoms,
    and there it differs from MuJoCo: a mesh geom gets a placeholder inertia (1 kg, unit
    inertia); a geom's mass is read from the geom element only, not from its default class;
    visual geoms (``contype = conaffinity = 0``) are left out although MuJoCo counts their
    mass; ``inertiagrouprange`` is ignored. An ``<inertial>`` without ``diaginertia`` or
    ``fullinertia`` has no rotational inertia in MuJoCo and the identity in Pinocchio.
    ``settotalmass``, ``boundmass`` and
    ``boundinertia`` change MuJoCo's masses beyond what Pinocchio applies. Each such body is
    returned with the causes found (possibly none: the body's inertia still comes from its
    geoms), for `redundancy.model.bridges.bridge` to copy MuJoCo's compiled inertia
    where Pinocchio's differs.

    Args:
        root: The parsed MJCF.
        model: MuJoCo's compiled model of the same text.

    Returns:
        MuJoCo body id -> causes, for every body whose inertia may be read differently.
        Empty when the XML's bodies cannot be matched one to one with the compiled model's.
    """
    from_geoms_always, group_range, global_causes = _inertia_compiler(root)
    defaults = _Defaults(root)
    found = _xml_bodies(root)
    if len(found) != model.nbody - 1:
        return {}
    out: dict[int, tuple[str, ...]] = {}
    bodies = display_names(model, mujoco.mjtObj.mjOBJ_BODY)
    geoms = display_names(model, mujoco.mjtObj.mjOBJ_GEOM)
    for b, (el, active) in enumerate(found, start=1):
        inertial = el.find("inertial")
        from_geoms = from_geoms_always or inertial is None
        no_inertia = (
            not from_geoms
            and inertial is not None
            and inertial.get("diaginertia") is None
            and inertial.get("fullinertia") is None
        )
        if not from_geoms and not global_causes and el.get("name") and not no_inertia:
            continue
        causes = list(global_causes) + _body_causes(el, bodies[b], no_inertia)
        elements = el.findall("geom")
        if from_geoms and len(elements) == model.body_geomnum[b]:
            for k, geom in enumerate(elements):
                g = int(model.body_geomadr[b]) + k
                causes += _geom_causes(
                    model,
                    g,
                    geoms[g],
                    geom,
                    geom.get("class", active or "main"),
                    defaults,
                    group_range,
                )
        out[b] = tuple(causes)
    return out


def _inertia_compiler(root: ET.Element) -> tuple[bool, list[int], tuple[str, ...]]:
    """The ``<compiler>`` settings the inertias depend on.

    Returns:
        Whether every inertia comes from geoms (``inertiafromgeom="true"``), the
        ``inertiagrouprange``, and the causes that apply to every body (mass settings
        Pinocchio's parser does not apply).
    """
    compiler: dict[str, str] = {}
    for el in root.iter("compiler"):
        compiler.update(el.attrib)
    from_geoms_always = compiler.get("inertiafromgeom", "auto") == "true"
    try:
        group_range = [int(x) for x in compiler.get("inertiagrouprange", "0 5").split()[:2]]
    except ValueError:  # MuJoCo refuses such a value before this is reached
        group_range = [0, 5]
    if len(group_range) != 2:
        group_range = [0, 5]
    global_causes = tuple(
        f"<compiler {a}={compiler[a]!r}> (Pinocchio's parser does not apply it as MuJoCo does)"
        for a in _MASS_OPTIONS
        if a in compiler
    )
    return from_geoms_always, group_range, global_causes


def _xml_bodies(root: ET.Element) -> list[tuple[ET.Element, str | None]]:
    """The MJCF's bodies in MuJoCo's order (depth first, through frames), each with its class."""
    found: list[tuple[ET.Element, str | None]] = []

    def walk(el: ET.Element, active: str | None) -> None:
        for child in el:
            if child.tag == "body":
                inner = child.get("childclass", active)
                found.append((child, inner))
                walk(child, inner)
            elif child.tag == "frame":
                walk(child, child.get("childclass", active))

    for world in root.findall("worldbody"):
        walk(world, None)
    return found


def _body_causes(el: ET.Element, name: str, no_inertia: bool) -> list[str]:
    """A body's own causes: an inertial without inertia, no name, geoms in a ``<frame>``."""
    causes = []
    if no_inertia:
        causes.append(
            f"<inertial> of body {name!r} without diaginertia or fullinertia "
            "(MuJoCo gives it no rotational inertia, Pinocchio's parser 1 kg m^2 on each axis)"
        )
    if not el.get("name"):
        causes.append(
            f"unnamed body {name!r} (Pinocchio's parser names it after its parent and can lose it)"
        )
    if any(f.iter("geom") for f in el.findall("frame")):
        causes.append(
            f"geoms inside <frame> in body {name!r} (Pinocchio's parser "
            "drops the contents of <frame>)"
        )
    return causes


def _geom_causes(
    model: mujoco.MjModel,
    g: int,
    name: str,
    el: ET.Element,
    cls: str,
    defaults: _Defaults,
    group_range: list[int],
) -> list[str]:
    """What Pinocchio's parser reads differently from MuJoCo in one geom of a geom-sum body."""
    visual = model.geom_contype[g] == 0 and model.geom_conaffinity[g] == 0
    counted_by_mujoco = group_range[0] <= model.geom_group[g] <= group_range[1]
    mass = el.get("mass")
    from_class = defaults.lookup(cls, "geom", "mass") if mass is None else None
    if from_class is not None:
        mass = from_class[0]
    density = el.get("density") or (defaults.lookup(cls, "geom", "density") or ("1000",))[0]
    try:
        has_mass = float(mass) != 0 if mass is not None else float(density) != 0
    except ValueError:  # MuJoCo has refused such a value already
        has_mass = True
    causes = []
    if not visual and not counted_by_mujoco:
        causes.append(
            f"geom {name!r} in group {model.geom_group[g]} outside inertiagrouprange "
            "(Pinocchio's parser counts it)"
        )
    if visual:
        if has_mass and counted_by_mujoco:
            causes.append(
                f"visual geom {name!r} has mass in MuJoCo (Pinocchio's parser leaves "
                "contype=conaffinity=0 geoms out of the inertia)"
            )
        return causes
    if int(model.geom_type[g]) == int(mujoco.mjtGeom.mjGEOM_MESH):
        causes.append(
            f"mesh geom {name!r} (Pinocchio's parser gives a mesh a placeholder inertia: "
            "1 kg, unit inertia)"
        )
    if from_class is not None:
        causes.append(
            f"geom {name!r} takes mass={from_class[0]} from default class {from_class[1]!r} "
            "(Pinocchio's parser reads a geom's mass from the geom element only)"
        )
    return causes

"""A URDF's link tree, checked: what the engines would read differently is refused first.

`check_urdf` returns the tree (`UrdfTree`) that the rest of the URDF path works on:
`redundancy.model.urdf` (MuJoCo's compiler), `redundancy.model.urdf_inertia` (the mended
inertials) and the loader, which finds the tool link (`resolve_frame`) and the arm's joints
(`chain_joints`) in it.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import numpy as np

from ..errors import ModelError, UnknownNameError, UnsupportedFeatureError

_XACRO_NS = "{http://www.ros.org/wiki/xacro}"
_JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
# MuJoCo compiler settings (the URDF's <mujoco><compiler> extension) that change masses or
# inertias in MuJoCo only: Pinocchio reads the inertials as written.
_MASS_SETTINGS = ("boundmass", "boundinertia", "settotalmass", "balanceinertia")
# Numeric attributes of URDF elements (tag -> attribute -> count of numbers), checked before
# either parser sees them: urdfdom prints its own complaint on stderr before Pinocchio raises.
_NUMBERS = {
    "origin": {"xyz": 3, "rpy": 3},
    "axis": {"xyz": 3},
    "limit": {"lower": 1, "upper": 1, "effort": 1, "velocity": 1},
    "dynamics": {"damping": 1, "friction": 1},
    "mass": {"value": 1},
    "inertia": {k: 1 for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")},
    "box": {"size": 3},
    "cylinder": {"radius": 1, "length": 1},
    "sphere": {"radius": 1},
    "capsule": {"radius": 1, "length": 1},
    "mesh": {"scale": 3},
}


@dataclass
class UrdfTree:
    """The link tree of a URDF, as written.

    Attributes:
        name: The robot's name.
        links: Link names, in file order.
        joints: Joint name -> (type, parent link, child link), in file order.
        root: The root link (the one that is no joint's child).
        groups: Link -> the links welded to it by fixed joints (itself included).
    """

    name: str
    links: list[str]
    joints: dict[str, tuple[str, str, str]]
    root: str
    groups: dict[str, frozenset[str]] = field(default_factory=dict)

    @property
    def moving_joints(self) -> list[str]:
        """Joints that are not fixed, in file order."""
        return [n for n, (t, _, _) in self.joints.items() if t != "fixed"]


def is_urdf(root: ET.Element) -> bool:
    """True when the parsed XML is a URDF (root element ``<robot>``)."""
    return root.tag == "robot" or root.tag.endswith("}robot")


def check_urdf(root: ET.Element, source: str) -> UrdfTree:
    """Refuse what the engines would read differently, and return the link tree.

    Args:
        root: The parsed URDF.
        source: File name or ``"<string>"``, for messages.

    Raises:
        UnsupportedFeatureError: xacro macros, floating or planar joints,
            MuJoCo compiler settings that change masses.
        ModelError: Not a valid URDF (missing names, unknown link, several roots).
    """
    _check_xacro(root, source)
    _check_numbers(root, source)
    if root.tag != "robot":
        raise UnsupportedFeatureError(
            f"<{root.tag}> root element", source, "a URDF's root element is <robot>"
        )
    links = _links(root, source)
    joints = _joints(root, links, source)
    for kind, names in (("joint", list(joints)), ("link", links)):
        if "universe" in names:
            raise UnsupportedFeatureError(
                f"{kind} named 'universe'",
                f"{kind} 'universe' in {source}",
                "Pinocchio reserves the name for its world joint and frame; rename it",
            )
    tree = UrdfTree(root.get("name", ""), links, joints, _tree_root(links, joints, source))
    if not tree.moving_joints:
        raise UnsupportedFeatureError(
            "no joints", source, "an arm needs at least one revolute, continuous or prismatic joint"
        )
    tree.groups = _weld_groups(tree)
    _check_inertials(root, tree, source)
    _check_mujoco_extension(root, source)
    return tree


def _links(root: ET.Element, source: str) -> list[str]:
    """The link names, in file order: each named, at least one, none repeated."""
    links = [el.get("name", "") for el in root.findall("link")]
    if "" in links:
        raise ModelError(f"URDF {source}: a <link> has no name")
    if not links:
        raise ModelError(f"URDF {source}: no <link> elements")
    repeated = sorted({n for n in links if links.count(n) > 1})
    if repeated:  # before the engines' parsers, which say it in their own words (and C++'s)
        raise ModelError(f"URDF {source}: link names must be unique; repeated: {repeated}")
    return links


def _joints(root: ET.Element, links: list[str], source: str) -> dict[str, tuple[str, str, str]]:
    """Joint name -> (type, parent link, child link), in file order, each joint checked."""
    joints: dict[str, tuple[str, str, str]] = {}
    for el in root.findall("joint"):
        name, kind = el.get("name", ""), el.get("type", "")
        parent, child = el.find("parent"), el.find("child")
        if not name or parent is None or child is None:
            raise ModelError(f"URDF {source}: joint {name!r} needs a name, <parent> and <child>")
        if name in joints:
            raise ModelError(f"URDF {source}: joint names must be unique; repeated: {name!r}")
        if kind not in _JOINT_TYPES:
            raise ModelError(
                f"URDF {source}: joint {name!r} has type {kind!r}; "
                f"valid URDF joint types: {list(_JOINT_TYPES)}"
            )
        # A <mimic> becomes an equality constraint in MuJoCo (none on a fixed joint) and is
        # ignored by Pinocchio's parser: it is set aside when it couples held joints and
        # refused when it reaches an arm joint (redundancy.model.robot).
        for link in (parent.get("link", ""), child.get("link", "")):
            if link not in links:
                raise UnknownNameError("link", link, links)
        joints[name] = (kind, parent.get("link", ""), child.get("link", ""))
    return joints


def _tree_root(links: list[str], joints: dict[str, tuple[str, str, str]], source: str) -> str:
    """The root link of the one tree the links must form (one root, no loop)."""
    children = {c for _, _, c in joints.values()}
    roots = [n for n in links if n not in children]
    if len(roots) != 1:
        raise ModelError(
            f"URDF {source}: the links must form one tree with one root; roots found: {roots}"
        )
    parents_of: dict[str, list[str]] = {}
    for name, (_, _, c) in joints.items():
        parents_of.setdefault(c, []).append(name)
    for link, named in parents_of.items():
        if len(named) > 1:
            raise ModelError(
                f"URDF {source}: the links must form one tree; link {link!r} is the child of "
                f"several joints {named} (a loop)"
            )
    below: dict[str, list[str]] = {}
    for _, p, c in joints.values():
        below.setdefault(p, []).append(c)
    reached, todo = {roots[0]}, [roots[0]]
    while todo:
        for c in below.get(todo.pop(), []):
            if c not in reached:
                reached.add(c)
                todo.append(c)
    if len(reached) != len(links):
        cut = [n for n in links if n not in reached]
        raise ModelError(
            f"URDF {source}: the links must form one tree; {cut} are not reached from the "
            f"root {roots[0]!r} (a loop)"
        )
    return roots[0]


def _check_xacro(root: ET.Element, source: str) -> None:
    for el in root.iter():
        macro = el.tag.startswith(_XACRO_NS)
        substitution = any("${" in v or "$(" in v for v in el.attrib.values())
        if macro or substitution:
            shown = el.tag.replace(_XACRO_NS, "xacro:")
            raise UnsupportedFeatureError(
                "xacro macros",
                f"<{shown}> in {source}",
                f"this is a xacro file, not URDF; expand it first ({_expand_command(source)}) "
                "and load the result",
            )


def _expand_command(source: str) -> str:
    """The xacro command that expands the user's file (``source``: its path, or a label)."""
    name = os.path.basename(source) if source.endswith((".xacro", ".urdf")) else ""
    if not name:
        return "`xacro model.urdf.xacro > model.urdf`"
    if name.endswith(".xacro"):
        return f"`xacro {name} > {name.removesuffix('.xacro')}`"
    return f"`xacro {name} > {name.removesuffix('.urdf')}_expanded.urdf`"


def _check_numbers(root: ET.Element, source: str) -> None:
    for el in root.iter():
        for attr, count in _NUMBERS.get(el.tag, {}).items():
            value = el.get(attr)
            if value is None:
                continue
            try:
                numbers = [float(x) for x in value.split()]
            except ValueError:
                numbers = []
            if len(numbers) != count or not all(np.isfinite(numbers)):
                what = "a finite number" if count == 1 else f"{count} finite numbers"
                raise ModelError(f"URDF {source}: <{el.tag} {attr}={value!r}> must be {what}")
    for joint in root.findall("joint"):
        for el in joint.findall("dynamics"):
            friction = float(el.get("friction", "0"))
            if friction < 0:  # Pinocchio's parser fails on it in words of its own
                raise ModelError(
                    f"URDF {source}: joint {joint.get('name', '')!r} has negative <dynamics "
                    f"friction={el.get('friction')!r}>; it must be >= 0 (a friction force "
                    "opposes motion)"
                )


def _weld_groups(tree: UrdfTree) -> dict[str, frozenset[str]]:
    parent_of: dict[str, str] = {}
    for kind, parent, child in tree.joints.values():
        if kind == "fixed":
            parent_of[child] = parent

    def top(link: str) -> str:
        while link in parent_of:
            link = parent_of[link]
        return link

    members: dict[str, set[str]] = {}
    for link in tree.links:
        members.setdefault(top(link), set()).add(link)
    return {link: frozenset(members[top(link)]) for link in tree.links}


def _check_inertials(root: ET.Element, tree: UrdfTree, source: str) -> None:
    """Every mass must be a number >= 0 (a moving link without one: `prepare_urdf`)."""
    mass: dict[str, float] = {}
    for el in root.findall("link"):
        inertial = el.find("inertial")
        m = inertial.find("mass") if inertial is not None else None
        try:
            mass[el.get("name", "")] = float(m.get("value", "0")) if m is not None else 0.0
        except ValueError as err:
            raise ModelError(f"URDF {source}: link {el.get('name')!r} mass: {err}") from err
    for link, value in mass.items():
        if not value >= 0:  # negative or NaN
            raise ModelError(
                f"URDF {source}: link {link!r} has mass {value:g} [kg]; a mass must be >= 0"
            )


def _check_mujoco_extension(root: ET.Element, source: str) -> None:
    for compiler in root.iterfind("mujoco/compiler"):
        if compiler.get("inertiafromgeom") == "true":
            raise UnsupportedFeatureError(
                "MuJoCo compiler inertiafromgeom",
                f"<mujoco><compiler inertiafromgeom='true'> in {source}",
                "MuJoCo would replace the inertials by its geoms' (Pinocchio reads the inertials)",
            )


def mass_settings(root: ET.Element) -> list[str]:
    """The URDF's MuJoCo extension options that change the masses MuJoCo compiles.

    ``boundmass``, ``boundinertia``, ``settotalmass``, ``balanceinertia`` in
    ``<mujoco><compiler>``: MuJoCo applies them to the inertials as written, Pinocchio's
    parser does not; the loader gives Pinocchio MuJoCo's compiled masses, each a bridge.
    """
    return [
        f"<mujoco><compiler {attr}={compiler.get(attr)!r}> (MuJoCo applies it to the inertials)"
        for compiler in root.iterfind("mujoco/compiler")
        for attr in _MASS_SETTINGS
        if compiler.get(attr) is not None
    ]


def chain_joints(tree: UrdfTree, link: str, base: str | None = None) -> list[str]:
    """Moving joints on the path from the root (or from ``base``) down to ``link``, in order."""
    child_of = {c: (n, kind, p) for n, (kind, p, c) in tree.joints.items()}
    out = []
    while link in child_of and link != base:
        name, kind, parent = child_of[link]
        if kind != "fixed":
            out.append(name)
        link = parent
    return out[::-1]


def below_planar_base(tree: UrdfTree, link: str) -> str | None:
    """The link a planar root joint (a mobile base) moves, where the arm starts by default.

    A robot's planar base is held where the file puts it, as a floating one is: None when the
    first moving joint from the root to ``link`` is not planar, or is the only one (no arm is
    left above it: `check_chain` refuses it, naming it).
    """
    chain = chain_joints(tree, link)
    if len(chain) > 1 and tree.joints[chain[0]][0] == "planar":
        return tree.joints[chain[0]][2]
    return None


def check_chain(tree: UrdfTree, chain: list[str], source: str) -> None:
    """Refuse a planar joint on the arm's chain (a floating one is held, as an MJCF free joint).

    A robot's floating or planar base is held at its zero (the base where the file puts it);
    a planar one (`below_planar_base`) when the arm starts below it, which is the default.
    MuJoCo reads a planar joint as three joints (``_TX``, ``_TY``, ``_RZ``), Pinocchio as one,
    so below another moving joint of the chain it has no arm coordinates both engines share.

    Raises:
        UnsupportedFeatureError: A planar joint on the chain (the message names the link to
            start the arm below).
    """
    for name in chain:
        kind, _, child = tree.joints[name]
        if kind == "planar":
            raise UnsupportedFeatureError(
                "planar joint on the arm's chain",
                f"joint {name!r} in {source}",
                "the arm is a chain of revolute and prismatic joints; a planar base is "
                f"held where the file puts it when the arm starts below it (base={child!r})",
            )


def resolve_frame(tree: UrdfTree, frame: str) -> str:
    """The link that carries the tool frame: ``frame`` names a link or a fixed joint.

    A name that is both a link and a joint is the link (URDF keeps the two apart; the tool
    is then the link's frame, Pinocchio's BODY frame, whatever the joint's placement).

    Raises:
        UnknownNameError: Neither a link nor a fixed joint (the message lists the links).
    """
    if frame in tree.links and frame != "world":
        return frame
    if frame in tree.joints and tree.joints[frame][0] == "fixed":
        return tree.joints[frame][2]  # a fixed joint's frame is its child link's frame
    raise UnknownNameError("link", frame, [n for n in tree.links if n != "world"])

"""URDF in both engines: Pinocchio's URDF parser and MuJoCo's URDF compiler.

Measured with MuJoCo 4.0 and Pinocchio 4.1 (``tests/test_urdf.py`` holds each case), the two
importers read the same numbers for link inertials, joint origins, axes, ranges, effort limits
(MuJoCo: ``actuatorfrcrange``), damping and friction (MuJoCo: ``frictionloss``). Where they
part, this module decides:

* **fixed links**: MuJoCo fuses them into their parent by default (a tool link then becomes a
  ``<frame>`` and its name is gone); the library compiles with ``fusestatic`` off, so every
  link stays a body and a tool link can carry the tool site (masses are unchanged: welded
  bodies move as one).
* **continuous joints**: Pinocchio makes them unbounded revolutes with two coordinates
  (cos, sin); the library rebuilds them as one-coordinate revolutes without limits, as
  MuJoCo's hinge (poses are sampled in [-pi, pi]).
* **mesh paths**: MuJoCo opens ``package://`` and ``file://`` names as plain paths and fails;
  the library resolves them (the URDF's directory and its parents, ``ROS_PACKAGE_PATH``) and
  gives MuJoCo absolute paths; an unresolved path is the library's error, naming it.
  Visual geoms are discarded (MuJoCo's default for URDF); Pinocchio's model reads no geometry.
* **missing inertials**: MuJoCo infers the mass of a link without ``<inertial>`` from its
  collision geoms (``inertiafromgeom`` auto), Pinocchio gives it none (URDF's meaning). The
  library compiles with ``inertiafromgeom`` false, so both read a missing inertial as no
  mass. A link the arm moves left with no mass at all (with the links fixed to it; the
  ROS-Industrial arms give none) gets a placeholder inertia so that MuJoCo compiles it, and
  the arm serves kinematics only: every dynamic quantity refuses, naming the links
  (`MissingInertiaError`). Off the arm, such a joint is held fixed.
* **mimic joints**: MuJoCo adds an equality constraint, Pinocchio ignores the mimic: set aside
  when the mimic couples held joints (a gripper's fingers), refused when it reaches an arm joint
  (`redundancy.model.robot`); a mimic on a fixed joint is nothing.
* **floating and planar joints**: refused (a fixed-base arm of hinges and slides).
* **armature**: URDF cannot express it; both engines read 0.
* **velocity limits**: Pinocchio reads them, MuJoCo drops them; the library uses neither.
* **self-collision**: URDF has no filter. MuJoCo's parent filter already skips a link and its
  parent, except where the parent is welded to the world; the library excludes every pair of links
  joined by a joint (with the links welded to each), the base included, plus the pairs of an SRDF's
  ``<disable_collisions>`` or a list given to [`redundancy.load`][redundancy.load].
"""

from __future__ import annotations

import copy
import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from ..engines.mujoco import captured_warnings
from ..errors import ModelError, UnknownNameError, UnsupportedFeatureError
from .content import feed_assets, record
from .robot import SetAside

#: What a moving link without mass gets so that MuJoCo compiles it; its dynamics are refused.
_PLACEHOLDER_INERTIAL = (
    '<inertial><origin xyz="0 0 0"/><mass value="1"/>'
    '<inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial>'
)
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

DisabledPairs = str | os.PathLike[str] | Iterable[Sequence[str]]


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
    links = [el.get("name", "") for el in root.findall("link")]
    if "" in links:
        raise ModelError(f"URDF {source}: a <link> has no name")
    if not links:
        raise ModelError(f"URDF {source}: no <link> elements")
    repeated = sorted({n for n in links if links.count(n) > 1})
    if repeated:  # before the engines' parsers, which say it in their own words (and C++'s)
        raise ModelError(f"URDF {source}: link names must be unique; repeated: {repeated}")
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
        where = f"joint {name!r} in {source}"
        if kind in ("floating", "planar"):
            raise UnsupportedFeatureError(
                f"{kind} joint",
                where,
                "only revolute, continuous, prismatic and fixed joints are supported "
                "(a fixed-base arm)",
            )
        # A <mimic> becomes an equality constraint in MuJoCo (none on a fixed joint) and is
        # ignored by Pinocchio's parser: it is set aside when it couples held joints and
        # refused when it reaches an arm joint (redundancy.model.robot).
        for link in (parent.get("link", ""), child.get("link", "")):
            if link not in links:
                raise UnknownNameError("link", link, links)
        joints[name] = (kind, parent.get("link", ""), child.get("link", ""))
    for kind, names in (("joint", list(joints)), ("link", links)):
        if "universe" in names:
            raise UnsupportedFeatureError(
                f"{kind} named 'universe'",
                f"{kind} 'universe' in {source}",
                "Pinocchio reserves the name for its world joint and frame; rename it",
            )
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
    tree = UrdfTree(root.get("name", ""), links, joints, roots[0])
    if not tree.moving_joints:
        raise UnsupportedFeatureError(
            "no joints", source, "an arm needs at least one revolute, continuous or prismatic joint"
        )
    tree.groups = _weld_groups(tree)
    _check_inertials(root, tree, source)
    _check_mujoco_extension(root, source)
    return tree


def _check_xacro(root: ET.Element, source: str) -> None:
    for el in root.iter():
        macro = el.tag.startswith(_XACRO_NS)
        substitution = any("${" in v or "$(" in v for v in el.attrib.values())
        if macro or substitution:
            shown = el.tag.replace(_XACRO_NS, "xacro:")
            raise UnsupportedFeatureError(
                "xacro macros",
                f"<{shown}> in {source}",
                "this is a xacro file, not URDF; expand it first "
                "(`xacro robot.urdf.xacro > robot.urdf`) and load the result",
            )


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
        for attr in _MASS_SETTINGS:
            if compiler.get(attr) is not None:
                raise UnsupportedFeatureError(
                    f"MuJoCo compiler {attr}",
                    f"<mujoco><compiler {attr}={compiler.get(attr)!r}> in {source}",
                    "it changes MuJoCo's masses only (Pinocchio reads the inertials as written)",
                )
        if compiler.get("inertiafromgeom") == "true":
            raise UnsupportedFeatureError(
                "MuJoCo compiler inertiafromgeom",
                f"<mujoco><compiler inertiafromgeom='true'> in {source}",
                "MuJoCo would replace the inertials by its geoms' (Pinocchio reads the inertials)",
            )


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


def _link_masses(root: ET.Element) -> dict[str, float]:
    out = {}
    for el in root.findall("link"):
        m = el.find("inertial/mass")
        out[el.get("name", "")] = float(m.get("value", "0")) if m is not None else 0.0
    return out


def _inertia_state(m: Sequence[Sequence[float]]) -> str:
    """``"valid"``, ``"degenerate"`` or ``"invalid"``: a link inertia as MuJoCo will judge it.

    MuJoCo wants positive principal moments with A + B >= C. A point mass (all moments 0) or
    a rod (one moment 0), up to rounding, is physics MuJoCo merely cannot take:
    ``"degenerate"``. A moment below zero or A + B < C beyond rounding is a defect:
    ``"invalid"``.
    """
    eig = np.linalg.eigvalsh(np.asarray(m, dtype=float))
    a, b, c = eig  # ascending
    noise = 1e-9 * abs(c) + 1e-15  # rounding, and MuJoCo's mjMINVAL
    if a < -noise or a + b < c - noise:
        return "invalid"
    if a <= 0 or a + b < c:
        return "degenerate"
    return "valid"


def prepare_urdf(
    root: ET.Element, tree: UrdfTree, tool_link: str, base: str | None, source: str
) -> tuple[ET.Element, list[SetAside], list[str], list[str]]:
    """The URDF as both engines read it, with what they would refuse mended off the arm.

    * A joint off the arm's chain that moves links without mass (MuJoCo refuses a moving
      body without mass; it is held anyway) becomes fixed at 0, the URDF's reference. On the
      chain, its link gets a placeholder inertial (1 kg, 1e-3 kg m^2) and is returned as
      missing: the arm serves kinematics and refuses dynamics
      (`MissingInertiaError`).
    * A published inertia MuJoCo rejects: a point mass or a rod (moments 0 up to rounding)
      gets a tiny isotropic moment added; an invalid one (a moment below 0, A + B < C) is
      replaced by MuJoCo's ``balanceinertia`` rule (all three moments their mean, about the
      same centre of mass). Both in the text both engines read; an invalid one on a body
      the arm moves is also a defect of the file, returned for the audit.

    Returns:
        The (possibly) mended URDF, what was set aside, the defects on the arm's bodies, and
        the links the arm moves that have no mass (their dynamics are refused).
    """
    chain = chain_joints(tree, tool_link, base)
    moved: set[str] = set()  # links an arm joint moves
    children: dict[str, list[str]] = {}
    for _, parent, child in tree.joints.values():
        children.setdefault(parent, []).append(child)
    stack = [tree.joints[j][2] for j in chain]
    while stack:
        link = stack.pop()
        if link not in moved:
            moved.add(link)
            stack += children.get(link, [])
    mass = _link_masses(root)
    out = copy.deepcopy(root)
    notes: list[SetAside] = []
    defects: list[str] = []
    missing: list[str] = []
    joints = {el.get("name", ""): el for el in out.findall("joint")}
    for joint in tree.moving_joints:
        child = tree.joints[joint][2]
        if sum(mass[link] for link in tree.groups[child]) > 0:
            continue
        if joint in chain:
            # Kinematics needs no mass, but MuJoCo refuses a moving body without one: a
            # placeholder in the text both engines read, and every dynamic quantity refused.
            link = next(el for el in out.findall("link") if el.get("name") == child)
            link.append(ET.fromstring(_PLACEHOLDER_INERTIAL))
            missing.append(child)
            continue
        el = joints[joint]
        el.set("type", "fixed")
        for sub in [*el.findall("mimic"), *el.findall("limit")]:
            el.remove(sub)
        notes.append(
            SetAside("joint", joint, f"moves link {child!r}, which has no mass: held as fixed at 0")
        )
    for link in out.findall("link"):
        inertia = link.find("inertial/inertia")
        if inertia is None or mass.get(link.get("name", ""), 0.0) <= 0:
            continue
        v = {k: float(inertia.get(k, "0")) for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")}
        m = [
            [v["ixx"], v["ixy"], v["ixz"]],
            [v["ixy"], v["iyy"], v["iyz"]],
            [v["ixz"], v["iyz"], v["izz"]],
        ]
        state = _inertia_state(m)
        if state == "valid":
            continue
        name = link.get("name", "")
        eig = np.linalg.eigvalsh(np.asarray(m))
        if state == "degenerate":
            # A point mass or a rod: MuJoCo needs positive moments; a tiny isotropic one is
            # added (it keeps A + B >= C), in the text both engines read.
            eps = max(1e-12, 1e-9 * float(np.trace(np.asarray(m))))
            for k in ("ixx", "iyy", "izz"):
                inertia.set(k, repr(v[k] + eps))
            notes.append(
                SetAside(
                    "degenerate inertia",
                    name,
                    f"principal moments {eig[0]:.3g}, {eig[1]:.3g}, {eig[2]:.3g} [kg m^2] "
                    f"(a point mass or a rod): {eps:.3g} added about each axis for MuJoCo",
                    reaches_arm=name in moved,
                )
            )
            continue
        mean = float(max(np.trace(np.asarray(m)) / 3.0, 1e-12))
        for k in ("ixx", "iyy", "izz"):
            inertia.set(k, repr(mean))
        for k in ("ixy", "ixz", "iyz"):
            inertia.set(k, "0")
        violated = (
            f"principal moment {eig.min():.3g} < 0"
            if eig.min() < 0 and eig[0] + eig[1] >= eig[2]
            else f"A + B < C ({eig[0]:.3g} + {eig[1]:.3g} < {eig[2]:.3g})"
        )
        what = f"{violated} [kg m^2]; replaced by {mean:.3g} about each axis (balanceinertia)"
        if name in moved:
            defects.append(f"link {name!r}: published inertia invalid, {what}")
            notes.append(
                SetAside("invalid inertia", name, f"the arm moves it: {what}", reaches_arm=True)
            )
        else:
            notes.append(SetAside("invalid inertia", name, f"the arm does not move it: {what}"))
    if missing:
        notes.append(
            SetAside(
                "links without inertial",
                ", ".join(missing),
                "moved by the arm with no mass in the file: kinematic quantities are served, "
                "dynamic ones (mass matrix, gravity, effective mass) refuse; a placeholder "
                "inertia keeps MuJoCo compiling",
            )
        )
    return out, notes, defects, missing


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


def _package_dirs(base: Path) -> list[Path]:
    dirs = [base, *base.parents]
    for entry in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep):
        if entry:
            dirs.append(Path(entry))
    return dirs


def resolve_mesh(filename: str, base: Path, source: str) -> Path:
    """Absolute path of a URDF mesh file name.

    ``package://pkg/rest`` is looked up as ``pkg/rest`` in the URDF's directory, each of its
    parents and each ``ROS_PACKAGE_PATH`` entry (and as ``rest`` in a directory named ``pkg``
    among them); ``file://`` and plain relative names are taken from the URDF's directory.

    Raises:
        ModelError: No such file (the message names the mesh and where it was looked for).
    """
    tried: list[Path] = []
    if filename.startswith("package://"):
        rest = filename[len("package://") :]
        pkg, _, inner = rest.partition("/")
        for d in _package_dirs(base):
            for candidate in (d / rest, d / pkg / inner) + ((d / inner,) if d.name == pkg else ()):
                tried.append(candidate)
                if candidate.is_file():
                    return candidate.resolve()
    else:
        name = filename[len("file://") :] if filename.startswith("file://") else filename
        candidate = Path(name) if Path(name).is_absolute() else base / name
        tried.append(candidate)
        if candidate.is_file():
            return candidate.resolve()
    shown = ", ".join(str(t) for t in dict.fromkeys(tried))
    raise ModelError(f"URDF {source}: mesh file {filename!r} not found (looked for: {shown})")


def read_disabled_pairs(
    pairs: DisabledPairs | None, tree: UrdfTree
) -> tuple[list[tuple[str, str]], SetAside | None]:
    """Link pairs that must never collide: an SRDF file's ``<disable_collisions>``, or pairs.

    An SRDF may describe a whole robot of which the URDF is a part (TALOS's SRDF for its
    left arm): its pairs naming a link the URDF does not have are skipped, and said so (see
    `whole_robot_pairs`). Listed pairs are this model's own: each link must exist.

    Args:
        pairs: Path of an SRDF file, or an iterable of (link, link) pairs, or None.
        tree: The URDF's tree (link names are checked against it).

    Returns:
        The pairs, and what was skipped of an SRDF's (None: nothing).

    Raises:
        ModelError: Unreadable SRDF, or a pair that is not two names.
        UnknownNameError: A listed pair's link the URDF does not have, or an SRDF none of
            whose pairs applies to this URDF (its first unknown link).
    """
    if pairs is None:
        return [], None
    out: list[tuple[str, str]] = []
    if isinstance(pairs, str | os.PathLike):
        p = Path(pairs)
        try:
            data = p.read_bytes()
            srdf = ET.fromstring(data)
        except (OSError, ET.ParseError) as err:
            raise ModelError(f"cannot read the SRDF file {str(p)!r}: {err}") from err
        record(p, data)
        for el in srdf.iter("disable_collisions"):
            out.append((el.get("link1", ""), el.get("link2", "")))
        return whole_robot_pairs(out, tree, p.name)
    else:
        for pair in pairs:
            if isinstance(pair, str) or len(pair) != 2:
                raise ModelError(f"a disabled collision pair is two link names, got {pair!r}")
            out.append((str(pair[0]), str(pair[1])))
    for a, b in out:
        for link in (a, b):
            if link not in tree.links:
                raise UnknownNameError("link", link, tree.links)
    return out, None


def whole_robot_pairs(
    pairs: list[tuple[str, str]], tree: UrdfTree, name: str
) -> tuple[list[tuple[str, str]], SetAside | None]:
    """An SRDF's pairs that apply to this URDF, and a note on those skipped.

    A pair naming a link the URDF does not have is another part of the robot's (the SRDF of
    a whole humanoid given with one arm's URDF): skipped, counted and named in the note. When
    no pair applies at all, the file is not this robot's, or its names are misspelt: the
    first unknown link is an error listing the valid names.

    Args:
        pairs: The SRDF's (link, link) pairs, in file order.
        tree: The URDF's tree.
        name: The SRDF file's name, for the note.

    Raises:
        UnknownNameError: No pair applies and a link is unknown.
    """
    known = set(tree.links)
    kept = [(a, b) for a, b in pairs if a in known and b in known]
    missing = sorted({link for pair in pairs for link in pair if link not in known})
    if not missing:
        return kept, None
    if not kept:
        raise UnknownNameError("link", missing[0], tree.links)
    shown = ", ".join(missing[:6]) + (f" and {len(missing) - 6} more" if len(missing) > 6 else "")
    note = SetAside(
        "SRDF pairs",
        name,
        f"{len(pairs) - len(kept)} of its {len(pairs)} pairs name links this URDF does not "
        f"have ({shown}): skipped, the {len(kept)} others applied",
    )
    return kept, note


def adjacent_pairs(tree: UrdfTree) -> list[tuple[str, str]]:
    """Pairs of links joined by a moving joint, each side with the links welded to it."""
    out = []
    for joint in tree.moving_joints:
        _, parent, child = tree.joints[joint]
        out += [(a, b) for a in sorted(tree.groups[parent]) for b in sorted(tree.groups[child])]
    return out


def build_mujoco(
    text: str,
    base: Path,
    source: str,
    tree: UrdfTree,
    tool_link: str,
    site: str,
    disabled: Sequence[tuple[str, str]],
) -> tuple[mujoco.MjSpec, mujoco.MjModel, list[SetAside]]:
    """Compile a URDF with MuJoCo, keeping fixed links as bodies, with a site on the tool link.

    Collada (``.dae``) meshes, which MuJoCo has no decoder for, are read with trimesh and
    handed to MuJoCo as vertices and faces (coal then collides the same vertices); each is
    reported. Meshes whose volume MuJoCo finds too small to take an inertia from get
    ``inertia="shell"``: URDF inertials are explicit (``inertiafromgeom`` is off), so no
    mass comes from a mesh either way.

    Args:
        text: The URDF text.
        base: Directory relative mesh paths are taken from.
        source: File name or ``"<string>"``, for messages.
        tree: The URDF's tree (from `check_urdf`).
        tool_link: Link that carries the tool frame.
        site: Name of the site added at the tool link's origin.
        disabled: Extra link pairs excluded from collision.

    Returns:
        An uncompiled copy of the spec (to hold joints in), its compiled model, and the notes
        on meshes.

    Raises:
        ModelError: MuJoCo cannot compile it (the message carries MuJoCo's).
    """
    notes: list[SetAside] = []
    try:
        with captured_warnings():
            spec = mujoco.MjSpec.from_string(text)
            # URDF keeps every link: the tool link must stay a body to carry the site, and
            # welded bodies change no mass, no inertia and no contact (weld groups are filtered).
            spec.compiler.fusestatic = False
            # A link without <inertial> has no mass in URDF (and in Pinocchio); MuJoCo's
            # default would infer one from the link's collision geoms.
            spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
            for mesh in spec.meshes:
                path = resolve_mesh(mesh.file, base, source)
                if path.suffix.lower() == ".dae":
                    record(path)
                    _collada_mesh(mesh, path, source)
                    notes.append(
                        SetAside(
                            "Collada mesh",
                            path.name,
                            "read with trimesh; MuJoCo and coal get the same vertices",
                            reaches_arm=True,
                        )
                    )
                else:
                    mesh.file = str(path)
                    feed_assets(spec, [path])
            _name_geoms(spec)
            body = spec.body(tool_link)
            if body is None:
                raise ModelError(f"URDF {source}: MuJoCo has no body for link {tool_link!r}")
            body.add_site(name=site)
            bodies = {b.name for b in spec.bodies}
            for a, b in dict.fromkeys([*adjacent_pairs(tree), *disabled]):
                if a in bodies and b in bodies and a != b:  # "world" is MuJoCo's world body
                    spec.add_exclude(bodyname1=a, bodyname2=b)
            # The spec is copied before it compiles: editing a compiled spec (deleting the
            # held joints) costs 50 ms a joint, a fresh copy 2 ms.
            try:
                return spec.copy(), spec.compile(), notes
            except ValueError as err:
                if "mesh volume is too small" not in str(err):
                    raise
                # Only the mesh's own inertia fails; with inertiafromgeom off it is unused.
                for mesh in spec.meshes:
                    mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
                return spec.copy(), spec.compile(), notes
    except (ValueError, TypeError) as err:
        found = re.search(r"no decoder found for mesh file '([^']+)'", str(err))
        if found:
            # Collada (.dae) collision meshes are common in ROS packages; MuJoCo reads STL, OBJ
            # and its own MSH.
            raise ModelError(
                f"URDF {source}: MuJoCo cannot read the mesh {found.group(1)!r} (no decoder "
                f"for {Path(found.group(1)).suffix!r} files); give the collision geometry as "
                "STL or OBJ, or as primitives"
            ) from err
        raise ModelError(f"MuJoCo could not compile the URDF {source}: {err}") from err


def _collada_mesh(mesh: mujoco.MjsMesh, path: Path, source: str) -> None:
    """Give MuJoCo a Collada mesh's triangles as vertex data (MuJoCo cannot decode .dae)."""
    try:
        import trimesh
    except ImportError as err:  # pragma: no cover - trimesh comes with the lab extra
        raise ModelError(
            f"URDF {source}: the mesh {path.name!r} is Collada (.dae); reading it needs "
            "trimesh and pycollada (pip install 'redundancy[meshes]')"
        ) from err
    try:
        loaded = trimesh.load(str(path), force="mesh", process=False)
        vertices = np.asarray(loaded.vertices, dtype=float)
        faces = np.asarray(loaded.faces, dtype=int)
    except Exception as err:  # trimesh and pycollada raise many kinds of errors
        raise ModelError(
            f"URDF {source}: cannot read the Collada mesh {str(path)!r}: {err}"
        ) from err
    if len(vertices) < 4 or len(faces) == 0:
        raise ModelError(f"URDF {source}: the Collada mesh {str(path)!r} has no triangles")
    mesh.file = ""
    mesh.uservert = vertices.ravel().tolist()
    mesh.userface = faces.ravel().tolist()


def _name_geoms(spec: mujoco.MjSpec) -> None:
    """Name MuJoCo's unnamed URDF geoms after their link, so reports can say which is which.

    A link's only collision geom takes the link's name; several take the names an unnamed MJCF geom
    gets ([`redundancy.model.names`][redundancy.model.names]): ``link geom 0``, ``link geom 1``...,
    by their index in the link, counted from 0 in file order (MuJoCo's URDF import leaves them
    unnamed; names already given are kept).
    """
    taken = {g.name for g in spec.geoms if g.name}
    for body in spec.bodies:
        unnamed = [(k, g) for k, g in enumerate(body.geoms) if not g.name]
        for k, geom in unnamed:
            name = body.name if len(body.geoms) == 1 else f"{body.name} geom {k}"
            while name in taken:
                name += "'"
            geom.name = name
            taken.add(name)


def build_pinocchio(text: str, source: str) -> tuple[object, list[str]]:
    """Pinocchio's model of a URDF, continuous joints as one-coordinate unbounded revolutes.

    Returns:
        The model, and the names of the continuous joints that were rebuilt.

    Raises:
        ModelError: Pinocchio cannot read it (the message carries Pinocchio's).
    """
    import pinocchio as pin

    try:
        model = pin.buildModelFromXML(text)
    except Exception as err:  # Pinocchio raises bare RuntimeError/ValueError from C++.
        raise ModelError(f"Pinocchio could not read the URDF {source}: {err}") from err
    return _bounded_revolutes(model)


def continuous_joints(model: object) -> list[str]:
    """Names of the joints Pinocchio read as (cos, sin) pairs."""
    kinds = ("JointModelRUBX", "JointModelRUBY", "JointModelRUBZ")
    kinds += ("JointModelRevoluteUnboundedUnaligned",)
    return [
        model.names[j]  # type: ignore[attr-defined]
        for j in range(1, model.njoints)  # type: ignore[attr-defined]
        if model.joints[j].shortname() in kinds  # type: ignore[attr-defined]
    ]


_NV_FIELDS = (
    "effortLimit",
    "lowerEffortLimit",
    "upperEffortLimit",
    "velocityLimit",
    "lowerVelocityLimit",
    "damping",
    "friction",
    "lowerDryFrictionLimit",
    "upperDryFrictionLimit",
    "armature",
    "rotorInertia",
    "rotorGearRatio",
)
_NQ_FIELDS = ("lowerPositionLimit", "upperPositionLimit", "positionLimitMargin")


def _bounded_revolutes(model: object) -> tuple[object, list[str]]:
    """Rebuild a Pinocchio model with each (cos, sin) revolute as a one-angle revolute.

    Same joint placements, inertias, frames and per-dof values; the configuration of a
    continuous joint becomes its angle, without limits, as MuJoCo's unlimited hinge.
    """
    import pinocchio as pin

    assert isinstance(model, pin.Model)
    axes = {"JointModelRUBX": pin.JointModelRX, "JointModelRUBY": pin.JointModelRY}
    axes["JointModelRUBZ"] = pin.JointModelRZ
    unaligned = "JointModelRevoluteUnboundedUnaligned"
    kinds = [model.joints[j].shortname() for j in range(model.njoints)]
    rebuilt = continuous_joints(model)
    if not rebuilt:
        return model, []
    new = pin.Model()
    new.name = model.name
    jmap = {0: 0}
    for j in range(1, model.njoints):
        joint = model.joints[j]
        if kinds[j] in axes:
            joint = axes[kinds[j]]()
        elif kinds[j] == unaligned:
            # The axis is not exposed; the motion subspace S = (0, axis) at angle 0 carries it.
            data = joint.createData()
            joint.calc(data, np.array([1.0, 0.0]))
            joint = pin.JointModelRevoluteUnaligned(np.asarray(data.S).reshape(6)[3:].copy())
        parent = jmap[model.parents[j]]
        jmap[j] = new.addJoint(parent, joint, model.jointPlacements[j], model.names[j])
        new.appendBodyToJoint(jmap[j], model.inertias[j], pin.SE3.Identity())
    new.inertias[0] = model.inertias[0].copy()
    fmap = {0: 0}
    for i in range(1, model.nframes):
        f = model.frames[i]
        copy = pin.Frame(
            f.name, jmap[f.parentJoint], fmap[f.parentFrame], f.placement, f.type, f.inertia
        )
        fmap[i] = new.addFrame(copy, False)  # the inertia is already in the joint's body
    for name in _NV_FIELDS + _NQ_FIELDS:
        old, out = np.asarray(getattr(model, name)), np.asarray(getattr(new, name)).copy()
        for j in range(1, model.njoints):
            a, b = model.joints[j], new.joints[jmap[j]]
            if name not in _NQ_FIELDS:
                out[b.idx_v : b.idx_v + b.nv] = old[a.idx_v : a.idx_v + a.nv]
            elif kinds[j] in axes or kinds[j] == unaligned:
                out[b.idx_q] = {"lowerPositionLimit": -np.inf, "upperPositionLimit": np.inf}.get(
                    name, 0.0
                )
            else:
                out[b.idx_q : b.idx_q + b.nq] = old[a.idx_q : a.idx_q + a.nq]
        setattr(new, name, out)
    new.gravity = model.gravity
    return new, rebuilt

"""A URDF's masses mended so both engines read them: links without mass, rejected inertias.

`prepare_urdf` edits a copy of the parsed URDF before either engine reads it (see
`redundancy.model.urdf` for how the library reads URDF).
"""

from __future__ import annotations

import copy
import xml.etree.ElementTree as ET
from collections.abc import Sequence

import numpy as np

from .selection import SetAside
from .urdf_tree import UrdfTree, chain_joints

#: What a moving link without mass gets so that MuJoCo compiles it; its dynamics are refused.
_PLACEHOLDER_INERTIAL = (
    '<inertial><origin xyz="0 0 0"/><mass value="1"/>'
    '<inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial>'
)


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
) -> tuple[ET.Element, list[SetAside], list[str], list[str], dict[str, float]]:
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
        The (possibly) mended URDF, what was set aside, the defects on the arm's bodies, the
        links the arm moves that have no mass (their dynamics are refused), and the held
        values of mimic followers whose leader was made fixed.
    """
    chain = chain_joints(tree, tool_link, base)
    moved = _moved_links(tree, chain)
    mass = _link_masses(root)
    out = copy.deepcopy(root)
    notes: list[SetAside] = []
    defects: list[str] = []
    follows: dict[str, float] = {}
    missing = _massless_joints(out, tree, chain, mass, notes, follows)
    for link in out.findall("link"):
        name, inertia = link.get("name", ""), link.find("inertial/inertia")
        if inertia is not None and mass.get(name, 0.0) > 0:
            _mend_inertia(inertia, name, name in moved, notes, defects)
    zero = [n for n in missing if root.find(f"link[@name='{n}']/inertial") is not None]
    if zero:
        notes.append(
            SetAside(
                "links of mass 0",
                ", ".join(zero),
                "an <inertial> with mass 0 on a link the arm moves: read as no inertia "
                "(a body MuJoCo cannot move without mass)",
                reaches_arm=True,
            )
        )
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
    return out, notes, defects, missing, follows


def _moved_links(tree: UrdfTree, chain: list[str]) -> set[str]:
    """Links an arm joint moves: the children of the chain's joints and everything below."""
    moved: set[str] = set()
    children: dict[str, list[str]] = {}
    for _, parent, child in tree.joints.values():
        children.setdefault(parent, []).append(child)
    stack = [tree.joints[j][2] for j in chain]
    while stack:
        link = stack.pop()
        if link not in moved:
            moved.add(link)
            stack += children.get(link, [])
    return moved


def _massless_joints(
    out: ET.Element,
    tree: UrdfTree,
    chain: list[str],
    mass: dict[str, float],
    notes: list[SetAside],
    follows: dict[str, float],
) -> list[str]:
    """Mend the joints that move no mass in ``out``; return the arm's links left without any.

    Off the chain, such a joint becomes fixed (noted in ``notes``) and its mimic followers
    are held at their rule's value (``follows``); on it, its link gets the placeholder
    inertial in place of an ``<inertial>`` of mass 0.
    """
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
            for empty in link.findall("inertial"):  # mass 0: replaced, never a second one
                link.remove(empty)
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
        _hold_followers(out, joint, notes, follows)
    return missing


def _hold_followers(
    out: ET.Element, leader: str, notes: list[SetAside], follows: dict[str, float]
) -> None:
    """Followers of a joint made fixed at 0 take the value their mimic gives: the offset.

    The ``<mimic>`` (which would name a joint that no longer moves) is removed and the
    follower's held value, ``multiplier x 0 + offset``, put in ``follows``.
    """
    for el in out.findall("joint"):
        mimic = el.find("mimic")
        if mimic is None or mimic.get("joint") != leader:
            continue
        offset = float(mimic.get("offset", "0"))
        el.remove(mimic)
        follows[el.get("name", "")] = offset
        notes.append(
            SetAside(
                "mimic",
                el.get("name", ""),
                f"follows {leader!r}, held fixed at 0 (no mass): held at its rule's value, "
                f"offset {offset:g} + multiplier x 0",
            )
        )


def _mend_inertia(
    inertia: ET.Element, name: str, moved: bool, notes: list[SetAside], defects: list[str]
) -> None:
    """Mend link ``name``'s published ``<inertia>`` in place when MuJoCo would reject it.

    A degenerate one gets a tiny isotropic moment, an invalid one MuJoCo's ``balanceinertia``
    rule; each is noted in ``notes`` and, when invalid on a link the arm moves (``moved``),
    in ``defects``.
    """
    v = {k: float(inertia.get(k, "0")) for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")}
    m = [
        [v["ixx"], v["ixy"], v["ixz"]],
        [v["ixy"], v["iyy"], v["iyz"]],
        [v["ixz"], v["iyz"], v["izz"]],
    ]
    state = _inertia_state(m)
    if state == "valid":
        return
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
                reaches_arm=moved,
            )
        )
        return
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
    if moved:
        defects.append(f"link {name!r}: published inertia invalid, {what}")
        notes.append(
            SetAside("invalid inertia", name, f"the arm moves it: {what}", reaches_arm=True)
        )
    else:
        notes.append(SetAside("invalid inertia", name, f"the arm does not move it: {what}"))

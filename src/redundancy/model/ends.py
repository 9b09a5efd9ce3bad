"""The ends of a model's kinematic chains, read from the file: the tool frame by default.

A *chain end* is a leaf of the kinematic tree (a URDF link that is no joint's parent, an MJCF body
with no child body) with at least one moving joint between it and the root: a link welded to the
base is no end of the arm. A model with one chain end needs no tool frame:
[`default_tool_frame`][redundancy.model.ends.default_tool_frame] gives it (the leaf link of a URDF;
the one site of the leaf body of an MJCF, else the body). The file is only parsed (no engine
compiles it), so the command line can choose the frame before loading.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path

from ..errors import ModelError
from .xmlfile import decode_xml, expanded, parse_xml

__all__ = ["chain_ends", "default_tool_frame", "ends_of", "frame_for", "single_chain_end"]

#: URDF joint types that move.
_MOVING = {"revolute", "continuous", "prismatic", "floating", "planar"}


def _root(path: str | os.PathLike[str]) -> ET.Element:
    p = Path(path)
    try:
        data = p.read_bytes()
    except FileNotFoundError as err:
        raise ModelError(f"model file not found: {str(p)!r}") from err
    except OSError as err:
        raise ModelError(f"cannot read the model file {str(p)!r}: {err.strerror}") from err
    text, _ = decode_xml(data, str(p))
    return parse_xml(text)


def chain_ends(path: str | os.PathLike[str]) -> tuple[str, ...]:
    """Names of the chain ends of an MJCF or URDF file, in file order.

    For an MJCF, each end is named by the one site its leaf body holds, else by the body.

    Raises:
        ModelError: The file is missing, not XML, or neither MJCF nor URDF.
    """
    root = _root(path)
    if root.tag not in ("robot", "mujoco"):
        raise ModelError(
            f"{str(path)!r} is neither MJCF (<mujoco>) nor URDF (<robot>): <{root.tag}>"
        )
    return ends_of(root)


def ends_of(root: ET.Element) -> tuple[str, ...]:
    """The chain ends of a parsed MJCF (``<mujoco>``) or URDF (``<robot>``) root element."""
    return _urdf_ends(root) if root.tag == "robot" else _mjcf_ends(root)


#: The tool frame a model with several chain ends defaults to when it has a frame so named
#: (the bundled models' tool sites).
CONVENTIONAL_FRAME = "ee"


def frame_for(root: ET.Element, source: str) -> str:
    """The tool frame of a model loaded without one: its one chain end, else ``"ee"``.

    A model with several chain ends (a gripper's fingers, two arms) and a site, body, link
    or joint named ``"ee"`` takes that frame (the bundled models' convention).

    Args:
        root: The parsed file (``<mujoco>`` or ``<robot>``).
        source: The file's name as the user gave it, for the message.

    Raises:
        ModelError: No chain end, or several and no frame named ``"ee"`` (the message lists
            the ends).
    """
    ends = ends_of(root)
    if len(ends) == 1:
        return ends[0]
    tags = ("site", "body") if root.tag == "mujoco" else ("link", "joint")
    if any(el.get("name") == CONVENTIONAL_FRAME for tag in tags for el in root.iter(tag)):
        return CONVENTIONAL_FRAME
    if not ends:
        raise ModelError(f"{source!r} has no moving chain: no tool frame to default to")
    raise ModelError(
        f"{source!r} has {len(ends)} chain ends: {', '.join(repr(e) for e in ends)}; name "
        "the tool frame (--frame NAME on the command line, frame=NAME in Python)"
    )


def single_chain_end(path: str | os.PathLike[str]) -> str | None:
    """The model's chain end when it has exactly one, else None (see `chain_ends`)."""
    ends = chain_ends(path)
    return ends[0] if len(ends) == 1 else None


def default_tool_frame(path: str | os.PathLike[str]) -> str:
    """The tool frame of a file loaded without one, as `redundancy.load` takes it.

    See [`frame_for`][redundancy.model.ends.frame_for]; an MJCF's ``<include>`` files are read too.

    Raises:
        ModelError: The file is missing or not XML; no chain end, or several and no frame
            named ``"ee"`` (the message lists them).
    """
    whole, _ = expanded(_root(path), Path(os.path.abspath(path)).parent)
    return frame_for(whole, str(path))


def _urdf_ends(root: ET.Element) -> tuple[str, ...]:
    links = [link.get("name", "") for link in root.findall("link")]
    parent_of: dict[str, tuple[str, bool]] = {}  # child link -> (parent link, joint moves)
    for joint in root.findall("joint"):
        parent, child = joint.find("parent"), joint.find("child")
        if parent is None or child is None:
            continue
        moving = joint.get("type", "") in _MOVING
        parent_of[child.get("link", "")] = (parent.get("link", ""), moving)
    parents = {p for p, _ in parent_of.values()}
    ends = []
    for link in links:
        if link in parents:
            continue
        node, seen, moves = link, set(), False
        while node in parent_of and node not in seen:  # a cycle is the loader's to refuse
            seen.add(node)
            node, moving = parent_of[node]
            moves |= moving
        if moves:
            ends.append(link)
    return tuple(ends)


def _children(element: ET.Element) -> list[ET.Element]:
    """The bodies directly under ``element`` (through ``<frame>`` elements)."""
    out = []
    for child in element:
        if child.tag == "body":
            out.append(child)
        elif child.tag == "frame":
            out += _children(child)
    return out


def _own(element: ET.Element, tag: str) -> list[ET.Element]:
    """``tag`` elements of a body itself (through ``<frame>``), not of its child bodies."""
    out = []
    for child in element:
        if child.tag == tag:
            out.append(child)
        elif child.tag == "frame":
            out += _own(child, tag)
    return out


def _mjcf_ends(root: ET.Element) -> tuple[str, ...]:
    ends: list[str] = []

    def walk(body: ET.Element, moves: bool) -> None:
        moves = moves or bool(_own(body, "joint") or _own(body, "freejoint"))
        kids = _children(body)
        if not kids and moves:
            sites = [s.get("name") for s in _own(body, "site")]
            name = sites[0] if len(sites) == 1 and sites[0] else body.get("name")
            ends.append(name or "(unnamed body)")
        for kid in kids:
            walk(kid, moves)

    for world in root.findall("worldbody"):
        for body in _children(world):
            walk(body, False)
    return tuple(ends)

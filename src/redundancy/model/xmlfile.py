"""Reading a model file as XML: its encoding, and the MJCF as Pinocchio's parser must be given it.

Below both `redundancy.model.loading` (which loads the arm) and `redundancy.model.ends` (which finds
the tool frame before loading), so neither needs the other to read a file.
"""

from __future__ import annotations

import codecs
import copy
import os
import re
import xml.etree.ElementTree as ET
from pathlib import Path

from ..errors import ModelError
from .content import record
from .robot import SetAside

__all__ = [
    "decode_xml",
    "expand_includes",
    "expanded",
    "include_path",
    "parse_xml",
    "strip_declaration",
]


def parse_xml(text: str) -> ET.Element:
    """The root element of XML text, or a ModelError saying it is not well-formed.

    A namespace prefix the file uses without declaring it (``<drake:joint_damping>`` in a
    URDF) is tolerated as both engines' parsers tolerate it: it is declared for this parse,
    and the library, like the engines, reads no element or attribute of that namespace.
    """
    try:
        return ET.fromstring(text)
    except ET.ParseError as err:
        if "unbound prefix" in str(err):
            declared = _declared(text)
            if declared is not text:
                return parse_xml(declared)
        raise ModelError(f"not well-formed XML: {err}") from err


_PREFIXED = re.compile(r"</?\s*([A-Za-z_][\w.-]*):[A-Za-z_]|\s([A-Za-z_][\w.-]*):[\w.-]+\s*=")
_ROOT_TAG = re.compile(r"<(?![?!])\s*[A-Za-z_][\w.:-]*")


def _declared(text: str) -> str:
    """The text with its undeclared namespace prefixes declared on the root element."""
    used = {a or b for a, b in _PREFIXED.findall(text)} - {"xml", "xmlns"}
    known = set(re.findall(r"xmlns:([A-Za-z_][\w.-]*)\s*=", text))
    missing = sorted(used - known)
    root = _ROOT_TAG.search(text)
    if not missing or root is None:
        return text
    names = "".join(f' xmlns:{p}="urn:redundancy:undeclared:{p}"' for p in missing)
    return text[: root.end()] + names + text[root.end() :]


_BOMS = (
    (codecs.BOM_UTF32_LE, "utf-32"),
    (codecs.BOM_UTF32_BE, "utf-32"),
    (codecs.BOM_UTF8, "utf-8-sig"),
    (codecs.BOM_UTF16_LE, "utf-16"),
    (codecs.BOM_UTF16_BE, "utf-16"),
)
_DECLARED = re.compile(rb"""^\s*<\?xml[^>]*?encoding\s*=\s*["']([A-Za-z0-9._-]+)["']""")


def strip_declaration(text: str) -> str:
    """The text without its XML declaration (an encoding it names no longer applies)."""
    return re.sub(r"^\s*<\?xml[^>]*\?>", "", text, count=1)


def decode_xml(data: bytes, source: str) -> tuple[str, bool]:
    """Decode a model file's bytes as XML does: byte-order mark, else the declared encoding.

    MuJoCo reads UTF-8 only (a UTF-16 file fails to parse, a Latin-1 file's names reach it
    as invalid UTF-8) and Pinocchio's parsers likewise, so a file in another encoding is
    handed to both as the decoded text.

    Args:
        data: The file's bytes.
        source: File name, for messages.

    Returns:
        The text without its XML declaration, and whether the bytes were UTF-8 without a
        byte-order mark (the engines may then read the file itself).

    Raises:
        ModelError: An unknown encoding, or bytes that are not in the declared one.
    """
    encoding = next((enc for bom, enc in _BOMS if data.startswith(bom)), None)
    if encoding is None and data[:2] in (b"<\x00", b"\x00<"):
        encoding = "utf-16-le" if data[:1] == b"<" else "utf-16-be"  # UTF-16 without a BOM
    if encoding is None:
        declared = _DECLARED.match(data)
        encoding = declared.group(1).decode("ascii") if declared else "utf-8"
    try:
        text = data.decode(encoding)
    except LookupError as err:
        raise ModelError(f"{source}: unknown encoding {encoding!r} in the XML declaration") from err
    except UnicodeDecodeError as err:
        raise ModelError(f"{source}: not valid {encoding} text: {err}") from err
    as_is = codecs.lookup(encoding).name == "utf-8"
    return strip_declaration(text), as_is


def expanded(root: ET.Element, folder: Path) -> tuple[ET.Element, list[SetAside]]:
    """An MJCF as Pinocchio's parser must be given it, with what was done to it.

    ``<include>`` files (counted from ``folder``) are expanded in place and several
    ``<worldbody>`` sections merged into the first; a URDF (or an MJCF with neither) comes
    back as it is. The list says what was done, for ``arm.set_aside``.
    """
    if root.tag != "mujoco":
        return root, []
    edits: list[SetAside] = []
    return _merge_worldbodies(expand_includes(root, folder, edits), edits), edits


def include_path(name: str, main: Path, here: Path) -> Path:
    """The file an ``<include file=name>`` reads, found as MuJoCo finds it.

    MuJoCo looks in the model file's directory (``main``) first, then beside the file that
    holds the ``<include>`` (``here``); backslashes separate folders as slashes do. The first
    place is returned when the file is in neither (the error then names it).
    """
    name = name.replace("\\", "/")
    places = [Path(os.path.normpath(d / name)) for d in dict.fromkeys((main, here))]
    return next((p for p in places if p.is_file()), places[0])


def expand_includes(
    root: ET.Element, main: Path, edits: list[SetAside], here: Path | None = None, depth: int = 0
) -> ET.Element:
    """The MJCF with each ``<include file=...>`` replaced by the included file's elements.

    MuJoCo follows includes itself; Pinocchio's parser does not, so Pinocchio (and the
    library's checks of the text) read this expanded copy, and so does MuJoCo when it is
    handed text (a file in another encoding than UTF-8, a pipe), which would otherwise look
    for the includes in the current directory. Each file is found as MuJoCo finds it
    (`include_path`), decoded as XML says (any encoding) and recorded.
    """
    if root.find(".//include") is None:
        return root
    if depth > 20:
        raise ModelError("<include> nested more than 20 deep (a loop?)")
    root = copy.deepcopy(root)
    for parent in list(root.iter()):
        for i, child in enumerate(list(parent)):
            if child.tag != "include":
                continue
            name = child.get("file", "")
            path = include_path(name, main, here or main)
            try:
                data = path.read_bytes()
            except OSError as err:
                raise ModelError(f"cannot read the included file {name!r}: {err}") from err
            inner = parse_xml(decode_xml(data, str(path))[0])
            record(path, data)
            inner = expand_includes(inner, main, edits, path.parent, depth + 1)
            parent.remove(child)
            for k, el in enumerate(list(inner)):
                parent.insert(i + k, el)
            edits.append(
                SetAside("include", name, "expanded in place for Pinocchio's parser", True)
            )
    return root


def _merge_worldbodies(root: ET.Element, edits: list[SetAside]) -> ET.Element:
    """The MJCF with its ``<worldbody>`` sections merged into the first, in order.

    MuJoCo reads several sections as one world, in the order they come (a Menagerie
    ``scene.xml`` adds its floor and lights to the robot file it includes); Pinocchio's
    parser would read the first section again for each. The merged copy is the same world
    with the same body order, so the same body ids.
    """
    worlds = root.findall("worldbody")
    if len(worlds) < 2:
        return root
    root = copy.deepcopy(root)
    first, *later = root.findall("worldbody")
    for world in later:
        for el in list(world):
            world.remove(el)
            first.append(el)
        root.remove(world)
    edits.append(
        SetAside(
            "worldbody",
            f"{len(worlds)} <worldbody> sections",
            "merged into one for Pinocchio's parser, in order (MuJoCo reads them as one)",
            reaches_arm=True,
        )
    )
    return root

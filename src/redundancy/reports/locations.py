"""Where an element is in the arm's file: the XML line of a link, body, joint or keyframe.

ElementTree forgets lines; `element_lines` reads the file with `xml.parsers.expat`, which
reports the line of each start tag, so that a finding can name the file and line of the
element it concerns (what SARIF, JUnit and GitHub annotations point at).
"""

from __future__ import annotations

import xml.parsers.expat
from pathlib import Path

#: The tags that name the elements findings concern, by what they are: a URDF link or an
#: MJCF body (``link``), a joint, an MJCF keyframe (``key``).
_KINDS = {"link": "link", "body": "link", "joint": "joint", "key": "key"}


def element_lines(text: str | bytes) -> dict[tuple[str, str], int]:
    """The line of each named link, body, joint and keyframe in one XML document.

    Args:
        text: The document.

    Returns:
        ``(kind, name) -> line`` (1-based), kind ``link`` (a URDF link, an MJCF body),
        ``joint`` or ``key``; the first element of a name wins. Empty when the text is not
        well-formed XML (a finding then names no line).
    """
    lines: dict[tuple[str, str], int] = {}
    parser = xml.parsers.expat.ParserCreate()

    def start(tag: str, attrs: dict[str, str]) -> None:
        kind = _KINDS.get(tag.rsplit(":", 1)[-1])
        name = attrs.get("name")
        if kind is not None and name is not None:
            lines.setdefault((kind, name), parser.CurrentLineNumber)

    parser.StartElementHandler = start
    try:
        parser.Parse(text, True)
    except xml.parsers.expat.ExpatError:
        return {}
    return lines


def root_line(text: str | bytes) -> int | None:
    """The line of the document's root element (1-based), or None when it is not XML.

    Where a finding names no element (the engines' agreement, the timestep), the formats that
    need a line (SARIF's region, an annotation) point at the model's root element.
    """
    found: list[int] = []
    parser = xml.parsers.expat.ParserCreate()

    def start(tag: str, attrs: dict[str, str]) -> None:
        if not found:
            found.append(parser.CurrentLineNumber)

    parser.StartElementHandler = start
    try:
        parser.Parse(text, True)
    except xml.parsers.expat.ExpatError:
        pass  # a line once found stands; an error before any start tag: no line
    return found[0] if found else None


def read_source(source: str) -> bytes | None:
    """The bytes of an arm's source file, or None (``"<string>"``, a pipe read once, gone)."""
    path = Path(source)
    try:
        return path.read_bytes() if path.is_file() else None
    except OSError:
        return None


class Locations:
    """The lines of the elements of an arm's source file.

    Args:
        source: The arm's file, as the findings name it.
        data: Its bytes (`read_source`; None: no lines).
    """

    def __init__(self, source: str, data: bytes | None) -> None:
        self.file = source
        self._lines = element_lines(data) if data is not None else {}

    def line(self, kind: str, name: str) -> int | None:
        """The line of element ``name`` of ``kind`` (``link``, ``joint``, ``key``), if known."""
        return self._lines.get((kind, name))

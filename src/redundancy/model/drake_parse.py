"""Drake's parser on the user's file: what it reads, and where it must be told more.

`parse` hands Drake the arm's file by its path (its includes and meshes beside it), or, for an
MJCF without the model name Drake's parser requires, a named copy as text whose relative
files are made absolute. A refusal, or an inertia Drake's parser replaced with one of its own,
is `DrakeAbsent` (`redundancy.model.drake_loading`).
"""

from __future__ import annotations

import contextlib
import logging
import re
import xml.etree.ElementTree as ET
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any


class DrakeAbsent(Exception):
    """Drake cannot take part; the message is the reason (``arm.absent_engines["drake"]``)."""


@contextlib.contextmanager
def _drake_log() -> Iterator[list[str]]:
    """Drake's log messages while parsing, kept instead of printed (the parser's warnings)."""
    messages: list[str] = []

    class Keep(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            messages.append(record.getMessage())

    logger = logging.getLogger("drake")
    handler, propagate = Keep(), logger.propagate
    logger.addHandler(handler)
    logger.propagate = False
    try:
        yield messages
    finally:
        logger.removeHandler(handler)
        logger.propagate = propagate


class DrakeSource:
    """What Drake's parser reads: a file, or text.

    Args:
        path: The user's file (None: ``text``).
        text: The model text (MJCF or URDF), when there is no file to read or the library
            mended a URDF's defects.
        urdf: ``text`` is URDF.
    """

    def __init__(self, path: Path | None = None, text: str | None = None, urdf: bool = False):
        self.path, self.text, self.urdf = path, text, urdf


def _named_mjcf(text: str, name: str) -> tuple[str, bool]:
    """MJCF text with a model name, which Drake's MJCF parser requires; True when it added one.

    Only the root element's opening tag changes (``<mujoco`` gains ``model="name"``): a name
    for Drake's model instance, no physical value (not a bridge).
    """
    try:
        root = ET.fromstring(text.encode("utf-8"))
    except ET.ParseError:
        return text, False  # Drake's parser says what is wrong with it
    if root.get("model"):
        return text, False
    return re.sub(r"<mujoco\b", f'<mujoco model="{name}"', text, count=1), True


#: Attributes of MJCF elements that name a file or folder relative to the model's file.
_RELATIVE = re.compile(
    r"(<(?:include|model)\b[^>]*?\bfile\s*=\s*|<compiler\b[^>]*?\b(?:meshdir|texturedir|assetdir)"
    r"\s*=\s*)([\"'])(.*?)\2",
    re.DOTALL,
)


def _anchored(text: str, folder: Path) -> str:
    """MJCF text whose relative include files and asset folders are made absolute.

    Drake reads text from a string relative to the working directory; MuJoCo reads the file's
    includes and assets relative to its folder. Every ``<include file>``, ``<model file>`` and
    ``<compiler meshdir|texturedir|assetdir>`` becomes ``folder / value``; without a mesh or
    asset folder, one is added on the root's line (``<compiler meshdir="folder">``, the
    default MuJoCo applies), so no line moves (Drake's warnings cite lines).
    """

    def absolute(m: re.Match[str]) -> str:
        value = m.group(3)
        if not value or Path(value).is_absolute():
            return m.group(0)
        return f"{m.group(1)}{m.group(2)}{(folder / value).as_posix()}{m.group(2)}"

    out = _RELATIVE.sub(absolute, text)
    if not re.search(r"<compiler\b[^>]*?\b(?:meshdir|assetdir)\s*=", out, re.DOTALL):
        where = folder.as_posix()
        out = re.sub(
            r"(<mujoco\b[^>]*?(?<!/)>)",
            lambda m: f'{m.group(1)}<compiler meshdir="{where}" texturedir="{where}"/>',
            out,
            count=1,
        )
    return out


def parse(plant: Any, source: DrakeSource) -> list[str]:
    """Drake's parser on the source: its warnings; a refusal is `DrakeAbsent`."""
    from pydrake.multibody.parsing import Parser

    with _drake_log() as log:
        try:
            parser = Parser(plant)
            if source.urdf:
                if source.path is not None:
                    parser.AddModels(str(source.path))
                else:
                    parser.AddModelsFromString(source.text or "", "urdf")
            else:
                text = source.text
                if source.path is not None:
                    text = source.path.read_text(encoding="utf-8", errors="replace")
                stem = "model" if source.path is None else source.path.stem
                named, changed = _named_mjcf(text or "", stem or "model")
                if source.path is not None and not changed:
                    parser.AddModels(str(source.path))  # its includes beside it
                elif source.path is not None:  # text has no folder: say where its files are
                    parser.AddModelsFromString(_anchored(named, source.path.parent), "xml")
                else:
                    parser.AddModelsFromString(named, "xml")
        # pydrake raises the parser's errors as RuntimeError, and a failed internal check (a
        # massless body's inertia: "condition 'mass > 0' failed") as SystemExit.
        except (RuntimeError, SystemExit) as err:
            text = " ".join(str(err).split()) or type(err).__name__
            raise DrakeAbsent(f"Drake's parser refuses the file: {text}") from err
    _refuse_replaced_inertia(log, source)
    return log


#: Drake's parser's warning when it cannot make a body's inertia of the file's values (a mass
#: of 0 with a rotational inertia: Drake keeps a unit inertia scaled by the mass) and puts
#: another in its place (measured, drake 1.51: 1 kg about the body origin).
_REPLACED_INERTIA = re.compile(r":(\d+): warning: While re-expressing as central inertia")


def _refuse_replaced_inertia(log: Sequence[str], source: DrakeSource) -> None:
    """`DrakeAbsent` when Drake's parser put an inertia of its own in place of the file's.

    Its model would then not be the file's (the cross-check would name Drake on M and
    gravity); the element is found by the warning's line number in the text Drake read.
    """
    for message in log:
        found = _REPLACED_INERTIA.search(message)
        if found is None:
            continue
        text = source.text or ""
        if source.path is not None:
            text = source.path.read_text(encoding="utf-8", errors="replace")
        before = "\n".join(text.splitlines()[: int(found[1])])
        names = re.findall(r"<(?:link|body)\b[^>]*?\bname\s*=\s*[\"']([^\"']*)", before)
        where = f"link {names[-1]!r}" if names else f"the element at line {found[1]}"
        raise DrakeAbsent(
            f"Drake's parser replaces the inertia of {where} by one of its own (it cannot "
            "hold the file's, e.g. a mass of 0 with a rotational inertia); Drake's dynamics "
            "would not be the file's"
        )

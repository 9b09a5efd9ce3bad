"""``redundancy audit --fix``: a copy of the model that excludes the pairs in contact everywhere.

The audit's self-collision sweep names the pairs in contact at (nearly) every pose
(`redundancy.reports.sections.touching_everywhere`, the ``pair-always-touching`` note): almost
always two links whose collision shapes overlap where a joint joins them, an exclusion the file
lacks. The fix writes what the note says to add, and nothing else:

* MJCF: the model file's bytes as they were, with one ``<contact>`` section inserted before the
  closing ``</mujoco>``: an ``<exclude body1=... body2=...>`` per pair, each after an XML
  comment saying why (MJCF allows several ``<contact>`` sections);
* URDF: the URDF's bytes unchanged, and an SRDF beside the copy (its name, suffix ``.srdf``)
  with a ``<disable_collisions ... reason="Always"/>`` per pair, each after a comment; the
  SRDF the audit was given is copied with the elements inserted before its ``</robot>``. The
  command line applies an SRDF of the URDF's name beside it
  ([`srdf_beside`][redundancy.reports.folders.srdf_beside]), so the copy is audited with it.

A pair MJCF cannot exclude is left, with the reason: a ``<contact><pair>`` (an explicit pair
bypasses exclusions) or a body without a name. The files are written together and atomically
(`redundancy.reports.files.write_together`), after the copy is loaded from its temporary file
beside the target: it must load as the model did (the same meshes found: a copy in another
folder loses the files the model names by relative path) and test none of the excluded pairs.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any
from xml.sax.saxutils import quoteattr

import mujoco

from ..arm import Arm
from ..collision import checker
from ..display import plural
from ..engines.mujoco import object_names
from ..errors import ModelError, RedundancyError
from ..model.loading import load
from .audit_report import AuditReport
from .files import OutputPathError, check_target, input_named, read_by, write_together
from .tables import fit


class FixError(RedundancyError):
    """The fixed copy cannot be made or would not be the model (the message says why)."""


@dataclass(frozen=True)
class Exclusion:
    """A pair the fix excludes, and the sweep that found it in contact everywhere.

    Attributes:
        body1: One body (MJCF) or link (URDF), the first by name.
        body2: The other.
        poses: Poses of the sweep in which the pair is in contact.
        n_poses: Poses swept.
        seed: The sweep's seed.
    """

    body1: str
    body2: str
    poses: int
    n_poses: int
    seed: int | None

    def why(self) -> list[str]:
        """The comment beside the element, on two lines: what the audit saw."""
        seed = "" if self.seed is None else f" (seed {self.seed})"
        return [
            f"{self.body1} / {self.body2}: in contact in {self.poses} of {self.n_poses} random "
            f"poses{seed} of redundancy's audit,",
            "two links whose collision shapes overlap at (nearly) every pose: excluded by its fix",
        ]


@dataclass(frozen=True)
class Fix:
    """What a fix wrote.

    Attributes:
        model: The model file fixed.
        out: The fixed copy.
        srdf: URDF: the SRDF written beside the copy; None for MJCF.
        excluded: The pairs excluded.
        left: (pair, why) of each pair in contact everywhere that could not be excluded.
    """

    model: str
    out: str
    srdf: str | None
    excluded: tuple[Exclusion, ...]
    left: tuple[tuple[str, str], ...] = ()

    def lines(self) -> list[str]:
        """The fix as report lines."""
        beside = f" and {self.srdf}" if self.srdf else ""
        what = (
            "excludes " + ", ".join(f"{e.body1} / {e.body2}" for e in self.excluded)
            if self.excluded
            else "a copy: no pair is in contact at every pose"
        )
        out = [f"fix of {self.model}: wrote {self.out}{beside}: {what}"]
        out += [f"  not excluded: {pair}: {why}" for pair, why in self.left]
        return fit(out)

    def to_dict(self) -> dict[str, Any]:
        """The fix as plain data."""
        return {**asdict(self), "left": [{"pair": p, "reason": w} for p, w in self.left]}


def exclusions(report: AuditReport, arm: Arm) -> tuple[list[Exclusion], list[tuple[str, str]]]:
    """The pairs a fix excludes, and those it cannot (with the reason).

    Args:
        report: The model's audit.
        arm: The model, as audited.
    """
    t, c = report.sections.touching, report.sections.contacts
    if t is None or c is None:
        return [], []
    urdf = arm.model_format == "URDF"
    named = set(object_names(arm.robot_model, mujoco.mjtObj.mjOBJ_BODY)) - {""}
    out: list[Exclusion] = []
    left: list[tuple[str, str]] = []
    for p in t.pairs:
        a, b = sorted((p.pair.body1, p.pair.body2))
        if p.pair.explicit and not urdf:
            left.append((p.pair.label, "a <contact><pair> of the file, which no exclude removes"))
            continue
        unnamed = [x for x in (a, b) if x not in named]
        if unnamed and not urdf:
            left.append((p.pair.label, f"body {unnamed[0]!r} has no name in the file to exclude"))
            continue
        out.append(Exclusion(a, b, p.poses, t.n_poses, c.seed))
    return out, left


def fix_targets(arm: Arm, out: str | os.PathLike[str]) -> list[Path]:
    """The files a fix writes: the copy, and for a URDF the SRDF beside it."""
    p = Path(out)
    return [p, p.with_suffix(".srdf")] if arm.model_format == "URDF" else [p]


def check_fix_targets(arm: Arm, out: str | os.PathLike[str]) -> None:
    """Refuse, before any work, a target that breaks the files rules or is a file the model read.

    Raises:
        OutputPathError: A target is a directory, a device..., in a missing directory, or
            the model, the SRDF or another file its load read (by any name).
    """
    targets = fix_targets(arm, out)
    if len(targets) > 1 and targets[0] == targets[1]:
        raise OutputPathError(f"{str(out)!r} ends in .srdf: the URDF's copy needs another name")
    inputs = read_by(arm)
    for target in targets:
        check_target(target)
        what = input_named(target, inputs)
        if what is not None:
            raise OutputPathError(f"{str(target)!r} is {what}: not replaced")


def _recipe(arm: Arm) -> Any:
    _, (recipe,) = arm.__reduce__()  # an Arm travels as its recipe
    return recipe


def _read(recipe: Any, path: str) -> bytes:
    """The bytes the load read of ``path`` (the file may have changed since)."""
    for (p, _), data in zip(recipe.files, recipe.content or (), strict=False):
        if p == path:
            return bytes(data)
    return Path(path).read_bytes()


def _element(tag: str, attributes: dict[str, str]) -> str:
    """``<tag a="..."/>`` in ASCII (other characters as references, in any encoding)."""
    text = " ".join(f"{k}={quoteattr(v)}" for k, v in attributes.items())
    return f"<{tag} {text}/>".encode("ascii", "xmlcharrefreplace").decode("ascii")


def _comment(lines: list[str], indent: str) -> list[str]:
    """An XML comment of ``lines`` at ``indent`` (a comment may not hold ``--``), in ASCII."""
    safe = [x.replace("--", "- -").replace("--", "- -") for x in lines]
    text = [f"{indent}<!-- {safe[0]}", *(f"{indent}     {x}" for x in safe[1:])]
    text[-1] += " -->"
    return [x.encode("ascii", "xmlcharrefreplace").decode("ascii") for x in text]


def _insert(data: bytes, closing: str, lines: list[str], name: str) -> bytes:
    """``data`` with ``lines`` inserted before its last ``</closing>``, on lines of their own."""
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise FixError(f"{name!r} is UTF-16: the fix inserts into ASCII-compatible files only")
    at = data.rfind(f"</{closing}".encode())
    if at < 0:
        raise FixError(f"{name!r} has no closing </{closing}> to insert the fix before")
    newline = "\r\n" if b"\r\n" in data else "\n"
    start = data.rfind(b"\n", 0, at) + 1
    own_line = not data[start:at].strip()
    block = "".join(line + newline for line in lines).encode("ascii")
    if own_line:
        return data[:start] + block + data[start:]
    return data[:at] + newline.encode() + block + data[at:]


def mjcf_fixed(data: bytes, excluded: list[Exclusion], name: str = "model") -> bytes:
    """An MJCF file's bytes with a ``<contact>`` section excluding the pairs (none: as it was)."""
    if not excluded:
        return data
    lines = ["  <contact>"]
    for e in excluded:
        lines += [*_comment(e.why(), "    "), "    " + _element("exclude", _pair(e, "body"))]
    return _insert(data, "mujoco", [*lines, "  </contact>"], name)


def srdf_fixed(
    data: bytes | None,
    robot: str,
    excluded: list[Exclusion],
    name: str,
    given: list[tuple[str, str]] | None = None,
) -> bytes:
    """An SRDF's bytes with a ``<disable_collisions>`` per pair.

    Args:
        data: The SRDF the model was audited with; None: a new SRDF is written.
        robot: The robot's name (a new SRDF's ``<robot name>``).
        excluded: The pairs to add.
        name: The SRDF's name, for a message.
        given: A new SRDF's pairs given as Python pairs (``disabled_collisions=``), first.
    """
    lines: list[str] = []
    for a, b in given or ():
        lines.append("  " + _element("disable_collisions", {"link1": a, "link2": b}))
    for e in excluded:
        attributes = {**_pair(e, "link"), "reason": "Always"}
        lines += [*_comment(e.why(), "  "), "  " + _element("disable_collisions", attributes)]
    if data is not None:
        return _insert(data, "robot", lines, name) if lines else data
    head = _element("robot", {"name": robot})[:-2] + ">"
    text = ['<?xml version="1.0"?>', head, *lines, "</robot>"]
    return ("\n".join(text) + "\n").encode("ascii")


def _pair(e: Exclusion, what: str) -> dict[str, str]:
    return {f"{what}1": e.body1, f"{what}2": e.body2}


def fixed_files(arm: Arm, report: AuditReport, out: str | os.PathLike[str]) -> list[bytes]:
    """The content of each of `fix_targets`, in order."""
    recipe = _recipe(arm)
    excluded, _ = exclusions(report, arm)
    data = _read(recipe, recipe.model)
    if arm.model_format != "URDF":
        return [mjcf_fixed(data, excluded, recipe.shown)]
    pairs = recipe.options[3]
    target = str(Path(out).with_suffix(".srdf"))
    if pairs is None or not isinstance(pairs, str):  # none, or Python's (link, link) pairs
        given = [(str(x), str(y)) for x, y in pairs or ()]
        srdf = srdf_fixed(None, _robot_name(data), excluded, target, given)
    else:
        srdf = srdf_fixed(_read(recipe, pairs), "", excluded, pairs)
    return [data, srdf]


def _robot_name(urdf: bytes) -> str:
    try:
        return ET.fromstring(urdf).get("name", "robot")
    except ET.ParseError:
        return "robot"


def write_fix(arm: Arm, report: AuditReport, out: str | os.PathLike[str]) -> Fix:
    """Write the fixed copy of an audited model at ``out`` (and a URDF's SRDF beside it).

    Args:
        arm: The model, as audited.
        report: Its audit (`redundancy.reports.audit.audit`).
        out: The copy's path.

    Returns:
        What was written.

    Raises:
        OutputPathError: A target breaks `redundancy.reports.files`' rules or is a file the
            model read.
        FixError: The copy, loaded from its place, is not the model with the pairs excluded.
    """
    check_fix_targets(arm, out)
    targets = fix_targets(arm, out)
    excluded, left = exclusions(report, arm)
    contents = fixed_files(arm, report, out)

    def same_model(written: list[Path]) -> None:
        _check_copy(arm, written, excluded, str(out))

    write_together(list(zip(targets, contents, strict=True)), same_model)
    srdf = str(targets[1]) if len(targets) > 1 else None
    return Fix(str(arm.source), str(out), srdf, tuple(excluded), tuple(left))


def _check_copy(arm: Arm, written: list[Path], excluded: list[Exclusion], out: str) -> None:
    """The copy in its temporary files loads as ``arm`` did, without the excluded pairs."""
    _, strict, frame, _, base, rest = _recipe(arm).options
    options: dict[str, Any] = {"strict": strict, "base": base, "rest": rest}
    if len(written) > 1:
        options["disabled_collisions"] = str(written[1])
    try:
        copy = load(written[0], frame=frame, **options)
    except ModelError as err:
        raise FixError(
            f"the fixed copy {out!r} would not load ({err}): a copy in another folder than the "
            "model's loses the files it names by relative path"
        ) from err
    lost = {(m.link, m.file) for m in copy.missing_meshes} - {
        (m.link, m.file) for m in arm.missing_meshes
    }
    if lost:
        link, file = sorted(lost)[0]
        folder = os.path.dirname(os.path.abspath(str(arm.source)))
        meshes = plural(len(lost), "mesh", "meshes")
        raise FixError(
            f"the fixed copy {out!r} would not find {meshes} the model "
            f"reads (link {link!r}: {file!r}): write it in the model's folder {folder!r}"
        )
    tested = {tuple(sorted((p.body1, p.body2))) for p in checker(copy).pairs}
    still = [e for e in excluded if (e.body1, e.body2) in tested]
    if still:
        raise FixError(f"the fixed copy {out!r} still tests {still[0].body1} / {still[0].body2}")

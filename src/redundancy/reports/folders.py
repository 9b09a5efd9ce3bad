"""Auditing many models at once: the robot models in files and folders, and one summary.

`find_models` walks the paths a command names (folders recursively, in sorted order) and
decides by content which files are robot models: a URDF (root ``<robot>`` with a ``<link>``)
or an MJCF (root ``<mujoco>``), whatever the suffix; an ``.xml`` that is neither (a ROS
``package.xml``, a launch file, an SRDF) is skipped with the reason, as is a file of the
suffixes models come in that is not one, and an MJCF another model found ``<include>``s (it is
audited as part of that model). Other files (meshes, textures) are counted, not listed.

`FolderAudit` holds the result: the per-model
[`AuditReport`][redundancy.reports.audit_report.AuditReport]s as a list (what the report
formats take), a row per model that could not be loaded or audited with its error, the
skipped files, and the summary table (model, tool frame, findings by severity, result).
"""

from __future__ import annotations

import dataclasses
import os
import xml.parsers.expat
from collections import Counter
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from ..display import json_ready, plural, to_json
from ..errors import ModelError
from .audit_report import AuditReport
from .findings import Note
from .fix import Fix
from .rules import rule
from .tables import fit, table

#: Suffixes of the files a model comes in: one of these that is no model is named as skipped.
MODEL_SUFFIXES = (".urdf", ".xml", ".mjcf", ".srdf", ".xacro", ".sdf")
#: Exit status of a model that could not be loaded or audited (the CLI's "bad input").
FAILED = 2
#: The first bytes read to find a file's root element and whether a URDF has a link [bytes].
_SNIFF = 1 << 20


@dataclass(frozen=True)
class Found:
    """A robot model found in the paths.

    Attributes:
        path: The file, as found (under the folder named, or as named).
        format: ``"MJCF"`` or ``"URDF"``, by its root element.
        relative: Its path under the folder it was found in (its name when named itself): where
            a fix of it goes under a fix folder.
    """

    path: str
    format: str
    relative: str


@dataclass(frozen=True)
class Skipped:
    """A file of the paths that is not audited, and why.

    Attributes:
        path: The file.
        reason: Why it is no robot model (or is audited as part of another).
    """

    path: str
    reason: str


@dataclass(frozen=True)
class Failure:
    """A robot model that could not be loaded or audited.

    Attributes:
        model: The file.
        error: The error, on one line.
        exit_code: 2 for an error of the library (the model or an argument), 3 for a bug.
    """

    model: str
    error: str
    exit_code: int = FAILED


def srdf_beside(path: str | os.PathLike[str]) -> Path | None:
    """The SRDF of the same name beside a URDF (``ur5.urdf``: ``ur5.srdf``), if there is one."""
    srdf = Path(path).with_suffix(".srdf")
    return srdf if srdf != Path(path) and srdf.is_file() else None


def with_srdf_note(report: AuditReport, srdf: str | os.PathLike[str]) -> AuditReport:
    """The report with the ``srdf-beside`` note: the SRDF found beside the URDF was applied."""
    r = rule("srdf-beside")
    message = (
        f"the SRDF {str(srdf)!r} beside the URDF is applied: its <disable_collisions> pairs "
        "are never tested (--srdf names another)"
    )
    note = Note(r.kind, message, r.id, "note", str(srdf), None, None)
    return dataclasses.replace(report, notes=(*report.notes, note))


def root_element(path: str | os.PathLike[str]) -> tuple[str | None, bool, list[str]]:
    """A file's root element, whether it has a ``<link>`` child, and the files it includes.

    Read with expat as far as `_SNIFF` bytes: enough for the root of any file; a URDF's first
    link and an MJCF's includes are early in any file of that size.

    Returns:
        The root's tag (None: not XML, or unreadable), whether a ``<link>`` is among the
        root's children, and every ``<include file=...>`` (MJCF), as written.
    """
    tags: list[str] = []
    depth = 0
    link = False
    includes: list[str] = []

    def start(name: str, attributes: dict[str, str]) -> None:
        nonlocal depth, link
        if depth == 0:
            tags.append(name)
        elif depth == 1 and name == "link":
            link = True
        if name == "include" and "file" in attributes:
            includes.append(attributes["file"])
        depth += 1

    def end(name: str) -> None:
        nonlocal depth
        depth -= 1

    parser = xml.parsers.expat.ParserCreate()
    parser.StartElementHandler = start
    parser.EndElementHandler = end
    try:
        with open(path, "rb") as f:
            parser.Parse(f.read(_SNIFF), False)
    except (OSError, xml.parsers.expat.ExpatError):
        pass  # the root, if it was read before the error, stands
    return (tags[0] if tags else None), link, includes


def _kind(path: Path) -> tuple[str | None, str, list[str]]:
    """A file's model format (None: no model) and, for no model, why; its includes."""
    root, link, includes = root_element(path)
    if root == "mujoco":
        return "MJCF", "", includes
    if root == "robot" and link:
        return "URDF", "", []
    if path.suffix.lower() == ".srdf" or root == "robot":
        beside = path.with_suffix(".urdf")
        applied = f": applied to {beside.name} beside it" if beside.is_file() else ""
        return None, f"an SRDF (root <robot> without a <link>), not a robot model{applied}", []
    if root is None:
        return None, "not an XML file: no robot model", []
    hint = {"package": " (a ROS package.xml)", "launch": " (a ROS launch file)"}.get(root, "")
    return None, f"root element <{root}>{hint}: not a robot model (<mujoco> or <robot>)", []


def _files(paths: list[str]) -> list[tuple[Path, str]]:
    """Every file of the paths, a folder's in sorted order: (file, its path under the folder)."""
    out: list[tuple[Path, str]] = []
    for given in paths:
        p = Path(given)
        if not p.exists():
            raise ModelError(f"no such file or folder: {given!r}")
        if not p.is_dir():
            out.append((p, p.name))
            continue
        for folder, dirs, names in os.walk(p):
            dirs.sort()
            for name in sorted(names):
                f = Path(folder) / name
                out.append((f, str(f.relative_to(p))))
    return out


def find_models(paths: list[str]) -> tuple[list[Found], list[Skipped]]:
    """The robot models in files and folders (recursively), and the files skipped.

    Args:
        paths: Files and folders.

    Returns:
        The models, in the order found (each folder's files sorted), and the skipped files:
        one entry per file of a model's suffix (`MODEL_SUFFIXES`) that is no model, or that
        another model includes, then one line counting the other files by suffix.

    Raises:
        ModelError: A path that does not exist.
    """
    kinds = {f: _kind(f) for f, _ in _files(paths) if f.suffix.lower() in MODEL_SUFFIXES}
    included: dict[Path, Path] = {}
    for f, (fmt, _, includes) in kinds.items():
        for name in includes if fmt == "MJCF" else ():
            target = Path(os.path.abspath(f.parent / name))
            included.setdefault(target, f)
    found: list[Found] = []
    skipped: list[Skipped] = []
    others: Counter[str] = Counter()
    for f, relative in _files(paths):
        if f not in kinds:
            others[f.suffix.lower() or "(no suffix)"] += 1
            continue
        fmt, why, _ = kinds[f]
        by = included.get(Path(os.path.abspath(f)))
        if fmt is not None and by is not None:
            skipped.append(Skipped(str(f), f"included by {str(by)!r}: audited as part of it"))
        elif fmt is None:
            skipped.append(Skipped(str(f), why))
        else:
            found.append(Found(str(f), fmt, relative))
    if others:
        counts = ", ".join(f"{n} {s}" for s, n in sorted(others.items()))
        other = plural(sum(others.values()), "other file")
        skipped.append(Skipped(other, f"not models ({counts})"))
    return found, skipped


@dataclass(frozen=True)
class FolderAudit:
    """The audit of many models: a report per model, a row per failure, the skipped files.

    Attributes:
        entries: Each model's audit, or why it has none, in the order found.
        skipped: The files that are no robot model, with the reason.
        fixes: What ``--fix`` wrote per model, or why it could not (a `Failure`).
    """

    entries: tuple[AuditReport | Failure, ...]
    skipped: tuple[Skipped, ...] = ()
    fixes: tuple[Fix | Failure, ...] = ()

    @property
    def reports(self) -> list[AuditReport]:
        """The audits of the models that loaded, in the order found (what the formats take)."""
        return [e for e in self.entries if isinstance(e, AuditReport)]

    @property
    def failures(self) -> list[Failure]:
        """The models that could not be loaded or audited."""
        return [e for e in self.entries if isinstance(e, Failure)]

    @property
    def exit_code(self) -> int:
        """The worst of the models': 0 none, 1 findings, 2 a model that failed (3: a bug)."""
        fixes = [f.exit_code for f in self.fixes if isinstance(f, Failure)]
        return max([e.exit_code for e in self.entries] + fixes, default=0)

    def rows(self) -> list[dict[str, Any]]:
        """A row per model, in the order found: model, frame, counts by severity, result."""
        out: list[dict[str, Any]] = []
        for e in self.entries:
            if isinstance(e, Failure):
                out.append({"model": e.model, "failed": e.error, "exit_code": e.exit_code})
                continue
            count = Counter(x.severity for x in (*e.findings, *e.notes))
            out.append(
                {
                    "model": e.model,
                    "frame": e.frame,
                    **{f"{s}s": count[s] for s in ("error", "warning", "note")},
                    "findings": len(e.findings),
                    "exit_code": e.exit_code,
                }
            )
        return out

    def summary_lines(self) -> list[str]:
        """The summary table and the skipped files, as report lines (see `tables.table`)."""
        body = []
        for row in self.rows():
            if "failed" in row:
                body.append([row["model"], "-", "-", "-", "-", f"failed: {row['failed']}"])
                continue
            result = plural(row["findings"], "finding") if row["findings"] else "ok"
            counts = [str(row[s]) for s in ("errors", "warnings", "notes")]
            body.append([row["model"], row["frame"], *counts, result])
        n = len(self.entries)
        out = [f"summary: {plural(n, 'model')}, exit status {self.exit_code}"]
        out += table(["model", "frame", "errors", "warnings", "notes", "result"], body, "llrrrl")
        out.append(
            "  key: errors, warnings, notes: the model's findings and notes by severity; "
            "result: its findings, or why it could not be audited"
        )
        out += self._fix_lines()
        if self.skipped:
            out += ["", f"skipped: {len(self.skipped)}"]
            out += [f"  {s.path}: {s.reason}" for s in self.skipped]
        return fit(out)

    def _fix_lines(self) -> list[str]:
        """What ``--fix`` wrote: a count, a line per copy with exclusions, per failure."""
        if not self.fixes:
            return []
        written = [f for f in self.fixes if isinstance(f, Fix)]
        changed = [f for f in written if f.excluded]
        out = [
            "",
            f"fixes: {plural(len(written), 'copy', 'copies')} written, "
            f"{len(changed)} with pairs excluded",
        ]
        for f in self.fixes:
            if isinstance(f, Failure):
                out.append(f"  {f.model}: {f.error}")
            elif f.excluded:
                pairs = ", ".join(f"{e.body1} / {e.body2}" for e in f.excluded)
                out.append(f"  {f.out}: excludes {pairs}")
        return out

    def to_dict(self) -> dict[str, Any]:
        """The audit as plain data: the ``--json`` document of a multi-model audit."""
        return json_ready(
            {
                "exit_code": self.exit_code,
                "summary": self.rows(),
                "models": [r.to_dict() for r in self.reports],
                "failed": [asdict(f) for f in self.failures],
                "skipped": [asdict(s) for s in self.skipped],
                "fixes": [f.to_dict() for f in self.fixes if isinstance(f, Fix)],
                "fixes_failed": [asdict(f) for f in self.fixes if isinstance(f, Failure)],
            }
        )

    def to_json(self) -> str:
        """The audit as one JSON document (infinities and NaN as null)."""
        return to_json(self.to_dict())

"""A baseline: the findings of an earlier audit, accepted as known so that they do not fail.

The baseline is a JSON report written earlier by ``redundancy audit --format json`` (or
``--json``): one report, or ``{"reports": [...]}`` for several models. A finding or note of
the new audit is *known* when the baseline holds one of the same rule, element and file; the
line is not compared, so an edit elsewhere in the file (which moves every line below it)
does not make a known finding new again. Each entry of the baseline accepts one result: a
third joint that cannot hold keyframe ``home`` is new where the baseline had two. Entries with
the same message are matched first, so that the one left new is the one that changed.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import RedundancyError

#: What identifies a result across audits: (rule id, element name or None, file).
Key = tuple[str, str | None, str]


class BaselineError(RedundancyError, ValueError):
    """The ``--baseline`` file cannot be read as an audit's JSON report (the message says why).

    Attributes:
        path: The baseline file as given.
    """

    def __init__(self, path: str, why: str) -> None:
        self.path = path
        super().__init__(f"--baseline {path!r}: {why}")


def place(path: str) -> str:
    """A file as a baseline compares it: the file itself when it exists, else its spelling.

    ``models/arm7.xml``, ``./models/arm7.xml`` and its absolute path are one file; a path
    that names no file here (a baseline written on another machine) is compared as written,
    normalised (``a/./b`` is ``a/b``).
    """
    return os.path.realpath(path) if os.path.exists(path) else os.path.normpath(path)


@dataclass(frozen=True)
class Baseline:
    """The results an earlier audit reported, each as its key and message.

    Attributes:
        path: The baseline file as given.
        entries: (key, message) of each finding and note it holds.
    """

    path: str
    entries: tuple[tuple[Key, str], ...]

    def known(self, results: Sequence[tuple[Key, str]]) -> list[bool]:
        """Which of ``results`` (each its key and message) the baseline accepts.

        Each entry accepts one result of its key: first one with its message, then any.
        """
        pool: dict[Key, list[str]] = {}
        for key, message in self.entries:
            pool.setdefault(key, []).append(message)
        known = [False] * len(results)
        for i, (key, message) in enumerate(results):
            left = pool.get(key, [])
            if message in left:
                left.remove(message)
                known[i] = True
        for i, (key, _) in enumerate(results):
            left = pool.get(key, [])
            if not known[i] and left:
                left.pop()
                known[i] = True
        return known


def read_baseline(path: str | os.PathLike[str]) -> Baseline:
    """The baseline in a JSON report file.

    Args:
        path: A file written by ``redundancy audit --format json``.

    Raises:
        BaselineError: The file cannot be read, is not JSON, or is not an audit report (no
            ``findings`` list, an entry without a ``rule`` id); the message names the cause.
    """
    shown = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise BaselineError(shown, "no such file") from None
    except IsADirectoryError:
        raise BaselineError(shown, "is a directory, not a JSON report") from None
    except UnicodeDecodeError as err:
        raise BaselineError(shown, f"not UTF-8 text (byte {err.start})") from None
    except OSError as err:
        raise BaselineError(shown, f"cannot be read: {err.strerror or err}") from None
    try:
        document = json.loads(text)
    except json.JSONDecodeError as err:
        raise BaselineError(
            shown, f"not JSON: {err.msg} at line {err.lineno} column {err.colno}"
        ) from None
    reports = _reports(shown, document)
    several = isinstance(document, dict) and "reports" in document
    entries = [
        entry
        for i, r in enumerate(reports)
        for entry in _entries(shown, r, f"reports[{i}]." if several else "")
    ]
    return Baseline(shown, tuple(entries))


_NOT_A_REPORT = "not an audit report written by --format json"


def _reports(shown: str, document: Any) -> list[dict[str, Any]]:
    """The reports of a baseline document: itself, or its list of them.

    ``reports`` is the list of ``--format json`` with several models, ``models`` that of a
    folder audit's ``--json``.
    """
    for part in ("reports", "models"):
        if isinstance(document, dict) and part in document:
            reports = document[part]
            if not isinstance(reports, list) or not all(isinstance(r, dict) for r in reports):
                raise BaselineError(shown, f'{_NOT_A_REPORT}: "{part}" is not a list of reports')
            return reports
    if not isinstance(document, dict):
        raise BaselineError(shown, f"{_NOT_A_REPORT}: a JSON {type(document).__name__}")
    if "runs" in document:
        raise BaselineError(shown, f"{_NOT_A_REPORT}: a SARIF log (give the JSON report)")
    return [document]


def _entries(shown: str, report: dict[str, Any], where: str) -> list[tuple[Key, str]]:
    """(key, message) of each finding and note of one report of the baseline.

    ``where`` is the report's place in the document (``reports[2].``), for a message.
    """
    model = report.get("model")
    if not isinstance(model, str) or not isinstance(report.get("findings"), list):
        what = where[:-1] if where else "the document"
        raise BaselineError(shown, f'{_NOT_A_REPORT}: {what} has no "model" and "findings" list')
    out = []
    for part in ("findings", "notes"):
        items = report.get(part, [])
        if not isinstance(items, list):
            raise BaselineError(shown, f'{_NOT_A_REPORT}: "{where}{part}" is not a list')
        for i, item in enumerate(items):
            rule = item.get("rule") if isinstance(item, dict) else None
            if not isinstance(rule, str) or not rule:
                raise BaselineError(
                    shown, f'{where}{part}[{i}] has no "rule" id (a report older than rule ids?)'
                )
            element, file = item.get("element"), item.get("file")
            if not (element is None or isinstance(element, str)) or not (
                file is None or isinstance(file, str)
            ):
                raise BaselineError(shown, f'{where}{part}[{i}]: "element" or "file" not a string')
            message = item.get("message")
            out.append(((rule, element, place(file or model)), str(message)))
    return out

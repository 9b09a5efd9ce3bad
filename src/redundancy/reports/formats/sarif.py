"""``--format sarif``: a SARIF 2.1.0 log, the format of GitHub code scanning's alerts.

One run for the whole audit (code scanning takes one run per tool and category): the tool's
rules are the audit's whole catalogue (`redundancy.reports.rules.RULES`), each with its
sentence and its severity as the default level; each finding or note is a result of its rule
at its level (``error``, ``warning``, ``note``), located at the file and line of the element it
concerns (the model's root element when it names none), the element named as a logical
location. A relative path is a URI relative to ``%SRCROOT%``, the folder the audit ran in; an
absolute one a ``file:`` URI. ``partialFingerprints`` key a result on its rule, element, file
and rank among its like, not its line, so an alert survives an edit elsewhere in the file;
with a baseline, ``baselineState`` says ``unchanged`` (known) or ``new``.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path, PurePath
from typing import Any
from urllib.parse import quote

from ..rules import RULES, Rule
from .results import ModelResults, Outcome, Result

#: The official schema of SARIF 2.1.0 (OASIS, errata 01), which the log names.
SCHEMA_URI = (
    "https://docs.oasis-open.org/sarif/sarif/v2.1.0/errata01/os/schemas/sarif-schema-2.1.0.json"
)
#: Where each rule is described.
HELP_URI = "https://github.com/redundancy-robotics/redundancy/blob/main/docs/guide/audit.md#rules"
#: The URI base of relative paths: the folder the audit ran in.
SRCROOT = "%SRCROOT%"


def render(outcome: Outcome, version: str = "unknown") -> str:
    """The SARIF log of an audit run, as indented JSON text ending with a newline.

    Args:
        outcome: The audit run's results.
        version: The tool's version (the package's), recorded in ``tool.driver``.
    """
    return json.dumps(log(outcome, version), indent=2, ensure_ascii=True) + "\n"


def log(outcome: Outcome, version: str = "unknown") -> dict[str, Any]:
    """The SARIF log as plain data."""
    index = {rule_id: i for i, rule_id in enumerate(RULES)}
    results = [r for m in outcome.models for r in _results(outcome, m, index)]
    run: dict[str, Any] = {
        "tool": {
            "driver": {
                "name": "redundancy",
                "version": version,
                "informationUri": "https://github.com/redundancy-robotics/redundancy",
                "rules": [_rule(r) for r in RULES.values()],
            }
        },
        "originalUriBaseIds": {SRCROOT: {"uri": Path.cwd().as_uri().rstrip("/") + "/"}},
        "results": results,
    }
    return {"$schema": SCHEMA_URI, "version": "2.1.0", "runs": [run]}


def _rule(r: Rule) -> dict[str, Any]:
    """A rule as a SARIF reportingDescriptor."""
    return {
        "id": r.id,
        "name": "".join(part.capitalize() for part in r.id.split("-")),
        "shortDescription": {"text": r.summary},
        "fullDescription": {"text": f"{r.summary} (kind: {r.kind}; severity: {r.severity})"},
        "defaultConfiguration": {"level": r.severity},
        "helpUri": HELP_URI,
        "properties": {"tags": ["robot-model", r.kind]},
    }


def _results(outcome: Outcome, m: ModelResults, index: dict[str, int]) -> list[dict[str, Any]]:
    seen: dict[tuple[str, str | None, str | None], int] = {}
    out = []
    for r in m.results:
        like = (r.rule, r.element, r.file)
        rank = seen.get(like, 0)
        seen[like] = rank + 1
        result: dict[str, Any] = {
            "ruleId": r.rule,
            "ruleIndex": index[r.rule],
            "level": r.severity,
            "message": {"text": r.message},
            "locations": [_location(r)] if r.file is not None else [],
            "partialFingerprints": {"ruleElementFile/v1": _fingerprint(like, rank)},
            "properties": {"model": m.report.model, "frame": m.report.frame, "kind": r.kind},
        }
        if outcome.baseline is not None:
            result["baselineState"] = "unchanged" if r.known else "new"
        out.append(result)
    return out


def _location(r: Result) -> dict[str, Any]:
    assert r.file is not None
    physical: dict[str, Any] = {"artifactLocation": artifact(r.file)}
    if r.line is not None:
        physical["region"] = {"startLine": r.line}
    location: dict[str, Any] = {"physicalLocation": physical}
    if r.element is not None:
        location["logicalLocations"] = [{"name": r.element, "kind": "element"}]
    return location


def artifact(path: str) -> dict[str, str]:
    """A file as a SARIF artifactLocation: relative to ``%SRCROOT%``, or an absolute URI."""
    p = PurePath(path)
    if p.is_absolute():
        return {"uri": Path(path).as_uri()}
    return {"uri": quote(p.as_posix(), safe="/"), "uriBaseId": SRCROOT}


def _fingerprint(like: tuple[str, str | None, str | None], rank: int) -> str:
    text = json.dumps([*like, rank], ensure_ascii=True)
    return hashlib.sha256(text.encode()).hexdigest()[:32]

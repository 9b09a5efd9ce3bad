"""The audit's results as every format writes them: one list per model, each result new or known.

A *result* is a finding or a note (`redundancy.reports.findings`), with its rule, severity,
file, line and element. `collect` takes the reports of one audit run (a list of one for one
model; a folder audit gives one per model), marks the results a baseline accepts as known,
and says which count for ``--fail-on``: the results at or above its severity that the
baseline does not accept. The exit status is 1 when any counts.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

from ...errors import ParameterError
from ..audit_report import AuditReport
from ..baseline import Baseline, place
from ..findings import Finding, Note, Severity
from ..locations import read_source, root_line
from .choices import DEFAULT_FAIL_ON, FAIL_ON, FailOn

#: Severities from the most to the least serious.
SEVERITIES: tuple[Severity, ...] = ("error", "warning", "note")
_RANK = {"error": 2, "warning": 1, "note": 0, "never": 3}


@dataclass(frozen=True)
class Result:
    """A finding or a note, where it is, and whether a baseline accepts it.

    Attributes:
        rule: The rule's stable id (`redundancy.reports.rules.RULES`).
        severity: ``error``, ``warning`` or ``note``.
        kind: The category the text report prints in brackets.
        message: What is wrong, with the numbers.
        file: The file of the element it concerns; the model's file when it names none
            (None: a model read from a string).
        line: The element's line in ``file`` (1-based); the model's root element when it
            names no element; None when unknown.
        element: The element's name (a link, joint, keyframe...), or None.
        located: True when ``line`` is the element's own, False when it is the root's.
        known: The baseline accepts it: it does not count for ``--fail-on``.
    """

    rule: str
    severity: Severity
    kind: str
    message: str
    file: str | None
    line: int | None
    element: str | None
    located: bool
    known: bool = False

    @property
    def finding(self) -> bool:
        """A finding (an error or a warning), not a note."""
        return self.severity != "note"


@dataclass(frozen=True)
class ModelResults:
    """One model's audit and its results, findings first, in the report's order.

    Attributes:
        report: The model's audit.
        results: Its findings, then its notes.
    """

    report: AuditReport
    results: tuple[Result, ...]


@dataclass(frozen=True)
class Outcome:
    """The results of one audit run, what counts, and the exit status that follows.

    Attributes:
        models: One entry per model audited, in the order audited.
        fail_on: The lowest severity that fails (``never``: none).
        baseline: The baseline file as given, or None.
    """

    models: tuple[ModelResults, ...]
    fail_on: FailOn = DEFAULT_FAIL_ON
    baseline: str | None = None

    def counts(self, result: Result) -> bool:
        """Whether ``result`` fails the run: at or above ``fail_on``, and not known."""
        return not result.known and _RANK[result.severity] >= _RANK[self.fail_on]

    def failing(self) -> list[Result]:
        """Every result that fails the run, model by model."""
        return [r for m in self.models for r in m.results if self.counts(r)]

    @property
    def exit_code(self) -> int:
        """1 when a result fails the run (`counts`), else 0."""
        return 1 if self.failing() else 0

    def tally(self, model: ModelResults) -> dict[str, int]:
        """A model's new results by severity, and how many are known: the summary's row."""
        new = [r for r in model.results if not r.known]
        out = {s: sum(1 for r in new if r.severity == s) for s in SEVERITIES}
        out["known"] = len(model.results) - len(new)
        return out


def sections(model: ModelResults) -> list[tuple[str, list[Result]]]:
    """A model's results as the readable reports group them: findings, notes, known.

    The findings' group is always there (a report says "none"); the others only when not empty.
    """
    new = [x for x in model.results if not x.known]
    groups = [
        ("Findings", [x for x in new if x.finding]),
        ("Notes", [x for x in new if not x.finding]),
        ("Known (in the baseline)", [x for x in model.results if x.known]),
    ]
    return [(title, rows) for title, rows in groups if rows or title == "Findings"]


def where(result: Result) -> str:
    """``file:line`` of a result, its file alone, or ``""``."""
    if result.file is None:
        return ""
    return result.file if result.line is None else f"{result.file}:{result.line}"


def collect(
    reports: Sequence[AuditReport],
    fail_on: FailOn = DEFAULT_FAIL_ON,
    baseline: Baseline | None = None,
) -> Outcome:
    """The results of audit reports, marked against a baseline.

    Args:
        reports: One report per model (a list of one for one model).
        fail_on: The lowest severity that fails the run.
        baseline: Results accepted as known (`redundancy.reports.baseline.read_baseline`).

    Raises:
        ParameterError: ``fail_on`` is none of `FAIL_ON` (the message lists them).
    """
    if fail_on not in FAIL_ON:
        raise ParameterError("fail_on", fail_on, f"one of {', '.join(FAIL_ON)}")
    models = [_model_results(r) for r in reports]
    if baseline is not None:
        flat = [(m, i) for m in models for i in range(len(m.results))]
        keys = [(key(m.results[i], m.report.model), m.results[i].message) for m, i in flat]
        marked = baseline.known(keys)
        rebuilt: dict[int, list[Result]] = {id(m): list(m.results) for m in models}
        for (m, i), known in zip(flat, marked, strict=True):
            rebuilt[id(m)][i] = replace(m.results[i], known=known)
        models = [ModelResults(m.report, tuple(rebuilt[id(m)])) for m in models]
    return Outcome(tuple(models), fail_on, None if baseline is None else baseline.path)


def key(result: Result, model: str) -> tuple[str, str | None, str]:
    """What a baseline matches a result by: rule id, element, file (never the line)."""
    return (result.rule, result.element, place(result.file or model))


def _model_results(report: AuditReport) -> ModelResults:
    """A report's findings and notes as results, each located (the root element if need be)."""
    data = read_source(report.model)
    root = root_line(data) if data is not None else None
    model_file = None if report.model == "<string>" else report.model

    def result(x: Finding | Note) -> Result:
        located = x.line is not None
        return Result(
            x.rule,
            x.severity,
            x.kind,
            x.message,
            x.file if located else model_file,
            x.line if located else root,
            x.element,
            located,
        )

    return ModelResults(report, tuple(result(x) for x in (*report.findings, *report.notes)))

"""``--format markdown``: a readable report (GitHub's job summary, a pull request comment).

A summary table (a row per model: its new errors, warnings and notes, and how many the
baseline knows), the exit status and why, then per model its findings, notes and known
results as tables (severity, rule, element, file and line, message), and its whole text
report folded in a ``<details>`` block. Text from the model (names, messages) is escaped:
a ``|`` or ``*`` in a joint's name cannot break a table or start emphasis.
"""

from __future__ import annotations

import re

from . import text
from .results import ModelResults, Outcome, Result, sections, where

#: Characters with a meaning in CommonMark or GitHub's tables, backslash-escaped in text.
_SPECIAL = re.compile(r"([\\`*_{}\[\]<>|~#!])")


def escape(value: str) -> str:
    """Text as Markdown shows it literally, on one line (a newline is a space)."""
    return _SPECIAL.sub(r"\\\1", " ".join(value.split()))


def code(value: str) -> str:
    """A name as an inline code span, fenced by more backticks than it holds; ``|`` escaped."""
    longest = max((len(run) for run in re.findall("`+", value)), default=0)
    fence = "`" * (longest + 1)
    pad = " " if value.startswith("`") or value.endswith("`") else ""
    return f"{fence}{pad}{' '.join(value.split())}{pad}{fence}".replace("|", "\\|")


def _fenced(lines: list[str]) -> list[str]:
    """Lines in a fenced block whose fence is longer than any backtick run they hold."""
    longest = max((len(run) for line in lines for run in re.findall("`+", line)), default=0)
    fence = "`" * max(3, longest + 1)
    return [f"{fence}text", *lines, fence]


def status_line(outcome: Outcome) -> str:
    """The exit status and why, in words."""
    failing = outcome.failing()
    if outcome.fail_on == "never":
        return "**Exit status 0**: `--fail-on never`."
    if failing:
        n = len(failing)
        return (
            f"**Exit status 1**: {n} result{'s' * (n != 1)} at or above "
            f"`--fail-on {outcome.fail_on}`."
        )
    return f"**Exit status 0**: nothing at or above `--fail-on {outcome.fail_on}`."


def render(outcome: Outcome) -> str:
    """The Markdown report of an audit run, ending with a newline."""
    out = [
        "# redundancy audit",
        "",
        "| model | format | tool frame | errors | warnings | notes | known |",
        "|---|---|---|--:|--:|--:|--:|",
    ]
    for m in outcome.models:
        t = outcome.tally(m)
        r = m.report
        out.append(
            f"| {code(r.model)} | {r.model_format} | {code(r.frame)} | {t['error']} | "
            f"{t['warning']} | {t['note']} | {t['known']} |"
        )
    out += ["", status_line(outcome)]
    if outcome.baseline is not None:
        out += ["", f"Baseline {code(outcome.baseline)}: its results are known and do not fail."]
    for m in outcome.models:
        out += ["", *_model(outcome, m)]
    return "\n".join(out) + "\n"


def _model(outcome: Outcome, m: ModelResults) -> list[str]:
    r = m.report
    out = [f"## {escape(r.model)}", ""]
    out.append(f"{r.model_format}, tool frame {code(r.frame)}, {r.mode} mode.")
    for title, rows in sections(m):
        out += ["", f"### {title}: {len(rows)}", ""]
        out += _table(rows) if rows else ["None."]
    full = text.render(Outcome((m,), outcome.fail_on, None)).rstrip("\n").split("\n")
    out += ["", "<details><summary>The whole text report</summary>", "", *_fenced(full)]
    out += ["", "</details>"]
    return out


def _table(rows: list[Result]) -> list[str]:
    out = ["| severity | rule | element | where | message |", "|---|---|---|---|---|"]
    for x in rows:
        element = code(x.element) if x.element is not None else ""
        place = code(where(x)) if x.file is not None else ""
        cells = (x.severity, code(x.rule), element, place, escape(x.message))
        out.append("| " + " | ".join(cells) + " |")
    return out

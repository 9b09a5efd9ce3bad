"""How results show themselves: in a terminal, with ``print``, and in a notebook.

Every report class mixes in [`Report`][redundancy.display.Report]: ``str(report)`` (and so
``print(report)``) is the readable text of its ``lines()``, ``repr(report)`` one short line saying
what it is, and ``_repr_html_`` the HTML tables Jupyter draws (Jupyter calls it when a cell's value
is the report). The tables come from one place,
[`Report.html_tables`][redundancy.display.Report.html_tables], so a report says what its columns are
once; the HTML is escaped, never built from unescaped names.

Example:
    >>> import redundancy as rd
    >>> arm = rd.load(rd.model_path("arm7"), frame="ee")
    >>> report = rd.crosscheck(arm, arm.keyframe("zero"))
    >>> repr(report)
    '<CrossCheckReport: ok, 8 quantities over 1 pose>'
"""

from __future__ import annotations

import html
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class Table:
    """One table of a report, as text cells.

    Attributes:
        caption: What the table shows (empty for none).
        header: Column titles.
        rows: Cells, one sequence per row, as many as titles.
        numeric: Per column, True where the cells are numbers (right-aligned).
    """

    caption: str
    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    numeric: tuple[bool, ...] = ()

    def html(self) -> str:
        """The table as an HTML ``<table>``, every cell escaped."""
        numeric = self.numeric or (False,) * len(self.header)

        def cell(tag: str, text: str, right: bool) -> str:
            style = ' style="text-align:right"' if right else ' style="text-align:left"'
            return f"<{tag}{style}>{html.escape(text)}</{tag}>"

        head = "".join(cell("th", h, r) for h, r in zip(self.header, numeric, strict=True))
        body = "".join(
            "<tr>" + "".join(cell("td", c, r) for c, r in zip(row, numeric, strict=True)) + "</tr>"
            for row in self.rows
        )
        caption = f"<caption>{html.escape(self.caption)}</caption>" if self.caption else ""
        return f"<table>{caption}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def table(
    caption: str,
    header: Sequence[str],
    rows: Sequence[Sequence[object]],
    numeric: Sequence[bool] = (),
) -> Table:
    """A [`Table`][redundancy.display.Table] with every cell turned into text (``str``)."""
    return Table(
        caption,
        tuple(header),
        tuple(tuple(str(c) for c in r) for r in rows),
        tuple(numeric),
    )


def html_document(
    title: str, tables: Sequence[Table], notes: Sequence[str] = (), text: Sequence[str] = ()
) -> str:
    """A report's HTML: title, tables, notes as a list, the full text folded (all escaped)."""
    parts = [f"<div><p><b>{html.escape(title)}</b></p>"]
    parts += [t.html() for t in tables]
    if notes:
        parts.append("<ul>" + "".join(f"<li>{html.escape(n)}</li>" for n in notes) + "</ul>")
    if text:
        body = html.escape("\n".join(text))
        parts.append(f"<details><summary>full text</summary><pre>{body}</pre></details>")
    parts.append("</div>")
    return "".join(parts)


class Report:
    """Mixin: ``str`` is the text of ``lines()``, ``repr`` a summary, HTML for notebooks.

    A subclass defines ``lines()`` (the text), [`summary`][redundancy.display.Report.summary] (one
    short line) and [`html_tables`][redundancy.display.Report.html_tables]; dataclasses mixing it in
    are declared with ``repr=False`` so the short ``repr`` is kept.
    """

    __slots__ = ()

    def lines(self) -> list[str]:
        """The report as text lines."""
        raise NotImplementedError

    def summary(self) -> str:
        """One short line: the verdict and the counts."""
        raise NotImplementedError

    def html_tables(self) -> list[Table]:
        """The tables a notebook shows (the text's tables, with their columns)."""
        return [table("", ("report",), [[line] for line in self.lines()])]

    def html_notes(self) -> list[str]:
        """Lines shown under the tables in a notebook (none by default)."""
        return []

    def html_text(self) -> list[str]:
        """Text shown folded under the tables in a notebook (none by default)."""
        return []

    def __str__(self) -> str:
        return "\n".join(self.lines())

    def __repr__(self) -> str:
        return f"<{type(self).__name__}: {self.summary()}>"

    def _repr_html_(self) -> str:
        title = f"{type(self).__name__}: {self.summary()}"
        return html_document(title, self.html_tables(), self.html_notes(), self.html_text())


def plural(n: int, word: str, words: str | None = None) -> str:
    """``"1 pose"``, ``"2 poses"``; ``words`` is the plural where it is not word + s."""
    return f"{n} {word}" if n == 1 else f"{n} {words or word + 's'}"


def json_ready(x: Any) -> Any:
    """A value as a JSON document holds it: the one convention of every document written.

    Dicts and sequences element by element, arrays and tuples as lists, NumPy scalars as
    Python's, and an infinite or NaN float as ``null`` (JSON has no infinity; a reader tells
    an infinite error or mass from a missing one by the field's documentation).
    """
    if isinstance(x, dict):
        return {k: json_ready(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [json_ready(v) for v in x]
    if isinstance(x, np.ndarray):
        return json_ready(x.tolist())
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def to_json(document: Any) -> str:
    """``document`` as indented, ASCII JSON after `json_ready` (never Infinity or NaN)."""
    return json.dumps(json_ready(document), indent=2, allow_nan=False)

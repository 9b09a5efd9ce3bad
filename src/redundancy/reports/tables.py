"""Plain-text report lines: numbers, tables sized by ``rich``, and lines that fit :data:`WIDTH`.

Every report line is at most :data:`WIDTH` characters whatever the names in the model: a
table's text columns fold a long name over several lines (``rich`` sizes the columns), and
a sentence longer than the width continues on the next line, indented.
"""

from __future__ import annotations

import io
import math
import textwrap
from collections.abc import Iterable, Sequence

from rich.console import Console
from rich.table import Table
from rich.text import Text

#: Longest report line [characters].
WIDTH = 100
#: Indent of a table's rows, and the extra indent of a sentence's continuation lines.
INDENT = "  "


def fmt(x: float, digits: int = 4) -> str:
    """A number in ``digits`` significant digits; ``inf``, ``-inf``; ``-`` for NaN."""
    x = float(x)
    if math.isnan(x):
        return "-"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return f"{x:.{digits}g}"


def limit(lower: float, upper: float, digits: int = 4) -> str:
    """A range of effort MuJoCo applies, ``[lo, hi]``; ``none`` when unlimited both ways."""
    if math.isinf(lower) and math.isinf(upper):
        return "none"
    return f"[{fmt(lower, digits)}, {fmt(upper, digits)}]"


def ms(h: float, unit: str = "") -> str:
    """A timestep in milliseconds with two decimals, ``any`` when unbounded, ``-`` for NaN.

    Args:
        h: The timestep [s].
        unit: Text after a number (``" ms"``; a table's header names it).
    """
    if math.isnan(h):
        return "-"
    return "any" if not math.isfinite(h) else f"{1e3 * h:.2f}{unit}"


def table(
    header: Sequence[str],
    rows: Sequence[Sequence[str]],
    align: str,
    width: int = WIDTH,
) -> list[str]:
    """Lines of a table indented by two spaces, at most ``width`` characters each.

    Columns are two spaces apart and sized to their content by ``rich``; when the table is
    wider than ``width``, text columns (``l``) fold their cells over several lines and
    number columns (``r``) keep theirs whole.

    Args:
        header: Column titles.
        rows: Cells, one sequence per row, as many as titles.
        align: One letter per column: ``l`` (left, text) or ``r`` (right, numbers).
        width: Longest line [characters].
    """
    t = Table(box=None, pad_edge=False, padding=(0, 1), show_edge=False, header_style="")
    for title, a in zip(header, align, strict=True):
        t.add_column(
            Text(title),
            justify="left" if a == "l" else "right",
            no_wrap=a != "l",
            overflow="fold",
        )
    for r in rows:
        t.add_row(*(Text(c) for c in r))
    out = io.StringIO()
    console = Console(
        file=out,
        width=width - len(INDENT),
        color_system=None,
        force_terminal=False,
        markup=False,
        emoji=False,
        highlight=False,
        legacy_windows=False,
    )
    console.print(t, crop=False)
    return [(INDENT + line).rstrip() for line in out.getvalue().splitlines()]


def wrap(line: str, width: int = WIDTH) -> list[str]:
    """A line as lines of at most ``width`` characters, continuations indented two more."""
    if len(line) <= width:
        return [line]
    lead = line[: len(line) - len(line.lstrip(" "))]
    return textwrap.wrap(
        line,
        width,
        initial_indent="",
        subsequent_indent=lead + INDENT,
        break_long_words=True,
        break_on_hyphens=False,
    )


def fit(lines: Iterable[str], width: int = WIDTH) -> list[str]:
    """Every line of ``lines`` wrapped to ``width`` (see :func:`wrap`)."""
    return [part for line in lines for part in wrap(line, width)]

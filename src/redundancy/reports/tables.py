"""Plain-text report lines: numbers, tables sized by ``rich``, and lines that fit `WIDTH`.

Every report line is at most `WIDTH` characters whatever the names in the model: a table's text
columns fold a long name over several lines (``rich`` sizes the columns), and a sentence longer than
the width continues on the next line, indented. Numbers are never cut: a number column, or a column
of numbers listed in one cell, keeps each cell whole; a file path longer than a line is kept whole
on a line of its own.
"""

from __future__ import annotations

import io
import math
import re
import textwrap
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Any

from rich.console import Console
from rich.table import Table
from rich.text import Text

from ..collision import GeomPair

if TYPE_CHECKING:
    from .pose_sections import FollowerRow

_GLUE = "\x00"  # stands for a space that must not end a line (never in a report's text)
#: Longest report line [characters].
WIDTH = 100
#: Indent of a table's rows, and the extra indent of a sentence's continuation lines.
INDENT = "  "
#: A value this small against the size of what it is printed beside is rounding (the
#: engines' float64 sums leave 1e-16 to 1e-13 of the scale): it prints as 0 [-].
ROUNDING = 1e-12


def fmt(x: float, digits: int = 4, scale: float | None = None) -> str:
    """A number in ``digits`` significant digits; ``inf``, ``-inf``; ``-`` for NaN.

    Args:
        x: The number.
        digits: Significant digits.
        scale: The size of the numbers it is printed beside (a table column's largest
            magnitude): ``|x| <= ROUNDING * scale`` prints as ``0``. None: printed as it is.
    """
    x = float(x)
    if math.isnan(x):
        return "-"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    if scale is not None and abs(x) <= ROUNDING * abs(scale):
        return "0"
    return f"{x:.{digits}g}"


def key(text: str) -> str:
    """The line after a table that says what its abbreviations and columns mean."""
    return f"{INDENT}key: {text}"


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
    number columns (``r``, ``n``) keep theirs whole.

    Args:
        header: Column titles.
        rows: Cells, one sequence per row, as many as titles.
        align: One letter per column: ``l`` (left, text), ``r`` (right, a number) or ``n``
            (left, several numbers in one cell, never folded).
        width: Longest line [characters].
    """
    t = Table(box=None, pad_edge=False, padding=(0, 1), show_edge=False, header_style="")
    for title, a in zip(header, align, strict=True):
        t.add_column(
            Text(title),
            justify="right" if a == "r" else "left",
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
    """A line as lines of at most ``width`` characters, continuations indented two more.

    A bracketed group (a unit ``[N m s/rad]``, a vector ``[0 0 0.12]``), a short one in
    parentheses (``(N m)``, ``(seed 0)``) and an XML element to copy into a file stay on one
    line. A
    word longer than a line is cut, except a file path (a word with a ``/``), which a reader
    copies whole: it stands whole on a line of its own, however long.
    """
    if len(line) <= width:
        return [line]
    lead = line[: len(line) - len(line.lstrip(" "))]
    room = width - len(lead) - len(INDENT)
    # A bracket's spaces are held by a stand-in while textwrap splits at the others.
    held = re.sub(
        r"\[[^\[\]]{1,40}\]|\([^()]{1,10}\)|<[^<>]{1,90}>",
        lambda m: m.group().replace(" ", _GLUE),
        line,
    )
    paths = any("/" in w and len(w) > room for w in held.split())
    parts = textwrap.wrap(
        held,
        width,
        initial_indent="",
        subsequent_indent=lead + INDENT,
        break_long_words=not paths,
        break_on_hyphens=False,
    )
    return [p.replace(_GLUE, " ") for p in parts]


def fit(lines: Iterable[str], width: int = WIDTH) -> list[str]:
    """Every line of ``lines`` wrapped to ``width`` (see `wrap`)."""
    return [part for line in lines for part in wrap(line, width)]


def one_line(x: object) -> str:
    """A value's text on one line (matrices print over several)."""
    return " ".join(str(x).split())


def timestep_text(h: float) -> str:
    """A timestep [s] as text in milliseconds."""
    return f"{1e3 * h:g} ms"


def exclusion(pair: GeomPair, urdf: bool) -> dict[str, Any]:
    """What removes a pair from the ones tested: the line for the file, the argument for Python.

    URDF: an SRDF ``<disable_collisions>`` line (``--srdf``) or a ``disabled_collisions=`` entry
    (its links); MJCF: a ``<contact><exclude>`` of its bodies.
    """
    a, b = sorted((pair.body1, pair.body2))  # in the order of the pair's label
    if urdf:
        return {
            "bodies": [a, b],
            "srdf": f'<disable_collisions link1="{a}" link2="{b}" reason="Always"/>',
            "disabled_collisions": [a, b],
        }
    return {"bodies": [a, b], "mjcf": f'<contact><exclude body1="{a}" body2="{b}"/></contact>'}


def follower_lines(rows: tuple[FollowerRow, ...]) -> list[str]:
    """The joints the couplings move: their ranges, values and what determines them."""
    if not rows:
        return []
    body = [
        [
            f.name,
            f.type,
            f"[{fmt(f.lower, 3)}, {fmt(f.upper, 3)}]",
            fmt(f.value, 4),
            fmt(f.armature),
            fmt(f.damping, 3),
            f.by,
        ]
        for f in rows
    ]
    header = ["follower", "type", "range", "value", "armature", "b", "determined by"]
    return [
        f"followers: {len(rows)} joints the couplings move (not coordinates of the arm):",
        *table(header, body, "llrrrrl"),
        key(
            "value: at the same pose [rad or m]; armature [kg m^2] and b [N m s/rad]: the "
            "joint's own (the arm's rows above include what the followers reflect)"
        ),
    ]


def split_table(header: list[str], rows: list[list[str]], cut: int) -> list[str]:
    """`table` of names, a text column, then numbers; two tables where one would fold the names.

    Args:
        header: Column titles.
        rows: Cells, one sequence per row, as many as titles.
        cut: The first column of the second table, which repeats the name column.
    """
    natural = sum(
        max(len(h), *(len(r[i]) for r in rows)) if rows else len(h) for i, h in enumerate(header)
    )
    align = "ll" + "r" * (len(header) - 2)
    if natural + 2 * (len(header) - 1) <= WIDTH - 2:
        return table(header, rows, align)
    second = [0, *range(cut, len(header))]
    return [
        *table(header[:cut], [r[:cut] for r in rows], align[:cut]),
        *table(
            [header[i] for i in second],
            [[r[i] for i in second] for r in rows],
            "l" + "r" * (len(second) - 1),
        ),
    ]

"""Plain-text tables whose columns are sized to their content.

Every cell is a string; columns are separated by two spaces, so no value can run into the
next whatever its length (a 30-character joint name, a limit of 20 beside an inertia of
0.0001398).
"""

from __future__ import annotations

import math
from collections.abc import Sequence


def fmt(x: float, digits: int = 4) -> str:
    """A number in ``digits`` significant digits; ``inf``, ``-inf``; ``-`` for NaN."""
    if math.isnan(x):
        return "-"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return f"{x:.{digits}g}"


def ms(h: float, unit: str = "") -> str:
    """A timestep in milliseconds with two decimals, ``any`` when unbounded.

    Args:
        h: The timestep [s].
        unit: Text after a number (the lesson's ``" ms"``; a table's header names it).
    """
    return "any" if not math.isfinite(h) else f"{1e3 * h:.2f}{unit}"


def table(header: Sequence[str], rows: Sequence[Sequence[str]], align: str) -> list[str]:
    """Lines of a table indented by two spaces.

    Args:
        header: Column titles.
        rows: Cells, one sequence per row, as many as titles.
        align: One letter per column: ``l`` (left) or ``r`` (right).
    """
    widths = [max([len(h)] + [len(r[i]) for r in rows]) for i, h in enumerate(header)]

    def line(cells: Sequence[str]) -> str:
        parts = [
            c.ljust(w) if a == "l" else c.rjust(w)
            for c, w, a in zip(cells, widths, align, strict=True)
        ]
        return ("  " + "  ".join(parts)).rstrip()

    return [line(header)] + [line(r) for r in rows]

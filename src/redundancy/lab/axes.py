"""The live plots' axes: tick values and labels, ranges rounded to 1, 2 or 5 times 10^k."""

from __future__ import annotations

import math

__all__ = ["log_axis", "nice_ceil", "symmetric_axis", "tick_label"]


def tick_label(v: float) -> str:
    """A tick value with enough significant digits to tell the ticks apart (3; "0" for 0)."""
    if v == 0:
        return "0"
    return f"{v:.3g}".replace("e-0", "e-").replace("e+0", "e")


def nice_ceil(x: float, floor: float) -> float:
    """The smallest of 1, 2, 5 times a power of ten that is >= max(x, floor)."""
    x = max(float(x), floor)
    e = math.floor(math.log10(x))
    for m in (1.0, 2.0, 5.0, 10.0):
        if m * 10.0**e >= x * (1 - 1e-12):
            return m * 10.0**e
    return 10.0 ** (e + 1)  # pragma: no cover


def symmetric_axis(half: float) -> tuple[tuple[float, ...], tuple[str, ...]]:
    """Ticks and labels of a symmetric axis [-half, half]: five ticks."""
    splits = (-half, -half / 2, 0.0, half / 2, half)
    return splits, tuple(tick_label(v) for v in splits)


def log_axis(lo: float, hi: float) -> tuple[tuple[float, ...], tuple[str, ...]]:
    """Ticks at each power of ten in [lo, hi], labelled ``1e-6`` ... ``0.01``, ``0.1``, ``1``."""
    splits = tuple(10.0**k for k in range(round(math.log10(lo)), round(math.log10(hi)) + 1))
    return splits, tuple(f"{v:g}" if v >= 1e-3 else f"1e{round(math.log10(v))}" for v in splits)

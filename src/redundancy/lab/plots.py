"""The lab's live plots: uPlot axes and scales of a series against time relative to now.

The tick positions and labels come from `redundancy.lab.axes`; this module turns them into
viser's uPlot axes and scales for `redundancy.lab.page`.
"""

from __future__ import annotations

from ..errors import MissingDependencyError
from .axes import symmetric_axis, tick_label
from .sim import SPEED_WINDOW

try:
    import viser.uplot
except ImportError as _err:  # pragma: no cover - exercised only without the extra
    raise MissingDependencyError("viser", "lab") from _err


def time_axis(window: float) -> viser.uplot.Axis:
    """The time axis of a plot of the last ``window`` seconds: ticks every 1 s (2 s past 4 s)."""
    step = 1.0 if window <= 4 else 2.0
    splits = tuple(-step * k for k in range(round(window / step), -1, -1))
    return viser.uplot.Axis(
        splits=splits,
        values=tuple(tick_label(v) for v in splits),
        label="t − now (s)",
        labelSize=18,
    )


def symmetric_axes(window: float, ticks: float, limit: float) -> tuple[viser.uplot.Axis, ...]:
    """Time axis; y ticks at 0, +-ticks/2, +-ticks; dashed lines at +-limit, if they show.

    The limit lines are left out when they would lie within 5 % of the range of 0 (the
    speed plot's at-rest band while the joint buzzes at 15 rad/s).
    """
    splits, labels = symmetric_axis(ticks)
    width = 12 + 7 * max(len(s) for s in labels)
    axes = [
        time_axis(window),
        viser.uplot.Axis(splits=splits, values=labels, size=width),
    ]
    if limit >= 0.05 * ticks:
        axes.append(
            # The limits: dashed lines across the plot, labelled on the right.
            viser.uplot.Axis(
                scale="y",
                side=1,
                splits=(-limit, limit),
                values=(tick_label(-limit), tick_label(limit)),
                grid=viser.uplot.Axis_Grid(stroke="#e03131", dash=(6.0, 4.0), width=1.5),
                ticks=viser.uplot.Axis_Ticks(show=False),
                size=12 + 7 * len(tick_label(-limit)),
                stroke="#e03131",
            )
        )
    return tuple(axes)


def speed_scales(half: float) -> dict[str, viser.uplot.Scale]:
    """The speed plot's scales: the last `SPEED_WINDOW` seconds, y in +-``half`` and a margin."""
    return {
        "x": viser.uplot.Scale(time=False, auto=False, range=(-SPEED_WINDOW, 0.0)),
        # 15 % above the outer ticks, so their labels are not clipped.
        "y": viser.uplot.Scale(auto=False, range=(-1.15 * half, 1.15 * half)),
    }


def external_scales(top: float) -> dict[str, viser.uplot.Scale]:
    """The external torque plot's scales: the last `SPEED_WINDOW` seconds, y in [0, 1.1 top]."""
    return {
        "x": viser.uplot.Scale(time=False, auto=False, range=(-SPEED_WINDOW, 0.0)),
        "y": viser.uplot.Scale(auto=False, range=(0.0, 1.1 * top)),
    }


__all__ = ["external_scales", "speed_scales", "symmetric_axes", "time_axis"]

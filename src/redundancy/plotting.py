"""Matplotlib for the scripts, headless, or an install hint when the ``plot`` extra is missing."""

from __future__ import annotations

from types import ModuleType

from .errors import MissingDependencyError


def pyplot() -> ModuleType:
    """``matplotlib.pyplot`` on the non-interactive Agg backend (PNG files, no display).

    Raises:
        MissingDependencyError: matplotlib is not installed (``pip install 'redundancy[plot]'``).
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as err:
        raise MissingDependencyError("matplotlib", "plot") from err
    return plt

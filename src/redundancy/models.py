"""Where the bundled models are: inside the installed package, or ``models/`` in a checkout."""

from __future__ import annotations

from pathlib import Path

from .errors import UnknownNameError


def _dirs() -> list[Path]:
    here = Path(__file__).resolve().parent
    # A wheel carries models/ as redundancy/models; an editable install reads the checkout's.
    return [here / "models", here.parent.parent / "models"]


def available() -> list[str]:
    """Names of the bundled models (file stems)."""
    names: set[str] = set()
    for d in _dirs():
        if d.is_dir():
            names.update(p.stem for p in d.glob("*.xml"))
    return sorted(names)


def model_path(name: str) -> Path:
    """Path of a bundled model, e.g. ``model_path("arm7")``.

    Raises:
        UnknownNameError: No bundled model has that name (the message lists them).
    """
    for d in _dirs():
        p = d / f"{name}.xml"
        if p.is_file():
            return p
    raise UnknownNameError("model", name, available())

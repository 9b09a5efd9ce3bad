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


def bundled(name: str) -> Path | None:
    """The bundled model a bare name means (``"panda"``), or None.

    A name means a bundled model only when it is not a file (so a file called ``panda`` in
    the working directory still wins), has no directory part and names one of
    :func:`available`.
    """
    if not name or Path(name).exists() or Path(name).name != name:
        return None
    stem = name.removesuffix(".xml")
    return model_path(stem) if stem in available() else None


def not_found_hint(name: str) -> str:
    """What to say after "model file not found" for a bare name: the bundled models."""
    if Path(name).name != name:
        return ""
    names = ", ".join(available())
    return f"; bundled models (load by name or rd.model_path(name)): {names}"

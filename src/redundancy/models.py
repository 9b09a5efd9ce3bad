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


def example_robot_data(path: str) -> Path:
    """Path of a robot file of example-robot-data (PyPI) by its path below ``robots/``.

    Example: ``example_robot_data("ur_description/urdf/ur5_robot.urdf")``.

    The package installs its robots under its own prefix in site-packages; this finds them.

    Raises:
        MissingDependencyError: example-robot-data is not installed.
        UnknownNameError: No such file (the message lists the package's URDF files).
    """
    import importlib.metadata

    from .errors import MissingDependencyError

    try:
        files = importlib.metadata.files("example-robot-data") or []
    except importlib.metadata.PackageNotFoundError as err:
        raise MissingDependencyError("example_robot_data", "test") from err
    urdfs = []
    for f in files:
        text = str(f).replace("\\", "/")
        if "/robots/" not in text:
            continue
        inner = text.split("/robots/", 1)[1]
        if inner == path:
            return Path(str(f.locate()))
        if inner.endswith(".urdf"):
            urdfs.append(inner)
    raise UnknownNameError("example-robot-data file", path, sorted(urdfs))

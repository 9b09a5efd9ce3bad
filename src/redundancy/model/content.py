"""What an Arm was loaded from: the bytes of every file a load read, the options, a digest.

A load records each file it reads (the model file, its ``<include>`` files, the meshes,
textures and height fields MuJoCo reads, a URDF's meshes, an SRDF) in a `Recipe`
with the load's options. The recipe is what an Arm pickles as, and what copies and
executor workers rebuild it from:

* the files still hold the same bytes at the same absolute paths: the arm is loaded from
  them again;
* a file changed, moved or cannot be read (another working directory, another machine, a
  temporary file removed, a file edited since): the arm is loaded from the bytes the recipe
  carries, written to a private temporary folder at the same relative places, and the
  folder is removed once the engines have compiled them.

Either way the files the rebuild read are checked against the recipe's: a rebuilt arm is
the robot that was loaded, or the library's `ModelError` names the file
that differs. The `Recipe.digest` (SHA-256 of the options and of every file's bytes)
is the arm's identity: executor workers keep rebuilt arms by it.
"""

from __future__ import annotations

import contextlib
import contextvars
import dataclasses
import hashlib
import os
import shutil
import tempfile
from collections.abc import Callable, Iterator
from functools import partial
from pathlib import Path
from typing import Any

import mujoco

from ..errors import ModelError

__all__ = ["Recipe", "feed_assets", "known_files", "mujoco_assets", "record", "recording"]


class _Reading:
    """The files one load reads: absolute path -> bytes, in the order first read."""

    def __init__(self, back: dict[str, str]) -> None:
        self.files: dict[str, bytes] = {}
        self.back = back  # a file's place in a rebuild's temporary folder -> its own path

    def add(self, path: str | os.PathLike[str], data: bytes | None) -> None:
        key = os.path.abspath(path)
        if data is None:
            try:
                data = Path(key).read_bytes()
            except OSError:  # the engine that needed it has already said so, or did not need it
                return
        self.files.setdefault(self.back.get(key, key), data)


_READING: contextvars.ContextVar[_Reading | None] = contextvars.ContextVar(
    "redundancy_reading", default=None
)

#: During a rebuild: where the recipe's files now are (a worker may lack the environment,
#: ``ROS_PACKAGE_PATH``, that found them at load).
_KNOWN: contextvars.ContextVar[tuple[str, ...]] = contextvars.ContextVar(
    "redundancy_known_files", default=()
)


def known_files() -> tuple[str, ...]:
    """The files of the recipe being rebuilt, where they now are (empty outside a rebuild)."""
    return _KNOWN.get()


@contextlib.contextmanager
def _knowing(recipe: Recipe, at: Callable[[str], str]) -> Iterator[None]:
    token = _KNOWN.set(tuple(at(p) for p, _ in recipe.files))
    try:
        yield
    finally:
        _KNOWN.reset(token)


@contextlib.contextmanager
def recording(back: dict[str, str] | None = None, fresh: bool = False) -> Iterator[_Reading]:
    """Record the files read in this context (into the enclosing record unless ``fresh``)."""
    outer = _READING.get()
    if outer is not None and not fresh:
        yield outer
        return
    reading = _Reading(back or {})
    token = _READING.set(reading)
    try:
        yield reading
    finally:
        _READING.reset(token)


def record(path: str | os.PathLike[str], data: bytes | None = None) -> None:
    """Note that the load in progress read ``path`` (``data``: its bytes, if already read)."""
    reading = _READING.get()
    if reading is not None:
        reading.add(path, data)


def mujoco_assets(spec: mujoco.MjSpec, folder: Path) -> list[Path]:
    """The files a spec's meshes, textures, height fields and skins name (those that exist).

    Paths count as MuJoCo counts them: a file name from the model file's directory and the
    compiler's ``meshdir`` (meshes, height fields, skins) or ``texturedir`` (textures), each
    of which may be absolute; ``strippath`` keeps only the file's own name.
    """
    model_dir = Path(spec.modelfiledir or folder)

    def place(name: str, subdir: str) -> Path | None:
        if not name:
            return None
        name, subdir = name.replace("\\", "/"), subdir.replace("\\", "/")  # as MuJoCo reads
        if spec.strippath:
            name = os.path.basename(name)
        p = model_dir / subdir / name  # an absolute subdir or name discards what precedes
        return Path(os.path.normpath(os.path.abspath(p))) if p.is_file() else None

    names = [(m.file, spec.meshdir) for m in spec.meshes]
    names += [(h.file, spec.meshdir) for h in spec.hfields]
    names += [(s.file, spec.meshdir) for s in spec.skins]
    for t in spec.textures:
        names += [(f, spec.texturedir) for f in [t.file, *t.cubefiles]]
    found = (place(name, subdir) for name, subdir in names)
    return list(dict.fromkeys(p for p in found if p is not None))


def feed_assets(spec: mujoco.MjSpec, paths: list[Path]) -> None:
    """Hand MuJoCo the bytes of these files, recorded, instead of letting it read them.

    MuJoCo's asset cache knows a file by its name and modification time in whole seconds,
    so a mesh edited within a second of being compiled would compile as it was before; the
    bytes given in the spec's assets are known by their content. Each is keyed once, by its
    absolute path with ``.`` and ``..`` folded (MuJoCo folds the path it looks up the same
    way, and refuses two keys that fold to one name).
    """
    for p in paths:
        key = os.path.normpath(os.path.abspath(p))
        if key in spec.assets:
            continue
        data = Path(key).read_bytes()
        record(key, data)
        spec.assets[key] = data


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


@dataclasses.dataclass(frozen=True, eq=False)
class Recipe:
    """How to load an arm again, and the bytes it was loaded from.

    Attributes:
        loader: ``"load"`` (a file) or ``"load_string"`` (text).
        model: The model file's absolute path (symbolic links resolved), or the text.
        folder: Absolute directory relative paths in the model count from.
        options: The load's options: (site, strict, frame, disabled pairs, base, rest).
        shown: What ``arm.source`` says (the path as the user gave it).
        files: (absolute path, SHA-256) of each file the load read, in the order read.
        content: Each file's bytes, in the same order; None in the lean copy sent to an
            executor's worker, which then reads the files at their paths.
        digest: SHA-256 of all of the above but ``content``: the arm's identity.
    """

    loader: str
    model: str
    folder: str
    options: tuple[Any, ...]
    shown: str
    files: tuple[tuple[str, str], ...]
    content: tuple[bytes, ...] | None
    digest: str = ""

    @classmethod
    def made(
        cls,
        loader: str,
        model: str,
        folder: str,
        options: tuple[Any, ...],
        shown: str,
        files: dict[str, bytes],
    ) -> Recipe:
        """The recipe of a load that read ``files`` (path -> bytes)."""
        listed = tuple((p, _sha(b)) for p, b in files.items())
        made = cls(loader, model, folder, options, shown, listed, tuple(files.values()))
        return dataclasses.replace(made, digest=made._identity())

    def _identity(self) -> str:
        """SHA-256 of everything but the files' bytes (see ``digest``)."""
        fields = (self.loader, self.model, self.folder, self.options, self.shown, self.files)
        return _sha(repr(fields).encode("utf-8", "surrogatepass"))

    def with_rest(self, rest: Any) -> Recipe:
        """This recipe with another ``rest=`` (the same files): the robot held elsewhere."""
        other = dataclasses.replace(self, options=(*self.options[:-1], rest))
        return dataclasses.replace(other, digest=other._identity())

    def lean(self) -> Recipe:
        """This recipe without the files' bytes (a worker reads them at their paths)."""
        return dataclasses.replace(self, content=None)

    @property
    def size(self) -> int:
        """Bytes of file content carried [B]."""
        return sum(len(b) for b in self.content or ())


def _changed(files: tuple[tuple[str, str], ...]) -> str | None:
    """Why the files on disk are not the recorded ones (naming the first that is not), or None."""
    for path, sha in files:
        try:
            data = Path(path).read_bytes()
        except OSError as err:
            return f"cannot read {path!r} ({err.strerror or err})"
        if _sha(data) != sha:
            return f"the file {path!r} changed since the arm was loaded"
    return None


def _mirrored_str(root: Path, path: str) -> str:
    return str(_mirrored(root, path))


def _mirrored(root: Path, path: str) -> Path:
    p = Path(path)
    return root.joinpath(*p.parts[1:]) if p.is_absolute() else root / p


class ContentUnavailable(ModelError):
    """A lean recipe's files are not on this machine as they were loaded (send the bytes)."""


#: load(recipe, at) -> Arm: the loader given the recipe and where its paths now are.
Loader = Callable[[Recipe, Callable[[str], str]], Any]


def rebuild(recipe: Recipe, loader: Loader) -> tuple[Any, Recipe]:
    """The arm the recipe was taken from, loaded again (see the module's docstring).

    Returns:
        The arm, and its recipe with the files' bytes (read again if ``recipe`` had none).

    Raises:
        ModelError: A file the rebuild read differs from the recipe's (a file outside the
            model's folders that changed), naming it; `ContentUnavailable` when the
            recipe carries no bytes and the files on disk are not the recorded ones.
    """
    why = _changed(recipe.files)
    if why is None:
        with recording(fresh=True) as reading, _knowing(recipe, lambda p: p):
            arm = loader(recipe, lambda p: p)
        why = _differs(recipe, reading.files)
        if why is None:
            content = tuple(reading.files[p] for p, _ in recipe.files)
            return arm, dataclasses.replace(recipe, content=content)
    if recipe.content is None:
        raise ContentUnavailable(f"cannot rebuild the arm of {recipe.shown!r} here: {why}")
    root = Path(tempfile.mkdtemp(prefix="redundancy-")).resolve()  # paths are read resolved
    try:
        back: dict[str, str] = {}
        for (path, _), data in zip(recipe.files, recipe.content, strict=True):
            place = _mirrored(root, path)
            place.parent.mkdir(parents=True, exist_ok=True)
            place.write_bytes(data)
            back[str(place)] = path
        mirrored = partial(_mirrored_str, root)
        with recording(back, fresh=True) as reading, _knowing(recipe, mirrored):
            try:
                arm = loader(recipe, mirrored)
            except ModelError as err:
                # A file named by absolute path is read where it is: gone or changed there?
                unread = tuple(f for f in recipe.files if f[0] not in reading.files)
                why = _changed(unread)
                if why is None:
                    raise
                shown = recipe.shown
                raise ModelError(
                    f"cannot rebuild the arm of {shown!r} as it was loaded: {why}"
                ) from err
    finally:
        shutil.rmtree(root, ignore_errors=True)
    why = _differs(recipe, reading.files)
    if why is not None:
        raise ModelError(f"cannot rebuild the arm of {recipe.shown!r} as it was loaded: {why}")
    return arm, recipe


def _differs(recipe: Recipe, read: dict[str, bytes]) -> str | None:
    """Why the files a rebuild read are not the recipe's, or None."""
    now = {p: _sha(b) for p, b in read.items()}
    for path, sha in recipe.files:
        if path not in now:
            return f"{path!r} was not read again"
        if now[path] != sha:
            return f"the file {path!r} changed since the arm was loaded"
    extra = [p for p in now if p not in dict(recipe.files)]
    return f"{extra[0]!r} is read now and was not then" if extra else None

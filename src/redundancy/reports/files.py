"""Writing a report file: only where the user pointed, only a regular file, atomically.

Rules (checked by `check_target` before any work, so a bad path fails at once):

* the path must name a regular file or nothing yet, in an existing directory; a directory,
  a device, a FIFO or a socket is refused;
* a symbolic link is followed to the file it names, which is replaced and the link kept; a
  link to nothing (dangling) is refused;
* an existing file keeps its permission bits; a new one gets ``0o666`` less the umask, as
  ``open()`` would give it;
* the new content goes to a temporary file in the same directory (``.redundancy-*.tmp``, a
  short name whatever the target's length), is flushed to disk, then renamed over the
  target: a crash leaves the old content or the new, never half of one;
* a report never replaces a file its command read: `input_named` says which input a path
  is (the same file by ``os.path.samefile``: through a symbolic link, a hard link or
  another spelling), for the caller to refuse it before any work.
"""

from __future__ import annotations

import os
import secrets
import stat
import tempfile
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import RedundancyError

if TYPE_CHECKING:
    from ..arm import Arm

#: Start of the temporary file's name beside the target: short and fixed, so any legal
#: target name (up to 255 bytes) works; a name built from the target's overflowed there.
_TMP_PREFIX = ".redundancy-"


class OutputPathError(RedundancyError, OSError):
    """A report cannot be written where the user pointed (the message says why)."""


def check_target(path: str | os.PathLike[str]) -> Path:
    """The regular file a report will replace or create, after the rules above.

    Returns:
        The resolved path (the file a symbolic link names).

    Raises:
        OutputPathError: A directory, device, FIFO or socket; a dangling link; a missing or
            unwritable directory.
    """
    p = Path(path)
    shown = str(p)
    if p.is_symlink():
        target = Path(os.path.realpath(p))
        if not target.exists():
            raise OutputPathError(f"{shown!r} is a symbolic link to nothing ({str(target)!r})")
        p = target
    if p.exists():
        mode = p.stat().st_mode
        if not stat.S_ISREG(mode):
            kind = (
                "a directory"
                if stat.S_ISDIR(mode)
                else "a FIFO"
                if stat.S_ISFIFO(mode)
                else "a device"
                if stat.S_ISCHR(mode) or stat.S_ISBLK(mode)
                else "a socket"
                if stat.S_ISSOCK(mode)
                else "not a regular file"
            )
            raise OutputPathError(f"{shown!r} is {kind}: reports are written to regular files only")
    parent = p.parent
    if not parent.is_dir():
        raise OutputPathError(f"directory {str(parent)!r} of {shown!r} does not exist")
    try:  # the one sure test of "can a file be created there": create one (procfs, read-only)
        fd, probe = tempfile.mkstemp(dir=parent, prefix=_TMP_PREFIX, suffix=".probe")
        os.close(fd)
        os.unlink(probe)
    except OSError as err:
        raise OutputPathError(
            f"cannot create files in directory {str(parent)!r} of {shown!r}: {err.strerror}"
        ) from err
    return p


def input_named(path: str | os.PathLike[str], inputs: Iterable[tuple[str, str]]) -> str | None:
    """What ``path`` is among the files a command read, or None when it is none of them.

    Args:
        path: Where a report would be written.
        inputs: (path, what it is, for a message) of each file read.

    Returns:
        The ``what`` of the first input that is the same file as ``path``.
    """
    if not os.path.exists(path):  # a new file is no input
        return None
    for file, what in inputs:
        try:
            if os.path.samefile(path, file):
                return what
        except OSError:  # an input gone since it was read: nothing there to replace
            continue
    return None


def read_by(arm: Arm) -> list[tuple[str, str]]:
    """Every file the load of ``arm`` read, as its recipe lists them: (path, what it is).

    The model, its includes at any depth, the models it attaches, the meshes, textures and
    height fields MuJoCo read, a URDF's meshes, the SRDF (`redundancy.model.content`).
    """
    _, (recipe,) = arm.__reduce__()  # an Arm travels as its recipe
    shown = arm.source
    return [
        (
            path,
            f"the model file {shown!r}"
            if path == recipe.model
            else f"{path!r}, a file the model {shown!r} reads",
        )
        for path, _ in recipe.files
    ]


def _new_temporary(folder: Path, suffix: str = "") -> tuple[int, str]:
    """A new file beside the target, opened for writing, with the mode ``open()`` gives.

    ``suffix`` follows ``.tmp`` (the target's, for a reader that goes by the suffix).

    Created with 0o666 for the kernel to apply the umask: reading the umask would mean
    setting it (``os.umask``), which races with every other thread creating files.
    """
    for _ in range(100):
        name = str(folder / f"{_TMP_PREFIX}{secrets.token_hex(8)}.tmp{suffix}")
        try:
            return os.open(name, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666), name
        except FileExistsError:
            continue
    raise FileExistsError(f"no free temporary name in {str(folder)!r}")


def write_atomic(path: str | os.PathLike[str], text: str | bytes) -> Path:
    """Write ``text`` to the regular file ``path`` names, atomically, keeping its mode.

    Args:
        path: The file to replace or create.
        text: Its new content: text (written in the locale's encoding, as ``open()`` does)
            or bytes (written as they are).

    Returns:
        The file written (a symbolic link's target).

    Raises:
        OutputPathError: The path breaks a rule of this module, or the write itself failed
            (an ``OSError`` too; the old file is left whole).
    """
    (written,) = write_together([(path, text)])
    return written


def write_together(
    files: Sequence[tuple[str | os.PathLike[str], str | bytes]],
    check: Callable[[list[Path]], None] | None = None,
) -> list[Path]:
    """Write several files by the rules above: each atomically, after ``check`` of them all.

    Every new content goes to its temporary file beside its target first; ``check`` is then
    called with the temporary files (in the order of ``files``), where each reads as its target
    will (the same directory: the relative paths in it count from the same place); only when
    it returns are the temporaries renamed over their targets, one after the other. A check
    that raises leaves every target as it was, and no temporary file behind.

    Args:
        files: (target, content) pairs; text or bytes as `write_atomic` takes them.
        check: Called with the temporary files before any target is replaced.

    Returns:
        The files written (symbolic links' targets), in order.

    Raises:
        OutputPathError: A path breaks a rule of this module, or a write failed.
    """
    targets = [check_target(path) for path, _ in files]
    made: list[str] = []
    try:
        for (path, content), p in zip(files, targets, strict=True):
            # Checked in place: named as the target ends (MuJoCo reads a model by its suffix).
            suffix = p.suffix[:16] if check is not None else ""
            made.append(_write_temporary(path, p, content, suffix))
        if check is not None:
            check([Path(t) for t in made])
        for tmp, p, (path, _) in zip(made, targets, files, strict=True):
            try:
                os.replace(tmp, p)  # atomic on POSIX within one filesystem
            except OSError as err:
                raise OutputPathError(f"cannot write {str(path)!r}: {err}") from err
    finally:
        for tmp in made:
            Path(tmp).unlink(missing_ok=True)  # none left once replaced
    return targets


def _write_temporary(
    path: str | os.PathLike[str], p: Path, content: str | bytes, suffix: str = ""
) -> str:
    """The temporary file of target ``p`` with ``content``, flushed to disk, in ``p``'s mode."""
    mode = stat.S_IMODE(p.stat().st_mode) if p.exists() else None
    try:
        fd, tmp = _new_temporary(p.parent, suffix)
    except OSError as err:
        raise OutputPathError(f"cannot write {str(path)!r}: {err}") from err
    try:
        with os.fdopen(fd, "wb" if isinstance(content, bytes) else "w") as f:
            f.write(content)
            f.flush()
            if mode is not None:  # an existing file keeps its permission bits
                os.fchmod(f.fileno(), mode)
            os.fsync(f.fileno())
    except OSError as err:
        Path(tmp).unlink(missing_ok=True)
        raise OutputPathError(f"cannot write {str(path)!r}: {err}") from err
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return tmp

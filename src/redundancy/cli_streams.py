"""The command line's streams: one-line errors on stderr, stdout guarded while a command runs.

Every command prints through ``sys.stdout``; `terminal_output` stands `Stdout` in for it, so
that each way the report can fail to go out (a closed stdout, a reader gone, a full disk) ends
the same way for all of them, and text the terminal cannot encode is escaped.
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterator
from typing import Any


def one_line(message: object) -> str:
    """A message on one line: its lines, stripped, joined with "; "."""
    return "; ".join(line.strip() for line in str(message).splitlines() if line.strip())


def error(message: object) -> None:
    """Print one line on stderr; nothing when stderr is closed or gone."""
    stream = sys.stderr
    if stream is None:  # started with stderr closed (2>&-)
        return
    try:
        print(one_line(message), file=stream, flush=True)
    except (OSError, ValueError):  # its reader went away, or the stream was closed
        pass


def silence_stdout() -> None:
    """After a broken pipe: point stdout at /dev/null so the exit's flush raises nothing."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):  # no real stdout (a test's capture)
        pass


class OutputError(Exception):
    """Writing to stdout failed other than by a closed pipe (a full disk): one line."""


def stdout_name() -> str:
    """Standard output, and the file it is when the system says (Linux's /proc)."""
    try:
        target = os.readlink("/proc/self/fd/1")
    except OSError:
        return "standard output"
    return f"standard output ({target})" if target.startswith("/") else "standard output"


class Stdout:
    """The command's stdout: a closed one is a broken pipe, a failed write an OutputError.

    Every command prints through ``sys.stdout``; this stands in for it while the command
    runs, so that each way the report can fail to go out ends the same way for all of them.
    """

    def __init__(self, stream: Any) -> None:
        self._stream = stream

    def _call(self, name: str, *args: Any) -> Any:
        if self._stream is None:  # started with stdout closed (>&-): as if nobody reads
            raise BrokenPipeError("standard output is closed")
        try:
            return getattr(self._stream, name)(*args)
        except BrokenPipeError:
            raise
        except ValueError as err:  # the stream object was closed: nobody reads either
            raise BrokenPipeError(str(err)) from err
        except OSError as err:
            raise OutputError(f"cannot write to {stdout_name()}: {err}") from err

    def write(self, text: str) -> int:
        """Write to the stream (see the class)."""
        return int(self._call("write", text))

    def flush(self) -> None:
        """Flush the stream (see the class)."""
        self._call("flush")

    def __getattr__(self, name: str) -> Any:  # fileno, encoding, isatty...
        if self._stream is None:
            raise AttributeError(name)
        return getattr(self._stream, name)


@contextlib.contextmanager
def terminal_output() -> Iterator[None]:
    """While a command runs: stdout guarded (`Stdout`), unencodable text escaped.

    The streams are put back as they were afterwards (``main`` is also called in-process).
    """
    saved: list[tuple[Any, str]] = []
    for stream in (sys.stdout, sys.stderr):
        errors = getattr(stream, "errors", None)
        if errors is not None and hasattr(stream, "reconfigure"):
            with contextlib.suppress(OSError, ValueError):
                stream.reconfigure(errors="backslashreplace")
                saved.append((stream, errors))
    original = sys.stdout
    sys.stdout = Stdout(original)  # type: ignore[assignment]
    try:
        yield
    finally:
        sys.stdout = original
        for stream, errors in saved:
            with contextlib.suppress(OSError, ValueError):
                stream.reconfigure(errors=errors)

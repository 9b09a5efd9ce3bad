"""A progress bar for long runs, on a terminal only (``rich.progress``).

`terminal_progress` gives the `Progress` callback of a command: a bar per stage on the stream
(stderr) once the run has taken `DELAY` seconds, cleared when the run ends; nothing at all when the
stream is not a terminal (a log, a pipe, CI) or the user asked for quiet. A dumb terminal (``$TERM``
dumb or unknown, as rich reads it: an editor's shell, some CI consoles) cannot redraw a bar, so it
gets a plain line per stage instead, at most every `LINE_INTERVAL` seconds and when the stage
completes.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TextIO

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from .sections import Progress as Callback

#: A run shows its bar once it has taken this long [s]: a short one stays silent.
DELAY = 1.0
#: On a dumb terminal, a stage's line is repeated at most this often [s].
LINE_INTERVAL = 10.0


class _Bars:
    """One bar per stage, started after `DELAY` seconds (see `terminal_progress`)."""

    def __init__(self, console: Console, delay: float) -> None:
        self.start = time.monotonic()
        self.delay = delay
        self.bars = Progress(
            TextColumn("{task.description}"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("poses"),
            TimeElapsedColumn(),
            console=console,
            transient=True,
        )
        self.tasks: dict[str, int] = {}
        self.shown = False

    def __call__(self, stage: str, done: int, total: int) -> None:
        if stage not in self.tasks:
            self.tasks[stage] = self.bars.add_task(stage, total=total)
        self.bars.update(self.tasks[stage], completed=done, total=total)  # type: ignore[arg-type]
        if not self.shown and time.monotonic() - self.start >= self.delay:
            self.bars.start()
            self.shown = True

    def close(self) -> None:
        if self.shown:
            self.bars.stop()


class _Lines:
    """A plain line per stage for a dumb terminal (see the module's description)."""

    def __init__(self, stream: TextIO, delay: float) -> None:
        self.stream = stream
        self.start = time.monotonic()
        self.delay = delay
        self.last: dict[str, float] = {}

    def __call__(self, stage: str, done: int, total: int) -> None:
        now = time.monotonic()
        if now - self.start < self.delay:
            return
        if done < total and now - self.last.get(stage, -LINE_INTERVAL) < LINE_INTERVAL:
            return
        self.last[stage] = now
        self.stream.write(f"{stage}: {done}/{total} poses, {now - self.start:.0f} s\n")
        self.stream.flush()

    def close(self) -> None:
        """Nothing to clear: the lines stay."""


@contextmanager
def terminal_progress(
    stream: TextIO, quiet: bool = False, delay: float | None = None
) -> Iterator[Callback | None]:
    """The progress callback for a run whose bar goes to ``stream``, or ``None``.

    Args:
        stream: Where the bar is drawn (a command's stderr).
        quiet: No bar whatever the stream.
        delay: Seconds before the bar appears (default `DELAY`).

    Yields:
        The callback, or ``None`` when ``stream`` is not a terminal or ``quiet`` is set.
    """
    isatty = getattr(stream, "isatty", None)
    if quiet or not (callable(isatty) and isatty()):
        yield None
        return
    wait = DELAY if delay is None else delay
    console = Console(file=stream, force_terminal=True)
    bars = _Lines(stream, wait) if console.is_dumb_terminal else _Bars(console, wait)
    try:
        yield bars
    finally:
        bars.close()

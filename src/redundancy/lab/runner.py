"""The lab's clock: a simulation stepped in a background thread, in step with real time.

`RealTimeRunner` steps any simulation with a ``timestep``, a ``time`` and a ``step(n)`` (the lab's
`redundancy.lab.sim.LabSim`) against a clock (the wall clock, or a fake one in tests) with pause,
single step and slow motion.
"""

from __future__ import annotations

import collections
import threading
import time
from collections.abc import Callable
from typing import Generic, Protocol, TypeVar

import numpy as np

from ..errors import RedundancyError


class Steppable(Protocol):
    """What the runner steps: a simulation with a timestep, a clock and a step."""

    timestep: float

    @property
    def time(self) -> float:
        """Simulated time [s]."""
        ...

    def step(self, n: int = 1) -> None:
        """Advance ``n`` timesteps."""
        ...


S = TypeVar("S", bound=Steppable)


class RealTimeRunner(Generic[S]):
    """Steps a `LabSim` in a background thread, in step with a clock.

    Each frame it steps ``rate * elapsed / timestep`` times (at most ``max_lag`` seconds' worth:
    when the machine falls behind, simulated time slows down rather than piling up), then calls the
    frame callbacks with the sim. `frame` is one such frame; the thread calls it ``fps`` times a
    second, and tests call it with a fake ``clock``.

    Args:
        sim: The simulation.
        fps: Frames per second (callback rate) [1/s].
        max_lag: Largest simulated time stepped in one frame [s].
        clock: Seconds from an arbitrary origin (default `time.perf_counter`).

    Attributes:
        paused: No steps while set (frames and callbacks go on); see `step_once`.
        rate: Simulated seconds per clock second (1: real time; see `redundancy.lab.sim.RATES`).
        real_time_factor: Simulated time over clock time across the last ~2 s of frames
            (``nan`` until two frames have run).
    """

    period: float
    max_steps: int
    frames: int
    paused: bool
    rate: float
    real_time_factor: float

    def __init__(
        self,
        sim: S,
        fps: float = 30.0,
        max_lag: float = 0.1,
        clock: Callable[[], float] = time.perf_counter,
    ) -> None:
        self.sim = sim
        self.period = 1.0 / fps
        self.max_steps = max(1, round(max_lag / sim.timestep))
        self.callbacks: list[Callable[[S], None]] = []
        self.errors: list[BaseException] = []
        self.frames = 0
        self.paused = False
        self.rate = 1.0
        self.real_time_factor = float("nan")
        self._clock = clock
        self._last: float | None = None
        self._owed = 0.0
        self._single = 0
        self._history: collections.deque[tuple[float, float]] = collections.deque()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def set_rate(self, rate: float) -> None:
        """Simulated seconds per clock second, in (0, 1]."""
        if not (np.isfinite(rate) and 0 < rate <= 1):
            raise RedundancyError(f"rate must be in (0, 1], got {rate}")
        self.rate = float(rate)
        self._owed = 0.0
        self._history.clear()

    def step_once(self) -> None:
        """Pause, and take exactly one timestep at the next frame."""
        self.paused = True
        self._single += 1

    def frame(self) -> int:
        """One frame: step what the clock owes (or one pending single step), run callbacks.

        Returns:
            Steps taken.
        """
        now = self._clock()
        h = self.sim.timestep
        elapsed = 0.0 if self._last is None else now - self._last
        self._last = now
        n = 0
        if self.paused:
            self._owed = 0.0
            if self._single:
                n, self._single = 1, self._single - 1
        else:
            self._owed += self.rate * elapsed
            n = min(int(self._owed / h + 1e-9), self.max_steps)
            # Behind by more than a step (max_lag reached): let it go.
            self._owed = min(self._owed - n * h, h)
        try:
            if n:
                self.sim.step(n)
            for cb in self.callbacks:
                cb(self.sim)
        except Exception as err:  # a page error must not stop the physics
            self.errors.append(err)
            del self.errors[:-10]
        self.frames += 1
        self._measure(now)
        return n

    def _measure(self, now: float) -> None:
        hist = self._history
        t_sim = self.sim.time
        if hist and (self.paused or t_sim < hist[-1][1]):  # paused or reset: start again
            hist.clear()
        hist.append((now, t_sim))
        while len(hist) > 2 and now - hist[0][0] > 2.0:
            hist.popleft()
        if len(hist) >= 2 and hist[-1][0] > hist[0][0]:
            self.real_time_factor = (hist[-1][1] - hist[0][1]) / (hist[-1][0] - hist[0][0])
        else:
            self.real_time_factor = float("nan")

    def start(self) -> None:
        """Start the thread (once)."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name="lab-sim", daemon=True)
            self._thread.start()

    def stop(self, timeout: float = 5.0) -> None:
        """Stop the thread and wait for it [s]."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout)

    @property
    def running(self) -> bool:
        """Whether the thread is alive."""
        return self._thread is not None and self._thread.is_alive()

    def _run(self) -> None:
        while not self._stop.is_set():
            start = self._clock()
            self.frame()
            self._stop.wait(max(0.0, self.period - (self._clock() - start)))


__all__ = ["RealTimeRunner", "Steppable"]

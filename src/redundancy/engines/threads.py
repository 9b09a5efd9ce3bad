"""The thread runner for stacks of poses: contiguous spans, one per thread, errors re-raised.

Results never depend on the thread count: each pose is computed by one thread, start to end,
with that thread's own engine data.
"""

from __future__ import annotations

import itertools
import threading
from collections.abc import Callable
from typing import Generic, TypeVar

import numpy as np

T = TypeVar("T")

#: Fewest poses per thread: below this a thread costs more than it saves (a 7-dof chain's
#: MuJoCo calls take 0.5-4 us per pose; starting a thread and its MjData takes ~100 us).
MIN_POSES_PER_THREAD = 256


def spans(n: int, threads: int) -> list[tuple[int, int]]:
    """Contiguous row ranges [lo, hi), one per thread (fewer for small n; at least one)."""
    k = max(1, min(threads, n // MIN_POSES_PER_THREAD))
    edges = np.linspace(0, n, k + 1).round().astype(int)
    return [(int(a), int(b)) for a, b in itertools.pairwise(edges)]


def run_split(n: int, threads: int, body: Callable[[int, int], None]) -> None:
    """Run ``body(lo, hi)`` over rows [0, n), split over up to ``threads`` threads.

    The caller's thread takes the first span; an exception in any thread is re-raised in
    the caller's after all have finished.
    """
    (lo, hi), *rest = spans(n, threads)
    run_beside(lambda: body(lo, hi), *(lambda a=a, b=b: body(a, b) for a, b in rest))


def run_beside(main: Callable[[], None], *sides: Callable[[], None]) -> None:
    """Run each of ``sides`` in a worker thread while ``main`` runs in the caller's.

    All are joined before returning; the first exception of any of them is re-raised in the
    caller's thread.
    """
    if not sides:
        main()
        return
    errors: list[BaseException] = []

    def guarded(f: Callable[[], None]) -> None:
        try:
            f()
        except BaseException as err:  # re-raised in the caller's thread
            errors.append(err)

    workers = [threading.Thread(target=guarded, args=(f,)) for f in sides]
    for w in workers:
        w.start()
    guarded(main)
    for w in workers:
        w.join()
    if errors:
        raise errors[0]


class PerThread(Generic[T]):
    """One value per thread: built by ``factory`` on the thread's first ``get``, freed with it.

    Engines keep their data (``MjData``, ``pinocchio.Data``, scratch buffers) in one, so
    threads never share engine data and no data outlives the thread that used it.
    """

    __slots__ = ("_factory", "_local")

    def __init__(self, factory: Callable[[], T]) -> None:
        self._factory = factory
        self._local = threading.local()

    def get(self) -> T:
        """This thread's value."""
        try:
            return self._local.value
        except AttributeError:
            value = self._local.value = self._factory()
            return value

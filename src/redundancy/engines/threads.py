"""The thread runner for stacks of poses: contiguous spans, one per thread, errors re-raised.

Results never depend on the thread count: each pose is computed by one thread, start to end,
with that thread's own engine data.
"""

from __future__ import annotations

import itertools
import os
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Generic, TypeVar

import numpy as np

from ..checks import max_threads

T = TypeVar("T")

#: Fewest poses per thread: below this a thread costs more than it saves (a 7-dof chain's
#: MuJoCo calls take 0.5-4 us per pose; handing a span to a worker takes ~100 us).
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


_pool: ThreadPoolExecutor | None = None
_pool_lock = threading.Lock()
_worker = threading.local()  # .active is True in the pool's own threads


def _mark_worker() -> None:
    _worker.active = True


def _workers() -> ThreadPoolExecutor:
    """The process's worker threads, one per usable CPU, started on first use.

    They live as long as the process, so their per-thread engine data (`PerThread`) stays warm from
    one call to the next: a fresh thread with a fresh ``MjData`` cost 6 ms per call on a 10 000-pose
    stack (first touches of its memory), a pooled one nothing. The data itself belongs to the engine
    and is freed with it.
    """
    global _pool
    with _pool_lock:
        if _pool is None:
            _pool = ThreadPoolExecutor(
                max_threads(), thread_name_prefix="redundancy", initializer=_mark_worker
            )
        return _pool


def _forget_workers() -> None:
    # A forked child has none of its parent's threads: start a pool of its own when needed.
    global _pool, _pool_lock
    _pool, _pool_lock = None, threading.Lock()


os.register_at_fork(after_in_child=_forget_workers)


def run_beside(main: Callable[[], None], *sides: Callable[[], None]) -> None:
    """Run ``sides`` on the worker threads while ``main`` runs in the caller's thread.

    All have finished when it returns; the first exception (``main``'s first) is re-raised
    in the caller's thread. A side must not wait for other work (a queue another thread
    fills): it would hold a worker that work may need. Called from a worker thread, the
    sides run there one after the other, so nested calls never wait for the pool.
    """
    if not sides or getattr(_worker, "active", False):
        for f in (main, *sides):
            f()
        return
    futures = [_workers().submit(f) for f in sides]
    error: BaseException | None = None
    try:
        main()
    except BaseException as err:  # re-raised once the sides have finished
        error = err
    for future in futures:
        try:
            future.result()
        except BaseException as err:
            error = error or err
    if error is not None:
        raise error


class PerThread(Generic[T]):
    """One value per thread: built by ``factory`` on the thread's first ``get``, freed with it.

    Engines keep their data (``MjData``, ``pinocchio.Data``, scratch buffers) in one, so
    threads never share engine data and no data outlives the thread that used it.
    """

    __slots__ = ("_factory", "local")

    def __init__(self, factory: Callable[[], T]) -> None:
        self._factory = factory
        #: The ``threading.local`` whose ``value`` is this thread's value once ``get`` built
        #: it; a hot path reads ``local.value`` itself and calls ``get`` on AttributeError.
        self.local: threading.local = threading.local()

    def get(self) -> T:
        """This thread's value."""
        try:
            return self.local.value  # type: ignore[no-any-return]
        except AttributeError:
            value = self.local.value = self._factory()
            return value

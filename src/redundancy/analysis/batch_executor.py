"""Batched functions on an executor: a stack sent to workers in chunks of poses, and back.

Any `concurrent.futures.Executor` (a ``ProcessPoolExecutor``, a Dask cluster's
``Client(...).get_executor()``) gets the stack in chunks (`scatter`); the arm travels as its
recipe (`redundancy.model.content`) and is rebuilt once per worker process and identity, and
the chunks' results are put back in order. `redundancy.analysis.batch` re-exports the public
names.
"""

from __future__ import annotations

import collections
import inspect
import threading
from collections.abc import Callable
from concurrent.futures import Executor, Future
from typing import Any, TypedDict, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..arm import Arm, check_arm
from ..checks import check_callable, check_count, check_options, check_poses, check_threads
from ..errors import ModelError, ParameterError, RedundancyError
from ..model.content import ContentUnavailable, Recipe
from ..model.loading import rebuild_arm

Array = NDArray[np.float64]
R = TypeVar("R")

#: Chunks sent to an executor hold at least this many poses (a task's overhead, a few ms
#: on a Dask cluster, stays small against its work) ...
EXECUTOR_MIN_CHUNK = 1024
#: ... and a stack is cut into at most this many chunks (so 10^8 poses are 256 tasks).
EXECUTOR_MAX_TASKS = 256


class RunOptions(TypedDict, total=False):
    """Where a batch function runs: the keywords every one of them takes.

    Attributes:
        threads: Worker threads (default 1). MuJoCo's calls release the GIL, Pinocchio's
            do not: each function says what its threads run.
        executor: Run on this `concurrent.futures.Executor` (a Dask cluster's
            ``Client(...).get_executor()``, a process pool) in chunks of poses; None
            (default) runs here. The results are the same, bit for bit.
    """

    threads: int
    executor: Executor | None


def check_run(run: RunOptions) -> tuple[int, Executor | None]:
    """The thread count checked, and the executor (`scatter` checks it when it is used).

    Raises:
        UnknownNameError: A keyword that is not one of `RunOptions`.
        ParameterError: ``threads`` not an integer >= 1 (more than `max_threads` run as many).
    """
    check_options(run, RunOptions)
    return check_threads(run.get("threads", 1)), run.get("executor")


def _poses(arm: Arm, Q: ArrayLike) -> Array:
    """The stack checked as `redundancy.analysis.batch.poses` checks it, (n, nq) float64."""
    return check_poses(Q, check_arm(arm).joint_names)


class _Shipped:
    """An arm on its way to an executor's worker.

    In the caller's process (a thread pool) it is the arm itself. Pickled (a process pool, a
    Dask worker) it is the arm's recipe (`redundancy.model.content`): lean (the files'
    paths and digests, not their bytes) unless ``recipe`` is given. Each worker process
    rebuilds the arm once per identity (`_arrive`) and keeps it for the next chunks. A
    worker that cannot rebuild it keeps the error, which the task raises: unpickling never
    fails, and the object pickles again as it came (Dask may move a task between workers).
    """

    __slots__ = ("arm", "error", "recipe")

    def __init__(
        self, arm: Arm | None, recipe: Recipe | None = None, error: Exception | None = None
    ) -> None:
        self.arm, self.recipe, self.error = arm, recipe, error

    def __reduce__(self) -> tuple[Callable[[Recipe], _Shipped], tuple[Recipe]]:
        return _arrive, (self.recipe or _recipe_of(self.arm).lean(),)


def _recipe_of(arm: Arm | None) -> Recipe:
    _, (recipe,) = arm.__reduce__()  # type: ignore[union-attr]
    return recipe  # type: ignore[no-any-return]


#: Arms rebuilt in this worker process, by identity (the digest of the files and options),
#: the most recently used last.
_ARRIVED: collections.OrderedDict[str, Arm] = collections.OrderedDict()
_ARRIVED_LOCK = threading.Lock()


def _arrive(recipe: Recipe) -> _Shipped:
    with _ARRIVED_LOCK:
        arm = _ARRIVED.get(recipe.digest)
        if arm is not None:
            _ARRIVED.move_to_end(recipe.digest)
            return _Shipped(arm, recipe)
    try:
        arm = rebuild_arm(recipe)
    except RedundancyError as err:
        return _Shipped(None, recipe, err)
    except Exception as err:  # an engine's own error: the task reports it, the worker lives on
        why = ModelError(f"cannot rebuild the arm of {recipe.shown!r}: {err}")
        return _Shipped(None, recipe, why)
    with _ARRIVED_LOCK:
        _ARRIVED[recipe.digest] = arm
        while len(_ARRIVED) > 8:
            _ARRIVED.popitem(last=False)
    return _Shipped(arm, recipe)


def _run_chunk(fn: Callable[..., R], shipped: _Shipped, Q: Array, kwargs: dict[str, Any]) -> R:
    """One task on a worker: ``fn`` on its chunk of poses, as in the caller's process."""
    if shipped.arm is None:
        raise shipped.error  # type: ignore[misc]
    return fn(shipped.arm, Q, **kwargs)


def map_chunks(
    executor: Executor,
    fn: Callable[..., R],
    arm: Arm,
    Q: Array,
    chunk: int | None = None,
    **kwargs: Any,
) -> list[tuple[int, R]]:
    """``fn(arm, Q[lo:hi], **kwargs)`` for consecutive chunks of ``Q``, run on ``executor``.

    Args:
        executor: Any `concurrent.futures.Executor`; a Dask cluster's ``Client(...).get_executor()``
            included.
        fn: A module-level function (it is pickled by name for a process or a cluster).
        arm: The arm (it must pickle: built by `redundancy.load` or ``load_string``).
            A worker rebuilds it from its files, or from their bytes, which the caller sends
            again with a chunk whose worker lacks them.
        Q: Poses, shape (n, nq).
        chunk: Poses per task; by default at least `EXECUTOR_MIN_CHUNK` and at most
            `EXECUTOR_MAX_TASKS` tasks.
        **kwargs: Passed to ``fn``.

    Returns:
        (first pose of the chunk, ``fn``'s result) per chunk, in order.

    Raises:
        ParameterError: ``executor`` is not a `concurrent.futures.Executor`, ``fn`` not callable,
            ``chunk`` not an integer >= 1.
        PoseError: ``Q`` not finite poses of the arm.
    """
    _check_executor(executor, fn, kwargs)
    return _map_chunks(executor, fn, arm, _poses(arm, Q), chunk, kwargs)


def _map_chunks(
    executor: Executor,
    fn: Callable[..., R],
    arm: Arm,
    Q: Array,
    chunk: int | None,
    kwargs: dict[str, Any],
) -> list[tuple[int, R]]:
    """`map_chunks` with the executor, ``fn`` and ``Q`` checked."""
    n = len(Q)
    if chunk is None:
        chunk = max(EXECUTOR_MIN_CHUNK, -(-n // EXECUTOR_MAX_TASKS))
    chunk = check_count("chunk", chunk, 1)
    shipped = _Shipped(arm)
    futures: list[tuple[int, Future[R]]] = []
    try:
        for lo in range(0, n, chunk):
            part = np.ascontiguousarray(Q[lo : lo + chunk])
            futures.append((lo, executor.submit(_run_chunk, fn, shipped, part, kwargs)))
        out = []
        for k, (lo, f) in enumerate(futures):
            try:
                out.append((lo, f.result()))
            except ContentUnavailable:
                # The worker does not have the files as they were loaded: send their bytes.
                part = np.ascontiguousarray(Q[lo : lo + chunk])
                futures[k] = (
                    lo,
                    executor.submit(_run_chunk, fn, _Shipped(arm, _recipe_of(arm)), part, kwargs),
                )
                out.append((lo, futures[k][1].result()))
        return out
    finally:  # an error or an interrupt: drop the tasks not yet started
        for _, f in futures:
            f.cancel()


def _scatter_rows(
    executor: Executor,
    fn: Callable[..., Array],
    arm: Arm,
    rows: Array,
    empty: Array,
    kwargs: dict[str, Any],
) -> Array:
    """``fn`` over checked rows (a pose and what travels beside it) in chunks on ``executor``.

    The chunks' results concatenated in order; ``empty`` when there are no rows.
    """
    _check_executor(executor, fn, kwargs)
    parts = _map_chunks(executor, fn, arm, rows, None, kwargs)
    return np.concatenate([r for _, r in parts]) if parts else empty


def _check_executor(executor: object, fn: object, kwargs: dict[str, Any]) -> None:
    """The executor, and ``fn`` callable as ``fn(arm, Q, **kwargs)``.

    What ``fn`` raises when it runs is its own, as with any executor.
    """
    if not isinstance(executor, Executor):
        raise ParameterError(
            "executor",
            executor,
            "None or a concurrent.futures.Executor (e.g. a Dask "
            "Client(...).get_executor(), a ProcessPoolExecutor)",
        )
    valid = "a module-level function fn(arm, Q, **kwargs)"
    check_callable("fn", fn, valid)
    try:
        inspect.signature(fn).bind(None, None, **kwargs)  # type: ignore[arg-type]
    except TypeError:
        raise ParameterError("fn", fn, valid) from None
    except ValueError:  # no signature to read (some builtins): calling it will tell
        pass


def scatter(
    executor: Executor, fn: Callable[..., Array], arm: Arm, Q: ArrayLike, **kwargs: Any
) -> Array:
    """A batch function's stacked result, computed in chunks on ``executor``.

    The one line that gives a batch function ``executor=``: ``fn`` is called locally on no
    poses first (so bad arguments raise here, not on a worker, and an empty stack has its
    shape), then on the chunks on the executor; the results are concatenated in order.

    Example:
        >>> def jacobians(arm, Q, engine="mujoco", threads=1, executor=None):
        ...     if executor is not None:
        ...         return scatter(executor, jacobians, arm, Q, engine=engine, threads=threads)
        ...     ...
    """
    _check_executor(executor, fn, kwargs)
    Q = _poses(arm, Q)
    empty = fn(arm, Q[:0], **kwargs)
    parts = [r for _, r in _map_chunks(executor, fn, arm, Q, None, kwargs)]
    return np.concatenate(parts, axis=0) if parts else empty

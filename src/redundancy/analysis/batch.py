"""Batched evaluation over a stack of poses, at close to the engines' own speed.

Every function takes a stack of joint configurations ``Q`` of shape (n, nq) and returns stacked
arrays, equal to what the single-pose methods of [`Arm`][redundancy.Arm] return pose by pose (bit
for bit; the tests hold them to it). What makes them fast:

* **No per-pose Python objects on the hot path.** The engines' stacked evaluation
  (`Engine.evaluate`) writes straight into the rows of preallocated output stacks (MuJoCo's
  ``mj_jacSite``, ``mj_fullM`` and ``mj_rne`` take output arrays); Pinocchio's post-processing
  (symmetrising ``crba``'s upper triangle, removing armature, reordering joints) is done once on the
  whole stack.
* **One call where the engine has one.** Pinocchio's gravity comes from
  ``pinocchio.rneaInParallel`` (RNEA with v = a = 0: the same sums as
  ``computeGeneralizedGravity``), one C++ call for the whole stack, on ``threads`` OpenMP
  threads. Singular values come from one ``np.linalg.svd`` call on the (n, 6, nv) stack.
* **Threads where the GIL allows.** MuJoCo's bindings release the GIL inside ``mj_*``;
  Pinocchio's never do. With ``threads > 1`` MuJoCo loops run on that many threads, each
  with its own ``MjData`` (a 7-dof chain's calls are 0.5-4 us, so the Python glue between
  them, which holds the GIL, limits the gain); NumPy's SVD releases the GIL, so
  `singular_values` overlaps the SVD of one chunk with the Jacobians of the next.
  Results do not depend on ``threads``: each pose is computed by one thread, start to end.
* **Other processes and machines with** ``executor=``. Any
  `concurrent.futures.Executor` (a ``ProcessPoolExecutor``, a Dask cluster's
  ``Client(...).get_executor()``) gets the stack in chunks of poses (`scatter`); the
  arm travels as its recipe (`redundancy.model.content`) and is rebuilt once per worker
  process and identity, and the chunks' results are put back in order. The arguments are
  checked and made plain values first, so what crosses is what the serial path uses. Every
  pose is computed by the same code as in the caller's process, so the results equal the
  serial ones bit for bit.

The singular values are NumPy's SVD (LAPACK ``gesdd`` without vectors), not the square roots
of the eigenvalues of the 6 x 6 Gram matrix J J^T: that closed form is faster but squares
the condition number, so near a singular pose the small singular values come out as
sqrt(eps) * sigma_max (about 1e-8 instead of 1e-16) and the rank is wrong (``scripts/bench.py``
measures both).
"""

from __future__ import annotations

import collections
import inspect
import itertools
import queue
import threading
from collections.abc import Callable
from concurrent.futures import Executor, Future
from typing import Any, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import kernels, linalg  # the unchecked kernels: the batch functions check input once
from ..arm import ENGINES, Arm, EngineName, _ik_settings, check_arm
from ..checks import (
    check_callable,
    check_choice,
    check_count,
    check_directions,
    check_flag,
    check_joint_subset,
    check_joint_vectors,
    check_number,
    check_poses,
    check_threads,
    check_tool_pose,
)
from ..collision import DistanceEngine, checker, distance_stack
from ..engines.contract import Stacks
from ..engines.threads import MIN_POSES_PER_THREAD, run_beside
from ..errors import ModelError, ParameterError, RedundancyError
from ..ik import DEFAULT_SETTINGS, IKResult
from ..linalg import MANIPULABILITY_KINDS, ManipulabilityKind
from ..model.content import ContentUnavailable, Recipe
from ..model.loading import rebuild_arm
from .observer import MomentumObserver, check_dt

Array = NDArray[np.float64]
R = TypeVar("R")

#: Chunks sent to an executor hold at least this many poses (a task's overhead, a few ms
#: on a Dask cluster, stays small against its work) ...
EXECUTOR_MIN_CHUNK = 1024
#: ... and a stack is cut into at most this many chunks (so 10^8 poses are 256 tasks).
EXECUTOR_MAX_TASKS = 256


def poses(arm: Arm, Q: ArrayLike) -> Array:
    """Validate a stack of joint configurations; return it as C-contiguous float64 (n, nq).

    Raises:
        PoseError: Not numeric, complex, not of shape (n, nq), or with NaN or infinite values.
        ParameterError: ``arm`` is not an Arm.
    """
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
    return _map_chunks(executor, fn, arm, poses(arm, Q), chunk, kwargs)


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
    Q = poses(arm, Q)
    empty = fn(arm, Q[:0], **kwargs)
    parts = [r for _, r in _map_chunks(executor, fn, arm, Q, None, kwargs)]
    return np.concatenate(parts, axis=0) if parts else empty


def _fill(arm: Arm, Q: Array, engine: str, threads: int, what: str, armature: bool = True) -> Array:
    """One quantity over a validated stack: allocate, let the engine fill it."""
    stacks = Stacks.empty(len(Q), arm.nq, (what,), armature)
    arm.engine(engine).evaluate(Q, stacks, threads)
    return getattr(stacks, what)  # type: ignore[no-any-return]


def _stack(
    arm: Arm, Q: ArrayLike, engine: str, threads: int, what: str, armature: bool = True
) -> Array:
    """One quantity over a stack: validate the inputs, then `_fill`."""
    check_choice("engine", engine, ENGINES)
    return _fill(arm, poses(arm, Q), engine, check_threads(threads), what, armature)


def jacobians(
    arm: Arm,
    Q: ArrayLike,
    engine: EngineName = "mujoco",
    threads: int = 1,
    executor: Executor | None = None,
) -> Array:
    """Site Jacobians of a stack of poses, as `Arm.jacobian`.

    Args:
        arm: The arm.
        Q: Poses, shape (n, nq) [rad or m].
        engine: ``"mujoco"`` or ``"pinocchio"``.
        threads: Worker threads (MuJoCo only; Pinocchio holds the GIL).
        executor: Run on this `concurrent.futures.Executor` (a Dask cluster's
            ``Client(...).get_executor()``, a process pool) in chunks of poses; None runs here. The
            results are the same, bit for bit.

    Returns:
        Jacobians, shape (n, 6, nq): linear rows [m/rad] then angular [rad/rad], world axes.
    """
    if executor is not None:
        return scatter(executor, jacobians, arm, Q, engine=engine, threads=threads)
    return _stack(arm, Q, engine, threads, "J")


def _svd_values(J: Array) -> Array:
    if len(J) == 0:
        return np.empty((0, min(J.shape[1:])))
    return np.linalg.svd(J, compute_uv=False)


def _jacobians_and_singular_values(
    arm: Arm, Q: Array, engine: EngineName, threads: int
) -> tuple[Array, Array]:
    """J of every pose and its singular values.

    With threads > 1 the SVD of one chunk runs in a worker thread (NumPy releases the GIL)
    while the engine computes the next chunk's Jacobians.
    """
    n = len(Q)
    if threads == 1 or n < 2 * MIN_POSES_PER_THREAD:
        J = _fill(arm, Q, engine, 1, "J")
        return J, _svd_values(J)
    J = np.empty((n, 6, arm.nq))
    S = np.empty((n, min(6, arm.nq)))
    chunk = max(MIN_POSES_PER_THREAD, n // 8)
    todo: queue.SimpleQueue[tuple[int, int] | None] = queue.SimpleQueue()

    def svds() -> None:
        while (span := todo.get()) is not None:
            S[span[0] : span[1]] = np.linalg.svd(J[span[0] : span[1]], compute_uv=False)

    def jacobians_in_chunks() -> None:
        try:
            for lo in range(0, n, chunk):
                hi = min(n, lo + chunk)
                arm.engine(engine).evaluate(Q[lo:hi], Stacks(J=J[lo:hi]), max(1, threads - 1))
                todo.put((lo, hi))
        finally:
            todo.put(None)  # the SVDs end even when a chunk raised

    # The Jacobians on a worker, the SVDs (which wait for them) in this thread: a worker
    # never waits for other work.
    run_beside(svds, jacobians_in_chunks)
    return J, S


def singular_values(
    arm: Arm,
    Q: ArrayLike,
    engine: EngineName = "mujoco",
    threads: int = 1,
    executor: Executor | None = None,
) -> Array:
    """Singular values of the site Jacobian at each pose, descending.

    Equal to ``linalg.yoshikawa``'s factors (``np.linalg.svd(J, compute_uv=False)``) bit for bit,
    and to `Arm.svd`'s ``sigma`` to rounding (1e-15 relative: that SVD also computes the vectors, by
    another LAPACK path).

    Args:
        arm: The arm.
        Q: Poses, shape (n, nq) [rad or m].
        engine: ``"mujoco"`` or ``"pinocchio"``.
        threads: With 2 or more, the Jacobians run on a worker thread alongside the SVDs.
        executor: Run on this `concurrent.futures.Executor` (a Dask cluster's
            ``Client(...).get_executor()``, a process pool) in chunks of poses; None runs here. The
            results are the same, bit for bit.

    Returns:
        Singular values, shape (n, min(6, nq)) [mixed units: m/rad and rad/rad].
    """
    if executor is not None:
        return scatter(executor, singular_values, arm, Q, engine=engine, threads=threads)
    check_choice("engine", engine, ENGINES)
    threads = check_threads(threads)
    return _jacobians_and_singular_values(arm, poses(arm, Q), engine, threads)[1]


def manipulabilities(
    arm: Arm,
    Q: ArrayLike,
    engine: EngineName = "mujoco",
    kind: ManipulabilityKind = "full",
    length: float = 1.0,
    threads: int = 1,
    executor: Executor | None = None,
) -> Array:
    """Yoshikawa's manipulability at each pose, as `linalg.manipulability`.

    The product of the singular values of the chosen rows of J (sqrt(det(J J^T)) with at least as
    many joints as rows, sqrt(det(J^T J)) with fewer:
    [`linalg.yoshikawa`][redundancy.linalg.yoshikawa]).

    Args:
        arm: The arm.
        Q: Poses, shape (n, nq) [rad or m].
        engine: ``"mujoco"`` or ``"pinocchio"``.
        kind: ``"full"`` (6 x n J, mixed units), ``"position"`` (linear rows [m^3/rad^3]),
            ``"orientation"`` (angular rows) or ``"scaled"`` (linear rows divided by ``length``,
            dimensionless); the fields of [`Manipulability`][redundancy.Manipulability].
        length: Characteristic length for ``"scaled"`` [m].
        threads: As in [`singular_values`][redundancy.analysis.batch.singular_values] (``"full"``
            only).
        executor: Run on this `concurrent.futures.Executor` (a Dask cluster's
            ``Client(...).get_executor()``, a process pool) in chunks of poses; None runs here. The
            results are the same, bit for bit.

    Returns:
        Manipulability per pose, shape (n,).
    """
    if executor is not None:
        return scatter(
            executor,
            manipulabilities,
            arm,
            Q,
            engine=engine,
            kind=kind,
            length=length,
            threads=threads,
        )
    check_choice("engine", engine, ENGINES)
    threads = check_threads(threads)
    check_choice("manipulability kind", kind, MANIPULABILITY_KINDS)
    length = check_number("length", length, 0.0, low_open=True, unit="m")
    Q = poses(arm, Q)
    if kind == "full":
        S = _jacobians_and_singular_values(arm, Q, engine, threads)[1]
        return np.prod(S, axis=1)
    J = _fill(arm, Q, engine, 1, "J")
    return np.prod(_svd_values(kernels.manipulability_rows(J, kind, length)), axis=1)


def mass_matrices(
    arm: Arm,
    Q: ArrayLike,
    armature: bool = True,
    engine: EngineName = "mujoco",
    threads: int = 1,
    executor: Executor | None = None,
) -> Array:
    """Joint-space mass matrices, as `Arm.mass_matrix`.

    Args:
        arm: The arm.
        Q: Poses, shape (n, nq) [rad or m].
        armature: Include armature on the diagonal.
        engine: ``"mujoco"`` or ``"pinocchio"``.
        threads: Worker threads (MuJoCo only).
        executor: Run on this `concurrent.futures.Executor` (a Dask cluster's
            ``Client(...).get_executor()``, a process pool) in chunks of poses; None runs here. The
            results are the same, bit for bit.

    Returns:
        Mass matrices, shape (n, nq, nq) [kg m^2].
    """
    armature = check_flag("armature", armature)
    if executor is not None:
        return scatter(
            executor, mass_matrices, arm, Q, armature=armature, engine=engine, threads=threads
        )
    return _stack(arm, Q, engine, threads, "M", armature)


def gravities(
    arm: Arm,
    Q: ArrayLike,
    engine: EngineName = "mujoco",
    threads: int = 1,
    executor: Executor | None = None,
) -> Array:
    """Gravity torques to hold each pose, as `Arm.gravity`.

    Args:
        arm: The arm.
        Q: Poses, shape (n, nq) [rad or m].
        engine: ``"mujoco"`` or ``"pinocchio"`` (``rneaInParallel`` on ``threads`` threads).
        threads: Worker threads.
        executor: Run on this `concurrent.futures.Executor` (a Dask cluster's
            ``Client(...).get_executor()``, a process pool) in chunks of poses; None runs here. The
            results are the same, bit for bit.

    Returns:
        Torques, shape (n, nq) [N m or N].
    """
    if executor is not None:
        return scatter(executor, gravities, arm, Q, engine=engine, threads=threads)
    return _stack(arm, Q, engine, threads, "G")


def distances(
    arm: Arm,
    Q: ArrayLike,
    engine: DistanceEngine = "coal",
    threads: int = 1,
    executor: Executor | None = None,
) -> Array:
    """Signed distance of every collision pair at each pose.

    Equal to
    [`CollisionChecker.distance_values`][redundancy.collision.CollisionChecker.distance_values] pose
    by pose; the pairs are ``redundancy.collision.checker(arm).pairs``, in that order.

    Args:
        arm: The arm.
        Q: Poses, shape (n, nq) [rad or m].
        engine: ``"coal"`` (geoms placed by Pinocchio) or ``"mujoco"`` (``mj_geomDistance``).
        threads: Worker threads (MuJoCo only).
        executor: Run on this `concurrent.futures.Executor` (a Dask cluster's
            ``Client(...).get_executor()``, a process pool) in chunks of poses; None runs here. The
            results are the same, bit for bit.

    Returns:
        Distances, shape (n, npairs), negative where the geoms overlap [m].
    """
    if executor is not None:
        return scatter(executor, distances, arm, Q, engine=engine, threads=threads)
    # distance_stack checks the engine, the poses and the threads.
    return distance_stack(checker(arm), Q, engine, threads)


# ------------------------------------------------------------------------------------------
# The mass a contact at the tool feels, and inverse kinematics, over many poses or targets
# ------------------------------------------------------------------------------------------


def _dynamics_inputs(
    arm: Arm, Q: ArrayLike, armature: object, joints: object, engine: object, threads: object
) -> tuple[Array, bool, tuple[str, ...] | None, str, int]:
    """The inputs of the tool-mass functions checked, in this order, and made plain values.

    ``joints`` (any iterable of names: a generator, a dict's keys, an array of names) is read
    once, here, into a tuple: what crosses to an executor's worker is the same plain tuple
    the serial path uses, so both give the same answer or the same error.
    """
    Q = poses(arm, Q)  # the arm checked first
    engine = check_choice("engine", engine, ENGINES)
    threads = check_threads(threads)
    if joints is not None and hasattr(joints, "__iter__") and not isinstance(joints, str | bytes):
        joints = tuple(joints)  # type: ignore[call-overload]
    check_joint_subset("joints", joints, arm.joint_names)
    armature = check_flag("armature", armature)
    return Q, armature, joints, engine, threads  # type: ignore[return-value]


def _mobilities(
    arm: Arm, Q: Array, armature: bool, joints: tuple[str, ...] | None, engine: str, threads: int
) -> tuple[Array, Array]:
    """J of the free joints and M_ff^-1 J_f^T over a stack (inputs checked)."""
    free = check_joint_subset("joints", joints, arm.joint_names)
    return arm.engine(engine).tool_mobilities(Q, armature, free, threads)


def _mobility_stack(
    fn: Callable[..., Array],
    kernel: Callable[[Array, Array, float], Array],
    arm: Arm,
    Q: ArrayLike,
    armature: object,
    joints: object,
    engine: object,
    threads: object,
    executor: Executor | None,
) -> Array:
    """A stack from the tool's mobilities: check, run ``fn`` on the executor's chunks, or here.

    ``kernel`` maps the stacks J, M^-1 J^T and the arm's motion floor (`linalg.motion_floor`)
    to the result.
    """
    Q, armature, joints, engine, threads = _dynamics_inputs(
        arm, Q, armature, joints, engine, threads
    )
    if executor is not None:
        return scatter(
            executor,
            fn,
            arm,
            Q,
            armature=armature,
            joints=joints,
            engine=engine,
            threads=threads,
        )
    J, X = _mobilities(arm, Q, armature, joints, engine, threads)
    return kernel(J, X, linalg.motion_floor(arm.length))


def operational_inertias(
    arm: Arm,
    Q: ArrayLike,
    *,
    armature: bool = True,
    joints: object = None,
    engine: EngineName = "mujoco",
    threads: int = 1,
    executor: Executor | None = None,
) -> Array:
    """Lambda at each pose, as `redundancy.Arm.operational_inertia`.

    Args:
        arm: The arm.
        Q: Poses, shape (n, nq) [rad or m].
        armature: Include armature in M.
        joints: Names of the joints free to move (the others held); None: all.
        engine: ``"mujoco"`` or ``"pinocchio"``.
        threads: Worker threads (MuJoCo only).
        executor: Run on this `concurrent.futures.Executor` in chunks of poses (see
            [`jacobians`][redundancy.analysis.batch.jacobians]); None runs here.

    Returns:
        Operational-space inertias, shape (n, 6, 6) [kg; kg m; kg m^2].

    Raises:
        SingularPoseError: At the first singular pose (the message names it and the lost
            tool directions).
    """

    def kernel(J: Array, X: Array, floor: float) -> Array:
        return kernels.operational_inertia(J, X, atol=floor) if len(J) else np.empty((0, 6, 6))

    return _mobility_stack(
        operational_inertias, kernel, arm, Q, armature, joints, engine, threads, executor
    )


def effective_masses(
    arm: Arm,
    Q: ArrayLike,
    direction: ArrayLike,
    *,
    armature: bool = True,
    joints: object = None,
    engine: EngineName = "mujoco",
    threads: int = 1,
    executor: Executor | None = None,
) -> Array:
    """Effective mass at the tool at each pose, as `redundancy.Arm.effective_mass`.

    Args:
        arm: The arm.
        Q: Poses, shape (n, nq) [rad or m].
        direction: One direction for every pose (3,) or one per pose (n, 3), world axes.
        armature: Include armature in M.
        joints: Names of the joints free to move (the others held); None: all.
        engine: ``"mujoco"`` or ``"pinocchio"``.
        threads: Worker threads (MuJoCo only).
        executor: Run on this `concurrent.futures.Executor` in chunks of poses (see
            [`jacobians`][redundancy.analysis.batch.jacobians]); None runs here.

    Returns:
        Effective masses, shape (n,) [kg]; ``inf`` where the tool cannot move along u.
    """
    Q, armature, joints, engine, threads = _dynamics_inputs(
        arm, Q, armature, joints, engine, threads
    )
    U = check_directions("direction", direction, len(Q))
    if executor is not None:
        # Each pose travels with its direction: one row of (n, nq + 3).
        kwargs = {"armature": armature, "joints": joints, "engine": engine, "threads": threads}
        _check_executor(executor, _effective_masses_of_rows, kwargs)
        QU = np.concatenate([Q, U], axis=1)
        parts = _map_chunks(executor, _effective_masses_of_rows, arm, QU, None, kwargs)
        return np.concatenate([r for _, r in parts]) if parts else np.empty(0)
    J, X = _mobilities(arm, Q, armature, joints, engine, threads)
    return kernels.effective_masses(J, X, U, atol=linalg.motion_floor(arm.length))


def _effective_masses_of_rows(
    arm: Arm, QU: Array, armature: bool, joints: tuple[str, ...] | None, engine: str, threads: int
) -> Array:
    """`effective_masses` of a chunk of rows (pose, unit direction), on a worker."""
    Q, U = np.ascontiguousarray(QU[:, : arm.nq]), np.ascontiguousarray(QU[:, arm.nq :])
    J, X = _mobilities(arm, Q, armature, joints, engine, threads)
    return kernels.effective_masses(J, X, U, atol=linalg.motion_floor(arm.length))


def effective_mass_ranges(
    arm: Arm,
    Q: ArrayLike,
    *,
    armature: bool = True,
    joints: object = None,
    engine: EngineName = "mujoco",
    threads: int = 1,
    executor: Executor | None = None,
) -> Array:
    """Least and greatest effective mass over directions at each pose, shape (n, 2) [kg].

    As `Arm.effective_mass_range`'s ``min`` and ``max`` (arguments as
    [`effective_masses`][redundancy.analysis.batch.effective_masses]).
    """

    def kernel(J: Array, X: Array, floor: float) -> Array:
        return kernels.effective_mass_ranges(J, X, atol=floor) if len(J) else np.empty((0, 2))

    return _mobility_stack(
        effective_mass_ranges, kernel, arm, Q, armature, joints, engine, threads, executor
    )


def dynamic_manipulabilities(
    arm: Arm,
    Q: ArrayLike,
    *,
    armature: bool = True,
    joints: object = None,
    engine: EngineName = "mujoco",
    threads: int = 1,
    executor: Executor | None = None,
) -> Array:
    """Yoshikawa's dynamic manipulability at each pose, shape (n,).

    As `Arm.dynamic_manipulability` (arguments as
    [`effective_masses`][redundancy.analysis.batch.effective_masses]).
    """

    def kernel(J: Array, X: Array, floor: float) -> Array:
        if not len(J):
            return np.zeros(0)
        return np.asarray(kernels.dynamic_manipulability(X), dtype=np.float64).reshape(len(J))

    return _mobility_stack(
        dynamic_manipulabilities, kernel, arm, Q, armature, joints, engine, threads, executor
    )


def solve_ik(
    arm: Arm,
    targets: object,
    Q0: ArrayLike | None = None,
    *,
    objective: object = None,
    position_only: bool = False,
    position_tol: float = DEFAULT_SETTINGS.position_tol,
    orientation_tol: float = DEFAULT_SETTINGS.orientation_tol,
    restarts: int = DEFAULT_SETTINGS.restarts,
    seed: int | None = 0,
    engine: EngineName = "mujoco",
    threads: int = 1,
) -> tuple[IKResult, ...]:
    """`Arm.solve_ik` for many targets, on ``threads`` threads.

    Result ``i`` is ``arm.solve_ik(targets[i], Q0[i], seed=seed + i, ...)`` whatever the
    thread count (each target is solved by one thread, start to end).

    Args:
        arm: The arm.
        targets: A sequence of targets (each a 4 x 4 pose or a (position, rotation) pair),
            or an array of poses (n, 4, 4).
        Q0: Starts, shape (n, nq) [rad or m]; None: each from the middle of the ranges.
        objective: As [`Arm.solve_ik`][redundancy.arm.Arm.solve_ik].
        position_only: As [`Arm.solve_ik`][redundancy.arm.Arm.solve_ik].
        position_tol: As [`Arm.solve_ik`][redundancy.arm.Arm.solve_ik] [m].
        orientation_tol: As [`Arm.solve_ik`][redundancy.arm.Arm.solve_ik] [rad].
        restarts: As [`Arm.solve_ik`][redundancy.arm.Arm.solve_ik].
        seed: Target ``i`` uses ``seed + i`` (None: fresh entropy for each).
        engine: As [`Arm.solve_ik`][redundancy.arm.Arm.solve_ik].
        threads: Worker threads. The solver is mostly Python, which holds the GIL, so
            threads gain little beyond MuJoCo's own calls.

    Returns:
        One [`IKResult`][redundancy.IKResult] per target.

    Raises:
        ParameterError: A bad target (named by its index), a bad count of starts.
    """
    arm = check_arm(arm)
    threads = check_threads(threads)
    check_choice("engine", engine, ENGINES)
    check_flag("position_only", position_only)
    _ik_settings(position_tol, orientation_tol, restarts)  # bad ones fail here, not in a thread
    if isinstance(targets, np.ndarray) and targets.ndim == 3:
        items = list(targets)
    elif isinstance(targets, list | tuple):
        items = list(targets)
    else:
        raise ParameterError(
            "targets", targets, "a sequence of targets or an array of poses of shape (n, 4, 4)"
        )
    goals = [check_tool_pose(f"targets[{i}]", t) for i, t in enumerate(items)]
    n = len(goals)
    starts = None if Q0 is None else poses(arm, Q0)
    if starts is not None and len(starts) != n:
        raise ParameterError("Q0", f"{len(starts)} poses", f"None or one start per target ({n})")
    if seed is not None:
        seed = check_count("seed", seed, 0)
    arm.ik_objective(objective, engine)  # a bad objective fails here, not in a worker
    out: list[IKResult | None] = [None] * n

    def span(lo: int, hi: int) -> None:
        for i in range(lo, hi):
            out[i] = arm.solve_ik(
                goals[i],
                None if starts is None else starts[i],
                objective=objective,
                position_only=position_only,
                position_tol=position_tol,
                orientation_tol=orientation_tol,
                restarts=restarts,
                seed=None if seed is None else seed + i,
                engine=engine,
            )

    if n:
        # A solve takes ~1 ms: spans of any length are worth a thread.
        edges = np.linspace(0, n, min(threads, n) + 1).round().astype(int)
        jobs = [(int(a), int(b)) for a, b in itertools.pairwise(edges)]
        (lo, hi), *rest = jobs
        run_beside(lambda: span(lo, hi), *(lambda a=a, b=b: span(a, b) for a, b in rest))
    return tuple(r for r in out if r is not None)


def coriolis(
    arm: Arm,
    Q: ArrayLike,
    V: ArrayLike,
    *,
    engine: EngineName = "mujoco",
    threads: int = 1,
    executor: Executor | None = None,
) -> Array:
    """Coriolis matrices of a stack of states, as `Arm.coriolis <redundancy.Arm.coriolis>`.

    Equal to the single calls bit for bit: each pose runs the same engine calls in the
    same order.

    Args:
        arm: The arm.
        Q: Poses, shape (n, nq) [rad or m].
        V: Joint velocities, one per pose, shape (n, nq) [rad/s or m/s].
        engine: ``"mujoco"`` or ``"pinocchio"``.
        threads: Worker threads (MuJoCo only; Pinocchio holds the GIL).
        executor: Run on this `concurrent.futures.Executor` in chunks of states (see
            `jacobians`); None runs here.

    Returns:
        Coriolis matrices in the Christoffel form, shape (n, nq, nq) [N m s/rad].

    Raises:
        PoseError: ``Q`` not finite poses, ``V`` not finite and of the same shape.
    """
    arm = check_arm(arm)
    check_choice("engine", engine, ENGINES)
    threads = check_threads(threads)
    Q = poses(arm, Q)
    V = check_joint_vectors("velocities", V, arm.joint_names, len(Q))
    nq = arm.nq
    if executor is not None:
        # The poses and velocities travel side by side, (n, 2 nq), chunked as poses are.
        kwargs = {"engine": engine, "threads": threads}
        _check_executor(executor, _coriolis_of_states, kwargs)
        parts = _map_chunks(executor, _coriolis_of_states, arm, np.hstack((Q, V)), None, kwargs)
        return np.concatenate([r for _, r in parts]) if parts else np.empty((0, nq, nq))
    out = np.empty((len(Q), nq, nq))
    arm.engine(engine).coriolis_stack(Q, V, out, threads)
    return out


def _coriolis_of_states(arm: Arm, QV: Array, engine: EngineName, threads: int) -> Array:
    """`coriolis` of a chunk of states laid side by side, (n, 2 nq), on a worker."""
    nq = arm.nq
    return coriolis(arm, QV[:, :nq], QV[:, nq:], engine=engine, threads=threads)


def external_torques(
    arm: Arm,
    Q: ArrayLike,
    V: ArrayLike,
    TAU: ArrayLike,
    dt: object,
    gain: object,
    *,
    executor: Executor | None = None,
) -> Array:
    """A recorded trajectory through a `MomentumObserver`, step by step.

    Equal to ``obs = MomentumObserver(arm, gain)`` and ``obs.update(Q[k], V[k], TAU[k],
    dt[k])`` for every k, bit for bit: the model's terms of every step (M v, C^T v - g and
    the passive force) are the same engine calls, here or on an executor's workers, and the
    observer then advances through them in order.

    Args:
        arm: The arm.
        Q: Poses at the steps, shape (n, nq) [rad or m].
        V: Joint velocities at the steps, shape (n, nq) [rad/s or m/s].
        TAU: The actuators' torque applied from each step to the next (MuJoCo's
            ``qfrc_actuator``), shape (n, nq) [N m or N].
        dt: Time from each step to the next [s], one number or one per step (n,), in
            (0, 2 / gain).
        gain: The observer's gain K [1/s], a number or one per joint.
        executor: Compute the model's terms on this `concurrent.futures.Executor`
            in chunks of steps (see `jacobians`); None: here.

    Returns:
        The estimated external joint torque at each step, shape (n, nq) [N m or N].

    Raises:
        PoseError: ``Q``, ``V`` or ``TAU`` not finite, or of different shapes.
        ParameterError: A bad ``dt`` or ``gain``.
    """
    arm = check_arm(arm)
    observer = MomentumObserver(arm, gain)
    Q = poses(arm, Q)
    n = len(Q)
    V = check_joint_vectors("velocities", V, arm.joint_names, n)
    TAU = check_joint_vectors("torques", TAU, arm.joint_names, n)
    steps = check_dt(dt, observer.max_dt)
    if steps.ndim == 0:
        steps = np.full(n, float(steps))
    elif steps.shape != (n,):
        raise ParameterError("dt", dt, f"a number or one per step, shape ({n},) [s]")
    nq = arm.nq
    if executor is not None:
        _check_executor(executor, _momentum_terms_of_states, {})
        parts = _map_chunks(executor, _momentum_terms_of_states, arm, np.hstack((Q, V)), None, {})
        terms = np.concatenate([r for _, r in parts]) if parts else np.empty((0, 2 * nq))
    else:
        terms = _momentum_terms_of_states(arm, np.hstack((Q, V)))
    out = np.empty((n, nq))
    for k in range(n):
        out[k] = observer.advance(terms[k, :nq], terms[k, nq:], TAU[k], float(steps[k]))
    return out


def _momentum_terms_of_states(arm: Arm, QV: Array) -> Array:
    """The observer's terms of states laid side by side, (n, 2 nq) -> (n, 2 nq).

    Each row [q, v] gives [p, beta] (`MujocoEngine.momentum_terms
    <redundancy.engines.mujoco.MujocoEngine.momentum_terms>`).
    """
    nq = arm.nq
    out = np.empty((len(QV), 2 * nq))
    terms = arm.mujoco.momentum_terms
    for row, qv in zip(out, QV, strict=True):
        p, beta = terms(qv[:nq], qv[nq:])
        row[:nq] = p
        row[nq:] = beta
    return out

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

import itertools
import queue
from concurrent.futures import Executor
from typing import Any, Unpack

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import ik, kernels  # the unchecked kernels: the batch functions check input once
from ..arm import ENGINES, Arm, EngineName, check_arm
from ..checks import (
    check_choice,
    check_count,
    check_flag,
    check_number,
    check_poses,
    check_tool_pose,
)
from ..collision import DistanceEngine, checker, distance_stack
from ..engines.contract import Stacks
from ..engines.threads import MIN_POSES_PER_THREAD, run_beside
from ..errors import ParameterError
from ..ik import DEFAULT_SETTINGS, IKResult
from ..linalg import MANIPULABILITY_KINDS, ManipulabilityKind
from .batch_dynamics import (
    BatchToolMassOptions,
    coriolis,
    dynamic_manipulabilities,
    effective_mass_ranges,
    effective_masses,
    external_torques,
    operational_inertias,
)
from .batch_executor import (
    EXECUTOR_MAX_TASKS,
    EXECUTOR_MIN_CHUNK,
    RunOptions,
    _check_executor,
    _map_chunks,
    check_run,
    map_chunks,
    scatter,
)

__all__ = [
    "EXECUTOR_MAX_TASKS",
    "EXECUTOR_MIN_CHUNK",
    "BatchToolMassOptions",
    "RunOptions",
    "coriolis",
    "distances",
    "dynamic_manipulabilities",
    "effective_mass_ranges",
    "effective_masses",
    "external_torques",
    "gravities",
    "jacobians",
    "manipulabilities",
    "map_chunks",
    "mass_matrices",
    "operational_inertias",
    "poses",
    "scatter",
    "singular_values",
    "solve_ik",
]

Array = NDArray[np.float64]


def poses(arm: Arm, Q: ArrayLike) -> Array:
    """Validate a stack of joint configurations; return it as C-contiguous float64 (n, nq).

    Raises:
        PoseError: Not numeric, complex, not of shape (n, nq), or with NaN or infinite values.
        ParameterError: ``arm`` is not an Arm.
    """
    return check_poses(Q, check_arm(arm).joint_names)


def _fill(arm: Arm, Q: Array, engine: str, threads: int, what: str, armature: bool = True) -> Array:
    """One quantity over a validated stack: allocate, let the engine fill it."""
    stacks = Stacks.empty(len(Q), arm.nq, (what,), armature)
    arm.engine(engine).evaluate(Q, stacks, threads)
    return getattr(stacks, what)  # type: ignore[no-any-return]


def _stack(
    arm: Arm, Q: ArrayLike, engine: str, threads: int, what: str, armature: bool = True
) -> Array:
    """One quantity over a stack: the engine and poses checked, then `_fill` (threads checked)."""
    check_choice("engine", engine, ENGINES)
    return _fill(arm, poses(arm, Q), engine, threads, what, armature)


def jacobians(
    arm: Arm, Q: ArrayLike, engine: EngineName = "mujoco", **run: Unpack[RunOptions]
) -> Array:
    """Site Jacobians of a stack of poses, as `Arm.jacobian`.

    The batch functions share these arguments; their docstrings refer here.

    Args:
        arm: The arm.
        Q: Poses, shape (n, nq) [rad or m].
        engine: ``"mujoco"`` or ``"pinocchio"``.
        **run: ``threads`` (MuJoCo only; Pinocchio holds the GIL) and ``executor``, as
            [`RunOptions`][redundancy.analysis.batch.RunOptions] states.

    Returns:
        Jacobians, shape (n, 6, nq): linear rows [m/rad] then angular [rad/rad], world axes.
    """
    threads, executor = check_run(run)
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
    arm: Arm, Q: ArrayLike, engine: EngineName = "mujoco", **run: Unpack[RunOptions]
) -> Array:
    """Singular values of the site Jacobian at each pose, descending.

    Equal to ``linalg.yoshikawa``'s factors (``np.linalg.svd(J, compute_uv=False)``) bit for bit,
    and to `Arm.svd`'s ``sigma`` to rounding (1e-15 relative: that SVD also computes the vectors, by
    another LAPACK path).

    Arguments as `jacobians`; with 2 or more ``threads`` the Jacobians run on a worker thread
    alongside the SVDs.

    Returns:
        Singular values, shape (n, min(6, nq)) [mixed units: m/rad and rad/rad].
    """
    threads, executor = check_run(run)
    if executor is not None:
        return scatter(executor, singular_values, arm, Q, engine=engine, threads=threads)
    check_choice("engine", engine, ENGINES)
    return _jacobians_and_singular_values(arm, poses(arm, Q), engine, threads)[1]


def manipulabilities(
    arm: Arm,
    Q: ArrayLike,
    engine: EngineName = "mujoco",
    kind: ManipulabilityKind = "full",
    length: float = 1.0,
    **run: Unpack[RunOptions],
) -> Array:
    """Yoshikawa's manipulability at each pose, as `linalg.manipulability`.

    The product of the singular values of the chosen rows of J (sqrt(det(J J^T)) with at least as
    many joints as rows, sqrt(det(J^T J)) with fewer:
    [`linalg.yoshikawa`][redundancy.linalg.yoshikawa]).

    Args:
        arm: As in `jacobians`.
        Q: As in `jacobians`.
        engine: As in `jacobians`.
        kind: ``"full"`` (6 x n J, mixed units), ``"position"`` (linear rows [m^3/rad^3]),
            ``"orientation"`` (angular rows) or ``"scaled"`` (linear rows divided by ``length``,
            dimensionless); the fields of [`Manipulability`][redundancy.Manipulability].
        length: Characteristic length for ``"scaled"`` [m].
        **run: As in `jacobians`; ``threads`` as in
            [`singular_values`][redundancy.analysis.batch.singular_values] (``"full"`` only).

    Returns:
        Manipulability per pose, shape (n,).
    """
    threads, executor = check_run(run)
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
    **run: Unpack[RunOptions],
) -> Array:
    """Joint-space mass matrices, as `Arm.mass_matrix`.

    With ``armature`` (default True) the motors' armature is on the diagonal; the other
    arguments are `jacobians`'.

    Returns:
        Mass matrices, shape (n, nq, nq) [kg m^2].
    """
    armature = check_flag("armature", armature)
    threads, executor = check_run(run)
    if executor is not None:
        return scatter(
            executor, mass_matrices, arm, Q, armature=armature, engine=engine, threads=threads
        )
    return _stack(arm, Q, engine, threads, "M", armature)


def gravities(
    arm: Arm, Q: ArrayLike, engine: EngineName = "mujoco", **run: Unpack[RunOptions]
) -> Array:
    """Gravity torques to hold each pose, as `Arm.gravity` (arguments as `jacobians`).

    Pinocchio runs ``rneaInParallel`` on ``threads`` threads; MuJoCo runs that many threads,
    each with its own ``MjData``.

    Returns:
        Torques, shape (n, nq) [N m or N].
    """
    threads, executor = check_run(run)
    if executor is not None:
        return scatter(executor, gravities, arm, Q, engine=engine, threads=threads)
    return _stack(arm, Q, engine, threads, "G")


def distances(
    arm: Arm, Q: ArrayLike, engine: DistanceEngine = "coal", **run: Unpack[RunOptions]
) -> Array:
    """Signed distance of every collision pair at each pose.

    Equal to
    [`CollisionChecker.distance_values`][redundancy.collision.CollisionChecker.distance_values] pose
    by pose; the pairs are ``redundancy.collision.checker(arm).pairs``, in that order.

    Arguments as `jacobians`, but for ``engine``: ``"coal"`` (default; the geoms placed by
    Pinocchio) or ``"mujoco"`` (``mj_geomDistance``).

    Returns:
        Distances, shape (n, npairs), negative where the geoms overlap [m].
    """
    threads, executor = check_run(run)
    if executor is not None:
        return scatter(executor, distances, arm, Q, engine=engine, threads=threads)
    # distance_stack checks the engine, the poses and the threads.
    return distance_stack(checker(arm), Q, engine, threads)


# ------------------------------------------------------------------------------------------
# Inverse kinematics over many targets
# ------------------------------------------------------------------------------------------


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
    **run: Unpack[RunOptions],
) -> tuple[IKResult, ...]:
    """`Arm.solve_ik` for many targets, on ``threads`` threads or an executor's workers.

    Result ``i`` is ``arm.solve_ik(targets[i], Q0[i], seed=seed + i, ...)`` whatever the
    thread count or the executor (each target is solved by one thread, start to end).

    Args:
        arm: The arm.
        targets: A sequence of targets (each a 4 x 4 pose or a (position, rotation) pair),
            or an array of poses (n, 4, 4).
        Q0: Starts, shape (n, nq) [rad or m]; None: each from the middle of the ranges.
        objective: As [`Arm.solve_ik`][redundancy.arm.Arm.solve_ik] (with an executor
            of other processes, it must pickle).
        position_only: As [`Arm.solve_ik`][redundancy.arm.Arm.solve_ik].
        position_tol: As [`Arm.solve_ik`][redundancy.arm.Arm.solve_ik] [m].
        orientation_tol: As [`Arm.solve_ik`][redundancy.arm.Arm.solve_ik] [rad].
        restarts: As [`Arm.solve_ik`][redundancy.arm.Arm.solve_ik].
        seed: Target ``i`` uses ``seed + i`` (None: fresh entropy for each).
        engine: As [`Arm.solve_ik`][redundancy.arm.Arm.solve_ik].
        **run: ``threads`` (worker threads; the solver is mostly Python, which holds the
            GIL, so threads gain little beyond MuJoCo's own calls) and ``executor`` (the
            targets in chunks on its workers), as in `jacobians`.

    Returns:
        One [`IKResult`][redundancy.IKResult] per target.

    Raises:
        ParameterError: A bad target (named by its index), a bad count of starts.
        UnknownNameError: A keyword that is not one of the above.
    """
    arm = check_arm(arm)
    threads, executor = check_run(run)
    check_choice("engine", engine, ENGINES)
    check_flag("position_only", position_only)
    ik.checked_settings(
        position_tol, orientation_tol, restarts
    )  # bad ones fail here, not in a thread
    goals, starts = _ik_targets(arm, targets, Q0)
    if seed is not None:
        seed = check_count("seed", seed, 0)
    arm.ik_objective(objective, engine)  # a bad objective fails here, not in a worker
    settings = {
        "objective": objective,
        "position_only": position_only,
        "position_tol": position_tol,
        "orientation_tol": orientation_tol,
        "restarts": restarts,
        "engine": engine,
    }
    if executor is None:
        return _solve_targets(arm, goals, starts, 0, seed, threads, settings)
    return _solve_on(executor, arm, goals, starts, seed, threads, settings)


def _solve_on(
    executor: Executor,
    arm: Arm,
    goals: list[tuple[Array, Array]],
    starts: Array | None,
    seed: int | None,
    threads: int,
    settings: dict[str, object],
) -> tuple[IKResult, ...]:
    """`solve_ik`'s checked targets in chunks on ``executor``, the results in order."""
    # A row per target: its index, its start (zeros for none), its position and rotation.
    n, nq = len(goals), arm.nq
    rows = np.zeros((n, 13 + nq))
    rows[:, 0] = np.arange(n)
    if starts is not None:
        rows[:, 1 : 1 + nq] = starts
    for row, (p, R) in zip(rows, goals, strict=True):
        row[1 + nq : 4 + nq], row[4 + nq :] = p, R.ravel()
    kwargs = {"has_starts": starts is not None, "seed": seed, "threads": threads}
    kwargs["settings"] = settings
    _check_executor(executor, _solve_ik_rows, kwargs)
    # A solve takes milliseconds: chunks of a few targets are worth a task.
    chunk = max(4, -(-n // EXECUTOR_MAX_TASKS))
    parts = _map_chunks(executor, _solve_ik_rows, arm, rows, chunk, kwargs)
    return tuple(r for _, part in parts for r in part)


def _solve_ik_rows(
    arm: Arm,
    rows: Array,
    has_starts: bool,
    seed: int | None,
    threads: int,
    settings: dict[str, object],
) -> tuple[IKResult, ...]:
    """`solve_ik` of a chunk of rows (index, start, position, rotation), on a worker."""
    nq = arm.nq
    goals = [(r[1 + nq : 4 + nq].copy(), r[4 + nq :].reshape(3, 3).copy()) for r in rows]
    starts = np.ascontiguousarray(rows[:, 1 : 1 + nq]) if has_starts else None
    first = int(rows[0, 0]) if len(rows) else 0
    return _solve_targets(arm, goals, starts, first, seed, threads, settings)


def _solve_targets(
    arm: Arm,
    goals: list[tuple[Array, Array]],
    starts: Array | None,
    first: int,
    seed: int | None,
    threads: int,
    settings: dict[str, Any],
) -> tuple[IKResult, ...]:
    """Checked targets solved on ``threads`` threads; target ``i`` is ``first + i`` overall."""
    n = len(goals)
    out: list[IKResult | None] = [None] * n

    def span(lo: int, hi: int) -> None:
        for i in range(lo, hi):
            out[i] = arm.solve_ik(
                goals[i],
                None if starts is None else starts[i],
                seed=None if seed is None else seed + first + i,
                **settings,
            )

    if n:
        # A solve takes ~1 ms: spans of any length are worth a thread.
        edges = np.linspace(0, n, min(threads, n) + 1).round().astype(int)
        jobs = [(int(a), int(b)) for a, b in itertools.pairwise(edges)]
        (lo, hi), *rest = jobs
        run_beside(lambda: span(lo, hi), *(lambda a=a, b=b: span(a, b) for a, b in rest))
    return tuple(r for r in out if r is not None)


def _ik_targets(
    arm: Arm, targets: object, Q0: ArrayLike | None
) -> tuple[list[tuple[Array, Array]], Array | None]:
    """`solve_ik`'s targets checked (each named by its index), and its starts, one per target."""
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
    return goals, starts

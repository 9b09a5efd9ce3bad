"""The mass a contact at the tool feels, and the joint dynamics of states, over many poses.

Batched as the rest of `redundancy.analysis.batch`, which re-exports the public names: the
inputs are checked once, the engines fill whole stacks, and ``executor=`` sends chunks of poses
to workers (`redundancy.analysis.batch_executor`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Unpack

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import kernels, linalg  # the unchecked kernels: the batch functions check input once
from ..arm import ENGINES, Arm, EngineName, check_arm
from ..arm_mass import ToolMassOptions
from ..checks import (
    check_choice,
    check_directions,
    check_flag,
    check_joint_subset,
    check_joint_vectors,
    check_options,
    check_threads,
)
from ..engines.threads import run_split
from ..errors import ParameterError
from .batch_executor import RunOptions, _poses, _scatter_rows, check_run, scatter
from .observer import MomentumObserver, check_dt

Array = NDArray[np.float64]


class BatchToolMassOptions(ToolMassOptions, RunOptions, total=False):
    """The keywords the batch tool-mass functions share: the single pose's and where to run.

    ``armature``, ``joints`` and ``engine`` as in
    [`ToolMassOptions`][redundancy.arm_mass.ToolMassOptions]; ``threads`` (MuJoCo's calls, or
    Pinocchio's stacked ones) and ``executor`` as in
    [`RunOptions`][redundancy.analysis.batch.RunOptions].
    """


def _dynamics_inputs(
    arm: Arm, Q: ArrayLike, options: BatchToolMassOptions
) -> tuple[Array, bool, tuple[str, ...] | None, str, int]:
    """The inputs of the tool-mass functions checked, in this order, and made plain values.

    ``joints`` (any iterable of names: a generator, a dict's keys, an array of names) is read
    once, here, into a tuple: what crosses to an executor's worker is the same plain tuple
    the serial path uses, so both give the same answer or the same error.
    """
    Q = _poses(arm, Q)  # the arm checked first
    check_options(options, BatchToolMassOptions)
    engine = check_choice("engine", options.get("engine", "mujoco"), ENGINES)
    threads = check_threads(options.get("threads", 1))
    joints = options.get("joints")
    if joints is not None and hasattr(joints, "__iter__") and not isinstance(joints, str | bytes):
        try:
            joints = tuple(joints)
        except TypeError:  # a 0-d array has __iter__ and cannot be iterated: refused below
            pass
    check_joint_subset("joints", joints, arm.joint_names)
    armature = check_flag("armature", options.get("armature", True))
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
    options: BatchToolMassOptions,
) -> Array:
    """A stack from the tool's mobilities: check, run ``fn`` on the executor's chunks, or here.

    ``kernel`` maps the stacks J, M^-1 J^T and the arm's motion floor (`linalg.motion_floor`)
    to the result.
    """
    Q, armature, joints, engine, threads = _dynamics_inputs(arm, Q, options)
    executor = options.get("executor")
    if executor is not None:
        kwargs = {"armature": armature, "joints": joints, "engine": engine, "threads": threads}
        return scatter(executor, fn, arm, Q, **kwargs)
    J, X = _mobilities(arm, Q, armature, joints, engine, threads)
    return kernel(J, X, linalg.motion_floor(arm.length))


def operational_inertias(arm: Arm, Q: ArrayLike, **options: Unpack[BatchToolMassOptions]) -> Array:
    """Lambda at each pose, as `redundancy.Arm.operational_inertia`.

    Args:
        arm: As in [`jacobians`][redundancy.analysis.batch.jacobians].
        Q: As in [`jacobians`][redundancy.analysis.batch.jacobians].
        **options: ``armature``, ``joints``, ``engine``, ``threads`` and ``executor``, as
            [`BatchToolMassOptions`][redundancy.analysis.batch.BatchToolMassOptions]
            states; the other tool-mass functions take the same.

    Returns:
        Operational-space inertias, shape (n, 6, 6) [kg; kg m; kg m^2].

    Raises:
        SingularPoseError: At the first singular pose (the message names it and the lost
            tool directions).
        UnknownNameError: A joint or engine name the arm does not have, or a keyword that is
            not one of the options.
    """

    def kernel(J: Array, X: Array, floor: float) -> Array:
        return kernels.operational_inertia(J, X, atol=floor) if len(J) else np.empty((0, 6, 6))

    return _mobility_stack(operational_inertias, kernel, arm, Q, options)


def effective_masses(
    arm: Arm, Q: ArrayLike, direction: ArrayLike, **options: Unpack[BatchToolMassOptions]
) -> Array:
    """Effective mass at the tool at each pose, as `redundancy.Arm.effective_mass`.

    Args:
        arm: As in [`jacobians`][redundancy.analysis.batch.jacobians].
        Q: As in [`jacobians`][redundancy.analysis.batch.jacobians].
        direction: One direction for every pose (3,) or one per pose (n, 3), world axes.
        **options: As in [`operational_inertias`][redundancy.analysis.batch.operational_inertias].

    Returns:
        Effective masses, shape (n,) [kg]; ``inf`` where the tool cannot move along u.
    """
    Q, armature, joints, engine, threads = _dynamics_inputs(arm, Q, options)
    U = check_directions("direction", direction, len(Q))
    executor = options.get("executor")
    if executor is not None:
        # Each pose travels with its direction: one row of (n, nq + 3).
        kwargs = {"armature": armature, "joints": joints, "engine": engine, "threads": threads}
        QU = np.concatenate([Q, U], axis=1)
        return _scatter_rows(executor, _effective_masses_of_rows, arm, QU, np.empty(0), kwargs)
    J, X = _mobilities(arm, Q, armature, joints, engine, threads)
    return kernels.effective_masses(J, X, U, atol=linalg.motion_floor(arm.length))


def _effective_masses_of_rows(
    arm: Arm, QU: Array, armature: bool, joints: tuple[str, ...] | None, engine: str, threads: int
) -> Array:
    """`effective_masses` of a chunk of rows (pose, unit direction), on a worker."""
    Q, U = np.ascontiguousarray(QU[:, : arm.nq]), np.ascontiguousarray(QU[:, arm.nq :])
    J, X = _mobilities(arm, Q, armature, joints, engine, threads)
    return kernels.effective_masses(J, X, U, atol=linalg.motion_floor(arm.length))


def effective_mass_ranges(arm: Arm, Q: ArrayLike, **options: Unpack[BatchToolMassOptions]) -> Array:
    """Least and greatest effective mass over directions at each pose, shape (n, 2) [kg].

    As `Arm.effective_mass_range`'s ``min`` and ``max`` (arguments as
    [`operational_inertias`][redundancy.analysis.batch.operational_inertias]).
    """

    def kernel(J: Array, X: Array, floor: float) -> Array:
        return kernels.effective_mass_ranges(J, X, atol=floor) if len(J) else np.empty((0, 2))

    return _mobility_stack(effective_mass_ranges, kernel, arm, Q, options)


def dynamic_manipulabilities(
    arm: Arm, Q: ArrayLike, **options: Unpack[BatchToolMassOptions]
) -> Array:
    """Yoshikawa's dynamic manipulability at each pose, shape (n,).

    As `Arm.dynamic_manipulability` (arguments as
    [`operational_inertias`][redundancy.analysis.batch.operational_inertias]).
    """

    def kernel(J: Array, X: Array, floor: float) -> Array:
        if not len(J):
            return np.zeros(0)
        return np.asarray(kernels.dynamic_manipulability(X), dtype=np.float64).reshape(len(J))

    return _mobility_stack(dynamic_manipulabilities, kernel, arm, Q, options)


def coriolis(
    arm: Arm,
    Q: ArrayLike,
    V: ArrayLike,
    *,
    engine: EngineName = "mujoco",
    **run: Unpack[RunOptions],
) -> Array:
    """Coriolis matrices of a stack of states, as `Arm.coriolis <redundancy.Arm.coriolis>`.

    Equal to the single calls bit for bit: each pose runs the same engine calls in the
    same order.

    Args:
        arm: As in [`jacobians`][redundancy.analysis.batch.jacobians].
        Q: As in [`jacobians`][redundancy.analysis.batch.jacobians].
        V: Joint velocities, one per pose, shape (n, nq) [rad/s or m/s].
        engine: As in [`jacobians`][redundancy.analysis.batch.jacobians].
        **run: As in [`jacobians`][redundancy.analysis.batch.jacobians], in chunks of states.

    Returns:
        Coriolis matrices in the Christoffel form, shape (n, nq, nq) [N m s/rad].

    Raises:
        PoseError: ``Q`` not finite poses, ``V`` not finite and of the same shape.
    """
    arm = check_arm(arm)
    check_choice("engine", engine, ENGINES)
    threads, executor = check_run(run)
    Q = _poses(arm, Q)
    V = check_joint_vectors("velocities", V, arm.joint_names, len(Q))
    nq = arm.nq
    if executor is not None:
        # The poses and velocities travel side by side, (n, 2 nq), chunked as poses are.
        kwargs = {"engine": engine, "threads": threads}
        QV, empty = np.hstack((Q, V)), np.empty((0, nq, nq))
        return _scatter_rows(executor, _coriolis_of_states, arm, QV, empty, kwargs)
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
    **run: Unpack[RunOptions],
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
        **run: ``threads`` (MuJoCo's model terms of the steps, split over that many
            threads; the observer then advances through them in order) and ``executor``
            (compute the model's terms on this `concurrent.futures.Executor` in chunks of
            steps), as in `jacobians`.

    Returns:
        The estimated external joint torque at each step, shape (n, nq) [N m or N].

    Raises:
        PoseError: ``Q``, ``V`` or ``TAU`` not finite, or of different shapes.
        ParameterError: A bad ``dt``, ``gain`` or thread count.
        UnknownNameError: A keyword that is not one of `RunOptions`.
    """
    arm = check_arm(arm)
    threads, executor = check_run(run)
    observer = MomentumObserver(arm, gain)
    Q = _poses(arm, Q)
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
        QV, empty = np.hstack((Q, V)), np.empty((0, 2 * nq))
        kwargs = {"threads": threads}
        terms = _scatter_rows(executor, _momentum_terms_of_states, arm, QV, empty, kwargs)
    else:
        terms = _momentum_terms_of_states(arm, np.hstack((Q, V)), threads)
    out = np.empty((n, nq))
    for k in range(n):
        out[k] = observer.advance(terms[k, :nq], terms[k, nq:], TAU[k], float(steps[k]))
    return out


def _momentum_terms_of_states(arm: Arm, QV: Array, threads: int = 1) -> Array:
    """The observer's terms of states laid side by side, (n, 2 nq) -> (n, 2 nq).

    Each row [q, v] gives [p, beta] (`MujocoEngine.momentum_terms
    <redundancy.engines.mujoco.MujocoEngine.momentum_terms>`), each computed by one thread
    in its own engine data (the same numbers for any ``threads``).
    """
    nq = arm.nq
    out = np.empty((len(QV), 2 * nq))
    terms = arm.mujoco.momentum_terms

    def span(lo: int, hi: int) -> None:
        for row, qv in zip(out[lo:hi], QV[lo:hi], strict=True):
            p, beta = terms(qv[:nq], qv[nq:])
            row[:nq] = p
            row[nq:] = beta

    if len(QV):
        run_split(len(QV), threads, span)
    return out

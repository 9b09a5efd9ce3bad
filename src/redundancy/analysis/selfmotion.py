"""Self-motion: moving the joints along the Jacobian's null space so the tool stays put.

Each step recomputes J at the current pose and moves a joint distance ``h`` along the unit
null-space direction, continuing the previous step's way (the sign of a null-space basis
vector is arbitrary). Two integrators are offered:

* ``"euler"``: one direction per step, taken at the step's start. The tool moves by
  O(h^2) per step (J n = 0 only at the start of the step), so over a fixed joint motion
  of ``total`` the drift adds up to O(h): halving the step halves the drift.
* ``"midpoint"``: the direction is taken again at the half step (explicit midpoint rule):
  O(h^3) per step, O(h^2) over ``total``: halving the step quarters the drift.

With ``correct=True`` every step ends with Newton corrections ``q += J^+ e``, where ``e`` is
the tool's error from its *start* pose (not from the previous step's), until ``|e| <= tol``:
the drift does not accumulate and stays at the level of ``tol``. ``J^+ e`` is in J's row
space, so the correction does not move the arm along the self-motion.

An objective-driven move picks, each step, the null-space direction along which a scalar
objective rises (its gradient projected onto the null space), and stops when that direction
reverses: the objective's maximum along the self-motion. Objectives provided: Yoshikawa's
manipulability (analytic gradient), the smallest margin to a joint limit, and the smallest
self-collision clearance (MuJoCo's per-pair signed distances).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import linalg
from ..arm import ENGINES, Arm, EngineName, check_arm
from ..checks import (
    check_callable,
    check_choice,
    check_count,
    check_flag,
    check_matrix,
    check_number,
    check_pose,
)
from ..errors import ParameterError
from ..kernels import rotation_vector
from ..objectives import Objective, Objectivelike
from ..objectives import checked as _checked

if TYPE_CHECKING:
    from ..collision import DistanceEngine, GeomPair

Array = NDArray[np.float64]
Integrator = Literal["euler", "midpoint"]
INTEGRATORS: tuple[Integrator, ...] = ("euler", "midpoint")

#: Most steps one self-motion may take (``total / step``): a bound on its run time.
MAX_STEPS = 100_000

#: Reasons a self-motion ends before its total joint motion (``SelfMotionPath.stopped``).
STOP_PREDICATE = "stop condition met"
STOP_MAXIMUM = "objective at its maximum along the self-motion"
STOP_STATIONARY = "objective does not change along the null space"
STOP_NO_NULLSPACE = "no null space"
STOP_LIMIT = "joint limit"  # followed by ": <joint name>"


def rotation_log(R: Array) -> Array:
    """Rotation vector (unit axis times angle in [0, pi]) of a rotation matrix [rad].

    The library's one rotation log (`redundancy.kernels.rotation_vector`), checked.

    Raises:
        ParameterError: ``R`` not a finite real 3 x 3 matrix.
    """
    return np.array(rotation_vector(check_matrix("R", R, (3, 3)), np.eye(3)))


def pose_error(arm: Arm, q: Array, p0: Array, R0: Array, engine: EngineName = "mujoco") -> Array:
    """Tool error ``[p0 - p; log(R0 R^T)]`` at ``q``, world axes, shape (6,) [m, rad].

    ``J^+`` of this error is the joint step that takes the tool back to ``(p0, R0)`` to
    first order (J's angular rows are world-frame angular velocities).

    Raises:
        ParameterError: Not an Arm, ``p0`` not a finite 3-vector, ``R0`` not a finite 3 x 3
            matrix.
        PoseError: Bad ``q``.
    """
    arm = check_arm(arm)
    p0, R0 = check_matrix("p0", p0, (3,)), check_matrix("R0", R0, (3, 3))
    p, R = arm.site_pose(q, engine)
    return np.concatenate([p0 - p, rotation_log(R0 @ R.T)])


# ==========================================================================================
# Objectives
# ==========================================================================================


def manipulability_objective(arm: Arm, engine: EngineName = "mujoco") -> Objective:
    """Yoshikawa's manipulability sqrt(det(J J^T)), with its analytic gradient [mixed units]."""
    arm = check_arm(arm)
    check_choice("engine", engine, ENGINES)
    return Objective(
        "manipulability sqrt(det(J J^T))",
        lambda q: linalg.yoshikawa(arm.jacobian(q, engine)),
        lambda q: arm.manipulability_gradient(q, engine),
    )


def joint_limit_objective(arm: Arm) -> Objective:
    """The smallest distance of any joint to its nearer limit [rad or m].

    Its gradient is the (sub)gradient of the minimum: +1 on the joint that is nearest its
    lower limit, -1 if it is nearest its upper limit; unlimited joints never count.
    """
    arm = check_arm(arm)

    def margins(q: Array) -> Array:
        return np.minimum(q - arm.lower, arm.upper - q)

    def gradient(q: Array) -> Array:
        m = margins(q)
        i = int(np.argmin(m))
        g = np.zeros(arm.nq)
        g[i] = 1.0 if q[i] - arm.lower[i] <= arm.upper[i] - q[i] else -1.0
        return g if np.isfinite(m[i]) else np.zeros(arm.nq)

    return Objective(
        "smallest joint-limit margin [rad]", lambda q: float(np.min(margins(q))), gradient
    )


def collision_objective(arm: Arm, engine: DistanceEngine = "mujoco") -> Objective:
    """The smallest self-collision clearance over all pairs MuJoCo tests [m].

    Clearance is the pair's signed distance less its contact threshold (margin + gap), so
    it is negative exactly when MuJoCo lists a contact. No analytic gradient (the minimum
    over pairs is not smooth): directions come from central differences.

    Args:
        arm: The arm.
        engine: Distance engine, ``"mujoco"`` (``mj_geomDistance``) or ``"coal"``.
    """
    from ..collision import checker

    ch = checker(arm)
    thresholds = np.array([p.threshold for p in ch.pairs])
    return Objective(
        f"smallest self-collision clearance ({engine}) [m]",
        lambda q: float(np.min(ch.distance_values(q, engine) - thresholds)),
    )


def no_contact(arm: Arm, pair: GeomPair | tuple[str, str] | None = None) -> Callable[[Array], bool]:
    """Stop predicate: true when MuJoCo's contact list (``mj_collision``) is empty.

    Args:
        arm: The arm.
        pair: Only this pair's contacts count (a pair or two geom names, either order).
    """
    from ..collision import checker

    ch = checker(arm)
    if pair is None:
        return lambda q: not ch.contact_pairs(q)
    target = ch.pair(*pair) if isinstance(pair, tuple) else pair
    return lambda q: target not in ch.contact_pairs(q)


# ==========================================================================================
# The self-motion
# ==========================================================================================


@dataclass(frozen=True)
class SelfMotionPath:
    """A sampled self-motion.

    Attributes:
        q: Poses, shape (n + 1, nq) [rad].
        joint_motion: Cumulative joint motion, sum of |q_k+1 - q_k|, shape (n + 1,) [rad].
        position_drift: |p - p0| of the tool, shape (n + 1,) [m].
        orientation_drift: Angle of R R0^T, shape (n + 1,) [rad].
        elbow_height: z of the elbow joint's anchor, shape (n + 1,) [m].
        objective: Objective value per pose when one was used, else empty.
        stopped: Why the motion ended before its total, ``""`` if it did not (see the
            ``STOP_*`` constants of this module).
        elbow: Name of the joint whose anchor is the elbow.
        correct: Whether the tool was pulled back to its start pose every step.
        integrator: ``"euler"`` or ``"midpoint"``.
    """

    q: Array
    joint_motion: Array
    position_drift: Array
    orientation_drift: Array
    elbow_height: Array
    objective: Array
    stopped: str
    elbow: str = ""
    correct: bool = True
    integrator: str = "euler"

    @property
    def total(self) -> float:
        """Joint motion covered [rad]."""
        return float(self.joint_motion[-1])

    @property
    def max_position_drift(self) -> float:
        """Largest tool position drift along the path [m]."""
        return float(np.max(self.position_drift))

    @property
    def max_orientation_drift(self) -> float:
        """Largest tool orientation drift along the path [rad]."""
        return float(np.max(self.orientation_drift))


def _objective_direction(objective: Objectivelike, q: Array, basis: Array, fd_step: float) -> Array:
    """Gradient of the objective projected onto the null space (basis columns), shape (nq,)."""
    grad = objective.gradient if isinstance(objective, Objective) else None
    if grad is not None:
        return basis @ (basis.T @ grad(q))
    h = fd_step
    c = np.array([(objective(q + h * b) - objective(q - h * b)) / (2.0 * h) for b in basis.T])
    return basis @ c


def _start_sign(arm: Arm, q: Array, v: Array, elbow_idx: int, engine: EngineName) -> float:
    """+1 if moving along ``v`` raises the elbow (or, if level, if v's largest entry is > 0)."""
    eps = 1e-6
    eng = arm.engine(engine)
    up, down = eng.joint_axes(q + eps * v)[1], eng.joint_axes(q - eps * v)[1]
    rise = up[elbow_idx, 2] - down[elbow_idx, 2]
    if abs(rise) > 1e-12:
        return float(np.sign(rise))
    return float(np.sign(v[int(np.argmax(np.abs(v)))]))


def self_motion(
    arm: Arm,
    q0: ArrayLike,
    total: float = 1.0,
    step: float = 0.01,
    direction: int = 1,
    correct: bool = True,
    objective: Objectivelike | None = None,
    elbow: str | None = None,
    engine: EngineName = "mujoco",
    stop: Callable[[Array], bool] | None = None,
    integrator: Integrator = "euler",
    tol: float = 1e-12,
    max_corrections: int = 5,
    fd_step: float = 1e-4,
    respect_limits: bool = True,
) -> SelfMotionPath:
    """Move along the null space of the site Jacobian for ``total`` joint motion.

    Args:
        arm: The arm. Its Jacobian should have a one-dimensional null space along the way;
            with a larger one the motion continues the previous direction projected onto it
            (or, with an objective, follows the projected gradient).
        q0: Start pose [rad].
        total: Joint motion to cover, sum of the null-space step lengths [rad].
        step: Null-space joint motion per step [rad].
        direction: +1 or -1: +1 starts the way that raises the elbow (ignored with an
            objective, which picks the rising direction).
        correct: Pull the tool back to its start pose after every step (Newton steps
            ``J^+ e`` until ``|e| <= tol``), removing the drift.
        objective: Scalar function of q to raise (an
            [`Objective`][redundancy.objectives.Objective], or any callable); each step
            goes along its gradient projected onto the null space; the motion stops where that
            direction reverses, at the better of the last two poses.
        elbow: Joint whose anchor height is reported; default the middle joint (j4 of a
            7-joint arm).
        engine: Engine for J and the site pose.
        stop: Predicate on q that ends the motion when true, tested before each step and at the end
            (e.g. [`no_contact`][redundancy.analysis.selfmotion.no_contact]).
        integrator: ``"euler"`` or ``"midpoint"`` (see the module docstring).
        tol: Tool error at which the correction stops [m and rad, as one 6-vector norm].
        max_corrections: Newton corrections per step at most.
        fd_step: Central-difference step for objectives without a gradient [rad].
        respect_limits: Stop before a step that would leave a joint's range.

    Raises:
        ParameterError: ``total`` not finite and > 0, ``step`` outside
            [total / MAX_STEPS, total], bad ``direction``, ``tol``, ``max_corrections`` or
            ``fd_step``; an ``objective`` or ``stop`` that is not callable, or an objective
            that returns a non-number, NaN or infinity (or a gradient of the wrong shape).
        UnknownNameError: Unknown ``elbow`` joint, ``integrator`` or ``engine``.
        PoseError: Bad ``q0``.
    """
    w, q = _checked_walk(
        arm,
        q0,
        total,
        step,
        direction,
        correct,
        objective,
        elbow,
        engine,
        stop,
        integrator,
        tol,
        max_corrections,
        fd_step,
        respect_limits,
    )
    qs, motion, stopped = _walk(w, q)
    return _path(w, np.stack(qs), motion, stopped)


@dataclass(frozen=True)
class _Walk:
    """A self-motion's checked settings and the tool's start pose (``p0`` [m], ``R0``)."""

    arm: Arm
    total: float
    step: float
    direction: int
    correct: bool
    objective: Objective | None
    elbow_idx: int
    engine: EngineName
    stop: Callable[[Array], bool] | None
    integrator: Integrator
    tol: float
    max_corrections: int
    fd_step: float
    respect_limits: bool
    p0: Array
    R0: Array


def _checked_walk(
    arm: Arm,
    q0: ArrayLike,
    total: float,
    step: float,
    direction: int,
    correct: bool,
    objective: Objectivelike | None,
    elbow: str | None,
    engine: EngineName,
    stop: Callable[[Array], bool] | None,
    integrator: Integrator,
    tol: float,
    max_corrections: int,
    fd_step: float,
    respect_limits: bool,
) -> tuple[_Walk, Array]:
    """`self_motion`'s arguments checked (in its documented order), and the start pose."""
    arm = check_arm(arm)
    total = check_number("total", total, 0.0, low_open=True, unit="rad")
    step = check_number("step", step, total / MAX_STEPS, total, unit="rad")
    if isinstance(direction, bool) or not isinstance(direction, int) or direction not in (1, -1):
        raise ParameterError("direction", direction, "+1 or -1")
    check_choice("integrator", integrator, INTEGRATORS)
    check_choice("engine", engine, ENGINES)
    tol = check_number("tol", tol, 0.0, low_open=True, unit="m and rad")
    max_corrections = check_count("max_corrections", max_corrections, 0)
    correct = check_flag("correct", correct)
    respect_limits = check_flag("respect_limits", respect_limits)
    fd_step = check_number("fd_step", fd_step, 0.0, low_open=True, unit="rad")
    q = check_pose(q0, arm.joint_names)
    checked = _checked(objective) if objective is not None else None
    if stop is not None:
        check_callable("stop", stop, "a callable q -> bool, or None")
    elbow_idx = arm.nq // 2 if elbow is None else arm.joint_index(elbow)
    p0, R0 = arm.site_pose(q, engine)
    # By name: sixteen fields of alike types are easy to misplace by position.
    walk = _Walk(
        arm=arm,
        total=total,
        step=step,
        direction=direction,
        correct=correct,
        objective=checked,
        elbow_idx=elbow_idx,
        engine=engine,
        stop=stop,
        integrator=integrator,
        tol=tol,
        max_corrections=max_corrections,
        fd_step=fd_step,
        respect_limits=respect_limits,
        p0=p0,
        R0=R0,
    )
    return walk, q


def _null_direction(w: _Walk, qk: Array, prev: Array | None) -> Array | None:
    """Unit null-space direction at qk continuing ``prev``; None if there is none."""
    basis = linalg.nullspace_basis(w.arm.jacobian(qk, w.engine))
    if basis.shape[1] == 0:
        return None
    if prev is None:
        v = basis[:, 0]
        return w.direction * _start_sign(w.arm, qk, v, w.elbow_idx, w.engine) * v
    v = basis @ (basis.T @ prev)  # the null-space direction closest to the previous one
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-12 else basis[:, 0]


def _rising_direction(
    w: _Walk, objective: Objective, q: Array, prev: Array | None
) -> tuple[Array | None, str]:
    """Unit null-space direction at q along which the objective rises, or why there is none."""
    basis = linalg.nullspace_basis(w.arm.jacobian(q, w.engine))
    if basis.shape[1] == 0:
        return None, STOP_NO_NULLSPACE
    g = _objective_direction(objective, q, basis, w.fd_step)
    gn = float(np.linalg.norm(g))
    if gn == 0.0:
        return None, STOP_STATIONARY
    v = g / gn
    if prev is not None and v @ prev < 0:
        return None, STOP_MAXIMUM
    return v, ""


def _corrected(w: _Walk, q_new: Array) -> Array:
    """``q_new`` after Newton corrections pulling the tool back to its start pose."""
    for _ in range(w.max_corrections):
        e = pose_error(w.arm, q_new, w.p0, w.R0, w.engine)
        if np.linalg.norm(e) <= w.tol:
            break
        q_new = q_new + np.linalg.pinv(w.arm.jacobian(q_new, w.engine)) @ e
    return q_new


def _walk(w: _Walk, q: Array) -> tuple[list[Array], list[float], str]:
    """The poses passed, the joint motion up to each [rad], and why the walk stopped early."""
    arm, objective = w.arm, w.objective
    prev: Array | None = None
    qs, motion = [q.copy()], [0.0]
    covered = 0.0
    stopped = ""
    while w.total - covered > 1e-12:
        if w.stop is not None and w.stop(q):
            stopped = STOP_PREDICATE
            break
        if objective is not None:
            v0, stopped = _rising_direction(w, objective, q, prev)
            if stopped == STOP_MAXIMUM and objective(q) < objective(qs[-2]):
                # the last step passed the maximum
                qs.pop()
                motion.pop()
                q = qs[-1]
        else:
            v0 = _null_direction(w, q, prev)
            stopped = STOP_NO_NULLSPACE if v0 is None else ""
        if v0 is None:
            break
        v = v0
        h = min(w.step, w.total - covered)
        if w.integrator == "midpoint":
            vm = _null_direction(w, q + 0.5 * h * v, v)
            if vm is None:
                stopped = STOP_NO_NULLSPACE
                break
            v = vm
        q_new = q + h * v
        if w.correct:
            q_new = _corrected(w, q_new)
        if w.respect_limits:
            out = np.flatnonzero((q_new < arm.lower) | (q_new > arm.upper))
            if out.size:
                stopped = f"{STOP_LIMIT}: {arm.joint_names[int(out[0])]}"
                break
        motion.append(motion[-1] + float(np.linalg.norm(q_new - q)))
        q, prev = q_new, v
        covered += h
        qs.append(q.copy())
    if not stopped and w.stop is not None and w.stop(q):
        stopped = STOP_PREDICATE
    return qs, motion, stopped


def _path(w: _Walk, Q: Array, motion: list[float], stopped: str) -> SelfMotionPath:
    """The walk's poses with the tool's drift and the elbow's height along them."""
    arm, engine = w.arm, w.engine
    pos, ori, elb = [], [], []
    eng = arm.engine(engine)
    for qi in Q:
        p, R = arm.site_pose(qi, engine)
        pos.append(np.linalg.norm(p - w.p0))
        ori.append(np.linalg.norm(rotation_log(R @ w.R0.T)))
        elb.append(eng.joint_axes(qi)[1][w.elbow_idx, 2])
    objective = w.objective
    obj = np.array([objective(qi) for qi in Q]) if objective is not None else np.zeros(0)
    return SelfMotionPath(
        Q,
        np.array(motion),
        np.array(pos),
        np.array(ori),
        np.array(elb),
        obj,
        stopped,
        arm.joint_names[w.elbow_idx],
        w.correct,
        w.integrator,
    )

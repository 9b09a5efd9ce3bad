"""Inverse kinematics: put the tool at a pose, inside the joint ranges, and use the spare joints.

The solver ([`solve`][redundancy.ik.solve], behind `Arm.solve_ik`):

* **Damped Levenberg-Marquardt** on the tool error e = [p* - p; log(R* R^T)] (world axes,
  [m] and [rad]), with Sugihara's damping lambda = E + w_N, E = e^T e / 2: the step is
  dq = J^T (J J^T + lambda I)^-1 e (the same step as (J^T J + lambda I)^-1 J^T e, through a
  6 x 6 system), clamped to the joint ranges after every step, so every iterate and every
  answer lies inside them.
* **The same steps at any size**: positions (the position errors and rows of J, the slide
  joints' values) are measured in half-lengths of the arm, so E and the damping are pure numbers
  and a 0.3 mm arm, a 1 m arm and a 100 m arm take the same steps towards the same
  (scaled) targets.
* **Random restarts** inside the ranges when an attempt stalls, up to a budget.
* **The answer checked in every other engine**: the iterations use one engine's kinematics
  (MuJoCo's by default, the fastest); when they meet the tolerances, every other engine
  recomputes the tool pose, and only their (worst) errors decide ``success`` and are
  reported. A success is a success in every engine.
* **Objectives in the null space**, after the task has converged: an objective is a value
  to raise ([`Objective`][redundancy.objectives.Objective], as `self_motion` takes), and the
  solver lowers its cost f = minus that value: steps -N grad(f) with N = I - J^+ J, each
  followed by a few Levenberg-Marquardt corrections that remove the second-order drift, kept
  only when f decreases and the task still holds; the objective never costs the task
  anything (the task-only answer is returned if the pursuit fails). The objective is given
  a copy of each pose: changing its argument changes nothing here.

Nothing here calls an engine library: the engines' ``kinematics_kernel`` (unchecked, per
thread) gives position, rotation and Jacobian at a pose.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .checks import check_count, check_matrix, check_number, check_returned, describe
from .engines.contract import Engine
from .engines.mujoco import damped_stepper
from .errors import ParameterError
from .kernels import rotation_vector
from .objectives import Objective, joint_limit_cost

Array = NDArray[np.float64]

#: The former form of an objective, deprecated: a cost to lower, q -> (cost, gradient (nq,)).
Cost = Callable[[Array], tuple[float, Array]]

#: Why the former form warns: what to pass instead.
LEGACY_WARNING = (
    "an objective returning a (cost, gradient) tuple to lower is deprecated: pass an "
    "Objective or a callable returning the value to raise"
)

#: Central-difference step of the gradient of an objective that has none [rad or m].
FD_STEP = 1e-6

#: Names of the built-in objectives.
OBJECTIVES = ("joint_limits", "manipulability")


@dataclass(frozen=True)
class IKResult:
    """What `Arm.solve_ik` found.

    Attributes:
        q: The pose, inside the joint ranges [rad or m].
        success: The tool errors, recomputed by the checking engine, are within tolerance
            (the position error alone with ``position_only``).
        position_error: |p* - p| at ``q`` by the checking engine [m].
        orientation_error: Angle of R* R^T at ``q`` by the checking engine [rad].
        iterations: Levenberg-Marquardt iterations, over every attempt and the objective's
            corrections.
        restarts: Random restarts taken (0: the first start converged).
        objective: The cost the solver lowered, at ``q``: minus the objective's value (the
            cost itself for the deprecated (cost, gradient) form; None without an objective).
        engine: The engine whose kinematics the iterations used.
        checked_by: The engines that recomputed the answer and decided ``success``, by
            name, comma-separated.

    ``success`` and the errors are those of this ``q``, the array returned (a copy of the
    solver's own: changing it changes nothing else).
    """

    q: Array
    success: bool
    position_error: float
    orientation_error: float
    iterations: int
    restarts: int = 0
    objective: float | None = None
    engine: str = "mujoco"
    checked_by: str = "pinocchio"


@dataclass(frozen=True)
class Settings:
    """The solver's knobs (the defaults are what the benchmark measures).

    Attributes:
        position_tol: Position tolerance [m].
        orientation_tol: Orientation tolerance [rad].
        iterations: Iterations per attempt before a restart.
        restarts: Random restarts at most.
        damping: w_N, the constant part of Sugihara's damping, on errors whose positions
            are in half-lengths of the arm [-].
        objective_steps: Null-space steps at most when pursuing an objective.
        stall_window: An attempt whose E (positions in half-lengths of the arm) fell by less
            than ``stall_ratio`` over this many iterations (while above 1e-8) is given up for
            a restart.
        stall_ratio: See ``stall_window``.
    """

    position_tol: float = 1e-6
    orientation_tol: float = 1e-6
    iterations: int = 30
    restarts: int = 100
    damping: float = 1e-9
    gain: float = 0.1
    objective_steps: int = 40
    stall_window: int = 5
    stall_ratio: float = 0.5


#: The settings of a call with every default.
DEFAULT_SETTINGS = Settings()

#: The iterating engine converges to this fraction of the tolerances before the other engine
#: checks (the engines agree to ~1e-15 m; the margin keeps a check from failing on rounding).
_MARGIN = 0.1

#: The unit the iterations measure positions in, as a share of the arm's length: half of it
#: (a typical reach) took 4 % fewer iterations than the whole length and than a fixed 1 m on
#: 1,200 targets of arm7, UR5, xArm7 and Panda (1.1-1.5 m long).
_UNIT = 0.5

#: Corrections allowed after each null-space step.
_CORRECTIONS = 8


rotation_error = rotation_vector  # its name in the solver's API


def tool_errors(p_t: Array, R_t: Array, p: Array, R: Array) -> tuple[float, float]:
    """Position error [m] and orientation error (an angle) [rad] of the tool at (p, R)."""
    x, y, z = rotation_error(R_t, R)
    return math.hypot(*(p_t - p).tolist()), math.sqrt(x * x + y * y + z * z)


def joint_limit_objective(lower: Array, upper: Array, margin: float = 1e-3) -> Cost:
    """Chan and Dubey's joint-limit cost q -> (cost, gradient), to lower (deprecated).

    Deprecated: [`objectives.joint_limits`][redundancy.objectives.joint_limits] is the same
    as an [`Objective`][redundancy.objectives.Objective] to raise (minus this cost).
    """
    warnings.warn(
        "ik.joint_limit_objective is deprecated: use redundancy.objectives.joint_limits, "
        "the Objective to raise (minus this cost)",
        DeprecationWarning,
        stacklevel=2,
    )
    return joint_limit_cost(lower, upper, margin)


def limit_clearance(q: Array, lower: Array, upper: Array) -> float:
    """Smallest distance to a limit over the limited joints, as a share of the range (0-0.5)."""
    limited = np.isfinite(lower) & np.isfinite(upper) & (upper > lower)
    if not limited.any():
        return 0.5
    lo, hi, x = lower[limited], upper[limited], q[limited]
    return float(np.min(np.minimum(x - lo, hi - x) / (hi - lo)))


def _checked(returned: object, nq: int) -> tuple[float, Array]:
    """An objective's output as (finite float, finite (nq,) gradient)."""
    valid = f"a callable returning (finite value, finite gradient of shape ({nq},))"
    if not isinstance(returned, tuple | list) or len(returned) != 2:
        raise ParameterError("objective", returned, valid, f"it returned {describe(returned)}")
    value, gradient = returned
    try:
        v = float(value)
        g = np.array(gradient, dtype=np.float64)  # a copy: the caller may reuse its array
    except (TypeError, ValueError, OverflowError):
        raise ParameterError("objective", (value, gradient), valid) from None
    if not math.isfinite(v) or g.shape != (nq,) or not np.all(np.isfinite(g)):
        raise ParameterError("objective", (value, gradient), valid)
    return v, g


class _Cost:
    """The cost the solver lowers: minus an objective's value, with minus its gradient.

    The objective gets copies of the pose. A value that is a (cost, gradient) pair is the
    deprecated form, taken as the cost itself (with a DeprecationWarning, once).
    """

    def __init__(self, objective: Objective, nq: int) -> None:
        self.objective = objective
        self.nq = nq
        self.warned = False
        self.legacy_gradient: Array | None = None

    def value(self, q: Array) -> float:
        """The cost at ``q`` (its gradient, for the deprecated form, kept for `gradient`)."""
        out = self.objective.value(q.copy())
        if isinstance(out, tuple | list) and len(out) == 2:
            if not self.warned:
                self.warned = True
                warnings.warn(LEGACY_WARNING, DeprecationWarning, stacklevel=2)
            v, self.legacy_gradient = _checked(out, self.nq)
            return v
        self.legacy_gradient = None
        return -check_returned("objective", out, q)

    def gradient(self, q: Array) -> Array:
        """The cost's gradient at ``q``, the pose `value` was last called at."""
        if self.legacy_gradient is not None:
            return self.legacy_gradient
        g = self.objective.gradient
        if g is not None:
            return -check_matrix("objective gradient", g(q.copy()), (self.nq,))
        h = FD_STEP
        f = self.objective.value
        rises = [
            check_returned("objective", f(q + h * e), q)
            - check_returned("objective", f(q - h * e), q)
            for e in np.eye(self.nq)
        ]
        return np.array(rises) / (-2.0 * h)

    def both(self, q: Array) -> tuple[float, Array]:
        """Cost and gradient at ``q``."""
        return self.value(q), self.gradient(q)


class _Solver:
    """One solve's state: the kernel, the target, the ranges, the arm's size and the counters.

    Positions are measured in L = `_UNIT` x ``length`` (the arm's length [m]): E =
    (|e_p|^2 / L^2 + |e_r|^2) / 2, the position rows damped by lambda L^2 (the step of J and
    e with those rows divided by L), and a slide joint's column and step scaled by L (its
    value in units of L). A hinge-only arm scaled by any factor takes exactly the steps of
    the unscaled one.
    """

    def __init__(
        self,
        engine: Engine,
        lower: Array,
        upper: Array,
        p_t: Array,
        R_t: Array,
        position_only: bool,
        settings: Settings,
        length: float = 1.0,
        slide: Array | None = None,
    ) -> None:
        self.kin = engine.ik_kernel(p_t, R_t)
        self.lower, self.upper = lower, upper
        self.p_t, self.R_t = p_t, R_t
        self.position_only = position_only
        self.s = settings
        self.tol_p = _MARGIN * settings.position_tol
        self.tol_r = math.inf if position_only else _MARGIN * settings.orientation_tol
        self.iterations = 0
        length = _UNIT * length
        self.inv_l2 = 1.0 / (length * length)
        # Per joint, the length a unit of its value is measured in (None: 1 for every joint).
        self.unit: Array | None = None
        if slide is not None and length != 1.0 and np.any(slide):
            self.unit = np.where(slide, length, 1.0)
        # The damped least-squares step with its work arrays made once per solve.
        L2 = length * length
        weights = [L2] * 3 if position_only else [L2, L2, L2, 1.0, 1.0, 1.0]
        self.step = damped_stepper(len(weights), len(lower), np.array(weights))

    def error(self, q: Array) -> tuple[Array, Array, float, float]:
        """Task error (6 or 3,), task Jacobian, position and orientation errors at ``q``.

        The arrays are the kernel's buffers: valid until the next call.
        """
        e, J = self.kin(q)
        x, y, z, a, b, c = e.tolist()
        npos, nrot = math.sqrt(x * x + y * y + z * z), math.sqrt(a * a + b * b + c * c)
        if self.position_only:
            return e[:3], J[:3], npos, nrot
        return e, J, npos, nrot

    def descend(self, q: Array, budget: int) -> tuple[Array, bool, float]:
        """Levenberg-Marquardt from ``q`` for at most ``budget`` iterations.

        The loop is written out (the kernel called directly, squared norms from one
        ``tolist``, counters in locals): at ~25 us an iteration, each Python call shows.

        Returns:
            The last pose, whether it converged, and E = e^T e / 2 there.
        """
        lo, hi, k, wn = self.lower, self.upper, self.s.gain, self.s.damping
        only, kin, inv_l2, unit = self.position_only, self.kin, self.inv_l2, self.unit
        tp2 = self.tol_p * self.tol_p
        tr2 = math.inf if only else self.tol_r * self.tol_r
        window, ratio = self.s.stall_window, self.s.stall_ratio
        step_of, maximum, minimum = self.step, np.maximum, np.minimum
        e, J = kin(q)
        x, y, z, a, b, c = e.tolist()
        pp, rr = x * x + y * y + z * z, a * a + b * b + c * c
        E = 0.5 * (pp * inv_l2 if only else pp * inv_l2 + rr)
        history = [E]
        done = 0
        for _ in range(budget):
            if pp <= tp2 and rr <= tr2:
                break
            done += 1
            lam = k * E + wn  # Sugihara's lambda = E + w_N (with the gain k of Chan's)
            Jt, et = (J[:3], e[:3]) if only else (J, e)
            if unit is None:
                step = q + step_of(Jt, et, lam)
            else:  # slides in lengths of the arm: J's columns and the step scaled
                step = q + unit * step_of(Jt * unit, et, lam)
            clamped = maximum(step, lo)  # -inf / inf where a joint is unlimited
            minimum(clamped, hi, out=clamped)
            values = clamped.tolist()
            if values != step.tolist():
                # A joint the step pushes past its limit stops there; the step is solved
                # again without it, so the other joints make up for it (the redundancy at
                # work).
                Jf = Jt * (clamped == step)
                if unit is None:
                    clamped = maximum(q + step_of(Jf, et, lam), lo)
                else:
                    clamped = maximum(q + unit * step_of(Jf * unit, et, lam), lo)
                minimum(clamped, hi, out=clamped)
                values = clamped.tolist()
            if not math.isfinite(lam) or not math.isfinite(sum(values)):
                break  # a target so far away that the squared error overflowed: q stays
            q = clamped
            e, J = kin(q)
            x, y, z, a, b, c = e.tolist()
            pp, rr = x * x + y * y + z * z, a * a + b * b + c * c
            E = 0.5 * (pp * inv_l2 if only else pp * inv_l2 + rr)
            # A stalled attempt (E down by less than ``stall_ratio`` over ``stall_window``
            # iterations, far from the tolerance) is given up for a restart rather than run
            # to the budget.
            history.append(E)
            if len(history) > window and E > ratio * history[-window - 1] and E > 1e-8:
                break
        self.iterations += done
        return q, pp <= tp2 and rr <= tr2, E

    def pursue(self, q: Array, cost: _Cost) -> Array:
        """Raise ``objective`` (lower its cost) along the task's null space from ``q``.

        The objective sees copies: one that changes its argument cannot move the solver's
        pose after its errors were computed.
        """
        nq = len(q)
        value, grad = cost.both(q)
        scale = 0.25  # largest joint motion of the next trial step [rad, or half-lengths]
        for _ in range(self.s.objective_steps):
            J = self.error(q)[1]
            N = np.eye(nq) - np.linalg.pinv(J).dot(J)
            d = -N.dot(grad)
            top = float(np.abs(d if self.unit is None else d / self.unit).max())
            if not top > 1e-12:
                break
            trial = np.clip(q + (scale / top) * d, self.lower, self.upper)
            trial, ok, _ = self.descend(trial, _CORRECTIONS)
            if ok:
                v = cost.value(trial)
                if v < value - 1e-12 * max(1.0, abs(value)):
                    gain = value - v
                    q, value, grad = trial, v, cost.gradient(trial)
                    scale = min(2.0 * scale, 0.5)
                    if gain <= 1e-9 * max(1e-12, abs(value)):
                        break
                    continue
            scale *= 0.25
            if scale < 1e-6:
                break
        return q


def solve(
    engine: Engine,
    checks: tuple[Engine, ...],
    lower: Array,
    upper: Array,
    sample_lower: Array,
    sample_upper: Array,
    p_t: Array,
    R_t: Array,
    q0: Array,
    rng: Callable[[], np.random.Generator],
    objective: Objective | None = None,
    position_only: bool = False,
    settings: Settings | None = None,
    length: float = 1.0,
    slide: Array | None = None,
) -> IKResult:
    """Solve one target (inputs validated by the caller; see the module's description).

    Args:
        engine: The engine whose kinematics the iterations use.
        checks: The engines that recompute the answer; the worst of their errors decides
            success.
        lower: Lower joint limits (``-inf`` where unlimited) [rad or m].
        upper: Upper joint limits (``inf`` where unlimited) [rad or m].
        sample_lower: Lower bounds of the random restarts [rad or m].
        sample_upper: Upper bounds of the random restarts [rad or m].
        p_t: Target position [m].
        R_t: Target rotation (orthonormal).
        q0: First start [rad or m] (clamped into the ranges).
        rng: Makes the restarts' random numbers (called on the first restart only: most
            solves need none, and a generator costs tens of microseconds to seed).
        objective: Raised in the null space after convergence (its cost, minus its value,
            lowered), or None.
        position_only: Solve for the position alone (3 rows of J).
        settings: The knobs (`Settings` defaults if None).
        length: The arm's length, which sets the unit of the iterations' positions [m] (see
            `_Solver`).
        slide: True for each slide joint (their values are lengths), None: all hinges.
    """
    s = settings or Settings()
    solver = _Solver(engine, lower, upper, p_t, R_t, position_only, s, length, slide)
    cost = None if objective is None else _Cost(objective, len(q0))
    q = np.minimum(np.maximum(q0, lower), upper)
    best: tuple[float, Array] | None = None
    restarts = 0
    generator: np.random.Generator | None = None
    while True:
        q, ok, E = solver.descend(q, s.iterations)
        if ok:
            errors = _checked_errors(solver, checks, q)
            if errors[2]:
                if cost is not None:
                    better = solver.pursue(q, cost)
                    if better is not q:
                        better_errors = _checked_errors(solver, checks, better)
                        if better_errors[2]:
                            q, errors = better, better_errors
                return _result(solver, checks, q, errors, restarts, cost, engine)
        if best is None or E < best[0] or not math.isfinite(best[0]):
            best = (E, q)
        if restarts >= s.restarts:
            break
        restarts += 1
        if generator is None:
            generator = rng()
        q = generator.uniform(sample_lower, sample_upper)
    q = best[1]
    return _result(solver, checks, q, _checked_errors(solver, checks, q), restarts, cost, engine)


def _checked_errors(
    solver: _Solver, checks: tuple[Engine, ...], q: Array
) -> tuple[float, float, bool]:
    """Position and orientation errors, the worst over the checkers (NaN wins); both pass?"""
    if len(checks) == 1:  # two engines: the other one's errors as they are (the common path)
        npos, nrot = tool_errors(solver.p_t, solver.R_t, *checks[0].site_pose(q))
    else:
        found = [tool_errors(solver.p_t, solver.R_t, *c.site_pose(q)) for c in checks]
        npos, nrot = (float(x) for x in np.max(found, axis=0))
    s = solver.s
    ok = npos <= s.position_tol and (solver.position_only or nrot <= s.orientation_tol)
    return npos, nrot, ok


def _result(
    solver: _Solver,
    checks: tuple[Engine, ...],
    q: Array,
    errors: tuple[float, float, bool],
    restarts: int,
    cost: _Cost | None,
    engine: Engine,
) -> IKResult:
    q = q.copy()  # the errors are this array's; the objective gets its own copy
    value = None if cost is None else cost.value(q)
    return IKResult(
        q=q,
        success=bool(errors[2]),
        position_error=errors[0],
        orientation_error=errors[1],
        iterations=solver.iterations,
        restarts=restarts,
        objective=value,
        engine=engine.name,
        checked_by=checks[0].name if len(checks) == 1 else ", ".join(c.name for c in checks),
    )


#:  solve_ik's default tolerances [m, rad] and restarts, which `DEFAULT_SETTINGS` holds.
_IK_DEFAULTS = (
    DEFAULT_SETTINGS.position_tol,
    DEFAULT_SETTINGS.orientation_tol,
    DEFAULT_SETTINGS.restarts,
)


def settings_for(position_tol: object, orientation_tol: object, restarts: object) -> Settings:
    """The solver's settings for `Arm.solve_ik`'s arguments, checked.

    Raises:
        ParameterError: A tolerance not a finite number > 0, ``restarts`` not an integer >= 0.
    """
    if (
        type(position_tol) is float
        and type(orientation_tol) is float
        and type(restarts) is int
        and (position_tol, orientation_tol, restarts) == _IK_DEFAULTS
    ):
        return DEFAULT_SETTINGS  # the common call: nothing to check or build
    return Settings(
        position_tol=check_number("position_tol", position_tol, 0.0, low_open=True, unit="m"),
        orientation_tol=check_number(
            "orientation_tol", orientation_tol, 0.0, low_open=True, unit="rad"
        ),
        restarts=check_count("restarts", restarts, 0),
    )

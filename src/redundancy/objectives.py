"""Objectives: scalar functions of the pose to RAISE, shared by `solve_ik` and `self_motion`.

One convention for both: an objective is a value to raise, with an optional analytic
gradient ([`Objective`][redundancy.objectives.Objective]); a plain callable q -> float is
an objective without a gradient (central differences stand in for it).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .checks import check_callable, check_matrix, check_returned

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Objective:
    """A scalar function of the pose to raise (in the null space of a task).

    Calling the objective returns its value, so a plain ``Callable[[Array], float]`` can be used
    wherever an [`Objective`][redundancy.objectives.Objective] is accepted.

    Attributes:
        name: Short description, with its unit.
        value: q -> value.
        gradient: q -> d value / dq, shape (nq,); ``None`` for central differences.
    """

    name: str
    value: Callable[[Array], float]
    gradient: Callable[[Array], Array] | None = None

    def __call__(self, q: Array) -> float:
        """The objective's value at ``q``."""
        return float(self.value(q))


Objectivelike = Objective | Callable[[Array], float]

#: What an objective argument accepts, for messages.
VALID = "an Objective or a callable q -> float"


def as_objective(objective: Objectivelike) -> Objective:
    """``objective`` as an Objective (a plain callable: one without a gradient), unchecked values.

    Raises:
        ParameterError: ``objective`` is not callable (or its ``value`` or ``gradient`` neither).
    """
    check_callable("objective", objective, VALID)
    if isinstance(objective, Objective):
        check_callable("objective", objective.value, VALID)
        if objective.gradient is not None:
            check_callable("objective gradient", objective.gradient, "a callable q -> array")
        return objective
    return Objective(getattr(objective, "__name__", "objective"), objective)


def checked(objective: Objectivelike) -> Objective:
    """The objective with its values and gradients checked.

    A NaN or a string it returns is the objective's fault (ParameterError naming it), not
    the pose's or numpy's.

    Raises:
        ParameterError: ``objective`` is not callable (or its ``gradient`` neither).
    """
    o = as_objective(objective)
    value, gradient = o.value, o.gradient

    def checked_value(q: Array) -> float:
        return check_returned("objective", value(q), q)

    checked_gradient = None
    if gradient is not None:

        def checked_gradient(q: Array) -> Array:
            return check_matrix("objective gradient", gradient(q), (len(q),))

    return Objective(o.name, checked_value, checked_gradient)


def joint_limit_cost(
    lower: Array, upper: Array, margin: float = 1e-3
) -> Callable[[Array], tuple[float, Array]]:
    """Chan and Dubey's joint-limit cost q -> (cost, gradient); see `joint_limits`."""
    limited = np.isfinite(lower) & np.isfinite(upper) & (upper > lower)
    lo = np.where(limited, lower, -1.0)
    hi = np.where(limited, upper, 1.0)
    r = hi - lo
    w = np.where(limited, 0.25 * r * r, 0.0) / max(1, int(limited.sum()))
    pad = margin * r

    def cost(q: Array) -> tuple[float, Array]:
        x = np.where(limited, q, 0.5 * (lo + hi))
        a, b = hi - x + pad, x - lo + pad
        f = a * b
        return float(np.sum(w / f)), w * (b - a) / (f * f)

    return cost


def joint_limits(lower: Array, upper: Array, margin: float = 1e-3) -> Objective:
    """Minus Chan and Dubey's joint-limit cost, the mean of r^2 / (4 (upper - q)(q - lower)).

    -1 with every limited joint at the middle of its range (r, the range's width), falling
    without bound toward a limit, so raising it moves first the joints nearest their limits
    (a quadratic measure would trade one joint at its limit for several nearer their
    middles). The distances carry ``margin`` times the range, so a joint clamped at its
    limit still has a finite value and gradient; unlimited joints never count [-].

    Args:
        lower: Lower joint limits (``-inf`` where unlimited) [rad or m].
        upper: Upper joint limits (``inf`` where unlimited) [rad or m].
        margin: Padding of the distances to the limits, as a share of the range [-].
    """
    cost = joint_limit_cost(lower, upper, margin)
    return Objective("minus the joint-limit cost [-]", lambda q: -cost(q)[0], lambda q: -cost(q)[1])

"""Pose-by-pose agreement of the two engines, with a stated tolerance per quantity."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..arm import Arm
from ..errors import UnknownNameError
from ..linalg import manipulability_gradient
from ..model.bridges import Bridge

Array = NDArray[np.float64]

#: Tolerance per quantity, on |mujoco - pinocchio| / max(1, |value|). Both engines evaluate
#: the same closed-form rigid-body algorithms in double precision; differences are rounding.
TOLERANCES: dict[str, float] = {
    "site position": 1e-9,
    "site rotation": 1e-9,
    "jacobian": 1e-9,
    "jacobian derivative": 1e-9,
    "mass matrix": 1e-9,
    "mass matrix (bare)": 1e-9,
    "gravity": 1e-9,
    "manipulability gradient": 1e-8,
}

_QUANTITIES: dict[str, Callable[[object, Array], Array]] = {
    "site position": lambda e, q: e.site_pose(q)[0],  # type: ignore[attr-defined]
    "site rotation": lambda e, q: e.site_pose(q)[1],  # type: ignore[attr-defined]
    "jacobian": lambda e, q: e.site_jacobian(q),  # type: ignore[attr-defined]
    "jacobian derivative": lambda e, q: e.jacobian_derivatives(q),  # type: ignore[attr-defined]
    "mass matrix": lambda e, q: e.mass_matrix(q, True),  # type: ignore[attr-defined]
    "mass matrix (bare)": lambda e, q: e.mass_matrix(q, False),  # type: ignore[attr-defined]
    "gravity": lambda e, q: e.gravity(q),  # type: ignore[attr-defined]
    "manipulability gradient": lambda e, q: manipulability_gradient(  # type: ignore[attr-defined]
        e.site_jacobian(q), e.jacobian_derivatives(q)
    ),
}


@dataclass(frozen=True)
class Agreement:
    """How closely the engines agree on one quantity over the poses checked.

    Attributes:
        quantity: Name, a key of :data:`TOLERANCES`.
        max_error: Largest |mujoco - pinocchio| / max(1, |value|) seen.
        tol: The tolerance it is held to.
        worst_pose: Index of the pose where ``max_error`` occurred.
    """

    quantity: str
    max_error: float
    tol: float
    worst_pose: int

    @property
    def ok(self) -> bool:
        """True when the largest error is within the tolerance."""
        return self.max_error <= self.tol


@dataclass(frozen=True)
class CrossCheckReport:
    """Result of :func:`crosscheck`.

    Attributes:
        agreements: One entry per quantity.
        bridges: Values Pinocchio got from MuJoCo (not independent, so not compared).
        n_poses: Number of poses compared.
    """

    agreements: tuple[Agreement, ...]
    bridges: tuple[Bridge, ...]
    n_poses: int

    @property
    def ok(self) -> bool:
        """True when every quantity agrees within its tolerance."""
        return all(a.ok for a in self.agreements)

    def __getitem__(self, quantity: str) -> Agreement:
        for a in self.agreements:
            if a.quantity == quantity:
                return a
        raise KeyError(quantity)

    def lines(self) -> list[str]:
        """Human-readable table lines."""
        out = [f"{'quantity':<26}{'max rel. diff':>14}{'tol':>9}  over {self.n_poses} poses"]
        for a in self.agreements:
            flag = "ok" if a.ok else "DISAGREE"
            out.append(f"{a.quantity:<26}{a.max_error:>14.2e}{a.tol:>9.0e}  {flag}")
        if self.bridges:
            kinds = sorted({b.quantity for b in self.bridges})
            out.append(
                f"bridged from MuJoCo (same numbers in both, not compared): {', '.join(kinds)}"
            )
        return out


def quantity_names(quantities: Iterable[str] | None) -> tuple[str, ...]:
    """The quantities to compare: all of :data:`TOLERANCES` by default.

    Raises:
        UnknownNameError: A name that is not a key of :data:`TOLERANCES` (lists the valid ones).
    """
    names = tuple(TOLERANCES) if quantities is None else tuple(quantities)
    for name in names:
        if name not in TOLERANCES:
            raise UnknownNameError("quantity", name, list(TOLERANCES))
    return names


def crosscheck(
    arm: Arm,
    poses: ArrayLike,
    quantities: tuple[str, ...] | None = None,
    tolerances: dict[str, float] | None = None,
) -> CrossCheckReport:
    """Compare MuJoCo and Pinocchio at one pose or many.

    Args:
        arm: The loaded arm.
        poses: One pose, shape (nq,), or many, shape (n, nq) [rad or m].
        quantities: Subset of :data:`TOLERANCES` keys; all by default.
        tolerances: Overrides for :data:`TOLERANCES`.
    """
    tols = {**TOLERANCES, **(tolerances or {})}
    names = quantity_names(quantities)
    qs = np.atleast_2d(np.asarray(poses, dtype=float))
    worst = dict.fromkeys(names, 0.0)
    where = dict.fromkeys(names, 0)
    for p, q in enumerate(qs):
        q = arm.pose(q)
        for name in names:
            a = np.asarray(_QUANTITIES[name](arm.mujoco, q))
            b = np.asarray(_QUANTITIES[name](arm.pinocchio, q))
            err = float(np.max(np.abs(a - b) / np.maximum(1.0, np.abs(a))))
            if err > worst[name] or not np.isfinite(err):
                worst[name], where[name] = err, p
    agreements = tuple(Agreement(n, worst[n], tols[n], where[n]) for n in names)
    return CrossCheckReport(agreements, arm.bridges, len(qs))

"""Reflected inertia and the explicit-damping timestep bound, per joint.

A torque controller that writes ``tau = -kd * qdot`` to ``ctrl`` is integrated explicitly by
every MuJoCo integrator, while the joint's own damping ``b`` is implicit under Euler. One
step of semi-implicit Euler then multiplies the joint speed by (I - h kd) / (I + h b), which
stays below 1 in magnitude exactly when h < 2 I / (kd - b).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .checks import check_broadcast, check_number, check_values
from .errors import ParameterError

Array = NDArray[np.float64]


def reflected_inertia(rotor_inertia: ArrayLike, gear_ratio: ArrayLike) -> Array:
    """Armature seen at the joint: N^2 J_rotor [kg m^2].

    Args:
        rotor_inertia: Rotor inertia J_rotor >= 0 [kg m^2].
        gear_ratio: Gear ratio N (rotor turns per joint turn; its sign is the direction) [-].

    Raises:
        ParameterError: A value negative (inertia), NaN or infinite, not a number, or shapes
            that do not broadcast.
    """
    J = check_values("rotor_inertia", rotor_inertia, 0.0, unit="kg m^2")
    N = check_values("gear_ratio", gear_ratio)
    J, N = check_broadcast(rotor_inertia=J, gear_ratio=N)
    with np.errstate(over="ignore"):  # beyond 1e308: inf, the product's limit
        return N**2 * J


def rotor_inertia(armature: ArrayLike, gear_ratio: ArrayLike) -> Array:
    """Inverse of `reflected_inertia`: J_rotor = armature / N^2 [kg m^2].

    Raises:
        ParameterError: ``armature`` negative, ``gear_ratio`` zero, a value NaN or infinite,
            not a number, or shapes that do not broadcast.
    """
    A = check_values("armature", armature, 0.0, unit="kg m^2")
    N = check_values("gear_ratio", gear_ratio)
    if np.any(N == 0):
        raise ParameterError("gear_ratio", gear_ratio, "a finite nonzero number (or array)")
    A, N = check_broadcast(armature=A, gear_ratio=N)
    with np.errstate(over="ignore", under="ignore"):  # |N| beyond 1e154: 0, the limit
        return A / N**2


def max_stable_timestep(inertia: ArrayLike, kd: ArrayLike, damping: ArrayLike) -> Array:
    """Largest timestep for explicit controller damping: h < 2 I / (kd - b) [s].

    Args:
        inertia: Joint inertia I, e.g. the diagonal of M [kg m^2].
        kd: Controller damping gain, integrated explicitly [N m s/rad].
        damping: Joint damping b, integrated implicitly (Euler, implicitfast) [N m s/rad].

    Returns:
        The bound per joint [s]; ``inf`` where kd <= b (any step is stable).

    Raises:
        ParameterError: ``inertia`` not > 0, ``kd`` or ``damping`` negative, a value NaN or
            infinite, not a number, or shapes that do not broadcast.
    """
    inertia, kd, damping = check_broadcast(
        inertia=check_values("inertia", inertia, 0.0, low_open=True, unit="kg m^2"),
        kd=check_values("kd", kd, 0.0, unit="N m s/rad"),
        damping=check_values("damping", damping, 0.0, unit="N m s/rad"),
    )
    excess = kd - damping
    with np.errstate(divide="ignore", over="ignore"):  # beyond 1e308: inf, the bound's limit
        return np.where(excess > 0, 2.0 * inertia / np.where(excess > 0, excess, 1.0), np.inf)


def max_stable_kd(inertia: ArrayLike, timestep: float, damping: ArrayLike) -> Array:
    """Largest explicit damping gain stable at a timestep: kd < b + 2 I / h [N m s/rad].

    Args:
        inertia: Joint inertia I [kg m^2].
        timestep: Integration step h [s].
        damping: Joint damping b (implicit) [N m s/rad].

    Raises:
        ParameterError: ``inertia`` or ``timestep`` not > 0, ``damping`` negative, a value
            NaN or infinite, not a number, or shapes that do not broadcast.
    """
    inertia_, damping_ = check_broadcast(
        inertia=check_values("inertia", inertia, 0.0, low_open=True, unit="kg m^2"),
        damping=check_values("damping", damping, 0.0, unit="N m s/rad"),
    )
    h = check_number("timestep", timestep, 0.0, low_open=True, unit="s")
    with np.errstate(over="ignore"):  # beyond 1e308: inf, the bound's limit
        return damping_ + 2.0 * inertia_ / h

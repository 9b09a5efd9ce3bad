"""Reflected inertia and the explicit-damping timestep bound, per joint.

A torque controller that writes ``tau = -kd * qdot`` to ``ctrl`` is integrated explicitly by
every MuJoCo integrator, while the joint's own damping ``b`` is implicit under Euler. One
step of semi-implicit Euler then multiplies the joint speed by (I - h kd) / (I + h b), which
stays below 1 in magnitude exactly when h < 2 I / (kd - b).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]


def reflected_inertia(rotor_inertia: ArrayLike, gear_ratio: ArrayLike) -> Array:
    """Armature seen at the joint: N^2 J_rotor [kg m^2].

    Args:
        rotor_inertia: Rotor inertia J_rotor [kg m^2].
        gear_ratio: Gear ratio N (rotor turns per joint turn) [-].
    """
    return np.asarray(gear_ratio, dtype=float) ** 2 * np.asarray(rotor_inertia, dtype=float)


def rotor_inertia(armature: ArrayLike, gear_ratio: ArrayLike) -> Array:
    """Inverse of :func:`reflected_inertia`: J_rotor = armature / N^2 [kg m^2]."""
    return np.asarray(armature, dtype=float) / np.asarray(gear_ratio, dtype=float) ** 2


def max_stable_timestep(inertia: ArrayLike, kd: ArrayLike, damping: ArrayLike) -> Array:
    """Largest timestep for explicit controller damping: h < 2 I / (kd - b) [s].

    Args:
        inertia: Joint inertia I, e.g. the diagonal of M [kg m^2].
        kd: Controller damping gain, integrated explicitly [N m s/rad].
        damping: Joint damping b, integrated implicitly (Euler, implicitfast) [N m s/rad].

    Returns:
        The bound per joint [s]; ``inf`` where kd <= b (any step is stable).
    """
    inertia, kd, damping = np.broadcast_arrays(
        np.asarray(inertia, float), np.asarray(kd, float), np.asarray(damping, float)
    )
    excess = kd - damping
    with np.errstate(divide="ignore"):
        return np.where(excess > 0, 2.0 * inertia / np.where(excess > 0, excess, 1.0), np.inf)


def max_stable_kd(inertia: ArrayLike, timestep: float, damping: ArrayLike) -> Array:
    """Largest explicit damping gain stable at a timestep: kd < b + 2 I / h [N m s/rad].

    Args:
        inertia: Joint inertia I [kg m^2].
        timestep: Integration step h [s].
        damping: Joint damping b (implicit) [N m s/rad].
    """
    return np.asarray(damping, float) + 2.0 * np.asarray(inertia, float) / timestep

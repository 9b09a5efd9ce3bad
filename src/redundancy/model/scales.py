"""The scale of each quantity on one arm, and the one error measure relative to it.

Every comparison of two numbers the library makes (MuJoCo against Pinocchio in the cross-check, one
file against another in ``compare`` and [`compare_models`][redundancy.compare_models]) divides the
difference by the quantity's own scale:

    error = max |a - b| / max(max |a|, FLOOR x size)

``max |a|`` is the size of the reference value itself (the mass matrix's largest entry, the largest
gravity torque at that pose...), and ``size`` the size that quantity has on this arm (its length
``L`` for positions, ``m L^2`` for inertias, ``m g L`` for gravity torques). The floor, `FLOOR` of
that size, keeps a value that happens to be near zero (gravity torque with the arm upright, whose
rounding noise is ~1e-16 of the size) from turning rounding noise into a large relative error (1e-13
at most), while any value above it is compared to itself. A 2.5 mm arm and a 150 m crane are so held
to the same relative tolerance: an absolute 1e-9 (or 1e-9 x max(1, |value|)) passes any difference
on an arm whose inertias are 1e-11 kg m^2, and fails a crane's rounding.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..arm import Arm
from .bridges import effective_gravity

Array = NDArray[np.float64]

#: Smallest scale, so that an arm of zero size or mass never divides by zero [SI].
_TINY = 1e-300

#: The fraction of a quantity's size on the arm below which a value is compared to that
#: floor rather than to itself [-].
FLOOR = 1e-3


@dataclass(frozen=True)
class Scales:
    """The size of an arm in each unit its quantities are measured in.

    Attributes:
        length: Total length of its links: the sum of the body offsets and the tool's [m].
        mass: Total mass [kg].
        gravity: Magnitude of the gravity MuJoCo simulates (1 when it is off) [m/s^2].
    """

    length: float
    mass: float
    gravity: float

    @property
    def inertia(self) -> float:
        """M L^2 [kg m^2]."""
        return max(self.mass * self.length**2, _TINY)

    @property
    def torque(self) -> float:
        """M g L: the largest gravity torque the arm's size allows [N m]."""
        return max(self.mass * self.gravity * self.length, _TINY)


def arm_scales(arm: Arm) -> Scales:
    """The `Scales` of an arm, from MuJoCo's compiled model (arrays only).

    Over the bodies the arm moves (an arm inside a robot: not the held rest of it): their
    offsets and the tool's make the length (the engine's
    `model_length`); their masses make the mass. Zero falls back
    to 1 (an absolute scale) rather than to nothing.
    """
    m = arm.mj_model
    moved = np.flatnonzero(m.body_weldid != 0)
    mass = float(m.body_mass[moved].sum())
    g = float(np.linalg.norm(effective_gravity(m)))
    return Scales(arm.mujoco.length, mass if mass > 0 else 1.0, g if g > 0 else 1.0)


def scaled_errors(a: Array, b: Array, size: float) -> Array:
    """Per pose, max |a - b| / max(max |a|, FLOOR x size) over one pose's value's entries.

    Args:
        a: Reference values, stacked (n, ...).
        b: Values compared to them, same shape.
        size: The quantity's size on the arm (see the module docstring) [its unit].

    Returns:
        Errors, shape (n,); NaN or inf where a value is not finite.
    """
    n = len(a)
    if n == 0:
        return np.zeros(0)
    a, b = a.reshape(n, -1), b.reshape(n, -1)
    if a.shape[1] == 0:
        return np.zeros(n)
    scale = np.maximum(np.max(np.abs(a), axis=1), max(FLOOR * size, _TINY))
    return np.max(np.abs(a - b), axis=1) / scale


def scaled_error(a: object, b: object, size: float) -> float:
    """One value's error, as `scaled_errors`, with infinities allowed.

    Equal infinities count as equal; an infinity against a finite value, or a NaN, is an
    infinite error. The scale is the largest finite ``|a|`` (or ``FLOOR x size``).
    """
    a_arr, b_arr = np.asarray(a, float).ravel(), np.asarray(b, float).ravel()
    if a_arr.size == 0:
        return 0.0
    same_inf = np.isinf(a_arr) & np.isinf(b_arr) & (np.sign(a_arr) == np.sign(b_arr))
    with np.errstate(invalid="ignore"):
        diff = np.abs(a_arr - b_arr)
    diff = np.where(same_inf, 0.0, np.nan_to_num(diff, nan=np.inf, posinf=np.inf))
    finite = np.abs(a_arr[np.isfinite(a_arr)])
    scale = max(float(finite.max()) if finite.size else 0.0, FLOOR * size, _TINY)
    return float(diff.max() / scale)

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

import numpy as np
from numpy.typing import NDArray

from ..arm import Arm
from ..engines.mujoco import effective_gravity
from ..kernels import FLOOR as FLOOR
from ..kernels import Scales as Scales
from ..kernels import scaled_error as scaled_error
from ..kernels import scaled_errors as scaled_errors

Array = NDArray[np.float64]


def arm_scales(arm: Arm) -> Scales:
    """The `Scales` of an arm, from MuJoCo's compiled model (arrays only).

    Over the bodies the arm moves (an arm inside a robot: not the held rest of it): their
    offsets and the tool's make the length (the engine's
    `model_length`); their masses make the mass, their own rotational inertias the
    inertia's other bound. Zero falls back to 1 (an absolute scale) rather than to nothing.
    """
    m = arm.mj_model
    moved = np.flatnonzero(m.body_weldid != 0)
    mass = float(m.body_mass[moved].sum())
    own = float(m.body_inertia[moved].max(axis=1).sum()) if len(moved) else 0.0
    g = float(np.linalg.norm(effective_gravity(m)))
    return Scales(arm.length, mass if mass > 0 else 1.0, g if g > 0 else 1.0, own, arm.nq)

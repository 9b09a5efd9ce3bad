"""What a model's actuators add to each joint: effort limits, reflected armature and damping.

Read from MuJoCo's compiled model (arrays only; no engine computation).
"""

from __future__ import annotations

import mujoco
import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]


def joint_force_limits(model: mujoco.MjModel) -> Array:
    """Largest force or torque the actuators can apply at each dof.

    For each actuator that transmits to a joint the limit is ``|gear| * forcerange`` when
    force-limited, otherwise ``|gear * gain * ctrlrange|`` for a motor-type actuator with a
    limited control; several actuators on one joint add up; a joint-level ``actfrcrange``
    caps the sum. Unlimited or unknown gives ``inf``.

    Args:
        model: Compiled MuJoCo model.

    Returns:
        Limits, shape (nv,) [N m for hinges, N for slides].
    """
    limit = np.zeros(model.nv)
    found = np.zeros(model.nv, dtype=bool)
    for a in range(model.nu):
        if model.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_JOINT:
            continue
        dof = model.jnt_dofadr[model.actuator_trnid[a, 0]]
        gear = abs(model.actuator_gear[a, 0])
        if model.actuator_forcelimited[a]:
            lim = np.max(np.abs(model.actuator_forcerange[a])) * gear
        elif (
            model.actuator_ctrllimited[a]
            and model.actuator_gaintype[a] == mujoco.mjtGain.mjGAIN_FIXED
            and model.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_NONE
        ):
            lim = (
                np.max(np.abs(model.actuator_ctrlrange[a]))
                * abs(model.actuator_gainprm[a, 0])
                * gear
            )
        else:
            lim = np.inf
        limit[dof] += lim
        found[dof] = True
    limit[~found] = np.inf
    for j in range(model.njnt):
        if model.jnt_actfrclimited[j]:
            dof = model.jnt_dofadr[j]
            limit[dof] = min(limit[dof], np.max(np.abs(model.jnt_actfrcrange[j])))
    return limit


def _reflected_per_dof(model: mujoco.MjModel, values: Array) -> Array:
    """Sum of gear^2 * value over the joint actuators of each dof (rotor-side to joint-side)."""
    extra = np.zeros(model.nv)
    for a in range(model.nu):
        if model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT:
            dof = model.jnt_dofadr[model.actuator_trnid[a, 0]]
            extra[dof] += model.actuator_gear[a, 0] ** 2 * values[a]
    return extra


def actuator_armature(model: mujoco.MjModel) -> Array:
    """Armature that actuators add to each dof: ``gear^2 * actuator_armature`` [kg m^2]."""
    return _reflected_per_dof(model, model.actuator_armature)


def actuator_damping(model: mujoco.MjModel) -> Array:
    """Damping that actuators add to each dof: ``gear^2 * actuator_damping`` [N m s/rad]."""
    return _reflected_per_dof(model, model.actuator_damping)

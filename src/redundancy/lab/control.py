"""The lesson's joint PD controller and a hold simulation, stepped in MuJoCo."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from ..arm import Arm
from ..engines import simulation
from ..engines.mujoco import captured_warnings
from ..errors import MissingInertiaError, UnsupportedFeatureError

Array = NDArray[np.float64]

_JOINT_TRANSMISSIONS = (int(mujoco.mjtTrn.mjTRN_JOINT), int(mujoco.mjtTrn.mjTRN_JOINTINPARENT))


class JointPD:
    """The lesson's controller, tau = qfrc_bias + kp (q* - q) - kd qdot, stepped in MuJoCo.

    The torque goes through each dof's first joint actuator as ``ctrl = tau / gear`` (so the
    actuator's ctrlrange clamps it, as on the real arm); a dof without one gets it through
    ``qfrc_applied``, unclamped.

    Args:
        model: The model it will step (only its actuator layout is read here).
    """

    actuators: tuple[tuple[int, int, float], ...]
    unactuated: NDArray[np.int_]

    def __init__(self, model: mujoco.MjModel) -> None:
        actuators: list[tuple[int, int, float]] = []
        seen: set[int] = set()
        for a in range(model.nu):
            # jointinparent is joint for a hinge or slide (model.actuators.JOINT_TRANSMISSIONS).
            if int(model.actuator_trntype[a]) not in _JOINT_TRANSMISSIONS:
                continue
            dof = int(model.jnt_dofadr[model.actuator_trnid[a, 0]])
            gear = float(model.actuator_gear[a, 0])
            if dof in seen or gear == 0.0:
                continue
            seen.add(dof)
            actuators.append((a, dof, gear))
        self.actuators = tuple(actuators)
        # Index arrays, so the per-step mapping is one vectorised assignment, not a loop.
        self._act = np.array([a for a, _, _ in actuators], dtype=int)
        self._dof = np.array([k for _, k, _ in actuators], dtype=int)
        self._gear = np.array([g for _, _, g in actuators], dtype=float)
        self.unactuated = np.array([k for k in range(model.nv) if k not in seen], dtype=int)

    def step(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        target: Array,
        kp: float,
        kd: float,
        gravity_compensation: bool = True,
    ) -> None:
        """One timestep under the controller (one ``mj_step``, see `simulation.step`)."""

        def actuate() -> None:
            # qfrc_bias is the state's about to be integrated (after mj_step1).
            tau = data.qfrc_bias.copy() if gravity_compensation else np.zeros(model.nv)
            if kp or kd:
                tau += kp * (target - data.qpos) - kd * data.qvel
            data.ctrl[self._act] = tau[self._dof] / self._gear
            if self.unactuated.size:
                data.qfrc_applied[self.unactuated] = tau[self.unactuated]

        simulation.step(model, data, actuate)

    def applied(self, data: mujoco.MjData, dof: int) -> float:
        """Torque applied to a dof in the last step, after the actuator's clamp [N m or N]."""
        if dof in self.unactuated:
            return float(data.qfrc_applied[dof])
        return float(data.qfrc_actuator[dof])


@dataclass(frozen=True)
class HoldResult:
    """Peak joint speeds while a controller holds a pose in simulation.

    Attributes:
        peak_speed: Largest |qvel| per joint over the run [rad/s or m/s].
        bad_qacc_warnings: MuJoCo's count of bad-acceleration warnings (NaN/huge qacc, after
            which it resets the simulation).
        messages: MuJoCo's warning texts during the run (captured, not printed).
    """

    peak_speed: Array
    bad_qacc_warnings: int
    messages: tuple[str, ...] = ()


def simulate_hold(
    model: mujoco.MjModel,
    target: Array,
    kp: float,
    kd: float,
    seconds: float,
    nudge: float = 0.01,
    gravity_compensation: bool = True,
    record_from: float = 0.0,
) -> HoldResult:
    """Hold ``target`` with tau = qfrc_bias + kp (q* - q) - kd qdot, written to ``ctrl``.

    The run starts at ``target`` with every joint speed set to ``nudge``. The controller's
    torque is clamped by the actuators' ctrlrange, as MuJoCo does.

    Args:
        model: Model to simulate (its timestep, integrator and flags are used as they are).
        target: Pose to hold [rad].
        kp: Stiffness [N m/rad].
        kd: Damping gain, applied explicitly through ctrl [N m s/rad].
        seconds: Duration [s].
        nudge: Initial joint speed on every joint [rad/s].
        gravity_compensation: Add qfrc_bias (gravity, Coriolis) to the command.
        record_from: Fraction of the run after which speeds are recorded (0: every step).
    """
    with captured_warnings() as messages:
        return _hold(
            model, target, kp, kd, seconds, nudge, gravity_compensation, record_from, messages
        )


def _hold(
    model: mujoco.MjModel,
    target: Array,
    kp: float,
    kd: float,
    seconds: float,
    nudge: float,
    gravity_compensation: bool,
    record_from: float,
    messages: list[str],
) -> HoldResult:
    d = simulation.new_state(model)
    d.qpos[:] = target
    d.qvel[:] = nudge
    n = round(seconds / model.opt.timestep)
    first = record_from * n if record_from > 0 else -1
    peak = np.zeros(model.nv)
    controller = JointPD(model)
    for i in range(n):
        controller.step(model, d, target, kp, kd, gravity_compensation)
        if i > first:
            np.maximum(peak, np.abs(d.qvel), out=peak)
    warnings = int(d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number)
    return HoldResult(peak, warnings, tuple(messages))


def simulable(arm: Arm) -> None:
    """Check that the lab can step the arm's MuJoCo model.

    Raises:
        MissingInertiaError: Links the arm moves without inertia.
        UnsupportedFeatureError: An arm with coupled joints: the chain model the engines
            compute on has its couplings solved, not simulated (stepping it would let the
            followers swing free).
    """
    if arm.missing_inertia:  # a simulation needs every mass the arm moves
        raise MissingInertiaError("a simulation", arm.missing_inertia)
    if arm.coupling is not None:
        raise UnsupportedFeatureError(
            "coupled joints in the lab",
            f"followers {', '.join(repr(n) for n in arm.followers)}",
            "the lab steps MuJoCo's model of the arm, whose couplings the library solves "
            "instead of simulating; the audit, the quantities, batch and IK serve the arm",
        )

"""MuJoCo side of the two-engine core: a thin wrapper that owns its ``MjData``.

All MuJoCo calls of the library live here. Arrays come back in the library's joint order,
which is MuJoCo's own (``jnt`` order; hinge and slide joints only, so qpos, qvel and dof
orders coincide).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from dataclasses import dataclass

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


class MujocoEngine:
    """MuJoCo model and data for one site, evaluated at joint configurations.

    Args:
        model: Compiled model (hinge and slide joints only; checked by the loader).
        site: Name of the tool site.
    """

    name = "mujoco"

    def __init__(self, model: mujoco.MjModel, site: str) -> None:
        self.model = model
        self.data = mujoco.MjData(model)
        self.site_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, site)
        self.nv = model.nv
        # Armature as M sees it: the joint's own plus what its actuators reflect.
        self.armature = model.dof_armature + actuator_armature(model)
        # mj_jacSite and mj_jacDot write into contiguous row views of one 6 x nv array, so the
        # stacked Jacobian needs no vstack; qpos/qvel views are kept because each attribute
        # access on MjData builds a new array view.
        self._jac = np.zeros((6, model.nv))
        self._jacp, self._jacr = self._jac[:3], self._jac[3:]
        self._qpos, self._qvel = self.data.qpos, self.data.qvel
        self._M = np.zeros((model.nv, model.nv))
        self._tau = np.zeros(model.nv)

    def _kinematics(self, q: Array) -> None:
        d = self.data
        self._qpos[:] = q
        self._qvel[:] = 0.0
        # mj_kinematics gives body, geom and site poses; mj_comPos adds the com-based
        # quantities (cdof, cinert) that Jacobians, mj_crb and mj_rne read.
        mujoco.mj_kinematics(self.model, d)
        mujoco.mj_comPos(self.model, d)

    def site_pose(self, q: Array) -> tuple[Array, Array]:
        """Site position [m] and rotation matrix (world frame)."""
        self._kinematics(q)
        i = self.site_id
        return self.data.site_xpos[i].copy(), self.data.site_xmat[i].reshape(3, 3).copy()

    def site_jacobian(self, q: Array) -> Array:
        """Site Jacobian, shape (6, nv): linear rows [m/rad], then angular [rad/rad], world axes."""
        self._kinematics(q)
        mujoco.mj_jacSite(self.model, self.data, self._jacp, self._jacr, self.site_id)
        return self._jac.copy()

    def mass_matrix(self, q: Array, armature: bool = True) -> Array:
        """Joint-space mass matrix [kg m^2], with or without armature on the diagonal."""
        self._kinematics(q)
        # mj_crb fills d.M (sparse, armature included); mj_fullM makes it dense.
        mujoco.mj_crb(self.model, self.data)
        mujoco.mj_fullM(self.model, self.data, self._M)
        M = self._M.copy()
        if not armature:
            M[np.diag_indices(self.nv)] -= self.armature
        return M

    def gravity(self, q: Array) -> Array:
        """Generalised gravity force [N m]: what the motors must apply to hold ``q`` still."""
        self._kinematics(q)
        # With qvel = 0 (and cvel = 0, see jacobian_derivatives) and flg_acc = 0, RNE returns
        # the bias force, which is then gravity alone.
        mujoco.mj_rne(self.model, self.data, 0, self._tau)
        return self._tau.copy()

    def jacobian_derivatives(self, q: Array) -> Array:
        """dJ/dq_k for every k, shape (nv, 6, nv), from ``mj_jacDot`` with qvel = e_k.

        ``mj_jacDot`` returns dJ/dt = sum_k dJ/dq_k qdot_k, so a unit velocity on one dof
        gives that dof's partial derivative exactly (no finite differences).
        """
        m, d = self.model, self.data
        self._kinematics(q)
        body = m.site_bodyid[self.site_id]
        point = d.site_xpos[self.site_id].copy()
        out = np.zeros((self.nv, 6, self.nv))
        for k in range(self.nv):
            d.qvel[:] = 0.0
            d.qvel[k] = 1.0
            # mj_comVel computes cvel and cdof_dot, which mj_jacDot reads.
            mujoco.mj_comVel(m, d)
            mujoco.mj_jacDot(m, d, self._jacp, self._jacr, point, body)
            out[k, :3] = self._jacp
            out[k, 3:] = self._jacr
        # Leave no velocity behind: mj_rne (gravity) reads cvel and cdof_dot.
        d.qvel[:] = 0.0
        mujoco.mj_comVel(m, d)
        return out

    def integrate(self, q: Array, dq: Array) -> Array:
        """Configuration reached from ``q`` after the displacement ``dq`` [rad or m]."""
        out = np.array(q, dtype=float)
        mujoco.mj_integratePos(self.model, out, dq, 1.0)
        return out

    def link_inertias(self, q: Array) -> tuple[Array, Array, Array]:
        """Mass [kg], centre of mass [m] and world inertia about it [kg m^2] per dof's body.

        Bodies welded to a moving body are lumped into it, as Pinocchio does.
        """
        m, d = self.model, self.data
        self._kinematics(q)
        masses = np.zeros(self.nv)
        coms = np.zeros((self.nv, 3))
        inertias = np.zeros((self.nv, 3, 3))
        for k in range(self.nv):
            owner = m.dof_bodyid[k]
            bodies = [b for b in range(1, m.nbody) if m.body_weldid[b] == owner]
            mass = sum(m.body_mass[b] for b in bodies)
            com = (
                sum(m.body_mass[b] * d.xipos[b] for b in bodies) / mass
                if mass > 0
                else d.xpos[owner]
            )
            inertia = np.zeros((3, 3))
            for b in bodies:
                R = d.ximat[b].reshape(3, 3)
                r = d.xipos[b] - com
                inertia += R @ np.diag(m.body_inertia[b]) @ R.T
                inertia += m.body_mass[b] * (r @ r * np.eye(3) - np.outer(r, r))
            masses[k], coms[k], inertias[k] = mass, com, inertia
        return masses, coms, inertias

    def joint_axes(self, q: Array) -> tuple[Array, Array]:
        """World joint axes (unit) and anchor points [m], shape (nv, 3) each."""
        self._kinematics(q)
        return self.data.xaxis.copy(), self.data.xanchor.copy()


class JointPD:
    """The lesson's controller, tau = qfrc_bias + kp (q* - q) - kd qdot, stepped in MuJoCo.

    The torque goes through each dof's first joint actuator as ``ctrl = tau / gear`` (so the
    actuator's ctrlrange clamps it, as on the real arm); a dof without one gets it through
    ``qfrc_applied``, unclamped.

    Args:
        model: The model it will step (only its actuator layout is read here).
    """

    def __init__(self, model: mujoco.MjModel) -> None:
        actuators: list[tuple[int, int, float]] = []
        seen: set[int] = set()
        for a in range(model.nu):
            if model.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_JOINT:
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
        """One timestep under the controller (one ``mj_step``)."""
        # mj_step1 runs the position and velocity stages, so qfrc_bias is current for the
        # state about to be integrated; mj_step2 then applies ctrl and integrates. Together
        # they are one mj_step, without the extra mj_forward a read-then-step loop needs.
        mujoco.mj_step1(model, data)
        tau = data.qfrc_bias.copy() if gravity_compensation else np.zeros(model.nv)
        if kp or kd:
            tau += kp * (target - data.qpos) - kd * data.qvel
        data.ctrl[self._act] = tau[self._dof] / self._gear
        if self.unactuated.size:
            data.qfrc_applied[self.unactuated] = tau[self.unactuated]
        mujoco.mj_step2(model, data)

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


@contextlib.contextmanager
def captured_warnings() -> Iterator[list[str]]:
    """Collect MuJoCo's warnings instead of letting it print them and write MUJOCO_LOG.TXT."""
    messages: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda msg: messages.append(str(msg).strip()))
    try:
        yield messages
    finally:
        mujoco.set_mju_user_warning(previous)


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
    d = mujoco.MjData(model)
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

"""The momentum observer: the external joint torque on an arm from its joint data alone.

De Luca and Mattone's observer of the generalized momentum p = M(q) v. Along the motion,
dp/dt = tau + tau_ext + C(q, v)^T v - g(q) + tau_passive, so the residual

    r = K (p(t) - p(0) - integral of (tau + C^T v - g + tau_passive + r) dt)

follows tau_ext as a first-order filter of gain K [1/s]: r(s) = K / (s + K) tau_ext(s). No
acceleration is measured or differentiated. The model's terms come from MuJoCo
(`MujocoEngine.momentum_terms <redundancy.engines.mujoco.MujocoEngine.momentum_terms>`):
M with armature, C^T v, gravity, and ``qfrc_passive`` (joint damping and springs, gravity
compensation, fluid forces), so ``tau`` is the actuators' torque alone (MuJoCo's
``qfrc_actuator``). What the model's smooth dynamics leave out shows in r as external:
contacts, joint-limit and friction-loss constraints, and any difference between the arm's
model and the robot (a changed armature, a payload).

The integral is a sum of rectangles, one per step, as MuJoCo's Euler step integrates: in
simulation the estimate differs from the true torque's first-order filter by the
discretization (0.3 % of the torque at dt = 2 ms in the tests, four times less at dt / 4).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..arm import Arm, check_arm
from ..checks import check_joint_vector, check_values
from ..errors import ParameterError

Array = NDArray[np.float64]

__all__ = ["MomentumObserver"]


def check_gain(gain: object, nq: int) -> Array:
    """The observer's gain: a number or one per joint, finite and > 0 [1/s], as (nq,).

    Raises:
        ParameterError: Not finite numbers > 0, or neither one number nor nq of them.
    """
    K = check_values("gain", gain, 0.0, low_open=True, unit="1/s")
    if K.ndim == 0:
        return np.full(nq, float(K))
    if K.shape != (nq,):
        raise ParameterError("gain", gain, f"a number or one per joint, shape ({nq},) [1/s]")
    return K.copy()


def check_dt(dt: object, max_dt: float) -> Array:
    """Steps of the observer: a number or an array of them, each in (0, max_dt) [s].

    Raises:
        ParameterError: Not finite numbers in that range (the message says why the bound).
    """
    return check_values("dt", dt, 0.0, max_dt, low_open=True, high_open=True, unit=_DT_UNIT)


_DT_UNIT = "s, below 2 / gain, where the observer diverges"


class MomentumObserver:
    """Estimate of the external joint torque from q, v and the actuators' torque.

    One observer follows one trajectory: its state is the momentum at the first update and
    the running integral. Give each thread or stream its own observer (an arm may be
    shared). The first `update` starts the observer and returns zeros.

    Args:
        arm: The arm.
        gain: K [1/s], a number or one per joint (> 0): the estimate follows a step of
            external torque as 1 - exp(-K t).

    Raises:
        ParameterError: ``arm`` is not an Arm, or a bad gain.

    Example:
        Each step of a MuJoCo simulation (the guide's Motion and momentum page runs one)::

            obs = MomentumObserver(arm, gain=50.0)
            q, v = d.qpos.copy(), d.qvel.copy()  # the state the step starts from
            mujoco.mj_step(m, d)
            r = obs.update(q, v, d.qfrc_actuator, m.opt.timestep)
    """

    def __init__(self, arm: Arm, gain: object) -> None:
        self.arm: Arm = check_arm(arm)
        self.gain: Array = check_gain(gain, arm.nq)
        #: The longest step [s]: the observer integrates r' = K (tau_ext - r) by forward
        #: Euler, r <- (1 - K dt) r + K dt tau_ext, which diverges at K dt >= 2.
        self.max_dt: float = 2.0 / float(np.max(self.gain))
        self._terms = arm.mujoco.momentum_terms
        self._names = arm.joint_names
        self.reset()

    def reset(self) -> None:
        """Forget the trajectory: the next `update` starts again from zero."""
        self._p0: Array | None = None
        self._integral = np.zeros(self.arm.nq)
        self._r = np.zeros(self.arm.nq)

    @property
    def residual(self) -> Array:
        """The last estimate of the external torque [N m or N] (a copy)."""
        return self._r.copy()

    def update(self, q: ArrayLike, v: ArrayLike, tau: ArrayLike, dt: float) -> Array:
        """Take the state at one step and the torque applied until the next; return r.

        Args:
            q: Pose at this step [rad or m].
            v: Joint velocity at this step [rad/s or m/s].
            tau: The actuators' torque applied from this step to the next (MuJoCo's
                ``qfrc_actuator``) [N m or N].
            dt: Time to the next step [s], in (0, `max_dt`): 2 / gain, beyond which
                the observer's filter diverges.

        Returns:
            The estimated external joint torque at this step, shape (nq,) [N m or N]
            (torques acting on the arm, as ``J^T F`` for a force F at the tool).

        Raises:
            PoseError: ``q``, ``v`` or ``tau`` not a finite real (nq,) vector.
            ParameterError: ``dt`` not a finite number in (0, 2 / gain).
        """
        tau = check_joint_vector("tau", tau, self._names)
        if type(dt) is not float or not 0.0 < dt < self.max_dt:
            step = check_dt(dt, self.max_dt)
            if step.ndim:
                raise ParameterError("dt", dt, "one number [s]")
            dt = float(step)
        p, beta = self._terms(q, v)
        return self.advance(p, beta, tau, dt)

    def advance(self, p: Array, beta: Array, tau: Array, dt: float) -> Array:
        """`update` from the model's terms at the step, unchecked.

        For a recorded trajectory whose terms were computed apart (on workers, see
        `redundancy.batch.external_torques`): the same arithmetic as `update`.

        Args:
            p: The momentum M v at the step (nq,) [N m s].
            beta: C^T v - g + the passive force at the step (nq,) [N m]
                (`MujocoEngine.momentum_terms
                <redundancy.engines.mujoco.MujocoEngine.momentum_terms>` gives both).
            tau: The actuators' torque (nq,) [N m], finite float64.
            dt: Time to the next step [s], a float in (0, `max_dt`).
        """
        if self._p0 is None:
            self._p0 = p
        r = self._r
        np.multiply(self.gain, p - self._p0 - self._integral, out=r)
        self._integral += (tau + beta + r) * dt
        return r.copy()

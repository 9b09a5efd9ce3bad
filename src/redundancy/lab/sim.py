"""The lab's simulation: an arm held at target angles by PD control with gravity compensation.

This module is the lab without a browser: :class:`LabSim` steps MuJoCo with the lesson's
controller and computes the readouts, and :class:`RealTimeRunner` steps it against the wall
clock in a background thread. :mod:`redundancy.lab` draws both in a web page.

The controller, evaluated at every step of ``h`` (the model's timestep)::

    tau = qfrc_bias + kp (q* - q) - kd qdot

is written to the joint motors, whose ``ctrlrange`` clamps it (for arm7's wrist roll j7,
to 10 N m). Like every torque computed outside MuJoCo, its damping ``kd qdot`` is explicit:
on a joint whose inertia is too small for ``h`` (arm7 without armature) it makes the joint
buzz, which is the lab's third experiment.

Self-contacts are a readout (MuJoCo's contact rules through
:func:`redundancy.collision.checker`), by default without contact forces so that the arm can
be posed through itself, as the lesson's second experiment asks; with ``contact_forces=True``
the links collide and stop each other.
"""

from __future__ import annotations

import collections
import copy
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import collision, linalg
from ..arm import Arm
from ..errors import PoseError
from .control import JointPD

Array = NDArray[np.float64]

#: The lesson's stiffness [N m/rad].
KP = 100.0
#: The lesson's starting damping gain [N m s/rad].
KD = 5.0
#: Span of the plot of the watched joint's speed [s].
SPEED_WINDOW = 4.0
#: Span of the plot of sigma_min [s].
SIGMA_WINDOW = 8.0
#: sigma_min is sampled every this many steps for its plot.
SIGMA_EVERY = 10
#: Span over which the peak speed of the watched joint is taken [s].
PEAK_WINDOW = 0.2
#: The nudge: a speed added to every joint [rad/s or m/s] (the lesson's script uses 0.01).
NUDGE = 0.01


@dataclass(frozen=True)
class LabReadouts:
    """What the lab shows, at one instant of the simulation.

    Attributes:
        time: Simulated time since the start [s].
        q: Joint positions [rad or m].
        qdot: Joint speeds [rad/s or m/s].
        targets: Target positions q* [rad or m].
        kp: Stiffness [N m/rad].
        kd: Damping gain [N m s/rad].
        armature: Armature per joint in the simulated model [kg m^2].
        contact_forces: Whether the links collide (True) or pass through each other (False).
        sigma_min: Smallest singular value of the site Jacobian [mixed: m/rad, rad/rad].
        manipulability: Yoshikawa's measure, the product of the singular values.
        contact_pairs: Geom pairs in self-contact (``"link2 / link4"``), in pair-set order.
        contact_points: Contact positions, world frame, shape (n, 3) [m].
        watch_joint: Name of the joint whose speed is watched (the last one: j7 for arm7).
        watch_speed: Its speed [rad/s].
        watch_peak: Its largest |speed| over the last :data:`PEAK_WINDOW` [rad/s].
        watch_torque: The torque its motor applies, after clamping [N m].
        watch_limit: Its motor's torque limit [N m].
    """

    time: float
    q: Array
    qdot: Array
    targets: Array
    kp: float
    kd: float
    armature: Array
    contact_forces: bool
    sigma_min: float
    manipulability: float
    contact_pairs: tuple[str, ...]
    contact_points: Array
    watch_joint: str
    watch_speed: float
    watch_peak: float
    watch_torque: float
    watch_limit: float

    @property
    def contacts_text(self) -> str:
        """The self-contact pairs joined by commas, or ``"none"``."""
        return ", ".join(self.contact_pairs) or "none"


class LabSim:
    """One arm under the lesson's controller, stepped on demand; thread-safe.

    Args:
        arm: The arm (its MuJoCo model is copied; the arm itself is not modified).
        kp: Stiffness [N m/rad].
        kd: Damping gain [N m s/rad].
        keyframe: Keyframe to start from and hold (falls back to ``qpos0`` when the model
            has no keyframe of that name).
        contact_forces: Let links collide; ``False`` keeps contacts as a readout only.
        watch: Joint whose speed is watched and plotted (default: the last joint).

    Raises:
        UnknownNameError: ``watch`` is not a joint of the arm.
    """

    def __init__(
        self,
        arm: Arm,
        kp: float = KP,
        kd: float = KD,
        keyframe: str = "home",
        contact_forces: bool = False,
        watch: str | None = None,
    ) -> None:
        self.arm = arm
        self.model = copy.deepcopy(arm.mj_model)
        self.data = mujoco.MjData(self.model)
        self.kp = float(kp)
        self.kd = float(kd)
        self.timestep = float(self.model.opt.timestep)
        self.joint_names = arm.joint_names
        self.watch_joint = watch if watch is not None else arm.joint_names[-1]
        self._watch = arm.joint_index(self.watch_joint)
        self.lower, self.upper = self.slider_ranges(arm)
        self.keyframe_name = keyframe if keyframe in arm.keyframes else None
        self.home = (
            arm.keyframe(keyframe) if self.keyframe_name else self.model.qpos0.copy()
        ).astype(float)
        self.modelled_armature = self.model.dof_armature.copy()
        self.effort_limit = arm.effort_limit.copy()
        self._controller = JointPD(self.model)
        self._checker = collision.checker(arm)
        self._lock = threading.RLock()
        self.targets = self.home.copy()
        self._steps = 0
        n_speed = round(SPEED_WINDOW / self.timestep)
        n_sigma = round(SIGMA_WINDOW / (SIGMA_EVERY * self.timestep))
        self._speed_t: collections.deque[float] = collections.deque(maxlen=n_speed)
        self._speed_v: collections.deque[float] = collections.deque(maxlen=n_speed)
        self._sigma_t: collections.deque[float] = collections.deque(maxlen=n_sigma)
        self._sigma_v: collections.deque[float] = collections.deque(maxlen=n_sigma)
        self.set_contact_forces(contact_forces)
        self.reset()

    # -- set-up helpers ------------------------------------------------------------------
    @staticmethod
    def slider_ranges(arm: Arm) -> tuple[Array, Array]:
        """Lower and upper slider bounds per joint: the joint range, or [-pi, pi] [rad or m]."""
        lo = np.where(np.isfinite(arm.lower), arm.lower, -np.pi)
        hi = np.where(np.isfinite(arm.upper), arm.upper, np.pi)
        return lo.astype(float), hi.astype(float)

    # -- commands ------------------------------------------------------------------------
    def reset(self) -> None:
        """Back to the keyframe at rest, with the keyframe as target; history cleared."""
        with self._lock:
            mujoco.mj_resetData(self.model, self.data)
            self.data.qpos[:] = self.home
            mujoco.mj_forward(self.model, self.data)
            self.targets = self.home.copy()
            self._steps = 0
            for buf in (self._speed_t, self._speed_v, self._sigma_t, self._sigma_v):
                buf.clear()
            self._record_sigma()

    def set_targets(self, q: ArrayLike) -> None:
        """Set every target q*, clipped to the slider ranges [rad or m].

        Raises:
            PoseError: Wrong shape or non-finite values.
        """
        arr = self.arm.pose(q)
        with self._lock:
            self.targets = np.clip(arr, self.lower, self.upper)

    def set_target(self, joint: str, value: float) -> None:
        """Set one joint's target, clipped to its slider range [rad or m].

        Raises:
            UnknownNameError: No joint of that name.
            PoseError: ``value`` is not finite.
        """
        i = self.arm.joint_index(joint)
        if not np.isfinite(value):
            raise PoseError(f"target for {joint!r} must be finite, got {value}")
        with self._lock:
            t = self.targets.copy()
            t[i] = np.clip(float(value), self.lower[i], self.upper[i])
            self.targets = t

    def set_kd(self, kd: float) -> None:
        """Set the controller's damping gain [N m s/rad] (>= 0)."""
        if not (np.isfinite(kd) and kd >= 0):
            raise ValueError(f"kd must be finite and >= 0, got {kd}")
        with self._lock:
            self.kd = float(kd)

    def set_armature(self, value: float | None) -> None:
        """Set the armature of every joint [kg m^2]; ``None`` restores the modelled values."""
        with self._lock:
            if value is None:
                self.model.dof_armature[:] = self.modelled_armature
            else:
                if not (np.isfinite(value) and value >= 0):
                    raise ValueError(f"armature must be finite and >= 0, got {value}")
                self.model.dof_armature[:] = float(value)

    def set_contact_forces(self, on: bool) -> None:
        """Let the links collide (True) or pass through each other (False)."""
        flag = int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
        with self._lock:
            if on:
                self.model.opt.disableflags &= ~flag
            else:
                self.model.opt.disableflags |= flag
            self.contact_forces = bool(on)

    def nudge(self, speed: float = NUDGE) -> None:
        """Add ``speed`` to every joint's velocity [rad/s or m/s]: a small, repeatable push."""
        with self._lock:
            self.data.qvel[:] += speed

    # -- stepping ------------------------------------------------------------------------
    @property
    def time(self) -> float:
        """Simulated time since the last reset [s]."""
        return self._steps * self.timestep

    def step(self, n: int = 1) -> None:
        """Advance ``n`` timesteps under the controller."""
        m, d = self.model, self.data
        with self._lock:
            for _ in range(int(n)):
                self._controller.step(m, d, self.targets, self.kp, self.kd)
                self._steps += 1
                self._speed_t.append(self.time)
                self._speed_v.append(float(d.qvel[self._watch]))
                if self._steps % SIGMA_EVERY == 0:
                    self._record_sigma()

    def _record_sigma(self) -> None:
        J = self.arm.jacobian(self.data.qpos)
        self._sigma_t.append(self.time)
        self._sigma_v.append(float(linalg.jacobian_svd(J).sigma[-1]))

    # -- readouts ------------------------------------------------------------------------
    def readouts(self) -> LabReadouts:
        """The readouts at the current state."""
        with self._lock:
            d = self.data
            q = d.qpos.copy()
            svd = linalg.jacobian_svd(self.arm.jacobian(q))
            contacts = self._checker.contacts(q)
            pairs = {c.pair for c in contacts}
            order = [p for p in self._checker.pairs if p in pairs]
            points = np.array([c.position for c in contacts]).reshape(-1, 3)
            peak_n = max(1, round(PEAK_WINDOW / self.timestep))
            recent = list(self._speed_v)[-peak_n:]
            torque = self._applied_torque(self._watch)
            return LabReadouts(
                time=self.time,
                q=q,
                qdot=d.qvel.copy(),
                targets=self.targets.copy(),
                kp=self.kp,
                kd=self.kd,
                armature=self.model.dof_armature.copy(),
                contact_forces=self.contact_forces,
                sigma_min=float(svd.sigma[-1]),
                manipulability=svd.manipulability,
                contact_pairs=tuple(p.label for p in order),
                contact_points=points,
                watch_joint=self.watch_joint,
                watch_speed=float(d.qvel[self._watch]),
                watch_peak=float(np.max(np.abs(recent))) if recent else 0.0,
                watch_torque=torque,
                watch_limit=float(self.effort_limit[self._watch]),
            )

    def _applied_torque(self, dof: int) -> float:
        """Torque the controller applied to a dof in the last step, after clamping [N m]."""
        return self._controller.applied(self.data, dof)

    def speed_history(self) -> tuple[Array, Array]:
        """Times [s] and speeds [rad/s] of the watched joint over the last :data:`SPEED_WINDOW`."""
        with self._lock:
            return np.array(self._speed_t), np.array(self._speed_v)

    def sigma_history(self) -> tuple[Array, Array]:
        """Times [s] and sigma_min over the last :data:`SIGMA_WINDOW`, one per ten steps."""
        with self._lock:
            return np.array(self._sigma_t), np.array(self._sigma_v)

    def geom_poses(self, geoms: Sequence[int]) -> tuple[Array, Array]:
        """World positions [m] and quaternions (w, x, y, z) of some geoms at the current state."""
        with self._lock:
            m, d = self.model, self.data
            mujoco.mj_kinematics(m, d)
            pos = d.geom_xpos[list(geoms)].copy()
            quat = np.zeros((len(geoms), 4))
            for k, g in enumerate(geoms):
                mujoco.mju_mat2Quat(quat[k], d.geom_xmat[g])
            return pos, quat

    def frames(self) -> tuple[Array, Array, Array, Array, Array]:
        """Poses for drawing at the current state, from one ``mj_kinematics``.

        Returns:
            Body positions [m] and quaternions (w, x, y, z) of the joints' bodies, joint
            anchors [m] and unit axes (world), and the tool site's position [m].
        """
        with self._lock:
            m, d = self.model, self.data
            mujoco.mj_kinematics(m, d)
            bodies = m.jnt_bodyid
            pos = d.xpos[bodies].copy()
            quat = d.xquat[bodies].copy()
            site = d.site_xpos[self.arm.mujoco.site_id].copy()
            return pos, quat, d.xanchor.copy(), d.xaxis.copy(), site

    def run_for(self, seconds: float) -> LabReadouts:
        """Step ``seconds`` of simulated time (as fast as possible) and return the readouts."""
        self.step(round(seconds / self.timestep))
        return self.readouts()


class RealTimeRunner:
    """Steps a :class:`LabSim` in a background thread, in step with the wall clock.

    Each frame it steps ``elapsed / timestep`` times (at most ``max_lag`` seconds' worth:
    when the machine falls behind, simulated time slows down rather than piling up), then
    calls the frame callbacks with the sim.

    Args:
        sim: The simulation.
        fps: Frames per second (callback rate) [1/s].
        max_lag: Largest simulated time stepped in one frame [s].
    """

    def __init__(self, sim: LabSim, fps: float = 30.0, max_lag: float = 0.1) -> None:
        self.sim = sim
        self.period = 1.0 / fps
        self.max_steps = max(1, round(max_lag / sim.timestep))
        self.callbacks: list[Callable[[LabSim], None]] = []
        self.errors: list[BaseException] = []
        self.frames = 0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        """Start the thread (once)."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name="lab-sim", daemon=True)
            self._thread.start()

    def stop(self, timeout: float = 5.0) -> None:
        """Stop the thread and wait for it [s]."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout)

    @property
    def running(self) -> bool:
        """Whether the thread is alive."""
        return self._thread is not None and self._thread.is_alive()

    def _run(self) -> None:
        h = self.sim.timestep
        last = time.perf_counter()
        owed = 0.0
        while not self._stop.is_set():
            start = time.perf_counter()
            owed += start - last
            last = start
            n = min(int(owed / h), self.max_steps)
            try:
                if n:
                    self.sim.step(n)
                for cb in self.callbacks:
                    cb(self.sim)
            except Exception as err:  # a page error must not stop the physics
                self.errors.append(err)
                del self.errors[:-10]
            owed = min(owed - n * h, h)  # behind by more than a step: let it go
            self.frames += 1
            self._stop.wait(max(0.0, self.period - (time.perf_counter() - start)))


__all__ = [
    "KD",
    "KP",
    "LabReadouts",
    "LabSim",
    "RealTimeRunner",
]

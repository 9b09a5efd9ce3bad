"""The lab's simulation: an arm held at target angles by PD control with gravity compensation.

This module is the lab without a browser: `LabSim` steps MuJoCo with the lesson's controller and
computes the readouts, and `RealTimeRunner` steps it against a clock (the wall clock, or a fake one
in tests) with pause, single step and slow motion. `redundancy.lab.page` draws both in a web page.

The controller, evaluated at every step of ``h`` (the model's timestep)::

    tau = qfrc_bias + kp (q* - q) - kd qdot

is written to the joint motors, whose ``ctrlrange`` clamps it (for arm7's wrist roll j7,
to 10 N m). Like every torque computed outside MuJoCo, its damping ``kd qdot`` is explicit:
on a joint whose inertia is too small for ``h`` (arm7 without armature) it makes the joint
buzz, which is the lab's third experiment.

Self-contacts are a readout (MuJoCo's contact rules through `redundancy.collision.checker`), by
default without contact forces so that the arm can be posed through itself, as the lesson's second
experiment asks; with ``contact_forces=True`` the links collide and stop each other.

Redundancy is something to touch here: `LabSim.self_motion_targets` moves the targets along the
Jacobian's null space with the tool held (the library's
[`redundancy.analysis.selfmotion.self_motion`][redundancy.analysis.selfmotion.self_motion] with
drift correction), and `solve_ik` takes the targets to a dragged tool pose with the library's
inverse kinematics (`redundancy.Arm.solve_ik`), pulling toward a rest posture in the null space.
"""

from __future__ import annotations

import collections
import copy
import io
import threading
from collections.abc import Sequence

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import collision, kernels, linalg
from ..analysis import selfmotion
from ..analysis.observer import MomentumObserver
from ..arm import Arm, sampling_ranges
from ..engines import simulation
from ..errors import PoseError, RedundancyError
from .control import JointPD, simulable
from .drag import solve_ik
from .readouts import LabReadouts, six_sigmas, velocity_ellipsoid
from .runner import RealTimeRunner

Array = NDArray[np.float64]

#: The lesson's stiffness [N m/rad].
KP = 100.0
#: The lesson's starting damping gain [N m s/rad].
KD = 5.0
#: Span of the plots of the watched joint's speed and torque [s].
SPEED_WINDOW = 4.0
#: Span of the plot of sigma_min [s].
SIGMA_WINDOW = 8.0
#: sigma_min is sampled every this many steps for its plot.
SIGMA_EVERY = 10
#: Span over which the peak speed of the watched joint is taken [s].
PEAK_WINDOW = 0.2
#: The nudge: a speed added to every joint [rad/s or m/s] (the lesson's script uses 0.01).
NUDGE = 0.01
#: Below this sigma the tool directions of U are shown as lost [m/rad or rad/rad].
LOST_SIGMA = 1e-3
#: Null-space joint motion per step of the self-motion slider [rad].
SELF_MOTION_STEP = 0.01
#: Speed at which the targets travel along a self-motion [rad/s of joint motion]. The PD
#: lags its moving targets by about kd qdot / kp, so on the way the tool moves by a few
#: millimetres; at rest it is back within the drift correction's tolerance.
SELF_MOTION_SPEED = 0.5
#: Slow-motion factors offered by the runner (simulated seconds per wall-clock second).
RATES = (1.0, 0.1, 0.01)
#: The push at the tool: largest force per world axis [N].
PUSH_MAX = 30.0
#: Gain of the momentum observer that estimates the push [1/s]: it follows a step of
#: external torque as 1 - exp(-K t), 95 % in 0.15 s.
OBSERVER_GAIN = 20.0


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
        MissingInertiaError: Links the arm moves without inertia.
        UnsupportedFeatureError: An arm with coupled joints (`Arm.followers`).
    """

    model: mujoco.MjModel
    data: mujoco.MjData
    kp: float
    kd: float
    timestep: float
    joint_names: tuple[str, ...]
    watch_joint: str
    watch_index: int
    lower: Array
    upper: Array
    keyframe_name: str | None
    home: Array
    modelled_armature: Array
    effort_limit: Array
    defaults: dict[str, float | bool]
    elbow_index: int
    resets: int
    targets: Array
    contact_forces: bool

    def __init__(
        self,
        arm: Arm,
        kp: float = KP,
        kd: float = KD,
        keyframe: str = "home",
        contact_forces: bool = False,
        watch: str | None = None,
    ) -> None:
        simulable(arm)
        if keyframe in arm.keyframe_names:
            # The keyframe is the whole robot's: where it moves held joints, the lab runs
            # the arm with them there, never the keyframe's arm joints on another robot pose.
            arm = arm.at_keyframe(keyframe)
        self.arm = arm
        self.model = copy.deepcopy(arm.mj_model)
        self.data = simulation.new_state(self.model)
        self.kp = float(kp)
        self.kd = float(kd)
        self.timestep = float(self.model.opt.timestep)
        self.joint_names = arm.joint_names
        self.watch_joint = watch if watch is not None else arm.joint_names[-1]
        self.watch_index = arm.joint_index(self.watch_joint)
        self.lower, self.upper = self.slider_ranges(arm)
        self.keyframe_name = keyframe if keyframe in arm.keyframes else None
        self.home = (
            arm.keyframe(keyframe) if self.keyframe_name else self.model.qpos0.copy()
        ).astype(float)
        self.modelled_armature = self.model.dof_armature.copy()
        self.effort_limit = arm.effort_limit.copy()
        #: The settings "reset all" goes back to.
        self.defaults = {"kd": self.kd, "contact_forces": bool(contact_forces)}
        #: The joint whose anchor is the elbow (the middle joint, as in the self-motion).
        self.elbow_index = arm.nq // 2
        self._controller = JointPD(self.model)
        self._checker = collision.checker(arm)
        self._lock = threading.RLock()
        self.targets = self.home.copy()
        self._path: Array | None = None
        self._path_start = 0.0
        self._steps = 0
        #:  How many times the pose was reset (`reset_pose`, `reset_all`).
        self.resets = -1
        self._drawn_qpos = b""  # qpos of the frames last computed for drawing
        n_speed = round(SPEED_WINDOW / self.timestep) + 1
        n_sigma = round(SIGMA_WINDOW / (SIGMA_EVERY * self.timestep)) + 1
        self._speed_t: collections.deque[float] = collections.deque(maxlen=n_speed)
        self._speed_v: collections.deque[float] = collections.deque(maxlen=n_speed)
        self._torque_v: collections.deque[float] = collections.deque(maxlen=n_speed)
        self._sigma_t: collections.deque[float] = collections.deque(maxlen=n_sigma)
        self._sigma_v: collections.deque[float] = collections.deque(maxlen=n_sigma)
        #: The force pushing at the tool, world axes [N] (`set_push`).
        self.push = np.zeros(3)
        # The external torque on the joints from q, qdot and the motors' torque alone
        # (the arm's model, as loaded: a changed armature shows as an external torque).
        self._observer = MomentumObserver(arm, OBSERVER_GAIN)
        self._push_body = int(self.model.site_bodyid[arm.mujoco.site_id])
        self._ext_estimate: collections.deque[float] = collections.deque(maxlen=n_speed)
        self._ext_true: collections.deque[float] = collections.deque(maxlen=n_speed)
        self.set_contact_forces(contact_forces)
        self.reset_pose()

    # -- set-up helpers ------------------------------------------------------------------
    @staticmethod
    def slider_ranges(arm: Arm) -> tuple[Array, Array]:
        """Lower and upper slider bounds per joint: the sampling ranges [rad or m].

        The joint range; an unlimited joint gets [-pi, pi], by the library's one rule
        ([`redundancy.arm.sampling_ranges`][redundancy.arm.sampling_ranges]).
        """
        return sampling_ranges(arm, unlimited_slide=np.pi)

    # -- commands ------------------------------------------------------------------------
    def reset_pose(self) -> None:
        """Back to the keyframe at rest, with the keyframe as target; history cleared.

        The settings (kd, armature, contact forces) are kept: see `reset_all`.
        """
        with self._lock:
            mujoco.mj_resetData(self.model, self.data)
            self.data.qpos[:] = self.home
            simulation.settle(self.model, self.data)
            self.targets = self.home.copy()
            self._path = None
            self._steps = 0
            self.resets += 1
            for buf in (
                self._speed_t,
                self._speed_v,
                self._torque_v,
                self._sigma_t,
                self._sigma_v,
                self._ext_estimate,
                self._ext_true,
            ):
                buf.clear()
            self._observer.reset()  # the state jumped: its momentum starts again
            self._record_sigma()

    def reset_all(self) -> None:
        """`reset_pose`, and kd, armature, contact forces and the push to their defaults."""
        with self._lock:
            self.set_push(np.zeros(3))
            self.set_kd(self.defaults["kd"])
            self.set_armature(None)
            self.set_contact_forces(bool(self.defaults["contact_forces"]))
            self.reset_pose()

    def set_targets(self, q: ArrayLike) -> None:
        """Set every target q*, clipped to the slider ranges [rad or m].

        Raises:
            PoseError: Wrong shape or non-finite values.
        """
        arr = self.arm.pose(q)
        with self._lock:
            self._path = None
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
            self._path = None
            t = self.targets.copy()
            t[i] = np.clip(float(value), self.lower[i], self.upper[i])
            self.targets = t

    def follow(self, path: ArrayLike, speed: float = SELF_MOTION_SPEED) -> None:
        """Move the targets along a sampled path of poses at a joint-motion speed.

        Args:
            path: Poses, shape (k, nq) [rad or m], e.g. a self-motion's ``q``.
            speed: Joint motion per second of simulated time [rad/s].
        """
        P = np.asarray(path, dtype=float)
        if P.ndim != 2 or P.shape[1] != self.arm.nq or len(P) == 0:
            raise PoseError(f"path must have shape (k, {self.arm.nq}), got {P.shape}")
        if not np.all(np.isfinite(P)):
            raise PoseError("path must be finite")
        step = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))]
        with self._lock:
            self._path = P
            self._path_s = step
            self._path_speed = float(speed)
            self._path_start = self.time
            self._advance_path()

    @property
    def following(self) -> bool:
        """Whether the targets are still travelling along a path (`follow`)."""
        return self._path is not None

    def _advance_path(self) -> None:
        if self._path is None:
            return
        s = (self.time - self._path_start) * self._path_speed
        k = int(np.searchsorted(self._path_s, s, side="right")) - 1
        if k >= len(self._path) - 1:
            self.targets = np.clip(self._path[-1], self.lower, self.upper)
            self._path = None
        else:
            self.targets = np.clip(self._path[max(k, 0)], self.lower, self.upper)

    def set_kd(self, kd: float) -> None:
        """Set the controller's damping gain [N m s/rad] (>= 0)."""
        if not (np.isfinite(kd) and kd >= 0):
            raise RedundancyError(f"kd must be finite and >= 0 N m s/rad, got {kd}")
        with self._lock:
            self.kd = float(kd)

    def set_armature(self, value: float | None) -> None:
        """Set the armature of every joint [kg m^2]; ``None`` restores the modelled values."""
        with self._lock:
            if value is None:
                self.model.dof_armature[:] = self.modelled_armature
            else:
                if not (np.isfinite(value) and value >= 0):
                    raise RedundancyError(f"armature must be finite and >= 0 kg m^2, got {value}")
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

    def set_push(self, force: ArrayLike) -> None:
        """Push at the tool with ``force`` (3,), world axes [N], each in +-`PUSH_MAX`.

        Raises:
            RedundancyError: Not three finite numbers.
        """
        f = np.asarray(force, dtype=float)
        if f.shape != (3,) or not np.all(np.isfinite(f)):
            raise RedundancyError(f"push must be three finite numbers [N], got {force!r}")
        with self._lock:
            self.push = np.clip(f, -PUSH_MAX, PUSH_MAX)

    def nudge(self, speed: float = NUDGE) -> None:
        """Add ``speed`` to every joint's velocity [rad/s or m/s]: a small, repeatable push."""
        with self._lock:
            self.data.qvel[:] += speed

    # -- redundancy ----------------------------------------------------------------------
    def elbow_position(self, q: ArrayLike) -> Array:
        """World position of the elbow joint's anchor at ``q`` [m]."""
        return self.arm.engine("mujoco").joint_axes(self.arm.pose(q))[1][self.elbow_index]

    def self_motion_path(self, anchor: ArrayLike, amount: float) -> selfmotion.SelfMotionPath:
        """The self-motion from ``anchor`` over ``|amount|`` of joint motion, tool held.

        Positive ``amount`` starts the way that raises the elbow. Uses the library's
        [`self_motion`][redundancy.analysis.selfmotion.self_motion] with drift correction, steps of
        `SELF_MOTION_STEP`; it stops early at a joint limit or where the null space vanishes
        (``path.stopped`` says which).
        """
        q = self.arm.pose(anchor)
        return selfmotion.self_motion(
            self.arm,
            q,
            total=abs(float(amount)),
            step=SELF_MOTION_STEP,
            direction=1 if amount > 0 else -1,
            correct=True,
        )

    # -- stepping ------------------------------------------------------------------------
    @property
    def time(self) -> float:
        """Simulated time since the last reset [s]."""
        return self._steps * self.timestep

    @property
    def steps(self) -> int:
        """Steps taken since the last reset."""
        return self._steps

    def step(self, n: int = 1) -> None:
        """Advance ``n`` timesteps under the controller."""
        m, d = self.model, self.data
        with self._lock:
            for _ in range(int(n)):
                self._advance_path()
                q, qdot = d.qpos.copy(), d.qvel.copy()
                true = self._apply_push(q)
                self._controller.step(m, d, self.targets, self.kp, self.kd)
                self._steps += 1
                self._speed_t.append(self.time)
                self._speed_v.append(float(d.qvel[self.watch_index]))
                self._torque_v.append(self._controller.applied(d, self.watch_index))
                self._observe(q, qdot, true)
                if self._steps % SIGMA_EVERY == 0:
                    self._record_sigma()

    def _apply_push(self, q: Array) -> Array:
        """Apply the push for the step about to be taken; its joint torque J^T F [N m].

        ``xfrc_applied`` acts at the body's centre of mass: the force at the tool is that
        force there plus the moment (tool - centre) x F. Both points are those of the last
        kinematics, the state about to be stepped.
        """
        d, F = self.data, self.push
        if not F.any():
            d.xfrc_applied[self._push_body] = 0.0
            return np.zeros(self.arm.nq)
        b = self._push_body
        arm_ = d.site_xpos[self.arm.mujoco.site_id] - d.xipos[b]
        d.xfrc_applied[b, :3] = F
        d.xfrc_applied[b, 3:] = np.cross(arm_, F)
        return self.arm.jacobian(q)[:3].T @ F

    def _observe(self, q: Array, qdot: Array, true: Array) -> None:
        """One update of the observer with the step's state and the motors' torque."""
        d = self.data
        tau = d.qfrc_actuator.copy()
        unactuated = self._controller.unactuated
        tau[unactuated] += d.qfrc_applied[unactuated]  # the controller's own torque there
        r = self._observer.update(q, qdot, tau, self.timestep)
        self._ext_estimate.append(float(np.linalg.norm(r)))
        self._ext_true.append(float(np.linalg.norm(true)))

    def _record_sigma(self) -> None:
        J = self.arm.jacobian(self.data.qpos)
        self._sigma_t.append(self.time)
        self._sigma_v.append(float(six_sigmas(linalg.jacobian_svd(J).sigma)[-1]))

    # -- readouts ------------------------------------------------------------------------
    def readouts(self) -> LabReadouts:
        """The readouts at the current state."""
        with self._lock:
            d = self.data
            q = d.qpos.copy()
            J = self.arm.jacobian(q)
            svd = linalg.jacobian_svd(J)
            sigma = six_sigmas(svd.sigma)
            axes, semi = velocity_ellipsoid(J)
            contacts = self._checker.contacts(q)
            pairs = {c.pair for c in contacts}
            order = [p for p in self._checker.pairs if p in pairs]
            points = np.array([c.position for c in contacts]).reshape(-1, 3)
            first: dict[object, Array] = {}
            for c in contacts:
                first.setdefault(c.pair, np.asarray(c.position, dtype=float))
            peak_n = max(1, round(PEAK_WINDOW / self.timestep))
            recent = list(self._speed_v)[-peak_n:]
            return LabReadouts(
                time=self.time,
                q=q,
                qdot=d.qvel.copy(),
                targets=self.targets.copy(),
                kp=self.kp,
                kd=self.kd,
                armature=self.model.dof_armature.copy(),
                contact_forces=self.contact_forces,
                sigma=sigma,
                sigma_min=float(sigma[-1]),
                manipulability=svd.manipulability,
                lost=svd.U[:, sigma < LOST_SIGMA].copy(),
                velocity_axes=axes,
                velocity_semi_axes=semi,
                tool_position=self.arm.site_pose(q)[0],
                contact_pairs=tuple(p.label for p in order),
                contact_bodies=frozenset(b for p in order for b in (p.body1, p.body2)),
                contact_points=points,
                contact_pair_points=np.array([first[p] for p in order]).reshape(-1, 3),
                watch_joint=self.watch_joint,
                watch_speed=float(d.qvel[self.watch_index]),
                watch_peak=float(np.max(np.abs(recent))) if recent else 0.0,
                watch_torque=self._controller.applied(d, self.watch_index),
                watch_limit=float(self.effort_limit[self.watch_index]),
                contact_mass=self._contact_mass(q, J, d.qvel),
            )

    def _contact_mass(self, q: Array, J: Array, qdot: Array) -> float:
        """Effective mass along the tool's velocity J_v qdot, the armature as simulated [kg]."""
        v = J[:3] @ qdot
        if not np.linalg.norm(v) > 1e-6:  # at rest: no direction of motion
            return float("nan")
        M = self.arm.mass_matrix(q, armature=False) + np.diag(self.model.dof_armature)
        u = v / np.linalg.norm(v)
        floor = linalg.motion_floor(self.arm.length)
        return kernels.effective_mass(J, np.linalg.solve(M, J.T), u, atol=floor)

    def _window(
        self, t: collections.deque[float], v: collections.deque[float], span: float
    ) -> tuple[Array, Array]:
        """The samples with time in [now - span, now]."""
        tt, vv = np.array(t), np.array(v)
        keep = tt >= self.time - span - 1e-9
        return tt[keep], vv[keep]

    def speed_history(self) -> tuple[Array, Array]:
        """Times [s] and speeds [rad/s] of the watched joint over the last `SPEED_WINDOW`."""
        with self._lock:
            return self._window(self._speed_t, self._speed_v, SPEED_WINDOW)

    def torque_history(self) -> tuple[Array, Array]:
        """Times [s] and applied torques [N m] of the watched joint's motor, same window."""
        with self._lock:
            return self._window(self._speed_t, self._torque_v, SPEED_WINDOW)

    def external_torque_history(self) -> tuple[float, tuple[Array, Array], tuple[Array, Array]]:
        """The external torque on the joints over the last `SPEED_WINDOW`, one lock.

        Returns:
            The simulated time [s]; times [s] and |r|, the observer's estimate [N m]; times
            and |J^T F|, the push's true joint torque [N m] (Euclidean norms over joints).
        """
        with self._lock:
            est = self._window(self._speed_t, self._ext_estimate, SPEED_WINDOW)
            true = self._window(self._speed_t, self._ext_true, SPEED_WINDOW)
            return self.time, est, true

    def sigma_history(self) -> tuple[Array, Array]:
        """Times [s] and sigma_min over the last `SIGMA_WINDOW`, one per ten steps."""
        with self._lock:
            return self._window(self._sigma_t, self._sigma_v, SIGMA_WINDOW)

    def histories(
        self,
    ) -> tuple[float, tuple[Array, Array], tuple[Array, Array], tuple[Array, Array]]:
        """The simulated time [s] and the three plotted series, read at one instant.

        One lock over all four, so no sample is later than the time returned (the runner
        thread steps between separate reads: a plot drawn from them showed data after now).
        """
        with self._lock:
            return self.time, self.speed_history(), self.torque_history(), self.sigma_history()

    def csv(self) -> str:
        """The plotted series as CSV: one block per plot, times relative to now [s].

        Columns: ``series, t_rel (s), value``; ``series`` is ``speed`` (rad/s), ``torque``
        (N m) or ``sigma_min``, and ``t_rel`` is the sample's time minus the current
        simulated time (0 is now, negative is the past), as on the plots.
        """
        now, (t, v), (_, tau), (ts, s) = self.histories()
        out = io.StringIO()
        out.write(f"# {self.arm.source}: {self.watch_joint}, simulated time {now:.6f} s\n")
        out.write("series,t_rel (s),value\n")
        for name, tt, vv in (("speed", t, v), ("torque", t, tau), ("sigma_min", ts, s)):
            for a, b in zip(tt - now, vv, strict=True):
                out.write(f"{name},{a:.6f},{b:.9g}\n")
        return out.getvalue()

    def _drawing_kinematics(self) -> None:
        """Frames for drawing at the current qpos (the lock held): one mj_kinematics per state.

        Drawing reads poses only, and mj_kinematics is the least that updates them; the page
        reads body frames and geom frames of one state back to back, so a state already
        brought up to date is not computed again.
        """
        key = self.data.qpos.tobytes()
        if key != self._drawn_qpos:
            simulation.place(self.model, self.data)
            self._drawn_qpos = key

    def geom_poses(self, geoms: Sequence[int]) -> tuple[Array, Array]:
        """World positions [m] and quaternions (w, x, y, z) of some geoms at the current state."""
        with self._lock:
            d = self.data
            self._drawing_kinematics()
            pos = d.geom_xpos[list(geoms)].copy()
            quat = np.zeros((len(geoms), 4))
            for k, g in enumerate(geoms):
                mujoco.mju_mat2Quat(quat[k], d.geom_xmat[g])
            return pos, quat

    def frames(self) -> tuple[Array, Array, Array, Array, Array, Array]:
        """Poses for drawing at the current state, from one ``mj_kinematics``.

        Returns:
            Body positions [m] and quaternions (w, x, y, z) of the joints' bodies, joint
            anchors [m] and unit axes (world), and the tool site's position [m] and rotation
            matrix (3 x 3).
        """
        with self._lock:
            m, d = self.model, self.data
            self._drawing_kinematics()
            bodies = m.jnt_bodyid
            pos = d.xpos[bodies].copy()
            quat = d.xquat[bodies].copy()
            sid = self.arm.mujoco.site_id
            site = d.site_xpos[sid].copy()
            rot = d.site_xmat[sid].reshape(3, 3).copy()
            return pos, quat, d.xanchor.copy(), d.xaxis.copy(), site, rot

    def run_for(self, seconds: float) -> LabReadouts:
        """Step ``seconds`` of simulated time (as fast as possible) and return the readouts."""
        self.step(round(seconds / self.timestep))
        return self.readouts()


__all__ = [
    "KD",
    "KP",
    "LabReadouts",
    "LabSim",
    "RealTimeRunner",
    "solve_ik",
    "velocity_ellipsoid",
]

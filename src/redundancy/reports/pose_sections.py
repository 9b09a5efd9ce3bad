"""The sections taken pose by pose: the joint table at the reference keyframe, a row per keyframe.

Both come from the [`Arm`][redundancy.Arm] at single poses; what MuJoCo simulates beyond it
(integrator, flags, actuator ranges, servo damping, gravity compensation) from
`redundancy.model.actuators`. `ActuatorLoad`, the torque the actuators must give against gravity
and what they can give, is shared with the gravity sweep of `redundancy.reports.sections`.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .. import linalg
from ..arm import Arm
from ..arm_coupled import ChainView
from ..engines import REFERENCE
from ..engines.mujoco import MujocoEngine
from ..model import actuators
from ..model.actuators import Simulation

Array = NDArray[np.float64]


def reference_keyframe(arm: Arm) -> tuple[str | None, Array]:
    """The pose the joint table is taken at: ``home``, else the first keyframe, else qpos0.

    Returns:
        The keyframe's name (``None`` for the model's reference pose qpos0) and its pose.
    """
    keys = arm.keyframes
    reachable = arm._reachable_keyframes()  # a loop that cannot close there: not a reference
    name = "home" if "home" in reachable else next(iter(reachable), None)
    if name is None:
        return None, arm._of_chain(arm.mj_model.qpos0)
    return name, keys[name]


def compared_engines(arm: Arm) -> list[str]:
    """The engines checked against the reference, by name."""
    return [name for name in arm.engines if name != REFERENCE]


class ActuatorLoad:
    """Holding torque and the actuators' range at a stack of poses, gravity compensation in.

    MuJoCo's ``gravcomp`` applies ``gravcomp_b m_b`` of each body's weight upward at its
    centre of mass; that is gravity's torque on an arm whose masses are scaled by the
    factors, computed by a MuJoCo engine of such a copy (by one multiplication when every
    body has the same factor: gravity's torque is linear in the masses). Passive
    compensation relieves the motors; ``actuatorgravcomp`` sends it through the actuators,
    where the joint's ``actuatorfrcrange`` clamps it with the motors' torque.
    """

    def __init__(self, arm: Arm) -> None:
        m = arm.mj_model  # a coupled arm's: the chain model (every joint it moves)
        self.model, self.arm = m, arm
        self.routed = np.zeros(m.nv, dtype=bool)
        factors = m.body_gravcomp[1:][m.body_mass[1:] > 0]
        self.uniform: float | None = None
        self.engine: MujocoEngine | None = None
        if not np.any(m.body_gravcomp):
            self.uniform = 0.0
        elif np.all(factors == factors[0]):
            self.uniform = float(factors[0])
        else:
            scaled = copy.copy(m)
            scaled.body_mass[:] = m.body_mass * m.body_gravcomp
            self.engine = MujocoEngine(scaled, arm.frame, np.zeros(m.nv))  # gravity alone
        self.routed[m.jnt_dofadr[m.jnt_actgravcomp.astype(bool)]] = True

    def __call__(self, Q: Array, tau: Array) -> tuple[Array, actuators.EffortRange]:
        """Torque the actuators must give at each pose, and what they can give."""
        if self.arm.coupling is not None:
            return self._coupled(Q, tau)
        if self.engine is not None:
            comp = np.array([self.engine.gravity(q) for q in Q]).reshape(tau.shape)
        else:
            comp = tau * self.uniform
        routed = np.where(self.routed, comp, 0.0)
        # With routed compensation the actuators' sum (motors + compensation) must equal
        # gravity; otherwise the motors give gravity minus the passive compensation.
        need = tau - np.where(self.routed, 0.0, comp)
        return need, actuators.effort_range(self.model, Q, routed)

    def _coupled(self, Q: Array, tau: Array) -> tuple[Array, actuators.EffortRange]:
        """The same on coupled joints: computed on the chain, seen through G (virtual work)."""
        X, G = self.arm._chain_stack(Q)
        if self.engine is not None:
            comp = np.array([self.engine.gravity(x) for x in X]).reshape(X.shape)
        elif self.uniform:
            inner = self.arm.mujoco.inner  # type: ignore[attr-defined]
            comp = self.uniform * np.array([inner.gravity(x) for x in X]).reshape(X.shape)
        else:
            comp = np.zeros(X.shape)
        passive = np.einsum("nxi,nx->ni", G, np.where(self.routed, 0.0, comp))
        chain = actuators.effort_range(self.model, X, np.where(self.routed, comp, 0.0))
        return tau - passive.reshape(tau.shape), _shaped(
            actuators.through_coupling(chain, G), tau.shape
        )


def _shaped(effort: actuators.EffortRange, shape: tuple[int, ...]) -> actuators.EffortRange:
    return actuators.EffortRange(
        effort.lower.reshape(shape), effort.upper.reshape(shape), effort.actuated
    )


def effort_at(arm: Arm, q: Array) -> actuators.EffortRange:
    """What the actuators can give at the arm's pose ``q`` (no gravity compensation routed)."""
    if arm.coupling is None:
        return actuators.effort_range(arm.mj_model, q)
    X, G = arm._chain_stack(q[None, :])
    chain = actuators.effort_range(arm.mj_model, X)
    return _shaped(actuators.through_coupling(chain, G), q.shape)


# -- joints ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class JointRow:
    """One joint at the reference pose.

    Attributes:
        name: Joint name.
        type: ``"hinge"`` or ``"slide"``.
        axis: ``"x"``, ``"y"`` or ``"z"``: the largest component of the joint axis (body frame).
        lower: Lower range limit (``-inf``: unlimited) [rad or m].
        upper: Upper range limit [rad or m].
        armature: Armature as M sees it [kg m^2].
        damping: Joint plus actuator damping b [N m s/rad].
        servo_kv: A servo's velocity feedback on the joint [N m s/rad].
        stiffness: Explicit stiffness, a servo's kp plus the joint's own [N m/rad].
        kd: Controller damping written to ctrl that the bound assumes [N m s/rad].
        effort_lower: Most negative torque the actuators give at the reference pose [N m].
        effort_upper: Most positive torque [N m].
        actuated: Whether an actuator drives the joint.
        m_ii: Diagonal of M with armature [kg m^2].
        m_ii_bare: Without armature [kg m^2].
        implicit: Damping the integrator treats implicitly [N m s/rad].
        explicit: Damping it treats explicitly, kd included [N m s/rad].
        h_max: Largest stable timestep with armature [s] (``inf``: any).
        h_max_bare: Without armature [s].
    """

    name: str
    type: str
    axis: str
    lower: float
    upper: float
    armature: float
    damping: float
    servo_kv: float
    stiffness: float
    kd: float
    effort_lower: float
    effort_upper: float
    actuated: bool
    m_ii: float
    m_ii_bare: float
    implicit: float
    explicit: float
    h_max: float
    h_max_bare: float

    @property
    def armature_share(self) -> float:
        """Armature / M_ii [-]."""
        return self.armature / self.m_ii if self.m_ii else 0.0

    @property
    def effort_limit(self) -> float:
        """max(-lower, upper) effort [N m or N] (the lesson's symmetric "limit")."""
        return max(-self.effort_lower, self.effort_upper)


@dataclass(frozen=True)
class FollowerRow:
    """A joint the arm moves through a coupling (`Arm.followers`), at the reference pose.

    Attributes:
        name: Joint name.
        type: ``"hinge"`` or ``"slide"``.
        lower: Lower range limit (``-inf``: unlimited) [rad or m].
        upper: Upper range limit [rad or m].
        value: Its value at the reference pose (the couplings' or the loop's) [rad or m].
        armature: Its own armature in the chain model [kg m^2].
        damping: Its own damping b [N m s/rad].
        by: What determines it (`Arm.followers`).
    """

    name: str
    type: str
    lower: float
    upper: float
    value: float
    armature: float
    damping: float
    by: str


def followers(arm: Arm, q: Array) -> tuple[FollowerRow, ...]:
    """The followers of a coupled arm at its pose ``q`` (none for an arm without couplings)."""
    if arm.coupling is None:
        return ()
    chain, x = ChainView.at(arm, q)
    armature, damping = chain.armature(), chain.damping()
    return tuple(
        FollowerRow(
            name,
            chain.joint_types[i],
            float(chain.lower[i]),
            float(chain.upper[i]),
            float(x[i]),
            float(armature[i]),
            float(damping[i]),
            arm.followers[name],
        )
        for i, name in enumerate(chain.joint_names)
        if name in arm.followers
    )


@dataclass(frozen=True)
class JointSection:
    """Joints at a reference pose, with the timestep bound for the model's integrator.

    Attributes:
        rows: One per joint.
        keyframe: The keyframe the rows are taken at (``None``: the model's reference pose,
            qpos0).
        simulation: The model's simulation settings.
        kd: The explicit kd asked about (``None``: the model's own, see `joints`).
        note: How the integrator treats damping, in one sentence.
        engine_diff: Largest |Pinocchio - MuJoCo| on M_ii, with and without armature [kg m^2].
        followers: The joints the arm's couplings move (`Arm.followers`), in chain order.
    """

    rows: tuple[JointRow, ...]
    keyframe: str | None
    simulation: Simulation
    kd: float | None
    note: str
    engine_diff: float
    followers: tuple[FollowerRow, ...] = ()


def joints(arm: Arm, kd: float | None = None, key: str | None = None) -> JointSection:
    """The joint table: ranges, armature, damping, effort, M_ii and the timestep bound.

    Args:
        arm: The arm.
        kd: Controller damping written to ``ctrl`` on every joint [N m s/rad]. ``None``: no
            controller is assumed (0): the damping is what the model itself has, the joint's
            own and a servo's ``kv``.
        key: Reference keyframe (default: `reference_keyframe`).
    """
    ref: str | None
    if key is None:
        ref, q = reference_keyframe(arm)
    else:
        ref, q = key, arm.keyframe(key)
    m = arm.mj_model
    sim = actuators.simulation(m)
    if arm.missing_inertia:  # M is unknown: M_ii and the timestep bounds are NaN ("-")
        M = bare = np.full(arm.nq, np.nan)
        diff = float("nan")
    else:
        M = np.diag(arm.mass_matrix(q))
        bare = np.diag(arm.mass_matrix(q, armature=False))
        diff = max(
            float(np.max(np.abs(np.diag(arm.mass_matrix(q, a, other)) - (M if a else bare))))
            for a in (True, False)
            for other in compared_engines(arm)
        )
    b = arm.damping()
    kv = arm._of_chain(actuators.servo_damping(m))
    kd_each = np.full(arm.nq, 0.0 if kd is None else float(kd))
    stiffness = arm._of_chain(actuators.servo_stiffness(m))
    split = actuators.damping_split(sim, b, kv, kd_each, stiffness)
    if arm.missing_inertia:
        h = hb = np.full(arm.nq, np.nan)
    else:
        h = actuators.max_stable_timestep(M, split)
        hb = actuators.max_stable_timestep(bare, split)
    effort = effort_at(arm, q)
    arma = arm.armature()
    dof = arm.coupling.independent if arm.coupling is not None else np.arange(arm.nq)
    rows = tuple(
        JointRow(
            name,
            arm.joint_types[i],
            "xyz"[int(np.argmax(np.abs(m.jnt_axis[dof[i]])))],
            float(arm.lower[i]),
            float(arm.upper[i]),
            float(arma[i]),
            float(b[i]),
            float(kv[i]),
            float(stiffness[i]),
            float(kd_each[i]),
            float(effort.lower[i]),
            float(effort.upper[i]),
            bool(effort.actuated[i]),
            float(M[i]),
            float(bare[i]),
            float(split.implicit[i]),
            float(split.explicit[i]),
            float(h[i]),
            float(hb[i]),
        )
        for i, name in enumerate(arm.joint_names)
    )
    return JointSection(rows, ref, sim, kd, split.note, diff, followers(arm, q))


# -- keyframes ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class KeyframeRow:
    """The site Jacobian at a keyframe, and whether the actuators can hold it.

    Attributes:
        name: Keyframe name.
        q: Its pose [rad or m].
        svd: SVD of MuJoCo's site Jacobian.
        engine_diff: Largest |Pinocchio - MuJoCo| singular value [m/rad or rad/rad].
        hold: Torque the actuators must give to hold it still (gravity minus passive
            gravity compensation) [N m or N].
        effort_lower: Most negative torque they can give there [N m or N].
        effort_upper: Most positive [N m or N].
        moves_held: Held joints the keyframe puts elsewhere than the arm holds them -> the
            keyframe's value [rad or m]; the row is computed there
            (`at_keyframe`).
    """

    name: str
    q: Array
    svd: linalg.JacobianSVD
    engine_diff: float
    hold: Array
    effort_lower: Array
    effort_upper: Array
    moves_held: dict[str, float | tuple[float, ...]] = field(default_factory=dict)

    @property
    def unheld(self) -> tuple[int, ...]:
        """Joints whose actuators cannot give the holding torque."""
        bad = (self.hold < self.effort_lower) | (self.hold > self.effort_upper)
        return tuple(int(i) for i in np.flatnonzero(bad))


def keyframes(arm: Arm, names: tuple[str, ...] | None = None) -> tuple[KeyframeRow, ...]:
    """Singular values and holding torque at each keyframe (all by default).

    A keyframe that moves held joints is computed on the arm at it
    (`at_keyframe`): the robot's real pose under the keyframe's name. By default a keyframe
    where the arm's loops cannot close is left out (`keyframe-loop-open` names it).
    """
    rows = []
    loads = {id(arm): ActuatorLoad(arm)}
    for name in names if names is not None else arm._reachable_keyframes():
        at = arm.at_keyframe(name)
        load = loads.setdefault(id(at), ActuatorLoad(at))
        q = at.keyframe(name)
        s = at.svd(q)
        sp = at.svd(q, "pinocchio")
        tau = np.full(at.nq, np.nan) if at.missing_inertia else at.gravity(q)
        hold, effort = load(q[None, :], tau[None, :])
        rows.append(
            KeyframeRow(
                name,
                q,
                s,
                float(np.max(np.abs(s.sigma - sp.sigma))),
                hold[0],
                effort.lower[0],
                effort.upper[0],
                arm.keyframe_moves(name),
            )
        )
    return tuple(rows)


__all__ = [
    "ActuatorLoad",
    "FollowerRow",
    "JointRow",
    "JointSection",
    "KeyframeRow",
    "compared_engines",
    "effort_at",
    "followers",
    "joints",
    "keyframes",
    "reference_keyframe",
]

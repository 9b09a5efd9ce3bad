"""What a model's actuators and simulation settings do to each joint.

Effort per direction (``ctrlrange`` x gain x gear, ``forcerange``, the joint's
``actuatorfrcrange``, whichever binds), reflected armature and damping, a servo's own
damping (position ``kv``, velocity actuators, general bias terms), and which damping MuJoCo's
integrator treats implicitly. Read from MuJoCo's compiled model (arrays only; no engine
computation).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..engines.mujoco import object_names
from ..errors import UnsupportedFeatureError
from ..inertia import max_stable_timestep as inertia_bound

Array = NDArray[np.float64]

#: Largest stable h D / I of the classical RK4 on a damped joint (the real-axis end of its
#: stability region, 2.7853); Euler's is 2.
RK4_STABILITY = 2.785293563405282


#: Transmissions that drive one joint by its own coordinate: ``jointinparent`` differs from
#: ``joint`` only for ball and free joints (their frame), which an arm does not have.
JOINT_TRANSMISSIONS = (int(mujoco.mjtTrn.mjTRN_JOINT), int(mujoco.mjtTrn.mjTRN_JOINTINPARENT))

_TRANSMISSION_NAMES = {
    int(mujoco.mjtTrn.mjTRN_SITE): "site",
    int(mujoco.mjtTrn.mjTRN_SLIDERCRANK): "slider-crank",
    int(mujoco.mjtTrn.mjTRN_BODY): "body (adhesion)",
    int(mujoco.mjtTrn.mjTRN_TENDON): "tendon",
}


def check_transmissions(model: mujoco.MjModel) -> None:
    """Refuse an actuator whose transmission reaches the arm other than through one joint.

    Joint and joint-in-parent transmissions are read (effort, armature, damping). A site or
    slider-crank transmission applies J^T of its sites (moment arms that depend on the
    pose) and a body (adhesion) transmission applies contact forces: the per-joint effort,
    reflected armature and damping this module reports would not describe them. One whose
    site (or reference or slider site) is on a body a joint moves is refused; a body
    transmission always. Tendons are refused when the model is loaded (Pinocchio does not
    read them).

    Raises:
        UnsupportedFeatureError: Naming the actuator and its transmission.
    """
    names = object_names(model, mujoco.mjtObj.mjOBJ_ACTUATOR)
    sites = (int(mujoco.mjtTrn.mjTRN_SITE), int(mujoco.mjtTrn.mjTRN_SLIDERCRANK))
    for a in range(model.nu):
        kind = int(model.actuator_trntype[a])
        if kind in JOINT_TRANSMISSIONS:
            continue
        if kind in sites:
            ids = [int(i) for i in model.actuator_trnid[a] if i >= 0]
            # body_weldid 0: the body is welded to the world, no joint moves it.
            if all(model.body_weldid[model.site_bodyid[i]] == 0 for i in ids):
                continue
        raise transmission_refusal(kind, names[a] or f"#{a}")


def transmission_refusal(kind: int, name: str) -> UnsupportedFeatureError:
    """The refusal of an actuator whose transmission reaches the arm other than by a joint."""
    return UnsupportedFeatureError(
        f"{_TRANSMISSION_NAMES.get(kind, str(kind))} transmission",
        f"actuator {name!r}",
        "it drives the arm's joints through pose-dependent moment arms; the library "
        "reads actuators with a joint transmission only (joint, jointinparent)",
    )


def _joint_actuators(model: mujoco.MjModel) -> list[tuple[int, int, int, float]]:
    """(actuator, dof, qpos address, gear) for every actuator with a joint transmission.

    Raises:
        UnsupportedFeatureError: As `check_transmissions`.
    """
    check_transmissions(model)
    out = []
    for a in range(model.nu):
        if int(model.actuator_trntype[a]) in JOINT_TRANSMISSIONS:
            j = model.actuator_trnid[a, 0]
            out.append(
                (
                    a,
                    int(model.jnt_dofadr[j]),
                    int(model.jnt_qposadr[j]),
                    float(model.actuator_gear[a, 0]),
                )
            )
    return out


def _input_range(model: mujoco.MjModel, a: int) -> tuple[float, float]:
    """Range of the signal that multiplies an actuator's gain: ctrl, or act where it has one."""
    clamp = not model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CLAMPCTRL
    lo, hi = (
        (float(model.actuator_ctrlrange[a, 0]), float(model.actuator_ctrlrange[a, 1]))
        if model.actuator_ctrllimited[a] and clamp
        else (-np.inf, np.inf)
    )
    dyn = int(model.actuator_dyntype[a])
    if dyn == int(mujoco.mjtDyn.mjDYN_NONE):
        return lo, hi
    if dyn not in (int(mujoco.mjtDyn.mjDYN_FILTER), int(mujoco.mjtDyn.mjDYN_FILTEREXACT)):
        lo, hi = -np.inf, np.inf  # integrator, muscle, user: bounded by actrange alone
    # A filter's act relaxes towards ctrl: at rest it equals ctrl.
    if model.actuator_actlimited[a]:
        lo = max(lo, float(model.actuator_actrange[a, 0]))
        hi = min(hi, float(model.actuator_actrange[a, 1]))
    return lo, hi


@dataclass(frozen=True)
class EffortRange:
    """The torque a dof's actuators can apply while the arm is held still, per direction.

    Arrays have shape (nv,) for one pose or (n, nv) for a stack: a servo's bias
    (``kp (ctrl - q)``) makes its range depend on the pose.

    Attributes:
        lower: Most negative torque the actuators can apply [N m or N] (``-inf``: unlimited).
        upper: Most positive torque [N m or N] (``inf``: unlimited).
        actuated: Per dof, whether any actuator transmits to it, shape (nv,).
    """

    lower: Array
    upper: Array
    actuated: NDArray[np.bool_]


def effort_range(
    model: mujoco.MjModel, q: ArrayLike | None = None, routed: ArrayLike | None = None
) -> EffortRange:
    """Torque range per dof that the actuators can apply while the arm is held still at ``q``.

    For each actuator with a joint transmission (gear ``g``, length ``L = g q``, velocity 0):
    force ``= gain u + bias`` for ``u`` in its input range (``ctrlrange``, or ``actrange`` for
    stateful actuators; none under ``clampctrl`` disabled); clamped to ``forcerange`` when
    force-limited; times ``g`` at the joint. Whichever of ``ctrlrange`` and ``forcerange``
    binds, binds. A *servo* (gain or bias depending on the length: a position actuator's
    ``kp u - kp L``) is limited by its ``forcerange`` alone: its input is a target position,
    and a held servo settles ``tau / kp`` away from its target, so its ``ctrlrange`` bounds
    where the arm can be held (to within that offset), not the torque. Several actuators on
    one dof add up, plus ``routed`` (gravity compensation sent through the actuators by
    ``actuatorgravcomp``), and the joint's ``actuatorfrcrange`` clamps the sum. A dof without
    an actuator gets ``(-inf, inf)`` and ``actuated`` False. Muscle and user gains or biases
    count as unlimited.

    Args:
        model: Compiled MuJoCo model.
        q: Joint positions, shape (nq,) or (n, nq) [rad or m]; default ``qpos0``.
        routed: Torque added to the actuators' sum before the joint's clamp, shaped like the
            result [N m or N].

    Returns:
        The ranges, shaped like ``q`` with nv columns [N m for hinges, N for slides].
    """
    Q = np.asarray(model.qpos0 if q is None else q, dtype=float)
    stack = Q.reshape(-1, model.nq)
    n, nv = len(stack), model.nv
    lo, hi = np.zeros((n, nv)), np.zeros((n, nv))
    actuated = np.zeros(nv, dtype=bool)
    for a, dof, qadr, gear in _joint_actuators(model):
        actuated[dof] = True
        length = gear * stack[:, qadr]
        gain = _affine(
            int(model.actuator_gaintype[a]), model.actuator_gainprm[a], length, gain=True
        )
        bias = _affine(
            int(model.actuator_biastype[a]), model.actuator_biasprm[a], length, gain=False
        )
        u0, u1 = (-np.inf, np.inf) if _is_servo(model, a) else _input_range(model, a)
        with np.errstate(invalid="ignore"):  # 0 x inf: a zero gain gives the bias alone
            f0 = np.where(gain == 0, bias, bias + gain * u0)
            f1 = np.where(gain == 0, bias, bias + gain * u1)
        # NaN (inf - inf) is unbounded; infinities stay infinite (nan_to_num's default
        # would turn them into +-1.8e308, a "limit" that overflows every ratio).
        f_lo = np.nan_to_num(np.fmin(f0, f1), nan=-np.inf, posinf=np.inf, neginf=-np.inf)
        f_hi = np.nan_to_num(np.fmax(f0, f1), nan=np.inf, posinf=np.inf, neginf=-np.inf)
        if model.actuator_forcelimited[a]:
            r0, r1 = model.actuator_forcerange[a]
            f_lo, f_hi = np.clip(f_lo, r0, r1), np.clip(f_hi, r0, r1)
        with np.errstate(over="ignore"):  # a huge gear times a huge force: unbounded, +-inf
            t0, t1 = gear * f_lo, gear * f_hi
        lo[:, dof] += np.fmin(t0, t1)
        hi[:, dof] += np.fmax(t0, t1)
    if routed is not None:
        extra = np.asarray(routed, dtype=float).reshape(n, nv)
        lo, hi = lo + extra, hi + extra
    lo[:, ~actuated], hi[:, ~actuated] = -np.inf, np.inf
    j_lo, j_hi = np.full(nv, -np.inf), np.full(nv, np.inf)
    for j in np.flatnonzero(model.jnt_actfrclimited):
        j_lo[model.jnt_dofadr[j]], j_hi[model.jnt_dofadr[j]] = model.jnt_actfrcrange[j]
    shape = (*Q.shape[:-1], nv)
    return EffortRange(
        np.clip(lo, j_lo, j_hi).reshape(shape), np.clip(hi, j_lo, j_hi).reshape(shape), actuated
    )


def through_coupling(chain: EffortRange, G: Array) -> EffortRange:
    """The torque range on coupled joints' independent coordinates, from the chain's.

    A torque ``tau`` on the chain's dofs acts on the independent coordinates as ``G^T tau``
    (virtual work). Each coordinate's range is that image of the chain's per-dof ranges
    (interval sums: exact for one coordinate, the projection with the others left free for
    several). A dof no actuator drives gives no torque (0, not unlimited); a coordinate none
    of whose dofs is actuated is unactuated, ``(-inf, inf)`` as in `effort_range`.

    Args:
        chain: `effort_range` of the chain model at the chain poses, shape (n, nx).
        G: d(chain pose)/dq at those poses, shape (n, nx, nq).

    Returns:
        The ranges, shape (n, nq) [N m or N].
    """
    G = np.asarray(G, dtype=float)
    drive = np.where(chain.actuated[None, :, None], G, 0.0)  # (n, nx, nq)
    lo = np.asarray(chain.lower, dtype=float).reshape(len(G), -1)[:, :, None]
    hi = np.asarray(chain.upper, dtype=float).reshape(len(G), -1)[:, :, None]
    # Each term is in [-inf, finite] (lower) or [finite, inf] (upper): no inf - inf.
    with np.errstate(invalid="ignore"):  # 0 x inf where np.where takes the other branch
        low = np.where(drive > 0, drive * lo, np.where(drive < 0, drive * hi, 0.0))
        high = np.where(drive > 0, drive * hi, np.where(drive < 0, drive * lo, 0.0))
    lower, upper = low.sum(axis=1), high.sum(axis=1)
    actuated = np.any(drive != 0.0, axis=(0, 1))
    lower[:, ~actuated], upper[:, ~actuated] = -np.inf, np.inf
    return EffortRange(lower, upper, actuated)


def _affine(kind: int, prm: Array, length: Array, gain: bool) -> Array:
    """An actuator's gain or bias at rest (velocity 0): fixed, affine in length, or unknown."""
    if gain and kind == int(mujoco.mjtGain.mjGAIN_FIXED):
        return np.full(len(length), float(prm[0]))
    if not gain and kind == int(mujoco.mjtBias.mjBIAS_NONE):
        return np.zeros(len(length))
    if kind == (int(mujoco.mjtGain.mjGAIN_AFFINE) if gain else int(mujoco.mjtBias.mjBIAS_AFFINE)):
        return prm[0] + prm[1] * length
    return np.full(len(length), np.nan)  # muscle or user: not bounded here


def joint_force_limits(model: mujoco.MjModel) -> Array:
    """Largest force or torque the actuators can apply at each dof, either direction.

    ``max(-lower, upper)`` of `effort_range`; ``inf`` where unlimited or without an actuator. This
    is the symmetric limit Pinocchio's ``effortLimit`` holds; the audit uses `effort_range`, per
    direction.

    Args:
        model: Compiled MuJoCo model.

    Returns:
        Limits, shape (nv,) [N m for hinges, N for slides].
    """
    r = effort_range(model)
    return np.maximum(-r.lower, r.upper)


def _is_servo(model: mujoco.MjModel, a: int) -> bool:
    """Whether an actuator's force depends on its length (a position-type servo)."""
    return bool(
        (
            model.actuator_gaintype[a] == mujoco.mjtGain.mjGAIN_AFFINE
            and model.actuator_gainprm[a, 1] != 0
        )
        or (
            model.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_AFFINE
            and model.actuator_biasprm[a, 1] != 0
        )
    )


def _reflected_per_dof(model: mujoco.MjModel, values: Array) -> Array:
    """Sum of gear^2 * value over the joint actuators of each dof (rotor-side to joint-side)."""
    extra = np.zeros(model.nv)
    for a, dof, _, _ in _joint_actuators(model):
        extra[dof] += model.actuator_gear[a, 0] ** 2 * values[a]
    return extra


def actuator_armature(model: mujoco.MjModel) -> Array:
    """Armature that actuators add to each dof: ``gear^2 * actuator_armature`` [kg m^2]."""
    return _reflected_per_dof(model, model.actuator_armature)


def actuator_damping(model: mujoco.MjModel) -> Array:
    """Damping that actuators add to each dof: ``gear^2 * actuator_damping`` [N m s/rad]."""
    return _reflected_per_dof(model, model.actuator_damping)


def actuator_damping_polynomial(model: mujoco.MjModel) -> Array:
    """The damping polynomial's higher terms actuators add to each dof, ``gear^2 * b1, b2``.

    MuJoCo applies an actuator's ``damping="b0 b1 b2"`` to the joint velocity as it does its
    linear damping (b0, `actuator_damping`). Shape (nv, 2): the v|v| and v^3 coefficients.
    """
    poly = model.actuator_dampingpoly
    return np.stack([_reflected_per_dof(model, poly[:, k]) for k in range(poly.shape[1])], axis=1)


def servo_damping(model: mujoco.MjModel) -> Array:
    """Damping a servo's own velocity feedback gives each dof [N m s/rad].

    A position actuator's ``kv``, a velocity actuator's ``kv`` and a general actuator's
    velocity bias ``biasprm[2]`` (force ``... + biasprm[2] * gear * qdot``) all come to
    ``-gear^2 * biasprm[2]`` at the joint.
    """
    kv = np.zeros(model.nv)
    for a, dof, _, gear in _joint_actuators(model):
        if model.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_AFFINE:
            kv[dof] -= gear**2 * float(model.actuator_biasprm[a, 2])
    return kv


def servo_stiffness(model: mujoco.MjModel) -> Array:
    """Stiffness on each dof that every integrator treats explicitly [N m/rad].

    A servo's position feedback (a position actuator's ``kp``, a general actuator's
    ``biasprm[1]``: ``-gear^2 biasprm[1]`` at the joint) plus the joint's own ``stiffness``.
    MuJoCo's implicit integrators take only velocity derivatives implicitly.
    """
    k = np.zeros(model.nv)
    for a, dof, _, gear in _joint_actuators(model):
        if model.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_AFFINE:
            k[dof] -= gear**2 * float(model.actuator_biasprm[a, 1])
    for j in range(model.njnt):
        k[model.jnt_dofadr[j]] += float(model.jnt_stiffness[j])
    return k


def servo_driven(model: mujoco.MjModel) -> NDArray[np.bool_]:
    """Per dof, whether a servo drives it rather than a torque motor.

    A servo's force feeds back position or velocity (an affine bias: position, velocity and
    general servos); a motor's is its control times a gain.
    """
    driven = np.zeros(model.nv, dtype=bool)
    for a, dof, _, _ in _joint_actuators(model):
        if model.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_AFFINE and np.any(
            model.actuator_biasprm[a, 1:3] != 0
        ):
            driven[dof] = True
    return driven


# -- how MuJoCo steps the model ----------------------------------------------------------------
_INTEGRATORS = {
    mujoco.mjtIntegrator.mjINT_EULER: "Euler",
    mujoco.mjtIntegrator.mjINT_RK4: "RK4",
    mujoco.mjtIntegrator.mjINT_IMPLICIT: "implicit",
    mujoco.mjtIntegrator.mjINT_IMPLICITFAST: "implicitfast",
}


@dataclass(frozen=True)
class Simulation:
    """What MuJoCo simulates beyond the rigid-body numbers both engines compute.

    Attributes:
        gravity: Gravity vector [m/s^2].
        gravity_enabled: False under ``<flag gravity="disable"/>``.
        gravcomp: (body name, ``gravcomp`` factor) per body that has one [-].
        gravcomp_to_actuators: Joints with ``actuatorgravcomp``: the compensation goes
            through the actuators and the joint's ``actuatorfrcrange`` clamps it.
        timestep: h [s].
        integrator: ``"Euler"``, ``"RK4"``, ``"implicit"`` or ``"implicitfast"``.
        eulerdamp: Euler integrates joint damping implicitly (the flag is not disabled).
    """

    # What holds the arm up, then how it steps.
    gravity: tuple[float, ...]
    gravity_enabled: bool
    gravcomp: tuple[tuple[str, float], ...]
    gravcomp_to_actuators: tuple[str, ...]
    timestep: float
    integrator: str
    eulerdamp: bool


def simulation(model: mujoco.MjModel) -> Simulation:
    """The model's simulation settings (``<option>``, its flags, body ``gravcomp``)."""
    dis = int(model.opt.disableflags)
    bodies = object_names(model, mujoco.mjtObj.mjOBJ_BODY)
    joints = object_names(model, mujoco.mjtObj.mjOBJ_JOINT)
    gravcomp = tuple(
        (bodies[b] or f"body {b}", float(model.body_gravcomp[b]))
        for b in range(1, model.nbody)
        if model.body_gravcomp[b] != 0.0
    )
    return Simulation(
        gravity=tuple(float(x) for x in model.opt.gravity),
        gravity_enabled=not dis & mujoco.mjtDisableBit.mjDSBL_GRAVITY,
        gravcomp=gravcomp,
        gravcomp_to_actuators=tuple(
            joints[j] for j in range(model.njnt) if model.jnt_actgravcomp[j] and gravcomp
        ),
        timestep=float(model.opt.timestep),
        integrator=_INTEGRATORS[mujoco.mjtIntegrator(model.opt.integrator)],
        eulerdamp=not dis & mujoco.mjtDisableBit.mjDSBL_EULERDAMP,
    )


@dataclass(frozen=True)
class DampingSplit:
    """Per dof, the damping MuJoCo's integrator treats implicitly and explicitly [N m s/rad].

    One step multiplies a joint's speed by ``(I - h D_explicit) / (I + h D_implicit)`` (Euler
    family), stable while ``h < 2 I / (D_explicit - D_implicit)``. With an explicit stiffness
    ``k`` (a servo's ``kp``) the step is an oscillator's, stable while
    ``k h^2 + 2 h (D_explicit - D_implicit) < 4 I`` (Jury's test on its 2 x 2 step), which is
    the stricter bound ``h < (sqrt(e^2 + 4 k I) - e) / k`` with ``e = D_explicit - D_implicit``:
    a stiff servo on a light joint needs a small step even when all damping is implicit.
    RK4 treats the model's
    damping explicitly, stable while ``h < 2.785 I / D``; a kd written to ``ctrl`` is held
    constant over the step (an Euler term), so with one the bound takes Euler's 2, which is
    conservative for the mix (at ``h D / I = 2`` the RK4 step's multiplier stays in [-1, 1]).

    Attributes:
        implicit: Damping integrated implicitly.
        explicit: Damping integrated explicitly, the controller's ``kd`` included.
        factor: Per dof, the stable ``h D / I``: 2 for the Euler family, and for RK4 on a joint
            without a ``ctrl``-written kd `RK4_STABILITY`.
        note: Why, in one sentence.
        stiffness: Explicit stiffness per dof (0 under RK4, whose bound here is damping's
            alone) [N m/rad].
    """

    implicit: Array
    explicit: Array
    factor: Array
    note: str
    stiffness: Array | None = None


def damping_split(
    sim: Simulation,
    joint_damping: ArrayLike,
    servo: ArrayLike,
    kd: ArrayLike,
    stiffness: ArrayLike = 0.0,
) -> DampingSplit:
    """Which damping the integrator treats implicitly, for the bound on the timestep.

    Measured in MuJoCo 3 and 4 (tests simulate each case): Euler integrates joint damping
    and actuator ``damping`` implicitly unless ``eulerdamp`` is disabled, but a servo's
    ``kv`` explicitly; ``implicit`` and ``implicitfast`` integrate all of the model's
    damping implicitly; RK4 none. A ``kd`` the controller computes and writes to ``ctrl`` is
    explicit under every integrator: MuJoCo cannot see it in advance.

    Args:
        sim: The model's simulation settings.
        joint_damping: Joint plus actuator damping per dof, b [N m s/rad].
        servo: Servo velocity feedback per dof, kv (`servo_damping`) [N m s/rad].
        kd: Controller damping written to ``ctrl`` per dof [N m s/rad].
        stiffness: Explicit stiffness per dof (`servo_stiffness`) [N m/rad].
    """
    split = _split(sim, joint_damping, servo, kd)
    k = np.broadcast_to(np.asarray(stiffness, dtype=float), split.implicit.shape)
    return replace(split, stiffness=np.zeros_like(k) if sim.integrator == "RK4" else k.copy())


def _split(
    sim: Simulation, joint_damping: ArrayLike, servo: ArrayLike, kd: ArrayLike
) -> DampingSplit:
    b, kv, kd = (np.asarray(x, dtype=float) for x in np.broadcast_arrays(joint_damping, servo, kd))
    zero, two = np.zeros_like(b), np.full_like(b, 2.0)
    if sim.integrator in ("implicit", "implicitfast"):
        return DampingSplit(
            b + kv,
            kd,
            two,
            f"{sim.integrator} integrates joint damping and servo kv implicitly; only a kd "
            "written to ctrl is explicit",
        )
    if sim.integrator == "RK4":
        return DampingSplit(
            zero,
            b + kv + kd,
            np.where(kd > 0, 2.0, RK4_STABILITY),
            "RK4 integrates all damping explicitly (stable to h D / I = 2.785; 2 with a kd "
            "written to ctrl, which it holds over the step)",
        )
    if sim.eulerdamp:
        return DampingSplit(
            b,
            kv + kd,
            two,
            "Euler integrates joint damping implicitly; servo kv and a kd written to ctrl "
            "are explicit",
        )
    return DampingSplit(
        zero,
        b + kv + kd,
        two,
        "Euler with eulerdamp disabled integrates all damping explicitly, joint damping included",
    )


def max_stable_timestep(inertia: ArrayLike, split: DampingSplit) -> Array:
    """Largest stable timestep per dof for a damping split [s] (``inf``: any step).

    Args:
        inertia: Joint inertia, e.g. the diagonal of M [kg m^2].
        split: The damping split (`damping_split`).
    """
    bound = inertia_bound(inertia, split.explicit, split.implicit)  # 2 I / (D_e - D_i)
    bound = bound * (split.factor / 2.0)
    if split.stiffness is None or not np.any(split.stiffness > 0):
        return bound
    k = split.stiffness
    e = split.explicit - split.implicit
    inertia = np.asarray(inertia, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        oscillator = (np.sqrt(e * e + 4.0 * k * inertia) - e) / np.where(k > 0, k, 1.0)
    return np.where(k > 0, oscillator, bound)

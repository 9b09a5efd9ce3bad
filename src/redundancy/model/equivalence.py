"""Structural comparison of the two compiled models: do both engines see the same arm?

Quantities are compared in the world frame at a reference pose, so that the engines' internal
frames (joint vs body frame, lumped fixed bodies) do not matter: only what the physics sees.

It also lists what MuJoCo *simulates* that neither engine's numbers (M, gravity, J) include:
gravity compensation, limits that differ per direction, friction loss, joint springs, the
integrator and its flags. Two engines agreeing says nothing about those; the report says so.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from ..arm import Arm, check_arm
from ..arm_coupled import ChainView
from ..display import Report, Table, plural, table
from ..errors import RedundancyError
from .actuators import simulation
from .bridges import Bridge, effective_gravity
from .names import display_names
from .scales import Scales, arm_scales, scaled_error


@dataclass(frozen=True)
class Difference:
    """One quantity on which the engines' models differ.

    Attributes:
        quantity: e.g. ``"body mass"``.
        item: Joint, body or site it concerns.
        mujoco: MuJoCo's value.
        pinocchio: Pinocchio's value.
        error: Largest difference, relative to the quantity's scale (see model.scales).
    """

    quantity: str
    item: str
    mujoco: object
    pinocchio: object
    error: float

    def __str__(self) -> str:
        return (
            f"{self.quantity} of {self.item}: MuJoCo {format_value(self.mujoco)}, Pinocchio "
            f"{format_value(self.pinocchio)} (|diff| {self.error:.3g})"
        )


def format_value(x: object) -> str:
    """A value as a report shows it: arrays on one line to 6 digits, floats to 9."""
    if isinstance(x, np.ndarray):
        return np.array2string(x, precision=6, suppress_small=True, max_line_width=200)
    if isinstance(x, list | tuple):  # their items' text, never numpy's repr of a scalar
        inner = ", ".join(repr(v) if isinstance(v, str) else format_value(v) for v in x)
        return f"[{inner}]" if isinstance(x, list) else f"({inner})"
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float):
        return f"{x:.9g}"
    return str(x)


@dataclass(frozen=True)
class SimulatedOnly:
    """Something MuJoCo simulates that neither engine's numbers include.

    Attributes:
        feature: e.g. ``"gravity compensation"``, ``"asymmetric force range"``.
        item: Body, joint, actuator or ``"model"``.
        value: The model's value (text).
        effect: What it changes in the simulated arm, and what the numbers leave out.
    """

    feature: str
    item: str
    value: str
    effect: str

    def __str__(self) -> str:
        return f"{self.feature} ({self.item}: {self.value}): {self.effect}"


@dataclass(frozen=True, repr=False)
class EquivalenceReport(Report):
    """Result of [`compare_models`][redundancy.compare_models].

    ``print(report)`` prints [`lines`][redundancy.model.equivalence.EquivalenceReport.lines]; a
    notebook shows the HTML tables.

    Attributes:
        differences: Every mismatch, with both values.
        bridges: Values copied from MuJoCo into Pinocchio because its parser does not read them.
        tol: Relative tolerance used (differences over each quantity's scale) [-].
        checked: Names of the quantities compared.
        largest: Largest relative difference per compared quantity, within tolerance or not.
        simulated: What MuJoCo simulates that neither engine's numbers include.
    """

    differences: tuple[Difference, ...]
    bridges: tuple[Bridge, ...]
    tol: float
    checked: tuple[str, ...]
    largest: dict[str, float] = field(default_factory=dict)
    simulated: tuple[SimulatedOnly, ...] = ()

    @property
    def equivalent(self) -> bool:
        """True when no quantity differs (bridged values are not differences)."""
        return not self.differences

    def summary(self) -> str:
        """``"equivalent, 12 quantities compared"`` or the number of differences."""
        verdict = "equivalent" if self.equivalent else plural(len(self.differences), "difference")
        n = plural(len(self.checked), "quantity", "quantities")
        return f"{verdict}, {n} compared, {plural(len(self.bridges), 'bridged value')}"

    def html_tables(self) -> list[Table]:
        """Differences, the largest difference per quantity, the bridged values."""
        return [
            table(
                plural(len(self.differences), "difference"),
                ("quantity", "item", "MuJoCo", "Pinocchio", "|diff|"),
                [
                    (
                        d.quantity,
                        d.item,
                        format_value(d.mujoco),
                        format_value(d.pinocchio),
                        f"{d.error:.3g}",
                    )
                    for d in self.differences
                ],
                (False, False, False, False, True),
            ),
            table(
                f"largest difference per quantity (tolerance {self.tol:g})",
                ("quantity", "largest"),
                [(k, f"{v:.2e}") for k, v in self.largest.items()],
                (False, True),
            ),
            table(
                "bridged from MuJoCo (Pinocchio's parser does not read them as MuJoCo does)",
                ("quantity", "joint", "value", "source"),
                [(b.quantity, b.joint, b.value_text, b.source) for b in self.bridges],
            ),
        ]

    def html_notes(self) -> list[str]:
        """What MuJoCo simulates that neither engine's numbers include."""
        return [f"SIMULATED  {s}" for s in self.simulated]

    def lines(self) -> list[str]:
        """Human-readable report lines."""
        out = [
            f"compared ({len(self.checked)} quantities, tol {self.tol:g}): "
            f"{', '.join(self.checked)}"
        ]
        if self.differences:
            out += [f"DIFFERS  {d}" for d in self.differences]
        else:
            out.append("no differences")
        by_kind: dict[tuple[str, str], list[Bridge]] = {}
        for b in self.bridges:
            by_kind.setdefault((b.quantity, b.source), []).append(b)
        for (kind, source), items in by_kind.items():
            vals = ", ".join(f"{b.joint}={b.value_text}" for b in items)
            out.append(
                f"BRIDGED  {kind} (from MuJoCo's {source}; Pinocchio's parser does "
                f"not read it as MuJoCo does): {vals}"
            )
        out += [f"SIMULATED  {s}" for s in self.simulated]
        return out


def abs_error(a: object, b: object) -> float:
    """Largest |a - b| over the entries [their unit]: 0 for equal infinities, ``inf`` for NaN.

    0 for empty arrays; an infinity against a finite value or the other infinity is ``inf``.
    """
    a_arr, b_arr = np.asarray(a, float), np.asarray(b, float)
    same_inf = np.isinf(a_arr) & np.isinf(b_arr) & (np.sign(a_arr) == np.sign(b_arr))
    with np.errstate(invalid="ignore"):
        diff = a_arr - b_arr
    err = np.where(
        same_inf, 0.0, np.abs(np.nan_to_num(diff, nan=np.inf, posinf=np.inf, neginf=np.inf))
    )
    return float(np.max(err)) if err.size else 0.0


def fit_rigid(
    dirs_a: np.ndarray,
    points_a: np.ndarray,
    dirs_b: np.ndarray,
    points_b: np.ndarray,
    lines: np.ndarray,
) -> tuple[np.ndarray, np.ndarray] | None:
    """The rigid transform ``x -> R x + t`` that best maps A's joint axes onto B's.

    Each joint gives a direction (unit axis) and a point; a hinge's point may sit anywhere on
    its axis line (only the offset across the line counts), a slide's point is its anchor.
    ``R`` comes from the directions (Kabsch; when they are all parallel, the smallest rotation
    taking one onto the other), ``t`` from the points by least squares.

    Args:
        dirs_a: A's unit axes, shape (n, 3) (world).
        points_a: A's points on them [m], shape (n, 3).
        dirs_b: B's unit axes, shape (n, 3).
        points_b: B's points [m], shape (n, 3).
        lines: Per joint, True where the point may slide along the axis (hinge).

    Returns:
        ``(R, t)``, or None when the joints do not fix the transform (no joint; all axes
        parallel lines leave the shift along them free).
    """
    n = len(dirs_a)
    if n == 0:
        return None
    H = dirs_a.T @ dirs_b
    if np.linalg.matrix_rank(H, tol=1e-9) >= 2:
        U, _, Vt = np.linalg.svd(H)
        D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T))])
        R = Vt.T @ D @ U.T
    else:  # parallel axes: the smallest rotation taking A's direction onto B's
        R = _align(dirs_a[0], dirs_b[0])
    A = np.zeros((3, 3))
    rhs = np.zeros(3)
    for i in range(n):
        u = dirs_b[i]
        P = np.eye(3) - np.outer(u, u) if lines[i] else np.eye(3)
        A += P
        rhs += P @ (points_b[i] - R @ points_a[i])
    if np.linalg.matrix_rank(A, tol=1e-9) < 3:
        return None
    return R, np.linalg.solve(A, rhs)


def _align(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation taking unit vector ``a`` onto unit vector ``b``."""
    v, c = np.cross(a, b), float(a @ b)
    if c < -1 + 1e-12:  # opposite: half a turn about any axis across a
        axis = np.cross(a, [1.0, 0.0, 0.0])
        if np.linalg.norm(axis) < 1e-6:
            axis = np.cross(a, [0.0, 1.0, 0.0])
        axis /= np.linalg.norm(axis)
        return 2 * np.outer(axis, axis) - np.eye(3)
    K = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + K + K @ K / (1 + c)


def compare_models(arm: Arm, q: np.ndarray | None = None, tol: float = 1e-9) -> EquivalenceReport:
    """Compare the two engines' compiled models, quantity by quantity.

    Args:
        arm: The loaded arm.
        q: Reference pose [rad or m]; defaults to zeros clipped into the joint ranges.
        tol: Relative tolerance: each difference is divided by its quantity's scale
            ([`scaled_error`][redundancy.model.scales.scaled_error]; the arm's length for positions,
            m L^2 for inertias...) [-].
    """
    arm = check_arm(arm)
    if not (isinstance(tol, (int, float)) and np.isfinite(tol) and tol >= 0):
        raise RedundancyError(f"tol must be a finite number >= 0, got {tol!r}")
    if arm.coupling is not None:  # the models compared are the chain's: every joint moved
        arm, q = ChainView.at(arm, q)  # type: ignore[assignment]
    mj, pn = arm.mujoco, arm.pinocchio
    q = np.clip(np.zeros(arm.nq), arm.lower, arm.upper) if q is None else arm.pose(q)
    t = _Tally(tol, _sizes(arm_scales(arm)))
    pm = pn.model
    _compare_tree(arm, pm, t.diffs)
    _compare_joints(arm, q, t)
    inertias = not arm.missing_inertia  # else the file gives none: nothing to compare
    if inertias:
        m_m, c_m, I_m = mj.link_inertias(q)
        m_p, c_p, I_p = pn.link_inertias(q)
        for i, n in enumerate(arm.joint_names):
            item = f"body moved by {n}"
            t.cmp("body mass", item, float(m_m[i]), float(m_p[i]))
            t.cmp("centre of mass (world)", item, c_m[i], c_p[i])
            t.cmp("inertia about com (world)", item, I_m[i], I_p[i])
    p_m, R_m = mj.site_pose(q)
    p_p, R_p = pn.site_pose(q)
    t.cmp("site position", arm.frame, p_m, p_p)
    t.cmp("site orientation", arm.frame, R_m, R_p)
    t.cmp("gravity vector", "model", effective_gravity(arm.mj_model), np.asarray(pm.gravity.linear))
    checked = (
        "parent joint",
        "joint type",
        "joint axis",
        "joint range",
        "armature",
        "damping",
        "effort limit",
        *(("body mass", "centre of mass", "inertia") if inertias else ()),
        "site frame",
        "gravity",
    )
    return EquivalenceReport(
        tuple(t.diffs),
        tuple(b for b in arm.bridges if b.engine == "pinocchio"),
        tol,
        checked,
        t.largest,
        simulated_only(arm.mj_model, int(arm.robot_model.opt.disableflags)),
    )


def _sizes(sc: Scales) -> dict[str, float]:
    """Each compared quantity's size on this arm (see `redundancy.model.scales`)."""
    L = sc.length
    return {
        "joint axis (world)": 1.0,
        "joint axis line offset": L,
        "armature": sc.inertia,
        "damping": sc.inertia * np.sqrt(sc.gravity / L),  # m L^2 / (time scale sqrt(L/g))
        "effort limit": sc.torque,
        "body mass": sc.mass,
        "centre of mass (world)": L,
        "inertia about com (world)": sc.inertia,
        "site position": L,
        "site orientation": 1.0,
        "gravity vector": sc.gravity,
    }


@dataclass
class _Tally:
    """The differences beyond ``tol`` found so far, and the largest per quantity."""

    tol: float
    sizes: dict[str, float]
    diffs: list[Difference] = field(default_factory=list)
    largest: dict[str, float] = field(default_factory=dict)

    def cmp(
        self, quantity: str, item: str, a: object, b: object, size: float | None = None
    ) -> None:
        e = scaled_error(a, b, self.sizes[quantity] if size is None else size)
        self.largest[quantity] = max(self.largest.get(quantity, 0.0), e)
        if e > self.tol:
            self.diffs.append(Difference(quantity, item, a, b, e))


def _compare_tree(arm: Arm, pm: object, diffs: list[Difference]) -> None:
    """Each joint's parent joint and type, by name: structure, infinitely different or equal."""
    from ..engines.pinocchio import joint_kind

    names = arm.joint_names
    for i, n in enumerate(names):
        mj_parent = parent_joint(arm, i)
        pin_parent = pm.names[pm.parents[pm.getJointId(n)]]  # type: ignore[attr-defined]
        pin_parent = "" if pin_parent == "universe" else pin_parent
        if mj_parent != pin_parent:
            diffs.append(
                Difference(
                    "parent joint", n, mj_parent or "(base)", pin_parent or "(base)", float("inf")
                )
            )
    for i, n in enumerate(names):
        kind = joint_kind(pm.joints[pm.getJointId(n)])  # type: ignore[attr-defined]
        if kind != arm.joint_types[i]:
            diffs.append(Difference("joint type", n, arm.joint_types[i], kind, float("inf")))


def _compare_joints(arm: Arm, q: np.ndarray, t: _Tally) -> None:
    """Each joint's axis (world), range, armature, damping and effort limit at pose ``q``."""
    mj, pn, names = arm.mujoco, arm.pinocchio, arm.joint_names
    ax_m, an_m = mj.joint_axes(q)
    ax_p, an_p = pn.joint_axes(q)
    for i, n in enumerate(names):
        t.cmp("joint axis (world)", n, ax_m[i], ax_p[i])
        if arm.joint_types[i] == "hinge":
            # The anchor may sit anywhere on the axis line: compare its offset across the line.
            r = an_p[i] - an_m[i]
            t.cmp("joint axis line offset", n, np.zeros(3), r - (r @ ax_m[i]) * ax_m[i])
    lo_p, hi_p = pn.limits
    for i, n in enumerate(names):
        unit = 1.0 if arm.joint_types[i] == "hinge" else t.sizes["joint axis line offset"]
        lo_hi = np.array([arm.lower[i], arm.upper[i]])
        t.cmp("joint range", n, lo_hi, np.array([lo_p[i], hi_p[i]]), unit)
    cmp_vec = [
        ("armature", arm.armature("mujoco"), arm.armature("pinocchio")),
        ("damping", arm.damping("mujoco"), arm.damping("pinocchio")),
        ("effort limit", arm.effort_limit, np.asarray(pn.model.effortLimit)[pn.perm]),
    ]
    for quantity, a, b in cmp_vec:
        for i, n in enumerate(names):
            t.cmp(quantity, n, float(a[i]), float(b[i]))


def joint_of_body(arm: Arm, body: int) -> str:
    """Name of the joint that moves ``body`` (walking up welded bodies), '' for the base.

    Of several joints in one body, the last: MuJoCo applies them one after the other.
    """
    m = arm.mj_model
    while body > 0 and m.body_jntnum[body] == 0:
        body = m.body_parentid[body]
    if body == 0:
        return ""
    return arm.joint_names[m.body_jntadr[body] + m.body_jntnum[body] - 1]


def parent_joint(arm: Arm, i: int) -> str:
    """The joint before joint ``i``: in its body, else the parent body's ('' at the base)."""
    m = arm.mj_model
    if i > m.body_jntadr[m.jnt_bodyid[i]]:
        return arm.joint_names[i - 1]
    return joint_of_body(arm, int(m.body_parentid[m.jnt_bodyid[i]]))


def simulated_only(
    model: mujoco.MjModel, file_flags: int | None = None
) -> tuple[SimulatedOnly, ...]:
    """What MuJoCo simulates for this model that neither engine's numbers include.

    Read from MuJoCo's compiled model: per-body ``gravcomp``; force, control and joint
    actuator-force ranges that differ per direction; friction loss and joint springs; the
    integrator; ``eulerdamp`` and ``gravity`` flags and any other disabled physics.

    Args:
        model: MuJoCo's compiled model.
        file_flags: The disable flags the file sets, where they differ from the model's (an
            arm inside a robot: its model turns ``filterparent`` off to keep the robot's
            parent rule as excludes); default: the model's.
    """
    flags = int(model.opt.disableflags) if file_flags is None else file_flags
    joints = display_names(model, mujoco.mjtObj.mjOBJ_JOINT)
    return (
        *_gravity_compensation(model, joints),
        *_asymmetric_actuators(model),
        *_joint_terms(model, joints),
        *_integration(model, flags),
    )


def _gravity_compensation(model: mujoco.MjModel, joints: tuple[str, ...]) -> list[SimulatedOnly]:
    """Bodies MuJoCo pushes up (``gravcomp``), joints whose actuators carry it."""
    out: list[SimulatedOnly] = []
    bodies = display_names(model, mujoco.mjtObj.mjOBJ_BODY)
    for b in range(1, model.nbody):
        gc = float(model.body_gravcomp[b])
        if gc != 0:
            out.append(
                SimulatedOnly(
                    "gravity compensation",
                    f"body {bodies[b]}",
                    f"gravcomp={gc:g}",
                    f"MuJoCo pushes up {gc:g} x the body's weight at its centre of mass, so the "
                    "motors hold gravity minus that; the gravity torque both engines give "
                    "leaves it out",
                )
            )
    for j in range(model.njnt):
        if model.jnt_actgravcomp[j] and np.any(model.body_gravcomp != 0):
            out.append(
                SimulatedOnly(
                    "gravity compensation through the actuators",
                    f"joint {joints[j]}",
                    "actuatorgravcomp=true",
                    "the compensation is added to the actuator force and clamped by its "
                    "force range, not applied as a free external force",
                )
            )
    return out


def _asymmetric_actuators(model: mujoco.MjModel) -> list[SimulatedOnly]:
    """Actuators whose force or control range differs per direction."""
    out: list[SimulatedOnly] = []
    actuators = [
        mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a) or f"actuator {a}"
        for a in range(model.nu)
    ]
    for a in range(model.nu):
        motor_like = (
            model.actuator_gaintype[a] == mujoco.mjtGain.mjGAIN_FIXED
            and model.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_NONE
        )
        ranges = []
        if model.actuator_forcelimited[a]:
            ranges.append(("force range", model.actuator_forcerange[a]))
        if model.actuator_ctrllimited[a] and motor_like:
            ranges.append(("control range", model.actuator_ctrlrange[a]))
        for what, (lo, hi) in ranges:
            if lo != -hi:
                out.append(
                    SimulatedOnly(
                        f"asymmetric {what}",
                        f"actuator {actuators[a]}",
                        f"[{lo:g}, {hi:g}]",
                        "the limit differs per direction; an effort limit of "
                        f"max(|lo|, |hi|) = {max(abs(lo), abs(hi)):g} overstates the "
                        f"{'negative' if abs(lo) < abs(hi) else 'positive'} direction",
                    )
                )
    return out


def _joint_terms(model: mujoco.MjModel, joints: tuple[str, ...]) -> list[SimulatedOnly]:
    """Per joint: an asymmetric actuator force range, a spring; then all friction loss."""
    out: list[SimulatedOnly] = []
    friction: list[str] = []
    for j in range(model.njnt):
        dof = model.jnt_dofadr[j]
        if model.jnt_actfrclimited[j]:
            lo, hi = model.jnt_actfrcrange[j]
            if lo != -hi:
                out.append(
                    SimulatedOnly(
                        "asymmetric actuator force range",
                        f"joint {joints[j]}",
                        f"[{lo:g}, {hi:g}]",
                        "the joint's actuator force is clamped per direction",
                    )
                )
        if model.dof_frictionloss[dof] > 0:
            friction.append(f"{joints[j]}={model.dof_frictionloss[dof]:g}")
        if model.jnt_stiffness[j] > 0:
            out.append(
                SimulatedOnly(
                    "joint spring",
                    f"joint {joints[j]}",
                    f"stiffness={model.jnt_stiffness[j]:g}, springref={model.qpos_spring[j]:g}",
                    "MuJoCo adds -stiffness x (q - springref); the gravity torque leaves it out",
                )
            )
    if friction:
        out.append(
            SimulatedOnly(
                "friction loss",
                "joints",
                ", ".join(friction),
                "MuJoCo resists motion with up to this much dry friction [N m or N]; the "
                "gravity and hold numbers leave it out",
            )
        )
    return out


def _integration(model: mujoco.MjModel, flags: int) -> list[SimulatedOnly]:
    """The integrator, and the physics the disable ``flags`` leave out."""
    out: list[SimulatedOnly] = []
    sim = simulation(model)  # integrator and flags, read as the timestep bound reads them
    integrator = sim.integrator
    out.append(
        SimulatedOnly(
            "integrator",
            "model",
            f"{integrator}, timestep {model.opt.timestep:g} s",
            {
                "Euler": "joint damping is integrated implicitly (eulerdamp), actuator "
                "damping (position kv, velocity actuators) explicitly",
                "RK4": "everything is integrated explicitly",
                "implicit": "joint and actuator damping are integrated implicitly",
                "implicitfast": "joint and actuator damping are integrated implicitly",
            }.get(integrator, "see MuJoCo's documentation"),
        )
    )
    if not sim.eulerdamp:
        out.append(
            SimulatedOnly(
                "eulerdamp disabled",
                "model",
                '<flag eulerdamp="disable"/>',
                "joint damping is integrated explicitly: the explicit stability bound on the "
                "timestep applies to it"
                if integrator == "Euler"
                else f"no effect under the {integrator} integrator",
            )
        )
    if not sim.gravity_enabled:
        out.append(
            SimulatedOnly(
                "gravity disabled",
                "model",
                '<flag gravity="disable"/>',
                "MuJoCo simulates without gravity; both engines' gravity torque is zero "
                f"(Pinocchio's gravity is bridged), whatever <option gravity> says "
                f"({' '.join(f'{g:g}' for g in model.opt.gravity)})",
            )
        )
    known = int(mujoco.mjtDisableBit.mjDSBL_GRAVITY) | int(mujoco.mjtDisableBit.mjDSBL_EULERDAMP)
    for key, bit in mujoco.mjtDisableBit.__members__.items():
        if key == "mjNDISABLE" or int(bit) & known:
            continue
        if int(bit) & flags:
            name = bit.name.removeprefix("mjDSBL_").lower()
            out.append(
                SimulatedOnly(
                    f"{name} disabled",
                    "model",
                    f'<flag {name}="disable"/>',
                    "MuJoCo leaves this part of the physics out of the simulation",
                )
            )
    return out

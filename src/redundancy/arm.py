"""The [`Arm`][redundancy.Arm]: one arm held by both engines, with joints matched by name.

An Arm is built by [`redundancy.load`][redundancy.load] (see `redundancy.model`), which checks the
model, bridges what Pinocchio's parser leaves out and hands both compiled models here. The Arm
itself only dispatches: every number comes from an engine of `redundancy.engines`.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator, Mapping
from typing import Any, ClassVar

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import ik, linalg, objectives
from .arm_coupled import ChainView, _Coupled, coupled_poses
from .arm_engines import _Engines
from .arm_keyframes import _Keyframes
from .arm_mass import _ToolMass
from .checks import (
    NameDict,
    check_count,
    check_flag,
    check_number,
    check_pose,
    check_tool_pose,
    describe,
)
from .engines import ENGINES, EngineName
from .engines.contract import Engine
from .engines.coupled import CoupledEngine
from .engines.coupling import CouplingMap
from .engines.mujoco import JOINT_TYPES, MujocoEngine, object_names
from .engines.pinocchio import PinocchioEngine
from .errors import (
    DeprecatedAlias,
    OutOfRangeError,
    ParameterError,
    PoseError,
    UnknownNameError,
)

Array = NDArray[np.float64]

__all__ = [
    "ENGINES",
    "Arm",
    "EngineName",
    "check_arm",
    "random_pose_chunks",
    "random_poses",
    "sampling_ranges",
]


#: Kinds of ``set_aside`` entries that are joints the file lets move and the arm never does:
#: a ball or free joint on the chain (held), a joint made fixed at load.
FROZEN = ("joint on the chain", "joint")


def check_arm(value: object, name: str = "arm") -> Arm:
    """An [`Arm`][redundancy.Arm], as every function taking one checks it first.

    Raises:
        ParameterError: Anything else (a path, a MuJoCo model...): the message says how an
            Arm is made.
    """
    if not isinstance(value, Arm):
        raise ParameterError(
            name, value, "an Arm (from redundancy.load or load_string)", describe(value)
        )
    return value


class Arm(_Engines, _Keyframes, _ToolMass, _Coupled):
    """One arm loaded into MuJoCo and Pinocchio, with joints matched by name.

    Build it with [`redundancy.load`][redundancy.load] or
    [`redundancy.load_string`][redundancy.load_string]. Joint order is MuJoCo's. An Arm may be
    shared by threads, copied and pickled (it pickles as its model source and options and is
    rebuilt, both engines, when loaded).

    Attributes:
        engines: The engines by name, the reference first: ``mujoco``, ``pinocchio`` and,
            when it can take part, ``drake``.
        absent_engines: Engine name -> why it is not in ``engines`` (``drake``: pydrake not
            installed, its parser refused the file, or a bridge the library would need).
        frame: Name of the tool frame (``site`` is its deprecated name).
        joint_names: Joint names, in order.
        joint_types: ``"hinge"`` or ``"slide"`` per joint.
        lower: Lower joint limits (``-inf`` where unlimited) [rad or m].
        upper: Upper joint limits (``inf`` where unlimited) [rad or m].
        effort_limit: Motor limit per joint from MuJoCo's actuators [N m or N].
        bridges: What was copied from MuJoCo into Pinocchio, one entry per value.
        source: The file the model came from, or ``"<string>"``.
        model_format: ``"MJCF"`` or ``"URDF"``, the format it was loaded from.
        held: Joints of the robot that are not the arm's, held still -> their rest value
            [rad or m] (a tuple for a ball or free joint, quaternions w x y z).
        set_aside: What in the robot's file does not reach the arm, with the reason
            (`redundancy.model.robot.SetAside`).
        defects: Defects of the published file on bodies the arm moves, mended the same way
            in both engines (an invalid inertia); the audit reports each as a finding.
        missing_inertia: Links the arm moves that the file gives no inertia (a URDF link
            without ``<inertial>``): kinematic quantities are served, dynamic ones raise
            `MissingInertiaError` naming them.
        missing_meshes: Meshes the file names that are found nowhere
            (`redundancy.model.selection.MissingMesh`: link, file, places looked in): their
            geoms are left out, and collision queries raise `MissingMeshError` naming them.
        robot_model: MuJoCo's compiled model of the whole robot (all joints).
        frame_type: ``"site"`` (an MJCF site) or ``"body"`` (an MJCF body, a URDF link).
        base: The body the arm's chain starts below (None: the world).
        rest: Where the held values come from: ``"qpos0"``, ``"keyframe 'name'"``, ``"given"``.
        length: The arm's size: its moving bodies' offsets and the tool's, summed [m]. The
            unit the inverse kinematics measures positions in, and the scale of the floor
            below which the tool counts as not moving (`effective_mass`).
        key_moves: Per keyframe, in file order: the held joints it puts elsewhere than
            ``held`` -> its value (see `keyframe_moves`); empty: none.
    """

    #: Drake's parser's warnings on the file (what it ignored), when Drake took part (the
    #: loader sets them on the arm).
    drake_warnings: tuple[str, ...] = ()
    #: What was copied from MuJoCo into Drake (`redundancy.model.drake_loading`).
    drake_bridges: tuple[Any, ...] = ()

    def __init__(
        self,
        mj_model: mujoco.MjModel,
        pin_model: Any,
        frame: str,
        source: str,
        *,
        armature: Array,
        damping: Array,
        effort_limit: Array,
        bridges: tuple[Any, ...] = (),
        recipe: tuple[Callable[..., Arm], tuple[Any, ...]] | None = None,
        model_format: str = "MJCF",
        held: Mapping[str, float | tuple[float, ...]] | None = None,
        set_aside: tuple[Any, ...] = (),
        defects: tuple[str, ...] = (),
        missing_inertia: tuple[str, ...] = (),
        missing_meshes: tuple[Any, ...] = (),
        robot_model: mujoco.MjModel | None = None,
        frame_type: str = "site",
        base: str | None = None,
        rest: str = "qpos0",
        key_moves: tuple[Mapping[str, float | tuple[float, ...]], ...] = (),
        coupling: CouplingMap | None = None,
    ) -> None:
        self.source = source
        self.frame = frame
        chain = tuple(object_names(mj_model, mujoco.mjtObj.mjOBJ_JOINT))
        types = tuple(JOINT_TYPES[mujoco.mjtJoint(t)] for t in mj_model.jnt_type)
        #: Every joint the arm moves, independent and followers, in MuJoCo's order: the
        #: chain's joints and the followers its couplings move (`chain_pose`).
        self.chain_joint_names: tuple[str, ...] = chain
        #: The chain's coupling map (None: every chain joint is a coordinate).
        self.coupling: CouplingMap | None = coupling
        self.joint_names: tuple[str, ...] = chain if coupling is None else coupling.names
        self.joint_types: tuple[str, ...] = (
            types if coupling is None else tuple(types[i] for i in coupling.independent)
        )
        self.nq: int = len(self.joint_names)
        effort = np.asarray(effort_limit, dtype=float)
        self.effort_limit: Array = effort if coupling is None else effort[coupling.independent]
        self._chain_types, self._chain_effort_limit = types, effort  # for `ChainView`
        self.bridges: tuple[Any, ...] = tuple(bridges)
        #: The engines by name, the reference first (`redundancy.engines.REFERENCE`): the
        #: cross-check compares it with each other one, IK confirms in every other one.
        self.engines: dict[str, Engine] = {
            "mujoco": MujocoEngine(mj_model, frame, armature, damping),
            "pinocchio": PinocchioEngine(pin_model, frame, chain, frame_type),
        }
        if coupling is not None:  # every engine seen in the independent coordinates
            self.engines = {n: CoupledEngine(e, coupling) for n, e in self.engines.items()}
        #: Follower joint -> what determines it (a joint equality, a loop's closure).
        self.followers: dict[str, str] = NameDict(
            coupling.followers if coupling is not None else {}, "follower joint"
        )
        limits: tuple[Array, Array] = self.mujoco.limits
        self.lower: Array = limits[0]
        self.upper: Array = limits[1]
        self.length: float = self.mujoco.length
        self._floor = linalg.motion_floor(self.length)
        self._slides: Array = np.array([t == "slide" for t in self.joint_types])
        self._recipe = recipe
        self.model_format = model_format
        self.held: dict[str, float | tuple[float, ...]] = NameDict(held or {}, "held joint")
        self.set_aside: tuple[Any, ...] = tuple(set_aside)
        self.defects: tuple[str, ...] = tuple(defects)
        self.missing_inertia: tuple[str, ...] = tuple(missing_inertia)
        for engine in self.engines.values():
            engine.missing_inertia = self.missing_inertia  # their dynamic quantities refuse
        #: Engine name -> why it is not in `engines` (the loader adds Drake or says why not).
        self.absent_engines: dict[str, str] = {}
        self.missing_meshes: tuple[Any, ...] = tuple(missing_meshes)
        self.robot_model: mujoco.MjModel = mj_model if robot_model is None else robot_model
        self.frame_type: str = frame_type
        self.base: str | None = base
        self.rest: str = rest
        self._key_moves = tuple(dict(k) for k in key_moves)
        self._at_keys: dict[str, Arm] = {}
        self._lock = threading.Lock()

    def __reduce__(self) -> tuple[Callable[..., Arm], tuple[Any, ...]]:
        # Engine models and data do not pickle (and views into MjData would become detached
        # copies): an Arm travels as its recipe, the load's options and the bytes of every
        # file it read (redundancy.model.content), and is rebuilt on arrival.
        if self._recipe is None:
            raise TypeError("this Arm was not built by redundancy.load and cannot be pickled")
        return self._recipe

    @property
    def frozen(self) -> dict[str, str]:
        """Joints of the robot's file that never move here -> why.

        A ball or free joint on the chain to the tool (held at rest: the arm's joints are
        hinges and slides), and a joint the loader made fixed (a URDF joint whose child link
        has no mass). The other held joints are in `held`.
        """
        frozen = ((a.name, a.reason) for a in self.set_aside if a.what in FROZEN)
        return NameDict(frozen, "frozen joint")

    # -- names, keyframes and poses --------------------------------------------------------
    site: ClassVar[DeprecatedAlias] = DeprecatedAlias("frame")
    """Deprecated name of `frame` (warns with a DeprecationWarning)."""

    def joint_index(self, name: str) -> int:
        """Index of a joint in the library's order."""
        if not isinstance(name, str) or name not in self.joint_names:
            raise UnknownNameError("joint", name, self.joint_names)
        return self.joint_names.index(name)

    def pose(self, q: ArrayLike, check_range: bool = False, tol: float = 1e-9) -> Array:
        """Validate a joint configuration and return it as a float64 array of shape (nq,).

        Args:
            q: Joint values in the order of `joint_names` [rad or m].
            check_range: Also require every value inside its joint's range (within ``tol``).
            tol: Slack on the range check [rad or m].

        Raises:
            PoseError: Wrong shape or type, complex, NaN or infinite values.
            OutOfRangeError: A value outside its range (only with ``check_range``).
        """
        arr = check_pose(q, self.joint_names)
        if check_flag("check_range", check_range):
            tol = check_number("tol", tol, 0.0, unit="rad or m")
            for i in range(self.nq):
                if not (self.lower[i] - tol <= arr[i] <= self.upper[i] + tol):
                    raise OutOfRangeError(
                        self.joint_names[i],
                        float(arr[i]),
                        float(self.lower[i]),
                        float(self.upper[i]),
                    )
        return arr

    # -- quantities, from either engine -----------------------------------------------------
    def site_pose(self, q: ArrayLike, engine: EngineName = "mujoco") -> tuple[Array, Array]:
        """Tool site position [m] and rotation matrix, world frame."""
        return self.engine(engine).site_pose(q)

    def jacobian(self, q: ArrayLike, engine: EngineName = "mujoco") -> Array:
        """Site Jacobian, shape (6, nq): linear rows [m/rad] then angular [rad/rad], world axes."""
        try:  # the engine table read inline: arm.jacobian is a controller's inner loop
            eng = self.engines[engine]
        except (KeyError, TypeError):
            return self.engine(engine).site_jacobian(q)  # absent or unknown: says which
        return eng.site_jacobian(q)

    def svd(
        self, q: ArrayLike, engine: EngineName = "mujoco", rtol: float = linalg.RANK_RTOL
    ) -> linalg.JacobianSVD:
        """SVD of the site Jacobian, with rank, lost directions and condition number.

        Args:
            q: Pose [rad or m].
            engine: ``"mujoco"`` or ``"pinocchio"``.
            rtol: Rank threshold relative to the largest singular value, in (0, 1).
        """
        return linalg.jacobian_svd(self.jacobian(q, engine), rtol)

    def manipulability(
        self, q: ArrayLike, length: float = 1.0, engine: EngineName = "mujoco"
    ) -> linalg.Manipulability:
        """Yoshikawa's measure of J, its blocks, and J with position rows divided by length [m].

        Each is the product of the singular values of its rows of J (sqrt(det(J J^T)) with 6 or more
        joints, sqrt(det(J^T J)) with fewer; see
        [`redundancy.linalg.yoshikawa`][redundancy.linalg.yoshikawa]). The measures are computed
        when read: ``arm.manipulability(q).full`` costs one J and one SVD.
        """
        return linalg.manipulability(self.jacobian(q, engine), length)

    def manipulability_gradient(self, q: ArrayLike, engine: EngineName = "mujoco") -> Array:
        """Gradient of ``manipulability(q).full`` from second-order kinematics, shape (nq,).

        The derivative of the same value for any joint count (the product of the singular
        values of J); zeros at a singular pose, where it has a kink.
        """
        q = check_pose(q, self.joint_names)
        eng = self.engine(engine)
        return linalg.manipulability_gradient(eng.site_jacobian(q), eng.jacobian_derivatives(q))

    def nullspace_projector(self, q: ArrayLike, engine: EngineName = "mujoco") -> Array:
        """N = I - J^+ J at ``q``, shape (nq, nq)."""
        return linalg.nullspace_projector(self.jacobian(q, engine))

    def nullspace_basis(self, q: ArrayLike, engine: EngineName = "mujoco") -> Array:
        """Orthonormal basis of J's null space at ``q``, shape (nq, nq - rank)."""
        return linalg.nullspace_basis(self.jacobian(q, engine))

    def mass_matrix(
        self, q: ArrayLike, armature: bool = True, engine: EngineName = "mujoco"
    ) -> Array:
        """Joint-space mass matrix [kg m^2], with or without armature."""
        return self.engine(engine).mass_matrix(q, check_flag("armature", armature))

    def gravity(self, q: ArrayLike, engine: EngineName = "mujoco") -> Array:
        """Gravity torque the motors must supply to hold ``q`` [N m or N]."""
        return self.engine(engine).gravity(q)

    def armature(self, engine: EngineName = "mujoco") -> Array:
        """Armature per joint as the engine's mass matrix sees it [kg m^2]."""
        return self.engine(engine).armature

    def damping(self, engine: EngineName = "mujoco") -> Array:
        """Linear viscous damping b per joint, the force -b v [N m s/rad or N s/m].

        The joint's ``damping`` plus gear^2 x its actuators' (reflected through the gear),
        as bridged into both engines. Left out, though MuJoCo simulates them: the damping
        polynomial's higher terms (``damping="b0 b1 b2"`` on a joint or actuator is the
        force -(b0 v + b1 v|v| + b2 v^3): this is b0; b1, b2 are ``mj_model.dof_dampingpoly``
        and ``actuator_dampingpoly``, compared by [`redundancy.compare`][redundancy.compare]),
        tendon damping, the friction loss (a constraint), and a servo's ``kv`` (counted on
        its own where the audit judges the timestep).

        Args:
            engine: ``"mujoco"`` or ``"pinocchio"``.
        """
        return self.engine(engine).damping

    # -- motion: the Coriolis matrix, the centre of mass and momentum ---------------------
    def coriolis(self, q: ArrayLike, v: ArrayLike, *, engine: EngineName = "mujoco") -> Array:
        """Coriolis matrix C(q, v) in the Christoffel form, shape (nq, nq) [N m s/rad].

        ``C @ v`` is the velocity-dependent joint torque (the bias force minus gravity) and
        dM/dt = C + C^T, so dM/dt - 2 C is skew-symmetric. Held joints have zero velocity.
        MuJoCo: from ``mj_rne``'s bias, exactly quadratic in v (2 nq evaluations, no
        finite-difference error); Pinocchio: ``computeCoriolisMatrix``.

        Args:
            q: Pose [rad or m].
            v: Joint velocity [rad/s or m/s], shape (nq,).
            engine: ``"mujoco"`` or ``"pinocchio"``.

        Raises:
            PoseError: ``q`` or ``v`` not a finite real vector of shape (nq,).
        """
        return self.engine(engine).coriolis(q, v)

    def mass_matrix_derivative(
        self, q: ArrayLike, v: ArrayLike, *, engine: EngineName = "mujoco"
    ) -> Array:
        """dM/dt along the joint velocity ``v``, shape (nq, nq) [kg m^2/s]: C + C^T.

        Arguments as `coriolis`. Armature is constant: it does not appear.
        """
        C = self.engine(engine).coriolis(q, v)
        return C + C.T

    def com(self, q: ArrayLike, *, engine: EngineName = "mujoco") -> Array:
        """The whole robot's centre of mass, world frame, shape (3,) [m].

        Every body of the file with mass: the arm's, the held ones at rest, and those
        welded to the world (a fixed base link, which Pinocchio's ``centerOfMass`` leaves
        out and the engine adds back).
        """
        return self.engine(engine).com(q)

    def com_jacobian(self, q: ArrayLike, *, engine: EngineName = "mujoco") -> Array:
        """Jacobian of `com` for the arm's joints, shape (3, nq) [m/rad or m/m]."""
        return self.engine(engine).com_jacobian(q)

    def centroidal_momentum_matrix(self, q: ArrayLike, *, engine: EngineName = "mujoco") -> Array:
        """The whole robot's momentum per unit joint velocity, shape (6, nq), world axes.

        Rows 0-2: linear momentum [kg m/s per rad/s]; rows 3-5: angular momentum about
        the whole robot's centre of mass (`com`) [kg m^2/s per rad/s]. Times a joint
        velocity it is the robot's momentum; bodies that do not move contribute their mass
        to the centre of mass only.
        """
        return self.engine(engine).centroidal_momentum_matrix(q)

    # -- inverse kinematics -----------------------------------------------------------------
    def ik_objective(
        self, objective: object, engine: EngineName = "mujoco"
    ) -> objectives.Objective | None:
        """The objective (a value to raise) behind an ``objective`` argument of `solve_ik`.

        ``"joint_limits"`` is
        [`redundancy.objectives.joint_limits`][redundancy.objectives.joint_limits] over the
        joint ranges; ``"manipulability"`` is Yoshikawa's sqrt(det(J J^T)) with its analytic
        gradient ([`manipulability_gradient`][redundancy.arm.Arm.manipulability_gradient]); an
        [`Objective`][redundancy.objectives.Objective] or a callable q -> float is taken as
        it is (a callable returning a (cost, gradient) pair to lower is deprecated).

        Raises:
            UnknownNameError: A name that is not one of `redundancy.ik.OBJECTIVES`.
            ParameterError: Neither None, a name, an Objective nor a callable.
        """
        if objective is None:
            return None
        if isinstance(objective, str):
            if objective not in ik.OBJECTIVES:
                raise UnknownNameError("objective", objective, ik.OBJECTIVES)
            if objective == "joint_limits":
                return objectives.joint_limits(self.lower, self.upper)
            eng = self.engine(engine)
            return objectives.Objective(
                "manipulability sqrt(det(J J^T))",
                lambda q: linalg.yoshikawa(eng.site_jacobian(q)),
                lambda q: linalg.manipulability_gradient(
                    eng.site_jacobian(q), eng.jacobian_derivatives(q)
                ),
            )
        if callable(objective):
            return objectives.as_objective(objective)  # type: ignore[arg-type]
        raise ParameterError(
            "objective",
            objective,
            f"None, one of {list(ik.OBJECTIVES)}, {objectives.VALID}",
        )

    def solve_ik(
        self,
        target: object,
        q0: ArrayLike | None = None,
        *,
        objective: object = None,
        position_only: bool = False,
        position_tol: float = ik.DEFAULT_SETTINGS.position_tol,
        orientation_tol: float = ik.DEFAULT_SETTINGS.orientation_tol,
        restarts: int = ik.DEFAULT_SETTINGS.restarts,
        seed: int | None = 0,
        engine: EngineName = "mujoco",
    ) -> ik.IKResult:
        """Joint values that put the tool at ``target``, inside the joint ranges.

        Damped Levenberg-Marquardt with the joints clamped to their ranges and random restarts
        inside them; the answer is recomputed by every other engine, whose errors decide ``success``
        (see [`redundancy.ik`][redundancy.ik]).

        Args:
            target: A 4 x 4 homogeneous pose, or a (position [m], rotation) pair as
                [`site_pose`][redundancy.arm.Arm.site_pose] returns, world frame.
            q0: First start [rad or m]; None: the middle of the joint ranges.
            objective: Pursued in the task's null space once the task is met, never at its
                expense: ``"joint_limits"`` (away from the limits), ``"manipulability"``
                (Yoshikawa's measure up), an [`Objective`][redundancy.objectives.Objective]
                or a callable q -> float to raise, as `self_motion` takes.
            position_only: Reach the position alone; the orientation is free.
            position_tol: Position tolerance [m], > 0.
            orientation_tol: Orientation tolerance [rad], > 0.
            restarts: Random restarts at most, >= 0.
            seed: Seed of the restarts' random starts (None: fresh entropy).
            engine: The engine that iterates; every other one checks.

        Returns:
            The [`IKResult`][redundancy.IKResult]: ``q`` (inside the ranges in every case),
            ``success``, ``position_error`` [m], ``orientation_error`` [rad], ``iterations``.

        Raises:
            ParameterError: A bad target, tolerance, count, seed or objective.
            PoseError: A bad ``q0``.
        """
        p_t, R_t = check_tool_pose("target", target)
        eng = self.engine(engine)
        settings = ik.checked_settings(position_tol, orientation_tol, restarts)
        if seed is not None:
            seed = check_count("seed", seed, 0)
        try:
            lo, hi = self._ik_ranges
        except AttributeError:  # drawn from where the sampling draws (an unlimited slide: +-L)
            lo, hi = self._ik_ranges = sampling_ranges(self, unlimited_slide=self.length)
        start = 0.5 * (lo + hi) if q0 is None else self.pose(q0)
        return ik.solve(
            eng,
            self._others(engine),
            self.lower,
            self.upper,
            lo,
            hi,
            p_t,
            R_t,
            start,
            lambda: np.random.default_rng(seed),
            self.ik_objective(objective, engine),
            check_flag("position_only", position_only),
            settings,
            self.length,
            self._slides,
        )

    def __repr__(self) -> str:
        held = f", held={len(self.held)}" if self.held else ""
        return f"Arm({self.source!r}, frame={self.frame!r}, joints={list(self.joint_names)}{held})"


def sampling_ranges(
    arm: Arm, unlimited: float = np.pi, unlimited_slide: float | None = None
) -> tuple[Array, Array]:
    """Lower and upper bounds used to draw random poses [rad or m].

    The joint ranges; an unlimited hinge is drawn in [-pi, pi] (the one place this rule
    lives: sampling, hypothesis strategies, sliders and reach bounds all read it here).

    Args:
        arm: The arm.
        unlimited: Half-width of the interval for an unlimited hinge [rad].
        unlimited_slide: Half-width for an unlimited slide [m]; None refuses one.

    Raises:
        PoseError: An unlimited slide joint and no ``unlimited_slide`` (no range to draw from).
        ParameterError: Not an Arm, or a half-width not a finite number > 0.
    """
    if not isinstance(arm, ChainView):  # a coupled arm's chain, compared as an open one
        arm = check_arm(arm)
    unlimited = check_number("unlimited", unlimited, 0.0, low_open=True, unit="rad")
    if unlimited_slide is not None:
        unlimited_slide = check_number(
            "unlimited_slide", unlimited_slide, 0.0, low_open=True, unit="m"
        )
    lo, hi = arm.lower.copy(), arm.upper.copy()
    for i, kind in enumerate(arm.joint_types):
        if not (np.isfinite(lo[i]) and np.isfinite(hi[i])):
            if kind != "hinge" and unlimited_slide is not None:
                lo[i], hi[i] = -unlimited_slide, unlimited_slide
                continue
            if kind != "hinge":
                raise PoseError(
                    f"joint {arm.joint_names[i]!r} is an unlimited slide: no range to sample"
                )
            lo[i], hi[i] = -unlimited, unlimited
    return lo, hi


def random_pose_chunks(arm: Arm, n: int, seed: int | None, size: int) -> Iterator[Array]:
    """`random_poses` ``(arm, n, seed)`` in chunks of ``size`` rows (the last one shorter).

    Drawn chunk by chunk from one generator, so memory stays flat in ``n``; a coupled arm's
    draws at once, where a draw its followers leave is replaced (`random_poses`' order).
    ``n`` and ``seed`` are checked by the caller.
    """
    if arm.coupling is not None:
        Q = random_poses(arm, n, seed)
        yield from (Q[start : start + size] for start in range(0, n, size))
        return
    lo, hi = sampling_ranges(arm)
    rng = np.random.default_rng(seed)
    for start in range(0, n, size):
        yield rng.uniform(lo, hi, size=(min(size, n - start), arm.nq))


def random_poses(arm: Arm, n: int, seed: int | None = 1) -> Array:
    """``n`` poses drawn uniformly in the joint ranges, shape (n, nq) [rad or m].

    On an arm with coupled joints, a draw whose followers leave their ranges (or whose loop
    cannot close) is not drawn: the next draw replaces it.

    Draws in the same order as ``rng = np.random.default_rng(seed)`` followed by
    ``rng.uniform(lo, hi)`` once per pose, so a seed reproduces the lesson's sample.

    Raises:
        ParameterError: ``n`` not an integer >= 0, or more poses than memory holds; ``seed``
            not None or an integer >= 0.
    """
    arm = check_arm(arm)
    n = check_count("n", n, 0)
    if seed is not None:
        seed = check_count("seed", seed, 0)
    lo, hi = sampling_ranges(arm)
    try:
        rng = np.random.default_rng(seed)
        Q = rng.uniform(lo, hi, size=(n, arm.nq))
    except (MemoryError, ValueError):  # ValueError: more bytes than an address can count
        size = n * arm.nq * 8
        raise ParameterError(
            "n",
            n,
            f"a count of poses that fits in memory ({n} x {arm.nq} float64: {size:.3g} bytes)",
        ) from None
    if arm.coupling is None:
        return Q
    return coupled_poses(arm, Q, rng, lo, hi)

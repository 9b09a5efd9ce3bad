"""The :class:`Arm`: one arm held by both engines, with joints matched by name.

An Arm is built by :func:`redundancy.load` (see :mod:`redundancy.model`), which checks the
model, bridges what Pinocchio's parser leaves out and hands both compiled models here. The
Arm itself only dispatches: every number comes from an engine of :mod:`redundancy.engines`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import linalg
from .checks import check_count, check_number, check_pose
from .engines import ENGINES, EngineName
from .engines.contract import Engine
from .engines.mujoco import JOINT_TYPES, MujocoEngine, object_names
from .engines.pinocchio import PinocchioEngine
from .errors import OutOfRangeError, PoseError, UnknownNameError

Array = NDArray[np.float64]

__all__ = ["ENGINES", "Arm", "EngineName", "random_poses", "sampling_ranges"]


class Arm:
    """One arm loaded into MuJoCo and Pinocchio, with joints matched by name.

    Build it with :func:`redundancy.load` or :func:`redundancy.load_string`. Joint order is
    MuJoCo's. An Arm may be shared by threads, copied and pickled (it pickles as its model
    source and options and is rebuilt, both engines, when loaded).

    Attributes:
        mujoco: The MuJoCo engine.
        pinocchio: The Pinocchio engine (with the bridged values).
        site: Name of the tool site.
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
            (:class:`redundancy.model.robot.SetAside`).
        defects: Defects of the published file on bodies the arm moves, mended the same way
            in both engines (an invalid inertia); the audit reports each as a finding.
        robot_model: MuJoCo's compiled model of the whole robot (all joints).
        frame_type: ``"site"`` (an MJCF site) or ``"body"`` (an MJCF body, a URDF link).
        base: The body the arm's chain starts below (None: the world).
        rest: Where the held values come from: ``"qpos0"``, ``"keyframe 'name'"``, ``"given"``.
    """

    def __init__(
        self,
        mj_model: mujoco.MjModel,
        pin_model: Any,
        site: str,
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
        robot_model: mujoco.MjModel | None = None,
        frame_type: str = "site",
        base: str | None = None,
        rest: str = "qpos0",
    ) -> None:
        self.source = source
        self.site = site
        self.joint_names: tuple[str, ...] = tuple(object_names(mj_model, mujoco.mjtObj.mjOBJ_JOINT))
        self.joint_types: tuple[str, ...] = tuple(
            JOINT_TYPES[mujoco.mjtJoint(t)] for t in mj_model.jnt_type
        )
        self.nq: int = mj_model.nq
        self.effort_limit: Array = np.asarray(effort_limit, dtype=float)
        self.bridges: tuple[Any, ...] = tuple(bridges)
        self.mujoco: MujocoEngine = MujocoEngine(mj_model, site, armature, damping)
        self.pinocchio: PinocchioEngine = PinocchioEngine(
            pin_model, site, self.joint_names, frame_type
        )
        limits: tuple[Array, Array] = self.mujoco.limits
        self.lower: Array = limits[0]
        self.upper: Array = limits[1]
        self._engines: dict[str, Engine] = {"mujoco": self.mujoco, "pinocchio": self.pinocchio}
        self._recipe = recipe
        self.model_format = model_format
        self.held: dict[str, float | tuple[float, ...]] = dict(held or {})
        self.set_aside: tuple[Any, ...] = tuple(set_aside)
        self.defects: tuple[str, ...] = tuple(defects)
        self.robot_model: mujoco.MjModel = mj_model if robot_model is None else robot_model
        self.frame_type: str = frame_type
        self.base: str | None = base
        self.rest: str = rest

    def __reduce__(self) -> tuple[Callable[..., Arm], tuple[Any, ...]]:
        # Engine models and data do not pickle (and views into MjData would become detached
        # copies): an Arm travels as the loader call that built it and is rebuilt on arrival.
        if self._recipe is None:
            raise TypeError("this Arm was not built by redundancy.load and cannot be pickled")
        return self._recipe

    # -- names, keyframes and poses --------------------------------------------------------
    @property
    def frame(self) -> str:
        """Name of the tool frame (``site`` is its older name)."""
        return self.site

    @property
    def mj_model(self) -> mujoco.MjModel:
        """MuJoCo's compiled model (shared, do not modify)."""
        return self.mujoco.model

    @property
    def keyframes(self) -> dict[str, Array]:
        """Keyframe name -> joint configuration [rad or m].

        An unnamed keyframe is called ``key<index>``, with ``_`` appended until the name is
        not one a keyframe of the model has (an unnamed key never hides a named one).
        """
        m = self.mj_model
        names = object_names(m, mujoco.mjtObj.mjOBJ_KEY)
        taken = set(names)
        for k, name in enumerate(names):
            if not name:
                name = f"key{k}"
                while name in taken:
                    name += "_"
                names[k] = name
                taken.add(name)
        return {names[k]: m.key_qpos[k].copy() for k in range(m.nkey)}

    def keyframe(self, name: str) -> Array:
        """Joint configuration of a named keyframe [rad or m]."""
        keys = self.keyframes
        if name not in keys:
            raise UnknownNameError("keyframe", name, list(keys))
        return keys[name]

    def joint_index(self, name: str) -> int:
        """Index of a joint in the library's order."""
        if name not in self.joint_names:
            raise UnknownNameError("joint", name, self.joint_names)
        return self.joint_names.index(name)

    def engine(self, name: EngineName) -> Engine:
        """One engine, by name (``"mujoco"`` or ``"pinocchio"``)."""
        try:
            return self._engines[name]
        except (KeyError, TypeError):
            raise UnknownNameError("engine", str(name), ENGINES) from None

    def pose(self, q: ArrayLike, check_range: bool = False, tol: float = 1e-9) -> Array:
        """Validate a joint configuration and return it as a float64 array of shape (nq,).

        Args:
            q: Joint values in the order of :attr:`joint_names` [rad or m].
            check_range: Also require every value inside its joint's range (within ``tol``).
            tol: Slack on the range check [rad or m].

        Raises:
            PoseError: Wrong shape or type, complex, NaN or infinite values.
            OutOfRangeError: A value outside its range (only with ``check_range``).
        """
        arr = check_pose(q, self.joint_names)
        if check_range:
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
            eng = self._engines[engine]
        except (KeyError, TypeError):
            raise UnknownNameError("engine", str(engine), ENGINES) from None
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

        Each is the product of the singular values of its rows of J (sqrt(det(J J^T)) with
        6 or more joints, sqrt(det(J^T J)) with fewer; see :func:`redundancy.linalg.yoshikawa`).
        The measures are computed when read: ``arm.manipulability(q).full`` costs one J and
        one SVD.
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
        return self.engine(engine).mass_matrix(q, armature)

    def gravity(self, q: ArrayLike, engine: EngineName = "mujoco") -> Array:
        """Gravity torque the motors must supply to hold ``q`` [N m or N]."""
        return self.engine(engine).gravity(q)

    def armature(self, engine: EngineName = "mujoco") -> Array:
        """Armature per joint as the engine's mass matrix sees it [kg m^2]."""
        return self.engine(engine).armature

    def damping(self, engine: EngineName = "mujoco") -> Array:
        """Damping b per joint: dof damping plus gear^2 x actuator damping [N m s/rad]."""
        return self.engine(engine).damping

    def __repr__(self) -> str:
        held = f", held={len(self.held)}" if self.held else ""
        return f"Arm({self.source!r}, frame={self.site!r}, joints={list(self.joint_names)}{held})"


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
    """
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


def random_poses(arm: Arm, n: int, seed: int | None = 1) -> Array:
    """``n`` poses drawn uniformly in the joint ranges, shape (n, nq) [rad or m].

    Draws in the same order as ``rng = np.random.default_rng(seed)`` followed by
    ``rng.uniform(lo, hi)`` once per pose, so a seed reproduces the lesson's sample.

    Raises:
        ParameterError: ``n`` not an integer >= 0, or ``seed`` not None or an integer >= 0.
    """
    n = check_count("n", n, 0)
    if seed is not None:
        seed = check_count("seed", seed, 0)
    lo, hi = sampling_ranges(arm)
    return np.random.default_rng(seed).uniform(lo, hi, size=(n, arm.nq))

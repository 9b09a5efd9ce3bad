"""The engine contract: what every engine computes, for one pose and for stacks of poses.

Both `MujocoEngine` and `PinocchioEngine` implement `Engine`; the rest of the library is typed
against it and never calls an engine library for these quantities.

Conventions shared by both: joint order is the library's (MuJoCo's ``jnt`` order); a single-pose
method takes any array-like pose and validates it with `redundancy.checks.pose_key` (so an engine
may be called directly, and the Arm only dispatches), while stacks are validated by the caller
(`redundancy.checks.check_poses`) because they are validated once and evaluated in chunks; the site
Jacobian is the velocity of the site origin along world axes (linear rows first); gravity is the
generalised force the motors must apply to hold a pose. Every method may be called from any number
of threads: each thread computes with its own engine data.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import MissingInertiaError

Array = NDArray[np.float64]


class JointVectors:
    """The contract's per-joint vectors of an engine that holds them as arrays: copies out.

    The engine sets ``_armature``, ``_damping`` and ``_limits`` (lower, upper) in its
    constructor; what each means in that engine (MuJoCo's ``dof_armature``, Drake's reflected
    rotor inertia, a coupled arm's diag(G^T A G)) its constructor says.
    """

    _armature: Array
    _damping: Array
    _limits: tuple[Array, Array]

    @property
    def armature(self) -> Array:
        """Armature per joint as the engine's M adds it [kg m^2] (a copy)."""
        return self._armature.copy()

    @property
    def damping(self) -> Array:
        """Viscous damping per joint [N m s/rad or N s/m] (a copy)."""
        return self._damping.copy()

    @property
    def limits(self) -> tuple[Array, Array]:
        """Lower and upper limits, ``-inf``/``inf`` where unlimited [rad or m] (copies)."""
        return self._limits[0].copy(), self._limits[1].copy()


@dataclass
class Stacks:
    """Output stacks that `Engine.evaluate` fills in place; None where not wanted.

    Attributes:
        X: Site positions (n, 3) [m].
        R: Site rotation matrices (n, 3, 3).
        J: Site Jacobians (n, 6, nv).
        M: Mass matrices (n, nv, nv) [kg m^2], with armature unless ``armature`` is False.
        G: Gravity torques (n, nv) [N m or N].
        armature: Include armature in ``M``.
    """

    X: Array | None = None
    R: Array | None = None
    J: Array | None = None
    M: Array | None = None
    G: Array | None = None
    armature: bool = True

    @classmethod
    def empty(cls, n: int, nv: int, fields: Iterable[str], armature: bool = True) -> Stacks:
        """Uninitialised stacks of ``n`` poses for the ``fields`` named (``"X"``... ``"G"``)."""
        shapes = {"X": (n, 3), "R": (n, 3, 3), "J": (n, 6, nv), "M": (n, nv, nv), "G": (n, nv)}
        return cls(**{f: np.empty(shapes[f]) for f in fields}, armature=armature)  # type: ignore[arg-type]

    @property
    def dynamics(self) -> bool:
        """True when anything beyond the site pose is wanted (J, M or gravity)."""
        return self.J is not None or self.M is not None or self.G is not None


def check_dynamics(engine: object, quantity: str) -> None:
    """Refuse a dynamic quantity of an engine whose arm lacks inertial data.

    Raises:
        MissingInertiaError: ``engine.missing_inertia`` names links without inertia.
    """
    links = getattr(engine, "missing_inertia", ())
    if links:
        raise MissingInertiaError(quantity, links)


def remove_armature(M: Array, armature: Array) -> None:
    """Subtract the armature from the diagonal of one mass matrix or a stack, in place.

    Args:
        M: Mass matrix (nv, nv) or stack (n, nv, nv) [kg m^2], armature included.
        armature: Armature per dof, in M's own joint order [kg m^2].
    """
    k = np.arange(M.shape[-1])
    M[..., k, k] -= armature


@runtime_checkable
class Engine(Protocol):
    """One arm and tool site in one engine."""

    name: str
    nv: int

    @property
    def armature(self) -> Array:
        """Armature per joint as the mass matrix sees it [kg m^2]."""
        ...

    @property
    def damping(self) -> Array:
        """Viscous damping per joint [N m s/rad or N s/m]."""
        ...

    @property
    def limits(self) -> tuple[Array, Array]:
        """Lower and upper joint limits (``-inf``/``inf`` where unlimited) [rad or m]."""
        ...

    def site_pose(self, q: ArrayLike) -> tuple[Array, Array]:
        """Site position [m] and rotation matrix, world frame."""
        ...

    def site_jacobian(self, q: ArrayLike) -> Array:
        """Site Jacobian, shape (6, nv) [m/rad; rad/rad]."""
        ...

    def jacobian_derivatives(self, q: ArrayLike) -> Array:
        """dJ/dq_k for every k, shape (nv, 6, nv)."""
        ...

    def mass_matrix(self, q: ArrayLike, armature: bool = True) -> Array:
        """Joint-space mass matrix [kg m^2], with or without armature."""
        ...

    def gravity(self, q: ArrayLike) -> Array:
        """Gravity torque to hold ``q`` [N m or N]."""
        ...

    def integrate(self, q: ArrayLike, dq: ArrayLike) -> Array:
        """Configuration reached from ``q`` after the displacement ``dq`` [rad or m]."""
        ...

    def link_inertias(self, q: ArrayLike) -> tuple[Array, Array, Array]:
        """Mass [kg], world centre of mass [m] and inertia about it [kg m^2] per joint's body."""
        ...

    def joint_axes(self, q: ArrayLike) -> tuple[Array, Array]:
        """World joint axes and anchors [m], shape (nv, 3) each."""
        ...

    def evaluate(self, Q: Array, out: Stacks, threads: int = 1) -> None:
        """Fill the stacks of ``out`` for every pose of ``Q`` (n, nv), in place.

        Args:
            Q: Poses, C-contiguous (n, nv) [rad or m].
            out: The stacks to fill (None where not wanted).
            threads: Worker threads (at most; validated by the caller).
        """
        ...

    def tool_mobility(
        self, q: ArrayLike, armature: bool = True, free: Array | None = None
    ) -> tuple[Array, Array]:
        """Site Jacobian of the free joints J_f (6, k) and M_ff^-1 J_f^T (k, 6).

        J_f M_ff^-1 J_f^T is the inverse of the operational-space inertia; held joints
        (those not in ``free``, indices ascending, validated by the caller; None: all free)
        lose their column of J and their row and column of M.
        """
        ...

    def tool_mobilities(
        self, Q: Array, armature: bool = True, free: Array | None = None, threads: int = 1
    ) -> tuple[Array, Array]:
        """`tool_mobility` over a validated stack: (n, 6, k) and (n, k, 6)."""
        ...

    def ik_kernel(self, position: Array, rotation: Array) -> Callable[[Array], tuple[Array, Array]]:
        """An unchecked q -> (tool error [p* - p; log(R* R^T)], J) for this thread (IK loops)."""
        ...

    def coriolis(self, q: ArrayLike, v: ArrayLike) -> Array:
        """Coriolis matrix in the Christoffel form (nv, nv) [N m s/rad]."""
        ...

    def coriolis_stack(self, Q: Array, V: Array, out: Array, threads: int = 1) -> None:
        """`coriolis` over validated stacks (n, nv), into ``out`` (n, nv, nv)."""
        ...

    def com(self, q: ArrayLike) -> Array:
        """The whole model's centre of mass, world frame (3,) [m]."""
        ...

    def com_jacobian(self, q: ArrayLike) -> Array:
        """Jacobian of `com`, (3, nv) [m/rad]."""
        ...

    def centroidal_momentum_matrix(self, q: ArrayLike) -> Array:
        """Linear and angular (about the centre of mass) momentum per joint velocity, (6, nv)."""
        ...

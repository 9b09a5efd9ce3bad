"""The mass a contact at an [`Arm`][redundancy.Arm]'s tool feels, from either engine.

`_ToolMass` is a part of `Arm`, which documents its methods: the operational-space
inertia, the effective mass along a direction and over all directions, and the dynamic
manipulability, each with some joints held rigid if asked.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import TypedDict, Unpack

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import kernels, linalg
from .checks import check_direction, check_flag, check_joint_subset, check_options
from .engines import EngineName
from .engines.contract import Engine

Array = NDArray[np.float64]


class ToolMassOptions(TypedDict, total=False):
    """The keywords the tool-mass methods share (`Arm.operational_inertia` and the others).

    Each is optional; the defaults are the whole arm with its motors, seen by MuJoCo.

    Attributes:
        armature: Include the armature (the motors' rotor inertia) in M (default True).
        joints: Names of the joints free to move; the others are held rigid (their column
            leaves J, their row and column leave M). None (default): every joint.
        engine: ``"mujoco"`` (default; sparse ``mj_solveM``) or ``"pinocchio"``
            (``computeMinverse``).
    """

    armature: bool
    joints: Iterable[str] | None
    engine: EngineName


class _ToolMass:
    """`Arm`'s tool-mass methods; they read the Arm's attributes declared here."""

    joint_names: tuple[str, ...]
    _floor: float
    engine: Callable[[EngineName], Engine]  # the Arm's method

    def _mobility(self, q: ArrayLike, options: ToolMassOptions) -> tuple[Array, Array]:
        """J of the free joints and M_ff^-1 J_f^T from one engine (the options checked)."""
        check_options(options, ToolMassOptions)
        eng = self.engine(options.get("engine", "mujoco"))
        free = check_joint_subset("joints", options.get("joints"), self.joint_names)
        return eng.tool_mobility(q, check_flag("armature", options.get("armature", True)), free)

    def operational_inertia(
        self,
        q: ArrayLike,
        **options: Unpack[ToolMassOptions],
    ) -> Array:
        """Operational-space inertia Lambda = (J M^-1 J^T)^-1 at the tool, shape (6, 6).

        Rows and axes as [`jacobian`][redundancy.arm.Arm.jacobian]: linear block [kg], angular block
        [kg m^2].

        Args:
            q: Pose [rad or m].
            **options: ``armature``, ``joints`` and ``engine``, as
                [`ToolMassOptions`][redundancy.arm_mass.ToolMassOptions] states.

        Raises:
            SingularPoseError: J M^-1 J^T is singular (J of the free joints has rank < 6, or
                moves the tool by no more than `motion_floor` along
                some direction); names the lost tool directions.
            UnknownNameError: A joint or engine name the arm does not have, or a keyword
                that is not one of the options.
            ParameterError: ``joints`` empty, repeated or not names.
        """
        J, X = self._mobility(q, options)
        return kernels.operational_inertia(J, X, atol=self._floor)

    def effective_mass(
        self,
        q: ArrayLike,
        direction: ArrayLike,
        **options: Unpack[ToolMassOptions],
    ) -> float:
        """Mass a point contact at the tool feels pushing along ``direction`` [kg].

        1 / (u^T J_v M^-1 J_v^T u), u the unit direction in world axes; ``inf`` along a
        direction the tool cannot move: |J_v^T u| below 1e-9 of |J_v| or at most
        `motion_floor` of `length` (rounding noise, as at a
        point on every free joint's axis). Defined at singular poses too.

        Args:
            q: Pose [rad or m].
            direction: Direction, world axes, any nonzero length (3,).
            **options: As [`operational_inertia`][redundancy.arm.Arm.operational_inertia].

        Raises:
            ParameterError: ``direction`` zero, non-finite or not a 3-vector.
        """
        u = check_direction("direction", direction)
        return kernels.effective_mass(*self._mobility(q, options), u, atol=self._floor)

    def effective_mass_range(
        self,
        q: ArrayLike,
        **options: Unpack[ToolMassOptions],
    ) -> linalg.EffectiveMassRange:
        """Least and greatest effective mass over all directions at ``q``, with directions.

        The extremes of the 3 x 3 linear block of Lambda^-1 (arguments as
        `operational_inertia`); the greatest is ``inf`` where the tool cannot move
        along some direction, the least too where it cannot move at all (the floor as
        `effective_mass`'s).
        """
        J, X = self._mobility(q, options)
        return kernels.effective_mass_range(J, X, atol=self._floor)

    def dynamic_manipulability(
        self,
        q: ArrayLike,
        **options: Unpack[ToolMassOptions],
    ) -> float:
        """Yoshikawa's dynamic manipulability sqrt(det(J M^-1 M^-T J^T)) at ``q``.

        Arguments as [`operational_inertia`][redundancy.arm.Arm.operational_inertia]; zero where
        fewer than six joints are free or at a singular pose [mixed units].
        """
        return float(kernels.dynamic_manipulability(self._mobility(q, options)[1]))

"""What the lab shows at one instant: the readouts' record and the tool-side quantities in it.

`LabReadouts` is what `redundancy.lab.sim.LabSim.readouts` returns; `six_sigmas` and
`velocity_ellipsoid` are the singular values and the velocity ellipsoid it is computed from.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]


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
        sigma: The six singular values of the site Jacobian, descending [m/rad, rad/rad].
        sigma_min: The smallest of them.
        manipulability: Yoshikawa's measure, the product of the singular values.
        lost: Tool directions (columns of U) whose singular value is below `LOST_SIGMA`, shape (6,
            k): translation rows first, then rotation.
        velocity_axes: Principal axes of the tool's translational velocity ellipsoid (left
            singular vectors of J's position block), columns, shape (3, 3).
        velocity_semi_axes: Its semi-axes, the singular values of J's position block
            [m/s per rad/s], shape (3,).
        tool_position: The tool site's position [m].
        contact_pairs: Geom pairs in self-contact (``"link2 / link4"``), in pair-set order.
        contact_bodies: Bodies carrying a geom in self-contact.
        contact_points: Contact positions, world frame, shape (n, 3) [m].
        contact_pair_points: The first contact position of each pair in ``contact_pairs``,
            shape (len(contact_pairs), 3) [m].
        watch_joint: Name of the joint whose speed is watched (the last one: j7 for arm7).
        watch_speed: Its speed [rad/s].
        watch_peak: Its largest |speed| over the last `PEAK_WINDOW` [rad/s].
        watch_torque: The torque its motor applies, after clamping [N m].
        watch_limit: Its motor's torque limit [N m].
        contact_mass: Effective mass at the tool along its direction of motion, with the simulated
            armature: what a contact in the tool's path would feel (`redundancy.Arm.effective_mass`)
            [kg]; NaN while the tool is at rest.
    """

    time: float
    q: Array
    qdot: Array
    targets: Array
    kp: float
    kd: float
    armature: Array
    contact_forces: bool
    sigma: Array
    sigma_min: float
    manipulability: float
    lost: Array
    velocity_axes: Array
    velocity_semi_axes: Array
    tool_position: Array
    contact_pairs: tuple[str, ...]
    contact_bodies: frozenset[str]
    contact_points: Array
    contact_pair_points: Array
    watch_joint: str
    watch_speed: float
    watch_peak: float
    watch_torque: float
    watch_limit: float
    contact_mass: float = float("nan")

    @property
    def contacts_text(self) -> str:
        """The self-contact pairs joined by commas, or ``"none"``."""
        return ", ".join(self.contact_pairs) or "none"


def six_sigmas(sigma: Array) -> Array:
    """The six singular values of a site Jacobian, zeros for the directions past its columns.

    An arm of n < 6 joints has n singular values; the 6 - n tool directions it cannot move
    along (the last columns of U) have sigma 0.
    """
    out = np.zeros(6)
    out[: len(sigma)] = sigma[:6]
    return out


def velocity_ellipsoid(J: Array) -> tuple[Array, Array]:
    """Axes (columns, a rotation) and semi-axes of the tool's translational velocity ellipsoid.

    The tool speeds reachable with joint speeds of unit norm, J_p qdot for |qdot| <= 1, fill
    the ellipsoid whose semi-axes are the singular values of J's position block J_p (its
    first three rows) along its left singular vectors.

    Args:
        J: Site Jacobian, shape (6, n), translation rows first.

    Returns:
        Axes, shape (3, 3) with determinant +1, and semi-axes [m/s per rad/s], shape (3,).
    """
    U, s, _ = np.linalg.svd(J[:3])
    if np.linalg.det(U) < 0:
        U = U.copy()
        U[:, 2] = -U[:, 2]
    return U, s


__all__ = ["LabReadouts", "six_sigmas", "velocity_ellipsoid"]

"""Pinocchio side of the two-engine core: a thin wrapper that owns its ``pinocchio.Data``.

All Pinocchio calls of the library live here. Pinocchio orders joints by its own tree
traversal; the wrapper maps them to the library's order (MuJoCo's) by joint name, so every
array it returns is in the same order as :mod:`redundancy.mujoco_engine`'s.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

Array = NDArray[np.float64]

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


def joint_kind(joint: pin.JointModel) -> str:
    """'hinge', 'slide' or Pinocchio's own short name for anything else."""
    name = joint.shortname()
    if name.startswith(("JointModelR", "JointModelRevolute")) and "UB" not in name:
        return "hinge"
    if name.startswith(("JointModelP", "JointModelPrismatic")):
        return "slide"
    return name


class PinocchioEngine:
    """Pinocchio model and data for one site frame, evaluated at joint configurations.

    Args:
        model: Model built by Pinocchio's MJCF parser.
        site: Name of the tool site (an ``OP_FRAME`` frame in Pinocchio).
        joint_names: Joint names in the library's order.
    """

    name = "pinocchio"

    def __init__(self, model: pin.Model, site: str, joint_names: Sequence[str]) -> None:
        self.model = model
        self.data = model.createData()
        self.frame_id = model.getFrameId(site)
        self.nv = model.nv
        # perm[i] is Pinocchio's index of the library's joint i (nq == nv: 1-dof joints only).
        self.perm = np.array(
            [model.joints[model.getJointId(n)].idx_v for n in joint_names], dtype=int
        )
        self._q = np.zeros(model.nq)

    def _pin_q(self, q: Array) -> Array:
        self._q[self.perm] = q
        return self._q

    def _vec(self, x: Array) -> Array:
        return np.asarray(x)[self.perm].copy()

    def site_pose(self, q: Array) -> tuple[Array, Array]:
        """Site position [m] and rotation matrix (world frame)."""
        # framesForwardKinematics = forwardKinematics + updateFramePlacements.
        pin.framesForwardKinematics(self.model, self.data, self._pin_q(q))
        oMf = self.data.oMf[self.frame_id]
        return oMf.translation.copy(), oMf.rotation.copy()

    def site_jacobian(self, q: Array) -> Array:
        """Site Jacobian, shape (6, nv): linear rows [m/rad], then angular, world axes."""
        # computeFrameJacobian runs the forward pass itself; LOCAL_WORLD_ALIGNED is MuJoCo's
        # convention: velocity of the site origin, expressed along world axes.
        J = pin.computeFrameJacobian(self.model, self.data, self._pin_q(q), self.frame_id, _LWA)
        # eigenpy returns a 6 x 1 matrix as a vector of shape (6,): keep it a matrix.
        return np.reshape(J, (6, self.nv))[:, self.perm]

    def mass_matrix(self, q: Array, armature: bool = True) -> Array:
        """Joint-space mass matrix [kg m^2], with or without armature on the diagonal."""
        # crba adds model.armature to the diagonal and fills the upper triangle only.
        M = pin.crba(self.model, self.data, self._pin_q(q))
        M = np.triu(M) + np.triu(M, 1).T
        if not armature:
            M[np.diag_indices(self.nv)] -= self.model.armature
        return M[np.ix_(self.perm, self.perm)]

    def gravity(self, q: Array) -> Array:
        """Generalised gravity force [N m]: what the motors must apply to hold ``q`` still."""
        return self._vec(pin.computeGeneralizedGravity(self.model, self.data, self._pin_q(q)))

    def jacobian_derivatives(self, q: Array) -> Array:
        """dJ/dq_k for every k, shape (nv, 6, nv), from Pinocchio's Jacobian time variation.

        With a unit velocity on one dof, dJ/dt of the LOCAL_WORLD_ALIGNED frame Jacobian is
        that dof's partial derivative: second-order kinematics, no finite differences.
        """
        out = np.zeros((self.nv, 6, self.nv))
        qp = self._pin_q(q).copy()
        v = np.zeros(self.nv)
        for i, k in enumerate(self.perm):
            v[:] = 0.0
            v[k] = 1.0
            pin.computeJointJacobiansTimeVariation(self.model, self.data, qp, v)
            # The frame's placement must be current for the frame-level variation.
            pin.updateFramePlacements(self.model, self.data)
            dJ = pin.getFrameJacobianTimeVariation(self.model, self.data, self.frame_id, _LWA)
            out[i] = np.reshape(dJ, (6, self.nv))[:, self.perm]
        return out

    def integrate(self, q: Array, dq: Array) -> Array:
        """Configuration reached from ``q`` after the displacement ``dq`` [rad or m]."""
        v = np.zeros(self.nv)
        v[self.perm] = dq
        return self._vec(pin.integrate(self.model, self._pin_q(q).copy(), v))

    def link_inertias(self, q: Array) -> tuple[Array, Array, Array]:
        """Mass [kg], centre of mass [m] and world inertia about it [kg m^2] per joint's body."""
        pin.forwardKinematics(self.model, self.data, self._pin_q(q))
        n = self.nv
        masses, coms, inertias = np.zeros(n), np.zeros((n, 3)), np.zeros((n, 3, 3))
        for i, k in enumerate(self.perm):
            jid = self._joint_id(k)
            world = self.data.oMi[jid].act(self.model.inertias[jid])
            masses[i] = world.mass
            coms[i] = world.lever
            inertias[i] = world.inertia
        return masses, coms, inertias

    def joint_axes(self, q: Array) -> tuple[Array, Array]:
        """World joint axes (unit) and anchor points [m], shape (nv, 3) each."""
        pin.computeJointJacobians(self.model, self.data, self._pin_q(q))
        axes, anchors = np.zeros((self.nv, 3)), np.zeros((self.nv, 3))
        for i, k in enumerate(self.perm):
            jid = self._joint_id(k)
            J = np.reshape(pin.getJointJacobian(self.model, self.data, jid, _LWA), (6, self.nv))[
                :, k
            ]
            kind = joint_kind(self.model.joints[jid])
            axes[i] = J[3:] if kind == "hinge" else J[:3]
            anchors[i] = self.data.oMi[jid].translation
        return axes, anchors

    def _joint_id(self, idx_v: int) -> int:
        for jid in range(1, self.model.njoints):
            if self.model.joints[jid].idx_v == idx_v:
                return jid
        raise IndexError(idx_v)

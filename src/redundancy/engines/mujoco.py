"""MuJoCo side of the two-engine core: a thin wrapper that owns its ``MjData``.

All MuJoCo calls of the library live here. Arrays come back in the library's joint order,
which is MuJoCo's own (``jnt`` order; hinge and slide joints only, so qpos, qvel and dof
orders coincide).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import mujoco
import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

#: MuJoCo joint type -> the library's name for it.
JOINT_TYPES = {
    mujoco.mjtJoint.mjJNT_HINGE: "hinge",
    mujoco.mjtJoint.mjJNT_SLIDE: "slide",
    mujoco.mjtJoint.mjJNT_BALL: "ball",
    mujoco.mjtJoint.mjJNT_FREE: "free",
}


def object_names(model: mujoco.MjModel, obj: mujoco.mjtObj, n: int | None = None) -> list[str]:
    """Names of the first ``n`` (default: all) objects of one type, ``""`` where unnamed."""
    if n is None:
        n = {
            mujoco.mjtObj.mjOBJ_JOINT: model.njnt,
            mujoco.mjtObj.mjOBJ_BODY: model.nbody,
            mujoco.mjtObj.mjOBJ_GEOM: model.ngeom,
            mujoco.mjtObj.mjOBJ_SITE: model.nsite,
            mujoco.mjtObj.mjOBJ_KEY: model.nkey,
            mujoco.mjtObj.mjOBJ_ACTUATOR: model.nu,
        }[obj]
    return [mujoco.mj_id2name(model, obj, i) or "" for i in range(n)]


class MujocoEngine:
    """MuJoCo model and data for one site, evaluated at joint configurations.

    Args:
        model: Compiled model (hinge and slide joints only; checked by the loader).
        site: Name of the tool site.
        armature: Armature per dof as M sees it: the joint's own plus what its actuators
            reflect [kg m^2].
    """

    name = "mujoco"

    def __init__(self, model: mujoco.MjModel, site: str, armature: Array) -> None:
        self.model = model
        self.data = mujoco.MjData(model)
        self.site_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, site)
        self.nv = model.nv
        # Armature as M sees it: the joint's own plus what its actuators reflect.
        self.armature = np.array(armature, dtype=float)
        # mj_jacSite and mj_jacDot write into contiguous row views of one 6 x nv array, so the
        # stacked Jacobian needs no vstack; qpos/qvel views are kept because each attribute
        # access on MjData builds a new array view.
        self._jac = np.zeros((6, model.nv))
        self._jacp, self._jacr = self._jac[:3], self._jac[3:]
        self._qpos, self._qvel = self.data.qpos, self.data.qvel
        self._M = np.zeros((model.nv, model.nv))
        self._tau = np.zeros(model.nv)

    def _kinematics(self, q: Array) -> None:
        d = self.data
        self._qpos[:] = q
        self._qvel[:] = 0.0
        # mj_kinematics gives body, geom and site poses; mj_comPos adds the com-based
        # quantities (cdof, cinert) that Jacobians, mj_crb and mj_rne read.
        mujoco.mj_kinematics(self.model, d)
        mujoco.mj_comPos(self.model, d)

    def site_pose(self, q: Array) -> tuple[Array, Array]:
        """Site position [m] and rotation matrix (world frame)."""
        self._kinematics(q)
        i = self.site_id
        return self.data.site_xpos[i].copy(), self.data.site_xmat[i].reshape(3, 3).copy()

    def site_jacobian(self, q: Array) -> Array:
        """Site Jacobian, shape (6, nv): linear rows [m/rad], then angular [rad/rad], world axes."""
        self._kinematics(q)
        mujoco.mj_jacSite(self.model, self.data, self._jacp, self._jacr, self.site_id)
        return self._jac.copy()

    def mass_matrix(self, q: Array, armature: bool = True) -> Array:
        """Joint-space mass matrix [kg m^2], with or without armature on the diagonal."""
        self._kinematics(q)
        # mj_crb fills d.M (sparse, armature included); mj_fullM makes it dense.
        mujoco.mj_crb(self.model, self.data)
        mujoco.mj_fullM(self.model, self.data, self._M)
        M = self._M.copy()
        if not armature:
            M[np.diag_indices(self.nv)] -= self.armature
        return M

    def gravity(self, q: Array) -> Array:
        """Generalised gravity force [N m]: what the motors must apply to hold ``q`` still."""
        self._kinematics(q)
        # With qvel = 0 (and cvel = 0, see jacobian_derivatives) and flg_acc = 0, RNE returns
        # the bias force, which is then gravity alone.
        mujoco.mj_rne(self.model, self.data, 0, self._tau)
        return self._tau.copy()

    def jacobian_derivatives(self, q: Array) -> Array:
        """dJ/dq_k for every k, shape (nv, 6, nv), from ``mj_jacDot`` with qvel = e_k.

        ``mj_jacDot`` returns dJ/dt = sum_k dJ/dq_k qdot_k, so a unit velocity on one dof
        gives that dof's partial derivative exactly (no finite differences).
        """
        m, d = self.model, self.data
        self._kinematics(q)
        body = m.site_bodyid[self.site_id]
        point = d.site_xpos[self.site_id].copy()
        out = np.zeros((self.nv, 6, self.nv))
        for k in range(self.nv):
            d.qvel[:] = 0.0
            d.qvel[k] = 1.0
            # mj_comVel computes cvel and cdof_dot, which mj_jacDot reads.
            mujoco.mj_comVel(m, d)
            mujoco.mj_jacDot(m, d, self._jacp, self._jacr, point, body)
            out[k, :3] = self._jacp
            out[k, 3:] = self._jacr
        # Leave no velocity behind: mj_rne (gravity) reads cvel and cdof_dot.
        d.qvel[:] = 0.0
        mujoco.mj_comVel(m, d)
        return out

    def integrate(self, q: Array, dq: Array) -> Array:
        """Configuration reached from ``q`` after the displacement ``dq`` [rad or m]."""
        out = np.array(q, dtype=float)
        mujoco.mj_integratePos(self.model, out, dq, 1.0)
        return out

    def link_inertias(self, q: Array) -> tuple[Array, Array, Array]:
        """Mass [kg], centre of mass [m] and world inertia about it [kg m^2] per dof's body.

        Bodies welded to a moving body are lumped into it, as Pinocchio does.
        """
        m, d = self.model, self.data
        self._kinematics(q)
        masses = np.zeros(self.nv)
        coms = np.zeros((self.nv, 3))
        inertias = np.zeros((self.nv, 3, 3))
        for k in range(self.nv):
            owner = m.dof_bodyid[k]
            bodies = [b for b in range(1, m.nbody) if m.body_weldid[b] == owner]
            mass = sum(m.body_mass[b] for b in bodies)
            com = (
                sum(m.body_mass[b] * d.xipos[b] for b in bodies) / mass
                if mass > 0
                else d.xpos[owner]
            )
            inertia = np.zeros((3, 3))
            for b in bodies:
                R = d.ximat[b].reshape(3, 3)
                r = d.xipos[b] - com
                inertia += R @ np.diag(m.body_inertia[b]) @ R.T
                inertia += m.body_mass[b] * (r @ r * np.eye(3) - np.outer(r, r))
            masses[k], coms[k], inertias[k] = mass, com, inertia
        return masses, coms, inertias

    def joint_axes(self, q: Array) -> tuple[Array, Array]:
        """World joint axes (unit) and anchor points [m], shape (nv, 3) each."""
        self._kinematics(q)
        return self.data.xaxis.copy(), self.data.xanchor.copy()


@contextlib.contextmanager
def captured_warnings() -> Iterator[list[str]]:
    """Collect MuJoCo's warnings instead of letting it print them and write MUJOCO_LOG.TXT."""
    messages: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda msg: messages.append(str(msg).strip()))
    try:
        yield messages
    finally:
        mujoco.set_mju_user_warning(previous)

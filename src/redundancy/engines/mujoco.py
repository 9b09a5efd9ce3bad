"""MuJoCo's side of the engine contract: one compiled model, one ``MjData`` per thread.

Every MuJoCo call for kinematics and dynamics lives here. Arrays come back in the library's
joint order, which is MuJoCo's own (``jnt`` order; hinge and slide joints only, so qpos, qvel
and dof orders coincide).
"""

from __future__ import annotations

import copy
import functools
import itertools
from collections.abc import Callable
from math import isfinite

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..checks import check_joint_vector, check_pose, pose_key
from ..kernels import cholesky_solve
from .contract import JointVectors, Stacks, check_dynamics, remove_armature
from .mujoco_warnings import captured_warnings as captured_warnings
from .threads import PerThread, run_split

Array = NDArray[np.float64]

_F64 = np.dtype(np.float64)
_ndarray = np.ndarray
# The single-pose hot path's engine calls, bound once (a module attribute lookup per call
# is measurable against a 1.5 us Jacobian).
_kinematics, _com_pos, _jac_site = mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_jacSite
# mju_mulInertVec as a 6 x 6 matrix of a body's cinert (10 values; index 10 is a zero):
# [angular; linear] momentum about the com-based frame's origin of a motion [w; v].
_INERT_INDEX = np.array(
    [
        [0, 3, 4, 10, 8, 7],
        [3, 1, 5, 8, 10, 6],
        [4, 5, 2, 7, 6, 10],
        [10, 8, 7, 9, 10, 10],
        [8, 10, 6, 10, 9, 10],
        [7, 6, 10, 10, 10, 9],
    ]
)
_INERT_SIGN = np.array(
    [
        [1, 1, 1, 0, -1, 1],
        [1, 1, 1, 1, 0, -1],
        [1, 1, 1, -1, 1, 0],
        [0, 1, -1, 1, 0, 0],
        [-1, 0, 1, 0, 1, 0],
        [1, -1, 0, 0, 0, 1],
    ],
    dtype=float,
)

#: MuJoCo joint type -> the library's name for it.
JOINT_TYPES = {
    mujoco.mjtJoint.mjJNT_HINGE: "hinge",
    mujoco.mjtJoint.mjJNT_SLIDE: "slide",
    mujoco.mjtJoint.mjJNT_BALL: "ball",
    mujoco.mjtJoint.mjJNT_FREE: "free",
}


def object_names(model: mujoco.MjModel, obj: mujoco.mjtObj) -> list[str]:
    """Names of every object of one type, ``""`` where unnamed."""
    n = {
        mujoco.mjtObj.mjOBJ_JOINT: model.njnt,
        mujoco.mjtObj.mjOBJ_BODY: model.nbody,
        mujoco.mjtObj.mjOBJ_GEOM: model.ngeom,
        mujoco.mjtObj.mjOBJ_SITE: model.nsite,
        mujoco.mjtObj.mjOBJ_KEY: model.nkey,
        mujoco.mjtObj.mjOBJ_ACTUATOR: model.nu,
    }[obj]
    return [mujoco.mj_id2name(model, obj, i) or "" for i in range(n)]


def joint_limits(model: mujoco.MjModel) -> tuple[Array, Array]:
    """Lower and upper joint limits, ``-inf``/``inf`` where a joint is unlimited [rad or m]."""
    limited = model.jnt_limited.astype(bool)
    return (
        np.where(limited, model.jnt_range[:, 0], -np.inf),
        np.where(limited, model.jnt_range[:, 1], np.inf),
    )


def model_length(model: mujoco.MjModel, site_id: int) -> float:
    """The size of the arm [m]: its moving bodies' offsets and the tool's, summed.

    Over the bodies a joint moves (an arm inside a robot: not the held rest of it). Every
    body at one point: MuJoCo's extent of the model (its geom sizes); nothing at all: 1.
    The one length the library scales by (tolerances, the solver's damping, the floor
    below which the tool counts as not moving).
    """
    moved = np.flatnonzero(model.body_weldid != 0)
    length = float(np.linalg.norm(model.body_pos[moved], axis=1).sum()) + float(
        np.linalg.norm(model.site_pos[site_id])
    )
    if length == 0:
        length = float(model.stat.extent)
    return length if length > 0 and isfinite(length) else 1.0


class _Work:
    """One thread's ``MjData`` and output buffers, with the pose its kinematics are for."""

    __slots__ = (
        "M",
        "data",
        "have_J",
        "have_M",
        "jac",
        "jacp",
        "jacr",
        "key",
        "moving",
        "qpos",
        "qvel",
        "tau",
    )

    def __init__(self, model: mujoco.MjModel) -> None:
        self.data: mujoco.MjData = mujoco.MjData(model)
        # Each attribute access on MjData builds a new array view: keep the ones used per call.
        self.qpos: Array = self.data.qpos
        self.qvel: Array = self.data.qvel
        # mj_jacSite writes into contiguous row views of one 6 x nv array (no vstack).
        self.jac: Array = np.zeros((6, model.nv))
        self.jacp: Array = self.jac[:3]
        self.jacr: Array = self.jac[3:]
        self.M = np.zeros((model.nv, model.nv))
        self.tau: Array = np.zeros(model.nv)
        self.key: list[float] | None = None  # the pose the kinematics stage holds
        self.have_M: bool = False  # M is current for that pose
        self.have_J: bool = False  # jac is current for that pose
        # qvel (and so cvel) may be nonzero: jacobian_derivatives was interrupted mid-loop.
        self.moving: bool = False

    # The three methods below are the only writers of ``key``: `load` brings the data to a
    # pose, `forget` hands it to code that writes its own states, `stop` returns from a
    # velocity to the pose loaded.
    def load(self, model: mujoco.MjModel, q: Array, key: list[float] | None) -> None:
        """Bring the data to pose ``q`` (kinematics and com-based quantities, at rest).

        ``key`` is the pose's cache key (`redundancy.checks.pose_key`), or None for a loop
        that loads poses the queries must not read. The key is cleared before the data changes
        and set only once every call has returned: an exception in between (a
        KeyboardInterrupt caught by the user) leaves no key that would let the next query
        read half-updated data.
        """
        self.key = None
        self.have_M = self.have_J = False
        self.qpos[:] = q
        # mj_kinematics gives body, geom and site poses; mj_comPos adds the com-based
        # quantities (cdof, cinert) that Jacobians, mj_crb and mj_rne read. qvel stays 0.
        _kinematics(model, self.data)
        _com_pos(model, self.data)
        if self.moving:
            self.stop(model)
        self.key = key

    def forget(self) -> None:
        """No pose is held from here: the data is about to hold other states."""
        self.key = None
        self.have_M = self.have_J = False

    def stop(self, model: mujoco.MjModel, key: list[float] | None = None) -> None:
        """Zero the velocity and what derives from it (cvel, cdof_dot: mj_rne reads them).

        ``key``: the pose whose kinematics the data still holds (a velocity changes none of
        them), held again once the velocity is zero.
        """
        self.qvel[:] = 0.0
        mujoco.mj_comVel(model, self.data)
        self.moving = False
        self.key = key


class MujocoEngine(JointVectors):
    """MuJoCo model for one tool site, evaluated at joint configurations.

    Each thread that calls gets its own ``MjData`` (created on its first call, freed with the
    thread), so an engine may be shared by threads; within a thread, the kinematics of the
    last pose are kept and queries at the same pose read them (mink's ``update(q)`` pattern).

    Args:
        model: Compiled model (hinge and slide joints only; checked by the loader).
        site: Name of the tool site.
        armature: Armature per dof as M sees it: the joint's own plus what its actuators
            reflect [kg m^2].
        damping: Viscous damping per dof: the joint's own plus what its actuators reflect
            [N m s/rad or N s/m].

    Attributes:
        length: The arm's size (`model_length`) [m].
    """

    name = "mujoco"
    #: Links without inertial data (set by the Arm): dynamic quantities refuse.
    missing_inertia: tuple[str, ...] = ()

    def __init__(
        self, model: mujoco.MjModel, site: str, armature: Array, damping: Array | None = None
    ) -> None:
        self.model = model
        self.site_id: int = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, site)
        self.site_body: int = int(model.site_bodyid[self.site_id])
        self.length: float = model_length(model, self.site_id)
        self.nv: int = model.nv
        self._armature = np.array(armature, dtype=float)
        self._damping = np.array(model.dof_damping if damping is None else damping, dtype=float)
        self._limits = joint_limits(model)
        self.joint_names: tuple[str, ...] = tuple(object_names(model, mujoco.mjtObj.mjOBJ_JOINT))
        self._shape = (self.nv,)
        # This thread's data: get() builds it on the thread's first call.
        threads = PerThread(lambda: _Work(model))
        self._work, self._local = threads.get, threads.local
        # The IK kernels' own data per thread: their poses never pass for the checked ones.
        self._kernel_work = PerThread(lambda: _Work(model)).get

    # -- per-thread data --------------------------------------------------------------------
    def update(self, q: ArrayLike) -> _Work:
        """Validate pose ``q`` and bring this thread's data to it; return the data.

        Every single-pose query enters here (`site_jacobian` writes out the check and the
        thread lookup, then loads through the same `_Work.load`). The kinematics run once
        per pose: a query at the pose already held reads them.

        Raises:
            PoseError: ``q`` is not a real (nv,) vector of finite values (see
                `redundancy.checks.pose_key`).
        """
        q, key = pose_key(q, self.joint_names)
        w = self._work()
        if key != w.key:
            w.load(self.model, q, key)
        return w

    # -- one pose ---------------------------------------------------------------------------
    def site_pose(self, q: ArrayLike) -> tuple[Array, Array]:
        """Site position [m] and rotation matrix (world frame)."""
        d = self.update(q).data
        i = self.site_id
        return d.site_xpos[i].copy(), d.site_xmat[i].reshape(3, 3).copy()

    def site_jacobian(self, q: ArrayLike) -> Array:
        """Site Jacobian, shape (6, nv): linear rows [m/rad], then angular [rad/rad], world axes.

        Raises:
            PoseError: As `update`.
        """
        # A controller's inner loop (arm.jacobian: at most 1.5x the bare MuJoCo calls), where
        # a Python call costs as much as the pose check: update(), pose_key's fast path and
        # the thread lookup are written out here, and a new pose pays one tolist for both
        # the check and the cache key.
        try:
            w = self._local.value
        except AttributeError:
            w = self._work()
        try:
            # Size first, so a huge array is never listed; any other shape of that size
            # lists as nested lists, on which sum() raises TypeError, as it does on None.
            key = q.tolist() if q.size == self.nv and q.dtype is _F64 else None  # type: ignore[union-attr]
            plain = isfinite(sum(key))  # type: ignore[arg-type]
        except (AttributeError, TypeError):  # not an array, or not a flat float64 one
            plain = False
        if not plain:
            q, key = pose_key(q, self.joint_names)  # converts, or refuses naming the cause
        if key != w.key:
            w.load(self.model, q, key)
        elif w.have_J:
            return w.jac.copy()
        _jac_site(self.model, w.data, w.jacp, w.jacr, self.site_id)
        w.have_J = True
        return w.jac.copy()

    def mass_matrix(self, q: ArrayLike, armature: bool = True) -> Array:
        """Joint-space mass matrix [kg m^2], with or without armature on the diagonal."""
        check_dynamics(self, "mass matrix")
        w = self.update(q)
        if not w.have_M:
            # mj_crb fills d.M (sparse, armature included); mj_fullM makes it dense.
            # have_M is False while w.M is written, True once both calls returned.
            mujoco.mj_crb(self.model, w.data)
            mujoco.mj_fullM(self.model, w.data, w.M)
            w.have_M = True
        M = w.M.copy()
        if not armature:
            remove_armature(M, self._armature)
        return M

    def gravity(self, q: ArrayLike) -> Array:
        """Generalised gravity force [N m]: what the motors must apply to hold ``q`` still."""
        check_dynamics(self, "gravity")
        w = self.update(q)
        # With qvel = 0 (and cvel = 0, see jacobian_derivatives) and flg_acc = 0, RNE returns
        # the bias force, which is then gravity alone.
        mujoco.mj_rne(self.model, w.data, 0, w.tau)
        return w.tau.copy()

    def jacobian_derivatives(self, q: ArrayLike) -> Array:
        """dJ/dq_k for every k, shape (nv, 6, nv), from ``mj_jacDot`` with qvel = e_k.

        ``mj_jacDot`` returns dJ/dt = sum_k dJ/dq_k qdot_k, so a unit velocity on one dof
        gives that dof's partial derivative exactly (no finite differences).
        """
        m = self.model
        w = self.update(q)
        d = w.data
        point = d.site_xpos[self.site_id].copy()
        out = np.zeros((self.nv, 6, self.nv))
        # Until the velocity is zero again the data is not the pose's: an interrupt in the
        # loop leaves no key, and the next query zeroes the velocity (_Work.load, stop).
        # mj_jacDot writes into the Jacobian buffers below.
        key = w.key
        w.forget()
        w.moving = True
        for k in range(self.nv):
            w.qvel[:] = 0.0
            w.qvel[k] = 1.0
            # mj_comVel computes cvel and cdof_dot, which mj_jacDot reads.
            mujoco.mj_comVel(m, d)
            mujoco.mj_jacDot(m, d, w.jacp, w.jacr, point, self.site_body)
            out[k] = w.jac
        # Leave no velocity behind: mj_rne (gravity) reads cvel and cdof_dot.
        w.stop(m, key)
        return out

    def integrate(self, q: ArrayLike, dq: ArrayLike) -> Array:
        """Configuration reached from ``q`` after the displacement ``dq`` [rad or m]."""
        out = check_pose(q, self.joint_names).copy()
        mujoco.mj_integratePos(self.model, out, check_pose(dq, self.joint_names), 1.0)
        return out

    def link_inertias(self, q: ArrayLike) -> tuple[Array, Array, Array]:
        """Mass [kg], centre of mass [m] and world inertia about it [kg m^2] per dof's body.

        Bodies welded to a moving body are lumped into it, as Pinocchio does. Of several
        joints in one body, the last carries it; the others carry nothing, at their anchor.
        """
        check_dynamics(self, "link inertias")
        m = self.model
        d = self.update(q).data
        masses = np.zeros(self.nv)
        coms = np.zeros((self.nv, 3))
        inertias = np.zeros((self.nv, 3, 3))
        for k in range(self.nv):
            owner, j = m.dof_bodyid[k], m.dof_jntid[k]
            if j != m.body_jntadr[owner] + m.body_jntnum[owner] - 1:
                # A joint before its body's last (several in one body) moves the body only
                # through the ones after it, as a massless link of a chain would.
                coms[k] = d.xanchor[j]
                continue
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

    def passive_forces(self, Q: Array, V: Array) -> tuple[Array, Array]:
        """MuJoCo's passive force and its gravity compensation at poses and velocities.

        ``qfrc_passive`` (joint springs about ``springref``, damping, fluid forces, and the
        gravity compensation unless it goes to the actuators) and ``qfrc_gravcomp`` (the
        body ``gravcomp`` forces), by ``mj_fwdPosition`` and ``mj_fwdVelocity`` on a data of
        their own: what the simulation adds that neither the gravity torque nor the mass
        matrix shows.

        Args:
            Q: Poses, shape (n, nv) [rad or m] (validated by the caller).
            V: Joint velocities, shape (n, nv) [rad/s or m/s].

        Returns:
            Passive forces and gravity compensation, shape (n, nv) each [N m or N].
        """
        m = self.model
        d = mujoco.MjData(m)
        P, C = np.empty((len(Q), self.nv)), np.empty((len(Q), self.nv))
        for k, (q, v) in enumerate(zip(Q, V, strict=True)):
            d.qpos[:], d.qvel[:] = q, v
            mujoco.mj_fwdPosition(m, d)
            mujoco.mj_fwdVelocity(m, d)
            P[k], C[k] = d.qfrc_passive, d.qfrc_gravcomp
        return P, C

    def joint_axes(self, q: ArrayLike) -> tuple[Array, Array]:
        """World joint axes (unit) and anchor points [m], shape (nv, 3) each."""
        d = self.update(q).data
        return d.xaxis.copy(), d.xanchor.copy()

    # -- stacks of poses ----------------------------------------------------------------------
    def _stack_data(self) -> tuple[mujoco.MjData, Array]:
        """This thread's data and its qpos, at rest and holding no pose: a stack's go in."""
        w = self._work()
        w.forget()  # this thread's data is about to hold other poses
        if w.moving:  # an interrupted jacobian_derivatives left a velocity (mj_rne)
            w.stop(self.model)
        return w.data, w.qpos

    def evaluate(self, Q: Array, out: Stacks, threads: int = 1) -> None:
        """Fill the stacks of ``out`` for every pose of ``Q``, in place (see the contract).

        One kinematics pass per pose serves every output; ``mj_jacSite``, ``mj_fullM`` and
        ``mj_rne`` write straight into the rows of the stacks. MuJoCo releases the GIL inside
        ``mj_*``, so ``threads`` > 1 runs spans of poses in parallel, each thread on its own
        ``MjData``.
        """
        if out.M is not None or out.G is not None:
            check_dynamics(self, "mass matrix" if out.M is not None else "gravity")
        m, sid, n = self.model, self.site_id, len(Q)
        kin, com, jac = mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_jacSite
        crb, full, rne = mujoco.mj_crb, mujoco.mj_fullM, mujoco.mj_rne
        X, J, M, G = out.X, out.J, out.M, out.G
        R9 = None if out.R is None else out.R.reshape(n, 9)
        # mj_jacSite writes the linear and angular rows: per pose, two contiguous 3 x nv rows.
        Jp, Jr = (None, None) if J is None else (J[:, :3], J[:, 3:])
        wanted = [s for s in (X, R9, Jp, Jr, M, G) if s is not None]
        dyn = out.dynamics
        data = self._stack_data

        def one_stack(lo: int, hi: int) -> None:
            # J, M or gravity alone get loops with no per-pose tests or indexing: each costs
            # 3 to 8 % of a pose's 1.7 us, under the GIL the other threads' mj_* calls are
            # waiting to take back (measured on arm7).
            d, qpos = data()
            rows = zip(Q[lo:hi], *(s[lo:hi] for s in wanted), strict=True)
            if J is not None:
                for q, jp, jr in rows:
                    qpos[:] = q
                    kin(m, d)
                    com(m, d)
                    jac(m, d, jp, jr, sid)
            elif M is not None:
                for q, Mi in rows:
                    qpos[:] = q
                    kin(m, d)
                    com(m, d)
                    crb(m, d)  # d.qM, armature included; mj_fullM makes it dense
                    full(m, d, Mi)
            else:
                # With qvel = cvel = 0 and flg_acc = 0, RNE returns gravity alone.
                for q, g in rows:
                    qpos[:] = q
                    kin(m, d)
                    com(m, d)
                    rne(m, d, 0, g)

        def any_stacks(lo: int, hi: int) -> None:
            d, qpos = data()
            sx, sm = d.site_xpos, d.site_xmat
            none = itertools.repeat(None)
            rows = (none if s is None else s[lo:hi] for s in (X, R9, Jp, Jr, M, G))
            # repeat(None) stands for a stack not wanted; every other row has hi - lo rows.
            for q, x, r, jp, jr, Mi, g in zip(Q[lo:hi], *rows, strict=False):
                qpos[:] = q
                kin(m, d)
                if x is not None:
                    x[:] = sx[sid]
                if r is not None:
                    r[:] = sm[sid]
                if not dyn:
                    continue
                com(m, d)
                if jp is not None:
                    jac(m, d, jp, jr, sid)
                if Mi is not None:
                    crb(m, d)
                    full(m, d, Mi)
                if g is not None:
                    rne(m, d, 0, g)

        single = X is None and R9 is None and sum(s is not None for s in (J, M, G)) == 1
        run_split(n, threads, one_stack if single else any_stacks)
        if M is not None and not out.armature:
            remove_armature(M, self._armature)

    # -- the tool's mobility J M^-1 J^T, and a kernel for inverse kinematics ---------------
    def _factor(self, w: _Work, armature: bool) -> None:
        """Fill and factor this thread's sparse M (``d.M`` then ``qLD``) at the pose held."""
        m, d = self.model, w.data
        # mj_crb fills the sparse d.M (armature included); without armature its diagonal
        # (the last entry of each CSR row) loses it before mj_factorM's L^T D L.
        mujoco.mj_crb(m, d)
        if not armature:
            d.M[self._m_diagonal] -= self._armature
        mujoco.mj_factorM(m, d)

    @property
    def _m_diagonal(self) -> Array:
        m = self.model
        return m.M_rowadr + m.M_rownnz - 1

    def tool_mobility(
        self, q: ArrayLike, armature: bool = True, free: Array | None = None
    ) -> tuple[Array, Array]:
        """The site Jacobian of the free joints and M_ff^-1 J_f^T, the tool's mobility factors.

        With every joint free, ``mj_solveM`` solves with MuJoCo's sparse L^T D L factor of M
        (``mj_factorM`` after ``mj_crb``); with joints held, the free joints' block of the
        dense M (``mj_fullM``) is solved by Cholesky: a held joint's row and column leave M.

        Args:
            q: Pose [rad or m].
            armature: Include armature in M.
            free: Indices of the free joints, ascending (validated by the caller); None for all.

        Returns:
            J_f, shape (6, k) [m/rad; rad/rad], and M_ff^-1 J_f^T, shape (k, 6) [1/kg...].
        """
        check_dynamics(self, "M^-1 J^T (effective mass, operational inertia)")
        w = self.update(q)
        m, d = self.model, w.data
        _jac_site(m, d, w.jacp, w.jacr, self.site_id)
        w.have_J = True
        J = w.jac.copy()
        if free is None:
            self._factor(w, armature)
            X = np.empty((6, self.nv))
            mujoco.mj_solveM(m, d, X, J)  # rows of X: M^-1 times the rows of J
            return J, X.T.copy()
        M = self.mass_matrix(q, armature)[np.ix_(free, free)]
        Jf = J[:, free]
        return Jf, cholesky_solve(M, Jf.T)

    def tool_mobilities(
        self, Q: Array, armature: bool = True, free: Array | None = None, threads: int = 1
    ) -> tuple[Array, Array]:
        """`tool_mobility` over a stack of poses: (n, 6, k) and (n, k, 6) stacks.

        One kinematics pass, ``mj_jacSite``, ``mj_crb``, ``mj_factorM`` and ``mj_solveM`` per
        pose, writing into the stacks' rows, on ``threads`` threads (MuJoCo releases the GIL).
        """
        check_dynamics(self, "M^-1 J^T (effective mass, operational inertia)")
        m, sid, n, nv = self.model, self.site_id, len(Q), self.nv
        J = np.empty((n, 6, nv))
        if free is not None:
            M = np.empty((n, nv, nv))
            self.evaluate(Q, Stacks(J=J, M=M, armature=armature), threads)
            ix = np.asarray(free)
            Jf = np.ascontiguousarray(J[:, :, ix])
            return Jf, cholesky_solve(M[:, ix][:, :, ix], Jf.transpose(0, 2, 1))
        X = np.empty((n, 6, nv))
        kin, com, jac = mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_jacSite
        crb, factor, solve = mujoco.mj_crb, mujoco.mj_factorM, mujoco.mj_solveM
        diag, arm_ = self._m_diagonal, self._armature

        def span(lo: int, hi: int) -> None:
            w = self._work()
            w.forget()  # this thread's data is about to hold other poses
            d, qpos = w.data, w.qpos
            Md = d.M
            for q, Ji, Xi in zip(Q[lo:hi], J[lo:hi], X[lo:hi], strict=True):
                qpos[:] = q
                kin(m, d)
                com(m, d)
                jac(m, d, Ji[:3], Ji[3:], sid)
                crb(m, d)
                if not armature:
                    Md[diag] -= arm_
                factor(m, d)
                solve(m, d, Xi, Ji)

        run_split(n, threads, span)
        return J, X.transpose(0, 2, 1)

    def ik_kernel(self, position: Array, rotation: Array) -> Callable[[Array], tuple[Array, Array]]:
        """A function q -> (tool error e (6,), site Jacobian (6, nv)) for this thread, unchecked.

        e = [p* - p; log(R* R^T)] in world axes [m; rad], for the target (``position``,
        ``rotation``). The inverse-kinematics inner loop ([`redundancy.ik`][redundancy.ik]) calls it
        tens of times per solve, where a pose check or a NumPy call on a 3 x 3 matrix costs as much
        as the kinematics: the caller passes only finite float64 (nv,) poses. The arrays returned
        are this thread's buffers, valid until the next call; the kernel must stay in the thread
        that made it. It computes in this thread's kernel data, never the data the checked
        queries read (no pose key to clear on its path).
        """
        w = self._kernel_work()
        m, d, sid = self.model, w.data, self.site_id
        qpos, jacp, jacr, jac = w.qpos, w.jacp, w.jacr, w.jac
        x, xmat = d.site_xpos[sid], d.site_xmat[sid]
        p_t = np.array(position, dtype=np.float64)
        quat_t = np.empty(4)
        mujoco.mju_mat2Quat(quat_t, np.ascontiguousarray(rotation, dtype=np.float64).ravel())
        quat, local = np.empty(4), np.empty(3)
        e = np.empty(6)
        ep, er = e[:3], e[3:]
        kin, com, jsite, sub = _kinematics, _com_pos, _jac_site, np.subtract
        to_quat, sub_quat, rotate = mujoco.mju_mat2Quat, mujoco.mju_subQuat, mujoco.mju_mulMatVec3

        def kernel(q: Array) -> tuple[Array, Array]:
            qpos[:] = q
            kin(m, d)
            com(m, d)  # cdof, which mj_jacSite reads
            jsite(m, d, jacp, jacr, sid)
            sub(p_t, x, out=ep)
            # quat * quat(local) = quat_t: the rotation still to go, in the site's axes;
            # R local is the same vector in world axes, log(R* R^T).
            to_quat(quat, xmat)
            sub_quat(local, quat_t, quat)
            rotate(er, xmat, local)
            return e, jac

        return kernel

    # -- motion: the Coriolis matrix, the centre of mass, momentum --------------------------
    @functools.cached_property
    def _weightless(self) -> mujoco.MjModel:
        """A copy of the model without gravity, for the Coriolis matrix's biases.

        With gravity the bias of a slow velocity is gravity plus a term below its rounding
        (at |v| = 1e-9 rad/s, C v ~ 1e-18 against g ~ 10): without it the bias is C v
        alone, to rounding relative to itself. Same sizes, so each thread's ``MjData``
        serves it too. (Made once; two threads racing to make it make equal copies.)
        """
        m = copy.copy(self.model)
        m.opt.gravity[:] = 0.0
        return m

    def _coriolis_at(self, w: _Work, v: Array, C: Array, Hp: Array, Hm: Array) -> None:
        """C(q, v) into ``C`` at the pose the data holds (kinematics and ``mj_comPos`` done).

        The bias C(q, u) u of ``mj_rne`` (flg_acc = 0, no gravity) is exactly quadratic
        in u, and the Christoffel symbols of the first kind are symmetric in their last two
        indices, so column j of the Christoffel-form C(q, u) is the bilinear form B(e_j, u):
        (h(u + e_j) - h(u - e_j)) / 4. No finite-difference error; u = v / s with s = max |v_i|
        keeps every bias near the size of C (no underflow or overflow), and C(q, v) =
        s C(q, u). The
        data is left moving (``w.moving``); the caller stops it or lets the next load do it.
        """
        m, d, qvel, n = self._weightless, w.data, w.qvel, self.nv
        s = float(np.max(np.abs(v)))  # not |v|, whose square may overflow
        if s == 0.0:
            C[:] = 0.0
            return
        u = v / s
        w.forget()  # until the velocity is zero again (see _Work.stop)
        w.moving = True
        vel, rne = mujoco.mj_comVel, mujoco.mj_rne
        for j in range(n):
            qvel[:] = u
            qvel[j] += 1.0
            vel(m, d)  # cvel and cdof_dot, which mj_rne reads
            rne(m, d, 0, Hp[j])
            qvel[j] = u[j] - 1.0
            vel(m, d)
            rne(m, d, 0, Hm[j])
        np.subtract(Hp, Hm, out=Hp)
        np.multiply(Hp.T, 0.25 * s, out=C)

    def coriolis(self, q: ArrayLike, v: ArrayLike) -> Array:
        """Coriolis matrix C(q, v) in the Christoffel form, (nv, nv) [N m s/rad].

        C v is the bias minus gravity, and dM/dt = C + C^T (see `_coriolis_at`).

        Raises:
            PoseError: ``q`` or ``v`` not a finite real (nv,) vector.
        """
        check_dynamics(self, "Coriolis matrix")
        v = check_joint_vector("velocity", v, self.joint_names)
        w = self.update(q)
        n = self.nv
        C, H = np.empty((n, n)), np.empty((2, n, n))
        key = w.key
        self._coriolis_at(w, v, C, H[0], H[1])
        if w.moving:
            w.stop(self.model, key)  # mj_comVel and mj_rne leave the pose's kinematics as they were
        return C

    def coriolis_stack(self, Q: Array, V: Array, out: Array, threads: int = 1) -> None:
        """`coriolis` for every pose and velocity of validated stacks, into ``out``.

        The same calls in the same order as one pose at a time (bit-equal results); MuJoCo
        releases the GIL inside ``mj_*``, so ``threads`` > 1 runs spans of poses in parallel.
        """
        check_dynamics(self, "Coriolis matrix")
        m, n = self.model, self.nv

        def span(lo: int, hi: int) -> None:
            w = self._work()
            w.forget()  # this thread's data is about to hold other poses
            d, qpos = w.data, w.qpos
            H = np.empty((2, n, n))
            for q, v, C in zip(Q[lo:hi], V[lo:hi], out[lo:hi], strict=True):
                qpos[:] = q
                _kinematics(m, d)
                _com_pos(m, d)
                self._coriolis_at(w, v, C, H[0], H[1])
            if w.moving:
                w.stop(m)

        run_split(len(Q), threads, span)

    def com(self, q: ArrayLike) -> Array:
        """The whole model's centre of mass, world frame (3,) [m].

        ``subtree_com`` of the world body (``mj_comPos``): every body with mass, those
        welded to the world included.
        """
        check_dynamics(self, "centre of mass")
        return self.update(q).data.subtree_com[0].copy()

    def com_jacobian(self, q: ArrayLike) -> Array:
        """Jacobian of `com` with respect to the joints, (3, nv) [m/rad]."""
        check_dynamics(self, "centre of mass")
        w = self.update(q)
        J = np.empty((3, self.nv))
        # The world's subtree: bodies welded to the world are in it with zero columns.
        mujoco.mj_jacSubtreeCom(self.model, w.data, J, 0)
        return J

    def centroidal_momentum_matrix(self, q: ArrayLike) -> Array:
        """Whole-model momentum per unit joint velocity, (6, nv), world-aligned.

        Rows 0-2: linear momentum [kg m/rad] (total mass times `com_jacobian`);
        rows 3-5: angular momentum about the centre of mass [kg m^2/rad], from
        ``mj_angmomMat`` of the world body (its subtree centre of mass is the whole one).
        """
        check_dynamics(self, "centroidal momentum")
        w = self.update(q)
        m, d = self.model, w.data
        A = np.empty((6, self.nv))
        mujoco.mj_jacSubtreeCom(m, d, A[:3], 0)
        A[:3] *= m.body_subtreemass[0]
        mujoco.mj_angmomMat(m, d, A[3:], 0)
        return A

    def momentum_terms(self, q: ArrayLike, v: ArrayLike) -> tuple[Array, Array]:
        """The generalized momentum p = M v and the rate of p without actuators and contacts.

        dp/dt = tau + tau_ext + beta with beta = C^T v - g + the passive force (joint and
        tendon damping and springs, gravity compensation, fluid: ``qfrc_passive``), the
        terms a momentum observer integrates. One state load: ``mj_fwdVelocity`` gives the
        passive force and the bias C v + g at v, ``mj_rne`` of the gravity-free copy C v
        alone, and C^T v comes from `_coriolis_transpose_times_v`.

        Returns:
            p (nv,) [N m s], beta (nv,) [N m].

        Raises:
            PoseError: ``q`` or ``v`` not a finite real (nv,) vector.
        """
        check_dynamics(self, "momentum observer")
        v = check_joint_vector("velocity", v, self.joint_names)
        q = pose_key(q, self.joint_names)[0]
        w = self._work()
        m, d, n = self.model, w.data, self.nv
        # The data holds a velocity from here on: no pose key (the next pose query reloads
        # the kinematics and stops it, see _Work.load).
        w.forget()
        w.moving = True
        w.qpos[:] = q
        w.qvel[:] = v
        _kinematics(m, d)
        _com_pos(m, d)
        p, cv = np.empty(n), np.empty(n)
        mujoco.mj_crb(m, d)  # the sparse M (armature included) that mj_mulM reads
        mujoco.mj_mulM(m, d, p, v)
        # Tendon lengths and moments (mj_tendon), then cvel and cdof_dot, the tendons'
        # velocities, mj_passive and qfrc_bias = C v + g (mj_fwdVelocity).
        mujoco.mj_tendon(m, d)
        mujoco.mj_fwdVelocity(m, d)
        mujoco.mj_rne(self._weightless, d, 0, cv)  # C v
        # C^T v - g = C^T v + C v - (C v + g)
        beta = self._coriolis_transpose_times_v(d)
        beta += cv
        beta -= d.qfrc_bias
        beta += d.qfrc_passive
        return p, beta

    @functools.cached_property
    def _subtrees(self) -> Array:
        """(nv, nbody): 1 where the body is in the subtree of the dof's body."""
        m = self.model
        out = np.zeros((self.nv, m.nbody))
        for i in range(self.nv):
            top = int(m.dof_bodyid[i])
            for b in range(1, m.nbody):
                k = b
                while k > top:  # a parent's id is below its children's
                    k = int(m.body_parentid[k])
                out[i, b] = k == top
        return out

    def _coriolis_transpose_times_v(self, d: mujoco.MjData) -> Array:
        """C^T v at the data's pose and velocity (``mj_comVel`` done).

        C^T v = (1/2) d(v^T M v)/dq: for dof i, cdof_dot_i . h_i with h_i the spatial
        momentum of its body's subtree, the sum of cinert_b cvel_b (``mju_mulInertVec``
        for every body at once, as a (6, 6) matrix per body); all in MuJoCo's com-based
        frame, where cdof_dot is expressed.
        """
        inert = np.zeros((self.model.nbody, 11))  # cinert and a zero for the matrix's zeros
        inert[:, :10] = d.cinert
        h = ((inert[:, _INERT_INDEX] * _INERT_SIGN) @ d.cvel[:, :, None])[:, :, 0]
        return (d.cdof_dot * (self._subtrees @ h)).sum(axis=1)


def effective_gravity(mm: mujoco.MjModel) -> Array:
    """The gravity MuJoCo simulates [m/s^2]: ``opt.gravity``, or zero when the flag disables it."""
    if mm.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_GRAVITY:
        return np.zeros(3)
    return mm.opt.gravity.copy()


def rest_data(model: mujoco.MjModel, qpos: ArrayLike | None = None) -> mujoco.MjData:
    """MuJoCo's data at ``qpos`` (``qpos0`` by default) after ``mj_kinematics``.

    Body, inertial and site frames only: what the loader reads the rest placements of held
    bodies and of the tool site from, before any engine exists.
    """
    data = mujoco.MjData(model)
    if qpos is not None:
        data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    return data


def whole_model_quantities(
    model: mujoco.MjModel, qpos: ArrayLike, site: str
) -> tuple[Array, Array, Array, Array]:
    """Site Jacobian (6, nv), mass matrix, gravity (nv,) and site position of a whole model.

    At ``qpos``, every dof of ``model`` (no joint held): the reference an arm inside a robot is
    held to (`redundancy.model.robot.whole_robot_quantities`).
    """
    d = mujoco.MjData(model)
    d.qpos[:] = qpos
    # mj_forward with qvel = 0: kinematics, M (mj_crb) and the bias force, which is then
    # gravity alone.
    mujoco.mj_forward(model, d)
    jac = np.zeros((6, model.nv))
    sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, site)
    mujoco.mj_jacSite(model, d, jac[:3], jac[3:], sid)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, d, M)
    return jac, M, d.qfrc_bias.copy(), d.site_xpos[sid].copy()


def damped_stepper(
    r: int, n: int, weights: Array | None = None
) -> Callable[[Array, Array, float], Array]:
    """The damped least-squares step J^T (J J^T + lam W)^-1 e for (r, n) Jacobians.

    By MuJoCo's dense routines (``mju_mulMatMatT``, ``mju_addToScl``,
    ``mju_cholFactor``/``mju_cholSolve``, ``mju_mulMatTVec``): for the 6 x 7 systems of the
    inverse-kinematics loop about a third of the time of the NumPy calls
    (``np.linalg.solve``'s wrapper alone costs more than the arithmetic at this size), with
    the work arrays made once. The function returned takes J (r, n) and e (r,) C-contiguous
    float64 and lam > 0; the step it returns is its buffer, valid until its next call (the
    loop adds it to the pose at once). A stepper belongs to one thread.

    Args:
        r: Rows of J.
        n: Columns of J.
        weights: The diagonal of W (r,), None: the identity. Damping each row in its own
            unit (a position row by the arm's length squared) is the step of J and e with
            those rows divided by the length: the same step for an arm of any size.
    """
    A, x, dq = np.empty((r, r)), np.empty(r), np.empty(n)
    eye = _EYES[r] if weights is None else np.diag(np.asarray(weights, dtype=np.float64)).ravel()
    flat = A.reshape(-1)
    mul, add, factor, solve, mul_t = (
        _mul_mat_mat_t,
        _add_to_scl,
        _chol_factor,
        _chol_solve,
        _mul_mat_t_vec,
    )

    def step(J: Array, e: Array, lam: float) -> Array:
        mul(A, J, J)
        add(flat, eye, lam)
        factor(A, 0.0)
        solve(x, A, e)
        mul_t(dq, J, x)
        return dq

    return step


_chol_factor, _chol_solve = mujoco.mju_cholFactor, mujoco.mju_cholSolve
_mul_mat_mat_t, _add_to_scl, _mul_mat_t_vec = (
    mujoco.mju_mulMatMatT,
    mujoco.mju_addToScl,
    mujoco.mju_mulMatTVec,
)
#: Flattened identities for damped_stepper, by size (read only).
_EYES = {r: np.eye(r).reshape(-1) for r in range(1, 7)}

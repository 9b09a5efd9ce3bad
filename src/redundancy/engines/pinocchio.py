"""Pinocchio's side of the engine contract: one model, one ``pinocchio.Data`` per thread.

Every Pinocchio call for kinematics and dynamics lives here. Pinocchio orders joints by its own tree
traversal; the engine maps them to the library's order (MuJoCo's) by joint name, so every array it
returns is in the same order as `redundancy.engines.mujoco`'s.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from ..checks import check_joint_vector, check_pose, pose_key
from ..errors import UnknownNameError
from ..kernels import cholesky_solve
from .contract import Stacks, check_dynamics, remove_armature
from .threads import PerThread, spans

Array = NDArray[np.float64]

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


class _OpenMP:
    """Whether this process may start OpenMP threads (``rneaInParallel``).

    libgomp's thread pool does not survive ``fork``: a child whose parent had started a
    team of OpenMP threads hangs in its first parallel region of more than one thread
    (``batch.gravities(engine="pinocchio", threads=2)`` then a fork). Such a child
    computes its stacked gravity on one thread (no pool involved); a child of a process
    that never started a team, or a spawned process, keeps its threads.
    """

    team = False  # this process has run a parallel region of more than one thread
    inherited = False  # ... or its parent had, before forking this process


def _forked_child() -> None:
    _OpenMP.inherited = _OpenMP.inherited or _OpenMP.team
    _OpenMP.team = False


os.register_at_fork(after_in_child=_forked_child)


def joint_kind(joint: pin.JointModel) -> str:
    """'hinge', 'slide' or Pinocchio's own short name for anything else."""
    name = joint.shortname()
    if name.startswith(("JointModelR", "JointModelRevolute")) and "UB" not in name:
        return "hinge"
    if name.startswith(("JointModelP", "JointModelPrismatic")):
        return "slide"
    return name


def _mirror_upper(M: Array) -> None:
    """Copy the upper triangle of one matrix, or of a stack, onto its lower one, in place.

    ``crba`` fills only the upper triangle. Index assignment moves the 21 off-diagonal
    values of a 7 x 7 matrix (0.3 ms for 10 000) where ``triu(M) + triu(M, 1).T`` builds
    and adds whole matrices (7 ms).
    """
    i, j = np.triu_indices(M.shape[-1], 1)
    M[..., j, i] = M[..., i, j]


def tool_frame_id(pm: pin.Model, name: str, frame_type: str = "site") -> int | None:
    """Pinocchio's frame for the tool: an MJCF site's ``OP_FRAME``, a body's or link's ``BODY``.

    A URDF link and a fixed joint of the same name (one frame, same placement) resolve to
    the link's BODY frame; a frame of another type is taken only when it is the one frame of
    that name. None when Pinocchio has no such frame.
    """
    wanted = pin.FrameType.BODY if frame_type == "body" else pin.FrameType.OP_FRAME
    if pm.existFrame(name, wanted):
        return int(pm.getFrameId(name, wanted))
    matches = [i for i, f in enumerate(pm.frames) if f.name == name]
    return matches[0] if len(matches) == 1 else None


def frame_placements(model: pin.Model, q: Array) -> pin.Data:
    """Pinocchio's data with every frame placed at ``q`` (Pinocchio's joint order).

    What the loader compares the tool's placement in both parsers' models with, before any
    engine exists.
    """
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    return data


class _Work:
    """One thread's ``pinocchio.Data``, its configuration buffer and the pose it holds."""

    __slots__ = ("J", "data", "key", "pools", "q")

    def __init__(self, model: pin.Model) -> None:
        self.data: pin.Data = model.createData()
        self.q: Array = np.zeros(model.nq)
        self.J = np.zeros((6, model.nv))  # the site Jacobian at that pose
        self.key: list[float] | None = None  # pose of the kinematics, J and site frame held
        self.pools: dict[int, pin.ModelPool] = {}  # rneaInParallel's data, per thread count

    def forget(self) -> None:
        """No pose is held from here: the data is about to hold other states.

        With `PinocchioEngine._load`, the only writer of ``key``.
        """
        self.key = None


class PinocchioEngine:
    """Pinocchio model for one tool frame, evaluated at joint configurations.

    Each thread that calls gets its own ``pinocchio.Data`` (freed with the thread), so an
    engine may be shared by threads; within a thread, the joint Jacobians and frame
    placements of the last pose are kept and site queries at the same pose read them.

    Args:
        model: Pinocchio model (bridged by the loader).
        site: Name of the tool frame.
        joint_names: Joint names in the library's order.
        frame_type: ``"site"`` (an ``OP_FRAME`` in Pinocchio) or ``"body"`` (a ``BODY`` frame).
    """

    name = "pinocchio"
    #: Links without inertial data (set by the Arm): dynamic quantities refuse.
    missing_inertia: tuple[str, ...] = ()

    def __init__(
        self, model: pin.Model, site: str, joint_names: Sequence[str], frame_type: str = "site"
    ) -> None:
        self.model = model
        # An MJCF site is an OP_FRAME, an MJCF body or a URDF link a BODY frame; a joint or
        # another kind of frame may share the name (the loader refuses a name it cannot resolve).
        frame_id = tool_frame_id(model, site, frame_type)
        if frame_id is None:
            raise UnknownNameError(f"tool {frame_type}", site, [f.name for f in model.frames])
        self.frame_id: int = frame_id
        self.nv: int = model.nv
        # perm[i] is Pinocchio's index of the library's joint i (nq == nv: 1-dof joints only).
        self.perm: NDArray[np.intp] = np.array(
            [model.joints[model.getJointId(n)].idx_v for n in joint_names], dtype=int
        )
        self.identity: bool = bool(np.array_equal(self.perm, np.arange(len(self.perm))))
        self.joint_names: tuple[str, ...] = tuple(joint_names)
        self._joint_ids = [model.getJointId(n) for n in joint_names]
        # This thread's data; a bound method, so a query pays one call to reach it.
        self._work = PerThread(lambda: _Work(model)).get
        # The IK kernels' own data per thread: their poses never pass for the checked ones.
        self._kernel_work = PerThread(lambda: _Work(model)).get

    # -- the contract's per-joint vectors ---------------------------------------------------
    @property
    def armature(self) -> Array:
        """Armature per joint as ``crba`` adds it [kg m^2] (a copy)."""
        return self._vec(self.model.armature)

    @property
    def damping(self) -> Array:
        """Viscous damping per joint [N m s/rad or N s/m] (a copy)."""
        return self._vec(self.model.damping)

    @property
    def limits(self) -> tuple[Array, Array]:
        """Lower and upper position limits [rad or m] (copies)."""
        return self._vec(self.model.lowerPositionLimit), self._vec(self.model.upperPositionLimit)

    # -- per-thread data and joint order ----------------------------------------------------
    def _pin_q(self, w: _Work, q: Array) -> Array:
        w.q[self.perm] = q
        return w.q

    def _vec(self, x: Array) -> Array:
        return np.asarray(x)[self.perm].copy()

    def _order(self, Q: Array) -> Array:
        """A stack of poses in Pinocchio's joint order."""
        if self.identity:
            return Q
        Qp = np.empty_like(Q)
        Qp[:, self.perm] = Q
        return Qp

    def update(self, q: ArrayLike) -> _Work:
        """Validate pose ``q`` and bring this thread's joints, site frame and site J to it.

        They are computed once per pose; site queries at the pose already held read them.

        Raises:
            PoseError: As `redundancy.checks.pose_key`.
        """
        q, key = pose_key(q, self.joint_names)
        w = self._work()
        if key != w.key:
            self._load(w, q, key)
        return w

    def _load(self, w: _Work, q: Array, key: list[float]) -> None:
        """Bring this thread's data to pose ``q``: joints, site frame and site J (the one loader).

        No key while the data changes, the key only once every call returned: an exception in
        between (a KeyboardInterrupt caught by the user) leaves nothing that would let the
        next query read half-updated data.
        """
        w.key = None
        # computeFrameJacobian runs the forward kinematics (oMi) and returns the site's
        # Jacobian; LOCAL_WORLD_ALIGNED is MuJoCo's convention: velocity of the site origin,
        # along world axes. updateFramePlacement then places the site from oMi.
        J = pin.computeFrameJacobian(self.model, w.data, self._pin_q(w, q), self.frame_id, _LWA)
        # eigenpy returns a 6 x 1 matrix as a vector of shape (6,): keep it a matrix.
        w.J[:] = np.reshape(J, (6, self.nv))
        pin.updateFramePlacement(self.model, w.data, self.frame_id)
        w.key = key

    def _lend(self) -> _Work:
        """This thread's data for a computation that writes its own states (no pose held after)."""
        w = self._work()
        w.forget()
        return w

    # -- one pose ---------------------------------------------------------------------------
    def site_pose(self, q: ArrayLike) -> tuple[Array, Array]:
        """Site position [m] and rotation matrix (world frame)."""
        oMf = self.update(q).data.oMf[self.frame_id]
        return oMf.translation.copy(), oMf.rotation.copy()

    def site_jacobian(self, q: ArrayLike) -> Array:
        """Site Jacobian, shape (6, nv): linear rows [m/rad], then angular, world axes."""
        J = self.update(q).J
        return J.copy() if self.identity else J[:, self.perm]

    def mass_matrix(self, q: ArrayLike, armature: bool = True) -> Array:
        """Joint-space mass matrix [kg m^2], with or without armature on the diagonal."""
        check_dynamics(self, "mass matrix")
        q = check_pose(q, self.joint_names)
        w = self._lend()  # crba overwrites the kinematics the key stands for
        # crba adds model.armature to the diagonal and fills the upper triangle only.
        M = np.array(pin.crba(self.model, w.data, self._pin_q(w, q)))
        _mirror_upper(M)
        if not armature:
            remove_armature(M, self.model.armature)
        return M if self.identity else M[np.ix_(self.perm, self.perm)]

    def gravity(self, q: ArrayLike) -> Array:
        """Generalised gravity force [N m]: what the motors must apply to hold ``q`` still."""
        check_dynamics(self, "gravity")
        q = check_pose(q, self.joint_names)
        w = self._lend()  # the RNEA pass overwrites the kinematics the key stands for
        return self._vec(pin.computeGeneralizedGravity(self.model, w.data, self._pin_q(w, q)))

    def jacobian_derivatives(self, q: ArrayLike) -> Array:
        """dJ/dq_k for every k, shape (nv, 6, nv), from Pinocchio's Jacobian time variation.

        With a unit velocity on one dof, dJ/dt of the LOCAL_WORLD_ALIGNED frame Jacobian is
        that dof's partial derivative: second-order kinematics, no finite differences.
        """
        q = check_pose(q, self.joint_names)
        w = self._lend()
        out = np.zeros((self.nv, 6, self.nv))
        qp = self._pin_q(w, q).copy()
        v = np.zeros(self.nv)
        for i, k in enumerate(self.perm):
            v[:] = 0.0
            v[k] = 1.0
            pin.computeJointJacobiansTimeVariation(self.model, w.data, qp, v)
            # The frame's placement must be current for the frame-level variation.
            pin.updateFramePlacements(self.model, w.data)
            dJ = pin.getFrameJacobianTimeVariation(self.model, w.data, self.frame_id, _LWA)
            out[i] = np.reshape(dJ, (6, self.nv))[:, self.perm]
        return out

    def integrate(self, q: ArrayLike, dq: ArrayLike) -> Array:
        """Configuration reached from ``q`` after the displacement ``dq`` [rad or m]."""
        q, dq = check_pose(q, self.joint_names), check_pose(dq, self.joint_names)
        w = self._work()
        v = np.zeros(self.nv)
        v[self.perm] = dq
        return self._vec(pin.integrate(self.model, self._pin_q(w, q).copy(), v))

    def link_inertias(self, q: ArrayLike) -> tuple[Array, Array, Array]:
        """Mass [kg], centre of mass [m] and world inertia about it [kg m^2] per joint's body."""
        check_dynamics(self, "link inertias")
        data = self.update(q).data  # oMi, from update's forward pass
        n = self.nv
        masses, coms, inertias = np.zeros(n), np.zeros((n, 3)), np.zeros((n, 3, 3))
        for i, jid in enumerate(self._joint_ids):
            world = data.oMi[jid].act(self.model.inertias[jid])
            masses[i] = world.mass
            coms[i] = world.lever
            inertias[i] = world.inertia
        return masses, coms, inertias

    def joint_axes(self, q: ArrayLike) -> tuple[Array, Array]:
        """World joint axes (unit) and anchor points [m], shape (nv, 3) each."""
        q = check_pose(q, self.joint_names)
        w = self._lend()
        data = w.data
        # Every joint's Jacobian, not only the site's: computeJointJacobians stores them all.
        pin.computeJointJacobians(self.model, data, self._pin_q(w, q))
        axes, anchors = np.zeros((self.nv, 3)), np.zeros((self.nv, 3))
        for i, jid in enumerate(self._joint_ids):
            k = self.perm[i]
            J = np.reshape(pin.getJointJacobian(self.model, data, jid, _LWA), (6, self.nv))[:, k]
            kind = joint_kind(self.model.joints[jid])
            axes[i] = J[3:] if kind == "hinge" else J[:3]
            anchors[i] = data.oMi[jid].translation
        return axes, anchors

    # -- stacks of poses ----------------------------------------------------------------------
    def evaluate(self, Q: Array, out: Stacks, threads: int = 1) -> None:
        """Fill the stacks of ``out`` for every pose of ``Q``, in place (see the contract).

        Pinocchio's bindings hold the GIL, so the per-pose loops run in the caller's thread; gravity
        is one ``rneaInParallel`` call (RNEA with v = a = 0, the same sums as
        ``computeGeneralizedGravity``) on ``threads`` OpenMP threads (fewer on a small stack, as
        `spans` splits one; one in a process forked from one that had started OpenMP threads, whose
        pool does not survive the fork).
        """
        if out.M is not None or out.G is not None:
            check_dynamics(self, "mass matrix" if out.M is not None else "gravity")
        model, fid, nv, n = self.model, self.frame_id, self.nv, len(Q)
        X, R, J, M, G = out.X, out.R, out.J, out.M, out.G
        w = self._lend()
        data = w.data
        Qp = self._order(Q)
        if X is not None or R is not None:
            ffk, oMf = pin.framesForwardKinematics, data.oMf
            for i, q in enumerate(Qp):
                ffk(model, data, q)
                T = oMf[fid]
                if X is not None:
                    X[i] = T.translation
                if R is not None:
                    R[i] = T.rotation
        if J is not None:
            cfj = pin.computeFrameJacobian  # the forward pass and the frame's Jacobian
            if nv == 1:  # eigenpy returns a 6 x 1 matrix as a vector of shape (6,)
                for i, q in enumerate(Qp):
                    J[i, :, 0] = cfj(model, data, q, fid, _LWA)
            else:
                for i, q in enumerate(Qp):
                    J[i] = cfj(model, data, q, fid, _LWA)
            if not self.identity:
                J[:] = J[:, :, self.perm]
        if M is not None:
            crba = pin.crba
            for i, q in enumerate(Qp):
                M[i] = crba(model, data, q)
            _mirror_upper(M)  # crba fills the upper triangle (armature on the diagonal)
            if not out.armature:
                remove_armature(M, model.armature)
            if not self.identity:
                M[:] = M[:, self.perm][:, :, self.perm]
        if G is not None and n:
            # As many OpenMP threads as run_split would use: below MIN_POSES_PER_THREAD poses
            # a thread costs more than it saves, and libgomp's workers busy-wait ~5 ms after
            # each call, on CPU the caller may need.
            threads = 1 if _OpenMP.inherited else len(spans(n, threads))
            _OpenMP.team = _OpenMP.team or threads > 1
            pool = w.pools.get(threads)
            if pool is None:
                pool = w.pools[threads] = pin.ModelPool(model, threads)
            # rneaInParallel takes (nq, n) column stacks: the transpose of a C-contiguous
            # (n, nq) stack is one, without a copy; tau is written in place, into G itself
            # when the joint orders agree.
            zeros = np.zeros((nv, n), order="F")
            direct = self.identity and G.flags.c_contiguous
            tau = G.T if direct else np.zeros((nv, n), order="F")
            pin.rneaInParallel(threads, pool, Qp.T, zeros, zeros, tau)
            if not direct:
                G[:] = tau.T[:, self.perm]

    # -- motion: the Coriolis matrix, the centre of mass, momentum --------------------------
    def _pin_v(self, v: Array) -> Array:
        vp = np.empty(self.nv)
        vp[self.perm] = v
        return vp

    def coriolis(self, q: ArrayLike, v: ArrayLike) -> Array:
        """Coriolis matrix C(q, v) in the Christoffel form, (nv, nv) [N m s/rad].

        ``computeCoriolisMatrix(model, data, q, v)``, q and v in Pinocchio's joint order,
        the result put back in the library's.

        Raises:
            PoseError: ``q`` or ``v`` not a finite real (nv,) vector.
        """
        check_dynamics(self, "Coriolis matrix")
        q = check_pose(q, self.joint_names)
        v = check_joint_vector("velocity", v, self.joint_names)
        w = self._lend()  # its forward pass overwrites the kinematics the key stands for
        C = pin.computeCoriolisMatrix(self.model, w.data, self._pin_q(w, q), self._pin_v(v))
        C = np.reshape(C, (self.nv, self.nv))  # eigenpy gives a 1 x 1 matrix as (1,)
        return C.copy() if self.identity else C[np.ix_(self.perm, self.perm)]

    def coriolis_stack(self, Q: Array, V: Array, out: Array, threads: int = 1) -> None:
        """`coriolis` over validated stacks, into ``out`` (the bindings hold the GIL)."""
        check_dynamics(self, "Coriolis matrix")
        for q, v, C in zip(Q, V, out, strict=True):
            C[:] = self.coriolis(q, v)

    def _fixed_inertia(self) -> pin.Inertia:
        """What is welded to the universe (a fixed base link, held joints' bodies).

        ``centerOfMass``, ``jacobianCenterOfMass`` and ``computeCentroidalMap`` sum joints
        1 and up: the universe's own inertia, where the parsers and ``buildReducedModel``
        put such bodies, is left out of them.
        """
        return self.model.inertias[0]

    def _subtree_com(self, q: Array) -> tuple[Array, float, Array, float]:
        """Centre of mass and mass of the moving bodies (joints 1 and up), and the whole's."""
        w = self._lend()
        com = np.array(pin.centerOfMass(self.model, w.data, self._pin_q(w, q)))
        moving = float(w.data.mass[0])
        fixed = self._fixed_inertia()
        total = moving + fixed.mass
        whole = (moving * com + fixed.mass * np.asarray(fixed.lever)) / total
        return com, moving, whole, total

    def com(self, q: ArrayLike) -> Array:
        """The whole model's centre of mass, world frame (3,) [m], fixed bodies included."""
        check_dynamics(self, "centre of mass")
        return self._subtree_com(check_pose(q, self.joint_names))[2]

    def com_jacobian(self, q: ArrayLike) -> Array:
        """Jacobian of `com`, (3, nv) [m/rad].

        ``jacobianCenterOfMass`` is the moving bodies' centre of mass; the fixed mass does
        not move, so the whole's is that times moving mass / total mass.
        """
        check_dynamics(self, "centre of mass")
        q = check_pose(q, self.joint_names)
        w = self._lend()
        J = pin.jacobianCenterOfMass(self.model, w.data, self._pin_q(w, q))
        J = np.reshape(J, (3, self.nv)) * (
            w.data.mass[0] / (w.data.mass[0] + self._fixed_inertia().mass)
        )
        return J if self.identity else J[:, self.perm]

    def centroidal_momentum_matrix(self, q: ArrayLike) -> Array:
        """Whole-model momentum per unit joint velocity, (6, nv), world-aligned.

        ``computeCentroidalMap`` gives the moving bodies' momentum with the angular part
        about their own centre of mass c_m; about the whole's c (fixed mass included, which
        has no momentum) the angular rows gain (c_m - c) x (linear rows).
        """
        check_dynamics(self, "centroidal momentum")
        q = check_pose(q, self.joint_names)
        w = self._lend()
        A = np.array(
            np.reshape(
                pin.computeCentroidalMap(self.model, w.data, self._pin_q(w, q)), (6, self.nv)
            )
        )
        c_m, moving = np.array(w.data.com[0]), float(w.data.mass[0])
        fixed = self._fixed_inertia()
        c = (moving * c_m + fixed.mass * np.asarray(fixed.lever)) / (moving + fixed.mass)
        A[3:] += np.cross(c_m - c, A[:3], axis=0)
        return A if self.identity else A[:, self.perm]

    # -- the tool's mobility J M^-1 J^T, and a kernel for inverse kinematics ---------------
    def _inverse_mass(self, w: _Work, q_pin: Array) -> Array:
        """M^-1 with armature, in the library's joint order, from ``computeMinverse``."""
        # computeMinverse: the articulated-body extension of ABA (armature included), which
        # fills the upper triangle of data.Minv; its forward pass recomputes the joint
        # placements at the same q (the caller's), so the site frame and J the work holds
        # stay valid.
        Minv = np.array(pin.computeMinverse(self.model, w.data, q_pin))
        _mirror_upper(Minv)
        return Minv if self.identity else Minv[np.ix_(self.perm, self.perm)]

    def tool_mobility(
        self, q: ArrayLike, armature: bool = True, free: Array | None = None
    ) -> tuple[Array, Array]:
        """The site Jacobian of the free joints and M_ff^-1 J_f^T (see the MuJoCo engine's).

        With every joint free and armature, M^-1 comes from ``computeMinverse``; otherwise
        the free joints' block of ``crba``'s M (armature removed if asked) is solved by
        Cholesky.

        Returns:
            J_f, shape (6, k) [m/rad; rad/rad], and M_ff^-1 J_f^T, shape (k, 6).
        """
        check_dynamics(self, "M^-1 J^T (effective mass, operational inertia)")
        q = check_pose(q, self.joint_names)
        J = self.site_jacobian(q)
        if free is None and armature:
            w = self._work()
            qp = np.empty(self.nv)
            qp[self.perm] = q  # not w.q: integrate() writes it without moving the key
            return J, self._inverse_mass(w, qp) @ J.T
        M = self.mass_matrix(q, armature)
        ix = np.arange(self.nv) if free is None else np.asarray(free)
        Jf = J[:, ix]
        return Jf, cholesky_solve(M[np.ix_(ix, ix)], Jf.T)

    def tool_mobilities(
        self, Q: Array, armature: bool = True, free: Array | None = None, threads: int = 1
    ) -> tuple[Array, Array]:
        """`tool_mobility` over a stack: (n, 6, k) and (n, k, 6) stacks.

        Pinocchio's bindings hold the GIL: the loop runs in the caller's thread
        (``threads`` is accepted for the contract's sake).
        """
        check_dynamics(self, "M^-1 J^T (effective mass, operational inertia)")
        n, nv = len(Q), self.nv
        J = np.empty((n, 6, nv))
        if free is None and armature:
            w = self._lend()
            Minv = np.empty((n, nv, nv))
            cfj, minv = pin.computeFrameJacobian, pin.computeMinverse
            model, data, fid = self.model, w.data, self.frame_id
            for i, q in enumerate(self._order(Q)):
                J[i] = np.reshape(cfj(model, data, q, fid, _LWA), (6, nv))
                Minv[i] = minv(model, data, q)
            _mirror_upper(Minv)
            if not self.identity:
                J[:] = J[:, :, self.perm]
                Minv[:] = Minv[:, self.perm][:, :, self.perm]
            return J, Minv @ J.transpose(0, 2, 1)
        M = np.empty((n, nv, nv))
        self.evaluate(Q, Stacks(J=J, M=M, armature=armature), 1)
        ix = np.arange(nv) if free is None else np.asarray(free)
        Jf = np.ascontiguousarray(J[:, :, ix])
        return Jf, cholesky_solve(M[:, ix][:, :, ix], Jf.transpose(0, 2, 1))

    def ik_kernel(self, position: Array, rotation: Array) -> Callable[[Array], tuple[Array, Array]]:
        """A function q -> (tool error e (6,), site Jacobian (6, nv)) for this thread, unchecked.

        As the MuJoCo engine's: e = [p* - p; log(R* R^T)] in world axes [m; rad], finite
        float64 (nv,) poses only, arrays valid until the next call, used in the thread that
        made it.
        """
        w = self._kernel_work()
        model, data, fid, nv = self.model, w.data, self.frame_id, self.nv
        cfj, place, log3 = pin.computeFrameJacobian, pin.updateFramePlacement, pin.log3
        perm, identity = self.perm, self.identity
        p_t = np.array(position, dtype=np.float64)
        R_t = np.array(rotation, dtype=np.float64)
        e = np.empty(6)

        def kernel(q: Array) -> tuple[Array, Array]:
            J = np.reshape(cfj(model, data, self._pin_q(w, q), fid, _LWA), (6, nv))
            oMf = place(model, data, fid)
            e[:3] = p_t - oMf.translation
            e[3:] = log3(R_t @ oMf.rotation.T)
            return e, (J if identity else J[:, perm])

        return kernel

"""Drake's side of the engine contract: one ``MultibodyPlant``, one ``Context`` per thread.

Every pydrake call for kinematics and dynamics lives here; the plant is built from the user's file
by Drake's own parser (`redundancy.model.drake_loading`). The plant is the *whole* robot: the held
joints are set to their rest values in every context and never move, and the engine reads the
arm's columns (and rows) out of Drake's full-size results, in the library's joint order. A held
body keeps its mass where the rest configuration puts it, so these are the quantities of the arm
with the rest of the robot still, as MuJoCo's reduced model and Pinocchio's locked one give them.

Drake's conventions, turned into the library's here: a spatial vector is angular first (the
library's linear rows come first); ``CalcGravityGeneralizedForces`` is the force gravity applies
(the library's gravity is what the motors must apply, its negative); the armature is the joint
actuators' reflected inertia (rotor inertia x gear ratio^2) that ``CalcMassMatrix`` adds to M's
diagonal. Two quantities Drake has no call for are computed from calls it has, exactly:
the Coriolis matrix from ``CalcBiasTerm`` (C(q, v) v, polarized: it is quadratic in v) and
dJ/dq from the Jacobian of the plant in automatic differentiation (``ToAutoDiffXd``).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydrake.autodiffutils import ExtractGradient, InitializeAutoDiff
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import Frame, JacobianWrtVariable, Joint

from ..checks import check_joint_vector, check_pose, pose_key
from ..kernels import cholesky_solve, rotation_vector
from .contract import JointVectors, Stacks, check_dynamics, remove_armature
from .threads import PerThread

Array = NDArray[np.float64]

_KV = JacobianWrtVariable.kV  # Jacobians with respect to v (q-dot for 1-dof joints)
_ORIGIN = np.zeros(3)


def joint_kind(joint: Joint) -> str:
    """``"hinge"``, ``"slide"`` or Drake's own type name for anything else."""
    return {"revolute": "hinge", "prismatic": "slide"}.get(joint.type_name(), joint.type_name())


class _Work:
    """One thread's context, its full position vector and the arm pose it holds."""

    __slots__ = ("context", "key", "q")

    def __init__(
        self, plant: MultibodyPlant, rest: Array, inertias: Sequence[tuple[Any, Any]] = ()
    ) -> None:
        self.context = plant.CreateDefaultContext()
        for body, inertia in inertias:  # bridged inertias live in the context's parameters
            body.SetSpatialInertiaInBodyFrame(self.context, inertia)
        self.q: Array = rest.copy()  # the whole robot's positions: held values, then the arm's
        plant.SetPositions(self.context, self.q)
        self.key: list[float] | None = None

    def forget(self) -> None:
        """No pose is held from here: the context is about to hold other states.

        With `DrakeEngine._load`, the only writer of ``key``.
        """
        self.key = None


class DrakeEngine(JointVectors):
    """Drake's plant of the whole robot for one tool frame, evaluated at arm configurations.

    Each thread that calls gets its own ``Context`` (freed with the thread); within a thread,
    the last pose's positions stay set and Drake's own cache serves repeated queries.

    Args:
        plant: The finalized plant of the whole robot (`redundancy.model.drake_loading`).
        tool: The tool frame (a body frame, or a frame added at an MJCF site's placement).
        joints: The arm's joints in the library's order (1-dof revolute or prismatic).
        rest: The whole robot's positions with the held joints at their rest values
            (Drake's order) [rad, m, quaternion components].
        damping: Viscous damping per arm joint as the library reads it [N m s/rad or N s/m].
        limits: Lower and upper limits per arm joint [rad or m].
        inertias: Bridged (body, spatial inertia) pairs, set in every context.
    """

    name = "drake"
    #: Links without inertial data (set by the Arm): dynamic quantities refuse.
    missing_inertia: tuple[str, ...] = ()

    def __init__(
        self,
        plant: MultibodyPlant,
        tool: Frame,
        joints: Sequence[Joint],
        rest: Array,
        damping: Array,
        limits: tuple[Array, Array],
        inertias: Sequence[tuple[Any, Any]] = (),
    ) -> None:
        self.plant = plant
        self.inertias = tuple(inertias)
        self.tool = tool
        self.world = plant.world_frame()
        self.joints = tuple(joints)
        self.joint_names: tuple[str, ...] = tuple(j.name() for j in joints)
        self.nv: int = len(joints)
        #: Positions and velocities of the arm's joints in the plant's vectors.
        self.qi = np.array([j.position_start() for j in joints], dtype=int)
        self.vi = np.array([j.velocity_start() for j in joints], dtype=int)
        self.rest = np.array(rest, dtype=float)
        #: The arm is the whole plant, in Drake's order (no held joints to set or skip).
        self.identity: bool = bool(
            len(self.rest) == self.nv == plant.num_velocities()
            and np.array_equal(self.qi, np.arange(self.nv))
            and np.array_equal(self.vi, np.arange(self.nv))
        )
        self._damping = np.array(damping, dtype=float)
        self._limits = (np.array(limits[0], dtype=float), np.array(limits[1], dtype=float))
        reflected = np.zeros(plant.num_velocities())
        for a in plant.GetJointActuatorIndices():
            actuator = plant.get_joint_actuator(a)
            reflected[actuator.joint().velocity_start()] += actuator.default_reflected_inertia()
        self._armature = reflected[self.vi]
        self._work = PerThread(lambda: _Work(plant, self.rest, self.inertias)).get
        # The IK kernels' own contexts per thread: their poses never pass for the checked ones.
        self._kernel_work = PerThread(lambda: _Work(plant, self.rest, self.inertias)).get

    # -- per-thread context -----------------------------------------------------------------
    def update(self, q: ArrayLike) -> _Work:
        """Validate pose ``q`` and set this thread's context to it (once per pose).

        Raises:
            PoseError: As `redundancy.checks.pose_key`.
        """
        q, key = pose_key(q, self.joint_names)
        w = self._work()
        if key != w.key:
            self._load(w, q, key)
        return w

    def _load(self, w: _Work, q: Array, key: list[float] | None) -> None:
        w.key = None  # no key while the context changes
        w.q[self.qi] = q
        self.plant.SetPositions(w.context, w.q)
        w.key = key

    def _lend(self) -> _Work:
        """This thread's context for a computation that writes its own states."""
        w = self._work()
        w.forget()
        return w

    def _jacobian(self, context: object) -> Array:
        """The tool's Jacobian (6, nv), linear rows first, the arm's columns."""
        J = self.plant.CalcJacobianSpatialVelocity(
            context, _KV, self.tool, _ORIGIN, self.world, self.world
        )
        return np.concatenate((J[3:, self.vi], J[:3, self.vi]))

    # -- one pose ---------------------------------------------------------------------------
    def site_pose(self, q: ArrayLike) -> tuple[Array, Array]:
        """Tool position [m] and rotation matrix (world frame)."""
        X = self.tool.CalcPoseInWorld(self.update(q).context)
        return np.array(X.translation()), np.array(X.rotation().matrix())

    def site_jacobian(self, q: ArrayLike) -> Array:
        """Tool Jacobian, shape (6, nv): linear rows [m/rad], then angular, world axes.

        ``CalcJacobianSpatialVelocity`` of the tool frame's origin, measured and expressed in
        the world: MuJoCo's convention once its angular rows go below the linear ones.
        """
        return self._jacobian(self.update(q).context)

    def mass_matrix(self, q: ArrayLike, armature: bool = True) -> Array:
        """Joint-space mass matrix [kg m^2], with or without armature on the diagonal.

        ``CalcMassMatrix`` of the whole robot (the joint actuators' reflected inertia on its
        diagonal), the arm's rows and columns.
        """
        check_dynamics(self, "mass matrix")
        M = self.plant.CalcMassMatrix(self.update(q).context)[np.ix_(self.vi, self.vi)]
        if not armature:
            remove_armature(M, self._armature)
        return M

    def gravity(self, q: ArrayLike) -> Array:
        """Generalised gravity force [N m]: what the motors must apply to hold ``q`` still.

        Minus ``CalcGravityGeneralizedForces`` (the force gravity applies).
        """
        check_dynamics(self, "gravity")
        return -self.plant.CalcGravityGeneralizedForces(self.update(q).context)[self.vi]

    @functools.cached_property
    def _autodiff(self) -> tuple[MultibodyPlant, Frame, Callable[[], object]]:
        """The plant in automatic differentiation, its tool frame, a context per thread.

        Made on first use (``ToAutoDiffXd`` copies the plant: ~1 ms); two threads racing to
        make it make equal copies.
        """
        plant = self.plant.ToAutoDiffXd()
        tool = plant.get_frame(self.tool.index())

        def context() -> object:
            ctx = plant.CreateDefaultContext()
            ctx.SetTimeStateAndParametersFrom(self._work().context)  # bridged inertias too
            return ctx

        return plant, tool, PerThread(context).get

    def jacobian_derivatives(self, q: ArrayLike) -> Array:
        """dJ/dq_k for every k, shape (nv, 6, nv), by automatic differentiation.

        The tool's ``CalcJacobianSpatialVelocity`` on the plant in ``AutoDiffXd``, the arm's
        positions seeded with unit derivatives: exact second-order kinematics (Drake has no
        call for the Jacobian's time variation itself; ``CalcBiasSpatialAcceleration`` gives
        only its product with v).
        """
        q = check_pose(q, self.joint_names)
        plant, tool, context = self._autodiff
        full = self.rest.copy()
        full[self.qi] = q
        seed = np.zeros((len(full), self.nv))
        seed[self.qi, np.arange(self.nv)] = 1.0
        ctx = context()
        plant.SetPositions(ctx, InitializeAutoDiff(full, seed))
        J = plant.CalcJacobianSpatialVelocity(
            ctx, _KV, tool, _ORIGIN, plant.world_frame(), plant.world_frame()
        )
        J = np.concatenate((J[3:, self.vi], J[:3, self.vi]))
        dJ = ExtractGradient(J.reshape(-1)).reshape(6, self.nv, self.nv)  # [row, col, k]
        return np.ascontiguousarray(dJ.transpose(2, 0, 1))

    def integrate(self, q: ArrayLike, dq: ArrayLike) -> Array:
        """Configuration reached from ``q`` after the displacement ``dq`` [rad or m].

        The arm's joints are 1-dof revolute and prismatic joints: positions add.
        """
        return check_pose(q, self.joint_names) + check_pose(dq, self.joint_names)

    def _composite(self, joint: Joint, context: object) -> tuple[float, Array, Array]:
        """Mass, world centre of mass and world inertia about it of what ``joint`` carries.

        The joint's child body and every body welded to it (``GetBodiesWeldedTo``).
        """
        plant = self.plant
        mass, moment, about_origin = 0.0, np.zeros(3), np.zeros((3, 3))
        for body in plant.GetBodiesWeldedTo(joint.child_body()):
            X = plant.EvalBodyPoseInWorld(context, body)
            M = body.CalcSpatialInertiaInBodyFrame(context)
            m = M.get_mass()
            if m <= 0.0:  # nothing to add (and Drake aborts shifting a massless inertia)
                continue
            R = X.rotation().matrix()
            c = X.translation() + R @ M.get_com()
            I_com = R @ M.Shift(M.get_com()).CalcRotationalInertia().CopyToFullMatrix3() @ R.T
            mass += m
            moment += m * c
            about_origin += I_com + m * (c @ c * np.eye(3) - np.outer(c, c))
        return mass, moment, about_origin

    def link_inertias(self, q: ArrayLike) -> tuple[Array, Array, Array]:
        """Mass [kg], centre of mass [m] and world inertia about it [kg m^2] per joint's body.

        A joint's body and the bodies welded to it, lumped; a joint whose body carries
        nothing (the massless body Drake's parser puts between two joints of one MJCF body)
        has its centre at the joint's anchor.
        """
        check_dynamics(self, "link inertias")
        context = self.update(q).context
        masses, coms, inertias = (
            np.zeros(self.nv),
            np.zeros((self.nv, 3)),
            np.zeros((self.nv, 3, 3)),
        )
        for i, joint in enumerate(self.joints):
            mass, moment, about_origin = self._composite(joint, context)
            if mass <= 0.0:
                coms[i] = joint.frame_on_child().CalcPoseInWorld(context).translation()
                continue
            c = moment / mass
            masses[i], coms[i] = mass, c
            inertias[i] = about_origin - mass * (c @ c * np.eye(3) - np.outer(c, c))
        return masses, coms, inertias

    def joint_axes(self, q: ArrayLike) -> tuple[Array, Array]:
        """World joint axes (unit) and anchor points [m], shape (nv, 3) each."""
        context = self.update(q).context
        axes, anchors = np.zeros((self.nv, 3)), np.zeros((self.nv, 3))
        for i, joint in enumerate(self.joints):
            F = joint.frame_on_parent().CalcPoseInWorld(context)
            axis = (
                joint.revolute_axis()
                if joint.type_name() == "revolute"
                else joint.translation_axis()
            )
            axes[i] = F.rotation().matrix() @ axis
            anchors[i] = joint.frame_on_child().CalcPoseInWorld(context).translation()
        return axes, anchors

    # -- stacks of poses ----------------------------------------------------------------------
    def evaluate(self, Q: Array, out: Stacks, threads: int = 1) -> None:
        """Fill the stacks of ``out`` for every pose of ``Q``, in place (see the contract).

        pydrake holds the GIL: the loop runs in the caller's thread (``threads`` is accepted for
        the contract's sake). One ``SetPositions`` per pose; Drake's cache shares the
        kinematics between the calls at that pose.
        """
        if out.M is not None or out.G is not None:
            check_dynamics(self, "mass matrix" if out.M is not None else "gravity")
        plant, tool, world, qi, vi = self.plant, self.tool, self.world, self.qi, self.vi
        X, R, J, M, G = out.X, out.R, out.J, out.M, out.G
        w = self._lend()
        ctx, full, set_q = w.context, w.q, plant.SetPositions
        if J is not None and X is None and R is None and M is None and G is None:
            jac = plant.CalcJacobianSpatialVelocity  # the batch.jacobians path: nothing else
            if self.identity:  # no held joints: the pose is Drake's whole position vector
                for q, Ji in zip(Q, J, strict=True):
                    set_q(ctx, q)
                    Jf = jac(ctx, _KV, tool, _ORIGIN, world, world)
                    Ji[:3], Ji[3:] = Jf[3:], Jf[:3]
                return
            for i, q in enumerate(Q):
                full[qi] = q
                set_q(ctx, full)
                Jf = jac(ctx, _KV, tool, _ORIGIN, world, world)
                J[i, :3] = Jf[3:, vi]
                J[i, 3:] = Jf[:3, vi]
            return
        ix = np.ix_(vi, vi)
        for i, q in enumerate(Q):
            full[qi] = q
            set_q(ctx, full)
            if X is not None or R is not None:
                T = tool.CalcPoseInWorld(ctx)
                if X is not None:
                    X[i] = T.translation()
                if R is not None:
                    R[i] = T.rotation().matrix()
            if J is not None:
                Jf = plant.CalcJacobianSpatialVelocity(ctx, _KV, tool, _ORIGIN, world, world)
                J[i, :3] = Jf[3:, vi]
                J[i, 3:] = Jf[:3, vi]
            if M is not None:
                M[i] = plant.CalcMassMatrix(ctx)[ix]
            if G is not None:
                G[i] = -plant.CalcGravityGeneralizedForces(ctx)[vi]
        if M is not None and not out.armature:
            remove_armature(M, self._armature)

    # -- motion: the Coriolis matrix, the centre of mass, momentum --------------------------
    def _coriolis_at(self, w: _Work, v: Array) -> Array:
        """C(q, v) at the pose the context holds, from ``CalcBiasTerm``, exactly.

        ``CalcBiasTerm`` is C(q, u) u, exactly quadratic in u, and the Christoffel symbols are
        symmetric in their last two indices, so column j of the Christoffel-form C(q, u) is
        (h(u + e_j) - h(u - e_j)) / 4 (the MuJoCo engine's polarization, with u = v / max |v|
        against overflow). The context's velocities are zero again on return.
        """
        n, vi, plant, ctx = self.nv, self.vi, self.plant, w.context
        C = np.zeros((n, n))
        s = float(np.max(np.abs(v)))
        if s == 0.0:
            return C
        u = np.zeros(plant.num_velocities())
        u[vi] = v / s
        try:
            for j in range(n):
                u[vi[j]] += 1.0
                plant.SetVelocities(ctx, u)
                hp = plant.CalcBiasTerm(ctx)[vi]
                u[vi[j]] -= 2.0
                plant.SetVelocities(ctx, u)
                hm = plant.CalcBiasTerm(ctx)[vi]
                u[vi[j]] += 1.0
                C[:, j] = (hp - hm) * (0.25 * s)
        finally:
            plant.SetVelocities(ctx, np.zeros(plant.num_velocities()))
        return C

    def coriolis(self, q: ArrayLike, v: ArrayLike) -> Array:
        """Coriolis matrix C(q, v) in the Christoffel form, (nv, nv) [N m s/rad].

        Raises:
            PoseError: ``q`` or ``v`` not a finite real (nv,) vector.
        """
        check_dynamics(self, "Coriolis matrix")
        v = check_joint_vector("velocity", v, self.joint_names)
        return self._coriolis_at(self.update(q), v)

    def coriolis_stack(self, Q: Array, V: Array, out: Array, threads: int = 1) -> None:
        """`coriolis` over validated stacks, into ``out`` (pydrake holds the GIL)."""
        check_dynamics(self, "Coriolis matrix")
        w = self._lend()
        for q, v, C in zip(Q, V, out, strict=True):
            self._load(w, q, None)
            C[:] = self._coriolis_at(w, v)

    def com(self, q: ArrayLike) -> Array:
        """The whole model's centre of mass, world frame (3,) [m].

        ``CalcCenterOfMassPositionInWorld``: every body but the world, held ones at rest and
        those welded to the world included.
        """
        check_dynamics(self, "centre of mass")
        return np.array(self.plant.CalcCenterOfMassPositionInWorld(self.update(q).context))

    def com_jacobian(self, q: ArrayLike) -> Array:
        """Jacobian of `com`, (3, nv) [m/rad]: ``CalcJacobianCenterOfMassTranslationalVelocity``."""
        check_dynamics(self, "centre of mass")
        J = self.plant.CalcJacobianCenterOfMassTranslationalVelocity(
            self.update(q).context, _KV, self.world, self.world
        )
        return np.array(J[:, self.vi])

    def centroidal_momentum_matrix(self, q: ArrayLike) -> Array:
        """Whole-model momentum per unit joint velocity, (6, nv), world-aligned.

        Column k is ``CalcSpatialMomentumInWorldAboutPoint`` about the centre of mass at the
        unit velocity of joint k (momentum is linear in v): linear rows [kg m/rad], then
        angular [kg m^2/rad]. Drake has no call for the matrix itself.
        """
        check_dynamics(self, "centroidal momentum")
        w = self.update(q)
        plant, ctx = self.plant, w.context
        c = plant.CalcCenterOfMassPositionInWorld(ctx)
        A = np.empty((6, self.nv))
        u = np.zeros(plant.num_velocities())
        try:
            for k, vk in enumerate(self.vi):
                u[vk] = 1.0
                plant.SetVelocities(ctx, u)
                h = plant.CalcSpatialMomentumInWorldAboutPoint(ctx, c)
                A[:3, k], A[3:, k] = h.translational(), h.rotational()
                u[vk] = 0.0
        finally:
            plant.SetVelocities(ctx, u * 0.0)
        return A

    # -- the tool's mobility J M^-1 J^T, and a kernel for inverse kinematics ---------------
    def tool_mobility(
        self, q: ArrayLike, armature: bool = True, free: Array | None = None
    ) -> tuple[Array, Array]:
        """The tool Jacobian of the free joints J_f (6, k) and M_ff^-1 J_f^T (k, 6).

        The free joints' block of ``CalcMassMatrix``'s M, solved by Cholesky (Drake has no
        call for M^-1 itself).
        """
        check_dynamics(self, "M^-1 J^T (effective mass, operational inertia)")
        J = self.site_jacobian(q)
        M = self.mass_matrix(q, armature)
        ix = np.arange(self.nv) if free is None else np.asarray(free)
        Jf = J[:, ix]
        return Jf, cholesky_solve(M[np.ix_(ix, ix)], Jf.T)

    def tool_mobilities(
        self, Q: Array, armature: bool = True, free: Array | None = None, threads: int = 1
    ) -> tuple[Array, Array]:
        """`tool_mobility` over a stack: (n, 6, k) and (n, k, 6) stacks."""
        check_dynamics(self, "M^-1 J^T (effective mass, operational inertia)")
        n, nv = len(Q), self.nv
        J, M = np.empty((n, 6, nv)), np.empty((n, nv, nv))
        self.evaluate(Q, Stacks(J=J, M=M, armature=armature), threads)
        ix = np.arange(nv) if free is None else np.asarray(free)
        Jf = np.ascontiguousarray(J[:, :, ix])
        return Jf, cholesky_solve(M[:, ix][:, :, ix], Jf.transpose(0, 2, 1))

    def ik_kernel(self, position: Array, rotation: Array) -> Callable[[Array], tuple[Array, Array]]:
        """A function q -> (tool error e (6,), tool Jacobian (6, nv)) for this thread, unchecked.

        As the MuJoCo engine's: e = [p* - p; log(R* R^T)] in world axes [m; rad], finite
        float64 (nv,) poses only, used in the thread that made it.
        """
        w = self._kernel_work()
        plant, tool, ctx, full, qi = self.plant, self.tool, w.context, w.q, self.qi
        p_t = np.array(position, dtype=np.float64)
        R_t = np.array(rotation, dtype=np.float64)
        e = np.empty(6)

        def kernel(q: Array) -> tuple[Array, Array]:
            full[qi] = q
            plant.SetPositions(ctx, full)
            T = tool.CalcPoseInWorld(ctx)
            e[:3] = p_t - T.translation()
            e[3:] = rotation_vector(R_t, T.rotation().matrix())
            return e, self._jacobian(ctx)

        return kernel

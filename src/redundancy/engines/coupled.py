"""Any engine's chain quantities in an arm's independent coordinates: the `CoupledEngine`.

The engine underneath (``inner``) holds the chain model: every joint the arm moves, followers
included, free (x). The `CouplingMap` gives x(q) and G = dx/dq once per pose; the quantities
follow from the chain's by the chain rule, the same for every engine:

* site pose at x(q); Jacobian J = J_x G; its derivatives dJ/dq_k = (sum_i dJ_x/dx_i G_ik) G +
  J_x dG/dq_k;
* mass matrix M = G^T M_x G (armature included as M_x has it), gravity g = G^T g_x (the
  virtual work of gravity over the chain's motion);
* Coriolis C = G^T C_x(x, G v) G + G^T M_x dG/dt, the Christoffel form of the reduced M
  (dM/dt = C + C^T);
* centre of mass and momentum at x(q), their Jacobians times G.

A third engine gets all of them by wrapping its chain engine in this class.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..checks import check_joint_vector, check_pose, pose_key
from ..kernels import cholesky_solve
from .contract import Engine, JointVectors, Stacks, check_dynamics
from .coupling import Coupled, CouplingMap

Array = NDArray[np.float64]


class CoupledEngine(JointVectors):
    """An engine of the chain model seen in the arm's independent coordinates.

    Args:
        inner: The engine of the chain model (joints: ``coupling.chain_names``).
        coupling: The chain's coupling map.

    Attributes:
        inner: The chain model's engine.
        coupling: The coupling map.
    """

    def __init__(self, inner: Engine, coupling: CouplingMap) -> None:
        self.inner = inner
        self.coupling = coupling
        self.name: str = inner.name
        self.nv: int = coupling.nq
        self.joint_names: tuple[str, ...] = coupling.names
        self.missing_inertia: tuple[str, ...] = ()
        idx = coupling.independent
        lo, hi = inner.limits
        self._limits = (lo[idx].copy(), hi[idx].copy())
        self._G0 = coupling.affine[1] if coupling.affine is not None else None
        self._x_at_0 = coupling.affine[0] if coupling.affine is not None else None
        self._plan = coupling.plan if coupling.closure is None and self._G0 is None else None
        c = self._map(coupling.q_rest)
        # Armature and damping as the reduced M and damping see them at rest: diag(G^T A G),
        # exact at every pose where the couplings are linear (G constant, G^T A G diagonal
        # when each follower has one leader).
        self._armature = np.einsum("xi,x,xi->i", c.G, inner.armature, c.G)
        self._damping = np.einsum("xi,x,xi->i", c.G, inner.damping, c.G)

    def __getattr__(self, name: str) -> Any:
        # What is not a quantity (the model, the site's id, the arm's length) is the inner
        # engine's; its quantities are all redefined below.
        if name in ("model", "site_id", "site_body", "frame_id", "length"):
            return getattr(self.inner, name)
        raise AttributeError(f"{type(self).__name__!r} has no attribute {name!r}")

    # -- the map -------------------------------------------------------------------------
    def _map(self, q: ArrayLike) -> Coupled:
        q, key = pose_key(q, self.joint_names)
        return self.coupling.at(q, key)

    def chain_pose(self, q: ArrayLike) -> Array:
        """The chain model's pose x(q) (nx,) [rad or m]."""
        return self._map(q).x.copy()

    def _check(self, quantity: str) -> None:
        check_dynamics(self, quantity)
        check_dynamics(self.inner, quantity)

    # -- one pose ------------------------------------------------------------------------
    def site_pose(self, q: ArrayLike) -> tuple[Array, Array]:
        """Site position [m] and rotation matrix at x(q)."""
        return self.inner.site_pose(self._map(q).x)

    def site_jacobian(self, q: ArrayLike) -> Array:
        """J_x(x) G, shape (6, nq)."""
        G0 = self._G0
        if G0 is not None:
            # Affine couplings (a mimic arm): x = x(0) + G0 q and J_x G0, two products around
            # the chain's J, no map object (a controller's inner loop).
            q = pose_key(q, self.joint_names)[0]
            x = G0 @ q
            x += self._x_at_0
            return self.inner.site_jacobian(x) @ G0
        if self._plan is not None:
            # Polynomial couplings: x(q) and G's one entry per row as Python floats, and J_x
            # G as J_x scaled by them summed into their columns; no map object.
            xs, scale = self._plan.chain(pose_key(q, self.joint_names)[1])
            return (self.inner.site_jacobian(np.array(xs)) * scale) @ self._plan.pattern
        c = self._map(q)
        return self.inner.site_jacobian(c.x) @ c.G

    def jacobian_derivatives(self, q: ArrayLike) -> Array:
        """dJ/dq_k = (sum_i dJ_x/dx_i G_ik) G + J_x dG/dq_k, shape (nq, 6, nq)."""
        c = self._map(q)
        dJx = self.inner.jacobian_derivatives(c.x)  # (nx, 6, nx)
        Jx = self.inner.site_jacobian(c.x)
        dG = self.coupling.derivatives(c)  # (nq, nx, nq)
        along = np.einsum("ik,irc->krc", c.G, dJx)  # (nq, 6, nx)
        return along @ c.G + np.einsum("rx,kxc->krc", Jx, dG)

    def mass_matrix(self, q: ArrayLike, armature: bool = True) -> Array:
        """G^T M_x G [kg m^2], with or without armature."""
        self._check("mass matrix")
        c = self._map(q)
        return c.G.T @ self.inner.mass_matrix(c.x, armature) @ c.G

    def gravity(self, q: ArrayLike) -> Array:
        """G^T g_x [N m or N]."""
        self._check("gravity")
        c = self._map(q)
        return c.G.T @ self.inner.gravity(c.x)

    def integrate(self, q: ArrayLike, dq: ArrayLike) -> Array:
        """``q + dq`` (hinge and slide coordinates) [rad or m]."""
        return check_pose(q, self.joint_names) + check_pose(dq, self.joint_names)

    def link_inertias(self, q: ArrayLike) -> tuple[Array, Array, Array]:
        """The independent joints' bodies' rows of the chain's `link_inertias` at x(q)."""
        m, com, inertia = self.inner.link_inertias(self._map(q).x)
        idx = self.coupling.independent
        return m[idx], com[idx], inertia[idx]

    def joint_axes(self, q: ArrayLike) -> tuple[Array, Array]:
        """The independent joints' world axes and anchors at x(q)."""
        axes, anchors = self.inner.joint_axes(self._map(q).x)
        idx = self.coupling.independent
        return axes[idx], anchors[idx]

    # -- stacks --------------------------------------------------------------------------
    def _maps(self, Q: Array) -> list[Coupled]:
        return [self.coupling.at(q, q.tolist()) for q in Q]

    def evaluate(self, Q: Array, out: Stacks, threads: int = 1) -> None:
        """The contract's stacks: the chain's at x(q) for every pose, then reduced by G."""
        if out.M is not None or out.G is not None:
            self._check("mass matrix" if out.M is not None else "gravity")
        maps = self._maps(Q)
        n, nx = len(Q), self.coupling.nx
        X = np.ascontiguousarray([c.x for c in maps]).reshape(n, nx)
        G = np.array([c.G for c in maps]).reshape(n, nx, self.nv)
        fields = [f for f in ("X", "R", "J", "M", "G") if getattr(out, f) is not None]
        inner = Stacks.empty(n, nx, fields, out.armature)
        self.inner.evaluate(X, inner, threads)
        if out.X is not None:
            out.X[:] = inner.X
        if out.R is not None:
            out.R[:] = inner.R
        if out.J is not None:
            np.matmul(inner.J, G, out=out.J)
        if out.M is not None:
            out.M[:] = G.transpose(0, 2, 1) @ inner.M @ G
        if out.G is not None:
            out.G[:] = np.einsum("nxi,nx->ni", G, inner.G)

    def tool_mobility(
        self, q: ArrayLike, armature: bool = True, free: Array | None = None
    ) -> tuple[Array, Array]:
        """J_f and M_ff^-1 J_f^T of the reduced J and M (free: indices of free joints)."""
        self._check("M^-1 J^T (effective mass, operational inertia)")
        J = self.site_jacobian(q)
        M = self.mass_matrix(q, armature)
        ix = np.arange(self.nv) if free is None else np.asarray(free)
        Jf = J[:, ix]
        return Jf, cholesky_solve(M[np.ix_(ix, ix)], Jf.T)

    def tool_mobilities(
        self, Q: Array, armature: bool = True, free: Array | None = None, threads: int = 1
    ) -> tuple[Array, Array]:
        """`tool_mobility` over a stack: (n, 6, k) and (n, k, 6)."""
        self._check("M^-1 J^T (effective mass, operational inertia)")
        n = len(Q)
        J, M = np.empty((n, 6, self.nv)), np.empty((n, self.nv, self.nv))
        self.evaluate(Q, Stacks(J=J, M=M, armature=armature), threads)
        ix = np.arange(self.nv) if free is None else np.asarray(free)
        Jf = np.ascontiguousarray(J[:, :, ix])
        return Jf, cholesky_solve(M[:, ix][:, :, ix], Jf.transpose(0, 2, 1))

    def ik_kernel(self, position: Array, rotation: Array) -> Callable[[Array], tuple[Array, Array]]:
        """The chain's IK kernel at x(q), its J times G; a loop that cannot close raises."""
        inner = self.inner.ik_kernel(position, rotation)
        at = self.coupling.at

        def kernel(q: Array) -> tuple[Array, Array]:
            c = at(q, q.tolist())
            e, Jx = inner(c.x)
            return e, Jx @ c.G

        return kernel

    def coriolis(self, q: ArrayLike, v: ArrayLike) -> Array:
        """G^T C_x(x, G v) G + G^T M_x dG/dt [N m s/rad] (Christoffel form of the reduced M)."""
        self._check("Coriolis matrix")
        v = check_joint_vector("velocity", v, self.joint_names)
        c = self._map(q)
        Cx = self.inner.coriolis(c.x, c.G @ v)
        out = c.G.T @ Cx @ c.G
        if not self.coupling.linear:
            out += c.G.T @ self.inner.mass_matrix(c.x, True) @ self.coupling.rate(c, v)
        return out

    def momentum_terms(self, q: ArrayLike, v: ArrayLike) -> tuple[Array, Array]:
        """The observer's terms: p = G^T M_x G v and beta = G^T beta_x + (dG/dt)^T M_x G v.

        With M_q = G^T M_x G and C_q = G^T (C_x G + M_x dG/dt), C_q^T v = G^T C_x^T x' +
        (dG/dt)^T M_x x' (x' = G v); the chain's gravity and passive forces reach q as G^T of
        them. Returns p (nq,) [N m s] and beta (nq,) [N m] (see the inner engine's).
        """
        self._check("momentum observer")
        v = check_joint_vector("velocity", v, self.joint_names)
        c = self._map(q)
        p_x, beta_x = self.inner.momentum_terms(c.x, c.G @ v)
        beta = c.G.T @ beta_x
        if not self.coupling.linear:
            beta += self.coupling.rate(c, v).T @ p_x
        return c.G.T @ p_x, beta

    def coriolis_stack(self, Q: Array, V: Array, out: Array, threads: int = 1) -> None:
        """`coriolis` over validated stacks, into ``out``."""
        for q, v, C in zip(Q, V, out, strict=True):
            C[:] = self.coriolis(q, v)

    def com(self, q: ArrayLike) -> Array:
        """The whole model's centre of mass at x(q) [m]."""
        self._check("centre of mass")
        return self.inner.com(self._map(q).x)

    def com_jacobian(self, q: ArrayLike) -> Array:
        """Its Jacobian, (3, nq) [m/rad]."""
        self._check("centre of mass")
        c = self._map(q)
        return self.inner.com_jacobian(c.x) @ c.G

    def centroidal_momentum_matrix(self, q: ArrayLike) -> Array:
        """Momentum per independent joint velocity, (6, nq)."""
        self._check("centroidal momentum")
        c = self._map(q)
        return self.inner.centroidal_momentum_matrix(c.x) @ c.G

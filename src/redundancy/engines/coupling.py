"""The coupling map of a chain with coupled joints: x(q), G = dx/dq and its rate, once per pose.

An arm whose chain contains coupled joints (a URDF ``<mimic>``, an MJCF joint equality, a loop
closed by ``<equality><connect>`` or ``<weld>``) is computed in its **independent** coordinates
q. Every engine holds the **chain model**: the chain's joints and the followers the couplings
move, all free (x, in MuJoCo's joint order). `CouplingMap` gives, per pose q, the chain pose
x(q) and G = dx/dq (shape (nx, nq)); `redundancy.engines.coupled.CoupledEngine` turns any
engine's chain quantities into the arm's (J = J_x G, M = G^T M_x G, g = G^T g_x...). The map is
engine-agnostic: polynomial couplings are evaluated here in closed form, and a loop's
constraint rows come from a `Closure` (MuJoCo's own equality rows,
`redundancy.engines.mujoco_closure`).

* **Polynomial couplings** (no loop): follower = ref_f + c0 + c1 t + ... + c4 t^4 with
  t = leader - ref_l (MuJoCo's joint equality; a URDF mimic is c0 = offset, c1 =
  multiplier), evaluated leader before follower. G, its rate and its derivatives exactly.
* **Loops**: the dependent joints solve h(x) = 0 (every constraint row: loop closures and
  joint equalities) by Newton's method on the constraint, from the rest pose along a path of
  short steps (so the assembly mode of the rest pose is kept), to 1e-12 or better;
  G_D = -H_D^+ H_I. The rate of G: H G = 0 gives H_D dG_D/dt = -(dH/dt) G, dH/dt the
  constraint Jacobian's derivative along dx/dt = G v (a central difference of H, 1e-10
  relative).

The maps of recent poses are kept (`CACHE_SIZE`), so the engines' quantities at one pose share
one solve; each thread solves with its own closure data.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from ..errors import PoseError
from ..kernels import SMALL_SOLVE, small_cholesky_solve

Array = NDArray[np.float64]

#: Largest constraint residual accepted as closed [m or rad].
CLOSURE_TOL = 1e-12
#: Largest step of the independent joints between two Newton solves on the way from rest
#: [rad or m]: short enough that a solve starts inside its basin.
PATH_STEP = 0.2
#: Newton iterations per solve, at most.
NEWTON_ITERATIONS = 30
#: How closely a loop is closed at the path's intermediate poses [m or rad]: far tighter
#: than a step's prediction error (PATH_STEP^2 times the curvature), so the path keeps its
#: branch; only the end pose is closed to `CLOSURE_TOL`.
PATH_CLOSURE = 1e-9
#: Poses whose maps are kept.
CACHE_SIZE = 4096


@dataclass(frozen=True)
class Polynomial:
    """One joint equality: follower = ref_f + c0 + c1 t + c2 t^2 + c3 t^3 + c4 t^4.

    Attributes:
        follower: The follower's index among the chain's joints.
        leader: The leader's index (-1: none; the follower is then fixed at ref_f + c0).
        coef: c0 .. c4.
        follower_ref: The follower's reference ``qpos0`` [rad or m].
        leader_ref: The leader's reference [rad or m]; t = leader - leader_ref.
    """

    follower: int
    leader: int
    coef: tuple[float, float, float, float, float]
    follower_ref: float
    leader_ref: float

    @property
    def linear(self) -> bool:
        """True when the coupling is affine (c2 = c3 = c4 = 0)."""
        return not any(self.coef[2:])

    def value(self, leader: float) -> float:
        """The follower's value at the leader's [rad or m]."""
        c0, c1, c2, c3, c4 = self.coef
        t = leader - self.leader_ref if self.leader >= 0 else 0.0
        return self.follower_ref + c0 + t * (c1 + t * (c2 + t * (c3 + t * c4)))

    def slope(self, leader: float) -> float:
        """D follower / d leader."""
        if self.leader < 0:
            return 0.0
        _, c1, c2, c3, c4 = self.coef
        t = leader - self.leader_ref
        return c1 + t * (2 * c2 + t * (3 * c3 + t * 4 * c4))

    def curvature(self, leader: float) -> float:
        """d^2 follower / d leader^2."""
        if self.leader < 0:
            return 0.0
        _, _, c2, c3, c4 = self.coef
        t = leader - self.leader_ref
        return 2 * c2 + t * (6 * c3 + t * 12 * c4)


class Closure(Protocol):
    """The constraint rows h(x) = 0 of a chain's loops (and its joint equalities)."""

    #: The equality each row belongs to, by name (for messages).
    row_names: tuple[str, ...]

    def rows(self, x: Array) -> tuple[Array, Array]:
        """Residuals h(x) (rows,) [m or rad] and their Jacobian dh/dx (rows, nx)."""
        ...


@dataclass
class Coupled:
    """The map at one pose: the chain pose x (nx,), G (nx, nq), and the pose q (a list)."""

    pose: list[float]
    x: Array
    G: Array


class CouplingMap:
    """x(q) and G(q) for one chain with coupled joints (see the module's docstring).

    Args:
        chain_names: Every joint of the chain model, in MuJoCo's order (nx).
        independent: Indices of the arm's coordinates among them, in the arm's order (nq).
        rest: The chain pose at rest (nx,): held loop joints keep their value, and a loop's
            solve starts from it.
        polynomials: The joint equalities, each leader before its followers.
        closure: The loops' constraint rows; None: polynomial couplings only.
        dependent: Indices the closure's Newton solve moves (with a closure).
        followers: Follower joint name -> what determines it (a short text).
    """

    def __init__(
        self,
        chain_names: Sequence[str],
        independent: Sequence[int],
        rest: Array,
        polynomials: Sequence[Polynomial],
        closure: Closure | None = None,
        dependent: Sequence[int] = (),
        followers: dict[str, str] | None = None,
    ) -> None:
        self.chain_names = tuple(chain_names)
        self.independent = np.asarray(independent, dtype=np.intp)
        self.names = tuple(self.chain_names[i] for i in self.independent)
        self.nx, self.nq = len(self.chain_names), len(self.independent)
        self.rest = np.array(rest, dtype=float)
        self.q_rest = self.rest[self.independent].copy()
        self.polynomials = tuple(polynomials)
        self.closure = closure
        self.dependent = np.asarray(dependent, dtype=np.intp)
        self.followers = dict(followers or {})
        #: Affine couplings and no loop: G is one constant matrix.
        self.linear = closure is None and all(p.linear for p in self.polynomials)
        #: The polynomial couplings' one-pass evaluation (used without a closure).
        self.plan = PolynomialPlan(self.nx, self.independent, self.rest, self.polynomials)
        self._G0: Array | None = None
        #: Affine couplings: (x(0), G0), x(q) = x(0) + G0 q; None otherwise.
        self.affine: tuple[Array, Array] | None = None
        if self.linear:
            self._x_at_0, self._G0 = self.plan.at(np.zeros(self.nq))
            self._G0.flags.writeable = False
            self._x_at_0.flags.writeable = False
            self.affine = (self._x_at_0, self._G0)
        # Maps already computed, by pose: the engines' stacks over one set of poses (a
        # cross-check's, one quantity after another) solve each loop once. Bounded; a
        # pose's map never depends on what was computed before it.
        self._cache: dict[tuple[float, ...], Coupled] = {}
        self._lock = threading.Lock()
        self._rest_tangent: Array | None = None  # `_tangent_at_rest`, once

    # -- the map at a pose ---------------------------------------------------------------
    def at(self, q: Array, pose: list[float]) -> Coupled:
        """The map at pose ``q`` (finite float64 (nq,), checked by the caller; ``pose`` its list).

        Polynomial couplings are evaluated in closed form (an affine one is one product);
        a loop's maps of the last `CACHE_SIZE` poses are kept (shared by threads; each is
        read only): the engines' quantities at one pose share one solve.

        Raises:
            PoseError: A loop that cannot close at ``q`` (the message names its constraint).
        """
        if self._G0 is not None:  # one product: the J of a mimic arm is a controller's loop
            return Coupled(pose, self._x_at_0 + self._G0 @ q, self._G0)
        if self.closure is None:  # closed forms, cheaper than a cache
            xs, sc = self.plan.chain(pose)
            return Coupled(pose, np.array(xs), self.plan.pattern * np.array(sc)[:, None])
        found = self._cache.get(tuple(pose))
        if found is not None:
            return found
        x, H = self._close(q)
        out = Coupled(pose, x, self._closure_G(x, H))
        with self._lock:
            if len(self._cache) >= CACHE_SIZE:
                self._cache.pop(next(iter(self._cache)))
            self._cache[tuple(pose)] = out
        return out

    def rate(self, c: Coupled, v: Array) -> Array:
        """dG/dt at the map ``c`` along the joint velocity ``v`` (nq,), shape (nx, nq)."""
        if self.linear:
            return np.zeros((self.nx, self.nq))
        xdot = c.G @ v
        if self.closure is None:
            Gd = np.zeros((self.nx, self.nq))
            for p in self.polynomials:
                if p.leader >= 0:
                    xl = c.x[p.leader]
                    Gd[p.follower] = (
                        p.curvature(xl) * xdot[p.leader] * c.G[p.leader]
                        + p.slope(xl) * Gd[p.leader]
                    )
            return Gd
        return self._closure_rate(c, xdot)

    def derivatives(self, c: Coupled) -> Array:
        """dG/dq_k for every k, shape (nq, nx, nq)."""
        eye = np.eye(self.nq)
        return np.array([self.rate(c, eye[k]) for k in range(self.nq)])

    # -- loops ---------------------------------------------------------------------------
    def _rows(self, x: Array) -> tuple[Array, Array]:
        return self.closure.rows(x)  # type: ignore[union-attr]

    def _newton(self, x: Array, stop: float = 0.01 * CLOSURE_TOL) -> tuple[Array, Array, Array]:
        """X with its dependent joints moved until the constraint holds to ``stop``.

        Returns x, its residual and the rows' Jacobian there (``stop`` [m or rad]).
        """
        D = self.dependent
        r, H = self._rows(x)
        size = _largest(r)
        for _ in range(NEWTON_ITERATIONS):
            if size <= stop:
                break
            step = _least_squares(H[:, D], r)
            x = x.copy()
            x[D] -= step
            r_new, H_new = self._rows(x)
            size_new = _largest(r_new)
            if size_new >= size and size <= CLOSURE_TOL:
                x[D] += step  # rounding: the last step made it no better
                break
            r, H, size = r_new, H_new, size_new
        return x, r, H

    def _close(self, q: Array) -> tuple[Array, Array]:
        """The chain pose at ``q``, closed, and its rows' Jacobian H there.

        Newton solves along a path of short steps from rest; each starts from a prediction
        of the dependent joints (the tangent G at rest for the first step, the line through
        the last two closed poses after it), so that a solve takes one or two iterations.
        """
        x = self.rest.copy()
        delta = q - self.q_rest
        steps = max(1, int(np.ceil(float(np.max(np.abs(delta), initial=0.0)) / PATH_STEP)))
        r, H = np.zeros(0), np.zeros((0, self.nx))
        D, last = self.dependent, None
        for k in range(1, steps + 1):
            before = x[D].copy()
            if last is None:
                x[D] += self._tangent_at_rest() @ (delta / steps)
            else:
                x[D] += before - last
            last = before
            x[self.independent] = self.q_rest + delta * (k / steps)
            # On the way, close enough to stay on the branch; at q, to the closure's tolerance.
            x, r, H = self._newton(x) if k == steps else self._newton(x, PATH_CLOSURE)
            if not np.all(np.isfinite(r)) or np.max(np.abs(r), initial=0.0) > 1e-3:
                break  # lost on the way: reported below
        worst = int(np.argmax(np.abs(r))) if r.size else 0
        if r.size and not (np.max(np.abs(r)) <= CLOSURE_TOL):
            names = self.closure.row_names  # type: ignore[union-attr]
            raise PoseError(
                f"the loop closed by equality {names[worst]!r} cannot close at this pose "
                f"(residual {float(np.max(np.abs(r))):.3g} after Newton's method on the "
                f"constraint; closed means {CLOSURE_TOL:g} m or rad): a pose the mechanism "
                "cannot reach"
            )
        return x, H

    def _tangent_at_rest(self) -> Array:
        """dx_D/dq at rest (G's dependent rows there), computed once."""
        if self._rest_tangent is None:
            self._rest_tangent = self._closure_G(self.rest)[self.dependent]
        return self._rest_tangent

    def _closure_G(self, x: Array, H: Array | None = None) -> Array:
        """G at a closed pose: identity on the independent joints, -H_D^+ H_I on the dependent.

        ``H``: the rows' Jacobian at ``x``, when the solve that closed it has it.
        """
        if H is None:
            _, H = self._rows(x)
        G = np.zeros((self.nx, self.nq))
        G[self.independent, np.arange(self.nq)] = 1.0
        D = self.dependent
        HD = H[:, D]
        solved, _, rank, _ = np.linalg.lstsq(HD, H[:, self.independent], rcond=None)
        if rank < len(D):
            names = self.closure.row_names  # type: ignore[union-attr]
            raise PoseError(
                f"the loop closed by equality {names[0]!r} is singular at this pose: its "
                "dependent joints are not determined by the arm's (a dead point of the "
                "mechanism)"
            )
        G[D] = -solved
        return G

    def _closure_rate(self, c: Coupled, xdot: Array) -> Array:
        """dG/dt from H G = 0: H_D dG_D/dt = -(dH/dt) G, dH/dt by a central difference."""
        s = float(np.max(np.abs(xdot), initial=0.0))
        if s == 0.0:
            return np.zeros((self.nx, self.nq))
        h = 1e-5 / s
        Hp = self._rows(c.x + h * xdot)[1]
        Hm = self._rows(c.x - h * xdot)[1]
        Hdot = (Hp - Hm) / (2 * h)
        _, H = self._rows(c.x)
        Gd = np.zeros((self.nx, self.nq))
        Gd[self.dependent] = -np.linalg.lstsq(H[:, self.dependent], Hdot @ c.G, rcond=None)[0]
        return Gd


class PolynomialPlan:
    """x(q) and G(q) of polynomial couplings in one pass of scalar operations.

    Every follower has one leader (or none), so each row of G has at most one entry: in the
    column of the independent joint its chain of leaders starts from, the product of the
    slopes along it. A pose is a few Horner steps on Python floats and one product with
    that pattern (a controller's inner loop: no per-polynomial NumPy call).
    """

    def __init__(
        self, nx: int, independent: Array, rest: Array, polynomials: Sequence[Polynomial]
    ) -> None:
        self.rest = rest.tolist()
        self.independent = independent.tolist()
        self.steps = tuple(
            (p.follower, p.leader, p.follower_ref + p.coef[0], *p.coef[1:], p.leader_ref)
            for p in polynomials
        )
        column = [-1] * nx
        for k, i in enumerate(self.independent):
            column[i] = k
        for p in polynomials:
            column[p.follower] = column[p.leader] if p.leader >= 0 else -1
        self.pattern = np.zeros((nx, len(self.independent)))
        for row, k in enumerate(column):
            if k >= 0:
                self.pattern[row, k] = 1.0
        self.scale = [1.0 if k >= 0 else 0.0 for k in column]

    def at(self, q: Array) -> tuple[Array, Array]:
        """The chain pose x (nx,) [rad or m] and G (nx, nq) at ``q``."""
        xs, sc = self.chain(q.tolist())
        return np.array(xs), self.pattern * np.array(sc)[:, None]

    def chain(self, q: list[float]) -> tuple[list[float], list[float]]:
        """The chain pose at ``q`` and G's entry per row (G = `pattern` x the entries)."""
        xs = self.rest.copy()
        for i, v in zip(self.independent, q, strict=True):
            xs[i] = v
        sc = self.scale.copy()
        for f, lead, c0, c1, c2, c3, c4, ref in self.steps:
            if lead < 0:
                xs[f], sc[f] = c0, 0.0
                continue
            t = xs[lead] - ref
            xs[f] = c0 + t * (c1 + t * (c2 + t * (c3 + t * c4)))
            sc[f] = sc[lead] * (c1 + t * (2 * c2 + t * (3 * c3 + t * 4 * c4)))
        return xs, sc


def _largest(r: Array) -> float:
    """The largest |r| (0 for no rows; NaN when a value is NaN, so no test on it passes)."""
    return float(np.abs(r).max()) if r.size else 0.0


def _least_squares(A: Array, b: Array) -> Array:
    """The x minimising |A x - b|: a Newton step on the constraint's dependent joints.

    A few dependent joints (up to `kernels.SMALL_SOLVE`): the normal equations' Cholesky
    factor in Python floats, where A is well conditioned (a fraction of an SVD's cost); else,
    or for more joints, the SVD (`numpy.linalg.lstsq`). The solve's rounding only changes the
    path: every solve is judged by the residual it reaches.
    """
    if A.shape[1] <= SMALL_SOLVE:
        x = small_cholesky_solve((A.T @ A).tolist(), (A.T @ b).tolist())
        if x is not None:
            return np.array(x)
    return np.linalg.lstsq(A, b, rcond=None)[0]

"""The registry of cross-checked quantities: each declared once, here.

A `Quantity` says what one quantity is (name, shape, unit, tolerance), what it needs (a pose, a
velocity; the links' inertias or not), how its error is measured (its blocks and their sizes on the
arm) and how any engine computes it, for one pose (the `Engine` method) and for a stack of poses
(from an `Evaluation`, which shares the engine work several quantities need: one stacked
kinematics pass, one M^-1 J^T, one dJ/dq per pose). The cross-check, the audit's engine section,
`redundancy.TOLERANCES` and the guide's tolerance table read `QUANTITIES`.

Adding a quantity is one entry in `QUANTITIES` plus its method in each engine (``Engine``'s
contract, `MujocoEngine`, `PinocchioEngine`), plus its tests.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .checks import NameDict
from .engines.contract import Engine, Stacks, remove_armature
from .kernels import Scales, mobility
from .linalg import manipulability_gradient

Array = NDArray[np.float64]

#: Rows and columns of one block of a quantity's value (after the pose axis).
Index = tuple[slice, ...]
ALL: Index = ()


class Evaluation:
    """One engine's work over one stack of poses, shared by the quantities that need it.

    Args:
        engine: The engine.
        Q: Validated poses (n, nv) [rad or m].
        names: The quantities wanted (their stacked fields are filled in one pass).
        threads: Worker threads for the engine's stacked calls.
        seed: Seed of the velocities paired with the poses (`velocities`).
    """

    def __init__(
        self, engine: Engine, Q: Array, names: tuple[str, ...], threads: int, seed: int
    ) -> None:
        self.engine, self.Q, self.threads, self.seed = engine, Q, threads, seed
        self.fields = {QUANTITY[n].field for n in names} - {None}

    @functools.cached_property
    def stacks(self) -> Stacks:
        """The engine's stacked kinematics and dynamics for every field wanted (one pass)."""
        stacks = Stacks.empty(len(self.Q), self.engine.nv, sorted(self.fields))
        self.engine.evaluate(self.Q, stacks, self.threads)
        return stacks

    @functools.cached_property
    def mobilities(self) -> tuple[Array, Array]:
        """The tool's J (n, 6, nv) and M^-1 J^T (n, nv, 6), armature in, all joints free."""
        return self.engine.tool_mobilities(self.Q, True, None, self.threads)

    @functools.cached_property
    def derivatives(self) -> Array:
        """dJ/dq_k per pose (n, nv, 6, nv), pose by pose (second-order kinematics)."""
        nv = self.engine.nv
        out = np.empty((len(self.Q), nv, 6, nv))
        for i, q in enumerate(self.Q):
            out[i] = self.engine.jacobian_derivatives(q)
        return out

    @functools.cached_property
    def velocities(self) -> Array:
        """The joint velocities paired with the poses (`crosscheck_velocities`) [rad/s]."""
        return crosscheck_velocities(self.Q, self.seed)


def crosscheck_velocities(Q: Array, seed: int) -> Array:
    """The joint velocities the cross-check pairs with poses ``Q`` (n, nq), each in -1..1 rad/s.

    Drawn from ``seed`` as a function of each pose, v = sin(q A + b) with A and b drawn
    from the seed: the same pose gets the same velocity in any chunk, thread or worker, so
    a report does not depend on how the poses were split. Elementwise (no matrix product,
    whose rounding may depend on the stack's size).
    """
    rng = np.random.default_rng(seed)
    nq = Q.shape[1]
    A, b = rng.standard_normal((nq, nq)), rng.uniform(-np.pi, np.pi, nq)
    phase = np.broadcast_to(b, Q.shape).copy()
    for k in range(nq):
        phase += Q[:, k : k + 1] * A[k]
    return np.sin(phase)


@dataclass(frozen=True)
class Quantity:
    """One cross-checked quantity.

    Attributes:
        name: Its name in reports and ``quantities=`` arguments.
        shape: Shape of one pose's value, in words.
        unit: Its unit.
        tol: Tolerance on max |reference - other| / scale (`redundancy.model.scales`).
        method: The `Engine` method that computes it at one pose.
        stack: Its values over a stack of poses, from one engine's `Evaluation`.
        blocks: Its blocks (rows, columns) and each block's size on the arm: the error is
            the largest over the blocks, each measured against its own size.
        field: The `Stacks` field the engine's stacked pass fills for it (None: not there).
        dynamic: Needs the links' inertias.
        m_inverse: Computed through M^-1: the tolerance grows with cond(M)
            (`redundancy.analysis.crosscheck.conditioned_tolerance`).
        velocity: Needs a joint velocity besides the pose.
        one_scale: Its blocks differ only in unit: each block is divided by its size and
            the whole is measured against one scale, the largest so divided (see
            `redundancy.analysis.crosscheck.quantity_errors`).
    """

    name: str
    shape: str
    unit: str
    tol: float
    method: str
    stack: Callable[[Evaluation], Array]
    blocks: Callable[[Scales], tuple[tuple[Index, float], ...]]
    field: str | None = None
    dynamic: bool = False
    m_inverse: bool = False
    velocity: bool = False
    one_scale: bool = False

    @property
    def batched(self) -> bool:
        """Computed by the engines' stacked pass (one kinematics pass per pose)."""
        return self.field is not None


def _whole(size: Callable[[Scales], float]) -> Callable[[Scales], tuple[tuple[Index, float], ...]]:
    """One block, the whole value, of size ``size(scales)``."""
    return lambda s: ((ALL, size(s)),)


def _motion_rows(s: Scales) -> tuple[tuple[Index, float], ...]:
    """A Jacobian's linear rows (size L) and angular rows (size 1): their units differ."""
    return (((slice(None, 3), slice(None)), s.length), ((slice(3, None), slice(None)), 1.0))


def _inertia_blocks(s: Scales) -> tuple[tuple[Index, float], ...]:
    """J M^-1 J^T's blocks: [1/kg] linear, [1/(kg m^2)] angular, [1/(kg m)] between."""
    return (
        ((slice(None, 3), slice(None, 3)), 1.0 / s.mass),
        ((slice(3, None), slice(3, None)), 1.0 / (s.mass * s.length * s.length)),
        ((slice(None, 3), slice(3, None)), 1.0 / (s.mass * s.length)),
    )


def _momentum_rows(s: Scales) -> tuple[tuple[Index, float], ...]:
    """The momentum matrix's linear rows (size m L) and angular rows (size m L^2)."""
    return (
        ((slice(None, 3), slice(None)), s.mass * s.length),
        ((slice(3, None), slice(None)), s.inertia),
    )


def _per_pose(method: str, rows: int, columns: bool) -> Callable[[Evaluation], Array]:
    """The stack of an `Engine` method of one pose, (n, rows) or (n, rows, nv), pose by pose."""

    def stack(e: Evaluation) -> Array:
        shape = (len(e.Q), rows, e.engine.nv) if columns else (len(e.Q), rows)
        out = np.empty(shape)
        compute = getattr(e.engine, method)
        for i, q in enumerate(e.Q):
            out[i] = compute(q)
        return out

    return stack


def _bare_mass(e: Evaluation) -> Array:
    bare = e.stacks.M.copy()  # type: ignore[union-attr]
    remove_armature(bare, e.engine.armature)
    return bare


def _gradient(e: Evaluation) -> Array:
    out = np.empty((len(e.Q), e.engine.nv))
    for i, (q, dJ) in enumerate(zip(e.Q, e.derivatives, strict=True)):
        out[i] = manipulability_gradient(e.engine.site_jacobian(q), dJ)
    return out


def _singular_values(stack: Array) -> Array:
    """Singular values of each matrix of ``stack``; NaN for a pose whose matrix is not finite.

    An engine with a singular mass matrix (a model read without masses) gives M^-1 J^T of
    infinities or NaN, where LAPACK's SVD does not converge: that pose's values are NaN, which
    the cross-check reports as a disagreement, never an exception.
    """
    out = np.full((*stack.shape[:-2], min(stack.shape[-2:])), np.nan)
    finite = np.isfinite(stack).all(axis=(-2, -1))
    try:
        out[finite] = np.linalg.svd(stack[finite], compute_uv=False)
    except np.linalg.LinAlgError:  # finite but not converged: pose by pose, NaN where it fails
        for k in zip(*np.nonzero(finite), strict=True):
            try:
                out[k] = np.linalg.svd(stack[k], compute_uv=False)
            except np.linalg.LinAlgError:
                pass
    return out


def _coriolis(e: Evaluation) -> Array:
    out = np.empty((len(e.Q), e.engine.nv, e.engine.nv))
    e.engine.coriolis_stack(e.Q, e.velocities, out, e.threads)
    return out


#: Every cross-checked quantity, in report order. The tolerances are relative to each
#: quantity's scale, so an arm of any size is held to the same number; both engines evaluate
#: the same closed-form rigid-body algorithms in double precision, differences are rounding.
# fmt: off
QUANTITIES: tuple[Quantity, ...] = (
    Quantity("site position", "(3,)", "m", 1e-9, "site_pose",
             lambda e: e.stacks.X, _whole(lambda s: s.length), field="X"),
    Quantity("site rotation", "(3, 3)", "-", 1e-9, "site_pose",
             lambda e: e.stacks.R, _whole(lambda s: 1.0), field="R"),
    Quantity("jacobian", "(6, nv)", "m/rad; rad/rad", 1e-9, "site_jacobian",
             lambda e: e.stacks.J, _motion_rows, field="J"),
    Quantity("jacobian derivative", "(nv, 6, nv)", "m/rad^2; rad/rad^2", 1e-9,
             "jacobian_derivatives", lambda e: e.derivatives, _motion_rows),
    Quantity("mass matrix", "(nv, nv)", "kg m^2", 1e-9, "mass_matrix",
             lambda e: e.stacks.M, _whole(lambda s: s.inertia), field="M", dynamic=True),
    Quantity("mass matrix (bare)", "(nv, nv)", "kg m^2", 1e-9, "mass_matrix",
             _bare_mass, _whole(lambda s: s.inertia), field="M", dynamic=True),
    Quantity("gravity", "(nv,)", "N m", 1e-9, "gravity",
             lambda e: e.stacks.G, _whole(lambda s: s.torque), field="G", dynamic=True),
    Quantity("manipulability gradient", "(nv,)", "m^3", 1e-8, "jacobian_derivatives",
             _gradient, _whole(lambda s: s.manipulability)),
    # J M^-1 J^T (the inverse of the operational-space inertia, defined at singular poses
    # too: MuJoCo's sparse mj_solveM against Pinocchio's computeMinverse), per block: [1/kg]
    # linear, [1/(kg m^2)] angular, [1/(kg m)] between. M^-1 multiplies the engines' rounding
    # of M by M's condition number: the bundled arms agree to 1e-13, but a generated arm with
    # a 4 g tip body on a 1 kg chain (cond(M) ~ 1e7) differed by 1.3e-9, hence 1e-8. One
    # scale over the blocks: M^-1 carries J's rounding into every block at M^-1's size (a
    # 1.7e-7 kg m^2 tip body: J_v's 7e-18 m on an axis became 4e-11 between, 1.5e-8 of that
    # block's own size, while the angular block is 6e6).
    Quantity("operational inertia^-1", "(6, 6)", "1/kg; 1/(kg m^2); 1/(kg m)", 1e-8,
             "tool_mobility", lambda e: mobility(*e.mobilities), _inertia_blocks,
             dynamic=True, m_inverse=True, one_scale=True),
    # Yoshikawa's dynamic manipulability, compared through its factors, the singular values
    # of M^-1 J^T, each against the largest: the product itself near a singular pose is the
    # tiny factor times others, and carries that factor's rounding (eps sigma_max) as a
    # relative error. A linear column of M^-1 J^T is [1/(kg m)].
    Quantity("dynamic manipulability", "(min(6, nv),)", "1/(kg m)", 1e-8, "tool_mobility",
             lambda e: _singular_values(e.mobilities[1]),
             _whole(lambda s: 1.0 / (s.mass * s.length)), dynamic=True, m_inverse=True),
    # C(q, v) in the Christoffel form at a velocity drawn from the seed
    # (`crosscheck_velocities`): MuJoCo's exact polarization of its bias against Pinocchio's
    # computeCoriolisMatrix. [N m s/rad]: an inertia times the drawn velocities' size, 1 rad/s.
    Quantity("coriolis", "(nv, nv)", "N m s/rad", 1e-9, "coriolis",
             _coriolis, _whole(lambda s: s.inertia), dynamic=True, velocity=True),
    # The whole robot's centre of mass (every body with mass: the arm's, the held ones at
    # rest, those welded to the world and mocap bodies), its Jacobian for the arm's joints and
    # the centroidal momentum matrix: MuJoCo's subtree_com, mj_jacSubtreeCom and
    # mj_angmomMat of the world body against Pinocchio's centerOfMass, jacobianCenterOfMass
    # and computeCentroidalMap with the world's inertia added back. Pose by pose.
    Quantity("centre of mass", "(3,)", "m", 1e-9, "com",
             _per_pose("com", 3, False), _whole(lambda s: s.length), dynamic=True),
    Quantity("centre of mass jacobian", "(3, nv)", "m/rad", 1e-9, "com_jacobian",
             _per_pose("com_jacobian", 3, True), _whole(lambda s: s.length), dynamic=True),
    Quantity("centroidal momentum", "(6, nv)", "kg m/rad; kg m^2/rad", 1e-9,
             "centroidal_momentum_matrix", _per_pose("centroidal_momentum_matrix", 6, True),
             _momentum_rows, dynamic=True),
)
# fmt: on

#: The quantities by name.
QUANTITY: dict[str, Quantity] = NameDict(((q.name, q) for q in QUANTITIES), "quantity")

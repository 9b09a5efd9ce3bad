"""Engine-agnostic maths on a Jacobian or a mass matrix: SVD, manipulability, null spaces.

Nothing here knows about MuJoCo or Pinocchio; every function takes plain arrays, so the
same code serves both engines and users' own matrices.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Literal, overload

import numpy as np
from numpy.typing import NDArray

from . import kernels
from .checks import (
    check_choice,
    check_direction,
    check_directions,
    check_matrix,
    check_number,
    describe,
    one_line,
)
from .display import Report, Table, table
from .errors import ParameterError
from .kernels import RANK_RTOL as RANK_RTOL
from .kernels import TOOL_DIRECTIONS as TOOL_DIRECTIONS
from .kernels import EffectiveMassRange as EffectiveMassRange

Array = NDArray[np.float64]

#: Rounding noise of a position on an arm of length 1 m, as a multiple of the double's
#: resolution: J's linear rows come from differences of positions up to the arm's length, so
#: their noise is a few eps x L (arm7's, with the tool on the wrist axes: 1e-17 m/rad).
_MOTION_EPS = 1024 * kernels.EPS


def motion_floor(length: float) -> float:
    """Below this, a column or direction of J's linear rows is rounding noise [m/rad].

    1024 eps x ``length`` (2.3e-13 of the arm's length, `Arm.length
    <redundancy.Arm.length>`): far below any lever arm a real joint has, far above the noise
    of a point the joints cannot move. The effective mass, its range and the operational
    inertia count a direction whose motion is below it as one the tool cannot move along.

    Raises:
        ParameterError: ``length`` not a finite number > 0 [m].
    """
    return _MOTION_EPS * check_number("length", length, 0.0, low_open=True, unit="m")


@dataclass(frozen=True, repr=False)
class JacobianSVD(Report):
    """Singular value decomposition J = U diag(sigma) V^T of a 6 x n site Jacobian.

    ``print(svd)`` prints the singular values and the lost directions; a notebook shows them
    as a table.

    Attributes:
        sigma: Singular values, descending, shape (6,) [mixed units: m/rad and rad/rad].
        U: Tool directions, columns, shape (6, 6).
        V: Joint directions, columns, shape (n, n).
        rank: Number of sigma_i > rtol * sigma_max.
        rtol: Relative tolerance used for the rank.
    """

    sigma: Array
    U: Array
    V: Array
    rank: int
    rtol: float

    @property
    def condition(self) -> float:
        """sigma_max / sigma_min (``inf`` at a singular pose)."""
        return float(self.sigma[0] / self.sigma[-1]) if self.sigma[-1] > 0 else float("inf")

    @property
    def manipulability(self) -> float:
        """Yoshikawa's measure, the product of the singular values (see `yoshikawa`)."""
        return float(np.prod(self.sigma))

    @property
    def lost_directions(self) -> Array:
        """Tool directions the arm cannot move along: columns of U past the rank, shape (6, k)."""
        return self.U[:, self.rank :]

    def lost_direction_names(self, atol: float = 1e-6) -> list[str]:
        """Name the lost tool directions when they span coordinate axes (as at arm7's zero pose).

        A coordinate direction e_i is lost when it lies in the span of the lost columns of U
        (its projection onto that span has unit norm to ``atol``).

        Returns:
            The names from `TOOL_DIRECTIONS` that are lost, in row order.

        Raises:
            ParameterError: ``atol`` not a finite number > 0.
        """
        return kernels.axis_names(
            self.lost_directions, check_number("atol", atol, 0.0, low_open=True)
        )

    def summary(self) -> str:
        """Rank, manipulability and condition number on one line."""
        return (
            f"rank {self.rank} of {len(self.sigma)}, manipulability {self.manipulability:.4g}, "
            f"condition {self.condition:.4g}"
        )

    def _rows(self) -> list[tuple[str, str, str]]:
        return [
            (str(i + 1), f"{s:.6g}", "yes" if i < self.rank else "no (lost)")
            for i, s in enumerate(self.sigma)
        ]

    def lines(self) -> list[str]:
        """The summary, one line per singular value, and the lost directions when named."""
        out = [self.summary() + f" (rank rtol {self.rtol:g})", "   i  sigma         counts"]
        out += [f"{i:>4}  {s:<12}  {c}" for i, s, c in self._rows()]
        names = self.lost_direction_names() if self.rank < len(self.sigma) else []
        if names:
            out.append("lost tool directions: " + ", ".join(names))
        return out

    def html_tables(self) -> list[Table]:
        """One row per singular value."""
        return [
            table(
                f"singular values (rank rtol {self.rtol:g})",
                ("i", "sigma", "counts for the rank"),
                self._rows(),
                (True, True, False),
            )
        ]

    def html_notes(self) -> list[str]:
        """The lost tool directions, when they are coordinate axes."""
        names = self.lost_direction_names() if self.rank < len(self.sigma) else []
        return ["lost tool directions: " + ", ".join(names)] if names else []


def jacobian_svd(J: Array, rtol: float = RANK_RTOL) -> JacobianSVD:
    """SVD of a Jacobian with its numerical rank.

    Args:
        J: Jacobian, shape (m, n).
        rtol: Relative rank tolerance (singular values below ``rtol * sigma_max`` are zero),
            in (0, 1).

    Raises:
        ParameterError: ``J`` not a non-empty finite real matrix, or ``rtol`` not a finite
            number in (0, 1).
    """
    J = check_matrix("J", J)
    rtol = check_number("rtol", rtol, 0.0, 1.0, low_open=True, high_open=True)
    U, s, Vt = np.linalg.svd(J)
    rank = int(np.sum(s > rtol * s[0])) if s[0] > 0 else 0
    return JacobianSVD(sigma=s, U=U, V=Vt.T, rank=rank, rtol=rtol)


class _Measure:
    """One of `Manipulability`'s measures: read-only, computed when first read, a float.

    A descriptor rather than four properties, so that the measures are one piece of code and
    type checkers still read ``m.full`` as a float.
    """

    def __init__(self, doc: str) -> None:
        self.__doc__ = doc
        self.kind: str = ""

    def __set_name__(self, owner: type, name: str) -> None:
        self.kind = name

    @overload
    def __get__(self, obj: None, owner: type | None = None) -> _Measure: ...
    @overload
    def __get__(self, obj: Manipulability, owner: type | None = None) -> float: ...
    def __get__(self, obj: Manipulability | None, owner: type | None = None) -> float | _Measure:
        return self if obj is None else obj._get(self.kind)

    def __set__(self, obj: Manipulability, value: object) -> None:
        raise AttributeError(f"property {self.kind!r} of 'Manipulability' object has no setter")


class Manipulability(Report):
    """Yoshikawa's manipulability of the whole Jacobian and of its blocks (see `yoshikawa`).

    Singular values of the full J mix m/rad and rad/rad, so ``full`` depends on the unit of
    length; ``position`` and ``orientation`` do not mix units, and ``scaled`` divides the
    position rows by a characteristic length of the task, making every row rad/rad.

    Each measure is computed when first read (one SVD each), so asking for one costs one.

    Attributes:
        full: Product of the singular values of the 6 x n Jacobian [mixed units].
        position: Same for the 3 linear rows [m^3/rad^3].
        orientation: Same for the 3 angular rows [dimensionless].
        scaled: Same for J with its linear rows divided by ``length`` [dimensionless].
        length: The characteristic length used for ``scaled`` [m].
    """

    __slots__ = ("_J", "_values", "length")

    def __init__(self, J: Array, length: float = 1.0) -> None:
        self._J = J
        self._values: dict[str, float] = {}
        self.length: float = float(length)

    def _get(self, kind: str) -> float:
        value = self._values.get(kind)
        if value is None:
            value = self._values[kind] = kernels.yoshikawa(
                kernels.manipulability_rows(self._J, kind, self.length)
            )
        return value

    full: ClassVar[_Measure] = _Measure(
        "Product of the singular values of the 6 x n J [mixed units]."
    )
    position: ClassVar[_Measure] = _Measure("sqrt(det(J J^T)) of the 3 linear rows [m^3/rad^3].")
    orientation: ClassVar[_Measure] = _Measure(
        "sqrt(det(J J^T)) of the 3 angular rows [dimensionless]."
    )
    scaled: ClassVar[_Measure] = _Measure(
        "sqrt(det(J J^T)) with the linear rows divided by ``length`` [dimensionless]."
    )

    def _rows(self) -> list[tuple[str, str, str]]:
        return [
            ("full", f"{self.full:.6g}", "mixed (m/rad and rad/rad)"),
            ("position", f"{self.position:.6g}", "m^3/rad^3"),
            ("orientation", f"{self.orientation:.6g}", "-"),
            ("scaled", f"{self.scaled:.6g}", f"- (length {self.length:g} m)"),
        ]

    def summary(self) -> str:
        """The four measures on one line."""
        return ", ".join(f"{k} {v}" for k, v, _ in self._rows())

    def lines(self) -> list[str]:
        """One line per measure, with its unit."""
        return [f"{k:<12} {v:<12} {unit}" for k, v, unit in self._rows()]

    def html_tables(self) -> list[Table]:
        """One row per measure."""
        return [
            table(
                "Yoshikawa's manipulability sqrt(det(J J^T))",
                ("measure", "value", "unit"),
                self._rows(),
                (False, True, False),
            )
        ]

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Manipulability):
            return NotImplemented
        fields = ("full", "position", "orientation", "scaled", "length")
        return all(getattr(self, f) == getattr(other, f) for f in fields)

    __hash__: ClassVar[None] = None  # type: ignore[assignment]  # equal by value: unhashable


ManipulabilityKind = Literal["full", "position", "orientation", "scaled"]
#:  The measures of [`Manipulability`][redundancy.Manipulability], each of its own rows of J.
MANIPULABILITY_KINDS: tuple[ManipulabilityKind, ...] = ("full", "position", "orientation", "scaled")


def manipulability_rows(J: Array, kind: str, length: float = 1.0) -> Array:
    """The rows of J one manipulability measure is taken of, for one J (6, n) or a stack.

    Args:
        J: Site Jacobian(s), shape (6, n) or (m, 6, n): linear rows first.
        kind: One of `MANIPULABILITY_KINDS`: all rows, the linear or the angular ones, or all with
            the linear rows divided by ``length``.
        length: Characteristic length for ``"scaled"`` [m], > 0.

    Raises:
        ParameterError: ``J`` not a finite real (6, n) or (m, 6, n) array, ``kind`` not one of
            the kinds, ``length`` not a finite number > 0.
    """
    J = _check_stackable("J", J, (6, None))
    kind = check_choice("manipulability kind", kind, MANIPULABILITY_KINDS)
    length = check_number("length", length, 0.0, low_open=True, unit="m")
    return kernels.manipulability_rows(J, kind, length)


def yoshikawa(J: Array) -> float:
    """Manipulability of an m x n J: the product of its min(m, n) singular values.

    This is the one definition the library uses, for any joint count: sqrt(det(J J^T)) (Yoshikawa's)
    when n >= m, and sqrt(det(J^T J)) when n < m, where det(J J^T) is identically 0 (an arm of fewer
    than 6 joints still has a measure of how far it is from losing one of the directions it can move
    along). The gradient ([`manipulability_gradient`][redundancy.linalg.manipulability_gradient])
    and the batch stacks are of this same value.
    """
    return kernels.yoshikawa(check_matrix("J", J))


def manipulability(J: Array, length: float = 1.0) -> Manipulability:
    """Yoshikawa's measure for the full Jacobian, its blocks and a length-scaled J.

    Args:
        J: Site Jacobian, shape (6, n): linear rows first.
        length: Characteristic length [m] that turns m/rad into rad/rad.

    Raises:
        ParameterError: ``J`` not a non-empty finite real matrix with 6 rows, or ``length``
            not a finite number > 0.
    """
    J = check_matrix("J", J, (6, None))
    length = check_number("length", length, 0.0, low_open=True, unit="m")
    return Manipulability(J.copy(), length)


def manipulability_gradient(J: Array, dJ: Array) -> Array:
    """Gradient of w = prod(sigma) (`yoshikawa`, any m and n) with respect to q.

    With the thin SVD J = U diag(sigma) V^T (r = min(m, n) singular values), d w / d q_k = sum_i
    (prod_{j != i} sigma_j) u_i^T dJ_k v_i: for n >= m the same as w * trace((J J^T)^-1 dJ_k J^T),
    without inverting J J^T, so it stays accurate near singular poses. At a singular pose (numerical
    rank below r, see `RANK_RTOL`) the measure has a kink, like |x| at 0, and no gradient: zeros are
    returned.

    Args:
        J: Jacobian, shape (m, n).
        dJ: Its partial derivatives, shape (n, m, n): dJ[k] = dJ/dq_k.

    Returns:
        Gradient, shape (n,).

    Raises:
        ParameterError: ``J`` or ``dJ`` not finite real arrays of those shapes.
    """
    J = check_matrix("J", J)
    m, n = J.shape
    dJ = check_matrix("dJ", dJ, shape=(n, m, n))
    if not J.size:
        return np.zeros(n)
    U, s, Vt = np.linalg.svd(J, full_matrices=False)
    if s[-1] <= RANK_RTOL * s[0]:
        return np.zeros(n)
    others = np.array([np.prod(np.delete(s, i)) for i in range(len(s))])
    # u_i^T dJ_k v_i for every k and i, weighted by the product of the other singular values.
    proj = np.einsum("mi,kmn,in->ki", U, dJ, Vt)
    return proj @ others


def nullspace_projector(J: Array, rtol: float = RANK_RTOL) -> Array:
    """Orthogonal projector onto the null space of J: N = I - J^+ J (symmetric, idempotent).

    Built from one SVD as N = V_0 V_0^T, V_0 the right singular vectors past the rank: the
    same matrix as I - pinv(J) J (to rounding) at half the cost.

    Raises:
        ParameterError: As [`jacobian_svd`][redundancy.linalg.jacobian_svd].
    """
    B = nullspace_basis(J, rtol)
    return B @ B.T


def nullspace_basis(J: Array, rtol: float = RANK_RTOL) -> Array:
    """Orthonormal basis of the null space of J, columns, shape (n, n - rank).

    Raises:
        ParameterError: As [`jacobian_svd`][redundancy.linalg.jacobian_svd].
    """
    s = jacobian_svd(J, rtol)
    return s.V[:, s.rank :]


def damped_pinv(J: Array, damping: float) -> Array:
    """Damped least-squares inverse J^T (J J^T + lambda^2 I)^-1, bounded near singular poses.

    Computed from the thin SVD as V diag(sigma / (sigma^2 + lambda^2)) U^T, the same matrix
    without forming J J^T (whose entries overflow where J's exceed 1e154).

    Args:
        J: Jacobian, shape (m, n).
        damping: lambda >= 0 [same unit as the singular values]; 0 gives the plain
            pseudo-inverse, which needs J of full rank.

    Raises:
        ParameterError: ``J`` not a non-empty finite real matrix, ``damping`` not a finite
            number >= 0, or ``damping`` 0 with a rank-deficient J.
    """
    J = check_matrix("J", J)
    damping = check_number("damping", damping, 0.0)
    U, s, Vt = np.linalg.svd(J, full_matrices=False)
    if damping == 0.0 and not s[-1] > RANK_RTOL * s[0]:
        raise ParameterError(
            "damping",
            damping,
            f"> 0 for a rank-deficient J (singular values {one_line(s)})",
        )
    with np.errstate(over="ignore", under="ignore"):  # sigma^2 overflows: sigma / inf = 0
        gain = s / (s * s + damping * damping)
    return (Vt.T * gain) @ U.T


def dynamic_nullspace_projector(J: Array, M: Array) -> Array:
    """Dynamically consistent null-space projector N = I - J_bar J (Khatib).

    J_bar = M^-1 J^T Lambda with Lambda = (J M^-1 J^T)^-1, the task-space inertia.

    Torques projected by N^T produce no tool acceleration. Requires J of full row rank.

    Args:
        J: Jacobian, shape (m, n), of full row rank.
        M: Joint-space mass matrix, shape (n, n), symmetric positive definite.

    Raises:
        ParameterError: ``J`` or ``M`` not non-empty finite real matrices of those shapes,
            ``M`` not symmetric positive definite, or ``J`` not of full row rank.
    """
    J = check_matrix("J", J)
    n = J.shape[1]
    M = check_matrix("M", M, (n, n))
    spd = "a symmetric positive definite matrix"
    if not np.allclose(M, M.T, rtol=1e-9, atol=1e-12 * float(np.abs(M).max())):
        raise ParameterError("M", M, spd, "a matrix that is not symmetric")
    try:
        np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        raise ParameterError("M", M, spd, "a matrix that is not positive definite") from None
    s = np.linalg.svd(J, compute_uv=False)
    if J.shape[0] > n or not s[-1] > RANK_RTOL * s[0]:
        raise ParameterError(
            "J", J, "of full row rank", f"{describe(J)}, singular values {one_line(s)}"
        )
    Minv_Jt = np.linalg.solve(M, J.T)
    Lambda = np.linalg.inv(J @ Minv_Jt)
    J_bar = Minv_Jt @ Lambda
    return np.eye(J.shape[1]) - J_bar @ J


# ------------------------------------------------------------------------------------------
# The mass a contact at the tool feels: the operational-space inertia and its inverse
# ------------------------------------------------------------------------------------------


# ------------------------------------------------------------------------------------------
# The tool's mobility: checked entry points (the kernels above take checked input and are
# what the engines and the batch functions call on their own, already checked, arrays)
# ------------------------------------------------------------------------------------------


def _ndim(value: object) -> int:
    try:
        return int(np.ndim(value))  # type: ignore[arg-type]
    except (TypeError, ValueError):  # ragged nested lists: check_matrix names the problem
        return 2


def _check_stackable(name: str, value: object, shape: tuple[int | None, ...]) -> Array:
    """One matrix of ``shape`` or a stack of them (one more leading dimension)."""
    full = (None, *shape) if _ndim(value) == len(shape) + 1 else shape
    return check_matrix(name, value, full)


def _check_jx(J: object, X: object, stack: bool | None) -> tuple[Array, Array]:
    """J (6, k) and X = M^-1 J^T (k, 6), or stacks (n, 6, k) and (n, k, 6).

    ``stack``: True for stacks only, False for single matrices only, None for either.
    """
    if stack is None:
        J = _check_stackable("J", J, (6, None))
    else:
        J = check_matrix("J", J, (None, 6, None) if stack else (6, None))
    k = J.shape[-1]
    X = check_matrix("X", X, (J.shape[0], k, 6) if J.ndim == 3 else (k, 6))
    return J, X


def _check_rtol(rtol: object) -> float:
    return check_number("rtol", rtol, 0.0, 1.0, low_open=True, high_open=True)


def _check_atol(atol: object) -> float:
    return check_number("atol", atol, 0.0, unit="m/rad")


def mobility(J: Array, X: Array) -> Array:
    """Lambda^-1 = J M^-1 J^T from J (…, 6, k) and X = M^-1 J^T (…, k, 6), symmetrised.

    Its linear block is [1/kg], its angular block [1/(kg m^2)].

    Raises:
        ParameterError: J or X not finite real arrays of matching shapes.
    """
    return kernels.mobility(*_check_jx(J, X, None))


def operational_inertia(J: Array, X: Array, rtol: float = RANK_RTOL, atol: float = 0.0) -> Array:
    """Lambda = (J M^-1 J^T)^-1 from J (…, 6, k) and X = M^-1 J^T (…, k, 6), symmetric.

    Through J's SVD, not by inverting J M^-1 J^T: it loses only J's condition number of
    accuracy near a singular pose, not its square. ``atol`` as `effective_mass`.

    Raises:
        SingularPoseError: J has rank below 6 at some pose, or J_v moves the tool by at
            most ``atol`` along some direction (names the lost directions).
        ParameterError: J or X not finite real arrays of matching shapes, ``rtol`` not in
            (0, 1).
    """
    J, X = _check_jx(J, X, None)
    return kernels.operational_inertia(J, X, _check_rtol(rtol), _check_atol(atol))


def effective_mass(
    J: Array, X: Array, u: Array, rtol: float = RANK_RTOL, atol: float = 0.0
) -> float:
    """Effective mass 1 / (u^T J_v M^-1 J_v^T u) [kg] along the direction ``u``.

    Args:
        J: Site Jacobian (6, k) (linear rows first).
        X: M^-1 J^T, shape (k, 6).
        u: Direction, world axes (3,), any nonzero length.
        rtol: Relative tolerance in (0, 1) below which the tool cannot move along ``u``
            (the mass is then ``inf``).
        atol: Motion |J_v^T u| at or below this [m/rad] counts as none, ``inf``:
            `motion_floor` of the arm's length (0: the relative test alone, which a
            J_v of rounding noise passes).

    Raises:
        ParameterError: J or X not finite real arrays of matching shapes, ``u`` zero or not
            a finite (3,) vector, ``rtol`` not in (0, 1).
    """
    J, X = _check_jx(J, X, False)
    return kernels.effective_mass(
        J, X, check_direction("u", u), _check_rtol(rtol), _check_atol(atol)
    )


def effective_masses(
    J: Array, X: Array, U: Array, rtol: float = RANK_RTOL, atol: float = 0.0
) -> Array:
    """`effective_mass` over stacks: J (n, 6, k), X (n, k, 6), U (n, 3) or (3,) -> (n,).

    Raises:
        ParameterError: As [`effective_mass`][redundancy.linalg.effective_mass], for stacks.
    """
    J, X = _check_jx(J, X, True)
    return kernels.effective_masses(
        J, X, check_directions("U", U, len(J)), _check_rtol(rtol), _check_atol(atol)
    )


def effective_mass_range(
    J: Array, X: Array, rtol: float = RANK_RTOL, atol: float = 0.0
) -> EffectiveMassRange:
    """The extremes of the effective mass over directions at one pose (see the class).

    ``atol`` as `effective_mass`: the greatest is ``inf`` where J_v moves the tool by at
    most ``atol`` along some direction, the least too where along every direction.

    Raises:
        ParameterError: J (6, k) or X (k, 6) not finite real arrays, ``rtol`` not in (0, 1).
    """
    J, X = _check_jx(J, X, False)
    return kernels.effective_mass_range(J, X, _check_rtol(rtol), _check_atol(atol))


def effective_mass_ranges(J: Array, X: Array, rtol: float = RANK_RTOL, atol: float = 0.0) -> Array:
    """Least and greatest effective mass over a stack, shape (n, 2) [kg].

    As `effective_mass_range` pose by pose.

    Raises:
        ParameterError: J (n, 6, k) or X (n, k, 6) not finite real arrays, ``rtol`` not in
            (0, 1).
    """
    J, X = _check_jx(J, X, True)
    return kernels.effective_mass_ranges(J, X, _check_rtol(rtol), _check_atol(atol))


def dynamic_manipulability(X: Array) -> Array | float:
    """Yoshikawa's dynamic manipulability sqrt(det(J M^-1 M^-T J^T)) from X = M^-1 J^T.

    The product of X's singular values (zero when fewer than six joints are free). Takes
    one X (k, 6) or a stack (n, k, 6).

    Raises:
        ParameterError: X not a finite real (k, 6) or (n, k, 6) array.
    """
    return kernels.dynamic_manipulability(_check_stackable("X", X, (None, 6)))

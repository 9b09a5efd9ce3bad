"""The unchecked kernels: maths on arrays the caller has already checked.

The checked entry points (`redundancy.linalg`, `redundancy.Arm`, `redundancy.batch`) validate their
input once and call these; the engines call `cholesky_solve` (a loop's Newton step
`small_cholesky_solve`), the inverse-kinematics loop `rotation_vector`. Nothing here validates:
finite float64 arrays of the documented shapes only. Each rule lives here once (the rank rule,
the one rotation log, the Cholesky solves: LAPACK's, and Python floats' for a few unknowns).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .errors import SingularPoseError

Array = NDArray[np.float64]

#: Relative tolerance for the numerical rank: sigma_i counts when sigma_i > RANK_RTOL * sigma_max.
RANK_RTOL = 1e-9

#: The double's resolution.
EPS = float(np.finfo(np.float64).eps)

#: Names of the six rows of a site Jacobian (linear, then angular, world axes).
TOOL_DIRECTIONS = (
    "translation x",
    "translation y",
    "translation z",
    "rotation x",
    "rotation y",
    "rotation z",
)


def manipulability_rows(J: Array, kind: str, length: float = 1.0) -> Array:
    """[`manipulability_rows`][redundancy.linalg.manipulability_rows] on checked input."""
    if kind == "position":
        return J[..., :3, :]
    if kind == "orientation":
        return J[..., 3:, :]
    if kind == "scaled":
        return np.concatenate([J[..., :3, :] / length, J[..., 3:, :]], axis=-2)
    return J


def yoshikawa(J: Array) -> float:
    """`yoshikawa` of a checked J (a Manipulability's rows: checked when it was made)."""
    return float(np.prod(np.linalg.svd(J, compute_uv=False)))


@dataclass(frozen=True)
class EffectiveMassRange:
    """The least and greatest effective mass at the tool over all directions, at one pose.

    They are the reciprocals of the extreme eigenvalues of the 3 x 3 linear block of
    Lambda^-1 = J M^-1 J^T, and the directions are its eigenvectors.

    Attributes:
        min: Least effective mass [kg].
        max: Greatest effective mass [kg] (``inf`` where the tool cannot move along some
            direction).
        min_direction: Unit direction of the least, world axes.
        max_direction: Unit direction of the greatest, world axes.
    """

    min: float
    max: float
    min_direction: Array
    max_direction: Array


def mobility(J: Array, X: Array) -> Array:
    """Lambda^-1 = J M^-1 J^T from J (…, 6, k) and X = M^-1 J^T (…, k, 6), symmetrised.

    Its linear block is [1/kg], its angular block [1/(kg m^2)].
    """
    A = J @ X
    return 0.5 * (A + np.swapaxes(A, -1, -2))


def lost_names(J: Array, rtol: float, atol: float = 0.0) -> list[str]:
    """The tool directions J cannot produce: axis names, or the unit 6-vectors written out.

    Linear directions whose motion is at most ``atol`` [m/rad] count as lost; the rank is
    `redundancy.linalg.jacobian_svd`'s (singular values above ``rtol`` of the largest).
    """
    if atol > 0 and J.shape[1]:
        U, s, Vt = np.linalg.svd(J[:3], full_matrices=False)
        J = J.copy()
        J[:3] = (U * np.where(s > atol, s, 0.0)) @ Vt  # the noise directions set to zero
    U, s, _ = np.linalg.svd(J)  # U is 6 x 6 whatever the number of joints
    rank = int(np.sum(s > rtol * s[0])) if s[0] > 0 else 0
    lost = U[:, rank:]
    names = axis_names(lost)
    if len(names) == lost.shape[1]:
        return names
    return [np.array2string(u, precision=3, suppress_small=True) for u in lost.T]


def axis_names(lost: Array, atol: float = 1e-6) -> list[str]:
    """The names in `TOOL_DIRECTIONS` of the coordinate axes in the span of ``lost``'s columns.

    A coordinate direction e_i is in the span when its projection onto it has unit norm to
    ``atol`` (``lost``'s columns orthonormal, shape (6, k)).
    """
    return [
        TOOL_DIRECTIONS[i]
        for i in range(lost.shape[0])
        if abs(np.linalg.norm(lost[i]) - 1.0) < atol
    ]


def operational_inertia(J: Array, X: Array, rtol: float = RANK_RTOL, atol: float = 0.0) -> Array:
    """Lambda = (J M^-1 J^T)^-1 from J (…, 6, k) and X = M^-1 J^T (…, k, 6), symmetric.

    Not by inverting J M^-1 J^T, whose condition number is J's squared (near a singular pose
    the inverse would be noise), but through J's SVD J = U S V^T: J M^-1 J^T = U S C S U^T
    with C = V^T M^-1 V, as well conditioned as M, so Lambda = U S^-1 C^-1 S^-1 U^T loses
    only J's condition number of accuracy. C is formed as V^T (X U S^-1) = V^T M^-1 V.

    Raises:
        SingularPoseError: J has rank below 6 (by `jacobian_svd`'s rule), or its
            linear rows move the tool by at most ``atol`` [m/rad] along some direction
            (`motion_floor`), at some pose: names the tool directions lost (and the
            pose, for a stack).
    """
    U, s, Vt = np.linalg.svd(J, full_matrices=False)
    bad = (s.shape[-1] < J.shape[-2]) | ~(s[..., 0] > 0) | (s[..., -1] <= rtol * s[..., 0])
    if atol > 0 and not np.all(bad):
        bad = bad | (np.linalg.svd(J[..., :3, :], compute_uv=False)[..., -1] <= atol)
    if np.any(bad):
        if J.ndim == 2:
            raise SingularPoseError("operational inertia", lost_names(J, rtol, atol))
        i = int(np.flatnonzero(bad)[0])
        lost = lost_names(J[i], rtol, atol)
        raise SingularPoseError("operational inertia", lost, f" (pose {i})")
    inv_s = 1.0 / s
    C = Vt @ ((X @ U) * inv_s[..., None, :])
    C = 0.5 * (C + np.swapaxes(C, -1, -2))
    W = U * inv_s[..., None, :]
    L = W @ np.linalg.inv(C) @ np.swapaxes(W, -1, -2)
    return 0.5 * (L + np.swapaxes(L, -1, -2))


def effective_mass(
    J: Array, X: Array, u: Array, rtol: float = RANK_RTOL, atol: float = 0.0
) -> float:
    """Effective mass 1 / (u^T J_v M^-1 J_v^T u) [kg] along the unit direction ``u``.

    Written as 1 / (g^T M^-1 g) with g = J_v^T u: a product of g with M^-1 g, which stays
    accurate relative to |g|^2 near a singular pose (a product J M^-1 J^T formed first
    carries an absolute rounding error of eps times its largest entry).

    Args:
        J: Site Jacobian (6, k) (linear rows first).
        X: M^-1 J^T, shape (k, 6).
        u: Unit direction, world axes (3,).
        rtol: Below ``rtol`` times the Frobenius norm of J_v, |J_v^T u| counts as zero: the
            tool cannot move along ``u`` and the mass is ``inf``.
        atol: Likewise at or below this [m/rad] (`motion_floor`): a J_v made of
            rounding noise, relative to which ``rtol`` would pass the noise.
    """
    # ndarray.dot: on arrays this small, @ costs several times more (numpy's matmul setup).
    Jv = J[:3]
    g = u.dot(Jv)
    gg = g.dot(g)
    if not (gg > rtol * rtol * np.vdot(Jv, Jv) and gg > atol * atol):
        return float("inf")
    a = g.dot(X[:, :3].dot(u))
    return float(1.0 / a) if a > 0 else float("inf")


def effective_masses(
    J: Array, X: Array, U: Array, rtol: float = RANK_RTOL, atol: float = 0.0
) -> Array:
    """`effective_mass` over stacks: J (n, 6, k), X (n, k, 6), U (n, 3) or (3,) -> (n,)."""
    U = np.broadcast_to(U, (len(J), 3))
    g = np.einsum("ni,nik->nk", U, J[:, :3])
    a = np.einsum("nk,nki,ni->n", g, X[:, :, :3], U)
    size = np.linalg.norm(g, axis=1)
    moving = (size > rtol * np.linalg.norm(J[:, :3], axis=(1, 2))) & (size > atol) & (a > 0)
    out = np.full(len(J), np.inf)
    np.divide(1.0, a, out=out, where=moving)
    return out


def _extremes_stuck(J: Array, w: Array, rtol: float, atol: float) -> tuple[Array, Array]:
    """Where the least and the greatest effective mass are ``inf``.

    From J (…, 6, k) and the eigenvalues w (…, 3) of J_v M^-1 J_v^T, ascending.
    The greatest is ``inf`` where the tool cannot move along some direction: fewer than three
    joints free, J_v's least singular value below ``rtol`` of its largest or at most ``atol``
    (`motion_floor`), or w's least at most 64 eps times its largest (inside eigh's
    rounding). The least is ``inf`` where it cannot move at all: J_v's largest at most ``atol``.
    """
    s = np.linalg.svd(J[..., :3, :], compute_uv=False)
    if s.shape[-1] < 3:  # two joints or fewer: a direction is lost, whatever J is
        s = np.concatenate([s, np.zeros((*s.shape[:-1], 3 - s.shape[-1]))], axis=-1)
    floor = np.maximum(rtol * s[..., 0], atol)
    none = ~(s[..., 0] > atol) | ~(w[..., -1] > 0)
    some = none | (s[..., -1] <= floor) | (w[..., 0] <= 64 * EPS * w[..., -1])
    return none, some


def effective_mass_range(
    J: Array, X: Array, rtol: float = RANK_RTOL, atol: float = 0.0
) -> EffectiveMassRange:
    """The extremes of the effective mass over directions at one pose (see the class)."""
    w, V = np.linalg.eigh(mobility(J[:3], X[:, :3]))
    none, some = _extremes_stuck(J, w, rtol, atol)
    low = float("inf") if none else float(1.0 / w[-1])
    top = float("inf") if some else float(1.0 / w[0])
    return EffectiveMassRange(low, top, V[:, -1].copy(), V[:, 0].copy())


def effective_mass_ranges(J: Array, X: Array, rtol: float = RANK_RTOL, atol: float = 0.0) -> Array:
    """Least and greatest effective mass over a stack, shape (n, 2) [kg]."""
    w = np.linalg.eigvalsh(mobility(J[:, :3], X[:, :, :3]))
    none, some = _extremes_stuck(J, w, rtol, atol)
    out = np.full((len(J), 2), np.inf)
    np.divide(1.0, w[:, -1], out=out[:, 0], where=~none)
    np.divide(1.0, w[:, 0], out=out[:, 1], where=~some)
    return out


def dynamic_manipulability(X: Array) -> Array | float:
    """Yoshikawa's dynamic manipulability sqrt(det(J M^-1 M^-T J^T)) from X = M^-1 J^T.

    J M^-1 = X^T, so the measure is the product of X's singular values (zero when fewer
    than six joints are free). Takes one X (k, 6) or a stack (n, k, 6).
    """
    if X.shape[-2] < X.shape[-1]:
        return np.zeros(X.shape[:-2]) if X.ndim > 2 else 0.0
    s = np.linalg.svd(X, compute_uv=False)
    return np.prod(s, axis=-1) if X.ndim > 2 else float(np.prod(s))


def cholesky_solve(M: Array, B: Array) -> Array:
    """M^-1 B for symmetric positive definite M (one matrix or a stack), by Cholesky."""
    L = np.linalg.cholesky(M)
    return np.linalg.solve(L.swapaxes(-1, -2), np.linalg.solve(L, B))


#: Largest system `small_cholesky_solve` takes: beyond, LAPACK's call costs less than the loops.
SMALL_SOLVE = 6


def small_cholesky_solve(N: list[list[float]], c: list[float]) -> list[float] | None:
    """N x = c for a small symmetric N (k x k, k <= `SMALL_SOLVE`), by Cholesky in Python floats.

    No LAPACK call: for the few unknowns of a loop's Newton step, a tenth of numpy's cost.
    None where the factor's diagonal falls below 1e-6 of its largest (N ill conditioned), N is
    not positive definite, or has a NaN: the caller then takes the SVD.
    """
    k = len(c)
    L = [[0.0] * k for _ in range(k)]
    for i in range(k):
        for j in range(i + 1):
            t = N[i][j] - sum(L[i][m] * L[j][m] for m in range(j))
            if i == j:
                if not t > 0.0:
                    return None
                L[i][i] = math.sqrt(t)
            else:
                L[i][j] = t / L[j][j]
    d = [L[i][i] for i in range(k)]
    if not min(d) > 1e-6 * max(d):
        return None
    y = [0.0] * k
    for i in range(k):
        y[i] = (c[i] - sum(L[i][m] * y[m] for m in range(i))) / L[i][i]
    x = [0.0] * k
    for i in reversed(range(k)):
        x[i] = (y[i] - sum(L[m][i] * x[m] for m in range(i + 1, k))) / L[i][i]
    return x


def rotation_vector(Rt: Array, R: Array) -> tuple[float, float, float]:
    """Rotation vector of Rt R^T (world axes) [rad]: the axis times the angle in [0, pi].

    The library's one rotation log. Accurate at every angle: the angle from atan2 (no
    arccos, which loses half the digits near 0 and pi), near 0 from the skew part, near pi
    from the symmetric part (whose largest diagonal entry gives the axis without
    cancellation). Written out in floats: the IK solver calls it every iteration, where
    NumPy's per-call cost on 3 x 3 arrays would dominate.
    """
    e00, e01, e02, e10, e11, e12, e20, e21, e22 = Rt.dot(R.T).ravel().tolist()
    x, y, z = e21 - e12, e02 - e20, e10 - e01  # 2 sin(theta) times the axis
    s2 = math.sqrt(x * x + y * y + z * z)
    c = 0.5 * (e00 + e11 + e22 - 1.0)
    theta = math.atan2(0.5 * s2, c)
    if s2 > 1e-6:
        k = theta / s2
        return k * x, k * y, k * z
    if c > 0.0:  # theta ~ 0: theta / (2 sin theta) -> 1/2
        return 0.5 * x, 0.5 * y, 0.5 * z
    # theta ~ pi: the axis from the symmetric part, (S - c I) / (1 - c) = a a^T.
    S = ((e00, e01, e02), (e10, e11, e12), (e20, e21, e22))
    i = max(range(3), key=lambda j: S[j][j])
    col = [0.5 * (S[j][i] + S[i][j]) - (c if i == j else 0.0) for j in range(3)]
    n = math.sqrt(sum(v * v for v in col)) or 1.0
    a = [v / n for v in col]
    if a[0] * x + a[1] * y + a[2] * z < 0.0:
        a = [-v for v in a]
    return theta * a[0], theta * a[1], theta * a[2]


# -- the one error measure (see redundancy.model.scales) ------------------------------------
#: Smallest scale, so that an arm of zero size or mass never divides by zero [SI].
_TINY = 1e-300

#: The fraction of a quantity's size on the arm below which a value is compared to that
#: floor rather than to itself [-].
FLOOR = 1e-3


@dataclass(frozen=True)
class Scales:
    """The size of an arm in each unit its quantities are measured in.

    Attributes:
        length: Total length of its links: the sum of the body offsets and the tool's [m].
        mass: Total mass [kg].
        gravity: Magnitude of the gravity MuJoCo simulates (1 when it is off) [m/s^2].
        own_inertia: The moving bodies' own rotational inertias (each body's largest
            principal moment), summed [kg m^2]: a link spinning about a joint at its centre
            has this inertia however short the offsets that make ``length`` are.
        joints: The arm's number of joints (nv), which decides the units of Yoshikawa's
            manipulability (`manipulability`).
    """

    length: float
    mass: float
    gravity: float
    own_inertia: float = 0.0
    joints: int = 6

    @property
    def inertia(self) -> float:
        """The larger of M L^2 and the bodies' own inertia [kg m^2]."""
        return max(self.mass * self.length**2, self.own_inertia, _TINY)

    @property
    def manipulability(self) -> float:
        """The size of Yoshikawa's w = sqrt(det(J J^T)) and of its gradient [m^3, or mixed].

        With six or more joints w scales as L^3 (its three linear rows in m, its three
        angular rows in rad/rad). With fewer joints, w = sqrt(det(J^T J)) mixes the units
        in proportions the pose decides: each of its min(nv, 3) linear factors is up to L,
        each angular one up to 1, so the size is max(1, L)^min(nv, 3). L^3 there (a 6 cm,
        3-joint arm: 2.4e-4, its w 0.06) made Pinocchio's 2.7e-15 rounding on a zero
        gradient read as a 1.1e-8 disagreement.
        """
        if self.joints >= 6:
            return max(self.length**3, _TINY)
        return max(1.0, self.length) ** min(self.joints, 3)

    @property
    def torque(self) -> float:
        """M g L: the largest gravity torque the arm's size allows [N m]."""
        return max(self.mass * self.gravity * self.length, _TINY)


def scaled_errors(a: Array, b: Array, size: float) -> Array:
    """Per pose, max |a - b| / max(max |a|, FLOOR x size) over one pose's value's entries.

    Args:
        a: Reference values, stacked (n, ...).
        b: Values compared to them, same shape.
        size: The quantity's size on the arm (see the module docstring) [its unit].

    Returns:
        Errors, shape (n,); NaN or inf where a value is not finite.
    """
    n = len(a)
    if n == 0:
        return np.zeros(0)
    a, b = a.reshape(n, -1), b.reshape(n, -1)
    if a.shape[1] == 0:
        return np.zeros(n)
    scale = np.maximum(np.max(np.abs(a), axis=1), max(FLOOR * size, _TINY))
    return np.max(np.abs(a - b), axis=1) / scale


def scaled_error(a: object, b: object, size: float) -> float:
    """One value's error, as `scaled_errors`, with infinities allowed.

    Equal infinities count as equal; an infinity against a finite value, or a NaN, is an
    infinite error. The scale is the largest finite ``|a|`` (or ``FLOOR x size``).
    """
    a_arr, b_arr = np.asarray(a, float).ravel(), np.asarray(b, float).ravel()
    if a_arr.size == 0:
        return 0.0
    same_inf = np.isinf(a_arr) & np.isinf(b_arr) & (np.sign(a_arr) == np.sign(b_arr))
    with np.errstate(invalid="ignore"):
        diff = np.abs(a_arr - b_arr)
    diff = np.where(same_inf, 0.0, np.nan_to_num(diff, nan=np.inf, posinf=np.inf))
    finite = np.abs(a_arr[np.isfinite(a_arr)])
    scale = max(float(finite.max()) if finite.size else 0.0, FLOOR * size, _TINY)
    return float(diff.max() / scale)

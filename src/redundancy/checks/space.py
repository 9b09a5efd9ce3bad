"""Directions and tool poses: the validators of quantities in the task's space."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ..errors import ParameterError

Array = NDArray[np.float64]

_F64 = np.dtype(np.float64)


def check_direction(name: str, u: object, size: int = 3) -> Array:
    """A direction as a unit float64 vector of shape (size,).

    Raises:
        ParameterError: Not a real vector of that shape, non-finite, or of zero length.
    """
    valid = f"a finite nonzero real vector of shape ({size},)"
    if type(u) is np.ndarray and u.dtype is _F64 and u.shape == (size,):
        norm = math.sqrt(sum(x * x for x in u.tolist()))  # NaN or inf if any value is
        if 0.0 < norm < math.inf:
            return u / norm
    arr = _real_or_refused(name, u, valid)
    if arr.shape != (size,) or not np.all(np.isfinite(arr)):
        raise ParameterError(name, u, valid)
    top = float(np.max(np.abs(arr)))
    if not top > 0.0:
        raise ParameterError(name, u, valid)
    arr = arr / top  # scaled first: the norm of a vector of huge values would overflow
    return arr / float(np.linalg.norm(arr))


#: How far from orthonormal (max |R^T R - I|) a target rotation may be.
ROTATION_ATOL = 1e-6


def check_tool_pose(name: str, target: object) -> tuple[Array, Array]:
    """A tool pose as (position (3,) [m], rotation (3, 3)): a 4 x 4 homogeneous matrix or a pair.

    The pair is what `Arm.site_pose` returns. The rotation must be orthonormal with determinant +1
    (to `ROTATION_ATOL`).

    Raises:
        ParameterError: Anything else (the message says what a target is).
    """
    valid = (
        "a 4 x 4 homogeneous pose or a (position [m], 3 x 3 rotation matrix) pair, "
        "finite, with an orthonormal rotation of determinant +1"
    )
    fast = _tool_pose_pair(target)
    if fast is not None:
        return fast
    try:
        if isinstance(target, tuple | list) and len(target) == 2:
            p, R = (np.asarray(x) for x in target)
        else:
            T = np.asarray(target)
            if T.shape != (4, 4) or np.iscomplexobj(T) or T.dtype.kind not in "biuf":
                raise ParameterError(name, target, valid)
            T = T.astype(np.float64)
            if not np.allclose(T[3], (0.0, 0.0, 0.0, 1.0), rtol=0.0, atol=ROTATION_ATOL):
                raise ParameterError(name, target, valid)
            p, R = T[:3, 3], T[:3, :3]
        if np.iscomplexobj(p) or np.iscomplexobj(R) or p.dtype.kind not in "biuf":
            raise ParameterError(name, target, valid)
        if R.dtype.kind not in "biuf":
            raise ParameterError(name, target, valid)
        p = np.array(p, dtype=np.float64)
        R = np.array(R, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise ParameterError(name, target, valid) from None
    if p.shape != (3,) or R.shape != (3, 3):
        raise ParameterError(name, target, valid)
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(R))):
        raise ParameterError(name, target, valid)
    if np.abs(R.T @ R - np.eye(3)).max() > ROTATION_ATOL or np.linalg.det(R) <= 0.0:
        raise ParameterError(name, target, valid)
    return p, R


def _real_or_refused(name: str, value: object, valid: str) -> Array:
    """``value`` as a float64 array; ParameterError(name, value, valid) unless real numbers."""
    try:
        arr = np.asarray(value)
        if np.iscomplexobj(arr) or arr.dtype.kind not in "biuf":
            raise ParameterError(name, value, valid)
        return np.asarray(arr, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise ParameterError(name, value, valid) from None


def check_directions(name: str, U: object, n: int) -> Array:
    """One direction (3,) for every pose, or one per pose (n, 3), as unit rows (n, 3).

    Raises:
        ParameterError: Not a real (3,) or (n, 3) array, non-finite, or a zero row.
    """
    valid = f"a finite nonzero real vector of shape (3,) or ({n}, 3)"
    arr = _real_or_refused(name, U, valid)
    if arr.shape == (3,):
        arr = np.broadcast_to(arr, (n, 3))
    if arr.shape != (n, 3) or not np.all(np.isfinite(arr)):
        raise ParameterError(name, U, valid)
    norms = np.linalg.norm(arr, axis=1)
    if not np.all((norms > 0) & np.isfinite(norms)):
        raise ParameterError(name, U, valid)
    return arr / norms[:, None]


def _tool_pose_pair(target: object) -> tuple[Array, Array] | None:
    """The common target, a (position, rotation) pair of float64 arrays, checked in floats.

    `check_tool_pose`'s fast path (an inverse-kinematics solve takes ~0.3 ms, of which the NumPy
    checks of the slow path took a tenth); None sends anything else, and any failure, to the slow
    path, which names the error.
    """
    if not (isinstance(target, tuple | list) and len(target) == 2):
        return None
    p, R = target
    if not (
        type(p) is np.ndarray
        and type(R) is np.ndarray
        and p.dtype is _F64
        and R.dtype is _F64
        and p.shape == (3,)
        and R.shape == (3, 3)
    ):
        return None
    a, b, c, d, e, f, g, h, i = R.ravel().tolist()
    if not math.isfinite(sum(p.tolist()) + a + b + c + d + e + f + g + h + i):
        return None
    worst = max(
        abs(a * a + b * b + c * c - 1.0),
        abs(d * d + e * e + f * f - 1.0),
        abs(g * g + h * h + i * i - 1.0),
        abs(a * d + b * e + c * f),
        abs(a * g + b * h + c * i),
        abs(d * g + e * h + f * i),
    )
    det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    if worst > ROTATION_ATOL or not det > 0.0:
        return None
    return p, R

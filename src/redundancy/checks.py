"""The one set of input validators: poses, stacks of poses, numbers, counts, names, threads.

Every public function validates its inputs through these helpers (MuJoCo's ``rollout``
style), so a bad input gets the same error and text wherever it enters the library.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import OutOfRangeError, ParameterError, PoseError, UnknownNameError

Array = NDArray[np.float64]

_F64 = np.dtype(np.float64)


def check_pose(q: ArrayLike, names: Sequence[str]) -> Array:
    """A joint configuration as a float64 array of shape (nq,), every value finite.

    Args:
        q: Joint values in the order of ``names`` [rad or m].
        names: Joint names (their number is nq; they name the bad values in messages).

    Raises:
        PoseError: Not numeric, complex, of another shape, or with NaN or infinite values.
    """
    return pose_key(q, names)[0]


def pose_key(q: ArrayLike, names: Sequence[str]) -> tuple[Array, list[float]]:
    """`check_pose`, also returning the pose's values as a list of floats.

    The engines key their per-thread kinematics cache by that list. Building it is also how
    the common pose (a float64 vector of the right length) is checked: a Python ``sum`` of
    its values is finite only if every value is (an overflowing sum of finite values falls
    through to the exact check), so a single-pose query makes one pass over ``q``.

    Raises:
        PoseError: As `check_pose`.
    """
    if type(q) is np.ndarray and q.dtype is _F64 and q.shape == (len(names),):
        key = q.tolist()
        if math.isfinite(sum(key)):
            return q, key
    arr = _check_pose_slow(q, names)
    return arr, arr.tolist()


def _as_real(x: ArrayLike, what: str) -> Array:
    try:
        arr = np.asarray(x)
        if np.iscomplexobj(arr):  # a float64 conversion would drop the imaginary part
            raise PoseError(f"{what} must be real, got complex values")
        if arr.dtype.kind not in "biuf":
            arr = np.asarray(arr, dtype=np.float64)  # strings, objects: may raise
        return np.asarray(arr, dtype=np.float64)
    except PoseError:
        raise
    except (TypeError, ValueError, OverflowError) as err:
        raise PoseError(f"{what} must be numeric, got {type(x).__name__}: {err}") from err


def _check_pose_slow(q: ArrayLike, names: Sequence[str]) -> Array:
    return _check_vector(q, names, "pose")


def _check_vector(x: ArrayLike, names: Sequence[str], what: str) -> Array:
    """`check_joint_vector` without its fast path (``what`` is ``"pose"`` for a pose)."""
    arr = _as_real(x, what)
    if arr.shape != (len(names),):
        raise PoseError(
            f"{what} must have shape ({len(names)},) for joints {list(names)}, "
            f"got shape {arr.shape}"
        )
    _check_finite(arr, names, what)
    return arr


def _check_finite(arr: Array, names: Sequence[str], label: str) -> None:
    """Raise PoseError naming the joints whose values in ``arr`` (nq,) are not finite."""
    bad = ~np.isfinite(arr)
    if bad.any():
        which = [f"{names[i]}={arr[i]}" for i in np.flatnonzero(bad)]
        raise PoseError(f"{label} has non-finite values: {', '.join(which)}")


def _check_finite_rows(arr: Array, names: Sequence[str], label: str) -> None:
    """`_check_finite` for the first row of ``arr`` (n, nq) with a non-finite value.

    ``label`` is formatted with that row's index (``"pose {}"``).
    """
    bad = ~np.isfinite(arr).all(axis=1)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        _check_finite(arr[row], names, label.format(row))


def check_poses(Q: ArrayLike, names: Sequence[str]) -> Array:
    """A stack of joint configurations as C-contiguous float64 of shape (n, nq).

    Raises:
        PoseError: Not numeric, complex, not of shape (n, nq), or with NaN or infinite values
            (the message names the first bad pose and its joints).
    """
    arr = _as_real(Q, "poses")
    nq = len(names)
    if arr.ndim != 2 or arr.shape[1] != nq:
        raise PoseError(
            f"poses must have shape (n, {nq}) for joints {list(names)}, got shape {arr.shape}"
        )
    _check_finite_rows(arr, names, "pose {}")
    return np.ascontiguousarray(arr)


def check_pose_or_poses(q: ArrayLike, names: Sequence[str]) -> Array:
    """One pose (nq,) or a stack (n, nq), returned as a stack of shape (n, nq)."""
    arr = _as_real(q, "poses")
    if arr.ndim == 1:
        return _check_pose_slow(arr, names).reshape(1, -1)
    return check_poses(arr, names)


def check_in_range(
    Q: Array, names: Sequence[str], lower: Array, upper: Array, what: str, tol: float = 1e-9
) -> None:
    """Every value of a checked stack of poses within its joint's range, to ``tol``.

    Args:
        Q: Poses, shape (n, nq), already checked by `check_poses` [rad or m].
        names: Joint names.
        lower: Lower limits, ``-inf`` where unlimited [rad or m].
        upper: Upper limits, ``inf`` where unlimited [rad or m].
        what: What one pose of the stack is called in the message (``"waypoint"``).
        tol: Slack on the limits [rad or m].

    Raises:
        OutOfRangeError: The first value outside its range, naming the pose and the joint.
    """
    bad = (Q < np.asarray(lower) - tol) | (Q > np.asarray(upper) + tol)
    if bad.any():
        i, j = (int(k) for k in np.argwhere(bad)[0])
        raise OutOfRangeError(
            names[j], float(Q[i, j]), float(lower[j]), float(upper[j]), f"{what} {i}"
        )


def _valid_range(
    what: str, low: float, high: float, low_open: bool, high_open: bool, unit: str
) -> str:
    """``what`` with its range, as error messages state it: "a finite number >= 0 [s]"."""
    if math.isinf(low) and math.isinf(high):
        valid = what
    elif math.isinf(high):
        valid = f"{what} {'>' if low_open else '>='} {low:g}"
    elif math.isinf(low):
        valid = f"{what} {'<' if high_open else '<='} {high:g}"
    else:
        lo_b, hi_b = ("(" if low_open else "["), (")" if high_open else "]")
        valid = f"{what} in {lo_b}{low:g}, {high:g}{hi_b}"
    return valid + (f" [{unit}]" if unit else "")


def check_values(
    name: str,
    value: object,
    low: float = -math.inf,
    high: float = math.inf,
    *,
    low_open: bool = False,
    high_open: bool = False,
    unit: str = "",
) -> Array:
    """A real number or array of them, every value finite and in [low, high], as float64.

    The array form of `check_number`, for arguments given per joint.

    Raises:
        ParameterError: Not real numbers (strings, objects, complex, booleans), empty, or a
            value NaN, infinite or outside the range; the message states the valid range.
    """
    valid = _valid_range("a finite number (or array of them)", low, high, low_open, high_open, unit)
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError, OverflowError) as err:  # ragged nested lists
        raise ParameterError(name, value, valid, describe(value)) from err
    if arr.dtype.kind not in "iuf" or arr.size == 0:
        raise ParameterError(name, value, valid, describe(value))
    arr = np.asarray(arr, dtype=np.float64)
    outside = ~np.isfinite(arr) | (arr < low) | (arr > high)
    if low_open:
        outside |= arr == low
    if high_open:
        outside |= arr == high
    if outside.any():
        bad = arr.flat[int(np.flatnonzero(outside)[0])]
        raise ParameterError(name, value, valid, repr(float(bad)) if arr.ndim else None)
    return arr


def check_broadcast(**arrays: Array) -> tuple[Array, ...]:
    """Arrays broadcast to one shape (`numpy.broadcast_arrays`).

    Raises:
        ParameterError: Their shapes do not broadcast (the message names every argument).
    """
    try:
        return tuple(np.broadcast_arrays(*arrays.values()))
    except ValueError:
        shapes = ", ".join(f"{k} {np.shape(v)}" for k, v in arrays.items())
        names = ", ".join(arrays)
        raise ParameterError(names, shapes, "arrays of shapes that broadcast together") from None


def check_returned(name: str, value: object, q: Array) -> float:
    """The number a user's function (an objective) returned at pose ``q``, as a float.

    Raises:
        ParameterError: Not a finite real number; the message blames ``name`` and says
            what it returned at which pose.
    """
    if (
        isinstance(value, bool | np.bool_)
        or not isinstance(value, int | float | np.integer | np.floating)
        or not math.isfinite(float(value))
    ):
        got = f"one that returned {describe(value)} at q = {one_line(q)}"
        raise ParameterError(name, value, "a function of q returning a finite real number", got)
    return float(value)


def check_callable(name: str, value: object, valid: str) -> None:
    """Raise ParameterError unless ``value`` can be called."""
    if not callable(value):
        raise ParameterError(name, value, valid)


def check_number(
    name: str,
    value: object,
    low: float = -math.inf,
    high: float = math.inf,
    *,
    low_open: bool = False,
    high_open: bool = False,
    unit: str = "",
) -> float:
    """A finite real number in [low, high] (or the open ends), as a float.

    Raises:
        ParameterError: Not a real number, NaN, infinite, or outside the range; the message
            states the valid range.
    """
    valid = _valid_range("a finite number", low, high, low_open, high_open, unit)
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise ParameterError(name, value, valid)
    x = float(value)
    if not math.isfinite(x):
        raise ParameterError(name, value, valid)
    if x < low or x > high or (low_open and x == low) or (high_open and x == high):
        raise ParameterError(name, value, valid)
    return x


def one_line(x: ArrayLike) -> str:
    """An array printed on one line (error messages are one line each)."""
    return np.array2string(np.asarray(x), precision=6, max_line_width=1_000_000)


def describe(value: object) -> str:
    """A short description of a value for an error message: an array's shape, not its data."""
    if isinstance(value, np.ndarray):
        return f"an array of shape {value.shape} and dtype {value.dtype}"
    text = repr(value)
    return text if len(text) <= 80 else f"{type(value).__name__} {text[:60]}..."


def check_matrix(
    name: str, value: object, shape: Sequence[int | None] | None = None, ndim: int = 2
) -> Array:
    """A non-empty real array of finite values, as float64, of ``ndim`` dimensions.

    Args:
        name: The argument's name, for the message.
        value: What was passed.
        shape: Required sizes per dimension, ``None`` for any (default: any).
        ndim: Number of dimensions when ``shape`` is not given.

    Raises:
        ParameterError: Not numeric (strings, objects, complex), of another shape, empty, or
            with NaN or infinite values; the message says which.
    """
    ndim = len(shape) if shape is not None else ndim
    # The common call, a float64 array of the right shape (a Jacobian in a control loop),
    # costs one pass of isfinite.
    if (
        type(value) is np.ndarray
        and value.dtype is _F64
        and value.ndim == ndim
        and value.size
        and (
            shape is None
            or all(k is None or k == a for k, a in zip(shape, value.shape, strict=True))
        )
        and np.isfinite(value).all()
    ):
        return value
    if shape is not None:
        sizes = ["n" if k is None else str(k) for k in shape]
        want = f"of shape ({', '.join(sizes)}{',' if len(sizes) == 1 else ''})"
    else:
        want = f"with {ndim} dimensions"
    valid = f"a non-empty real array of finite numbers {want}"
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError, OverflowError) as err:  # ragged nested lists
        raise ParameterError(name, value, valid, describe(value)) from err
    if arr.dtype.kind not in "iuf":
        raise ParameterError(name, value, valid, describe(value))
    shown = f"shape {arr.shape}"
    if arr.ndim != ndim or arr.size == 0:
        raise ParameterError(name, value, valid, shown)
    if shape is not None and any(
        k is not None and k != a for k, a in zip(shape, arr.shape, strict=True)
    ):
        raise ParameterError(name, value, valid, shown)
    arr = np.asarray(arr, dtype=np.float64)
    bad = ~np.isfinite(arr)
    if bad.any():
        first = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ParameterError(name, value, valid, f"{arr[first]} at index {first}")
    return arr


def check_count(name: str, value: object, minimum: int = 0, maximum: int | None = None) -> int:
    """An integer in [minimum, maximum], as an int.

    Raises:
        ParameterError: Not an integer (bools and floats included) or out of range.
    """
    top = "" if maximum is None else f" and <= {maximum}"
    valid = f"an integer >= {minimum}{top}"
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ParameterError(name, value, valid)
    n = int(value)
    if n < minimum or (maximum is not None and n > maximum):
        raise ParameterError(name, value, valid)
    return n


def max_threads() -> int:
    """The most threads that can help: the CPUs this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not on Linux
        return max(1, os.cpu_count() or 1)


def check_threads(threads: object) -> int:
    """A thread count >= 1, capped at `max_threads` (more cannot run at once).

    Raises:
        ParameterError: Not an integer >= 1.
    """
    return min(check_count("threads", threads, 1), max_threads())


def check_flag(name: str, value: object) -> bool:
    """A yes/no argument: a bool (numpy's too).

    Raises:
        ParameterError: Anything else (an array's truth value is ambiguous, a string is
            always true).
    """
    if not isinstance(value, bool | np.bool_):
        raise ParameterError(name, value, "True or False", describe(value))
    return bool(value)


def check_choice(kind: str, value: object, choices: Sequence[str]) -> str:
    """One of ``choices``.

    Raises:
        UnknownNameError: Anything else (the message lists the choices).
    """
    if not isinstance(value, str) or value not in choices:
        raise UnknownNameError(kind, str(value), choices)
    return value


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


def check_joint_subset(name: str, joints: object, names: Sequence[str]) -> NDArray[np.intp] | None:
    """Indices (ascending) of the joints named in ``joints``; None for None or every joint.

    Raises:
        UnknownNameError: A name that is not one of ``names`` (lists them).
        ParameterError: Not an iterable of names, empty, or with a name twice.
    """
    if joints is None:
        return None
    valid = f"None or a nonempty collection of distinct joint names from {list(names)}"
    if isinstance(joints, str | bytes) or not hasattr(joints, "__iter__"):
        raise ParameterError(name, joints, valid)
    given = list(joints)  # type: ignore[call-overload]
    for j in given:
        if not isinstance(j, str):
            raise ParameterError(name, joints, valid)
        if j not in names:
            raise UnknownNameError("joint", j, names)
    if not given or len(set(given)) != len(given):
        raise ParameterError(name, joints, valid)
    if len(given) == len(names):
        return None
    return np.array(sorted(names.index(j) for j in given), dtype=np.intp)


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


def check_joint_vector(what: str, x: ArrayLike, names: Sequence[str]) -> Array:
    """A per-joint vector other than a pose (a velocity, a torque) as float64 (nq,), finite.

    Args:
        what: Its name in messages (``"velocity"``, ``"tau"``).
        x: The values, in the order of ``names`` [rad/s, N m...].
        names: Joint names (their number is nq; they name the bad values in messages).

    Raises:
        PoseError: Not numeric, complex, of another shape, or with NaN or infinite values.
    """
    if type(x) is np.ndarray and x.dtype is _F64 and x.shape == (len(names),):
        if math.isfinite(sum(x.tolist())):
            return x
    return _check_vector(x, names, what)


def check_joint_vectors(what: str, X: ArrayLike, names: Sequence[str], n: int) -> Array:
    """A stack of per-joint vectors, one per pose, as C-contiguous float64 (n, nq), finite.

    Args:
        what: Its name in messages (``"velocities"``).
        X: The stack, shape (n, nq).
        names: Joint names.
        n: The number of poses it goes with.

    Raises:
        PoseError: Not numeric, complex, not of shape (n, nq), or with NaN or infinite values
            (the message names the first bad row and its joints).
    """
    arr = _as_real(X, what)
    nq = len(names)
    if arr.shape != (n, nq):
        raise PoseError(
            f"{what} must have shape ({n}, {nq}), one row per pose, for joints "
            f"{list(names)}, got shape {arr.shape}"
        )
    _check_finite_rows(arr, names, what + " row {}")
    return np.ascontiguousarray(arr)

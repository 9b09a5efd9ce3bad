"""The one set of input validators: poses, stacks of poses, numbers, counts, names, threads.

Directions and tool poses are checked in `redundancy.checks.space`; this module re-exports
them, so every validator is imported from here.

Every public function validates its inputs through these helpers (MuJoCo's ``rollout``
style), so a bad input gets the same error and text wherever it enters the library.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping, Sequence
from typing import Any, Generic, TypedDict, TypeVar, Unpack

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import OutOfRangeError, ParameterError, PoseError, UnknownNameError
from .space import ROTATION_ATOL as ROTATION_ATOL
from .space import check_direction as check_direction
from .space import check_directions as check_directions
from .space import check_tool_pose as check_tool_pose

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


class Ends(TypedDict, total=False):
    """How `check_number` and `check_values` state a range's ends and unit.

    Attributes:
        low_open: ``low`` itself is outside the range (default False).
        high_open: ``high`` itself is outside the range (default False).
        unit: The unit the message names, e.g. ``"s"`` (default: none).
    """

    low_open: bool
    high_open: bool
    unit: str


def _valid_range(what: str, low: float, high: float, ends: Ends) -> str:
    """``what`` with its range, as error messages state it: "a finite number >= 0 [s]"."""
    low_open, high_open = ends.get("low_open", False), ends.get("high_open", False)
    unit = ends.get("unit", "")
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


def _outside(x: Any, low: float, high: float, ends: Ends) -> Any:
    """Whether ``x`` (a float, or an array elementwise) is outside the range; NaN is not."""
    out = (x < low) | (x > high)
    if ends.get("low_open", False):
        out = out | (x == low)
    if ends.get("high_open", False):
        out = out | (x == high)
    return out


def check_values(
    name: str, value: object, low: float = -math.inf, high: float = math.inf, **ends: Unpack[Ends]
) -> Array:
    """A real number or array of them, every value finite and in [low, high], as float64.

    The array form of `check_number`, for arguments given per joint.

    Raises:
        ParameterError: Not real numbers (strings, objects, complex, booleans), empty, or a
            value NaN, infinite or outside the range; the message states the valid range.
    """
    valid = _valid_range("a finite number (or array of them)", low, high, ends)
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError, OverflowError) as err:  # ragged nested lists
        raise ParameterError(name, value, valid, describe(value)) from err
    if arr.dtype.kind not in "iuf" or arr.size == 0:
        raise ParameterError(name, value, valid, describe(value))
    arr = np.asarray(arr, dtype=np.float64)
    outside = ~np.isfinite(arr) | _outside(arr, low, high, ends)
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
    name: str, value: object, low: float = -math.inf, high: float = math.inf, **ends: Unpack[Ends]
) -> float:
    """A finite real number in [low, high] (or the open ends), as a float.

    Raises:
        ParameterError: Not a real number, NaN, infinite, or outside the range; the message
            states the valid range.
    """
    valid = _valid_range("a finite number", low, high, ends)
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise ParameterError(name, value, valid)
    x = float(value)
    if not math.isfinite(x):
        raise ParameterError(name, value, valid)
    if _outside(x, low, high, ends):
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


_V = TypeVar("_V")


class NameDict(dict[str, _V], Generic[_V]):
    """A dict of names whose lookup of a missing one is the library's error listing the names.

    Every public mapping by name (the registry of quantities, the tolerances, an arm's held
    joints and keyframes) is one: ``d[name]`` of a name it lacks raises `UnknownNameError`
    (still a `KeyError`) naming ``kind`` and the names it has, where a dict's `KeyError`
    names none. Otherwise a plain dict: equal to one with the same items, ``get`` and ``in``
    as usual, pickled with its ``kind``.

    Args:
        items: The mapping's items (a mapping or (name, value) pairs).
        kind: What a key is, for the message (``"quantity"``, ``"held joint"``).
    """

    kind: str = "name"

    def __init__(
        self, items: Mapping[str, _V] | Iterable[tuple[str, _V]] = (), kind: str = "name"
    ) -> None:
        super().__init__(items)
        self.kind = kind

    def __missing__(self, key: str) -> _V:
        raise UnknownNameError(self.kind, key, tuple(self))


def check_options(options: Mapping[str, object], allowed: type) -> None:
    """Keyword options given as ``**options: Unpack[allowed]``, ``allowed`` a TypedDict.

    Python lets any keyword into ``**options``; this is the check that it is one of them.

    Raises:
        UnknownNameError: A keyword that is not one of ``allowed``'s (the message lists
            them).
    """
    if not options:  # the common call: every option at its default
        return
    valid = allowed.__annotations__  # a TypedDict's keys, its bases' included, in order
    if not options.keys() <= valid.keys():
        unknown = next(k for k in options if k not in valid)
        raise UnknownNameError("option", unknown, tuple(valid))


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
    try:
        given = list(joints)  # type: ignore[call-overload]
    except TypeError:  # a 0-d array: __iter__ without items
        raise ParameterError(name, joints, valid) from None
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

"""The keyframes of an [`Arm`][redundancy.Arm]'s file: their names, poses and held joints.

A keyframe is the whole robot's: one that puts a held joint elsewhere than the arm holds it
is a pose of another arm (`Arm.at_keyframe`). `_Keyframes` is a part of `Arm`, which
documents its methods.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any, Self

import mujoco
import numpy as np
from numpy.typing import NDArray

from .checks import NameDict
from .engines.mujoco import object_names
from .errors import PoseError, UnknownNameError

Array = NDArray[np.float64]


class _Keyframes:
    """`Arm`'s keyframe methods; they read the Arm's attributes declared here."""

    held: dict[str, float | tuple[float, ...]]
    robot_model: mujoco.MjModel
    _key_moves: tuple[dict[str, float | tuple[float, ...]], ...]
    _at_keys: dict[str, Any]
    _lock: threading.Lock
    _recipe: tuple[Callable[..., Any], tuple[Any, ...]] | None
    mj_model: mujoco.MjModel  # the Arm's property
    _of_chain: Callable[[Array], Array]  # the Arm's (arm_coupled)

    @property
    def keyframe_names(self) -> tuple[str, ...]:
        """Every keyframe of the robot's file, in file order.

        An unnamed keyframe is called ``key<index>``, with ``_`` appended until the name is
        not one a keyframe of the model has (an unnamed key never hides a named one).
        """
        names = object_names(self.mj_model, mujoco.mjtObj.mjOBJ_KEY)
        taken = set(names)
        for k, name in enumerate(names):
            if not name:
                name = f"key{k}"
                while name in taken:
                    name += "_"
                names[k] = name
                taken.add(name)
        return tuple(names)

    @property
    def keyframes(self) -> dict[str, Array]:
        """Keyframe name -> joint configuration [rad or m], for the keyframes of this arm.

        A keyframe is the whole robot's: one that puts a held joint elsewhere than this arm
        holds it (`keyframe_moves`) is a pose of another arm, `at_keyframe`, and
        is not listed here (`keyframe_names` lists every keyframe). An unknown name looked
        up in it raises `UnknownNameError` naming those listed.
        """
        m = self.mj_model
        keys = (
            (name, self._of_chain(m.key_qpos[k]))
            for k, name in enumerate(self.keyframe_names)
            if not self.keyframe_moves(name)
        )
        return NameDict(keys, "arm keyframe")

    def keyframe(self, name: str) -> Array:
        """Joint configuration of a named keyframe [rad or m].

        Raises:
            UnknownNameError: No keyframe of that name.
            PoseError: The keyframe moves held joints: it is a pose of `at_keyframe`.
        """
        moved = self.keyframe_moves(name)
        if moved:
            shown = ", ".join(
                f"{j} = {_value(v)} (held at {_value(self.held[j])})" for j, v in moved.items()
            )
            raise PoseError(
                f"keyframe {name!r} moves held joints ({shown}): it is not a pose of this arm; "
                f"arm.at_keyframe({name!r}) is the arm at it (or load with rest={name!r})"
            )
        return self._of_chain(self.mj_model.key_qpos[self.keyframe_names.index(name)])

    def keyframe_moves(self, name: str) -> dict[str, float | tuple[float, ...]]:
        """The held joints keyframe ``name`` puts elsewhere than this arm holds them.

        Returns:
            Held joint name -> the keyframe's value [rad or m] (its couplings followed);
            empty when the keyframe is a pose of this arm.

        Raises:
            UnknownNameError: No keyframe of that name.
        """
        names = self.keyframe_names
        if not isinstance(name, str) or name not in names:
            raise UnknownNameError("keyframe", name, list(names))
        moves = self._key_moves[names.index(name)] if self._key_moves else {}
        return NameDict(moves, "moved held joint")

    def at_keyframe(self, name: str) -> Self:
        """This arm with its held joints where keyframe ``name`` puts them.

        Itself when the keyframe moves no held joint; otherwise the robot loaded again with
        ``rest=name`` (built once per keyframe, then shared), whose ``keyframe(name)`` is the
        keyframe's pose. The audit, the lab and the collision statistics judge each keyframe
        there, at the robot's real pose.

        Raises:
            UnknownNameError: No keyframe of that name.
            TypeError: The keyframe moves held joints and this Arm was not built by
                `redundancy.load` (it cannot be loaded again).
        """
        if not self.keyframe_moves(name):
            return self
        with self._lock:
            if name not in self._at_keys:
                if self._recipe is None:
                    raise TypeError(
                        "this Arm was not built by redundancy.load and cannot be loaded again "
                        f"at keyframe {name!r}"
                    )
                fn, (recipe,) = self._recipe
                # The same files loaded with rest=: the keyframe by name, or (unnamed) its
                # held values.
                named = name in object_names(self.robot_model, mujoco.mjtObj.mjOBJ_KEY)
                rest = name if named else self._key_held(name)
                self._at_keys[name] = fn(recipe.with_rest(rest))
            return self._at_keys[name]

    def _key_held(self, name: str) -> dict[str, float | tuple[float, ...]]:
        """The held values an unnamed keyframe gives (its couplings followed)."""
        return {**self.held, **self.keyframe_moves(name)}


def held_value_distance(a: float | tuple[float, ...], b: float | tuple[float, ...]) -> float:
    """How far apart two values of one held joint put the robot [rad or m].

    A hinge's or slide's values are compared as numbers. A ball joint's (w x y z) or a free
    joint's (x y z, then w x y z) quaternion is compared as the rotation it stands for, as
    MuJoCo's kinematics read it: normalised (a zero quaternion is the identity,
    ``mju_normalize4``), and q and -q are one rotation. The distance is the largest
    coordinate difference, the quaternion's taken with the nearer sign.

    Returns:
        The distance; inf when the values have different sizes.
    """
    x, y = np.atleast_1d(np.asarray(a, float)), np.atleast_1d(np.asarray(b, float))
    if x.shape != y.shape:
        return float("inf")
    if x.size not in (4, 7):
        return float(np.max(np.abs(x - y), initial=0.0))
    p, r = _unit_quaternion(x[-4:]), _unit_quaternion(y[-4:])
    turn = min(np.max(np.abs(p - r)), np.max(np.abs(p + r)))
    return float(max(np.max(np.abs(x[:-4] - y[:-4]), initial=0.0), turn))


def _unit_quaternion(q: Array) -> Array:
    """``q`` normalised as MuJoCo's ``mju_normalize4`` does (below 1e-15 in norm: identity)."""
    norm = float(np.linalg.norm(q))
    return q / norm if norm >= mujoco.mjMINVAL else np.array([1.0, 0.0, 0.0, 0.0])


def _value(v: float | tuple[float, ...]) -> str:
    """A held joint's value for a message: ``1.2`` or ``(0, 0, 0.8, 1, 0, 0, 0)``."""
    if isinstance(v, tuple):
        return "(" + ", ".join(f"{x:.6g}" for x in v) + ")"
    return f"{v:.6g}"

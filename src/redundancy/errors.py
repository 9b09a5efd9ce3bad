"""The library's exceptions: one root, subclasses that carry the offending values.

Every error a user can trigger with a model, a name or a pose is a
[`RedundancyError`][redundancy.RedundancyError], so ``except RedundancyError`` is enough; engine
exceptions are re-raised as one of these with the original kept as ``__cause__``.
"""

from __future__ import annotations

import pickle
import warnings
from collections.abc import Sequence
from typing import Any


class RedundancyError(Exception):
    """Root of every exception raised by this library.

    Every one pickles with its message and attributes (an executor's worker sends it back
    to the caller), whatever its constructor's arguments; an attribute that does not pickle
    travels as its ``repr``.
    """

    def __reduce__(self) -> tuple[Any, ...]:
        return _restored, (type(self), self.args, {k: _travels(v) for k, v in vars(self).items()})


def _travels(value: object) -> object:
    try:
        pickle.dumps(value)
    except Exception:  # any object may refuse to pickle, in any way
        return repr(value)
    return value


def _restored(cls: type[RedundancyError], args: tuple[Any, ...], state: dict[str, Any]) -> Any:
    err = cls.__new__(cls, *args)
    err.args = args
    err.__dict__.update(state)
    return err


class ModelError(RedundancyError):
    """The MJCF could not be read or compiled (malformed XML, missing file, bad values)."""


class UnsupportedFeatureError(ModelError):
    """The model uses a feature that the two engines cannot be shown to agree on.

    Attributes:
        feature: Short name of the feature, e.g. ``"ball joint"``.
        where: The element that uses it, e.g. ``"joint 'shoulder'"``.
    """

    def __init__(self, feature: str, where: str, why: str) -> None:
        self.feature = feature
        self.where = where
        super().__init__(f"unsupported feature: {feature} ({where}): {why}")


class GeomPlacementError(ModelError):
    """Pinocchio's collision geoms sit elsewhere than MuJoCo's: the engines see other bodies.

    The collision checker's self-check at build; a lenient audit (whose engines' models may
    differ) skips its self-collision sweep on it instead of stopping.
    """


class MissingInertiaError(ModelError):
    """A dynamic quantity of an arm whose model gives some moving links no inertia.

    Kinematic quantities (pose, Jacobian, SVD, manipulability, null space, self-motion, IK,
    collision) need no inertia and are served; the mass matrix, gravity and everything
    computed from them are refused.

    Attributes:
        quantity: What was asked for, e.g. ``"mass matrix"``.
        links: The links (bodies) the arm moves that have no inertial data.
    """

    def __init__(self, quantity: str, links: Sequence[str]) -> None:
        self.quantity = quantity
        self.links: tuple[str, ...] = tuple(links)
        shown = ", ".join(repr(n) for n in self.links)
        super().__init__(
            f"{quantity} needs the inertia of every link the arm moves, and the model gives "
            f"none for {shown} (no <inertial>); kinematic quantities (Jacobian, SVD, "
            "manipulability, null space, self-motion, IK, collision) are served: add an "
            "<inertial> with mass, centre of mass and inertia to each of these links"
        )


class MissingMeshError(ModelError):
    """A collision query on an arm whose file names meshes that are found nowhere.

    The arm is served without those meshes' geoms (every kinematic and dynamic quantity is
    defined by the file); what collides them is refused.

    Attributes:
        meshes: The missing meshes (`redundancy.model.selection.MissingMesh`: link, file name
            as written, the places looked in).
    """

    def __init__(self, meshes: Sequence[Any]) -> None:
        self.meshes: tuple[Any, ...] = tuple(meshes)
        shown = "; ".join(
            f"link {m.link!r}: {m.file!r} (looked for: {', '.join(m.looked) or 'nowhere'})"
            for m in self.meshes
        )
        super().__init__(
            f"collision needs the meshes the model names, and these are found nowhere: "
            f"{shown}; install the package that ships them (or put it on "
            "ROS_PACKAGE_PATH) and load again"
        )


class UnknownNameError(RedundancyError, KeyError):
    """A site, joint, body, geom or keyframe name that the model does not have.

    Attributes:
        kind: What was looked up (``"site"``, ``"joint"``...).
        name: The name asked for.
        valid: The names the model has, in model order.
    """

    def __init__(self, kind: str, name: str, valid: Sequence[str]) -> None:
        self.kind = kind
        self.name = name
        self.valid: tuple[str, ...] = tuple(valid)
        super().__init__(kind, name)

    def __str__(self) -> str:
        choices = ", ".join(repr(v) for v in self.valid) if self.valid else "none"
        return f"unknown {self.kind} {self.name!r}; valid {self.kind} names: [{choices}]"


class AbsentEngineError(UnknownNameError):
    """An engine this arm was loaded without (``arm.absent_engines`` says why).

    Attributes:
        reason: Why the engine is absent (not installed, its parser refused the file...).
    """

    def __init__(self, name: str, reason: str, valid: Sequence[str]) -> None:
        self.reason = reason
        super().__init__("engine", name, valid)

    def __str__(self) -> str:
        present = ", ".join(repr(v) for v in self.valid)
        return f"engine {self.name!r} is absent from this arm: {self.reason}; engines: [{present}]"


class PoseError(RedundancyError, ValueError):
    """A joint configuration of the wrong shape or type, or with NaN or infinite values."""


class OutOfRangeError(PoseError):
    """A joint value outside the joint's range.

    Attributes:
        joint: Joint name.
        value: The offending value [rad or m].
        lower: Lower limit [rad or m].
        upper: Upper limit [rad or m].
        where: Which of several poses holds the value (e.g. ``"waypoint 2"``), or ``""``.
    """

    def __init__(
        self, joint: str, value: float, lower: float, upper: float, where: str = ""
    ) -> None:
        self.joint = joint
        self.value = value
        self.lower = lower
        self.upper = upper
        self.where = where
        super().__init__(
            f"{where + ': ' if where else ''}joint {joint!r} = {value:.6g} is outside its "
            f"range [{lower:.6g}, {upper:.6g}]"
        )


class ParameterError(RedundancyError, ValueError):
    """A parameter outside its valid range (a tolerance, a count, a step), or of the wrong type.

    Attributes:
        name: The parameter's name.
        value: The value given (the message shows ``shown`` instead when given: an array's
            shape and its first bad entry rather than all of it).
    """

    def __init__(self, name: str, value: object, valid: str, shown: str | None = None) -> None:
        self.name = name
        self.value = value
        got = repr(value) if shown is None else shown
        super().__init__(f"{name} must be {valid}, got {got}")


class MissingDependencyError(RedundancyError, ImportError):
    """An optional dependency is not installed; the message says how to install it."""

    def __init__(self, module: str, extra: str) -> None:
        self.module = module
        self.extra = extra
        super().__init__(
            f"{module} is required for this feature; install it with "
            f"`pip install 'redundancy[{extra}]'`"
        )


class SingularPoseError(PoseError):
    """A quantity that does not exist at a singular pose (the tool has lost directions).

    Attributes:
        quantity: What was asked for, e.g. ``"operational inertia"``.
        lost: The tool directions lost, by name (``"translation x"``...) where they are
            coordinate axes, otherwise as unit 6-vectors written out.
    """

    def __init__(self, quantity: str, lost: Sequence[str], why: str = "") -> None:
        self.quantity = quantity
        self.lost: tuple[str, ...] = tuple(lost)
        super().__init__(
            f"{quantity} is undefined at a singular pose: the tool cannot move along "
            f"{', '.join(self.lost)}{why}"
        )


class DeprecatedAlias:
    """A read-only class attribute that is an old name of another one (``site`` of ``frame``).

    Reading it warns ``"<Class>.<old> is deprecated: use <Class>.<new>"`` with a
    DeprecationWarning pointing at the reader's line, then returns the new attribute.

    Args:
        new: The attribute's current name.
    """

    def __init__(self, new: str) -> None:
        self.new: str = new
        self.name: str = new
        self.message: str = f"deprecated: use {new}"
        self.__doc__ = f"Deprecated name of `{new}` (warns with a DeprecationWarning)."

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name
        self.message = f"{owner.__name__}.{name} is deprecated: use {owner.__name__}.{self.new}"

    def __get__(self, obj: object, owner: type | None = None) -> Any:
        if obj is None:
            return self
        warnings.warn(self.message, DeprecationWarning, stacklevel=2)
        return getattr(obj, self.new)

    def __set__(self, obj: object, value: object) -> None:
        owner = type(obj).__name__
        raise AttributeError(f"property {self.name!r} of {owner!r} object has no setter")

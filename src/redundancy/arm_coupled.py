"""An [`Arm`][redundancy.Arm] with coupled joints: its chain pose, G, and poses that respect both.

`_Coupled` is a part of `Arm`, which documents its methods; `coupled_poses` is
[`random_poses`][redundancy.random_poses]'s draw on such an arm. The coupling map itself is
`redundancy.engines.coupling`.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .checks import check_pose
from .engines.coupling import CouplingMap
from .errors import PoseError, UnknownNameError

Array = NDArray[np.float64]


class _Coupled:
    """`Arm`'s coupled-joint methods; they read the Arm's attributes declared here."""

    joint_names: tuple[str, ...]
    nq: int
    coupling: CouplingMap | None

    def _of_chain(self, values: Array) -> Array:
        """The arm's coordinates' entries of a vector over the chain model's joints."""
        values = np.asarray(values)
        return values.copy() if self.coupling is None else values[self.coupling.independent]

    def chain_pose(self, q: ArrayLike) -> Array:
        """Every joint the arm moves at ``q``, in the order of `chain_joint_names` [rad or m].

        The followers as their couplings give them; a loop closed by Newton's method on its
        constraint (to 1e-12 m or rad). Without couplings: ``q`` itself.

        Raises:
            PoseError: A bad ``q``, or a loop that cannot close at ``q`` (naming its
                constraint).
        """
        q = check_pose(q, self.joint_names)
        if self.coupling is None:
            return q.copy()
        return self.coupling.at(q, q.tolist()).x.copy()

    def coupling_jacobian(self, q: ArrayLike) -> Array:
        """G = d(chain_pose)/dq, shape (len(chain_joint_names), nq) (the identity uncoupled)."""
        q = check_pose(q, self.joint_names)
        if self.coupling is None:
            return np.eye(self.nq)
        return self.coupling.at(q, q.tolist()).G.copy()

    def _closes(self, q: Array) -> bool:
        """Whether the arm's loops close at its pose ``q`` (always, without loops)."""
        if self.coupling is None or self.coupling.closure is None:
            return True
        try:
            self.chain_pose(q)
        except PoseError:
            return False
        return True

    def _reachable_keyframes(self) -> tuple[str, ...]:
        """The keyframes at which the arm's loops close (every one, without loops), in order.

        A keyframe that moves held joints is tried on the arm at it (`at_keyframe`).
        """
        arm: Any = self
        if self.coupling is None or self.coupling.closure is None:
            return tuple(arm.keyframe_names)  # nothing to close: no arm loaded again
        return tuple(
            k for k in arm.keyframe_names if (at := arm.at_keyframe(k))._closes(at.keyframe(k))
        )

    def _chain_stack(self, Q: Array) -> tuple[Array, Array]:
        """Chain poses X (n, nx) and G (n, nx, nq) of a stack of the arm's poses ``Q``.

        ``Q`` is checked already (n, nq). Uncoupled: ``Q`` itself and identities.

        Raises:
            PoseError: A loop that cannot close at one of the poses (naming its constraint).
        """
        Q = np.asarray(Q, dtype=float).reshape(-1, self.nq)
        if self.coupling is None:
            return Q.copy(), np.broadcast_to(np.eye(self.nq), (len(Q), self.nq, self.nq))
        maps = [self.coupling.at(q, q.tolist()) for q in Q]
        nx = self.coupling.nx
        X = np.array([c.x for c in maps]).reshape(len(Q), nx)
        G = np.array([c.G for c in maps]).reshape(len(Q), nx, self.nq)
        return X, G


class ChainView:
    """A coupled arm seen as its chain model: every joint it moves is a coordinate.

    What compares the engines' *models* joint by joint (`redundancy.compare_models`) reads a
    coupled arm through this view: the chain's joint names, types, ranges, armature, damping
    and effort limits, and each engine's chain model (the engine under its coupling);
    everything else is the arm's.
    """

    def __init__(self, arm: Any) -> None:
        self._arm = arm
        self.joint_names: tuple[str, ...] = arm.chain_joint_names
        self.joint_types: tuple[str, ...] = tuple(arm._chain_types)
        self.nq = len(self.joint_names)
        self.engines = {n: e.inner for n, e in arm.engines.items()}
        self.lower, self.upper = self.engines["mujoco"].limits
        self.effort_limit: Array = np.asarray(arm._chain_effort_limit, dtype=float)
        self.coupling = None

    @classmethod
    def at(cls, arm: Any, q: ArrayLike | None) -> tuple[ChainView, Array]:
        """The view of ``arm`` and its chain pose at the arm's ``q`` (None: the rest)."""
        x = arm.coupling.rest if q is None else arm.chain_pose(q)
        return cls(arm), np.array(x, dtype=float)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._arm, name)

    @property
    def mujoco(self) -> Any:
        """MuJoCo's engine of the chain model."""
        return self.engines["mujoco"]

    @property
    def pinocchio(self) -> Any:
        """Pinocchio's engine of the chain model."""
        return self.engines["pinocchio"]

    def armature(self, engine: str = "mujoco") -> Array:
        """Armature per chain joint [kg m^2]."""
        return np.asarray(self.engines[engine].armature)

    def damping(self, engine: str = "mujoco") -> Array:
        """Damping per chain joint [N m s/rad or N s/m]."""
        return np.asarray(self.engines[engine].damping)

    def pose(self, x: ArrayLike) -> Array:
        """A checked chain pose [rad or m]."""
        return check_pose(x, self.joint_names)

    def joint_index(self, name: str) -> int:
        """Index of chain joint ``name``."""
        if name not in self.joint_names:
            raise UnknownNameError("joint", name, self.joint_names)
        return self.joint_names.index(name)

    @functools.cached_property
    def keyframes(self) -> dict[str, Array]:
        """The keyframes at which the arm's loops close, as chain poses [rad or m]."""
        arm = self._arm
        return {k: arm.chain_pose(arm.keyframes[k]) for k in arm._reachable_keyframes()}

    @property
    def keyframe_names(self) -> tuple[str, ...]:
        """Names of `keyframes`, in file order."""
        return tuple(self.keyframes)

    def keyframe(self, name: str) -> Array:
        """One of `keyframes` [rad or m]."""
        return self.keyframes[name]

    def __repr__(self) -> str:
        return f"ChainView({self._arm!r})"


#: Draws per pose a coupled arm's sampling may take before it says its followers' ranges
#: leave no room.
_DRAWS_PER_POSE = 200


def coupled_poses(arm: Any, Q: Array, rng: np.random.Generator, lo: Array, hi: Array) -> Array:
    """The draws ``Q`` whose followers stay in their ranges and whose loops close, topped up.

    A pose whose chain pose (`Arm.chain_pose`) puts a follower outside its range, or where
    a loop cannot close, is not drawn: it is replaced by the next draw of the generator.

    Raises:
        PoseError: No pose in ``_DRAWS_PER_POSE`` draws per pose wanted keeps the followers
            in range (naming the follower most often out).
    """
    inner = arm.reference.inner  # type: ignore[attr-defined]
    clo, chi = inner.limits
    names = arm.chain_joint_names
    tol = 1e-9
    out: list[Array] = []
    misses: dict[str, int] = {}
    draws = 0
    pending = list(Q)
    while len(out) < len(Q):
        if not pending:
            if draws > _DRAWS_PER_POSE * max(1, len(Q)):
                worst = max(misses, key=misses.__getitem__) if misses else "a loop"
                raise PoseError(
                    f"no pose of the arm keeps its followers in their ranges in {draws} "
                    f"draws (most often out: {worst!r}); widen the ranges in the file"
                )
            pending = list(rng.uniform(lo, hi, size=(len(Q) - len(out), arm.nq)))
        q = pending.pop(0)
        draws += 1
        try:
            x = arm.chain_pose(q)
        except PoseError:
            misses["a loop"] = misses.get("a loop", 0) + 1
            continue
        bad = np.flatnonzero((x < clo - tol) | (x > chi + tol))
        if bad.size:
            misses[names[bad[0]]] = misses.get(names[bad[0]], 0) + 1
            continue
        out.append(q)
    return np.array(out, dtype=float).reshape(len(Q), arm.nq)

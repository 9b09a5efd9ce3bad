"""How closely the engines agree on one quantity: every pair, and the one that reads it otherwise.

An `Agreement` keeps, per quantity, the largest error over the poses for every pair of engines
(`pair_errors`, each pair's error measured as `redundancy.analysis.crosscheck.quantity_errors`
measures it, scaled by the first engine's value). With three engines or more, the **suspect** is
the one engine that disagrees with every other while they agree among themselves: the engine that
reads the file differently. Two engines that disagree name nobody: either may be the one.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

#: One pair's largest error: (first engine, second engine, error).
PairError = tuple[str, str, float]


def _agrees(error: float, tol: float) -> bool:
    return bool(error <= tol)  # NaN, inf: never


@dataclass(frozen=True)
class Agreement:
    """How closely the engines agree on one quantity over the poses checked.

    Attributes:
        quantity: Name, a key of `TOLERANCES`.
        max_error: Largest error over the poses and the pairs of engines
            ([`quantity_errors`][redundancy.analysis.crosscheck.quantity_errors]).
        tol: The tolerance it is held to.
        worst_pose: Index of the pose where ``max_error`` occurred.
        pairs: Each pair of engines' largest error, ``(a, b, error)``, in engine order.
    """

    quantity: str
    max_error: float
    tol: float
    worst_pose: int
    pairs: tuple[PairError, ...] = ()

    @property
    def ok(self) -> bool:
        """True when the largest error is within the tolerance."""
        return self.max_error <= self.tol

    @property
    def engines(self) -> tuple[str, ...]:
        """The engines compared, in order."""
        return tuple(dict.fromkeys(n for a, b, _ in self.pairs for n in (a, b)))

    @property
    def by_pair(self) -> dict[tuple[str, str], float]:
        """Pair of engine names -> its largest error (both orders)."""
        out = {}
        for a, b, e in self.pairs:
            out[(a, b)] = out[(b, a)] = e
        return out

    @property
    def suspect(self) -> str | None:
        """The one engine that disagrees with all the others while they agree, else None.

        None when every pair agrees, with two engines (either may be wrong), or when the
        disagreements name no single engine.
        """
        engines = self.engines
        if len(engines) < 3 or self.ok:
            return None
        for e in engines:
            mine = [err for a, b, err in self.pairs if e in (a, b)]
            theirs = [err for a, b, err in self.pairs if e not in (a, b)]
            if not any(_agrees(x, self.tol) for x in mine) and all(
                _agrees(x, self.tol) for x in theirs
            ):
                return e
        return None

    def verdict(self) -> str:
        """One line naming who disagrees, for a quantity beyond its tolerance ("" when ok).

        ``"gravity: pinocchio disagrees with mujoco and drake (1.0e-06); mujoco and drake
        agree (2.2e-16)"``; without a suspect, every pair's error.
        """
        if self.ok or not self.pairs:
            return ""
        e = self.suspect
        if e is None:
            each = ", ".join(f"{a}-{b} {x:.1e}" for a, b, x in self.pairs)
            return f"{self.quantity}: no one engine stands out ({each})"
        others = [n for n in self.engines if n != e]
        mine = max(x for a, b, x in self.pairs if e in (a, b))
        theirs = max(x for a, b, x in self.pairs if e not in (a, b))
        names = " and ".join(others)
        return (
            f"{self.quantity}: {e} disagrees with {names} ({mine:.1e}); "
            f"{names} agree ({theirs:.1e})"
        )

    def json(self) -> dict[str, object]:
        """The fields, ``ok``, ``suspect`` and the pairs as ``{"a/b": error}``."""
        return {
            "quantity": self.quantity,
            "max_error": self.max_error,
            "tol": self.tol,
            "worst_pose": self.worst_pose,
            "ok": self.ok,
            "pairs": {f"{a}/{b}": x for a, b, x in self.pairs},
            "suspect": self.suspect,
        }


def engine_pairs(names: Sequence[str]) -> list[tuple[str, str]]:
    """Every pair of engines, in order (the reference's pairs first)."""
    return list(itertools.combinations(names, 2))


def pair_errors(
    stacks: Mapping[str, Array], measure: object, names: Sequence[str]
) -> dict[tuple[str, str], Array]:
    """Per pose, ``measure(a's stack, b's stack)`` for every pair of engines ``names``."""
    return {(a, b): measure(stacks[a], stacks[b]) for a, b in engine_pairs(names)}  # type: ignore[operator]


def largest(errors: Array) -> float:
    """The largest of a pair's errors; any non-finite one wins (a NaN is never hidden)."""
    if len(errors) == 0:
        return 0.0
    bad = errors[~np.isfinite(errors)]
    return float(bad[-1]) if len(bad) else float(np.max(errors))


def merge_pairs(old: tuple[PairError, ...], new: tuple[PairError, ...]) -> tuple[PairError, ...]:
    """Two chunks' pair errors merged: per pair the larger (non-finite wins)."""
    if not old:
        return new
    kept = {(a, b): x for a, b, x in old}

    def pick(x: float, y: float) -> float:
        if not np.isfinite(x):
            return x
        return y if not np.isfinite(y) else max(x, y)

    return tuple((a, b, pick(x, kept.get((a, b), 0.0))) for a, b, x in new)

"""Pose-by-pose agreement of every pair of engines, with a stated tolerance per quantity.

One error measure, max |a - b| / the quantity's scale per pose for each pair of engines a, b (the
scale is max |a| at that pose, never below FLOOR x the quantity's size on the arm: see
[`redundancy.model.scales`][redundancy.model.scales]), and its maximum over the poses
([`quantity_errors`][redundancy.analysis.crosscheck.quantity_errors],
[`worst`][redundancy.analysis.crosscheck.worst]), serves the single-pose and the stacked cross-check
alike: [`crosscheck`][redundancy.crosscheck] and [`crosscheck_batch`][redundancy.crosscheck_batch]
are one computation, over stacks of poses taken in chunks so memory stays flat in their number.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from concurrent.futures import Executor
from dataclasses import dataclass
from typing import Unpack

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..arm import Arm, check_arm
from ..checks import (
    NameDict,
    check_choice,
    check_count,
    check_number,
    check_options,
    check_pose_or_poses,
    check_threads,
)
from ..display import Report, Table, plural, table
from ..engines.contract import Engine, Stacks
from ..engines.threads import MIN_POSES_PER_THREAD, run_beside
from ..errors import ParameterError, UnknownNameError
from ..model.bridges import Bridge
from ..model.scales import Scales, arm_scales, scaled_errors
from ..quantities import QUANTITIES, QUANTITY, Evaluation
from ..quantities import crosscheck_velocities as crosscheck_velocities  # its old home
from .agreement import Agreement, PairError, largest, merge_pairs, pair_errors
from .batch import map_chunks
from .batch_executor import RunOptions

Array = NDArray[np.float64]

#: Tolerance per quantity, on max |mujoco - pinocchio| / the quantity's scale (see
#: [`quantity_errors`][redundancy.analysis.crosscheck.quantity_errors]), from the registry
#: ([`redundancy.quantities`][redundancy.quantities], where each is declared and explained).
TOLERANCES: dict[str, float] = NameDict(((q.name, q.tol) for q in QUANTITIES), "quantity")

#: Quantities computed through M^-1: their tolerance holds for cond(M) up to
#: `CALIBRATED_CONDITION` and grows with it beyond (`conditioned_tolerance`).
M_INVERSE_QUANTITIES = tuple(q.name for q in QUANTITIES if q.m_inverse)
#: The conditioning at which the M^-1 tolerances were set (a generated arm, cond(M) ~ 1e7).
CALIBRATED_CONDITION = 1e7
#: Quantities that need the links' inertias; an arm without them is checked on the others.
DYNAMIC_QUANTITIES = tuple(q.name for q in QUANTITIES if q.dynamic)


def worse_condition(a: float | None, b: float | None) -> float | None:
    """The larger of two condition numbers of M, either of which may be None (not measured)."""
    return b if a is None else a if b is None else max(a, b)


def conditioned_tolerance(name: str, tol: float, condition: float | None) -> float:
    """The tolerance of ``name`` at a mass matrix of condition number ``condition``.

    Solving with M multiplies the engines' rounding of M (relative, ~eps) by cond(M): links
    with mass but (almost) no rotational inertia give cond(M) ~ 1e12 and M^-1 J^T differs
    by ~1e-4 between two correct engines. A quantity computed through M^-1 is held to
    ``tol x max(1, condition / CALIBRATED_CONDITION)``; the others to ``tol``.
    """
    if name not in M_INVERSE_QUANTITIES or condition is None:
        return tol
    return float(tol * max(1.0, condition / CALIBRATED_CONDITION))


@dataclass(frozen=True, repr=False)
class CrossCheckReport(Report):
    """Result of [`crosscheck`][redundancy.crosscheck].

    ``print(report)`` prints the table of
    [`lines`][redundancy.analysis.crosscheck.CrossCheckReport.lines]; in a notebook the report shows
    as an HTML table.

    Attributes:
        agreements: One entry per quantity.
        bridges: Values Pinocchio got from MuJoCo (not independent, so not compared).
        n_poses: Number of poses compared.
        mass_condition: Largest condition number of MuJoCo's M (armature in) over the poses
            where a quantity computed through M^-1 was compared (None: none was).
        skipped: Why quantities were left out (an arm whose links lack inertias), or "".
        engines: The engines compared, the reference first (every pair of them).
    """

    agreements: tuple[Agreement, ...]
    bridges: tuple[Bridge, ...]
    n_poses: int
    mass_condition: float | None = None
    skipped: str = ""
    engines: tuple[str, ...] = ("mujoco", "pinocchio")

    @property
    def checked(self) -> bool:
        """True when at least one pose and one quantity were compared."""
        return self.n_poses > 0 and bool(self.agreements)

    @property
    def ok(self) -> bool:
        """True when something was checked and every quantity agrees within its tolerance.

        A check over no poses is not ok: nothing was shown to agree.
        """
        return self.checked and all(a.ok for a in self.agreements)

    def __getitem__(self, quantity: str) -> Agreement:
        """The agreement on one compared quantity.

        Raises:
            UnknownNameError: A quantity this report did not compare (lists those it did).
        """
        for a in self.agreements:
            if a.quantity == quantity:
                return a
        raise UnknownNameError("compared quantity", quantity, [a.quantity for a in self.agreements])

    def summary(self) -> str:
        """``"ok, 8 quantities over 200 poses"`` (or ``DISAGREE`` naming the quantities)."""
        if not self.checked:
            return f"nothing checked ({plural(self.n_poses, 'pose')})"
        bad = [a.quantity for a in self.agreements if not a.ok]
        verdict = "ok" if not bad else "DISAGREE on " + ", ".join(bad)
        n = plural(len(self.agreements), "quantity", "quantities")
        return f"{verdict}, {n} over {plural(self.n_poses, 'pose')}"

    def html_tables(self) -> list[Table]:
        """One row per quantity: the largest relative difference, the tolerance, ok or not."""
        return [
            table(
                f"{' against '.join(self.engines)} over {plural(self.n_poses, 'pose')}",
                ("quantity", "max rel. diff", "tol", "worst pose", "agree", "suspect"),
                [
                    (
                        a.quantity,
                        f"{a.max_error:.2e}",
                        f"{a.tol:.0e}",
                        a.worst_pose,
                        "ok" if a.ok else "DISAGREE",
                        a.suspect or "",
                    )
                    for a in self.agreements
                ],
                (False, True, True, True, False, False),
            )
        ]

    def html_notes(self) -> list[str]:
        """The bridged quantities (same numbers in both engines, not compared)."""
        return self.lines()[len(self.agreements) + 1 :] if self.checked else self.lines()

    def lines(self) -> list[str]:
        """Human-readable table lines."""
        if not self.checked:
            return [f"nothing checked: {self.n_poses} poses, {len(self.agreements)} quantities"]
        out = [f"{'quantity':<26}{'max rel. diff':>14}{'tol':>9}  over {self.n_poses} poses"]
        for a in self.agreements:
            flag = "ok" if a.ok else "DISAGREE"
            out.append(f"{a.quantity:<26}{a.max_error:>14.2e}{a.tol:>9.0e}  {flag}")
        out += [a.verdict() for a in self.agreements if not a.ok]
        if self.mass_condition is not None and self.mass_condition > CALIBRATED_CONDITION:
            out.append(
                f"cond(M) up to {self.mass_condition:.2g}: the M^-1 tolerances grow with it "
                f"(x cond(M) / {CALIBRATED_CONDITION:.0e})"
            )
        if self.skipped:
            out.append(f"not compared: {self.skipped}")
        into = {b.engine for b in self.bridges}
        for engine in (e for e in self.engines if e in into):
            kinds = sorted({b.quantity for b in self.bridges if b.engine == engine})
            out.append(
                f"bridged from MuJoCo into {engine} (same numbers, not compared): "
                + ", ".join(kinds)
            )
        return out


def quantity_names(quantities: Iterable[str] | None) -> tuple[str, ...]:
    """The quantities to compare: all of `TOLERANCES` by default.

    Raises:
        UnknownNameError: A name that is not a key of `TOLERANCES` (lists the valid ones).
    """
    if isinstance(quantities, str):
        quantities = (quantities,)
    if quantities is not None and not isinstance(quantities, Iterable):
        raise ParameterError(
            "quantities", quantities, f"None, a name or names of {list(TOLERANCES)}"
        )
    names = tuple(TOLERANCES) if quantities is None else tuple(quantities)
    for name in names:
        check_choice("quantity", name, tuple(TOLERANCES))
    return names


def tolerances_for(names: Iterable[str], overrides: dict[str, float] | None) -> dict[str, float]:
    """`TOLERANCES` with overrides, each checked to be a finite number >= 0.

    Raises:
        UnknownNameError: An override for a quantity that does not exist.
        ParameterError: A tolerance that is NaN, infinite or negative.
    """
    tols = dict(TOLERANCES)
    if overrides is not None and not isinstance(overrides, Mapping):
        raise ParameterError("tolerances", overrides, "None or a dict: quantity -> tolerance")
    for name, tol in (overrides or {}).items():
        check_choice("quantity", name, tuple(TOLERANCES))
        tols[name] = check_number(f"tolerance for {name!r}", tol, 0.0)
    return {n: tols[n] for n in names}


def quantity_errors(name: str, a: Array, b: Array, scales: Scales) -> Array:
    """Per pose, the library's error measure for one quantity of `TOLERANCES`.

    max |a - b| / max(max |a|, FLOOR x size) over one pose's value
    ([`scaled_errors`][redundancy.model.scales.scaled_errors]), the size being the quantity's size
    on the arm: its length L for the site position, 1 for the rotation, ``m L^2`` for the mass
    matrices, ``m g L`` for gravity, L^3 for the manipulability gradient (six joints or more;
    `Scales.manipulability`). The Jacobian and its
    derivatives are measured per block of rows, linear (size L) and angular (size 1), since their
    units differ. J M^-1 J^T's blocks ([1/m], [1/(m L^2)], [1/(m L)]) are each divided by their
    size and measured as one value (M^-1 carries the engines' rounding of J from one block into
    the others at its own size). The dynamic manipulability is measured through its factors,
    the singular values of M^-1 J^T.

    Args:
        name: A key of `TOLERANCES`.
        a: MuJoCo's values, stacked (n, ...).
        b: Pinocchio's values, same shape.
        scales: The arm's scales ([`arm_scales`][redundancy.model.scales.arm_scales]).

    Returns:
        Errors, shape (n,); NaN or inf where a value is not finite.
    """
    quantity = QUANTITY[name]
    blocks = quantity.blocks(scales)
    if len(blocks) == 1 and blocks[0][0] == ():
        return scaled_errors(a, b, blocks[0][1])
    if quantity.one_scale:  # each block in units of its size, then one value of size 1

        def in_sizes(x: Array) -> Array:
            return np.concatenate([(x[(..., *i)] / s).reshape(len(x), -1) for i, s in blocks], 1)

        return scaled_errors(in_sizes(a), in_sizes(b), 1.0)
    # A NaN in any block stays NaN.
    return np.maximum.reduce([scaled_errors(a[(..., *i)], b[(..., *i)], s) for i, s in blocks])


def worst(err: Array) -> tuple[float, int]:
    """Largest error and its pose: the first strict maximum; any non-finite error wins.

    A non-finite error (an engine returned NaN) outranks every finite one, and the last
    non-finite one is kept, so a report never hides a NaN behind a small number.
    """
    if len(err) == 0:
        return 0.0, 0
    nonfinite = np.flatnonzero(~np.isfinite(err))
    if len(nonfinite):
        p = int(nonfinite[-1])
        return float(err[p]), p
    p = int(np.argmax(err))
    if err[p] > 0.0:
        return float(err[p]), p
    return 0.0, 0


def merge_worst(old: tuple[float, int], new: tuple[float, int], offset: int) -> tuple[float, int]:
    """Combine the worst of an earlier chunk with a later chunk's, by `worst`'s rules.

    ``new``'s pose is counted from ``offset``, the later chunk's first pose.
    """
    (e0, p0), (e1, p1) = old, new
    if not np.isfinite(e1):
        return e1, p1 + offset
    if not np.isfinite(e0) or e1 <= e0:
        return e0, p0
    return e1, p1 + offset


#: Quantities computed by the engines' stacked evaluation (one kinematics pass per pose);
#: the others (second-order kinematics) are computed pose by pose.
BATCH_QUANTITIES: tuple[str, ...] = tuple(q.name for q in QUANTITIES if q.batched)

#: Poses per chunk: the stacks of one chunk take about 4 KB per pose for a 7-dof arm.
CHUNK = 2048


def _evaluate(
    engine: Engine, Q: Array, names: tuple[str, ...], threads: int, seed: int = 0
) -> dict[str, Array]:
    """Every requested quantity over the stack ``Q`` from one engine (the registry's stacks)."""
    work = Evaluation(engine, Q, names, threads, seed)
    return {name: QUANTITY[name].stack(work) for name in names}


def _compared(arm: Arm) -> list[Engine]:
    """The engines compared with the reference: every other one."""
    return [e for e in arm.engines.values() if e is not arm.reference]


def _all_engines(
    arm: Arm, Q: Array, names: tuple[str, ...], threads: int, seed: int = 0
) -> dict[str, dict[str, Array]]:
    """Every engine's stacks for ``Q``, keyed by engine name.

    With threads, the reference engine (MuJoCo, whose ``mj_*`` calls release the GIL) runs
    in one worker thread beside the others in the caller's, which get the ``threads - 1``
    threads left (Pinocchio's gravity): never more threads busy than ``threads``.
    """
    out: dict[str, dict[str, Array]] = {}

    def fill(engine: Engine, k: int) -> None:
        out[engine.name] = _evaluate(engine, Q, names, k, seed)

    def others(k: int) -> None:
        for engine in _compared(arm):
            fill(engine, k)

    # The others get no more OpenMP threads than the reference leaves free: Pinocchio's
    # rneaInParallel workers busy-wait ~5 ms after each call (libgomp's default), once per
    # chunk, on the CPU that MuJoCo's thread and the next chunk's Pinocchio loops need. With
    # gravity on all ``threads`` beside MuJoCo, 2 threads took 118 ms against 72 ms for 1
    # (arm7, 10 000 poses). Below MIN_POSES_PER_THREAD poses no thread pays, OpenMP's included.
    if threads > 1 and len(Q) >= MIN_POSES_PER_THREAD:
        # The reference runs on one thread: run_split in a worker runs its spans one after another.
        run_beside(lambda: others(threads - 1), lambda: fill(arm.reference, 1))
    else:
        others(1)
        fill(arm.reference, 1)
    return out


def _agreement_errors(
    arm: Arm, name: str, out: dict[str, dict[str, Array]], scales: Scales
) -> tuple[Array, tuple[PairError, ...]]:
    """Per pose, the largest error of any pair of engines on ``name``; each pair's largest."""
    stacks = {e: out[e][name] for e in arm.engines}
    pairs = pair_errors(stacks, lambda a, b: quantity_errors(name, a, b, scales), list(stacks))
    errors = list(pairs.values())
    per_pose = errors[0] if len(errors) == 1 else np.maximum.reduce(errors)  # NaN stays NaN
    return per_pose, tuple((a, b, largest(e)) for (a, b), e in pairs.items())


class CrossCheckOptions(RunOptions, total=False):
    """How `crosscheck` takes its poses, and where it runs.

    Attributes:
        threads: With 2 or more (and at least ``MIN_POSES_PER_THREAD`` poses in a chunk),
            the reference engine runs in a worker thread (MuJoCo's ``mj_*`` calls release
            the GIL) beside the other in the caller's thread, and Pinocchio's gravity uses
            the other ``threads - 1`` as OpenMP threads (default 1).
        executor: Run on this `concurrent.futures.Executor` (a Dask cluster's
            ``Client(...).get_executor()``, a process pool), in chunks of poses each
            cross-checked on a worker (`redundancy.batch.map_chunks`); None (default) runs
            here. The report is the same, bit for bit: the worst pose of the chunks is
            merged as within one process.
        chunk: Poses per chunk (>= 1; default `CHUNK`).
        seed: Seed of the joint velocities paired with the poses for ``"coriolis"``
            (`crosscheck_velocities`), an integer >= 0 (default 0).
    """

    chunk: int
    seed: int


def crosscheck(
    arm: Arm,
    poses: ArrayLike,
    quantities: Iterable[str] | None = None,
    tolerances: dict[str, float] | None = None,
    **options: Unpack[CrossCheckOptions],
) -> CrossCheckReport:
    """Compare each engine with the reference at one pose or over a stack of poses.

    The stacks are taken ``chunk`` poses at a time, so memory does not grow with the number
    of poses; errors, worst poses and the report do not depend on ``chunk`` or ``threads``.

    Args:
        arm: The arm.
        poses: One pose, shape (nq,), or many, shape (n, nq) [rad or m].
        quantities: Subset of `TOLERANCES` keys; all by default.
        tolerances: Overrides for `TOLERANCES` (finite, >= 0).
        **options: ``threads``, ``executor``, ``chunk`` and ``seed``, as
            [`CrossCheckOptions`][redundancy.analysis.crosscheck.CrossCheckOptions] states.

    Returns:
        The report; over zero poses it says that nothing was checked and is not ``ok``.

    Raises:
        UnknownNameError: A quantity that is not a key of `TOLERANCES`, or a keyword that is
            not one of the options.
        ParameterError: A bad tolerance, thread count or chunk size.
        PoseError: Bad poses.
    """
    arm = check_arm(arm)
    names = quantity_names(quantities)
    skipped = ""
    if quantities is None and arm.missing_inertia:
        names = tuple(n for n in names if n not in DYNAMIC_QUANTITIES)
        skipped = f"{', '.join(DYNAMIC_QUANTITIES)}: no inertia for " + ", ".join(
            repr(n) for n in arm.missing_inertia
        )
    tols = tolerances_for(names, tolerances)
    check_options(options, CrossCheckOptions)
    threads, executor = check_threads(options.get("threads", 1)), options.get("executor")
    chunk = check_count("chunk", options.get("chunk", CHUNK), 1)
    seed = check_count("seed", options.get("seed", 0), 0)
    Q = check_pose_or_poses(poses, arm.joint_names)
    found = dict.fromkeys(names, (0.0, 0))
    pairs: dict[str, tuple[PairError, ...]] = dict.fromkeys(names, ())
    condition = _crosscheck_chunks(
        executor, arm, Q, names, tols, threads, chunk, seed, found, pairs
    )
    agreements = tuple(
        Agreement(
            n, found[n][0], conditioned_tolerance(n, tols[n], condition), found[n][1], pairs[n]
        )
        for n in names
    )
    bridges = arm.bridges + arm.drake_bridges
    return CrossCheckReport(agreements, bridges, len(Q), condition, skipped, tuple(arm.engines))


def crosscheck_batch(
    arm: Arm,
    Q: ArrayLike,
    quantities: Iterable[str] | None = None,
    tolerances: dict[str, float] | None = None,
    threads: int = 1,
    chunk: int = CHUNK,
    executor: Executor | None = None,
    *,
    seed: int = 0,
) -> CrossCheckReport:
    """`crosscheck` with its options also by position: the same computation, the same report.

    Arguments as [`crosscheck`][redundancy.crosscheck] (``Q`` is its ``poses``).
    """
    options = CrossCheckOptions(threads=threads, chunk=chunk, executor=executor, seed=seed)
    return crosscheck(arm, Q, quantities, tolerances, **options)


def _crosscheck_chunks(
    executor: Executor | None,
    arm: Arm,
    Q: Array,
    names: tuple[str, ...],
    tols: dict[str, float],
    threads: int,
    chunk: int,
    seed: int,
    found: dict[str, tuple[float, int]],
    pairs: dict[str, tuple[PairError, ...]],
) -> float | None:
    """`crosscheck_batch` ``chunk`` poses at a time, on the executor's workers or (None) here.

    Each quantity's worst error and pose are merged into ``found``, its pairs' largest
    errors into ``pairs``; returns the largest
    condition number of the mass matrix, None where no quantity through M^-1 was compared.
    """
    condition: float | None = None
    if executor is not None:
        kwargs = {
            "quantities": names,
            "tolerances": tols,
            "threads": threads,
            "chunk": chunk,
            "seed": seed,
        }
        for lo, part in map_chunks(executor, crosscheck_batch, arm, Q, **kwargs):
            for a in part.agreements:
                found[a.quantity] = merge_worst(found[a.quantity], (a.max_error, a.worst_pose), lo)
                pairs[a.quantity] = merge_pairs(pairs[a.quantity], a.pairs)
            condition = worse_condition(condition, part.mass_condition)
        return condition
    scales = arm_scales(arm)
    for lo in range(0, len(Q), chunk):
        part = Q[lo : lo + chunk]
        out = _all_engines(arm, part, names, threads, seed)
        for name in names:
            errors, each = _agreement_errors(arm, name, out, scales)
            found[name] = merge_worst(found[name], worst(errors), lo)
            pairs[name] = merge_pairs(pairs[name], each)
        if set(names) & set(M_INVERSE_QUANTITIES) and len(part):
            # The reference's M with armature, when compared.
            M = out[arm.reference.name].get("mass matrix")
            condition = worse_condition(condition, mass_condition(arm, part, M))
    return condition


def mass_condition(arm: Arm, Q: Array, M: Array | None = None) -> float:
    """Largest condition number of the reference's mass matrix (armature in) over ``Q``.

    ``M``: those mass matrices when already computed, shape (n, nq, nq).
    """
    if M is None:
        stacks = Stacks.empty(len(Q), arm.nq, "M")
        arm.reference.evaluate(Q, stacks)
        M = stacks.M
    return float(np.max(np.linalg.cond(M)))

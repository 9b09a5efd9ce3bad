"""``redundancy audit``: everything the library knows about an arm, and what to act on.

The audit takes the shared `sections` (joints and timesteps, keyframes, gravity against the
actuators, self-collision), adds the engines' agreement and the model comparison, and *judges*
what the file says (`redundancy.reports.judging`): a
[`Finding`][redundancy.reports.findings.Finding] only where the model's own numbers show a
problem (a keyframe the actuators cannot hold, a timestep above the stable bound of the damping
the model has, engines that disagree); what the file's format cannot express (a URDF's armature,
actuators, timestep and integrator) is a [`Note`][redundancy.reports.findings.Note], never a
finding. Numbers follow what MuJoCo simulates: the integrator and its flags, gravity
compensation, actuator ranges per direction, servo damping. The explicit-damping question (which
timestep a controller's kd allows) is asked only with ``kd`` or of a model whose servos have
damping of their own. The report's text and JSON are in `redundancy.reports.audit_report`.
"""

from __future__ import annotations

from ..analysis.agreement import merge_pairs
from ..analysis.crosscheck import (
    BATCH_QUANTITIES,
    DYNAMIC_QUANTITIES,
    TOLERANCES,
    Agreement,
    CrossCheckReport,
    crosscheck_batch,
    merge_worst,
    worse_condition,
)
from ..arm import Arm
from ..checks import check_count, check_number
from ..model.equivalence import compare_models
from . import sections
from .audit_report import (
    SINGULAR_SIGMA,
    AuditReport,
    EngineAgreement,
    Finding,
    Note,
    RobotPart,
    format_report,
)
from .judging import ILL_CONDITIONED, judge, quoted
from .sections import Progress, Sections
from .tables import exclusion

__all__ = [
    "CROSSCHECK_POSES",
    "ILL_CONDITIONED",
    "SINGULAR_SIGMA",
    "AuditReport",
    "EngineAgreement",
    "Finding",
    "Note",
    "RobotPart",
    "audit",
    "exclusion",
    "format_report",
]

#: Poses on which the second-order quantities (dJ/dq, manipulability gradient) are
#: cross-checked; the others are checked on every pose of the gravity sweep.
CROSSCHECK_POSES = 200


def audit(
    arm: Arm,
    n_poses: int = 10_000,
    seed: int = 0,
    kd: float | None = None,
    computed: Sections | None = None,
    mode: str = "strict",
    progress: Progress | None = None,
) -> AuditReport:
    """Audit an arm: every section of the report, the findings and the notes.

    Args:
        arm: The loaded arm.
        n_poses: Random poses for the gravity and self-collision sweeps (>= 1).
        seed: Seed of the random poses (>= 0); both sweeps and the cross-check use them.
        kd: Controller damping written to ``ctrl`` at which timesteps are judged
            [N m s/rad]; ``None``: none assumed, only the damping the model has (the
            joints' own, a servo's ``kv``) bounds the timestep.
        computed: Sections already computed with these arguments.
        mode: ``"strict"`` or ``"lenient"``: how the arm was loaded (recorded in the report).
        progress: Called as each sweep advances (see `redundancy.reports.sections.Progress`).

    Raises:
        ParameterError: ``n_poses`` or ``seed`` out of range, ``kd`` negative or not finite.
    """
    n_poses = check_count("n_poses", n_poses, 1)
    seed = check_count("seed", seed, 0)
    kd = None if kd is None else check_number("kd", kd, 0.0, unit="N m s/rad")
    say = progress or sections._quiet
    if computed is None:
        computed = sections.compute(arm, n_poses, seed, kd, progress=say)
    g = computed.gravity
    engines = _engines(arm, n_poses, seed, None if g is None else g.agreement, say)
    findings, notes = judge(arm, computed, engines)
    return AuditReport(
        str(arm.source),
        arm.frame,
        mode,
        computed,
        engines,
        findings,
        notes,
        arm.model_format,
        RobotPart.of(arm),
        None if arm.missing_inertia else sections.contact_mass(arm, n_poses, seed),
    )


def _engines(
    arm: Arm, n_poses: int, seed: int, gravity: Agreement | None, say: Progress
) -> EngineAgreement:
    """Cross-check over the gravity sweep's poses, chunk by chunk, and compare the models.

    ``gravity`` is the sweep's own row (it computed both engines' gravity on these poses);
    None when the arm's links lack inertias: then only the kinematic quantities are compared.
    """
    skip = set(DYNAMIC_QUANTITIES) if arm.missing_inertia else set()
    skip |= {"gravity"}  # the sweep's own row, or nothing to compare
    batched = tuple(q for q in BATCH_QUANTITIES if q not in skip)
    rest = tuple(q for q in TOLERANCES if q not in BATCH_QUANTITIES and q not in skip)
    merged: dict[str, Agreement] = {} if gravity is None else {gravity.quantity: gravity}
    condition: float | None = None
    offset, second = 0, 0
    say("engine cross-check", 0, n_poses)
    for Q in sections.pose_chunks(arm, n_poses, seed):
        parts = crosscheck_batch(arm, Q, quantities=batched).agreements
        if offset < CROSSCHECK_POSES:
            head = Q[: CROSSCHECK_POSES - offset]
            # The Coriolis row's velocities are drawn from the audit's seed too.
            velocity_seed = 0 if seed is None else seed
            second_order = crosscheck_batch(arm, head, quantities=rest, seed=velocity_seed)
            parts += second_order.agreements
            condition = worse_condition(condition, second_order.mass_condition)
            second += len(head)
        for a in parts:
            merged[a.quantity] = _worse(merged.get(a.quantity), a, offset)
        offset += len(Q)
        say("engine cross-check", offset, n_poses)
    agreements = tuple(merged[q] for q in (*BATCH_QUANTITIES, *rest) if q in merged)
    skipped = (
        f"{', '.join(DYNAMIC_QUANTITIES)}: no inertia for {quoted(list(arm.missing_inertia))}"
        if arm.missing_inertia
        else ""
    )
    bridges = arm.bridges + arm.drake_bridges
    cc = CrossCheckReport(agreements, bridges, n_poses, condition, skipped, tuple(arm.engines))
    return EngineAgreement(cc, second, compare_models(arm))


def _worse(kept: Agreement | None, new: Agreement, offset: int) -> Agreement:
    """The worse of two chunks' agreements, by `redundancy.crosscheck`'s rules."""
    if kept is None:
        return Agreement(new.quantity, new.max_error, new.tol, new.worst_pose + offset, new.pairs)
    error, pose = merge_worst(
        (kept.max_error, kept.worst_pose), (new.max_error, new.worst_pose), offset
    )
    return Agreement(new.quantity, error, new.tol, pose, merge_pairs(kept.pairs, new.pairs))

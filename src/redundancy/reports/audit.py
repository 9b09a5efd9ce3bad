"""``redundancy audit``: everything the library knows about an arm, and what to act on.

The audit takes the shared `sections` (joints and timesteps, keyframes, gravity against the
actuators, self-collision), adds the engines' agreement and the model comparison, and *judges* what
the file says: a [`Finding`][redundancy.reports.audit.Finding] only where the model's own numbers
show a problem (a keyframe the actuators cannot hold, a timestep above the stable bound of the
damping the model has, engines that disagree); what the file's format cannot express (a URDF's
armature, actuators, timestep and integrator) is a [`Note`][redundancy.reports.audit.Note], never a
finding. Numbers follow what MuJoCo simulates: the integrator and its flags, gravity compensation,
actuator ranges per direction, servo damping. The explicit-damping question (which timestep a
controller's kd allows) is asked only with ``kd`` or of a model whose servos have damping of their
own.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from ..analysis.crosscheck import (
    BATCH_QUANTITIES,
    DYNAMIC_QUANTITIES,
    TOLERANCES,
    Agreement,
    CrossCheckReport,
    crosscheck_batch,
    merge_worst,
)
from ..arm import FROZEN, Arm
from ..checks import check_count, check_number
from ..collision import CollisionStatistics, GeomPair
from ..display import Report, Table, json_ready, plural, to_json
from ..display import table as html_table
from ..model.equivalence import EquivalenceReport, compare_models
from . import sections
from .sections import GravityBudget, JointSection, KeyframeRow, Progress, Sections
from .tables import fit, fmt, key, limit, ms, table

#: A keyframe is singular when sigma_min of its site Jacobian is below this [m/rad or rad/rad].
SINGULAR_SIGMA = 1e-3
#: Condition number of M above which the model is reported as ill-conditioned: M^-1's
#: rounding (cond(M) x eps) passes 1e-7 relative.
ILL_CONDITIONED = 1e9
#: Poses on which the second-order quantities (dJ/dq, manipulability gradient) are
#: cross-checked; the others are checked on every pose of the gravity sweep.
CROSSCHECK_POSES = 200


@dataclass(frozen=True)
class Finding:
    """Something in the model a user should act on.

    Attributes:
        kind: Category: ``armature``, ``timestep``, ``simulation``, ``gravity``,
            ``keyframe``, ``engines``.
        message: What is wrong and where, with the numbers.
    """

    kind: str
    message: str


@dataclass(frozen=True)
class Note:
    """What the audit cannot judge from the file, and what it assumed instead.

    Attributes:
        kind: Category: ``format`` (the file's format cannot express it), ``armature``,
            ``timestep``.
        message: What is missing and what the numbers use in its place.
    """

    kind: str
    message: str


@dataclass(frozen=True)
class EngineAgreement:
    """The two engines, pose by pose and model against model.

    Attributes:
        crosscheck: Agreement per quantity over the gravity sweep's poses.
        second_order_poses: Poses on which dJ/dq and the manipulability gradient were checked.
        equivalence: MuJoCo's compiled model against Pinocchio's.
    """

    crosscheck: CrossCheckReport
    second_order_poses: int
    equivalence: EquivalenceReport


@dataclass(frozen=True)
class RobotPart:
    """The robot around the arm, as the audit reports it.

    Attributes:
        held: Held joint -> its rest value [rad or m] (a tuple for a ball or free joint).
        rest: Where the held values come from (``"qpos0"``, ``"keyframe 'name'"``, ``"given"``).
        base: The body the arm's chain starts below, or None (the world).
        set_aside: What in the file does not reach the arm, each with the reason.
        frozen: Joints the file lets move that never move here -> why (``arm.frozen``).
        mended: What the loader read or mended that the arm does depend on (a link the arm
            moves whose published inertia MuJoCo rejects, a mesh read with trimesh), each
            with what was done.
    """

    held: dict[str, float | tuple[float, ...]]
    rest: str
    base: str | None
    set_aside: tuple[str, ...]
    frozen: dict[str, str] = field(default_factory=dict)
    mended: tuple[str, ...] = ()

    @classmethod
    def of(cls, arm: Arm) -> RobotPart:
        """The arm's robot part."""
        items = arm.set_aside
        aside = tuple(
            str(a) for a in items if a.what not in FROZEN and not getattr(a, "reaches_arm", False)
        )
        mended = tuple(str(a) for a in items if getattr(a, "reaches_arm", False))
        return cls(dict(arm.held), arm.rest, arm.base, aside, arm.frozen, mended)


@dataclass(frozen=True, repr=False)
class AuditReport(Report):
    """All sections of an audit, the engines' agreement, and the findings.

    ``print(report)`` prints the text report
    ([`lines`][redundancy.reports.audit.AuditReport.lines]); a notebook shows the findings, the
    keyframes and the engines' agreement as tables, with the full text folded below.

    Attributes:
        model: The model file (or ``"<string>"``).
        site: The tool frame (a site of MuJoCo's model: an MJCF site, a URDF link).
        mode: ``"strict"`` or ``"lenient"`` (loaded with ``strict=False``: what Pinocchio reads
            differently is a finding, not a refusal).
        sections: Joints, keyframes, gravity, self-collision.
        engines: Cross-check and model equivalence.
        findings: What to act on.
        notes: What the file does not say, and what the audit assumed instead.
        model_format: ``"MJCF"`` or ``"URDF"``.
        robot: The rest of the robot: the joints held off the arm and what was set aside.
        contact_mass: The effective mass at the tool beside ISO/TS 15066's estimate.
    """

    model: str
    site: str
    mode: str
    sections: Sections
    engines: EngineAgreement
    findings: tuple[Finding, ...]
    notes: tuple[Note, ...] = ()
    model_format: str = "MJCF"
    robot: RobotPart | None = None
    contact_mass: sections.ContactMass | None = None

    @property
    def exit_code(self) -> int:
        """The CLI's status: 1 with findings, 0 without."""
        return 1 if self.findings else 0

    def to_dict(self) -> dict[str, Any]:
        """The report as plain data (the ``--json`` document)."""
        s = self.sections
        j, g, c, t = s.joints, s.gravity, s.contacts, s.touching
        urdf = self.model_format == "URDF"
        cc, eq = self.engines.crosscheck, self.engines.equivalence
        gravity = (
            None
            if g is None
            else {
                **{k: v for k, v in asdict(g).items() if k != "agreement"},  # in "crosscheck"
                "peak": g.peak,
                "ratio": g.ratio,
            }
        )
        doc = {
            "model": self.model,
            "format": self.model_format,
            "frame": self.site,
            "mode": self.mode,
            "simulation": asdict(j.simulation),
            "kd": j.kd,
            "reference_keyframe": j.keyframe,
            "timestep_note": j.note,
            "joints": [{**asdict(r), "armature_share": r.armature_share} for r in j.rows],
            "keyframes": [
                {
                    "name": k.name,
                    "q": k.q,
                    "sigma": k.svd.sigma,
                    "rank": k.svd.rank,
                    "manipulability": k.svd.manipulability,
                    "condition": k.svd.condition,
                    "lost_directions": k.svd.lost_direction_names(),
                    "engine_sigma_diff": k.engine_diff,
                    "hold": k.hold,
                    "effort_lower": k.effort_lower,
                    "effort_upper": k.effort_upper,
                    "moves_held": k.moves_held,
                }
                for k in s.keyframes
            ],
            "gravity": gravity,
            "collision": {
                "n_poses": c.n_poses,
                "seed": c.seed,
                "share_with_contact": c.share_with_contact,
                "touching_everywhere": [
                    {"pair": p.pair.label, "poses": p.poses, **exclusion(p.pair, urdf)}
                    for p in (t.pairs if t is not None else ())
                ],
                "share_with_contact_without_them": (
                    c.share_with_contact if t is None else t.share_with_contact
                ),
                "n_pairs": len(c.pairs),
                "disagreements": c.disagreements,
                "pairs": [
                    {
                        "pair": p.pair.label,
                        "poses": p.poses,
                        "contacts": p.contacts,
                        "closest": p.closest,
                    }
                    for p in sorted(c.pairs, key=lambda p: (-p.poses, p.closest))
                ],
                "keyframes": [
                    {
                        "name": k.keyframe,
                        "contacts": k.contacts,
                        "closest_pair": k.closest.pair.label if k.closest else None,
                        "closest_distance": k.closest.distance if k.closest else None,
                        "moves_held": k.moves_held,
                    }
                    for k in c.keyframes
                ],
            },
            "crosscheck": {
                "n_poses": cc.n_poses,
                "n_poses_second_order": self.engines.second_order_poses,
                "ok": cc.ok,
                "mass_condition": cc.mass_condition,
                "skipped": cc.skipped,
                "quantities": [{**asdict(a), "ok": a.ok} for a in cc.agreements],
            },
            "equivalence": {
                "equivalent": eq.equivalent,
                "differences": [str(d) for d in eq.differences],
                "bridged": [asdict(b) for b in eq.bridges],
            },
            "robot": None if self.robot is None else asdict(self.robot),
            "notes": [asdict(n) for n in self.notes],
            "findings": [asdict(f) for f in self.findings],
            "contact_mass": None if self.contact_mass is None else asdict(self.contact_mass),
        }
        return json_ready(doc)

    def to_json(self) -> str:
        """The report as a JSON document (infinite or NaN values as null)."""
        return to_json(self.to_dict())

    def lines(self) -> list[str]:
        """The report as text lines."""
        return format_report(self)

    def summary(self) -> str:
        """The model, the tool frame and the number of findings."""
        return f"{self.model} ({self.site}): {plural(len(self.findings), 'finding')}"

    def html_tables(self) -> list[Table]:
        """Findings, keyframes, and the engines' agreement."""
        keys = [
            (
                k.name,
                f"{k.svd.rank}",
                fmt(float(k.svd.sigma[-1])),
                fmt(k.svd.manipulability),
                fmt(k.svd.condition),
                ", ".join(k.svd.lost_direction_names()) or "-",
            )
            for k in self.sections.keyframes
        ]
        return [
            html_table(
                plural(len(self.findings), "finding"),
                ("kind", "finding"),
                [(f.kind, f.message) for f in self.findings],
            ),
            html_table(
                "keyframes: the tool Jacobian",
                ("keyframe", "rank", "sigma min", "manipulability", "condition", "lost"),
                keys,
                (False, True, True, True, True, False),
            ),
            *self.engines.crosscheck.html_tables(),
        ]

    def html_text(self) -> list[str]:
        """The whole text report."""
        return self.lines()


# -- the audit ------------------------------------------------------------------------------------
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
    urdf = arm.model_format == "URDF"
    judged = _Judged()
    _judge_inertia(judged, arm, engines)
    _judge_joints(judged, computed.joints, urdf)
    _judge_simulation(judged, computed)
    _judge_keyframes(judged, arm, computed)
    if g is not None:
        _judge_gravity(judged, arm, g, computed.joints, urdf)
    _judge_engines(judged, engines, computed.contacts)
    _judge_touching(judged, computed.touching, urdf)
    for defect in arm.defects:  # a published value MuJoCo rejects, on a body the arm moves
        judged.finding("published inertia", defect)
    return AuditReport(
        str(arm.source),
        arm.site,
        mode,
        computed,
        engines,
        tuple(judged.findings),
        tuple(judged.notes),
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
    condition = np.nan
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
            condition = np.fmax(condition, second_order.mass_condition)
            second += len(head)
        for a in parts:
            merged[a.quantity] = _worse(merged.get(a.quantity), a, offset)
        offset += len(Q)
        say("engine cross-check", offset, n_poses)
    agreements = tuple(merged[q] for q in (*BATCH_QUANTITIES, *rest) if q in merged)
    skipped = (
        f"{', '.join(DYNAMIC_QUANTITIES)}: no inertia for {_names(list(arm.missing_inertia))}"
        if arm.missing_inertia
        else ""
    )
    cc = CrossCheckReport(agreements, arm.bridges, n_poses, float(condition), skipped)
    return EngineAgreement(cc, second, compare_models(arm))


def _worse(kept: Agreement | None, new: Agreement, offset: int) -> Agreement:
    """The worse of two chunks' agreements, by `redundancy.crosscheck`'s rules."""
    if kept is None:
        return Agreement(new.quantity, new.max_error, new.tol, new.worst_pose + offset)
    error, pose = merge_worst(
        (kept.max_error, kept.worst_pose), (new.max_error, new.worst_pose), offset
    )
    return Agreement(new.quantity, error, new.tol, pose)


# -- judging --------------------------------------------------------------------------------------
class _Judged:
    """Findings and notes, in the order the report gives them."""

    def __init__(self) -> None:
        self.findings: list[Finding] = []
        self.notes: list[Note] = []

    def finding(self, kind: str, message: str) -> None:
        self.findings.append(Finding(kind, message))

    def note(self, kind: str, message: str) -> None:
        self.notes.append(Note(kind, message))


def _names(names: list[str]) -> str:
    return ", ".join(repr(n) for n in names)


def _judge_inertia(out: _Judged, arm: Arm, e: EngineAgreement) -> None:
    """What the model's inertias do not allow: skipped sections, an ill-conditioned M."""
    if arm.missing_inertia:
        links = _names(list(arm.missing_inertia))
        for section in (
            "the gravity budget",
            "the keyframes' holding torques",
            "M_ii and the timestep bounds",
            "the effective mass at the tool",
            f"the engines' cross-check of {', '.join(DYNAMIC_QUANTITIES)}",
        ):
            out.note("inertia", f"skipped {section}: the file gives no inertia for {links}")
    kappa = e.crosscheck.mass_condition
    if np.isfinite(kappa) and kappa > ILL_CONDITIONED:
        out.finding(
            "inertia",
            f"the mass matrix is ill-conditioned: cond(M) up to {kappa:.2g} (links with mass "
            "but almost no rotational inertia?); anything solved with M (effective mass, "
            f"operational inertia, accelerations) carries a relative rounding of about "
            f"{kappa * np.finfo(float).eps:.1g}, in either engine",
        )


def _judge_joints(out: _Judged, j: JointSection, urdf: bool) -> None:
    h = j.simulation.timestep
    rows = j.rows
    arma = np.array([r.armature for r in rows])
    if urdf:
        out.note(
            "format",
            "URDF cannot express armature (a geared joint's rotor inertia N^2 J_rotor): the "
            "mass matrix has none",
        )
        out.note(
            "format",
            "URDF cannot express actuators: each joint's <limit effort> is the limit MuJoCo "
            "applies (actuatorfrcrange), the gravity budget's limit",
        )
        out.note(
            "format",
            f"URDF cannot express the timestep or the integrator: MuJoCo's defaults "
            f"({_h(h)}, {j.simulation.integrator}) are used",
        )
    else:
        zero = [r.name for r in rows if r.armature == 0.0]
        if zero:
            out.note(
                "armature",
                f"zero armature on {_names(zero)}: a geared joint's rotor inertia N^2 J_rotor "
                "is missing unless the joint is direct-drive",
            )
        if len(set(np.round(arma, 12))) == 1 and arma[0] > 0 and len(arma) > 1:
            out.note(
                "armature",
                f"every joint has the same armature {arma[0]:g} kg m^2: reflected inertia is "
                "N^2 J_rotor and differs between a shoulder and a wrist motor",
            )
    for r in rows:
        if h > 0 and h >= r.h_max:
            kd = f"kd {r.kd:g} N m s/rad written to ctrl" if j.kd is not None else ""
            damping = f"explicit damping {r.explicit:g}, implicit {r.implicit:g} N m s/rad" + (
                f", explicit stiffness {r.stiffness:g} N m/rad" if r.stiffness else ""
            )
            text = (
                f"timestep {_h(h)} is above the h_max {r.h_max * 1e3:.3g} ms of joint "
                f"{r.name!r} (M_ii {r.m_ii:.4g} kg m^2, {damping}"
                + (f", {kd}" if kd else "")
                + f"; {j.note}): the joint's speed will grow step by step"
            )
            if urdf:  # the file sets no timestep: the bound tells the user which to choose
                out.note("timestep", f"MuJoCo's default {text}")
            else:
                out.finding("timestep", text)
    if h <= 0:
        out.finding("timestep", f"timestep {h:g} s is not positive: MuJoCo cannot step the model")


def _judge_simulation(out: _Judged, s: Sections) -> None:
    sim = s.joints.simulation
    if not sim.gravity_enabled and any(sim.gravity):
        out.finding(
            "simulation",
            'gravity is disabled (<flag gravity="disable"/>): MuJoCo simulates the arm '
            f"weightless, ignoring gravity [{', '.join(f'{g:g}' for g in sim.gravity)}] "
            "m/s^2, so the gravity budget is 0: the motors are never checked against the "
            "arm's weight",
        )


def _judge_keyframes(out: _Judged, arm: Arm, s: Sections) -> None:
    for k in s.keyframes:
        if k.svd.sigma[-1] < SINGULAR_SIGMA:
            lost = ", ".join(k.svd.lost_direction_names()) or "see U"
            out.finding(
                "keyframe",
                f"keyframe {k.name!r} is singular: sigma_min {k.svd.sigma[-1]:.2e} < "
                f"{SINGULAR_SIGMA:g}, rank {k.svd.rank} (lost: {lost})",
            )
        _unheld(out, arm, k)
    for c in s.contacts.keyframes:
        if c.contacts:
            out.finding(
                "keyframe", f"keyframe {c.keyframe!r} is in self-contact ({c.contacts} contacts)"
            )


def _unheld(out: _Judged, arm: Arm, k: KeyframeRow) -> None:
    for i in k.unheld:
        out.finding(
            "keyframe",
            f"keyframe {k.name!r} cannot be held: joint {arm.joint_names[i]!r} needs "
            f"{k.hold[i]:.4g} N m, its actuators give "
            f"{limit(float(k.effort_lower[i]), float(k.effort_upper[i]))} N m there",
        )


def _judge_gravity(out: _Judged, arm: Arm, g: GravityBudget, j: JointSection, urdf: bool) -> None:
    comp = " after gravity compensation" if g.gravcomp else ""
    for i, name in enumerate(arm.joint_names):
        # A URDF has no actuators at all (a note says so); its effort limits are judged below.
        if not urdf and not j.rows[i].actuated and g.peak[i] > 1e-9:
            out.finding(
                "gravity",
                f"joint {name!r} has no actuator, and gravity{comp} loads it with up to "
                f"{g.peak[i]:.3g} N m: nothing in the model holds it",
            )
        for count, (need, lim), side in (
            (g.over_low[i], g.worst_low[i], "negative"),
            (g.over_high[i], g.worst_high[i], "positive"),
        ):
            if count and urdf:  # no actuators: the file's effort limit is what binds
                out.finding(
                    "gravity",
                    f"gravity at joint {name!r} needs more {side} torque than its <limit "
                    f"effort> allows in {count} of {g.n_poses} poses; worst: needs "
                    f"{need:.3g} N m where the limit is {lim:.3g} N m",
                )
            elif count:
                out.finding(
                    "gravity",
                    f"gravity{comp} at joint {name!r} needs more {side} torque than its "
                    f"actuators give in {count} of {g.n_poses} poses; worst: needs "
                    f"{need:.3g} N m where their most {side} is {lim:.3g} N m",
                )


def _one_line(x: object) -> str:
    """A value's text on one line (matrices print over several)."""
    return " ".join(str(x).split())


def _judge_engines(out: _Judged, e: EngineAgreement, c: CollisionStatistics) -> None:
    if c.disagreements > 0:
        out.finding(
            "engines",
            f"{c.distance_engine}'s touching pairs differ from MuJoCo's contacts in "
            f"{c.disagreements} of {c.n_poses} poses",
        )
    for a in e.crosscheck.agreements:
        if not a.ok:
            out.finding(
                "engines", f"engines disagree on {a.quantity}: {a.max_error:.3g} > tol {a.tol:g}"
            )
    for d in e.equivalence.differences:
        out.finding("engines", f"models differ: {_one_line(d)}")


def exclusion(pair: GeomPair, urdf: bool) -> dict[str, Any]:
    """What removes a pair from the ones tested: the line for the file, the argument for Python.

    URDF: an SRDF ``<disable_collisions>`` line (``--srdf``) or a ``disabled_collisions=`` entry
    (its links); MJCF: a ``<contact><exclude>`` of its bodies.
    """
    a, b = sorted((pair.body1, pair.body2))  # in the order of the pair's label
    if urdf:
        return {
            "bodies": [a, b],
            "srdf": f'<disable_collisions link1="{a}" link2="{b}" reason="Always"/>',
            "disabled_collisions": [a, b],
        }
    return {"bodies": [a, b], "mjcf": f'<contact><exclude body1="{a}" body2="{b}"/></contact>'}


def _judge_touching(out: _Judged, t: sections.TouchingEverywhere | None, urdf: bool) -> None:
    for p in t.pairs if t is not None else ():
        fix = exclusion(p.pair, urdf)
        remedy = (
            f"the SRDF line {fix['srdf']} (--srdf), or disabled_collisions="
            f"[{tuple(fix['disabled_collisions'])!r}] in Python"
            if urdf
            else f"{fix['mjcf']} in the MJCF file"
        )
        out.note(
            "collision",
            f"{p.pair.label} touch in {p.poses} of {t.n_poses} poses: a pair in contact at "
            "(nearly) every pose is almost always two links whose collision shapes overlap where "
            "a joint joins them, an exclusion the file lacks rather than a collision to avoid; "
            f"if so, exclude it with {remedy}",
        )


# -- text -----------------------------------------------------------------------------------------
def format_report(r: AuditReport) -> list[str]:
    """The audit as text lines of at most `WIDTH` characters.

    Tables are sized to their content (a long name folds within its column); a longer
    sentence continues on the next line.
    """
    s = r.sections
    sim = s.joints.simulation
    lenient = ": Pinocchio's differences are findings" if r.mode == "lenient" else ""
    out = [
        f"audit of {r.model}",
        f"  {r.model_format}, tool frame {r.site!r}, {r.mode} mode{lenient}",
        "",
    ]
    defaults = " (MuJoCo's defaults: URDF cannot set them)" if r.model_format == "URDF" else ""
    out.append(
        f"simulation: timestep {_h(sim.timestep)}, integrator {sim.integrator}"
        + ("" if sim.eulerdamp else ", eulerdamp disabled")
        + ("" if sim.gravity_enabled else ", gravity disabled")
        + (f", gravcomp on {len(sim.gravcomp)} bodies" if sim.gravcomp else "")
        + defaults
    )
    out += _robot_lines(r)
    out += ["", *_joint_lines(r)]
    out += ["", *_keyframe_lines(r)]
    out += ["", *_gravity_lines(r)]
    out += ["", *_collision_lines(r)]
    out += ["", *_engine_lines(r)]
    out += ["", *r.contact_mass.lines()] if r.contact_mass is not None else []
    if r.notes:
        out += ["", f"notes (what the file does not say): {len(r.notes)}"]
        out += [f"  [{n.kind}] {n.message}" for n in r.notes]
    out += ["", f"findings: {len(r.findings)}"]
    out += [f"  [{f.kind}] {f.message}" for f in r.findings] or ["  none"]
    return fit(out)


def _robot_lines(r: AuditReport) -> list[str]:
    """The rest of the robot: which joints are held, at what, and what was set aside."""
    rp = r.robot
    if rp is None or not (rp.held or rp.set_aside or rp.frozen or rp.mended):
        return []
    out = [""]
    if rp.held:
        rest = "the reference pose (qpos0)" if rp.rest == "qpos0" else rp.rest
        base = f"; the arm starts below {rp.base!r}" if rp.base else ""
        out.append(f"the rest of the robot: {plural(len(rp.held), 'joint')} held at {rest}{base}")
        out.append("  held: " + ", ".join(f"{k} {_held_value(v)}" for k, v in rp.held.items()))
    if rp.frozen:
        out.append(f"frozen (the file lets them move, the arm does not): {len(rp.frozen)}")
        out += [f"  joint {name!r}: {why}" for name, why in rp.frozen.items()]
    if rp.set_aside:
        out.append(f"set aside (does not reach the arm): {len(rp.set_aside)}")
        out += [f"  {a}" for a in rp.set_aside]
    if rp.mended:
        out.append(f"read or mended for the engines (the arm depends on these): {len(rp.mended)}")
        out += [f"  {a}" for a in rp.mended]
    return out


def _held_value(v: float | tuple[float, ...]) -> str:
    if isinstance(v, tuple):
        return "(" + " ".join(f"{x:.4g}" for x in v) + ")"
    return f"{v:.4g}"


def _h(h: float) -> str:
    return f"{1e3 * h:g} ms"


def _reference(name: str | None) -> str:
    return "reference pose (qpos0)" if name is None else f"keyframe {name!r}"


def _joint_lines(r: AuditReport) -> list[str]:
    j = r.sections.joints
    urdf = r.model_format == "URDF"
    kd = "the model's own damping" if j.kd is None else f"kd = {j.kd:g} N m s/rad written to ctrl"
    servos = any(x.servo_kv or x.stiffness for x in j.rows)
    header = ["joint", "type", "range", "effort N m", "armature", "b"]
    header += ["kv", "kp"] if servos else []
    header += ["M_ii", "h_max ms", "bare ms"]

    def effort(x: sections.JointRow) -> str:
        if not x.actuated and not urdf:
            return "no actuator"
        return limit(x.effort_lower, x.effort_upper, 3)

    rows = []
    for x in j.rows:
        row = [
            x.name,
            x.type,
            f"[{fmt(x.lower, 3)}, {fmt(x.upper, 3)}]",
            effort(x),
            fmt(x.armature),
            fmt(x.damping, 3),
        ]
        row += [fmt(x.servo_kv, 3), fmt(x.stiffness, 3)] if servos else []
        row += [fmt(x.m_ii), ms(x.h_max), ms(x.h_max_bare)]
        rows.append(row)
    gains = "; kv, kp: a servo's velocity and position gains" if servos else ""
    return [
        f"joints at the {_reference(j.keyframe)}:",
        *table(header, rows, "ll" + "r" * (len(header) - 2)),
        key(
            "range [rad or m]; effort: what the actuators can apply; armature [kg m^2]; b: "
            f"damping [N m s/rad]{gains}; M_ii: mass matrix diagonal [kg m^2]; h_max: largest "
            f"stable timestep for {kd}, bare: without armature (any: no bound)"
        ),
        f"  {j.note}: implicit damping cannot make a step unstable, explicit damping can",
    ]


def _keyframe_lines(r: AuditReport) -> list[str]:
    s = r.sections
    if not s.keyframes:
        return ["keyframes: none in the file"]
    names = [x.name for x in s.joints.rows]
    return [
        "keyframes (tool frame Jacobian; torque the actuators must give to hold it):",
        *table(
            ["keyframe", "sigma", "rank", "manipulability", "lost", "held"],
            [
                [
                    k.name,
                    " ".join(fmt(x, 4, max(k.svd.sigma, default=0.0)) for x in k.svd.sigma),
                    str(k.svd.rank),
                    fmt(k.svd.manipulability, 3),
                    ", ".join(k.svd.lost_direction_names()) or "-",
                    "-"
                    if np.isnan(k.hold).any()
                    else "yes"
                    if not k.unheld
                    else "no: " + ", ".join(names[i] for i in k.unheld),
                ]
                for k in s.keyframes
            ],
            "lnrrll",
        ),
        key(
            f"sigma: singular values of the tool's Jacobian; rank: how many exceed "
            f"{SINGULAR_SIGMA:g}; lost: tool directions lost; held: the actuators hold it"
        ),
        *(
            f"  keyframe {k.name!r} is judged where it puts held joints: {_moved(k.moves_held, r)}"
            for k in s.keyframes
            if k.moves_held
        ),
    ]


def _moved(moves: dict[str, float | tuple[float, ...]], r: AuditReport) -> str:
    """``torso_pitch 1.2 (held at 0)``: a keyframe's values for held joints."""
    held = r.robot.held if r.robot is not None else {}
    return ", ".join(
        f"{j} {_held_value(v)}" + (f" (held at {_held_value(held[j])})" if j in held else "")
        for j, v in moves.items()
    )


def _gravity_lines(r: AuditReport) -> list[str]:
    g = r.sections.gravity
    if g is None:
        return ["gravity: skipped (the file gives some links the arm moves no inertia)"]
    names = [x.name for x in r.sections.joints.rows]
    comp = ", gravity compensation subtracted" if g.gravcomp else ""
    off = "" if g.gravity_enabled else " (gravity disabled: nothing to hold)"

    rows = r.sections.joints.rows
    # An MJCF joint without an actuator: nothing applies a force there (a finding when
    # gravity loads it); a URDF joint's limit is its <limit effort>.
    unheld = [not x.actuated and r.model_format != "URDF" for x in rows]

    def bound(i: int, x: float) -> str:
        if g.varies[i]:
            return "varies"
        if unheld[i]:
            return "-"
        return "none" if math.isinf(x) else fmt(x, 4)

    need = float(np.max(g.peak, initial=0.0))  # the column's size: below it, rounding is 0

    def ratio(i: int) -> str:
        value = float(g.ratio[i])
        if unheld[i]:
            return "no actuator"
        if math.isfinite(value):
            return f"{value:.2f}"
        return "-" if g.peak[i] <= 1e-9 else "none"

    return [
        f"gravity over {g.n_poses} random poses (seed {g.seed}){comp}{off}: torque the "
        "actuators must give, against what they can give (N m)",
        *table(
            ["joint", "min need", "max need", "lower limit", "upper limit", "limit/need", "over"],
            [
                [
                    names[i],
                    fmt(g.low[i], 4, need),
                    fmt(g.high[i], 4, need),
                    bound(i, g.limit_lower[i]),
                    bound(i, g.limit_upper[i]),
                    ratio(i),
                    str(int(g.over_low[i] + g.over_high[i])),
                ]
                for i in range(len(names))
            ],
            "lrrrrrr",
        ),
        key(
            "need: torque gravity asks over the poses; limit: what the actuators can give; "
            "limit/need: in the binding direction (< 1: some poses not held; -: no load); "
            "over: poses beyond a limit"
        ),
        f"  poses over a limit: {g.n_over}   (Pinocchio vs MuJoCo gravity: "
        f"{g.engine_diff:.1e} N m)",
    ]


def _collision_lines(r: AuditReport) -> list[str]:
    c = r.sections.contacts
    ranked = sorted(c.pairs, key=lambda p: (-p.poses, p.closest))[:8]
    t = r.sections.touching
    without = (
        f"; {100 * t.share_with_contact:.1f}% without the "
        f"{plural(len(t.pairs), 'pair')} in contact at every pose (see the notes)"
        if t is not None and t.pairs
        else ""
    )
    out = [
        f"self-collision over {c.n_poses} random poses (seed {c.seed}), {len(c.pairs)} pairs "
        f"tested: {100 * c.share_with_contact:.1f}% of poses have a contact{without}",
    ]
    if ranked:
        out += table(
            ["pair", "poses", "contacts", "closest (m)"],
            [[p.pair.label, str(p.poses), str(p.contacts), fmt(p.closest, 4)] for p in ranked],
            "lrrr",
        )
        out.append(
            key(
                "poses: poses with the pair in contact; contacts: MuJoCo's contact points over "
                "them; closest: closest approach [m] (< 0: penetration)"
            )
        )
    for k in c.keyframes:
        near = (
            f", closest {k.closest.pair.label} at {k.closest.distance:.4f} m" if k.closest else ""
        )
        moved = " (at its own pose: it moves held joints)" if k.moves_held else ""
        out.append(f"  keyframe {k.keyframe!r}{moved}: {k.contacts} contacts{near}")
    if c.distance_engine is not None and c.pairs:
        out.append(
            f"  distances by {c.distance_engine}; poses where its touching pairs differ from "
            f"MuJoCo's contacts: {c.disagreements}"
        )
    return out


def _engine_lines(r: AuditReport) -> list[str]:
    cc, eq = r.engines.crosscheck, r.engines.equivalence
    out = [
        f"engine cross-check over {cc.n_poses} poses ({r.engines.second_order_poses} for dJ/dq "
        "and the manipulability gradient), |MuJoCo - Pinocchio| / the quantity's scale:",
        *table(
            ["quantity", "max error", "tol", ""],
            [
                [a.quantity, f"{a.max_error:.2e}", f"{a.tol:.0e}", "ok" if a.ok else "DISAGREE"]
                for a in cc.agreements
            ],
            "lrrl",
        ),
        key(
            "max error: largest over the poses; tol: its tolerance; DISAGREE: beyond it (a finding)"
        ),
        "",
        "model equivalence (MuJoCo's compiled model vs Pinocchio's):",
    ]
    out += [f"  DIFFERS {_one_line(d)}" for d in eq.differences] or ["  no differences"]
    kinds: dict[tuple[str, str], list[str]] = {}
    for b in eq.bridges:
        kinds.setdefault((b.quantity, b.source), []).append(f"{b.joint}={b.value_text}")
    for (kind, source), vals in kinds.items():
        out.append(
            f"  BRIDGED {kind} (from MuJoCo's {source}; Pinocchio's parser does not read it "
            f"as MuJoCo does): {', '.join(vals)}"
        )
    if eq.differences or kinds:
        out.append(
            key(
                "DIFFERS: the two compiled models disagree beyond the tolerance; BRIDGED: a "
                "value Pinocchio's parser does not read as MuJoCo does, copied from MuJoCo's "
                "compiled model into Pinocchio's (both engines then use MuJoCo's value)"
            )
        )
    return out

"""The audit's rules: which numbers of the sections are a finding to act on, which a note.

A [`Finding`][redundancy.reports.findings.Finding] only where the model's own numbers show a
problem; what the file's format cannot express is a
[`Note`][redundancy.reports.findings.Note], never a finding.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ..analysis.crosscheck import DYNAMIC_QUANTITIES
from ..arm import Arm
from ..collision import CollisionStatistics
from ..model.couplings import TENDON_ON_CHAIN
from . import physics, sections
from .audit_report import (
    SINGULAR_SIGMA,
    EngineAgreement,
    Finding,
    Note,
)
from .locations import Locations, read_source
from .rules import rule
from .sections import GravityBudget, JointSection, KeyframeRow, Sections
from .tables import exclusion, limit, one_line, timestep_text

#: Condition number of M above which the model is reported as ill-conditioned: M^-1's
#: rounding (cond(M) x eps) passes 1e-7 relative.
ILL_CONDITIONED = 1e9


# -- judging --------------------------------------------------------------------------------------
def judge(
    arm: Arm, computed: Sections, engines: EngineAgreement
) -> tuple[tuple[Finding, ...], tuple[Note, ...]]:
    """The findings and notes of an arm's audit sections, in the order the report gives them."""
    urdf = arm.model_format == "URDF"
    data = read_source(arm.source)  # read once: the elements' lines and the URDF's limits
    judged = _Judged(Locations(arm.source, data))
    _judge_meshes(judged, arm)
    if computed.collision_skipped:
        judged.note(
            "collision-engines-differ",
            f"skipped the self-collision sweep: {computed.collision_skipped} (the model "
            "equivalence's differences say where)",
        )
    _judge_inertia(judged, arm, engines)
    _judge_joints(judged, computed.joints, urdf)
    _judge_simulation(judged, computed)
    _judge_keyframes(judged, arm, computed)
    if computed.gravity is not None:
        _judge_gravity(judged, arm, computed.gravity, computed.joints, urdf)
    _judge_engines(judged, engines, computed.contacts)
    _judge_touching(judged, computed.touching, urdf)
    for defect in arm.defects:  # a published value MuJoCo rejects, on a body the arm moves
        judged.finding("published-inertia", defect)
    root = physics.urdf_root(arm, data)
    for r in (
        *physics.masses(arm, root),
        *physics.inertias(arm),
        *physics.urdf_limits(arm, root),
        *physics.joint_ranges(arm, dict(arm.keyframes)),
    ):
        add = judged.note if rule(r.rule).severity == "note" else judged.finding
        add(r.rule, r.message, r.element, r.kind)
    return tuple(judged.findings), tuple(judged.notes)


class _Judged:
    """Findings and notes, in the order the report gives them."""

    #: The kind of element (`Locations`) a rule's findings name, by the rule's kind.
    _TAGS: ClassVar[dict[str, str]] = {"keyframe": "key", "gravity": "joint", "timestep": "joint"}

    def __init__(self, locations: Locations) -> None:
        self.findings: list[Finding] = []
        self.notes: list[Note] = []
        self.locations = locations

    def finding(
        self, rule_id: str, message: str, element: str | None = None, tag: str | None = None
    ) -> None:
        """A finding of rule ``rule_id``, with the file and line of ``element``.

        ``tag`` is the element's kind (``link``, ``joint``, ``key``); by default the one the
        rule's kind names.
        """
        r = rule(rule_id)
        file, line = self._where(r.kind, element, tag)
        self.findings.append(Finding(r.kind, message, r.id, r.severity, file, line, element))

    def note(
        self, rule_id: str, message: str, element: str | None = None, tag: str | None = None
    ) -> None:
        """A note of rule ``rule_id``, located as `finding` locates one."""
        r = rule(rule_id)
        file, line = self._where(r.kind, element, tag)
        self.notes.append(Note(r.kind, message, r.id, "note", file, line, element))

    def _where(
        self, kind: str, element: str | None, tag: str | None
    ) -> tuple[str | None, int | None]:
        tag = tag or self._TAGS.get(kind)
        line = self.locations.line(tag, element) if element and tag else None
        return (self.locations.file if line is not None else None), line


def quoted(items: list[str]) -> str:
    """Names quoted and joined by commas, as the messages list them."""
    return ", ".join(repr(n) for n in items)


def _judge_meshes(out: _Judged, arm: Arm) -> None:
    """Meshes found nowhere: the self-collision sweep that needs them was skipped."""
    if arm.missing_meshes:
        meshes = "; ".join(f"link {m.link!r}: {m.file!r}" for m in arm.missing_meshes)
        out.note(
            "meshes-missing",
            f"skipped the self-collision sweep: the file names meshes found nowhere ({meshes}); "
            "install the package that ships them (or put it on ROS_PACKAGE_PATH)",
        )


def _judge_inertia(out: _Judged, arm: Arm, e: EngineAgreement) -> None:
    """What the model's inertias do not allow: skipped sections, an ill-conditioned M."""
    if arm.missing_inertia:
        links = quoted(list(arm.missing_inertia))
        for section in (
            "the gravity budget",
            "the keyframes' holding torques",
            "M_ii and the timestep bounds",
            "the effective mass at the tool",
            f"the engines' cross-check of {', '.join(DYNAMIC_QUANTITIES)}",
        ):
            out.note("inertia-missing", f"skipped {section}: the file gives no inertia for {links}")
    kappa = e.crosscheck.mass_condition
    if kappa is not None and kappa > ILL_CONDITIONED:
        out.finding(
            "mass-matrix-ill-conditioned",
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
            "urdf-no-armature",
            "URDF cannot express armature (a geared joint's rotor inertia N^2 J_rotor): the "
            "mass matrix has none",
        )
        out.note(
            "urdf-no-actuators",
            "URDF cannot express actuators: each joint's <limit effort> is the limit MuJoCo "
            "applies (actuatorfrcrange), the gravity budget's limit",
        )
        out.note(
            "urdf-no-timestep",
            f"URDF cannot express the timestep or the integrator: MuJoCo's defaults "
            f"({timestep_text(h)}, {j.simulation.integrator}) are used",
        )
    else:
        zero = [r.name for r in rows if r.armature == 0.0]
        if zero:
            out.note(
                "armature-zero",
                f"zero armature on {quoted(zero)}: a geared joint's rotor inertia N^2 J_rotor "
                "is missing unless the joint is direct-drive",
            )
        if len(set(np.round(arma, 12))) == 1 and arma[0] > 0 and len(arma) > 1:
            out.note(
                "armature-uniform",
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
                f"timestep {timestep_text(h)} is above the h_max {r.h_max * 1e3:.3g} ms of joint "
                f"{r.name!r} (M_ii {r.m_ii:.4g} kg m^2, {damping}"
                + (f", {kd}" if kd else "")
                + f"; {j.note}): the joint's speed will grow step by step"
            )
            if urdf:  # the file sets no timestep: the bound tells the user which to choose
                out.note("timestep-default-unstable", f"MuJoCo's default {text}", r.name)
            else:
                out.finding("timestep-unstable", text, r.name)
    if h <= 0:
        out.finding(
            "timestep-not-positive",
            f"timestep {h:g} s is not positive: MuJoCo cannot step the model",
        )


def _judge_simulation(out: _Judged, s: Sections) -> None:
    sim = s.joints.simulation
    if not sim.gravity_enabled and any(sim.gravity):
        out.finding(
            "gravity-disabled",
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
                "keyframe-singular",
                f"keyframe {k.name!r} is singular: sigma_min {k.svd.sigma[-1]:.2e} < "
                f"{SINGULAR_SIGMA:g}, rank {k.svd.rank} (lost: {lost})",
                k.name,
            )
        _unheld(out, arm, k)
    for c in s.contacts.keyframes if s.contacts is not None else ():
        if c.contacts:
            out.finding(
                "keyframe-self-contact",
                f"keyframe {c.keyframe!r} is in self-contact ({c.contacts} contacts)",
                c.keyframe,
            )


def _unheld(out: _Judged, arm: Arm, k: KeyframeRow) -> None:
    for i in k.unheld:
        out.finding(
            "keyframe-unheld",
            f"keyframe {k.name!r} cannot be held: joint {arm.joint_names[i]!r} needs "
            f"{k.hold[i]:.4g} N m, its actuators give "
            f"{limit(float(k.effort_lower[i]), float(k.effort_upper[i]))} N m there",
            k.name,
        )


def _tendon_actuators(arm: Arm) -> list[str]:
    """Actuators set aside because they pull a tendon over a coupled arm's chain."""
    return [a.name for a in arm.set_aside if a.what == "actuator" and a.reason == TENDON_ON_CHAIN]


def _judge_gravity(out: _Judged, arm: Arm, g: GravityBudget, j: JointSection, urdf: bool) -> None:
    comp = " after gravity compensation" if g.gravcomp else ""
    tendon, through = _tendon_actuators(arm), []
    for i, name in enumerate(arm.joint_names):
        # A URDF has no actuators at all (a note says so); its effort limits are judged below.
        if not urdf and not j.rows[i].actuated and g.peak[i] > 1e-9 and tendon:
            through.append(name)
        elif not urdf and not j.rows[i].actuated and g.peak[i] > 1e-9:
            out.finding(
                "joint-unactuated-loaded",
                f"joint {name!r} has no actuator, and gravity{comp} loads it with up to "
                f"{g.peak[i]:.3g} N m: nothing in the model holds it",
                name,
            )
        for count, (need, lim), side in (
            (g.over_low[i], g.worst_low[i], "negative"),
            (g.over_high[i], g.worst_high[i], "positive"),
        ):
            if count and urdf:  # no actuators: the file's effort limit is what binds
                out.finding(
                    "gravity-over-limit",
                    f"gravity at joint {name!r} needs more {side} torque than its <limit "
                    f"effort> allows in {count} of {g.n_poses} poses; worst: needs "
                    f"{need:.3g} N m where the limit is {lim:.3g} N m",
                    name,
                )
            elif count:
                out.finding(
                    "gravity-over-limit",
                    f"gravity{comp} at joint {name!r} needs more {side} torque than its "
                    f"actuators give in {count} of {g.n_poses} poses; worst: needs "
                    f"{need:.3g} N m where their most {side} is {lim:.3g} N m",
                    name,
                )
    if through:
        out.note(
            "joint-tendon-actuated",
            f"joints {quoted(through)} have no actuator of their own; the file drives the chain "
            f"through {quoted(tendon)}, pulling a tendon (set aside: a tendon's force is in "
            f"neither engine's J, M or gravity), so gravity{comp} is not judged against it",
            through[0],
        )


def _judge_engines(out: _Judged, e: EngineAgreement, c: CollisionStatistics | None) -> None:
    if c is not None and c.disagreements > 0:
        out.finding(
            "engines-contacts-differ",
            f"{c.distance_engine}'s touching pairs differ from MuJoCo's contacts in "
            f"{c.disagreements} of {c.n_poses} poses",
        )
    for a in e.crosscheck.agreements:
        if not a.ok:
            out.finding(
                "engines-disagree",
                f"engines disagree on {a.quantity}: {a.max_error:.3g} > tol {a.tol:g}"
                + (f" ({a.suspect} reads the file otherwise: {a.verdict()})" if a.suspect else ""),
            )
    for d in e.equivalence.differences:
        out.finding("engines-models-differ", f"models differ: {one_line(d)}")


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
            "pair-always-touching",
            f"{p.pair.label} touch in {p.poses} of {t.n_poses} poses: a pair in contact at "
            "(nearly) every pose is almost always two links whose collision shapes overlap where "
            "a joint joins them, an exclusion the file lacks rather than a collision to avoid; "
            f"if so, exclude it with {remedy}",
            p.pair.label,
        )

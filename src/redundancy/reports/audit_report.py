"""The audit's report: its data, and the same data as text, JSON and HTML tables.

[`audit`][redundancy.reports.audit.audit] fills an
[`AuditReport`][redundancy.reports.audit_report.AuditReport]; the judging rules
(`redundancy.reports.judging`) turned the sections into its findings and notes.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any, ClassVar

import numpy as np

from ..analysis.crosscheck import CrossCheckReport
from ..arm import FROZEN, Arm
from ..display import Report, Table, json_ready, plural, to_json
from ..display import table as html_table
from ..errors import DeprecatedAlias
from ..model.equivalence import EquivalenceReport
from . import sections
from .findings import Finding, Note
from .sections import Sections
from .tables import (
    exclusion,
    fit,
    fmt,
    follower_lines,
    key,
    limit,
    ms,
    one_line,
    split_table,
    table,
    timestep_text,
)

#: A keyframe is singular when sigma_min of its site Jacobian is below this [m/rad or rad/rad].
SINGULAR_SIGMA = 1e-3


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
    ([`lines`][redundancy.reports.audit_report.AuditReport.lines]); a notebook shows the findings,
    the keyframes and the engines' agreement as tables, with the full text folded below.

    Attributes:
        model: The model file (or ``"<string>"``).
        frame: The tool frame (a site of MuJoCo's model: an MJCF site, a URDF link).
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
    frame: str
    mode: str
    sections: Sections
    engines: EngineAgreement
    findings: tuple[Finding, ...]
    notes: tuple[Note, ...] = ()
    model_format: str = "MJCF"
    robot: RobotPart | None = None
    contact_mass: sections.ContactMass | None = None

    site: ClassVar[DeprecatedAlias] = DeprecatedAlias("frame")
    """Deprecated name of `frame` (warns with a DeprecationWarning)."""

    @property
    def exit_code(self) -> int:
        """The CLI's status: 1 with findings, 0 without."""
        return 1 if self.findings else 0

    def to_dict(self) -> dict[str, Any]:
        """The report as plain data (the ``--json`` document)."""
        s = self.sections
        j, g = s.joints, s.gravity
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
            "frame": self.frame,
            "mode": self.mode,
            "simulation": asdict(j.simulation),
            "kd": j.kd,
            "reference_keyframe": j.keyframe,
            "timestep_note": j.note,
            "joints": [{**asdict(r), "armature_share": r.armature_share} for r in j.rows],
            "followers": [asdict(f) for f in j.followers],
            "keyframes": [self._keyframe_data(k) for k in s.keyframes],
            "gravity": gravity,
            "collision": self._collision_data(),
            "crosscheck": {
                "n_poses": cc.n_poses,
                "n_poses_second_order": self.engines.second_order_poses,
                "ok": cc.ok,
                "mass_condition": cc.mass_condition,
                "skipped": cc.skipped,
                "engines": list(cc.engines),
                "quantities": [a.json() for a in cc.agreements],
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

    @staticmethod
    def _keyframe_data(k: sections.KeyframeRow) -> dict[str, Any]:
        """A keyframe's row of the JSON document: its Jacobian's SVD and its hold."""
        return {
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

    def _collision_data(self) -> dict[str, Any] | None:
        """The self-collision section of the JSON document (None: not swept, see the notes)."""
        c, t = self.sections.contacts, self.sections.touching
        if c is None:
            return None
        urdf = self.model_format == "URDF"
        return {
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
        }

    def to_json(self) -> str:
        """The report as a JSON document (infinite or NaN values as null)."""
        return to_json(self.to_dict())

    def lines(self) -> list[str]:
        """The report as text lines."""
        return format_report(self)

    def summary(self) -> str:
        """The model, the tool frame and the number of findings."""
        return f"{self.model} ({self.frame}): {plural(len(self.findings), 'finding')}"

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
        f"  {r.model_format}, tool frame {r.frame!r}, {r.mode} mode{lenient}",
        "",
    ]
    defaults = " (MuJoCo's defaults: URDF cannot set them)" if r.model_format == "URDF" else ""
    out.append(
        f"simulation: timestep {timestep_text(sim.timestep)}, integrator {sim.integrator}"
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
        *split_table(header, rows, len(header) - 3),
        key(
            "range [rad or m]; effort: what the actuators can apply; armature [kg m^2]; b: "
            f"damping [N m s/rad]{gains}; M_ii: mass matrix diagonal [kg m^2]; h_max: largest "
            f"stable timestep for {kd}, bare: without armature (any: no bound)"
        ),
        f"  {j.note}: implicit damping cannot make a step unstable, explicit damping can",
        *follower_lines(j.followers),
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
    if c is None:
        return ["self-collision: not swept, the file names meshes found nowhere (see the notes)"]
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
    others = cc.engines[1:]
    out = [
        f"engine cross-check over {cc.n_poses} poses ({r.engines.second_order_poses} for dJ/dq "
        f"and the manipulability gradient), |{cc.engines[0]} - each other engine| / the "
        "quantity's scale:",
        *table(
            ["quantity", *others, "tol", "", "suspect"],
            [
                [
                    a.quantity,
                    *(f"{a.by_pair.get((cc.engines[0], e), a.max_error):.2e}" for e in others),
                    f"{a.tol:.0e}",
                    "ok" if a.ok else "DISAGREE",
                    a.suspect or "",
                ]
                for a in cc.agreements
            ],
            "l" + "r" * len(others) + "rll",
        ),
        *(f"  {a.verdict()}" for a in cc.agreements if not a.ok),
        key(
            "a column per engine: its largest difference to the reference over the poses; tol: "
            "the tolerance; DISAGREE: beyond it (a finding); suspect: the one engine that "
            "disagrees with the others while they agree"
        ),
        "",
        "model equivalence (MuJoCo's compiled model vs Pinocchio's):",
    ]
    out += [f"  DIFFERS {one_line(d)}" for d in eq.differences] or ["  no differences"]
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

"""``redundancy audit``: everything the library knows about an arm, and what to act on.

The audit takes the shared :mod:`~redundancy.reports.sections` (joints and timesteps,
keyframes, gravity against the actuators, self-collision), adds the engines' agreement and
the model comparison, and *judges* them: each problem a user should fix is a
:class:`Finding`. Numbers follow what MuJoCo simulates: the integrator and its flags, gravity
compensation, actuator ranges per direction, servo damping.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from ..analysis.crosscheck import (
    BATCH_QUANTITIES,
    TOLERANCES,
    Agreement,
    CrossCheckReport,
    crosscheck_batch,
    merge_worst,
)
from ..arm import Arm
from ..checks import check_count, check_number
from ..collision import CollisionStatistics
from ..display import Report, Table, plural
from ..display import table as html_table
from ..model.equivalence import EquivalenceReport, compare_models
from . import sections
from .sections import GravityBudget, JointSection, KeyframeRow, Sections
from .tables import fmt, ms, table

#: A keyframe is singular when sigma_min of its site Jacobian is below this [m/rad or rad/rad].
SINGULAR_SIGMA = 1e-3
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


@dataclass(frozen=True, repr=False)
class AuditReport(Report):
    """All sections of an audit, the engines' agreement, and the findings.

    ``print(report)`` prints the text report (:meth:`lines`); a notebook shows the findings,
    the keyframes and the engines' agreement as tables, with the full text folded below.

    Attributes:
        model: The model file (or ``"<string>"``).
        site: The tool site.
        mode: ``"strict"`` or ``"lenient"`` (loaded with ``strict=False``: what Pinocchio reads
            differently is a finding, not a refusal).
        sections: Joints, keyframes, gravity, self-collision.
        engines: Cross-check and model equivalence.
        findings: What to act on.
    """

    model: str
    site: str
    mode: str
    sections: Sections
    engines: EngineAgreement
    findings: tuple[Finding, ...]

    @property
    def exit_code(self) -> int:
        """The CLI's status: 1 with findings, 0 without."""
        return 1 if self.findings else 0

    def to_dict(self) -> dict[str, Any]:
        """The report as plain data (the ``--json`` document)."""
        s = self.sections
        j, g, c = s.joints, s.gravity, s.contacts
        cc, eq = self.engines.crosscheck, self.engines.equivalence
        gravity = {k: v for k, v in asdict(g).items() if k != "agreement"}  # in "crosscheck"
        doc = {
            "model": self.model,
            "site": self.site,
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
                }
                for k in s.keyframes
            ],
            "gravity": {**gravity, "peak": g.peak, "ratio": g.ratio},
            "collision": {
                "n_poses": c.n_poses,
                "seed": c.seed,
                "share_with_contact": c.share_with_contact,
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
                    }
                    for k in c.keyframes
                ],
            },
            "crosscheck": {
                "n_poses": cc.n_poses,
                "n_poses_second_order": self.engines.second_order_poses,
                "ok": cc.ok,
                "quantities": [{**asdict(a), "ok": a.ok} for a in cc.agreements],
            },
            "equivalence": {
                "equivalent": eq.equivalent,
                "differences": [str(d) for d in eq.differences],
                "bridged": [asdict(b) for b in eq.bridges],
            },
            "findings": [asdict(f) for f in self.findings],
        }
        return _clean(doc)

    def to_json(self) -> str:
        """The report as a JSON document (infinite or NaN values as null)."""
        return json.dumps(self.to_dict(), indent=2, allow_nan=False)

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


def _clean(x: Any) -> Any:
    if isinstance(x, dict):
        return {k: _clean(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_clean(v) for v in x]
    if isinstance(x, np.ndarray):
        return _clean(x.tolist())
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


# -- the audit ------------------------------------------------------------------------------------
def audit(
    arm: Arm,
    n_poses: int = 10_000,
    seed: int = 0,
    kd: float | None = None,
    computed: Sections | None = None,
    mode: str = "strict",
    progress: Callable[[str], object] | None = None,
) -> AuditReport:
    """Audit an arm: every section of the report, and the findings.

    Args:
        arm: The loaded arm.
        n_poses: Random poses for the gravity and self-collision sweeps (>= 1).
        seed: Seed of the gravity sweep (>= 0); the collision sweep uses ``seed + 1``.
        kd: Controller damping written to ``ctrl`` at which timesteps are judged
            [N m s/rad]; ``None``: the lesson's 5 on motor-driven joints, the servo's own
            ``kv`` on servo-driven ones (see :func:`~redundancy.reports.sections.joints`).
        computed: Sections already computed with these arguments (the CLI shares them with
            the lesson's tables).
        mode: ``"strict"`` or ``"lenient"``: how the arm was loaded (recorded in the report).
        progress: Called with a short label as each part starts.

    Raises:
        ParameterError: ``n_poses`` or ``seed`` out of range, ``kd`` negative or not finite.
    """
    n_poses = check_count("n_poses", n_poses, 1)
    seed = check_count("seed", seed, 0)
    kd = None if kd is None else check_number("kd", kd, 0.0, unit="N m s/rad")
    say = progress or (lambda label: None)
    if computed is None:
        computed = sections.compute(arm, n_poses, seed, kd, progress=say)
    say("engine cross-check")
    engines = _engines(arm, n_poses, seed, computed.gravity.agreement)
    findings = (
        _joint_findings(computed.joints)
        + _simulation_findings(computed)
        + _keyframe_findings(arm, computed)
        + _gravity_findings(arm, computed.gravity, computed.joints)
        + _engine_findings(engines, computed.contacts)
    )
    return AuditReport(str(arm.source), arm.site, mode, computed, engines, tuple(findings))


def _engines(arm: Arm, n_poses: int, seed: int, gravity: Agreement) -> EngineAgreement:
    """Cross-check over the gravity sweep's poses, chunk by chunk, and compare the models.

    ``gravity`` is the sweep's own row (it computed both engines' gravity on these poses).
    """
    batched = tuple(q for q in BATCH_QUANTITIES if q != gravity.quantity)
    rest = tuple(q for q in TOLERANCES if q not in BATCH_QUANTITIES)
    merged: dict[str, Agreement] = {gravity.quantity: gravity}
    offset, second = 0, 0
    for Q in sections.pose_chunks(arm, n_poses, seed):
        parts = crosscheck_batch(arm, Q, quantities=batched).agreements
        if offset < CROSSCHECK_POSES:
            head = Q[: CROSSCHECK_POSES - offset]
            parts += crosscheck_batch(arm, head, quantities=rest).agreements
            second += len(head)
        for a in parts:
            merged[a.quantity] = _worse(merged.get(a.quantity), a, offset)
        offset += len(Q)
    agreements = tuple(merged[q] for q in (*BATCH_QUANTITIES, *rest) if q in merged)
    cc = CrossCheckReport(agreements, arm.bridges, n_poses)
    return EngineAgreement(cc, second, compare_models(arm))


def _worse(kept: Agreement | None, new: Agreement, offset: int) -> Agreement:
    """The worse of two chunks' agreements, by :func:`redundancy.crosscheck`'s rules."""
    if kept is None:
        return Agreement(new.quantity, new.max_error, new.tol, new.worst_pose + offset)
    error, pose = merge_worst(
        (kept.max_error, kept.worst_pose), (new.max_error, new.worst_pose), offset
    )
    return Agreement(new.quantity, error, new.tol, pose)


# -- judging --------------------------------------------------------------------------------------
def _joint_findings(j: JointSection) -> list[Finding]:
    out = []
    h = j.simulation.timestep
    arma = np.array([r.armature for r in j.rows])
    for r in j.rows:
        if r.armature == 0.0:
            out.append(
                Finding(
                    "armature",
                    f"joint {r.name!r} has zero armature: a geared joint's rotor inertia N^2 "
                    "J_rotor is missing",
                )
            )
        if h > 0 and h >= r.h_max:
            out.append(
                Finding(
                    "timestep",
                    f"timestep {h * 1e3:.3g} ms is above joint {r.name!r}'s h_max "
                    f"{r.h_max * 1e3:.3g} ms (M_ii {r.m_ii:.4g} kg m^2, explicit damping "
                    f"{r.explicit:g}, implicit {r.implicit:g} N m s/rad"
                    + (f", explicit stiffness {r.stiffness:g} N m/rad" if r.stiffness else "")
                    + f"; {j.note}): the joint's speed will grow step by step",
                )
            )
    if h <= 0:
        out.append(
            Finding("timestep", f"timestep {h:g} s is not positive: MuJoCo cannot step the model")
        )
    if len(set(np.round(arma, 12))) == 1 and arma[0] > 0 and len(arma) > 1:
        out.append(
            Finding(
                "armature",
                f"every joint has the same armature {arma[0]:g} kg m^2: a placeholder? "
                "reflected inertia is N^2 J_rotor and differs between a shoulder and a wrist "
                "motor",
            )
        )
    return out


def _simulation_findings(s: Sections) -> list[Finding]:
    sim = s.joints.simulation
    out = []
    if not sim.gravity_enabled and any(sim.gravity):
        out.append(
            Finding(
                "simulation",
                'gravity is disabled (<flag gravity="disable"/>): MuJoCo simulates the arm '
                f"weightless, ignoring gravity {list(sim.gravity)} m/s^2, so the gravity "
                "budget is 0: the motors are never checked against the arm's weight",
            )
        )
    return out


def _keyframe_findings(arm: Arm, s: Sections) -> list[Finding]:
    out = []
    for k in s.keyframes:
        if k.svd.sigma[-1] < SINGULAR_SIGMA:
            lost = ", ".join(k.svd.lost_direction_names()) or "see U"
            out.append(
                Finding(
                    "keyframe",
                    f"keyframe {k.name!r} is singular: sigma_min {k.svd.sigma[-1]:.2e} < "
                    f"{SINGULAR_SIGMA:g}, rank {k.svd.rank} (lost: {lost})",
                )
            )
        out += _unheld(arm, k)
    for c in s.contacts.keyframes:
        if c.contacts:
            out.append(
                Finding(
                    "keyframe",
                    f"keyframe {c.keyframe!r} is in self-contact ({c.contacts} contacts)",
                )
            )
    return out


def _unheld(arm: Arm, k: KeyframeRow) -> list[Finding]:
    return [
        Finding(
            "keyframe",
            f"keyframe {k.name!r} cannot be held: joint {arm.joint_names[i]!r} needs "
            f"{k.hold[i]:.4g} N m, its actuators give [{k.effort_lower[i]:.4g}, "
            f"{k.effort_upper[i]:.4g}] N m there",
        )
        for i in k.unheld
    ]


def _gravity_findings(arm: Arm, g: GravityBudget, j: JointSection) -> list[Finding]:
    out = []
    comp = " after gravity compensation" if g.gravcomp else ""
    for i, name in enumerate(arm.joint_names):
        if not j.rows[i].actuated and g.peak[i] > 1e-9:
            out.append(
                Finding(
                    "gravity",
                    f"joint {name!r} has no actuator, and gravity{comp} loads it with up to "
                    f"{g.peak[i]:.3g} N m: nothing in the model holds it",
                )
            )
        for count, (need, limit), side in (
            (g.over_low[i], g.worst_low[i], "negative"),
            (g.over_high[i], g.worst_high[i], "positive"),
        ):
            if count:
                out.append(
                    Finding(
                        "gravity",
                        f"gravity{comp} at joint {name!r} needs more {side} torque than its "
                        f"actuators give in {count} of {g.n_poses} poses; worst: needs "
                        f"{need:.3g} N m where their most {side} is {limit:.3g} N m",
                    )
                )
    return out


def _one_line(x: object) -> str:
    """A value's text on one line (matrices print over several)."""
    return " ".join(str(x).split())


def _engine_findings(e: EngineAgreement, c: CollisionStatistics) -> list[Finding]:
    out = []
    if c.disagreements > 0:
        out.append(
            Finding(
                "engines",
                f"{c.distance_engine}'s touching pairs differ from MuJoCo's contacts in "
                f"{c.disagreements} of {c.n_poses} poses",
            )
        )
    out += [
        Finding("engines", f"engines disagree on {a.quantity}: {a.max_error:.3g} > tol {a.tol:g}")
        for a in e.crosscheck.agreements
        if not a.ok
    ]
    out += [Finding("engines", f"models differ: {_one_line(d)}") for d in e.equivalence.differences]
    return out


# -- text -----------------------------------------------------------------------------------------
def format_report(r: AuditReport) -> list[str]:
    """The audit as text lines; every table's columns are sized to their content."""
    s = r.sections
    j, sim = s.joints, s.joints.simulation
    mode = "" if r.mode == "strict" else f", {r.mode} mode: Pinocchio's differences are findings"
    out = [f"audit of {r.model} (site {r.site!r}{mode})", ""]
    out.append(
        f"simulation: timestep {_h(sim.timestep)}, integrator {sim.integrator}"
        + ("" if sim.eulerdamp else ", eulerdamp disabled")
        + ("" if sim.gravity_enabled else ", gravity disabled")
        + (f", gravcomp on {len(sim.gravcomp)} bodies" if sim.gravcomp else "")
    )
    kd = "kd per joint (column kd)" if j.kd is None else f"kd = {j.kd:g} N m s/rad"
    out += [
        "",
        f"joints (at keyframe {j.keyframe!r}; h_max for {kd}; {j.note}):",
        *table(
            [
                "joint",
                "type",
                "range",
                "armature",
                "share",
                "b",
                "kv",
                "kp",
                "kd",
                "effort N m",
                "M_ii",
                "h_max ms",
                "bare ms",
            ],
            [
                [
                    x.name,
                    x.type,
                    f"[{fmt(x.lower, 3)}, {fmt(x.upper, 3)}]",
                    fmt(x.armature),
                    f"{100 * x.armature_share:.1f}%",
                    fmt(x.damping, 3),
                    fmt(x.servo_kv, 3),
                    fmt(x.stiffness, 3),
                    fmt(x.kd, 3),
                    f"[{fmt(x.effort_lower, 3)}, {fmt(x.effort_upper, 3)}]"
                    if x.actuated
                    else "no actuator",
                    fmt(x.m_ii),
                    ms(x.h_max),
                    ms(x.h_max_bare),
                ]
                for x in j.rows
            ],
            "llrrrrrrrrrrr",
        ),
    ]
    out += ["", "keyframes (site Jacobian; torque the actuators must give to hold it):"]
    out += table(
        ["keyframe", "sigma", "rank", "manipulability", "lost", "held"],
        [
            [
                k.name,
                " ".join(fmt(x, 4) for x in k.svd.sigma),
                str(k.svd.rank),
                fmt(k.svd.manipulability, 3),
                ", ".join(k.svd.lost_direction_names()) or "-",
                "yes" if not k.unheld else "no: " + ", ".join(j.rows[i].name for i in k.unheld),
            ]
            for k in s.keyframes
        ],
        "llrrll",
    )
    out += ["", *_gravity_lines(r)]
    out += ["", *_collision_lines(r)]
    out += ["", *_engine_lines(r)]
    out += ["", f"findings: {len(r.findings)}"]
    out += [f"  [{f.kind}] {f.message}" for f in r.findings] or ["  none"]
    return out


def _h(h: float) -> str:
    return f"{1e3 * h:g} ms"


def _gravity_lines(r: AuditReport) -> list[str]:
    g = r.sections.gravity
    names = [x.name for x in r.sections.joints.rows]
    comp = ", gravity compensation subtracted" if g.gravcomp else ""
    off = "" if g.gravity_enabled else " (gravity disabled: nothing to hold)"
    return [
        f"gravity over {g.n_poses} random poses (seed {g.seed}){comp}{off}: torque the "
        "actuators must give, against what they can give (N m)",
        *table(
            ["joint", "min need", "max need", "lower limit", "upper limit", "limit/need", "over"],
            [
                [
                    names[i],
                    fmt(g.low[i], 4),
                    fmt(g.high[i], 4),
                    "varies" if g.varies[i] else fmt(g.limit_lower[i], 4),
                    "varies" if g.varies[i] else fmt(g.limit_upper[i], 4),
                    "-" if not math.isfinite(g.ratio[i]) else f"{g.ratio[i]:.2f}",
                    str(int(g.over_low[i] + g.over_high[i])),
                ]
                for i in range(len(names))
            ],
            "lrrrrrr",
        ),
        f"  poses over a limit: {g.n_over}   (Pinocchio vs MuJoCo gravity: "
        f"{g.engine_diff:.1e} N m)",
    ]


def _collision_lines(r: AuditReport) -> list[str]:
    c = r.sections.contacts
    ranked = sorted(c.pairs, key=lambda p: (-p.poses, p.closest))[:8]
    out = [
        f"self-collision over {c.n_poses} random poses (seed {c.seed}), {len(c.pairs)} pairs "
        f"tested: {100 * c.share_with_contact:.1f}% of poses have a contact",
        *table(
            ["pair", "poses", "contacts", "closest (m)"],
            [[p.pair.label, str(p.poses), str(p.contacts), fmt(p.closest, 4)] for p in ranked],
            "lrrr",
        ),
    ]
    for k in c.keyframes:
        near = (
            f", closest {k.closest.pair.label} at {k.closest.distance:.4f} m" if k.closest else ""
        )
        out.append(f"  keyframe {k.keyframe}: {k.contacts} contacts{near}")
    if c.distance_engine is not None:
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
        "",
        "model equivalence (MuJoCo's compiled model vs Pinocchio's):",
    ]
    out += [f"  DIFFERS {_one_line(d)}" for d in eq.differences] or ["  no differences"]
    kinds: dict[str, list[str]] = {}
    for b in eq.bridges:
        kinds.setdefault(b.quantity, []).append(f"{b.joint}={b.value_text}")
    for kind, vals in kinds.items():
        out.append(
            f"  BRIDGED {kind} from MuJoCo (Pinocchio's MJCF parser does not read it): "
            f"{', '.join(vals)}"
        )
    return out

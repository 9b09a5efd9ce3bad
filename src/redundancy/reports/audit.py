"""``redundancy audit``: everything the library knows about an arm, and what to act on.

The report has one section per question (joints and timesteps, keyframe singularity,
gravity against motor limits, self-collision, engine agreement, model equivalence) and ends
with *findings*: concrete problems a user should fix. The exit status is 1 when there are
findings, 0 when there are none.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import inertia
from ..analysis import batch
from ..analysis.crosscheck import BATCH_QUANTITIES, TOLERANCES, CrossCheckReport, crosscheck_batch
from ..arm import Arm, random_poses
from ..collision import CollisionStatistics, collision_statistics
from ..linalg import jacobian_svd
from ..model.equivalence import EquivalenceReport, compare_models
from ..model.loading import load

#: A keyframe is singular when sigma_min of its site Jacobian is below this [m/rad or rad/rad].
SINGULAR_SIGMA = 1e-3
#: Controller damping gain at which timesteps are judged [N m s/rad] (the lesson's kd).
AUDIT_KD = 5.0
#: Poses on which the second-order quantities (dJ/dq, manipulability gradient) are cross-checked;
#: the others are checked on every pose of the gravity sweep.
CROSSCHECK_POSES = 200


@dataclass(frozen=True)
class Finding:
    """Something in the model a user should act on.

    Attributes:
        kind: Short category: ``armature``, ``timestep``, ``gravity``, ``keyframe``, ``engines``.
        message: What is wrong and where, with the numbers.
    """

    kind: str
    message: str


@dataclass(frozen=True)
class AuditReport:
    """All sections of an audit, as data (``to_json`` gives the ``--json`` document)."""

    model: str
    site: str
    joints: list[dict[str, Any]]
    timestep: float
    kd: float
    keyframes: list[dict[str, Any]]
    gravity: dict[str, Any]
    collision: dict[str, Any]
    crosscheck: dict[str, Any]
    equivalence: dict[str, Any]
    findings: list[Finding] = field(default_factory=list)

    def to_json(self) -> str:
        """The report as a JSON document (infinite values as null)."""
        return json.dumps(_clean(asdict(self)), indent=2)


def _clean(x: Any) -> Any:
    if isinstance(x, dict):
        return {k: _clean(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_clean(v) for v in x]
    if isinstance(x, np.ndarray):
        return _clean(x.tolist())
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and not np.isfinite(x):
        return None
    return x


class Progress:
    """A one-line progress bar on stderr (silent when stderr is not a terminal)."""

    def __init__(self, label: str, total: int, enabled: bool | None = None) -> None:
        self.label, self.total = label, total
        self.enabled = sys.stderr.isatty() if enabled is None else enabled
        self.t0 = time.perf_counter()

    def __call__(self, done: int) -> None:
        """Report ``done`` of ``total`` items."""
        if not self.enabled:
            return
        frac = done / max(self.total, 1)
        bar = "#" * int(30 * frac)
        sys.stderr.write(
            f"\r  {self.label:<22}[{bar:<30}] {done}/{self.total} "
            f"{time.perf_counter() - self.t0:5.1f} s"
        )
        if done >= self.total:
            sys.stderr.write("\n")
        sys.stderr.flush()


def audit(
    arm: Arm,
    n_poses: int = 10_000,
    seed: int = 0,
    kd: float = AUDIT_KD,
    progress: bool | None = None,
) -> AuditReport:
    """Audit an arm: every section of the report, and the findings.

    Args:
        arm: The loaded arm.
        n_poses: Random poses for the gravity and self-collision sweeps.
        seed: Seed of the gravity sweep; the collision sweep uses ``seed + 1``.
        kd: Controller damping gain at which timesteps are judged [N m s/rad].
        progress: Show progress bars on stderr (default: when it is a terminal).
    """
    findings: list[Finding] = []
    names = arm.joint_names
    m = arm.mj_model
    h = float(m.opt.timestep)

    # Joints: armature share and the explicit-damping timestep bound at a reference pose.
    keys = arm.keyframes
    ref_name = "home" if "home" in keys else (next(iter(keys)) if keys else "qpos0")
    q_ref = keys.get(ref_name, m.qpos0.copy())
    M = np.diag(arm.mass_matrix(q_ref))
    M_bare = np.diag(arm.mass_matrix(q_ref, armature=False))
    arma = arm.armature()
    b = arm.damping()
    hmax = inertia.max_stable_timestep(M, kd, b)
    hmax_bare = inertia.max_stable_timestep(M_bare, kd, b)
    joints = []
    for i, n in enumerate(names):
        joints.append(
            {
                "name": n,
                "type": arm.joint_types[i],
                "lower": float(arm.lower[i]),
                "upper": float(arm.upper[i]),
                "armature": float(arma[i]),
                "armature_share": float(arma[i] / M[i]),
                "damping": float(b[i]),
                "effort_limit": float(arm.effort_limit[i]),
                "M_ii": float(M[i]),
                "M_ii_bare": float(M_bare[i]),
                "h_max": float(hmax[i]),
                "h_max_bare": float(hmax_bare[i]),
            }
        )
        if arma[i] == 0.0:
            findings.append(
                Finding(
                    "armature",
                    f"joint {n!r} has zero armature: a geared joint's rotor inertia N^2 "
                    "J_rotor is missing",
                )
            )
        if h >= hmax[i]:
            findings.append(
                Finding(
                    "timestep",
                    f"timestep {h * 1e3:.3g} ms is above joint {n!r}'s h_max "
                    f"{hmax[i] * 1e3:.3g} ms at kd = {kd:g} N m s/rad "
                    f"(M_ii {M[i]:.4g} kg m^2, b {b[i]:g}): explicit controller damping will "
                    "diverge",
                )
            )
    if len(set(np.round(arma, 12))) == 1 and arma[0] > 0 and arm.nq > 1:
        findings.append(
            Finding(
                "armature",
                f"every joint has the same armature {arma[0]:g} kg m^2: a placeholder? "
                "reflected inertia is N^2 J_rotor "
                "and differs between a shoulder and a wrist motor",
            )
        )

    # Keyframes: singular values and manipulability; contacts come with the collision section.
    keyframes = []
    for k, q in keys.items():
        s = jacobian_svd(arm.jacobian(q))
        sp = jacobian_svd(arm.jacobian(q, "pinocchio"))
        keyframes.append(
            {
                "name": k,
                "q": q,
                "sigma": s.sigma,
                "rank": s.rank,
                "manipulability": s.manipulability,
                "condition": s.condition,
                "lost_directions": s.lost_direction_names(),
                "engine_sigma_diff": float(np.max(np.abs(s.sigma - sp.sigma))),
            }
        )
        if s.sigma[-1] < SINGULAR_SIGMA:
            lost = ", ".join(s.lost_direction_names()) or "see U"
            findings.append(
                Finding(
                    "keyframe",
                    f"keyframe {k!r} is singular: sigma_min {s.sigma[-1]:.2e} < "
                    f"{SINGULAR_SIGMA:g}, rank {s.rank} (lost: {lost})",
                )
            )

    # Gravity against the motor limits, both engines.
    qs = random_poses(arm, n_poses, seed)
    bar = Progress("gravity sweep", len(qs), progress)
    tau = np.zeros_like(qs)
    tau_p = np.zeros_like(qs)
    for start in range(0, len(qs), 1000):
        chunk = slice(start, start + 1000)
        tau[chunk] = batch.gravities(arm, qs[chunk], "mujoco")
        tau_p[chunk] = batch.gravities(arm, qs[chunk], "pinocchio")
        bar(min(start + 1000, len(qs)))
    peak = np.max(np.abs(tau), axis=0)
    over = np.abs(tau) > arm.effort_limit
    gravity = {
        "n_poses": n_poses,
        "seed": seed,
        "peak": peak,
        "limit": arm.effort_limit,
        "poses_over_limit": int(np.sum(over.any(axis=1))),
        "engine_diff": float(np.max(np.abs(tau - tau_p))),
    }
    for i, n in enumerate(names):
        if over[:, i].any():
            findings.append(
                Finding(
                    "gravity",
                    f"gravity torque at joint {n!r} reaches {peak[i]:.3g} N m, over its motor "
                    "limit "
                    f"{arm.effort_limit[i]:.3g} N m, in {int(over[:, i].sum())} of {n_poses} poses",
                )
            )

    # Self-collision over random poses, and at the keyframes.
    stats: CollisionStatistics = collision_statistics(arm, n_poses, seed + 1, distances="mujoco")
    collision = {
        "n_poses": stats.n_poses,
        "seed": stats.seed,
        "share_with_contact": stats.share_with_contact,
        "pairs": [
            {"pair": p.pair.label, "poses": p.poses, "contacts": p.contacts, "closest": p.closest}
            for p in sorted(stats.pairs, key=lambda p: (-p.poses, p.closest))
        ],
        "keyframes": [
            {
                "name": k.keyframe,
                "contacts": k.contacts,
                "closest_pair": k.closest.pair.label if k.closest else None,
                "closest_distance": k.closest.distance if k.closest else None,
            }
            for k in stats.keyframes
        ],
        "n_pairs": len(stats.pairs),
    }
    for k in stats.keyframes:
        if k.contacts:
            findings.append(
                Finding(
                    "keyframe",
                    f"keyframe {k.keyframe!r} is in self-contact ({k.contacts} contacts)",
                )
            )

    # The engines, pose by pose and model against model.
    # Batched quantities over every sweep pose; second-order ones over the first few hundred.
    fast = crosscheck_batch(arm, qs, quantities=BATCH_QUANTITIES)
    rest = tuple(q for q in TOLERANCES if q not in BATCH_QUANTITIES)
    slow = crosscheck_batch(arm, qs[:CROSSCHECK_POSES], quantities=rest)
    cc = CrossCheckReport(fast.agreements + slow.agreements, fast.bridges, fast.n_poses)
    crossd = {
        "n_poses": cc.n_poses,
        "n_poses_second_order": slow.n_poses,
        "ok": cc.ok,
        "quantities": [
            {"quantity": a.quantity, "max_error": a.max_error, "tol": a.tol, "ok": a.ok}
            for a in cc.agreements
        ],
    }
    for a in cc.agreements:
        if not a.ok:
            findings.append(
                Finding(
                    "engines",
                    f"engines disagree on {a.quantity}: {a.max_error:.3g} > tol {a.tol:g}",
                )
            )
    eq: EquivalenceReport = compare_models(arm)
    equiv = {
        "equivalent": eq.equivalent,
        "differences": [str(d) for d in eq.differences],
        "bridged": [asdict(b) for b in eq.bridges],
    }
    for d in eq.differences:
        findings.append(Finding("engines", f"models differ: {d}"))
    return AuditReport(
        str(arm.source),
        arm.site,
        joints,
        h,
        kd,
        keyframes,
        gravity,
        collision,
        crossd,
        equiv,
        findings,
    )


def format_report(r: AuditReport) -> list[str]:
    """The audit as text lines."""
    ms = lambda x: "any" if x is None or not np.isfinite(x) else f"{1e3 * x:.2f}"  # noqa: E731
    out = [
        f"audit of {r.model} (site {r.site!r})",
        "",
        f"joints (M_ii at the reference pose; h_max at kd = {r.kd:g} N m s/rad, timestep "
        f"{1e3 * r.timestep:g} ms):",
    ]
    out.append(
        f"  {'joint':<8}{'type':<7}{'range':>17}{'armature':>10}{'share':>7}{'damping':>9}"
        f"{'limit':>8}{'M_ii':>9}{'h_max ms':>10}{'bare ms':>9}"
    )
    for j in r.joints:
        rng = f"[{j['lower']:.3g}, {j['upper']:.3g}]"
        out.append(
            f"  {j['name']:<8}{j['type']:<7}{rng:>17}{j['armature']:>10.4g}"
            f"{100 * j['armature_share']:>6.1f}%{j['damping']:>9.3g}{j['effort_limit']:>8.3g}"
            f"{j['M_ii']:>9.4g}{ms(j['h_max']):>10}{ms(j['h_max_bare']):>9}"
        )
    out += ["", "keyframes (site Jacobian):"]
    for k in r.keyframes:
        lost = f", lost: {', '.join(k['lost_directions'])}" if k["lost_directions"] else ""
        out.append(
            f"  {k['name']:<8} sigma "
            f"{np.array2string(np.asarray(k['sigma']), precision=4, suppress_small=True)}"
            f" rank {k['rank']}, manipulability {k['manipulability']:.3g}{lost}"
        )
    g = r.gravity
    out += ["", f"gravity over {g['n_poses']} random poses (seed {g['seed']}):"]
    out.append(f"  peak |tau| (N m)     {np.round(np.asarray(g['peak']), 2) + 0.0}")
    ratio = [
        "-" if p < 1e-9 else f"{lim / p:.2f}" for p, lim in zip(g["peak"], g["limit"], strict=True)
    ]
    out.append(f"  limit / peak         {' '.join(ratio)}")
    out.append(
        f"  poses over a limit   {g['poses_over_limit']}   (Pinocchio vs MuJoCo: "
        f"{g['engine_diff']:.1e} N m)"
    )
    c = r.collision
    out += [
        "",
        f"self-collision over {c['n_poses']} random poses (seed {c['seed']}), {c['n_pairs']} "
        "pairs tested:",
    ]
    out.append(f"  {100 * c['share_with_contact']:.1f}% of poses have a contact")
    out.append(f"  {'pair':<24}{'poses':>7}{'contacts':>10}{'closest (m)':>13}")
    for p in c["pairs"][:8]:
        out.append(f"  {p['pair']:<24}{p['poses']:>7}{p['contacts']:>10}{p['closest']:>13.4f}")
    for k in c["keyframes"]:
        near = (
            f", closest {k['closest_pair']} at {k['closest_distance']:.4f} m"
            if k["closest_pair"]
            else ""
        )
        out.append(f"  keyframe {k['name']}: {k['contacts']} contacts{near}")
    x = r.crosscheck
    out += [
        "",
        f"engine cross-check over {x['n_poses']} poses ({x['n_poses_second_order']} for dJ/dq and "
        "the manipulability gradient), |MuJoCo - Pinocchio| / max(1, |value|):",
    ]
    for a in x["quantities"]:
        out.append(
            f"  {a['quantity']:<26}{a['max_error']:>10.2e}  tol {a['tol']:.0e}  "
            f"{'ok' if a['ok'] else 'DISAGREE'}"
        )
    e = r.equivalence
    out += ["", "model equivalence (MuJoCo's compiled model vs Pinocchio's):"]
    out += [f"  DIFFERS {d}" for d in e["differences"]] or ["  no differences"]
    kinds: dict[str, list[str]] = {}
    for b in e["bridged"]:
        kinds.setdefault(b["quantity"], []).append(f"{b['joint']}={b['value']}")
    for kind, vals in kinds.items():
        out.append(
            f"  BRIDGED {kind} from MuJoCo (Pinocchio's MJCF parser does not read it): "
            f"{', '.join(vals)}"
        )
    out += ["", f"findings: {len(r.findings)}"]
    out += [f"  [{f.kind}] {f.message}" for f in r.findings] or ["  none"]
    return out


def write_atomic(path: str | os.PathLike[str], text: str) -> None:
    """Write a file so that a crash leaves the old content or the new, never half of one."""
    p = Path(path)
    fd, tmp = tempfile.mkstemp(dir=p.parent, prefix=f".{p.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, p)  # atomic on POSIX within one filesystem
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def run_audit(args: argparse.Namespace) -> int:
    """The ``audit`` subcommand; returns 1 when there are findings."""
    from ..models import model_path

    path = args.model or model_path("arm7")
    arm = load(path, site=args.site)
    if args.model is None and not args.no_lesson:
        from .lesson import print_tables

        print("lesson 5.2's tables for arm7", flush=True)
        print_tables(arm, n_poses=args.poses)
        print()
    report = audit(arm, args.poses, args.seed)
    if args.json == "-":
        print(report.to_json())
    else:
        for line in format_report(report):
            print(line)
        if args.json:
            write_atomic(args.json, report.to_json() + "\n")
    return 1 if report.findings else 0

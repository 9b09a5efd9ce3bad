"""Every published arm of example-robot-data, loaded as published: the closing-note table.

For each arm (``redundancy.models.EXAMPLE_ARMS``, then :data:`MORE_ARMS`): served or the
refusal's text, its joints and held joints, the largest cross-check error over random poses
(every pair of engines), Drake's part in it, the largest difference to MuJoCo's model of the
whole robot with the rest held, the audit's exit status and the load time. An arm whose links
lack inertias is compared on its kinematic quantities only (its dynamic ones refuse), and the
table says so. The bundled models (:data:`BUNDLED`) come first.

The column "Drake" (``published_arms.drake_cell``): ``ok (e)`` when Drake is in
``arm.engines`` and the cross-check over every pair is ok (``e``: the largest error of a pair
with Drake in it), ``not ok:`` and which engine disagrees on which quantity, else ``absent:``
and ``arm.absent_engines["drake"]``; the counts follow the table.

Usage: ``python scripts/survey_robots.py [--poses 20] [--audit-poses 200] [--no-audit]``

With ``--published``: every arm of the robot-model packages on the Python package index instead
(`published_arms`, beside this script), each compared with raw MuJoCo's model of its whole
file: ``python scripts/survey_robots.py --published [--cache DIR] [--jobs 2] [--timeout 300]
[--only REGEX] [--output FILE]``.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import redundancy as rd
from redundancy.arm import random_poses
from redundancy.cli import main as cli
from redundancy.model.robot import difference_to_whole_robot, whole_robot_quantities
from redundancy.models import EXAMPLE_ARMS, example_robot_data, model_path

sys.path.insert(0, str(Path(__file__).parent))  # published_arms, beside this script
from published_arms import drake_cell, drake_counts

#: Published arms beyond the tests' list: a human model whose shoulders and wrists are
#: revolute joints through massless virtual links (no <inertial>).
MORE_ARMS: tuple[tuple[str, str, str | None], ...] = (
    ("human_description/robots/human.urdf", "left_hand", None),
    ("human_description/robots/human.urdf", "right_hand", None),
)

#: The bundled models, as files (``models/``): (file, tool frame).
BUNDLED: tuple[tuple[str, str], ...] = (
    ("arm7.xml", "ee"),
    ("arm7.urdf", "ee"),
    ("panda.xml", "ee"),
    ("panda.urdf", "ee"),
)


def kinematic_difference(arm: rd.Arm, q: np.ndarray) -> float:
    """Largest relative difference of J and the tool position to MuJoCo's whole robot."""
    whole = whole_robot_quantities(arm, q)
    worst = 0.0
    for engine in arm.engines:
        for key, value in (
            ("jacobian", arm.jacobian(q, engine)),
            ("site position", arm.site_pose(q, engine)[0]),
        ):
            scale = max(1.0, float(np.max(np.abs(whole[key]))))
            worst = max(worst, float(np.max(np.abs(value - whole[key]))) / scale)
    return worst


def survey_one(
    path: Path, name: str, tool: str, base: str | None, args: argparse.Namespace
) -> tuple[str, str]:
    """One table row, and its Drake cell ("" when the arm is refused)."""
    name += f" (base {base})" if base else ""
    t = time.perf_counter()
    try:
        arm = rd.load(path, frame=tool, base=base)
    except rd.RedundancyError as err:
        return f"| {name} | {tool} | refused: {err} | - | - | - | - | - | - | - |", ""
    load = time.perf_counter() - t
    Q = random_poses(arm, args.poses, seed=0)
    report = rd.crosscheck(arm, Q)
    xerr = max(a.max_error for a in report.agreements)
    if arm.missing_inertia:
        whole = max(kinematic_difference(arm, q) for q in Q)
        served = f"kinematics only (no inertia: {', '.join(arm.missing_inertia)})"
    else:
        whole = max(difference_to_whole_robot(arm, q) for q in Q)
        served = "served"
    code = "-"
    if not args.no_audit:
        cmd = ["audit", str(path), "--frame", tool, "--poses", str(args.audit_poses)]
        if base:
            cmd += ["--base", base]
        with tempfile.TemporaryDirectory() as tmp:
            cmd += ["--json", str(Path(tmp) / "r.json")]
            with contextlib.redirect_stdout(io.StringIO()):
                code = str(cli(cmd))
    drake = drake_cell(arm, report)
    row = (
        f"| {name} | {tool} | {served} | {arm.nq} | {len(arm.held)} | {xerr:.1e}"
        f"{'' if report.ok else ' FAILED'} | {drake.replace('|', '/')} | {whole:.1e} | {code} "
        f"| {load:.2f} s |"
    )
    return row, drake


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--poses", type=int, default=20, help="random poses per arm (seed 0)")
    p.add_argument("--audit-poses", type=int, default=200, help="poses of each audit")
    p.add_argument("--no-audit", action="store_true", help="skip the audits")
    p.add_argument(
        "--published", action="store_true", help="survey the robot-model packages of PyPI"
    )
    p.add_argument("--cache", default=None, help="download cache (--published)")
    p.add_argument("--jobs", type=int, default=2, help="arms surveyed at once (--published)")
    p.add_argument("--timeout", type=float, default=300, help="seconds per arm (--published)")
    p.add_argument("--only", default=None, help="regex on package/file/tool (--published)")
    p.add_argument("--output", default=None, help="also write the table here (--published)")
    args = p.parse_args(argv)
    if args.published:
        from published_arms import DEFAULT_CACHE, main_published

        args.cache = args.cache or str(DEFAULT_CACHE)
        return main_published(args)
    print(
        "| robot | tool | served | arm joints | held joints | largest cross-check error "
        "| Drake | largest difference to MuJoCo's full model | audit exit | load time |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    rows = [(model_path("arm7").parent / f, f"{f} (bundled)", t, None) for f, t in BUNDLED]
    rows += [(example_robot_data(f), Path(f).name, t, b) for f, t, b in (*EXAMPLE_ARMS, *MORE_ARMS)]
    cells = []
    for path, name, tool, base in rows:
        row, drake = survey_one(path, name, tool, base, args)
        print(row, flush=True)
        cells.append(drake)
    print()
    print("\n".join(drake_counts([c for c in cells if c])))
    return 0


if __name__ == "__main__":
    sys.exit(main())

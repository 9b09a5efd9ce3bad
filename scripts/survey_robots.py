"""Every published arm of example-robot-data, loaded as published: the closing-note table.

For each arm (``redundancy.models.EXAMPLE_ARMS``, then :data:`MORE_ARMS`): served or the
refusal's text, its joints and held joints, the largest cross-check error over random poses,
the largest difference to MuJoCo's model of the whole robot with the rest held, the audit's
exit status and the load time. An arm whose links lack inertias is compared on its kinematic
quantities only (its dynamic ones refuse), and the table says so.

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
from redundancy.models import EXAMPLE_ARMS, example_robot_data

#: Published arms beyond the tests' list: a human model whose shoulders and wrists are
#: revolute joints through massless virtual links (no <inertial>).
MORE_ARMS: tuple[tuple[str, str, str | None], ...] = (
    ("human_description/robots/human.urdf", "left_hand", None),
    ("human_description/robots/human.urdf", "right_hand", None),
)


def kinematic_difference(arm: rd.Arm, q: np.ndarray) -> float:
    """Largest relative difference of J and the tool position to MuJoCo's whole robot."""
    whole = whole_robot_quantities(arm, q)
    worst = 0.0
    for engine in ("mujoco", "pinocchio"):
        for key, value in (
            ("jacobian", arm.jacobian(q, engine)),
            ("site position", arm.site_pose(q, engine)[0]),
        ):
            scale = max(1.0, float(np.max(np.abs(whole[key]))))
            worst = max(worst, float(np.max(np.abs(value - whole[key]))) / scale)
    return worst


def survey_one(file: str, tool: str, base: str | None, args: argparse.Namespace) -> str:
    """One table row."""
    path = example_robot_data(file)
    name = Path(file).name + (f" (base {base})" if base else "")
    t = time.perf_counter()
    try:
        arm = rd.load(path, frame=tool, base=base)
    except rd.RedundancyError as err:
        return f"| {name} | {tool} | refused: {err} | - | - | - | - | - | - |"
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
    return (
        f"| {name} | {tool} | {served} | {arm.nq} | {len(arm.held)} | {xerr:.1e}"
        f"{'' if report.ok else ' FAILED'} | {whole:.1e} | {code} | {load:.2f} s |"
    )


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
        "| largest difference to MuJoCo's full model | audit exit | load time |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for file, tool, base in (*EXAMPLE_ARMS, *MORE_ARMS):
        print(survey_one(file, tool, base, args), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

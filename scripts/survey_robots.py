"""Every published arm of example-robot-data, loaded as published: the closing-note table.

For each arm (``redundancy.models.EXAMPLE_ARMS``): its joints and held joints, the largest
cross-check error over random poses, the largest difference to MuJoCo's model of the whole
robot with the rest held, the audit's exit status and the load time.

Usage: ``python scripts/survey_robots.py [--poses 20] [--audit-poses 200] [--no-audit]``
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
import tempfile
import time
from pathlib import Path

import redundancy as rd
from redundancy.arm import random_poses
from redundancy.cli import main as cli
from redundancy.model.robot import difference_to_whole_robot
from redundancy.models import EXAMPLE_ARMS, example_robot_data


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--poses", type=int, default=20, help="random poses per arm (seed 0)")
    p.add_argument("--audit-poses", type=int, default=200, help="poses of each audit")
    p.add_argument("--no-audit", action="store_true", help="skip the audits")
    args = p.parse_args(argv)
    print(
        "| robot | tool | arm joints | held joints | largest cross-check error "
        "| largest difference to MuJoCo's full model | audit exit | load time |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for file, tool, base in EXAMPLE_ARMS:
        path = example_robot_data(file)
        t = time.perf_counter()
        arm = rd.load(path, frame=tool, base=base)
        load = time.perf_counter() - t
        Q = random_poses(arm, args.poses, seed=0)
        report = rd.crosscheck(arm, Q)
        xerr = max(a.max_error for a in report.agreements)
        whole = max(difference_to_whole_robot(arm, q) for q in Q)
        code = "-"
        if not args.no_audit:
            cmd = ["audit", str(path), "--site", tool, "--poses", str(args.audit_poses)]
            if base:
                cmd += ["--base", base]
            with tempfile.TemporaryDirectory() as tmp:
                cmd += ["--json", str(Path(tmp) / "r.json")]
                with contextlib.redirect_stdout(io.StringIO()):
                    code = str(cli(cmd))
        name = Path(file).name + (f" (base {base})" if base else "")
        print(
            f"| {name} | {tool} | {arm.nq} | {len(arm.held)} | {xerr:.1e}"
            f"{'' if report.ok else ' FAILED'} | {whole:.1e} | {code} | {load:.2f} s |",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())

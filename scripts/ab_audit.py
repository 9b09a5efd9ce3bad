"""A/B check: the audit's reports and per-pair collision statistics before and after a change.

``--save DIR`` writes, for each arm, the audit's JSON document (``audit(arm, n_poses)``) and every
pair's statistics of the self-collision sweep (poses, contacts, closest approach as the hex of its
float, its pose index), unpruned sweep included; ``--check DIR`` computes them again and compares
them with the saved ones character for character, so a closest approach that moved by one ulp is
a difference. Run ``--save`` on the old code, ``--check`` on the new.

Usage: ``python scripts/ab_audit.py --save /tmp/ab``, then on the new code
``python scripts/ab_audit.py --check /tmp/ab``
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import redundancy as rd
from redundancy.collision import collision_statistics
from redundancy.reports.audit import audit

#: (label, file, tool frame): arm7 and the Panda (primitives, MJCF), whole robots with meshes.
ARMS = (
    ("arm7", "arm7", "ee"),
    ("panda", "panda", "ee"),
    ("g1_left", "g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf", "left_hand_palm_link"),
    ("g1_right", "g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf", "right_hand_palm_link"),
    ("talos_left", "talos_data/robots/talos_full_v2.urdf", "gripper_left_base_link"),
)


def load(file: str, tool: str) -> rd.Arm:
    """An arm of the package's models or of example-robot-data."""
    if "/" not in file:
        return rd.load(rd.model_path(file), frame=tool)
    return rd.load(rd.example_robot_data(file), frame=tool)


def documents(arm: rd.Arm, n: int) -> dict[str, str]:
    """The audit's JSON and the sweeps' per-pair statistics (pruned, unpruned), as text."""
    # The model's path is where the package is installed: the same file reads the same.
    out = {"audit": audit(arm, n_poses=n).to_json().replace(str(arm.source), "<model>")}
    for prune in (True, False):
        stats = collision_statistics(arm, n_poses=n, seed=0, prune=prune, keyframes=False)
        rows = [
            [p.pair.label, p.poses, p.contacts, float(p.closest).hex(), p.closest_pose]
            for p in stats.pairs
        ]
        out[f"pairs prune={prune}"] = json.dumps(
            {
                "poses_with_contact": stats.poses_with_contact,
                "disagreements": stats.disagreements,
                "pairs": rows,
            }
        )
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--save", type=Path, help="write the documents to this folder")
    g.add_argument("--check", type=Path, help="compare with the documents in this folder")
    p.add_argument("--n", type=int, default=2000, help="poses per sweep")
    p.add_argument("--arms", nargs="*", default=[a[0] for a in ARMS], help="labels of ARMS")
    args = p.parse_args(argv)
    bad = 0
    for label, file, tool in ARMS:
        if label not in args.arms:
            continue
        docs = documents(load(file, tool), args.n)
        for key, text in docs.items():
            path = (args.save or args.check) / f"{label} {key}.json"
            if args.save:
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_text(text)
                print(f"{label} {key}: saved ({len(text)} characters)")
                continue
            same = path.read_text() == text
            bad += not same
            print(f"{label} {key}: {'identical' if same else 'DIFFERENT'}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())

"""Lesson 5.2 on the project's arm7: the six tables, computed by the library.

(1) each joint's axis, range, armature, damping, motor limit, M_ii at home with and without
armature, and the explicit-damping timestep bound; (2) singular values of the 6x7 site
Jacobian at the zero and home poses; (3) gravity torque over random poses against the motor
limits; (4) self-collision over random poses (poses and contacts counted separately); (5) the
home pose held for 2 s under five settings; (6) the bare wrist's kd stability threshold.

Run: python scripts/l5_2_seven_dof.py [MODEL.xml] [--poses N]
"""

from __future__ import annotations

import argparse
import sys
import time


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model", nargs="?", help="MJCF file (default: the bundled arm7)")
    parser.add_argument("--poses", type=int, default=10_000, help="random poses for (3) and (4)")
    args = parser.parse_args(argv)

    import redundancy as rd
    from redundancy.reports import lesson

    t0 = time.perf_counter()
    arm = rd.load(args.model or rd.model_path("arm7"), frame="ee")
    lesson.print_tables(arm, n_poses=args.poses)
    print(f"({time.perf_counter() - t0:.2f} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())

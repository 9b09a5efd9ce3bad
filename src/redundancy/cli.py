"""Command line: ``redundancy audit [MODEL.xml]``, ``redundancy lesson`` and ``redundancy lab``.

Heavy imports (the engines) happen inside the subcommands, so ``--help`` is instant.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="redundancy",
        description="Audit a redundant arm with MuJoCo and Pinocchio, cross-checked.",
    )
    sub = p.add_subparsers(dest="command", required=True)
    a = sub.add_parser(
        "audit", help="audit an MJCF arm (default: the bundled arm7, with lesson 5.2's tables)"
    )
    a.add_argument("model", nargs="?", help="MJCF file (default: bundled arm7)")
    a.add_argument("--site", default="ee", help="tool site name (default: ee)")
    a.add_argument(
        "--poses", type=int, default=10_000, help="random poses for the sweeps (default: 10000)"
    )
    a.add_argument("--seed", type=int, default=0, help="seed of the random poses (default: 0)")
    a.add_argument(
        "--json", metavar="FILE", help="also write a machine-readable report ('-' for stdout)"
    )
    a.add_argument("--no-lesson", action="store_true", help="skip lesson 5.2's tables for arm7")
    les = sub.add_parser("lesson", help="print lesson 5.2's six tables for arm7")
    les.add_argument("model", nargs="?", help="MJCF file (default: bundled arm7)")
    les.add_argument(
        "--poses", type=int, default=10_000, help="random poses for tables (3) and (4)"
    )
    lab = sub.add_parser(
        "lab", help="serve lesson 5.2's interactive arm as a local web page (redundancy[lab])"
    )
    lab.add_argument("model", nargs="?", help="MJCF file (default: bundled arm7)")
    lab.add_argument("--site", default="ee", help="tool site name (default: ee)")
    lab.add_argument(
        "--host", default="127.0.0.1", help="interface to listen on (default: 127.0.0.1)"
    )
    lab.add_argument(
        "--port", type=int, default=8080, help="TCP port (default: 8080; if taken, the next free)"
    )
    cmp = sub.add_parser(
        "compare",
        help="compare two descriptions of one robot (URDF or MJCF), structurally and pose by pose",
    )
    cmp.add_argument("a", help="first model file (MJCF or URDF)")
    cmp.add_argument("b", help="second model file (MJCF or URDF)")
    cmp.add_argument("--frame-a", default="ee", help="A's tool site or link (default: ee)")
    cmp.add_argument("--frame-b", default="ee", help="B's tool site or link (default: ee)")
    cmp.add_argument(
        "--joint-map", metavar="FILE", help="joint names of A -> B (JSON object, or lines 'a b')"
    )
    cmp.add_argument("--json", metavar="FILE", help="also write the comparison ('-' for stdout)")
    cmp.add_argument("--poses", type=int, default=200, help="random poses (default: 200)")
    cmp.add_argument("--seed", type=int, default=0, help="seed of the random poses (default: 0)")
    cmp.add_argument("--tol", type=float, default=1e-9, help="absolute tolerance (default: 1e-9)")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``redundancy`` command.

    Returns:
        0 on success, 1 when the audit has findings, 2 on bad input.
    """
    args = _parser().parse_args(argv)
    from .errors import RedundancyError

    try:
        if args.command == "lesson":
            from .model.loading import load
            from .models import model_path
            from .reports import lesson

            arm = load(args.model or model_path("arm7"), site="ee")
            lesson.print_tables(arm, n_poses=args.poses)
            return 0
        if args.command == "lab":
            from .model.loading import load
            from .models import model_path

            arm = load(args.model or model_path("arm7"), site=args.site)
            from .lab import page  # MissingDependencyError without the `lab` extra

            page.serve(arm, host=args.host, port=args.port)
            return 0
        if args.command == "compare":
            from .analysis.compare import run_compare
            from .reports.audit import write_atomic

            return run_compare(args, write_atomic)
        from .reports.audit import run_audit

        return run_audit(args)
    except RedundancyError as err:
        print(f"redundancy: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

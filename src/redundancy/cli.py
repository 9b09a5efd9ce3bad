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
        "--host",
        default="127.0.0.1",
        help="interface to listen on (default: 127.0.0.1; any other is reachable from other "
        "machines, without authentication: a warning is printed)",
    )
    lab.add_argument(
        "--port",
        type=int,
        default=8080,
        help="TCP port, 0..65535 (default: 8080; 0: any free port; if taken, the next free "
        "one, with a warning)",
    )
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
            from .lab import page  # MissingDependencyError without the `lab` extra
            from .model.loading import load
            from .models import model_path

            page.check_address(args.host, args.port)  # before any work
            arm = load(args.model or model_path("arm7"), site=args.site)
            page.serve(arm, host=args.host, port=args.port)
            return 0
        from .reports.audit import run_audit

        return run_audit(args)
    except RedundancyError as err:
        print(f"redundancy: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

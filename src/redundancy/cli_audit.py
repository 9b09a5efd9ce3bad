"""``redundancy audit`` of many models and ``--fix``: the command line's side of both.

``redundancy audit PATH...`` with a folder or several paths audits every robot model found
(`redundancy.reports.folders`): each model's report in turn (with ``--quiet`` its findings),
then one summary table; the exit status is the worst over the models (0 none, 1 findings,
2 a model that failed to load or to be audited, or a fix not written). ``--fix OUT`` writes
the fixed copy (`redundancy.reports.fix`): with one model at OUT, with several under the folder
OUT, at each model's path under the folder it was found in.

The library does the work; this module only reads the arguments, loads, prints and writes.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .cli_io import one_line


def is_many(paths: list[str]) -> bool:
    """Whether the paths ask for the audit of many models: a folder, or several paths."""
    return len(paths) > 1 or any(os.path.isdir(p) for p in paths)


def fix_argument(parser: argparse.ArgumentParser) -> None:
    """Add ``--fix OUT`` to the ``audit`` subcommand."""
    parser.add_argument(
        "--fix",
        metavar="OUT",
        help="write a copy of the model at OUT that excludes the pairs in contact at every "
        "pose (MJCF: <contact><exclude>; URDF: the URDF as it is and an SRDF beside OUT); "
        "with several models OUT is a folder, each copy at the model's path under it",
    )


def srdf_for(args: argparse.Namespace, path: str | os.PathLike[str]) -> str | None:
    """The SRDF to load a URDF with: ``--srdf``, else the one of its name beside it."""
    from .reports.folders import root_element, srdf_beside

    if args.srdf is not None:
        return str(args.srdf)
    beside = srdf_beside(path)  # first: a model read from a pipe must not be read here
    if beside is None or not os.path.isfile(path) or root_element(path)[0] != "robot":
        return None
    return str(beside)


def noted(report: Any, args: argparse.Namespace, srdf: str | None) -> Any:
    """The report, with the ``srdf-beside`` note when the SRDF was found, not named."""
    from .reports.folders import with_srdf_note

    return report if srdf is None or args.srdf is not None else with_srdf_note(report, srdf)


def check_fix(arm: Any, out: str | None) -> None:
    """Refuse a bad ``--fix`` target before any work (see `redundancy.reports.fix`)."""
    if out is not None:
        from .reports.fix import check_fix_targets

        check_fix_targets(arm, out)


def write_fix(arm: Any, report: Any, out: str | None, say: Callable[[str], None]) -> None:
    """Write the fixed copy of an audited model, and say what was written."""
    if out is not None:
        from .reports.fix import write_fix as write

        for line in write(arm, report, out).lines():
            say(line)


def run_many(args: argparse.Namespace, load_file: Callable[..., Any]) -> int:
    """``redundancy audit`` of a folder or several paths: every model, then the summary.

    Args:
        args: The parsed arguments (``args.model``: the paths).
        load_file: The command line's loader (`redundancy.cli._load_file`).

    Returns:
        The worst exit status over the models.
    """
    from .errors import ModelError, ParameterError
    from .reports.files import OutputPathError, input_named, write_atomic
    from .reports.folders import FolderAudit, find_models

    if args.srdf is not None:
        raise ParameterError(
            "--srdf",
            args.srdf,
            "left out with several models (it names one URDF's pairs): put each URDF's SRDF "
            "beside it under its name (ur5.urdf, ur5.srdf)",
        )
    from .reports.baseline import read_baseline

    baseline = None if args.baseline is None else read_baseline(args.baseline)  # before any work
    found, skipped = find_models(args.model)
    if not found:
        shown = ", ".join(repr(p) for p in args.model)
        raise ModelError(f"no robot model (MJCF or URDF) in {shown}")
    inputs = [(m.path, f"the model file {m.path!r}") for m in found]
    if args.json not in (None, "-") and (what := input_named(args.json, inputs)) is not None:
        raise OutputPathError(f"--json {args.json!r} is {what}: not replaced")
    fix_dir = _fix_folder(args.fix, found, inputs)
    document = args.format != "text"  # a --format document, to -o or else to stdout
    to_stdout = args.json == "-" or (document and args.output in (None, "-"))
    stream = sys.stderr if to_stdout else sys.stdout

    def say(line: str = "") -> None:
        if stream is not None:  # None: started with that stream closed
            print(line, file=stream, flush=True)

    entries: list[Any] = []
    fixes: list[Any] = []
    for i, model in enumerate(found):
        if i:
            say()
        out = None if fix_dir is None else str(fix_dir / model.relative)
        entry, fix = _one(args, model.path, load_file, out, say, f"{i + 1}/{len(found)}")
        entries.append(entry)
        fixes += [] if fix is None else [fix]
    result = FolderAudit(tuple(entries), tuple(skipped), tuple(fixes))
    say()
    for line in result.summary_lines():
        say(line)
    if args.json == "-":
        print(result.to_json(), flush=True)
    elif args.json:
        write_atomic(args.json, result.to_json() + "\n")
    return _formats(args, result, baseline)


def _formats(args: argparse.Namespace, result: Any, baseline: Any) -> int:
    """The ``--format`` document of every model audited, and the run's exit status.

    The exit status is the worst of the models that failed (2, 3) and the audited models'
    results judged by ``--fail-on`` and ``--baseline`` (`redundancy.reports.formats`).
    """
    from .reports.files import write_atomic
    from .reports.formats import render
    from .reports.formats.results import collect

    outcome = collect(result.reports, args.fail_on, baseline)
    if args.format != "text":
        text = render(args.format, outcome, args.quiet)
        if args.output not in (None, "-"):
            write_atomic(args.output, text)
        elif args.json != "-":
            sys.stdout.write(text)
            sys.stdout.flush()
    from .reports.folders import Failure

    failed = [f.exit_code for f in (*result.failures, *result.fixes) if isinstance(f, Failure)]
    return max([outcome.exit_code, *failed])


def _fix_folder(out: str | None, found: list[Any], inputs: list[tuple[str, str]]) -> Path | None:
    """``--fix`` of several models: a folder, made if missing; no copy may replace a model."""
    from .reports.files import OutputPathError, input_named

    if out is None:
        return None
    folder = Path(out)
    if folder.exists() and not folder.is_dir():
        raise OutputPathError(f"--fix {out!r} is a file: with several models it names a folder")
    if not folder.parent.is_dir():
        raise OutputPathError(f"directory {str(folder.parent)!r} of --fix {out!r} does not exist")
    targets = [folder / m.relative for m in found]
    for target in targets:
        what = input_named(target, inputs)
        if what is not None:
            raise OutputPathError(f"--fix {out!r} would write {str(target)!r}, {what}")
    if len(set(targets)) < len(targets):
        raise OutputPathError(f"--fix {out!r}: two models of the paths have one name under it")
    folder.mkdir(exist_ok=True)
    return folder


def _one(
    args: argparse.Namespace,
    path: str,
    load_file: Callable[..., Any],
    out: str | None,
    say: Callable[[str], None],
    counter: str,
) -> tuple[Any, Any]:
    """One model of many: its report (or its failure), and its fix (or its failure)."""
    from .errors import RedundancyError
    from .reports.audit import audit, format_report
    from .reports.files import OutputPathError
    from .reports.folders import Failure
    from .reports.progress import terminal_progress

    try:
        srdf = srdf_for(args, path)
        extra = {k: getattr(args, k) for k in ("base", "rest") if getattr(args, k) is not None}
        if srdf is not None:
            extra["disabled_collisions"] = srdf
        arm = load_file(path, frame=args.frame, strict=not args.lenient, **extra)
        if out is not None:
            Path(out).parent.mkdir(parents=True, exist_ok=True)
        check_fix(arm, out)
        mode = "lenient" if args.lenient else "strict"
        with terminal_progress(sys.stderr, quiet=args.quiet) as progress:
            step = None if progress is None else _counted(progress, counter)
            report = audit(arm, args.poses, args.seed, args.kd, None, mode, step)  # type: ignore[arg-type]
        report = noted(report, args, srdf)
    except OutputPathError:  # --json or --fix would replace an input: the run stops
        raise
    except RedundancyError as err:
        say(f"audit of {path}: failed: {one_line(err)}")
        return Failure(path, one_line(err)), None
    except Exception as err:  # a bug: this model's row says so, the others are audited
        message = f"internal error: {type(err).__name__}: {one_line(err)} (please report it)"
        say(f"audit of {path}: {message}")
        return Failure(path, message, 3), None
    lines = format_report(report)
    if args.quiet:
        lines = [f"audit of {path}", *lines[_findings_at(lines) :]]
    for line in lines:
        say(line)
    if out is None:
        return report, None
    try:
        from .reports.fix import write_fix as write

        fix = write(arm, report, out)
    except OutputPathError:
        raise
    except RedundancyError as err:
        say(f"fix of {path}: not written: {one_line(err)}")
        return report, Failure(path, f"fix not written: {one_line(err)}")
    for line in fix.lines():
        say(line)
    return report, fix


def _counted(progress: Callable[[str, int, int], None], counter: str) -> Any:
    """The progress callback, each stage named with the model's number (``2/5``)."""

    def step(stage: str, done: int, total: int) -> None:
        progress(f"{counter} {stage}", done, total)

    return step


def _findings_at(lines: list[str]) -> int:
    """Where the findings start in a report's lines."""
    return next(i for i, x in enumerate(lines) if x.startswith("findings: "))

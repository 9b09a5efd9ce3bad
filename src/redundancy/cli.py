"""Command line: ``redundancy audit [PATH...]``, ``lab``, ``compare A B``, ``example arm7``.

Every argument is checked before any work; heavy imports (the engines) happen inside the
subcommands, so ``--help`` is instant.

Exit status:
    0: done, no findings; 1: the audit has findings (with ``--fail-on``: a result at or above
    its severity that the ``--baseline`` does not accept); 2: bad input (an argument, the
    model file, a name, a baseline) or a report that cannot be written (a full disk, a JSON
    file that cannot be replaced), with one line on stderr; 3: an internal error (a bug:
    please report it), with one line on stderr; 130: interrupted; 141: the reader of stdout
    went away, or stdout is closed (as a Unix tool killed by SIGPIPE: ``redundancy audit
    --json - | head -1`` and ``redundancy compare a.xml b.xml >&-`` end quietly).

Every error is one line on stderr (a multi-line engine message is joined with "; "); with
stderr closed the status alone says what happened. Text goes out in whatever encoding the
terminal has: a character it cannot show (a Cyrillic joint name on a Latin-1 terminal) is
written as a backslash escape (``\u043b``). JSON documents are ASCII, with infinities and
NaN as ``null`` (`redundancy.display.json_ready`).
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
import warnings
from collections.abc import Callable, Sequence
from typing import Any, NoReturn

from .cli_io import OutputError as _OutputError
from .cli_io import error as _error
from .cli_io import silence_stdout as _silence_stdout
from .cli_io import terminal_output as _terminal_output

OK, FINDINGS, BAD_INPUT, INTERNAL_ERROR, INTERRUPTED = 0, 1, 2, 3, 130
PIPE_CLOSED = 128 + 13  # 128 + SIGPIPE, the status a shell shows for a tool that got it


class _BadInput(Exception):
    """An argument that fails its check (one line for stderr)."""


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (no usage block) and exit status 2."""

    def error(self, message: str) -> NoReturn:
        raise _BadInput(f"{self.prog}: error: {message}")


def _count(minimum: int) -> Callable[[str], int]:
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be >= {minimum}, got {value}")
        return value

    return parse


def _gain(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got {text}")
    return value


def _rest(text: str) -> str | dict[str, float]:
    """``--rest``: a keyframe name, or ``JOINT=VALUE,...`` [rad or m]."""
    if "=" not in text:
        if not text.strip():
            raise argparse.ArgumentTypeError("expected a keyframe name or JOINT=VALUE,...")
        return text.strip()
    out: dict[str, float] = {}
    for item in text.split(","):
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or not name:
            raise argparse.ArgumentTypeError(f"expected JOINT=VALUE, got {item.strip()!r}")
        try:
            number = float(value)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected a number for joint {name!r}, got {value.strip()!r}"
            ) from None
        if not math.isfinite(number):
            raise argparse.ArgumentTypeError(f"joint {name!r}: must be finite, got {value.strip()}")
        out[name] = number
    return out


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("redundancy")
    except PackageNotFoundError:  # a source tree on sys.path, not installed
        return "unknown (not installed)"


_EXIT = "exit status: 0 no findings, 1 findings, 2 bad input, 3 internal error"


class _FrameOption(argparse.Action):
    """``--frame NAME``; its old name ``--site`` still works (`_warn_site`).

    The two naming two frames are refused: the user says which (Python's ``frame=`` wins).
    """

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        given: dict[str, Any] = dict(getattr(namespace, "frame_options", {}))
        given[option_string or "--frame"] = values
        if len(given) > 1 and len(set(given.values())) > 1:
            (first, a), (second, b) = given.items()
            parser.error(
                f"{first} {a!r} and {second} {b!r} name two tool frames (--site is the "
                "deprecated name of --frame): give one"
            )
        namespace.frame_options = given
        setattr(namespace, self.dest, values)


def _warn_site(args: argparse.Namespace) -> None:
    """The deprecation warning of ``--site``, once the arguments are known to be good."""
    if "--site" in getattr(args, "frame_options", {}):
        message = "--site is deprecated: name the tool frame with --frame"
        warnings.warn(message, DeprecationWarning, stacklevel=3)
        _error(f"redundancy: warning: {message}")


def _model_arguments(p: argparse.ArgumentParser, many: bool = False) -> None:
    """The model file and how to load it: shared by ``audit`` (``many``: paths) and ``lab``."""
    if many:
        what = "MJCF or URDF files, or folders of them (recursive; default: the bundled arm7)"
        p.add_argument("model", nargs="*", metavar="PATH", help=what)
    else:
        p.add_argument("model", nargs="?", help="MJCF or URDF file (default: the bundled arm7)")
    p.add_argument(
        "--frame",
        "--site",
        dest="frame",
        metavar="NAME",
        action=_FrameOption,
        help="tool frame: an MJCF site or body, a URDF link or fixed joint (default: the "
        "model's one chain end; with several, the error lists them); --site is its "
        "deprecated name",
    )
    p.add_argument(
        "--srdf",
        metavar="FILE",
        help="URDF only: SRDF file whose <disable_collisions> pairs never collide",
    )
    p.add_argument(
        "--base", metavar="BODY", help="body or link the arm starts from (default: the root)"
    )
    p.add_argument(
        "--rest",
        type=_rest,
        metavar="KEY|JOINT=VALUE,...",
        help="rest configuration of the joints off the arm's chain: a keyframe name, or "
        "joint=value pairs [rad or m]",
    )


def _parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="redundancy",
        description="Audit a robot arm with MuJoCo and Pinocchio, cross-checked.",
        epilog=_EXIT,
    )
    p.add_argument("--version", action="version", version=f"redundancy {_version()}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    _audit_parser(sub)
    _example_parser(sub)
    _lab_parser(sub)
    _compare_parser(sub)
    return p


def _audit_parser(sub: Any) -> None:
    """The ``audit`` subcommand's arguments."""
    a = sub.add_parser(
        "audit",
        help="audit an MJCF or URDF arm: findings where its own numbers show a problem",
        description="Audit an MJCF or URDF arm: joints, keyframes, gravity against the "
        "effort limits, self-collision, the engines' agreement; findings where the model's "
        "own numbers show a problem, notes for what its format cannot express.",
        epilog="exit status: 0 no findings, 1 findings (--fail-on: at or above its severity, "
        "not in the --baseline), 2 bad input, 3 internal error",
    )
    _model_arguments(a, many=True)
    a.add_argument(
        "--poses",
        type=_count(1),
        default=10_000,
        help="random poses for the sweeps, >= 1 (default: 10000)",
    )
    a.add_argument(
        "--seed", type=_count(0), default=0, help="seed of the random poses, >= 0 (default: 0)"
    )
    a.add_argument(
        "--kd",
        type=_gain,
        default=None,
        help="judge the timestep for a controller writing damping kd to ctrl [N m s/rad] "
        "(default: no controller; only the model's own damping, its servos' kv included)",
    )
    a.add_argument(
        "--lenient",
        action="store_true",
        help="load with strict=False: audit a model the library would refuse, each "
        "difference between the engines' models a finding",
    )
    a.add_argument(
        "--json",
        metavar="FILE",
        help="also write the report as JSON to a regular file (a symbolic link is followed "
        "to the file it names); '-' prints only the JSON on stdout, tables on stderr",
    )
    _report_arguments(a)
    a.add_argument(
        "-q",
        "--quiet",
        action="store_true",
        help="no progress bar and no tables: print the findings only",
    )
    from .cli_audit import fix_argument

    fix_argument(a)


def _report_arguments(a: argparse.ArgumentParser) -> None:
    """What the audit writes (``--format``, ``-o``), and when it fails (``--fail-on``...)."""
    from .reports.formats.choices import DEFAULT_FAIL_ON, FAIL_ON, FORMATS

    a.add_argument(
        "--format",
        choices=FORMATS,
        default="text",
        help="the report's format (default: text): json is --json's document, sarif for code "
        "scanning, junit for CI test reports, github for workflow annotations, markdown or "
        "html to read; without -o the document alone goes to stdout, the text to stderr",
    )
    a.add_argument(
        "-o",
        "--output",
        metavar="FILE",
        help="write the --format document to FILE only (atomically, a regular file as for --json)",
    )
    a.add_argument(
        "--fail-on",
        choices=FAIL_ON,
        default=DEFAULT_FAIL_ON,
        help="the lowest severity that makes the exit status 1 (default: warning, that is any "
        "finding; note: notes too; never: 0 whatever is found)",
    )
    a.add_argument(
        "--baseline",
        metavar="REPORT.json",
        help="an earlier audit's JSON report (--format json): its findings are known and do "
        "not fail (matched by rule, element and file, not by line)",
    )


def _example_parser(sub: Any) -> None:
    """The ``example`` subcommand's arguments."""
    ex = sub.add_parser(
        "example",
        help="run a worked example: 'arm7' prints the tables of the bundled arm7's lesson",
    )
    ex.add_argument("name", choices=["arm7"], help="the example")
    ex.add_argument("model", nargs="?", help="MJCF file shaped like arm7 (default: bundled)")
    ex.add_argument(
        "--poses", type=_count(1), default=10_000, help="random poses for tables (3) and (4)"
    )


def _lab_parser(sub: Any) -> None:
    """The ``lab`` subcommand's arguments."""
    lab = sub.add_parser(
        "lab", help="serve an arm as an interactive local web page (needs redundancy[lab])"
    )
    _model_arguments(lab)
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


def _compare_parser(sub: Any) -> None:
    """The ``compare`` subcommand's arguments."""
    cmp = sub.add_parser(
        "compare",
        help="compare two descriptions of one robot (MJCF or URDF), structurally and pose by pose",
        epilog="exit status: 0 the same robot, 1 differences, 2 bad input, 3 internal error",
    )
    cmp.add_argument("a", help="first model file (MJCF or URDF)")
    cmp.add_argument("b", help="second model file (MJCF or URDF)")
    cmp.add_argument(
        "--frame",
        metavar="NAME",
        help="tool frame of both (default: each model's one chain end)",
    )
    cmp.add_argument("--frame-a", metavar="NAME", help="A's tool frame (overrides --frame)")
    cmp.add_argument("--frame-b", metavar="NAME", help="B's tool frame (overrides --frame)")
    cmp.add_argument(
        "--joint-map", metavar="FILE", help="A's joint names -> B's (JSON object, or lines 'a b')"
    )
    cmp.add_argument(
        "--json", metavar="FILE", help="also write the comparison as JSON ('-': only JSON)"
    )
    cmp.add_argument("--poses", type=_count(0), default=200, help="random poses (default: 200)")
    cmp.add_argument("--seed", type=_count(0), default=0, help="seed of the poses (default: 0)")
    cmp.add_argument("--tol", type=float, default=1e-9, help="tolerance (default: 1e-9)")


#: The input files a command line names, by argparse attribute: what each is, for a message.
_NAMED = {"model": "the model file", "a": "the model file", "b": "the model file"}
_NAMED |= {"srdf": "the SRDF file", "joint_map": "the joint map", "baseline": "the baseline"}


def _targets(args: argparse.Namespace) -> list[tuple[str, str]]:
    """(option, file) of each report file the command line names (``-`` is stdout)."""
    given = (("--json", getattr(args, "json", None)), ("-o", getattr(args, "output", None)))
    return [(option, t) for option, t in given if t not in (None, "-")]


def _check_output(args: argparse.Namespace, inputs: list[tuple[str, str]]) -> None:
    """Refuse a report file that is one of ``inputs`` (by any name: a link, ``..``)."""
    from .reports.files import input_named

    for option, target in _targets(args):
        what = input_named(target, inputs)
        if what is not None:
            raise _BadInput(f"{option} {target!r} is {what}: not replaced")


def _check_files(args: argparse.Namespace) -> None:
    """Report files must obey reports.files' rules, be none of the inputs, and not collide.

    The loader checks the input files themselves; the files a model reads are known once it
    is loaded (`redundancy.reports.files.read_by`).
    """
    fmt, output = getattr(args, "format", "text"), getattr(args, "output", None)
    if getattr(args, "json", None) == "-" and output in (None, "-") and fmt not in ("text", "json"):
        raise _BadInput(f"--json - and --format {fmt} both print on stdout: give -o FILE")
    targets = _targets(args)
    if len(targets) == 2 and os.path.realpath(targets[0][1]) == os.path.realpath(targets[1][1]):
        raise _BadInput(f"--json and -o name one file, {targets[0][1]!r}: give two")
    if targets:
        from .reports.files import check_target

        for _, target in targets:
            check_target(target)
        named = ((getattr(args, k, None), what) for k, what in _NAMED.items())
        named = ((p, what) for v, what in named for p in (v if isinstance(v, list) else [v]))
        _check_output(args, [(p, f"{what} {p!r}") for p, what in named if isinstance(p, str)])


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``redundancy`` command.

    Returns:
        0 no findings, 1 findings, 2 bad input, 3 internal error (see the module docstring).
    """
    with _terminal_output():
        return _main(argv)


def _main(argv: Sequence[str] | None) -> int:
    try:
        try:
            args = _parser().parse_args(argv)
        except _BadInput as err:
            _error(err)
            return BAD_INPUT
        except SystemExit as exit_:  # --help
            return int(exit_.code or 0)
        from .errors import RedundancyError

        try:
            _check_files(args)
            _warn_site(args)
            return _run(args)
        except (_BadInput, RedundancyError) as err:
            _error(f"redundancy: error: {err}")
            return BAD_INPUT
        except KeyboardInterrupt:
            _error("redundancy: interrupted")
            return INTERRUPTED
    except BrokenPipeError:  # the reader of stdout (or stderr) went away: end quietly
        _silence_stdout()
        return PIPE_CLOSED
    except _OutputError as err:  # the report did not go out: say where, as for a bad file
        _silence_stdout()  # what stays buffered must not fail again at the exit
        _error(f"redundancy: error: {err}")
        return BAD_INPUT
    except Exception as err:  # a bug, not the user's input: one line, and the status says so
        _error(f"redundancy: internal error: {type(err).__name__}: {err} (please report it)")
        return INTERNAL_ERROR


def _load(args: argparse.Namespace, strict: bool = True) -> Any:
    """The arm of ``audit`` or ``lab``: the file, its tool frame, and how to load it."""
    from .cli_audit import srdf_for
    from .models import model_path
    from .reports.files import read_by

    extra: dict[str, object] = {}
    path = args.model or model_path("arm7")
    if (srdf := srdf_for(args, path)) is not None:  # --srdf, or the SRDF beside the URDF
        extra["disabled_collisions"] = srdf
    # base= and rest= are passed only when given: rd.load grew them for robots whose arm is
    # one chain of a larger tree.
    if args.base is not None:
        extra["base"] = args.base
    if args.rest is not None:
        extra["rest"] = args.rest
    # No --frame: load's default (the file's one chain end, else its frame "ee").
    arm = _load_file(path, frame=args.frame, strict=strict, **extra)
    _check_output(args, read_by(arm))  # before any work: the files it read are known
    return arm


def _load_file(path: str | os.PathLike[str], **options: Any) -> Any:
    """`redundancy.load`; a model through a pipe (``<(cat arm.xml)``) that fails says so.

    A pipe loads as its file would, but the files it names by relative path count from the
    pipe's folder (``/dev/fd``), not the model's.
    """
    import stat

    from .errors import MissingInertiaError, ModelError, UnsupportedFeatureError
    from .model.loading import load

    try:
        return load(path, **options)
    except (UnsupportedFeatureError, MissingInertiaError):
        raise
    except ModelError as err:
        with contextlib.suppress(OSError):
            if stat.S_ISFIFO(os.stat(path).st_mode):
                folder = os.path.dirname(os.path.abspath(path))
                raise ModelError(
                    f"{err} ({str(path)!r} is a pipe, not a file: the paths in it count from "
                    f"{folder!r}; give the model's own file)"
                ) from err
        raise


def _run(args: argparse.Namespace) -> int:
    if args.command == "example":
        from .models import model_path
        from .reports import lesson

        arm = _load_file(args.model or model_path("arm7"), frame="ee")
        lesson.print_tables(arm, n_poses=args.poses)
        return OK
    if args.command == "lab":
        from .lab import page  # MissingDependencyError without the `lab` extra

        page.check_address(args.host, args.port)  # before any work
        arm = _load(args)
        lab = page.LabServer(arm, host=args.host, port=args.port)
        print(f"redundancy lab: {arm.source} at {lab.url} (Ctrl-C to stop)", flush=True)
        lab.serve_forever()
        return OK
    if args.command == "compare":
        return _compare(args)
    from . import cli_audit

    if cli_audit.is_many(args.model):  # a folder, or several paths
        return cli_audit.run_many(args, _load_file)
    args.model = args.model[0] if args.model else None
    return _audit(args)


def _compare(args: argparse.Namespace) -> int:
    """The ``compare`` subcommand: 0 the same robot, 1 differences (bad input raises)."""
    from .analysis.compare import compare, read_joint_map
    from .display import to_json
    from .errors import ModelError
    from .reports.files import read_by, write_atomic

    if not (math.isfinite(args.tol) and args.tol > 0):
        raise ModelError(f"--tol must be a finite number > 0, got {args.tol}")
    joint_map = read_joint_map(args.joint_map) if args.joint_map else None
    # Loaded here, not by compare: the files each read are known before any work.
    arm_a = _load_file(args.a, frame=args.frame_a or args.frame)  # None: load's default
    arm_b = _load_file(args.b, frame=args.frame_b or args.frame)
    _check_output(args, read_by(arm_a) + read_by(arm_b))
    result = compare(
        arm_a,
        arm_b,
        joint_map=joint_map,
        n_poses=args.poses,
        seed=args.seed,
        tol=args.tol,
    )
    document = to_json(result.to_dict())
    if args.json == "-":
        print(document)
    else:
        for line in result.lines():
            print(line)
        if args.json:
            write_atomic(args.json, document + "\n")
    sys.stdout.flush()
    return 0 if result.equivalent else 1


def _audit(args: argparse.Namespace) -> int:
    """The ``audit`` subcommand; 1 when a result at or above --fail-on is not in the baseline."""
    from .cli_audit import check_fix, noted, srdf_for, write_fix
    from .reports.audit import audit
    from .reports.baseline import read_baseline
    from .reports.formats.results import collect
    from .reports.progress import terminal_progress

    baseline = None if args.baseline is None else read_baseline(args.baseline)  # before any work
    arm = _load(args, strict=not args.lenient)
    check_fix(arm, args.fix)  # before any work
    mode = "lenient" if args.lenient else "strict"
    with terminal_progress(sys.stderr, quiet=args.quiet) as progress:
        report = audit(arm, args.poses, args.seed, args.kd, None, mode, progress)  # type: ignore[arg-type]
    report = noted(report, args, srdf_for(args, arm.source))
    outcome = collect([report], args.fail_on, baseline)
    _deliver(args, outcome)
    write_fix(arm, report, args.fix, _say_beside(args))
    return outcome.exit_code


def _say_beside(args: argparse.Namespace) -> Callable[[str], None]:
    """Print a line beside the report: on stderr when stdout carries a document."""
    to_stdout = args.json == "-" or (args.format != "text" and args.output in (None, "-"))
    stream = sys.stderr if to_stdout else sys.stdout

    def say(line: str = "") -> None:
        if stream is not None:  # None: started with that stream closed
            print(line, file=stream, flush=True)

    return say


def _deliver(args: argparse.Namespace, outcome: Any) -> None:
    """Print and write an audit's documents.

    stdout carries one document: the ``--format`` one without ``-o`` (``--json -``'s JSON),
    else the text report; the text report goes to stderr when stdout carries another, and
    nowhere when it is the ``-o`` document itself. Files are written last, atomically.
    """
    from .reports.files import write_atomic
    from .reports.formats import render

    output = None if args.output in (None, "-") else args.output
    on_stdout = "json" if args.json == "-" else None
    if on_stdout is None and not output and args.format != "text":
        on_stdout = args.format
    if not (args.format == "text" and output):
        stream = sys.stderr if on_stdout else sys.stdout
        if stream is not None:  # None: started with that stream closed
            print(render("text", outcome, args.quiet), end="", file=stream, flush=True)
    if on_stdout:
        sys.stdout.write(render(on_stdout, outcome, args.quiet))
        sys.stdout.flush()
    if output:
        write_atomic(output, render(args.format, outcome, args.quiet))
    if args.json not in (None, "-"):
        write_atomic(args.json, render("json", outcome))


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

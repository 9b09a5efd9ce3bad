"""The command line: arguments checked before any work, exit codes, where and how JSON is written."""

from __future__ import annotations

import io
import json
import os
import re
import stat
import sys

import pytest

import redundancy as rd
from redundancy import cli
from redundancy.cli import main
from redundancy.model import loading
from redundancy.reports import files

from .test_urdf import write_stl

PANDA = str(rd.model_path("panda"))


@pytest.fixture
def no_work(monkeypatch):
    """Fail the test if a model is loaded: the arguments must be refused before that."""

    def refuse(*args, **kwargs):
        raise AssertionError("a model was loaded before the arguments were checked")

    monkeypatch.setattr(loading, "load", refuse)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--poses", "0"], "argument --poses: must be >= 1, got 0"),
        (["--poses", "-1"], "argument --poses: must be >= 1, got -1"),
        (["--poses", "ten"], "argument --poses: expected an integer, got 'ten'"),
        (["--seed", "-5"], "argument --seed: must be >= 0, got -5"),
        (["--kd", "nan"], "argument --kd: must be a finite number >= 0, got nan"),
        (["--kd", "-1"], "argument --kd: must be a finite number >= 0, got -1"),
    ],
)
def test_bad_arguments_exit_2_with_one_line(args, message, capsys, no_work):
    assert main(["audit", PANDA, *args]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err == f"redundancy audit: error: {message}\n"


def test_json_paths_are_checked_before_any_work(tmp_path, capsys, no_work):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    cases = {
        str(tmp_path): "is a directory: reports are written to regular files only",
        str(tmp_path / "missing" / "r.json"): "does not exist",
        "/dev/null": "is a device: reports are written to regular files only",
        str(fifo): "is a FIFO: reports are written to regular files only",
        # A regular file in a directory where no file can be created (procfs).
        "/proc/version": "cannot create files in directory '/proc'",
    }
    dangling = tmp_path / "dangling.json"
    dangling.symlink_to(tmp_path / "nowhere.json")
    cases[str(dangling)] = "is a symbolic link to nothing"
    for path, why in cases.items():
        assert main(["audit", PANDA, "--json", path]) == 2
        err = capsys.readouterr().err
        assert err.startswith("redundancy: error: ") and why in err, err
        assert err.count("\n") == 1
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)  # untouched


def test_json_to_stdout_is_json_only(capsys):
    # The tables go to stderr with the report: stdout is the JSON document alone.
    assert main(["audit", "--poses", "50", "--json", "-"]) == 1
    captured = capsys.readouterr()
    assert json.loads(captured.out)["frame"] == "ee"
    assert "lesson" not in captured.err
    assert "findings: 1" in captured.err


def test_symlink_is_followed_and_mode_kept(tmp_path):
    target = tmp_path / "real.json"
    target.write_text("old")
    target.chmod(0o644)
    link = tmp_path / "link.json"
    link.symlink_to(target)
    assert main(["audit", PANDA, "--poses", "20", "--json", str(link)]) == 0
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert json.loads(target.read_text())["mode"] == "strict"
    assert stat.S_IMODE(target.stat().st_mode) == 0o644
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.json", "real.json"]


def test_new_file_gets_the_umask_default(tmp_path):
    old = os.umask(0o027)
    try:
        files.write_atomic(tmp_path / "new.json", "{}")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "new.json").stat().st_mode) == 0o640


def test_a_new_file_never_sets_the_process_umask(tmp_path, monkeypatch):
    # Setting the umask to read it races with every other thread creating files; the mode
    # must come from the kernel, with or without /proc.
    calls = []
    real = os.umask
    monkeypatch.setattr(files.os, "umask", lambda m: calls.append(m) or real(m))

    def no_proc(self, *args, **kwargs):
        raise OSError("no /proc here")

    monkeypatch.setattr(files.Path, "read_text", no_proc)
    old = real(0o077)
    try:
        files.write_atomic(tmp_path / "new.json", "{}")
    finally:
        real(old)
    assert calls == []
    assert stat.S_IMODE((tmp_path / "new.json").stat().st_mode) == 0o600


def test_json_report_is_written_atomically(tmp_path, monkeypatch):
    target = tmp_path / "report.json"
    target.write_text("old")
    files.write_atomic(target, "new")
    assert target.read_text() == "new"

    def crash(src, dst):
        raise OSError("disk pulled out")

    monkeypatch.setattr(files.os, "replace", crash)
    with pytest.raises(OSError, match="disk pulled out"):
        files.write_atomic(target, "half-written?")
    assert target.read_text() == "new"  # the old file, whole
    assert [p.name for p in tmp_path.iterdir()] == ["report.json"]  # no temporary left behind


def test_bad_names_exit_2(capsys):
    assert main(["audit", "/nonexistent.xml"]) == 2
    assert (
        capsys.readouterr().err == "redundancy: error: model file not found: '/nonexistent.xml'\n"
    )
    assert main(["audit", PANDA, "--frame", "tcp"]) == 2
    err = capsys.readouterr().err
    assert "valid site or body names: ['ee', 'link0'" in err and err.count("\n") == 1


def test_an_internal_error_exits_3_with_one_line(monkeypatch, capsys):
    def broken(args):
        raise ZeroDivisionError("division by zero")

    monkeypatch.setattr(cli, "_audit", broken)
    assert main(["audit", PANDA]) == 3
    assert capsys.readouterr().err == (
        "redundancy: internal error: ZeroDivisionError: division by zero (please report it)\n"
    )


def test_lenient_audits_what_strict_refuses(tmp_path, capsys):
    # An extrinsic euler sequence: strict loading gives Pinocchio MuJoCo's compiled model (no
    # differences); lenient loading lets Pinocchio read the file, and audits its differences.
    xml = """
<mujoco>
  <compiler eulerseq="XYZ"/>
  <worldbody>
    <body name="l1" euler="0.3 0.2 0.1"><joint name="a" axis="0 1 0" range="-2 2" armature="0.01"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.04" mass="1"/>
      <body name="l2" pos="0.3 0 0"><joint name="b" axis="0 0 1" range="-2 2" armature="0.02"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.04" mass="1"/>
        <site name="tip" pos="0.3 0 0"/></body></body>
  </worldbody>
  <actuator><motor joint="a" ctrlrange="-50 50"/><motor joint="b" ctrlrange="-50 50"/></actuator>
</mujoco>"""
    path = tmp_path / "m.xml"
    path.write_text(xml)
    strict = main(["audit", str(path), "--frame", "tip", "--poses", "20"])
    capsys.readouterr()
    out = tmp_path / "r.json"
    lenient = main(
        ["audit", str(path), "--frame", "tip", "--poses", "20", "--lenient", "--json", str(out)]
    )
    text = capsys.readouterr().out
    data = json.loads(out.read_text())
    assert data["mode"] == "lenient"
    assert text.splitlines()[1] == (
        "  MJCF, tool frame 'tip', lenient mode: Pinocchio's differences are findings"
    )
    differences = [f for f in data["findings"] if f["message"].startswith("models differ")]
    assert len(differences) == len(data["equivalence"]["differences"]) > 0
    assert (strict, lenient) == (0, 1)


def test_json_never_replaces_the_model_file(tmp_path, capsys, no_work):
    model = tmp_path / "arm.xml"
    model.write_text("<mujoco/>")
    link = tmp_path / "link.json"
    link.symlink_to(model)
    for target in (model, link):
        assert main(["audit", str(model), "--json", str(target)]) == 2
        err = capsys.readouterr().err
        assert err == (
            f"redundancy: error: --json {str(target)!r} is the model file {str(model)!r}: "
            "not replaced\n"
        )
    assert model.read_text() == "<mujoco/>"


def test_default_audit_computes_each_section_once(monkeypatch, capsys):
    from redundancy.reports import sections

    calls: dict[str, int] = {}
    for name in ("joints", "keyframes", "gravity_budget", "contacts"):
        real = getattr(sections, name)

        def counted(*args, _real=real, _name=name, **kwargs):
            calls[_name] = calls.get(_name, 0) + 1
            return _real(*args, **kwargs)

        monkeypatch.setattr(sections, name, counted)
    assert main(["audit", "--poses", "300"]) == 1
    out = capsys.readouterr().out
    assert calls == {"joints": 1, "keyframes": 1, "gravity_budget": 1, "contacts": 1}
    assert "lesson" not in out and "(1) joints" not in out


def test_example_arm7_prints_the_worked_example(capsys):
    assert main(["example", "arm7", "--poses", "300"]) == 0
    out = capsys.readouterr().out
    heads = [line.split(" ")[0] for line in out.splitlines() if line.startswith("(")]
    assert heads == ["(1)", "(2)", "(3)", "(4)", "(5)", "(6)"]
    assert main(["lesson"]) == 2  # the old top-level command is gone
    assert "invalid choice: 'lesson'" in capsys.readouterr().err


def test_version(capsys):
    from importlib.metadata import version

    assert main(["--version"]) == 0
    assert capsys.readouterr().out == f"redundancy {version('redundancy')}\n"


def test_help_names_both_formats_and_the_frame(capsys):
    assert main(["audit", "-h"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "MJCF or URDF files, or folders of them (recursive; default: the bundled arm7)" in text
    assert "--frame NAME, --site NAME" in text
    for flag in ("--srdf FILE", "--base BODY", "--rest KEY|JOINT=VALUE,...", "--quiet"):
        assert flag in text


@pytest.fixture
def load_calls(monkeypatch):
    """Record rd.load's arguments and stop the command there (exit 3, one line)."""
    calls: list[tuple[tuple, dict]] = []

    def spy(*args, **kwargs):
        calls.append((args, kwargs))
        raise RuntimeError("stop here")

    monkeypatch.setattr(loading, "load", spy)
    return calls


def test_frame_site_srdf_base_rest_reach_load(load_calls, capsys):
    assert main(["audit", PANDA, "--frame", "ee"]) == 3
    assert main(["audit", PANDA, "--frame", "ee", "--srdf", "a.srdf"]) == 3
    assert main(["lab", PANDA, "--frame", "ee", "--base", "link0", "--rest", "home"]) == 3
    assert main(["audit", PANDA, "--frame", "ee", "--rest", "j1=0.5, j2=-1e-1"]) == 3
    capsys.readouterr()
    kwargs = [k for _, k in load_calls]
    assert kwargs == [
        {"frame": "ee", "strict": True},
        {"frame": "ee", "strict": True, "disabled_collisions": "a.srdf"},
        {"frame": "ee", "strict": True, "base": "link0", "rest": "home"},
        {"frame": "ee", "strict": True, "rest": {"j1": 0.5, "j2": -0.1}},
    ]


@pytest.mark.parametrize(
    ("rest", "message"),
    [
        ("j1=abc", "argument --rest: expected a number for joint 'j1', got 'abc'"),
        ("j1=0.5,=2", "argument --rest: expected JOINT=VALUE, got '=2'"),
        ("j1=nan", "argument --rest: joint 'j1': must be finite, got nan"),
        (" ", "argument --rest: expected a keyframe name or JOINT=VALUE,..."),
    ],
)
def test_bad_rest_exits_2(rest, message, capsys, no_work):
    assert main(["audit", PANDA, "--rest", rest]) == 2
    assert capsys.readouterr().err == f"redundancy audit: error: {message}\n"


def test_one_chain_end_needs_no_frame(tmp_path, capsys):
    xml = open(PANDA).read()
    assert main(["audit", PANDA, "--poses", "20", "--json", "-"]) == 0
    assert json.loads(capsys.readouterr().out)["frame"] == "ee"  # the leaf body's one site
    two = tmp_path / "two.xml"
    two.write_text(
        xml.replace('<site name="ee"', '<site name="tcp" pos="0 0 0.2"/><site name="ee"')
    )
    # Two sites on the leaf body: the chain end is the body itself, a frame like a site.
    from redundancy.model.ends import chain_ends

    assert chain_ends(two) == ("link7",)
    assert main(["audit", str(two), "--poses", "20", "--json", "-"]) == 0
    assert json.loads(capsys.readouterr().out)["frame"] == "link7"
    tree = tmp_path / "tree.urdf"
    tree.write_text(
        '<robot name="t"><link name="base"/><link name="a"/><link name="b"/><link name="c"/>'
        '<joint name="j1" type="revolute"><parent link="base"/><child link="a"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        '<joint name="j2" type="revolute"><parent link="base"/><child link="b"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        '<joint name="f" type="fixed"><parent link="base"/><child link="c"/></joint></robot>'
    )
    assert chain_ends(tree) == ("a", "b")  # c is welded to the base: no end of an arm
    assert main(["audit", str(tree)]) == 2
    assert capsys.readouterr().err == (
        f"redundancy: error: {str(tree)!r} has 2 chain ends: 'a', 'b'; name the tool frame "
        "(--frame NAME on the command line, frame=NAME in Python)\n"
    )


def test_seed_is_printed_as_used(capsys):
    assert main(["audit", PANDA, "--poses", "30", "--seed", "3"]) == 0
    out = capsys.readouterr().out
    assert "gravity over 30 random poses (seed 3)" in out
    assert "self-collision over 30 random poses (seed 3)" in out
    assert "seed 4" not in out


def test_quiet_prints_the_findings_only(capsys, monkeypatch):
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True, raising=False)
    assert main(["audit", "--poses", "30", "--quiet"]) == 1
    captured = capsys.readouterr()
    assert captured.out.splitlines()[0] == "findings: 1"
    assert captured.err == ""


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_bar_on_a_terminal_only(monkeypatch, capsys):
    from redundancy.reports import progress

    monkeypatch.setattr(progress, "DELAY", 0.0)
    monkeypatch.setenv("TERM", "xterm-256color")  # whatever terminal the tests run from
    terminal = _Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    assert main(["audit", PANDA, "--poses", "30"]) == 0
    drawn = terminal.getvalue()
    for stage in ("gravity", "self-collision", "engine cross-check"):
        assert stage in drawn
    assert "30/30" in drawn
    # Not a terminal (capsys): nothing on stderr.
    monkeypatch.undo()
    assert main(["audit", PANDA, "--poses", "30"]) == 0
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("term", ["dumb", "unknown"])
def test_a_dumb_terminal_gets_a_line_per_stage(monkeypatch, term):
    """No cursor motion, so no bar to redraw: plain lines, one when each stage completes
    (and at most one per LINE_INTERVAL before that), no escape sequences."""
    from redundancy.reports import progress

    monkeypatch.setattr(progress, "DELAY", 0.0)
    monkeypatch.setattr(progress, "LINE_INTERVAL", 1e9)
    monkeypatch.setenv("TERM", term)
    terminal = _Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    assert main(["audit", PANDA, "--poses", "30"]) == 0
    lines = terminal.getvalue().splitlines()
    assert "\x1b" not in terminal.getvalue()
    for stage in ("gravity", "self-collision", "engine cross-check"):
        assert any(re.fullmatch(rf"{stage}: 0/30 poses, \d+ s", line) for line in lines), lines
        assert any(re.fullmatch(rf"{stage}: 30/30 poses, \d+ s", line) for line in lines), lines
    assert len(lines) == len(set(lines))  # nothing repeated within the interval


def test_base_and_rest_load_the_arm(capsys):
    assert main(["audit", PANDA, "--base", "link0", "--rest", "home", "--poses", "20"]) == 0
    assert main(["audit", PANDA, "--base", "nowhere", "--poses", "20"]) == 2
    assert "nowhere" in capsys.readouterr().err


# -- A CLI that behaves like a Unix tool ---------------------------------------------------

RUN = "import sys; from redundancy.cli import main; sys.exit(main())"


def test_closed_stdout_ends_quietly_as_after_sigpipe() -> None:
    """``redundancy audit --json - | head -1``: the reader goes; no traceback, no exit 3."""
    import subprocess
    import sys

    proc = subprocess.Popen(
        [sys.executable, "-c", RUN, "audit", "--poses", "20", "--json", "-"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None
    proc.stdout.close()  # before the report is written: its write gets EPIPE
    _, err = proc.communicate(timeout=600)
    assert proc.returncode == cli.PIPE_CLOSED == 141
    assert "Traceback" not in err and "internal error" not in err, err[-500:]


@pytest.mark.parametrize(
    ("model", "status", "stdout_has"),
    [("nothere.xml", 2, ""), (str(rd.model_path("arm7")), 1, "findings: ")],
)
def test_stderr_closed_error_path_works(model: str, status: int, stdout_has: str) -> None:
    """Started with stderr closed (2>&-): no AttributeError on isatty (exit 3), and the error
    line does not land on stdout; the status alone tells."""
    import subprocess
    import sys

    done = subprocess.run(
        [sys.executable, "-c", RUN, "audit", model, "--poses", "10"],
        capture_output=False,
        stdout=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: os.close(2),
        timeout=600,
    )
    assert done.returncode == status
    assert stdout_has in done.stdout and "redundancy: error" not in done.stdout


def test_engine_errors_are_one_line(tmp_path, capsys) -> None:
    bad = tmp_path / "bad.xml"
    bad.write_text('<mujoco><worldbody><body><joint/><geom size="x"/></body></worldbody></mujoco>')
    assert main(["audit", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err == (
        "redundancy: error: MuJoCo could not compile the model: XML Error: bad format in "
        "attribute 'size'; Element 'geom', line 1\n"
    )


def test_a_file_name_that_is_not_utf8(tmp_path, capsys) -> None:
    raw = os.fsencode(tmp_path) + b"/arm\xff.xml"
    with open(raw, "wb") as f:
        f.write(rd.model_path("arm7").read_bytes())
    name = os.fsdecode(raw)  # as Python gives argv: the byte as a surrogate
    assert main(["audit", name, "--poses", "10"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.endswith(
        "/arm\\xff.xml' is not UTF-8, which MuJoCo and Pinocchio require of file names: "
        "rename the file\n"
    )


def test_json_with_a_long_legal_name_is_written_atomically(tmp_path, capsys) -> None:
    """A 250-character name: the temporary file's name was the target's plus 15 characters,
    over the 255-byte limit ("File name too long" for a name the user never chose)."""
    target = tmp_path / ("r" * 245 + ".json")
    assert len(target.name) == 250
    assert main(["audit", "--poses", "10", "--json", str(target)]) == 1
    assert "findings" in json.loads(target.read_text())
    assert sorted(p.name for p in tmp_path.iterdir()) == [target.name]  # no temporary left


def two_links(j1: str = "j1", j2: str = "j2") -> str:
    """Two pitch hinges of 0.5 m links with a tool site, joints named ``j1`` and ``j2``."""
    return f"""<mujoco><compiler angle="radian"/><worldbody>
  <body name="l1"><joint name="{j1}" axis="0 1 0" range="-2 2"/>
    <geom type="capsule" fromto="0 0 0 0 0 0.5" size="0.05"/>
    <body name="l2" pos="0 0 0.5"><joint name="{j2}" axis="0 1 0" range="-2 2"/>
      <geom type="capsule" fromto="0 0 0 0 0 0.5" size="0.05"/>
      <site name="tip" pos="0 0 0.5"/>
    </body>
  </body>
</worldbody></mujoco>"""


def _command(args: list[str], stdout, env: dict[str, str] | None = None, **kw):
    """The command in its own process: (status, stdout text or None, stderr text)."""
    import subprocess

    done = subprocess.run(
        [sys.executable, "-c", RUN, *args],
        stdout=stdout,
        stderr=subprocess.PIPE,
        env={**os.environ, **(env or {})},
        timeout=600,
        **kw,
    )
    out = done.stdout.decode("latin-1") if done.stdout is not None else None
    return done.returncode, out, done.stderr.decode("latin-1")


@pytest.fixture
def two(tmp_path):
    path = tmp_path / "two.xml"
    path.write_text(two_links())
    return str(path)


@pytest.mark.parametrize("command", ["audit", "compare"])
def test_a_closed_stdout_ends_quietly(command: str, two: str) -> None:
    """``redundancy compare a b >&-``: as for a reader gone, no AttributeError (exit 3)."""
    args = ["audit", two, "--poses", "10"] if command == "audit" else ["compare", two, two]
    status, _, err = _command(args, None, preexec_fn=lambda: os.close(1))
    assert (status, err) == (cli.PIPE_CLOSED, "")


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full (Linux)")
@pytest.mark.parametrize("command", ["audit", "compare", "compare-json"])
def test_a_full_disk_is_exit_2_with_one_line_naming_the_output(command: str, two: str) -> None:
    args = {
        "audit": ["audit", two, "--poses", "10"],
        "compare": ["compare", two, two],
        "compare-json": ["compare", two, two, "--json", "-"],
    }[command]
    with open("/dev/full", "w") as full:
        status, _, err = _command(args, full)
    assert status == 2
    assert err == (
        "redundancy: error: cannot write to standard output (/dev/full): "
        "[Errno 28] No space left on device\n"
    )


def test_names_the_terminal_cannot_encode_are_escaped(tmp_path) -> None:
    """Cyrillic joint names on a Latin-1 terminal: printed escaped, not exit 3 at the end."""
    import subprocess

    path = tmp_path / "cyrillic.xml"
    path.write_text(two_links("плечо", "локоть"), encoding="utf-8")
    latin1 = {"PYTHONIOENCODING": "latin-1"}
    status, out, err = _command(
        ["audit", str(path), "--poses", "10", "-q"], subprocess.PIPE, latin1
    )
    assert status == 1 and err == ""
    assert "joint '\\u043f\\u043b\\u0435\\u0447\\u043e' has no actuator" in out
    status, out, err = _command(["compare", str(path), str(path)], subprocess.PIPE, latin1)
    assert status == 0 and err == ""
    assert "joints matched: 2 (\\u043f\\u043b\\u0435\\u0447\\u043e, " in out
    # A name in an error message, on stderr, likewise.
    status, _, err = _command(["audit", str(path), "--frame", "рука"], subprocess.PIPE, latin1)
    assert status == 2 and err.startswith("redundancy: error: ") and "\\u0440\\u0443" in err


def test_one_json_convention_for_infinities(tmp_path, capsys) -> None:
    """compare wrote an infinite difference as the string "inf", the audit as null: null."""
    a, b = tmp_path / "a.xml", tmp_path / "b.xml"
    a.write_text(two_links())
    b.write_text(two_links(j2="elbow"))  # one joint each side only: presence, infinite
    streams = (sys.stdout, sys.stdout.errors, sys.stderr.errors)
    assert main(["compare", str(a), str(b), "--json", "-"]) == 1
    assert (sys.stdout, sys.stdout.errors, sys.stderr.errors) == streams  # put back
    text = capsys.readouterr().out
    document = json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} in the JSON"))
    presence = [d for d in document["differences"] if d["quantity"] == "presence"]
    assert presence and all(d["error"] is None for d in presence)
    assert '"inf"' not in text and "Infinity" not in text


def test_site_option_is_a_deprecated_name_of_frame(load_calls, capsys):
    message = "--site is deprecated: name the tool frame with --frame"
    with pytest.warns(DeprecationWarning, match=f"^{message}$"):
        assert main(["audit", PANDA, "--site", "ee"]) == 3
    assert capsys.readouterr().err.startswith(f"redundancy: warning: {message}\n")
    assert [k for _, k in load_calls] == [{"frame": "ee", "strict": True}]


# -- what a command reads, it never writes (issue 35) --------------------------------------
def _png() -> bytes:
    """A 1x1 red PNG."""
    import struct
    import zlib

    def chunk(kind: bytes, body: bytes) -> bytes:
        crc = zlib.crc32(kind + body) & 0xFFFFFFFF
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", crc)

    header = struct.pack(">IIBBBBB", 1, 1, 8, 2, 0, 0, 0)
    pixels = zlib.compress(b"\x00\xff\x00\x00")
    return (
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", pixels) + chunk(b"IEND", b"")
    )


@pytest.fixture
def many_files(tmp_path):
    """An MJCF that reads six files: an include of an include, an attached model with a
    mesh, and a texture named in an included file. Returns (the model, {name: path})."""
    (tmp_path / "sub").mkdir()
    written = {
        "top.xml": """<mujoco><compiler angle="radian"/><include file="mid.xml"/>
  <asset><model name="hand" file="hand.xml"/></asset>
  <worldbody><body name="l1"><joint name="j1" axis="0 1 0" range="-2 2"/>
    <geom type="capsule" fromto="0 0 0 0 0 0.5" size="0.05"/>
    <body name="mount" pos="0 0 0.5"><attach model="hand" body="palm" prefix="h_"/></body>
  </body></worldbody></mujoco>""",
        "mid.xml": '<mujoco><include file="sub/looks.xml"/></mujoco>',
        "sub/looks.xml": '<mujoco><asset><texture name="t" type="2d" file="red.png"/></asset>'
        "</mujoco>",
        "hand.xml": """<mujoco><asset><mesh name="tet" file="tet.stl"/></asset><worldbody>
  <body name="palm"><joint name="j2" axis="0 0 1" range="-1 1"/>
    <geom type="mesh" mesh="tet" mass="0.1"/><site name="tip" pos="0 0 0.1"/></body>
</worldbody></mujoco>""",
    }
    paths = {}
    for name, text in written.items():
        paths[name] = tmp_path / name
        paths[name].write_text(text)
    paths["tet.stl"], paths["red.png"] = tmp_path / "tet.stl", tmp_path / "red.png"
    write_stl(paths["tet.stl"])
    paths["red.png"].write_bytes(_png())
    return paths["top.xml"], paths


def test_json_never_replaces_a_file_the_model_reads(many_files, tmp_path, capsys, monkeypatch):
    """Issue 35: ``--json`` an included file destroyed the user's model. Every file the load
    read (includes at any depth, an attached model, its mesh, a texture) is refused, by
    any spelling (a symbolic link, ``..``), before the audit runs."""
    from redundancy.reports import audit

    model, paths = many_files
    # Ground truth outside the library: MuJoCo compiles the model from the file.
    assert mujoco_model(model).nq == 2
    before = {p: p.read_bytes() for p in paths.values()}

    def no_audit(*args, **kwargs):
        raise AssertionError("the audit ran before the --json target was checked")

    monkeypatch.setattr(audit, "audit", no_audit)
    link = tmp_path / "link.json"
    link.symlink_to(paths["sub/looks.xml"])
    targets = {str(paths[name]): paths[name] for name in paths if name != "top.xml"}
    targets[str(link)] = paths["sub/looks.xml"]
    targets[f"{tmp_path}/sub/../hand.xml"] = paths["hand.xml"]
    for target, read in targets.items():
        assert main(["audit", str(model), "--frame", "h_tip", "--json", target]) == 2
        assert capsys.readouterr().err == (
            f"redundancy: error: --json {target!r} is {str(read)!r}, a file the model "
            f"{str(model)!r} reads: not replaced\n"
        )
    assert {p: p.read_bytes() for p in paths.values()} == before


def mujoco_model(path):
    import mujoco

    return mujoco.MjModel.from_xml_path(str(path))


def _urdf_with_mesh(tmp_path):
    write_stl(tmp_path / "tet.stl")
    (tmp_path / "arm.srdf").write_text(
        '<robot name="r"><disable_collisions link1="base" link2="a" reason="Adjacent"/></robot>'
    )
    path = tmp_path / "arm.urdf"
    path.write_text(
        '<robot name="r"><link name="base"/><link name="a"><inertial><mass value="1"/>'
        '<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>'
        '<collision><geometry><mesh filename="tet.stl"/></geometry></collision></link>'
        '<joint name="j1" type="revolute"><parent link="base"/><child link="a"/>'
        '<axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="10" velocity="1"/></joint>'
        "</robot>"
    )
    return path


def test_json_never_replaces_the_srdf(tmp_path, capsys, no_work):
    model = _urdf_with_mesh(tmp_path)
    srdf = tmp_path / "arm.srdf"
    again = f"{tmp_path}/./arm.srdf"
    assert main(["audit", str(model), "--srdf", str(srdf), "--json", again]) == 2
    assert capsys.readouterr().err == (
        f"redundancy: error: --json {again!r} is the SRDF file {str(srdf)!r}: not replaced\n"
    )
    assert "disable_collisions" in srdf.read_text()


def test_json_never_replaces_a_urdf_mesh(tmp_path, capsys):
    model = _urdf_with_mesh(tmp_path)
    mesh = tmp_path / "tet.stl"
    before = mesh.read_bytes()
    assert main(["audit", str(model), "--json", str(mesh)]) == 2
    assert capsys.readouterr().err == (
        f"redundancy: error: --json {str(mesh)!r} is {str(mesh)!r}, a file the model "
        f"{str(model)!r} reads: not replaced\n"
    )
    assert mesh.read_bytes() == before


def test_compare_json_never_replaces_an_input(many_files, tmp_path, capsys, no_work):
    """compare's --json: neither model, nor the joint map (checked before loading)."""
    model, _ = many_files
    joint_map = tmp_path / "map.txt"
    joint_map.write_text("j1 j1\n")
    for target, what in (
        (model, f"the model file {str(model)!r}"),
        (joint_map, f"the joint map {str(joint_map)!r}"),
    ):
        args = ["compare", str(model), PANDA, "--joint-map", str(joint_map)]
        assert main([*args, "--json", str(target)]) == 2
        assert capsys.readouterr().err == (
            f"redundancy: error: --json {str(target)!r} is {what}: not replaced\n"
        )
    assert joint_map.read_text() == "j1 j1\n"


def test_compare_json_never_replaces_a_file_b_includes(many_files, capsys):
    model, paths = many_files
    mid = paths["mid.xml"]
    before = mid.read_bytes()
    assert main(["compare", str(model), str(model), "--frame", "h_tip", "--json", str(mid)]) == 2
    assert capsys.readouterr().err == (
        f"redundancy: error: --json {str(mid)!r} is {str(mid)!r}, a file the model "
        f"{str(model)!r} reads: not replaced\n"
    )
    assert mid.read_bytes() == before


@pytest.mark.parametrize("order", [("--frame", "--site"), ("--site", "--frame")])
def test_frame_and_site_naming_two_frames_are_refused(order, capsys, no_work):
    """Issue 35: ``--frame A --site B`` audited B (the last won); the Python API says frame
    wins. Two names for one option, two frames: refused naming both."""
    first, second = order
    assert main(["audit", PANDA, first, "ee", second, "link7"]) == 2
    assert capsys.readouterr().err == (
        f"redundancy audit: error: {first} 'ee' and {second} 'link7' name two tool frames "
        "(--site is the deprecated name of --frame): give one\n"
    )


def test_frame_and_site_naming_one_frame_load_it(load_calls, capsys):
    with pytest.warns(DeprecationWarning):
        assert main(["audit", PANDA, "--frame", "ee", "--site", "ee"]) == 3
    capsys.readouterr()
    assert [k for _, k in load_calls] == [{"frame": "ee", "strict": True}]


def _piped(text: bytes) -> str:
    """A /dev/fd path whose reader gets ``text`` (a shell's ``<(cat file)``)."""
    read, write = os.pipe()
    os.write(write, text)  # below the pipe's buffer: no writer thread needed
    os.close(write)
    return f"/dev/fd/{read}"


def test_an_mjcf_from_a_pipe_is_audited_as_from_its_file(tmp_path, capsys):
    """``redundancy audit <(cat model.xml)``: an MJCF through a pipe, in Latin-1 too, gives
    its file's report, as a URDF does (issue 35 saw a decoder error)."""
    latin1 = two_links("\xe9paule", "coude").encode("latin-1")
    xml = b'<?xml version="1.0" encoding="latin-1"?>\n' + latin1
    path = tmp_path / "arm.xml"
    path.write_bytes(xml)
    urdf = rd.model_path("panda").with_suffix(".urdf")
    reports = []
    for data, source in ((xml, path), (urdf.read_bytes(), urdf)):
        for given in (str(source), _piped(data)):
            assert main(["audit", given, "--poses", "10", "--json", "-"]) in (0, 1)
            document = json.loads(capsys.readouterr().out)
            for item in (*document["findings"], *document["notes"]):
                # The path given, and the line only where that path can be read again (not a pipe).
                item.pop("file"), item.pop("line")
            reports.append({k: v for k, v in document.items() if k != "model"})
    assert reports[0] == reports[1] and reports[2] == reports[3]
    assert [r["format"] for r in reports] == ["MJCF", "MJCF", "URDF", "URDF"]
    assert [j["name"] for j in reports[1]["joints"]] == ["\xe9paule", "coude"]


def test_a_pipe_names_where_its_relative_paths_count_from(tmp_path, capsys):
    """A piped model's relative paths count from /dev/fd (where MuJoCo looks, and a URDF's
    meshes): the error says the model came through a pipe."""
    (tmp_path / "body.xml").write_text(
        two_links().replace('<mujoco><compiler angle="radian"/>', "<mujoco>")
    )
    pipe = _piped(b'<mujoco><compiler angle="radian"/><include file="body.xml"/></mujoco>')
    assert main(["audit", pipe, "--poses", "10"]) == 2
    assert capsys.readouterr().err == (
        "redundancy: error: cannot read the included file 'body.xml': [Errno 2] No such file "
        f"or directory: '/dev/fd/body.xml' ({pipe!r} is a pipe, not a file: the paths in it "
        "count from '/dev/fd'; give the model's own file)\n"
    )

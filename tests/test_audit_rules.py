"""The audit's rules: declared once, listed in the guide, named by every finding and note."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import redundancy as rd
from redundancy.reports.audit import audit
from redundancy.reports.rules import RULES, rule

GUIDE = Path(__file__).resolve().parents[1] / "docs" / "guide" / "audit.md"


def test_rule_ids_are_stable_kebab_case_and_each_has_a_sentence():
    for r in RULES.values():
        assert re.fullmatch(r"[a-z]+(-[a-z]+)*", r.id), r.id
        assert r.severity in ("error", "warning", "note")
        assert r.summary.endswith(".") and len(r.summary) < 140, r.id


def test_the_guide_lists_every_rule_as_declared():
    text = GUIDE.read_text()
    for r in RULES.values():
        assert f"| `{r.id}` | {r.severity} | {r.kind} | {r.summary} |" in text, r.id


def test_an_undeclared_rule_is_a_key_error():
    with pytest.raises(KeyError):
        rule("no-such-rule")


MODELS = Path(__file__).resolve().parents[1] / "models"


@pytest.mark.parametrize("name", ["arm7.xml", "panda.urdf"])
def test_every_finding_and_note_names_a_declared_rule_with_its_severity(name):
    report = audit(rd.load(MODELS / name), n_poses=50, seed=0)
    assert report.findings or report.notes
    for item in (*report.findings, *report.notes):
        declared = RULES[item.rule]
        assert (item.kind, item.severity) == (declared.kind, declared.severity)


def test_arm7s_singular_keyframe_is_a_warning_naming_the_keyframe():
    report = audit(rd.load(rd.models.model_path("arm7")), n_poses=50, seed=0)
    singular = [f for f in report.findings if f.rule == "keyframe-singular"]
    assert [(f.severity, f.element) for f in singular] == [("warning", "zero")]
    data = report.to_dict()
    assert {"rule": "keyframe-singular", "severity": "warning", "element": "zero"}.items() <= (
        data["findings"][0].items()
    )


# -- plausible physics: each rule on a published file with the defect planted ------------------
def _planted(tmp_path, name, old, new):
    text = (MODELS / name).read_text()
    assert text.count(old) == 1, old
    path = tmp_path / name
    path.write_text(text.replace(old, new))
    return path, text.replace(old, new).splitlines()


def _raised(path, frame=None, rules=None):
    report = audit(rd.load(path, frame=frame), n_poses=20, seed=0)
    items = (*report.findings, *report.notes)
    return [i for i in items if rules is None or i.rule in rules]


def _line_of(lines, needle):
    return next(i + 1 for i, text in enumerate(lines) if needle in text)


def test_a_keyframe_outside_a_range_names_the_keyframe_joint_and_line(tmp_path):
    path, lines = _planted(
        tmp_path, "arm7.xml", 'qpos="0 0.5 0 1.6 0 1.0416 0"', 'qpos="0 0.5 0 3.25 0 1.0416 0"'
    )
    (f,) = _raised(path, rules={"keyframe-out-of-range"})
    assert (f.severity, f.element, f.file, f.line) == (
        "error",
        "home",
        str(path),
        _line_of(lines, '<key name="home"'),
    )
    assert "joint 'j4' at 3.25, above its range [-0.1, 2.9] rad by 0.35 rad" in f.message


def test_a_reference_pose_outside_a_range_is_a_note_naming_the_joint(tmp_path):
    path, lines = _planted(tmp_path, "arm7.xml", 'range="-0.1 2.9"', 'range="0.25 2.9"')
    raised = _raised(path, rules={"reference-out-of-range", "keyframe-out-of-range"})
    ref = [r for r in raised if r.rule == "reference-out-of-range"]
    assert [(r.severity, r.element, r.line) for r in ref] == [
        ("note", "j4", _line_of(lines, 'name="j4"'))
    ]
    assert "joint 'j4' at 0, below its range [0.25, 2.9] rad by 0.25 rad" in ref[0].message
    # keyframe zero puts j4 at 0 too; home (1.6) is inside
    assert [(r.rule, r.element) for r in raised if r.rule != "reference-out-of-range"] == [
        ("keyframe-out-of-range", "zero")
    ]


@pytest.mark.parametrize("attr", ["effort", "velocity"])
def test_a_zero_effort_or_velocity_limit_on_a_moving_joint_is_a_finding(tmp_path, attr):
    text = (MODELS / "panda.urdf").read_text()
    joint = re.search(r'<joint name="joint3".*?</joint>', text, re.S).group(0)
    planted = re.sub(rf'{attr}="[^"]*"', f'{attr}="0"', joint, count=1)
    assert planted != joint
    path = tmp_path / "panda.urdf"
    path.write_text(text.replace(joint, planted))
    lines = path.read_text().splitlines()
    (f,) = _raised(path, frame="ee", rules={f"{attr}-limit-zero"})
    assert (f.severity, f.element, f.line) == (
        "error",
        "joint3",
        _line_of(lines, '<joint name="joint3"'),
    )
    assert f'<limit {attr}="0">' in f.message


def test_mass_zero_on_a_moving_link_is_a_finding_naming_the_link_not_a_load_failure(tmp_path):
    path, lines = _planted(tmp_path, "panda.urdf", '<mass value="1.225946"/>', '<mass value="0"/>')
    (f,) = _raised(path, frame="ee", rules={"mass-not-positive"})
    assert (f.severity, f.element, f.line) == (
        "error",
        "link5",
        _line_of(lines, '<link name="link5"'),
    )
    assert "mass 0 kg" in f.message


@pytest.mark.parametrize(
    ("name", "frame", "notes"),
    [
        ("arm7.xml", None, []),
        # Franka's joint4 range is [-3.07, -0.07] rad: the zero pose is outside it (a note)
        ("panda.urdf", "ee", [("reference-out-of-range", "note", "joint4")]),
        ("panda.xml", None, [("reference-out-of-range", "note", "joint4")]),
    ],
)
def test_the_clean_published_files_raise_no_physics_error_or_warning(name, frame, notes):
    physics = {
        "keyframe-out-of-range",
        "reference-out-of-range",
        "effort-limit-zero",
        "velocity-limit-zero",
        "mass-not-positive",
    }
    raised = _raised(MODELS / name, frame, physics)
    assert [(r.rule, r.severity, r.element) for r in raised] == notes


PANDA_LINK4_INERTIA = (
    'ixx="0.025853" iyy="0.019552" izz="0.028323" ixy="0.007796" ixz="-0.001332" iyz="0.008641"'
)


def test_an_inertia_in_kg_mm2_is_named_with_its_ratio_and_unit(tmp_path):
    # link4's tensor written in kg mm^2: every value x 1e6
    scaled = " ".join(
        f'{k}="{float(v) * 1e6:g}"' for k, v in re.findall(r'(\w+)="([^"]+)"', PANDA_LINK4_INERTIA)
    )
    path, lines = _planted(tmp_path, "panda.urdf", PANDA_LINK4_INERTIA, scaled)
    raised = _raised(path, frame="ee", rules={"inertia-unit", "gyration-radius"})
    assert [(r.rule, r.severity, r.element, r.line) for r in raised] == [
        (rule_id, "error", "link4", _line_of(lines, '<link name="link4"'))
        for rule_id in ("inertia-unit", "gyration-radius")
    ]
    clean = rd.load(MODELS / "panda.urdf", frame="ee").mj_model
    planted = rd.load(path, frame="ee").mj_model
    body = clean.body("link4").id
    # the ratio over the clean file's is the planted 1e6 (the message's ratio is over the
    # geometry, so it is 1e6 times the clean link's ratio)
    assert planted.body_inertia[body].sum() / clean.body_inertia[body].sum() == pytest.approx(1e6)
    assert "likely kg mm^2 (x1e6) written as kg m^2" in raised[0].message


def test_a_centre_of_mass_1_m_from_its_link_names_the_link_and_distance(tmp_path):
    old = '<origin xyz="-0.05317 0.104419 0.027454" rpy="0 0 0"/>'
    path, lines = _planted(tmp_path, "panda.urdf", old, old.replace("0.027454", "1.027454"))
    (f,) = _raised(path, frame="ee", rules={"com-outside-link"})
    assert (f.severity, f.element, f.line) == (
        "error",
        "link4",
        _line_of(lines, '<link name="link4"'),
    )
    assert re.search(r"centre of mass 0\.9\d* m outside", f.message), f.message


@pytest.mark.parametrize(
    ("name", "frame"), [("arm7.xml", None), ("panda.urdf", "ee"), ("panda.xml", None)]
)
def test_the_clean_published_files_raise_no_inertia_rule(name, frame):
    rules = {"inertia-unit", "gyration-radius", "com-outside-link"}
    assert _raised(MODELS / name, frame, rules) == []


def test_element_lines_are_the_lines_of_the_start_tags():
    from redundancy.reports.locations import element_lines

    text = (
        '<mujoco>\n  <worldbody>\n    <body name="a">\n      <joint\n        name="j"/>\n'
        '    </body>\n  </worldbody>\n  <keyframe><key name="k"/></keyframe>\n</mujoco>\n'
    )
    assert element_lines(text) == {("link", "a"): 3, ("joint", "j"): 4, ("key", "k"): 8}
    assert element_lines("<robot><link name='x'>") == {}  # not well-formed: no lines

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

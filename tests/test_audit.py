"""`redundancy audit`: every finding is triggered by a tiny model made to have it."""

from __future__ import annotations

import json

import pytest

import redundancy as rd
from redundancy.cli import main
from redundancy.reports.audit import audit, format_report


def arm_xml(
    armature: str = "0.02 0.01",
    timestep: str = "0.002",
    limit: str = "50",
    key: str = "0.3 0.5",
    visual: str = "",
    axis_c: str = "1 0 0",
) -> str:
    """Two links (shoulder pitch, elbow pitch) with a motor each and one keyframe."""
    a1, a2 = armature.split()
    return f"""
<mujoco>
  <compiler angle="radian"/>
  <option timestep="{timestep}"/>
  <worldbody>
    <body name="l1" pos="0 0 0.1">
      <joint name="a" axis="0 1 0" range="-2 2" armature="{a1}" damping="0.1"/>
      <geom name="g1" type="capsule" fromto="0 0 0 0 0 0.3" size="0.04" mass="2"/>
      <body name="l2" pos="0 0 0.3">
        <joint name="b" axis="0 1 0" range="-2.8 2.8" armature="{a2}" damping="0.1"/>
        <geom name="g2" type="capsule" fromto="0 0 0 0 0 0.3" size="0.04" mass="1"/>
        <body name="l3" pos="0 0 0.3">
          <joint name="c" axis="{axis_c}" range="-1 1" armature="{a2}" damping="0.1"/>
          <geom name="g3" type="capsule" fromto="0 0 0 0.3 0 0" size="0.04" mass="0.5"/>
          {visual}
          <site name="tip" pos="0.3 0 0"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor joint="a" ctrlrange="-{limit} {limit}"/>
    <motor joint="b" ctrlrange="-50 50"/>
    <motor joint="c" ctrlrange="-50 50"/>
  </actuator>
  <keyframe><key name="k" qpos="{key} 0"/></keyframe>
</mujoco>
"""


def kinds(xml: str) -> list[str]:
    return [f.kind for f in audit(rd.load_string(xml, site="tip"), n_poses=300).findings]


def test_a_sound_model_has_no_findings():
    assert kinds(arm_xml()) == []


def test_zero_and_placeholder_armature():
    assert kinds(arm_xml(armature="0 0.01")) == ["armature"]
    report = audit(rd.load_string(arm_xml(armature="0.02 0.02"), site="tip"), n_poses=50)
    assert [f.message.split(":")[0] for f in report.findings] == [
        "every joint has the same armature 0.02 kg m^2"
    ]


def test_timestep_above_h_max():
    # Joint c: M_cc ~ 0.015 + 0.01 kg m^2, kd - b = 4.9: h_max ~ 10 ms < 20 ms.
    report = audit(rd.load_string(arm_xml(timestep="0.02"), site="tip"), n_poses=50)
    msgs = [f.message for f in report.findings if f.kind == "timestep"]
    assert msgs and msgs[0].startswith("timestep 20 ms is above joint 'c''s h_max")


def test_gravity_over_a_motor_limit():
    report = audit(rd.load_string(arm_xml(limit="2"), site="tip"), n_poses=300)
    msgs = [f.message for f in report.findings if f.kind == "gravity"]
    assert len(msgs) == 1 and msgs[0].startswith("gravity torque at joint 'a' reaches")


def test_keyframe_in_contact_and_singular():
    found = kinds(arm_xml(key="0 2.75"))  # elbow folded back onto the upper link
    assert "keyframe" in found
    # All three axes pitch about y and the arm stands straight: rank 2 of 3.
    straight = arm_xml(key="0 0", axis_c="0 1 0").replace('pos="0.3 0 0"/>', 'pos="0 0 0.3"/>')
    report = audit(rd.load_string(straight, site="tip"), n_poses=50)
    assert any(f.message.startswith("keyframe 'k' is singular") for f in report.findings)


def test_engine_disagreement_is_a_finding():
    visual = '<geom type="sphere" size="0.03" contype="0" conaffinity="0" mass="0.2"/>'
    report = audit(rd.load_string(arm_xml(visual=visual), site="tip"), n_poses=50)
    engines = [f.message for f in report.findings if f.kind == "engines"]
    assert any(m.startswith("models differ: body mass of body moved by c") for m in engines)
    assert any(m.startswith("engines disagree on gravity") for m in engines)


@pytest.mark.parametrize(("model", "status"), [("arm7", 1), ("panda", 0)])
def test_cli_on_both_bundled_models(model, status, tmp_path, capsys):
    out = tmp_path / "report.json"
    path = str(rd.model_path(model))
    assert main(["audit", path, "--poses", "500", "--json", str(out)]) == status
    text = capsys.readouterr().out
    assert text.splitlines()[0] == f"audit of {path} (site 'ee')"
    data = json.loads(out.read_text())
    assert set(data) == {
        "model",
        "site",
        "joints",
        "timestep",
        "kd",
        "keyframes",
        "gravity",
        "collision",
        "crosscheck",
        "equivalence",
        "findings",
    }
    assert data["crosscheck"]["ok"] and data["equivalence"]["equivalent"]
    assert len(data["findings"]) == (status == 1) * len(data["findings"])


def test_arm7_audit_findings(capsys):
    assert main(["audit", str(rd.model_path("arm7")), "--poses", "300"]) == 1
    text = capsys.readouterr().out
    findings = text.split("findings: ")[1].splitlines()[1:]
    # The zero keyframe is the lesson's singular pose; 0.05 on every joint is its
    # illustrative (not datasheet) armature.
    assert [line.split(":")[0] for line in findings] == [
        "  [armature] every joint has the same armature 0.05 kg m^2",
        "  [keyframe] keyframe 'zero' is singular",
    ]


def test_json_to_stdout_and_bad_input_exit_code(capsys):
    assert main(["audit", str(rd.model_path("panda")), "--poses", "50", "--json", "-"]) == 0
    assert json.loads(capsys.readouterr().out)["site"] == "ee"
    assert main(["audit", "/nonexistent.xml"]) == 2
    assert capsys.readouterr().err == "redundancy: error: MJCF file not found: '/nonexistent.xml'\n"
    assert main(["audit", str(rd.model_path("panda")), "--site", "tcp"]) == 2
    assert "valid site names: ['ee']" in capsys.readouterr().err


def test_report_lines_are_printable():
    lines = format_report(audit(rd.load(rd.model_path("arm7")), n_poses=100))
    assert lines[-1].startswith("  [keyframe] keyframe 'zero' is singular")


def test_json_report_is_written_atomically(tmp_path, monkeypatch):
    from redundancy.reports import audit as audit_mod

    target = tmp_path / "report.json"
    target.write_text("old")
    audit_mod.write_atomic(target, "new")
    assert target.read_text() == "new"

    def crash(src, dst):
        raise OSError("disk pulled out")

    monkeypatch.setattr(audit_mod.os, "replace", crash)
    with pytest.raises(OSError, match="disk pulled out"):
        audit_mod.write_atomic(target, "half-written?")
    assert target.read_text() == "new"  # the old file, whole
    assert [p.name for p in tmp_path.iterdir()] == ["report.json"]  # no temporary left behind

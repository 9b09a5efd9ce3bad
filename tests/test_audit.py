"""`redundancy audit`: every finding is triggered by a tiny model made to have it.

Where the finding is about what MuJoCo simulates (an actuator range per direction, gravity
compensation, the eulerdamp and gravity flags, servo damping under each integrator), the test
also simulates the model's hold in MuJoCo and requires the audit to say what the simulation
shows.
"""

from __future__ import annotations

import json
import warnings

import mujoco
import numpy as np
import pytest

import redundancy as rd
from redundancy.cli import main
from redundancy.collision import collision_statistics
from redundancy.engines.mujoco import captured_warnings
from redundancy.errors import ParameterError
from redundancy.lab.control import simulate_hold
from redundancy.reports import sections
from redundancy.reports.audit import audit, format_report

#: A hold "sags" or "buzzes" when some joint reaches this speed [rad/s]; the hold starts with
#: a 0.01 rad/s nudge and a held arm stays within about that.
MOVES = 0.5


def arm_xml(
    armature: str = "0.02 0.01",
    timestep: str = "0.002",
    ctrl_a: str = "-50 50",
    key: str = "0.3 0.5",
    visual: str = "",
    axis_c: str = "1 0 0",
    option: str = "",
    flags: str = "",
    gravcomp: str = "",
    damping: str = "0.1",
    actuators: str | None = None,
) -> str:
    """Two pitch links and a roll link with a motor each and one keyframe ``k``."""
    a1, a2 = armature.split()
    gc = f'gravcomp="{gravcomp}"' if gravcomp else ""
    act = actuators or (
        f'<motor joint="a" ctrlrange="{ctrl_a}"/><motor joint="b" ctrlrange="-50 50"/>'
        '<motor joint="c" ctrlrange="-50 50"/>'
    )
    return f"""
<mujoco>
  <compiler angle="radian"/>
  <option timestep="{timestep}" {option}>{flags}</option>
  <worldbody>
    <body name="l1" pos="0 0 0.1" {gc}>
      <joint name="a" axis="0 1 0" range="-2 2" armature="{a1}" damping="{damping}"/>
      <geom name="g1" type="capsule" fromto="0 0 0 0 0 0.3" size="0.04" mass="2"/>
      <body name="l2" pos="0 0 0.3" {gc}>
        <joint name="b" axis="0 1 0" range="-2.8 2.8" armature="{a2}" damping="{damping}"/>
        <geom name="g2" type="capsule" fromto="0 0 0 0 0 0.3" size="0.04" mass="1"/>
        <body name="l3" pos="0 0 0.3" {gc}>
          <joint name="c" axis="{axis_c}" range="-1 1" armature="{a2}" damping="{damping}"/>
          <geom name="g3" type="capsule" fromto="0 0 0 0.3 0 0" size="0.04" mass="0.5"/>
          {visual}
          <site name="tip" pos="0.3 0 0"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>{act}</actuator>
  <keyframe><key name="k" qpos="{key} 0"/></keyframe>
</mujoco>
"""


def run(xml: str, n_poses: int = 300, **kw) -> tuple[rd.Arm, list[str], list[str]]:
    arm = rd.load_string(xml, frame="tip")
    r = audit(arm, n_poses=n_poses, **kw)
    return arm, [f.kind for f in r.findings], [f.message for f in r.findings]


def kinds(xml: str) -> list[str]:
    return run(xml)[1]


def moves(arm: rd.Arm, kp: float = 100.0, kd: float = 5.0, compensate: bool = True) -> bool:
    """Whether MuJoCo's 2 s hold of keyframe k sags or buzzes (the lesson's controller)."""
    r = simulate_hold(arm.mj_model, arm.keyframe("k"), kp, kd, 2.0, gravity_compensation=compensate)
    return bool(r.bad_qacc_warnings or np.max(r.peak_speed) > MOVES)


def test_a_sound_model_has_no_findings():
    arm, found, _ = run(arm_xml())
    assert found == []
    assert not moves(arm)


def test_zero_and_placeholder_armature_are_notes_not_findings():
    # Armature is a value the file gives or not: the model's numbers show no problem by it.
    report = audit(rd.load_string(arm_xml(armature="0 0.01"), frame="tip"), n_poses=50)
    assert report.findings == ()
    assert [(n.kind, n.message.split(":")[0]) for n in report.notes] == [
        ("armature", "zero armature on 'a'")
    ]
    report = audit(rd.load_string(arm_xml(armature="0.02 0.02"), frame="tip"), n_poses=50)
    assert report.findings == ()
    assert [n.message.split(":")[0] for n in report.notes] == [
        "every joint has the same armature 0.02 kg m^2"
    ]


def test_timestep_above_h_max_is_asked_with_kd_only():
    # Motors and implicit joint damping: no controller in the file, no explicit damping, so
    # the question is not asked. With kd = 5 written to ctrl, joint c (M_cc ~ 0.0004 +
    # 0.01 kg m^2, kd - b = 4.9) allows h_max ~ 4 ms < 20 ms.
    _, found, _ = run(arm_xml(timestep="0.02"), n_poses=50)
    assert found == []
    _, found, msgs = run(arm_xml(timestep="0.02"), n_poses=50, kd=5.0)
    assert found == ["timestep"]
    assert msgs[0].startswith("timestep 20 ms is above the h_max 4.24 ms of joint 'c' (M_ii")
    assert "kd 5 N m s/rad written to ctrl" in msgs[0]


@pytest.mark.parametrize("timestep", ["0", "-0.001"])
def test_a_timestep_that_is_not_positive_is_a_finding(timestep):
    _, found, msgs = run(arm_xml(timestep=timestep), n_poses=20)
    assert found == ["timestep"]
    assert msgs[0].startswith(f"timestep {float(timestep):g} s is not positive")


def test_asymmetric_ctrlrange_is_judged_per_direction_as_mujoco_holds_it():
    # Holding k needs about -4.8 N m at joint a. A motor with ctrlrange "-2 50" is no weaker
    # than +-50 in the positive direction and far weaker in the negative one.
    arm, found, msgs = run(arm_xml(ctrl_a="-2 50"))
    row = audit(arm, n_poses=10).sections.joints.rows[0]
    assert (row.effort_lower, row.effort_upper) == (-2.0, 50.0)
    assert "keyframe 'k' cannot be held: joint 'a' needs -4.798 N m" in msgs[0]
    gravity = [m for f, m in zip(found, msgs, strict=True) if f == "gravity"]
    assert len(gravity) == 1 and gravity[0].startswith(
        "gravity at joint 'a' needs more negative torque than its actuators give"
    )
    assert moves(arm)  # MuJoCo: the clamped motor lets the arm sag
    # The mirror range holds k, and MuJoCo holds it too.
    arm, found, _ = run(arm_xml(ctrl_a="-50 2"))
    assert "keyframe" not in found and found.count("gravity") == 1
    assert not moves(arm)


@pytest.mark.parametrize(("gravcomp", "held"), [("", False), ("1", True), ("0.5", False)])
def test_gravcomp_relieves_the_motors_as_in_mujoco(gravcomp, held):
    # +-2 N m motors cannot hold the arm; full gravity compensation does it for them.
    arm, found, msgs = run(arm_xml(ctrl_a="-2 2", gravcomp=gravcomp))
    assert (found == []) == held
    if gravcomp == "0.5":
        assert "needs -2.399 N m" in msgs[0]  # half of the 4.798 N m without compensation
    # MuJoCo: a PD without feed-forward, clamped by ctrlrange (gravcomp is a passive force).
    assert moves(arm, compensate=False) != held


def test_actuatorgravcomp_counts_against_the_joint_actuatorfrcrange():
    # Compensation sent through the actuators is clamped with them by actuatorfrcrange.
    def xml(routed: str) -> str:
        return arm_xml(gravcomp="1").replace(
            'armature="0.02" damping="0.1"/>',
            f'armature="0.02" damping="0.1" actuatorfrcrange="-2 2" {routed}/>',
        )

    arm, found, msgs = run(xml('actuatorgravcomp="true"'))
    assert "keyframe" in found and "needs 0 N m" not in msgs[0]
    assert moves(arm, compensate=False)
    arm, found, _ = run(xml(""))  # passive compensation: the clamp has nothing to hold
    assert found == []
    assert not moves(arm, compensate=False)


def test_forcerange_and_ctrlrange_whichever_binds():
    motors = (
        '<motor joint="a" gear="10" ctrlrange="-5 5" forcerange="-0.3 0.4" forcelimited="true"/>'
        '<motor joint="b" gear="2" ctrlrange="-1 3"/><motor joint="c" ctrlrange="-50 50"/>'
    )
    arm = rd.load_string(arm_xml(actuators=motors), frame="tip")
    rows = sections.joints(arm).rows
    assert (rows[0].effort_lower, rows[0].effort_upper) == (-3.0, 4.0)  # forcerange x gear
    assert (rows[1].effort_lower, rows[1].effort_upper) == (-2.0, 6.0)  # ctrlrange x gear
    capped = arm_xml(actuators=motors).replace(
        'range="-2 2" armature', 'range="-2 2" actuatorfrcrange="-1 1" armature'
    )
    rows = sections.joints(rd.load_string(capped, frame="tip")).rows
    assert (rows[0].effort_lower, rows[0].effort_upper) == (-1.0, 1.0)  # the joint's clamp


@pytest.mark.parametrize("eulerdamp", [True, False])
def test_eulerdamp_flag_changes_the_bound_as_in_mujoco(eulerdamp):
    # Joint damping 8 N m s/rad at h = 10 ms: implicit under Euler, it makes any step stable
    # for kd 5; explicit (eulerdamp disabled), joint c's 0.0104 kg m^2 allows 1.6 ms.
    flags = "" if eulerdamp else '<flag eulerdamp="disable"/>'
    arm, found, msgs = run(arm_xml(damping="8", timestep="0.01", flags=flags))
    assert ("timestep" in found) != eulerdamp
    if not eulerdamp:
        assert "Euler with eulerdamp disabled integrates all damping explicitly" in msgs[0]
    assert moves(arm, kp=0.0) != eulerdamp


def test_gravity_flag_the_budget_follows_mujoco():
    weak = arm_xml(ctrl_a="-2 2", flags='<flag gravity="disable"/>')
    arm, found, msgs = run(weak)
    assert found == ["simulation"]  # both engines see no gravity (Pinocchio's is bridged)
    assert msgs[0].startswith(
        'gravity is disabled (<flag gravity="disable"/>): MuJoCo simulates the arm weightless, '
        "ignoring gravity [0, 0, -9.81] m/s^2"
    )
    assert not moves(arm, compensate=False)
    arm, found, _ = run(arm_xml(ctrl_a="-2 2"))
    assert "gravity" in found and moves(arm, compensate=False)


SERVOS = "".join(f'<position joint="{j}" kp="200" kv="5" ctrlrange="-2.8 2.8"/>' for j in "abc")


@pytest.mark.parametrize(("integrator", "stable"), [("Euler", False), ("implicitfast", True)])
def test_servo_damping_is_read_from_the_actuators(integrator, stable):
    # Position servos (kv 5) at h = 10 ms: Euler integrates kv explicitly and joint c
    # (0.0104 kg m^2) allows 4.2 ms; implicitfast integrates it implicitly.
    xml = arm_xml(key="0 0", timestep="0.01", actuators=SERVOS, option=f'integrator="{integrator}"')
    arm = rd.load_string(xml, frame="tip")
    report = audit(arm, n_poses=100)
    rows = report.sections.joints.rows
    assert [r.servo_kv for r in rows] == [5.0, 5.0, 5.0] and [r.kd for r in rows] == [0, 0, 0]
    timestep = [f.message for f in report.findings if f.kind == "timestep"]
    assert (timestep == []) == stable
    if stable:  # the damping leaves no bound; the servo's kp 200 leaves one above 10 ms
        assert all(0.01 < r.h_max < np.inf for r in rows)
        assert report.sections.joints.note.startswith("implicitfast integrates joint damping")
    text = " ".join(line.strip() for line in format_report(report))
    assert "kv, kp: a servo's velocity and position gains" in text  # the joint table's key
    # MuJoCo: ctrl 0 is the servo's own target, keyframe k; no controller of ours.
    assert moves(arm, kp=0.0, kd=0.0, compensate=False) != stable


def test_kd_asks_the_explicit_damping_question_under_implicitfast():
    # A kd written to ctrl stays explicit under implicitfast (lesson 5.2, output (5)).
    xml = arm_xml(timestep="0.01", option='integrator="implicitfast"')
    _, found, _ = run(xml, kd=1.0)
    assert "timestep" not in found
    arm, found, msgs = run(xml, kd=50.0)
    assert "timestep" in found
    assert "only a kd written to ctrl is explicit" in next(m for m in msgs if "timestep" in m)
    assert moves(arm, kp=0.0, kd=50.0)
    assert not moves(arm, kp=0.0, kd=1.0)


def test_gravity_over_a_motor_limit():
    _, found, msgs = run(arm_xml(ctrl_a="-2 2"))
    gravity = [m for f, m in zip(found, msgs, strict=True) if f == "gravity"]
    assert [m.split(" torque")[0] for m in gravity] == [
        "gravity at joint 'a' needs more negative",
        "gravity at joint 'a' needs more positive",
    ]


def test_keyframe_in_contact_and_singular():
    found = kinds(arm_xml(key="0 2.75"))  # elbow folded back onto the upper link
    assert "keyframe" in found
    # All three axes pitch about y and the arm stands straight: rank 2 of 3.
    straight = arm_xml(key="0 0", axis_c="0 1 0").replace('pos="0.3 0 0"/>', 'pos="0 0 0.3"/>')
    report = audit(rd.load_string(straight, frame="tip"), n_poses=50)
    assert any(f.message.startswith("keyframe 'k' is singular") for f in report.findings)


def test_engine_disagreement_is_a_finding():
    # Pinocchio's parser drops the contents of <frame> (a body of 0.2 kg here); the loader
    # bridges only inertia summed from geoms, so this difference stays (lenient load).
    lost = (
        '<inertial pos="0.15 0 0" mass="0.5" diaginertia="1e-4 1e-4 1e-4"/><frame pos="0.1 0 0">'
        '<body name="lost"><inertial pos="0 0 0" mass="0.2" diaginertia="1e-4 1e-4 1e-4"/>'
        "</body></frame>"
    )
    report = audit(rd.load_string(arm_xml(visual=lost), frame="tip", strict=False), n_poses=50)
    engines = [f.message for f in report.findings if f.kind == "engines"]
    assert any(m.startswith("models differ: body mass of body moved by c") for m in engines)
    assert any(m.startswith("engines disagree on gravity") for m in engines)


def test_chunks_give_the_numbers_of_one_sweep(monkeypatch, arm7):
    whole_g = sections.gravity_budget(arm7, 250, 3)
    whole_c = collision_statistics(arm7, 250, 4, distances="coal")
    whole_x = audit(arm7, 250, 3).engines.crosscheck
    monkeypatch.setattr(sections, "CHUNK", 60)  # 5 chunks, the last of 10 poses
    g = sections.gravity_budget(arm7, 250, 3)
    c = sections.contacts(arm7, 250, 4)
    x = audit(arm7, 250, 3).engines.crosscheck
    for name in ("low", "high", "over_low", "over_high", "limit_lower", "limit_upper"):
        assert np.array_equal(getattr(g, name), getattr(whole_g, name)), name
    assert (g.n_over, g.engine_diff) == (whole_g.n_over, whole_g.engine_diff)
    assert (c.n_poses, c.poses_with_contact, c.disagreements) == (
        whole_c.n_poses,
        whole_c.poses_with_contact,
        whole_c.disagreements,
    )
    for p, w in zip(c.pairs, whole_c.pairs, strict=True):
        assert (p.poses, p.contacts, p.closest, p.closest_pose) == (
            w.poses,
            w.contacts,
            w.closest,
            w.closest_pose,
        )
    assert x.agreements == whole_x.agreements


def test_a_one_joint_arm_is_audited():
    xml = """
<mujoco>
  <worldbody>
    <body name="l1"><joint name="a" axis="0 1 0" range="-2 2" armature="0.01"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.04" mass="1"/>
      <site name="tip" pos="0.3 0 0"/></body>
  </worldbody>
  <actuator><motor joint="a" ctrlrange="-5 5"/></actuator>
</mujoco>"""
    report = audit(rd.load_string(xml, frame="tip"), n_poses=40)
    assert [r.name for r in report.sections.joints.rows] == ["a"]
    assert report.engines.crosscheck.ok
    assert report.sections.gravity.n_over == 0
    assert format_report(report)[:2] == [
        "audit of <string>",
        "  MJCF, tool frame 'tip', strict mode",
    ]


@pytest.mark.parametrize("length", [30, 250])
def test_every_line_fits_100_characters_at_any_name_length(length):
    name = ("shoulder_pan_joint_of_a_long_arm_" * 10)[:length]
    xml = arm_xml(ctrl_a="-20 20", armature="0.0001398 0.0001398").replace(
        'joint name="a"', f'joint name="{name}"'
    )
    # No motor on the long-named joint: a finding names it.
    xml = xml.replace('<motor joint="a" ctrlrange="-20 20"/>', "").replace(
        'body name="l3"', f'body name="{name[:-1]}X"'
    )
    lines = format_report(audit(rd.load_string(xml, frame="tip"), n_poses=20))
    assert max(len(line) for line in lines) <= 100
    assert "200.0001398" not in "\n".join(lines)
    # The joint table: the first column holds the whole name, folded within the column when
    # it is wider than the table allows; the other cells of its row stay whole.
    start = lines.index(next(x for x in lines if x.startswith("  joint ")))
    header = lines[start]
    width = header.index("type") - 2
    folded = []
    for row in lines[start + 1 :]:
        folded.append(row[2:width].strip())
        if "hinge" in row:
            assert row[width:].split()[:2] == ["hinge", "[-2,"]
        if not row[width:].strip() and len("".join(folded)) >= length:
            break
        if len("".join(folded)) >= length:
            break
    assert "".join(folded) == name
    text = " ".join(line.strip() for line in lines)
    assert f"joint '{name[:40]}" in text


@pytest.mark.parametrize(("model", "status"), [("arm7", 1), ("panda", 0)])
def test_cli_on_both_bundled_models(model, status, tmp_path, capsys):
    out = tmp_path / "report.json"
    path = str(rd.model_path(model))
    assert main(["audit", path, "--poses", "500", "--json", str(out)]) == status
    text = capsys.readouterr().out
    assert text.splitlines()[1] == "  MJCF, tool frame 'ee', strict mode"
    data = json.loads(out.read_text())
    assert set(data) == {
        "model",
        "format",
        "frame",
        "mode",
        "simulation",
        "kd",
        "reference_keyframe",
        "timestep_note",
        "joints",
        "followers",
        "keyframes",
        "gravity",
        "collision",
        "crosscheck",
        "equivalence",
        "notes",
        "findings",
        "contact_mass",
        "robot",
    }
    assert data["robot"] == {
        "held": {},
        "rest": "qpos0",
        "base": None,
        "set_aside": [],
        "frozen": {},
        "mended": [],
    }
    cm = data["contact_mass"]
    assert cm["n_poses"] == 500 and cm["payload"] == 0.0
    assert cm["with_armature"][0] <= cm["with_armature"][1] <= cm["with_armature"][2]
    assert all(a >= b for a, b in zip(cm["with_armature"], cm["without_armature"], strict=True))
    assert "effective mass at the tool (ISO/TS 15066 transient contact)" in text
    integrator = {"arm7": "Euler", "panda": "implicitfast"}[model]
    assert data["mode"] == "strict" and data["simulation"]["integrator"] == integrator
    assert data["crosscheck"]["ok"] and data["equivalence"]["equivalent"]
    # The exit status and the report's findings say the same thing.
    assert (status == 1) == (len(data["findings"]) > 0)
    assert f"findings: {len(data['findings'])}" in text


def test_arm7_audit_findings(capsys):
    assert main(["audit", str(rd.model_path("arm7")), "--poses", "300"]) == 1
    text = capsys.readouterr().out
    findings = text.split("findings: ")[1].splitlines()
    # The zero keyframe is arm7's singular pose by design (the arm stretched straight up);
    # 0.05 on every joint is its illustrative (not datasheet) armature: a note.
    assert findings == [
        "1",
        "  [keyframe] keyframe 'zero' is singular: sigma_min 0.00e+00 < 0.001, rank 3 (lost: "
        "translation y,",
        "    translation z, rotation x)",
    ]
    notes = text.split("notes (what the file does not say): ")[1].split("findings:")[0]
    assert notes.splitlines()[1].startswith(
        "  [armature] every joint has the same armature 0.05 kg m^2"
    )


def test_report_lines_are_printable():
    lines = format_report(audit(rd.load(rd.model_path("arm7")), n_poses=100))
    assert all(line.isprintable() and len(line) <= 100 for line in lines)
    assert lines[-2].startswith("  [keyframe] keyframe 'zero' is singular")


@pytest.mark.parametrize(
    ("kw", "message"),
    [
        ({"n_poses": 0}, "n_poses must be an integer >= 1, got 0"),
        ({"n_poses": 1.5}, "n_poses must be an integer >= 1, got 1.5"),
        ({"seed": -5}, "seed must be an integer >= 0, got -5"),
        ({"kd": float("nan")}, "kd must be a finite number >= 0 [N m s/rad], got nan"),
        ({"kd": -1.0}, "kd must be a finite number >= 0 [N m s/rad], got -1.0"),
        ({"kd": "5"}, "kd must be a finite number >= 0 [N m s/rad], got '5'"),
    ],
)
def test_audit_parameters_are_checked(arm7, kw, message):
    with pytest.raises(ParameterError) as err:
        audit(arm7, **{"n_poses": 10, **kw})
    assert str(err.value) == message


def _free_run(arm: rd.Arm, seconds: float = 2.0) -> bool:
    """Whether MuJoCo's own mj_step (RK4 included) lets keyframe k's nudge grow, no control."""
    m = arm.mj_model
    d = mujoco.MjData(m)
    d.qpos[:] = arm.keyframe("k")
    d.qvel[:] = 0.01
    peak = 0.0
    with captured_warnings():
        for _ in range(round(seconds / m.opt.timestep)):
            mujoco.mj_step(m, d)  # simulate_hold steps in two halves, which MuJoCo runs as Euler
            peak = max(peak, float(np.max(np.abs(d.qvel))))
    return bool(d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number or peak > MOVES)


@pytest.mark.parametrize(
    ("integrator", "flags", "timestep", "stable"),
    [
        ("RK4", "", "0.003", True),  # joint c: h D / I = 2.3 < 2.785
        ("Euler", '<flag eulerdamp="disable"/>', "0.003", False),  # 2.3 > 2
        ("RK4", "", "0.005", False),  # 3.8 > 2.785
    ],
)
def test_rk4_bound_as_in_mujoco(integrator, flags, timestep, stable):
    xml = arm_xml(
        damping="8",
        timestep=timestep,
        flags=flags,
        option=f'integrator="{integrator}" gravity="0 0 0"',
    )
    arm, found, _ = run(xml, kd=0.0)
    assert ("timestep" not in found) == stable
    assert _free_run(arm) != stable


@pytest.mark.parametrize(("force", "held"), [("2", False), ("50", True)])
def test_a_servo_is_limited_by_its_forcerange_as_in_mujoco(force, held):
    # Position servos hold keyframe k (their ctrl 0 is k) on a base tilted by 1.2 rad: joint a
    # needs 9.9 N m there; the servo's forcerange, not its ctrlrange (a target position), binds.
    servos = "".join(
        f'<position joint="{j}" kp="500" kv="20" ctrlrange="-0.5 0.5" forcerange="-{force} '
        f'{force}"/>'
        for j in "abc"
    )
    xml = arm_xml(key="0 0", actuators=servos, option='integrator="implicitfast"').replace(
        'pos="0 0 0.1"', 'pos="0 0 0.1" euler="0 1.2 0"'
    )
    arm, found, msgs = run(xml)
    rows = sections.joints(arm).rows
    assert (rows[0].effort_lower, rows[0].effort_upper) == (-float(force), float(force))
    assert ("keyframe" not in found) == held
    if not held:
        assert msgs[0].startswith("keyframe 'k' cannot be held: joint 'a' needs")
    assert moves(arm, kp=0.0, kd=0.0, compensate=False) != held


@pytest.mark.parametrize(
    "factors",
    [{"l1": 0.6, "l2": 0.6, "l3": 0.6}, {"l2": 0.4}, {"l1": 0.4, "l2": 0.7, "l3": 1.0}],
)
def test_holding_torque_is_mujocos_bias_minus_its_gravcomp(factors):
    # Uniform factors take gravity x factor; mixed ones a MuJoCo engine of the scaled arm.
    xml = arm_xml()
    for body, factor in factors.items():
        xml = xml.replace(f'name="{body}" pos=', f'name="{body}" gravcomp="{factor}" pos=')
    arm = rd.load_string(xml, frame="tip")
    row = sections.keyframes(arm)[0]
    d = mujoco.MjData(arm.mj_model)
    d.qpos[:] = arm.keyframe("k")
    mujoco.mj_forward(arm.mj_model, d)
    np.testing.assert_allclose(row.hold, d.qfrc_bias - d.qfrc_gravcomp, rtol=0, atol=1e-12)
    assert np.max(np.abs(d.qfrc_gravcomp)) > 0.1  # the compensation is really there


def test_every_sweep_works_in_chunks(monkeypatch, arm7):
    # Memory stays flat in the number of poses when no engine call sees more than a chunk
    # (measured through the CLI: 153.1 MB resident at 10 000 poses, 154.0 MB at 1 000 000).
    from redundancy.reports import audit as audit_module

    seen: list[int] = []

    def spy(module, name):
        real = getattr(module, name)

        def wrapped(arm, *args, **kwargs):
            stack = kwargs.get("poses", args[0] if args else None)
            seen.append(len(stack) if stack is not None and np.ndim(stack) == 2 else -1)
            return real(arm, *args, **kwargs)

        monkeypatch.setattr(module, name, wrapped)

    spy(sections.batch, "gravities")
    spy(sections, "collision_statistics")
    spy(audit_module, "crosscheck_batch")
    monkeypatch.setattr(sections, "CHUNK", 40)
    audit(arm7, 130)
    assert len(seen) > 10 and max(seen) == 40 and -1 not in seen


def test_a_joint_without_actuator_that_gravity_loads_is_a_finding():
    xml = arm_xml().replace('<motor joint="b" ctrlrange="-50 50"/>', "")
    _, found, msgs = run(xml)
    assert found == ["gravity"]
    assert msgs[0].startswith("joint 'b' has no actuator, and gravity loads it with up to")


def test_no_controller_damping_is_assumed_without_kd():
    # No kd given: no controller is assumed on any joint, motor- or servo-driven; the damping
    # that bounds the timestep is the model's own (the joints', the servos' kv).
    actuators = (
        '<position joint="a" kp="300" kv="4" ctrlrange="-2 2"/>'
        '<motor joint="b" ctrlrange="-50 50"/><motor joint="c" ctrlrange="-50 50"/>'
    )
    arm = rd.load_string(arm_xml(actuators=actuators), frame="tip")
    rows = sections.joints(arm).rows
    assert [r.kd for r in rows] == [0.0, 0.0, 0.0]
    assert [r.servo_kv for r in rows] == [4.0, 0.0, 0.0]
    assert [r.h_max < np.inf for r in rows] == [True, False, False]
    assert [r.kd for r in sections.joints(arm, kd=2.0).rows] == [2.0, 2.0, 2.0]


@pytest.mark.parametrize(("kp", "stable"), [(200.0, True), (2000.0, False)])
def test_a_stiff_servo_needs_a_small_step_even_under_implicitfast(kp, stable):
    # kp is explicit under every integrator (MuJoCo's implicit ones take velocity derivatives
    # only): joint c (0.0104 kg m^2, damping 0.1 implicit) allows
    # h < (0.1 + sqrt(0.01 + 4 kp I)) / kp: 14.9 ms at kp 200, 4.6 ms at kp 2000; h = 10 ms.
    servos = "".join(f'<position joint="{j}" kp="{kp}" ctrlrange="-2 2"/>' for j in "abc")
    xml = arm_xml(key="0 0", timestep="0.01", actuators=servos, option='integrator="implicitfast"')
    arm, found, msgs = run(xml)
    row = audit(arm, n_poses=10).sections.joints.rows[2]
    assert row.stiffness == kp
    assert row.h_max == pytest.approx((0.1 + np.sqrt(0.01 + 4 * kp * row.m_ii)) / kp)
    assert ("timestep" not in found) == stable
    if not stable:
        assert "explicit stiffness 2000 N m/rad" in next(m for m in msgs if "timestep" in m)
    assert moves(arm, kp=0.0, kd=0.0, compensate=False) != stable


def test_an_unlimited_servo_has_effort_none_and_nothing_overflows():
    # Servos without a forcerange (as the Menagerie iiwa14's): MuJoCo applies no limit. The
    # effort was +-1.8e308 (numpy's largest float for infinity) and its ratios overflowed.
    servos = "".join(
        f'<general joint="{j}" gaintype="fixed" biastype="affine" gainprm="2000" '
        f'biasprm="0 -2000 -200" ctrlrange="-2 2"/>'
        for j in "abc"
    )
    xml = arm_xml(key="0.3 0.5", actuators=servos, option='integrator="implicitfast"')
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        report = audit(rd.load_string(xml, frame="tip"), n_poses=50)
        lines = format_report(report)
        data = json.loads(report.to_json())
    rows = report.sections.joints.rows
    assert [(r.effort_lower, r.effort_upper) for r in rows] == [(-np.inf, np.inf)] * 3
    assert [j["effort_upper"] for j in data["joints"]] == [None] * 3
    text = "\n".join(lines)
    assert "e+308" not in text and "np.float64" not in text
    joint_a = next(x for x in lines if x.startswith("  a "))
    assert joint_a.split()[4] == "none"  # joint, type, range (two words), effort
    gravity_a = [x for x in lines if x.startswith("  a ")][1]
    assert gravity_a.split()[3:6] == ["none", "none", "none"]  # limits, limit/need
    assert report.findings == ()


# -- a report a newcomer can read ----------------------------------------------------------


@pytest.fixture(scope="module")
def arm7_lines(arm7) -> list[str]:
    return format_report(audit(arm7, n_poses=300))


def test_every_table_is_followed_by_a_key_to_its_columns(arm7_lines):
    starts = ("  joint ", "  keyframe ", "  pair ", "  quantity ")
    for start in starts:
        header = next(i for i, x in enumerate(arm7_lines) if x.startswith(start))
        after = next(x for x in arm7_lines[header + 1 :] if not x.startswith("  ") or "key:" in x)
        assert after.startswith("  key: "), (start, after)
    text = " ".join(x.strip() for x in arm7_lines)
    for abbreviation in (
        "b: damping [N m s/rad]",
        "M_ii: mass matrix diagonal [kg m^2]",
        "h_max: largest stable timestep",
        "bare: without armature",
        "limit/need: in the binding direction",
        "any: no bound",
    ):
        assert abbreviation in text


def test_values_at_rounding_level_print_as_0(arm7_lines):
    # arm7's j7 turns about the axis through its centre of mass: gravity asks 1e-16 N m of it.
    gravity = next(i for i, x in enumerate(arm7_lines) if "min need" in x)
    j7 = next(x for x in arm7_lines[gravity:] if x.startswith("  j7 "))
    assert j7.split()[1:3] == ["0", "0"]
    assert "e-1" not in " ".join(arm7_lines[gravity : gravity + 9])


def test_no_value_is_wrapped_and_units_stay_whole(arm7_lines):
    home = next(x for x in arm7_lines if x.startswith("  home "))
    assert home.split()[1:7] == ["1.85", "1.825", "1.068", "0.4078", "0.35", "0.2332"]
    assert not any(x.rstrip().endswith("[N m") or x.rstrip().endswith("[kg") for x in arm7_lines)


def test_a_long_path_is_never_broken():
    from redundancy.reports.tables import wrap

    path = "/opt/" + "/".join(["site-packages"] * 9) + "/robots/talos_left_arm.urdf"
    lines = wrap(f"audit of {path}")
    assert lines == ["audit of", f"  {path}"]
    units = wrap("  key: b: damping [N m s/rad]; M_ii [kg m^2]" * 4)
    assert len(units) > 1
    assert " ".join(units).count("[N m s/rad]") == 4  # no unit cut by a line's end


def test_report_site_is_a_deprecated_name_of_frame(arm7) -> None:
    report = audit(arm7, n_poses=5)
    assert report.frame == "ee" and report.to_dict()["frame"] == "ee"
    with pytest.warns(
        DeprecationWarning, match=r"^AuditReport.site is deprecated: use AuditReport.frame$"
    ):
        assert report.site == "ee"


#: Joint pos in a default class: a difference Pinocchio's MJCF parser makes (the strict load
#: bridges it); a lenient load keeps it, and the engines' geoms sit apart.
LENIENT_MJCF = """<mujoco model="len"><compiler angle="radian"/>
<default><default class="c"><joint pos="0 0 0.05" axis="0 1 0"/></default></default>
<worldbody>
<body name="l1" pos="0 0 0.1"><joint name="j1" axis="0 0 1" range="-2 2"/>
 <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.04" mass="2"/>
 <body name="l2" pos="0 0 0.3" childclass="c"><joint name="j2" range="-1.5 1.5"/>
  <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1.5"/>
  <body name="l3" pos="0.3 0 0"><joint name="j3" range="-2 2"/>
   <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.03" mass="1"/>
   <site name="tool" pos="0.25 0 0"/>
  </body></body></body>
</worldbody></mujoco>"""


def test_a_lenient_audit_whose_engines_place_the_geoms_apart_skips_the_sweep_with_a_note():
    from redundancy.reports.audit import audit

    arm = rd.load_string(LENIENT_MJCF, frame="tool", strict=False)
    with pytest.raises(rd.ModelError, match="place the collision geoms differently"):
        rd.collision.checker(arm)
    r = audit(arm, n_poses=20, mode="lenient")
    assert r.sections.contacts is None
    (note,) = [n for n in r.notes if n.rule == "collision-engines-differ"]
    assert note.message.startswith("skipped the self-collision sweep: Pinocchio and MuJoCo place")
    assert any(f.rule == "engines-models-differ" for f in r.findings)
    assert r.exit_code == 1

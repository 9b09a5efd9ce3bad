"""The audit of an arm with coupled joints: every section, every format, the followers judged.

Ground truth is the files' own numbers: the actuators' gears and control ranges seen through
the couplings written in the file (virtual work: a follower x = c q passes c times its torque
to q), the followers' ranges against the values their polynomials give.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import redundancy as rd
from redundancy.reports.audit import audit
from redundancy.reports.formats import FORMATS, render
from redundancy.reports.formats.results import collect

from .test_coupled import MIMIC_URDF, POLY_MJCF
from .test_loops import CRANK_ROCKER

GRIPPER = Path(__file__).resolve().parents[1] / "examples" / "gripper_2f85.xml"


def _arms() -> dict[str, rd.Arm]:
    return {
        "mjcf polynomial": rd.load_string(POLY_MJCF, frame="tool"),
        "urdf mimic": rd.load_string(MIMIC_URDF, frame="tool"),
        "four-bar": rd.load_string(CRANK_ROCKER.xml, frame="tip"),
        "2f85": rd.load(GRIPPER, frame="right_pad"),
    }


@pytest.fixture(scope="module")
def reports() -> dict[str, object]:
    return {name: audit(arm, n_poses=60) for name, arm in _arms().items()}


@pytest.mark.parametrize("name", ["mjcf polynomial", "urdf mimic", "four-bar", "2f85"])
def test_every_section_and_format_of_a_coupled_arms_audit(reports, name) -> None:
    r = reports[name]
    arm = _arms()[name]
    doc = r.to_dict()
    assert [j["name"] for j in doc["joints"]] == list(arm.joint_names)
    assert {f["name"] for f in doc["followers"]} == set(arm.followers)
    for f in doc["followers"]:
        assert f["by"] == arm.followers[f["name"]]
    assert "followers:" in "\n".join(r.lines())
    assert r.engines.crosscheck.ok
    assert not [d for d in r.engines.equivalence.differences]
    for fmt in FORMATS:
        assert render(fmt, collect([r]))
    json.loads(render("sarif", collect([r])))


def test_the_2f85s_tendon_actuator_is_a_note_not_an_unheld_finding(reports) -> None:
    r = reports["2f85"]
    assert not [f for f in r.findings if f.rule == "joint-unactuated-loaded"]
    (note,) = [n for n in r.notes if n.rule == "joint-tendon-actuated"]
    assert "'fingers_actuator'" in note.message


#: j2 drives j3 = 0.05 - 0.5 (j2 - 0) (joint equality); motors on both, the follower's
#: range narrower than its leader's image, and a keyframe that puts it outside.
ACTUATED = """<mujoco model="coupled motors"><compiler angle="radian"/>
<worldbody>
<body name="l1" pos="0 0 0.1"><joint name="j1" axis="0 0 1" range="-2 2"/>
 <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.04" mass="2"/>
 <body name="l2" pos="0 0 0.3"><joint name="j2" axis="0 1 0" range="-1.5 1.5"/>
  <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1.5"/>
  <body name="l3" pos="0.3 0 0"><joint name="j3" axis="0 1 0" range="-0.5 0.5"/>
   <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.03" mass="1"/>
   <site name="tool" pos="0.25 0 0"/>
  </body></body></body>
</worldbody>
<equality><joint name="tie" joint1="j3" joint2="j2" polycoef="0.05 -0.5 0 0 0"/></equality>
<actuator>
 <motor name="m1" joint="j1" gear="2" ctrlrange="-1 1"/>
 <motor name="m2" joint="j2" gear="3" ctrlrange="-2 1"/>
 <motor name="m3" joint="j3" gear="4" ctrlrange="0 1"/>
</actuator>
<keyframe><key name="inside" qpos="0.1 0.6 -0.25"/><key name="beyond" qpos="0.1 1.4 -0.65"/>
</keyframe>
</mujoco>"""


def test_effort_on_an_independent_joint_is_its_own_plus_the_followers_through_the_coupling():
    arm = rd.load_string(ACTUATED, frame="tool")
    assert arm.joint_names == ("j1", "j2")
    r = audit(arm, n_poses=20)
    rows = {x.name: x for x in r.sections.joints.rows}
    # j1: gear 2 x [-1, 1]. j2: its own gear 3 x [-2, 1] = [-6, 3], plus j3's 4 x [0, 1] = [0, 4]
    # passed through dj3/dj2 = -0.5: [-2, 0]; together [-8, 3].
    assert (rows["j1"].effort_lower, rows["j1"].effort_upper) == (-2.0, 2.0)
    assert (rows["j2"].effort_lower, rows["j2"].effort_upper) == (-8.0, 3.0)
    assert rows["j2"].actuated
    # The same range over the gravity sweep (no servo: it does not depend on the pose).
    g = r.sections.gravity
    assert g.limit_lower[1] == -8.0 and g.limit_upper[1] == 3.0


def test_a_keyframe_that_puts_a_follower_outside_its_range_is_a_finding():
    arm = rd.load_string(ACTUATED, frame="tool")
    r = audit(arm, n_poses=20)
    out = [f for f in r.findings if f.rule == "keyframe-out-of-range"]
    # "beyond": j2 = 1.4 gives j3 = 0.05 - 0.7 = -0.65, below j3's -0.5; "inside" gives -0.25.
    assert [f.element for f in out] == ["beyond"]
    assert "'j3'" in out[0].message and "-0.65" in out[0].message
    assert "follower" in out[0].message
    (f,) = r.sections.joints.followers
    assert (f.name, f.lower, f.upper) == ("j3", -0.5, 0.5)
    assert f.by == arm.followers["j3"]


def test_a_mimic_followers_zero_effort_limit_is_a_finding(tmp_path):
    text = MIMIC_URDF.replace(
        '<limit lower="-2" upper="1.2" effort="10" velocity="1"/>',
        '<limit lower="-2" upper="1.2" effort="0" velocity="1"/>',
    )
    assert text != MIMIC_URDF
    path = tmp_path / "mimic.urdf"
    path.write_text(text)
    r = audit(rd.load(path, frame="tool"), n_poses=20)
    hits = [f for f in r.findings if f.rule == "effort-limit-zero"]
    assert [f.element for f in hits] == ["j3"]
    assert hits[0].line is not None


def test_the_sweeps_draw_the_poses_random_poses_draws_on_a_coupled_arm():
    arm = _arms()["four-bar"]
    r = audit(arm, n_poses=30, seed=4)
    Q = rd.random_poses(arm, 30, seed=4)
    # Every pose of the sweep closes its loop: the gravity sweep's worst poses are among them.
    assert r.sections.gravity.n_poses == 30
    tau = np.array([arm.gravity(q) for q in Q])
    assert np.allclose(r.sections.gravity.high, np.maximum(0, tau.max(axis=0)), rtol=0, atol=1e-12)


def test_the_lab_refuses_a_coupled_arm_naming_its_followers():
    from redundancy.lab.sim import LabSim

    arm = rd.load_string(ACTUATED, frame="tool")
    with pytest.raises(rd.UnsupportedFeatureError) as e:
        LabSim(arm)
    assert str(e.value) == (
        "unsupported feature: coupled joints in the lab (followers 'j3'): the lab steps "
        "MuJoCo's model of the arm, whose couplings the library solves instead of simulating; "
        "the audit, the quantities, batch and IK serve the arm"
    )


def test_a_linear_couplings_path_is_checked_on_its_chain_and_a_loops_is_refused():
    wide = ACTUATED.replace(
        'name="j3" axis="0 1 0" range="-0.5 0.5"', 'name="j3" axis="0 1 0" range="-1 1"'
    )
    assert wide != ACTUATED
    arm = rd.load_string(wide, frame="tool")
    a, b = np.array([0.0, 0.0]), np.array([0.0, 1.5])
    result = rd.check_path(arm, [a, b])
    assert not result.free and result.contact is not None
    # Ground truth: the chain's pose at dense points of the segment, by the file's coupling.
    s = np.linspace(0.0, 1.0, 3001)
    d = np.array([rd.collision.distances(arm, a + t * (b - a)).values.min() for t in s])
    first = s[np.argmax(d < 0)]
    assert np.all(d[s < result.contact.clear_until] > 0)
    assert result.contact.clear_until <= result.contact.s <= first + 1e-3
    assert result.contact.q.shape == (2,)
    # The narrow file: the end waypoint puts the follower j3 at -0.7, outside [-0.5, 0.5].
    with pytest.raises(rd.OutOfRangeError, match="j3"):
        rd.check_path(rd.load_string(ACTUATED, frame="tool"), [a, b])
    loop = _arms()["four-bar"]
    with pytest.raises(rd.UnsupportedFeatureError, match="nonlinear couplings"):
        rd.check_path(loop, rd.random_poses(loop, 2, seed=1))


#: A planar three-link arm whose tool is welded to a mocap body (a simulation's handle, as in
#: gym-xarm, Fetch and Meta-World) and tied to the world by an inactive connect.
MOCAP_ARM = """<mujoco model="mocap arm"><compiler angle="radian"/>
<worldbody>
<body name="handle" mocap="true" pos="0.5 0 0.3"/>
<body name="l1" pos="0 0 0.1"><joint name="j1" axis="0 0 1" range="-2 2"/>
 <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.04" mass="2"/>
 <body name="l2" pos="0 0 0.3"><joint name="j2" axis="0 1 0" range="-1.5 1.5"/>
  <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1.5"/>
  <body name="l3" pos="0.3 0 0"><joint name="j3" axis="0 1 0" range="-2 2"/>
   <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.03" mass="1"/>
   <site name="tool" pos="0.25 0 0"/>
  </body></body></body>
</worldbody>
<equality><weld name="drag" body1="handle" body2="l3"/>
<connect name="pin" body1="l3" body2="world" anchor="0 0 0" active="false"/></equality>
</mujoco>"""


def test_a_weld_to_a_mocap_body_and_an_inactive_constraint_are_set_aside():
    arm = rd.load_string(MOCAP_ARM, frame="tool")
    assert arm.joint_names == ("j1", "j2", "j3") and not arm.followers
    reasons = {a.name: a.reason for a in arm.set_aside if a.what == "equality constraint"}
    assert "mocap body 'handle'" in reasons["drag"]
    assert reasons["pin"].startswith('inactive in the file (active="false")')
    # Ground truth: the same arm without the constraints, to the bit.
    start, end = MOCAP_ARM.index("<equality>"), MOCAP_ARM.index("</equality>") + len("</equality>")
    bare = rd.load_string(MOCAP_ARM[:start] + MOCAP_ARM[end:], frame="tool")
    for q in rd.random_poses(arm, 5, seed=1):
        assert np.array_equal(arm.jacobian(q), bare.jacobian(q))
        assert np.array_equal(arm.mass_matrix(q), bare.mass_matrix(q))
        assert np.array_equal(arm.gravity(q), bare.gravity(q))
    assert rd.crosscheck(arm, rd.random_poses(arm, 50, seed=2)).ok


def test_a_huge_damping_on_a_joint_says_how_to_hold_it():
    text = MOCAP_ARM.replace('name="j1" axis="0 0 1"', 'name="j1" axis="0 0 1" damping="1e11"')
    with pytest.raises(rd.ModelError) as e:
        rd.load_string(text, frame="tool")
    assert str(e.value) == (
        "implausible value in the compiled model: dof_damping of joint 'j1' is 100000000000.0; "
        "the library handles magnitudes up to 1e+10 (SI units): beyond, the engines' products "
        "overflow; a joint the arm should not move is held by starting the arm below it "
        "(base=BODY, --base BODY)"
    )


def test_a_keyframe_where_the_loop_cannot_close_is_a_finding_not_a_failure():
    from .test_loops import TRIPLE_ROCKER

    keys = '<keyframe><key name="far" qpos="3.0 0 0"/><key name="near" qpos="0.3 0 0"/></keyframe>'
    arm = rd.load_string(TRIPLE_ROCKER.xml.replace("</mujoco>", keys + "</mujoco>"), frame="tip")
    with pytest.raises(rd.PoseError, match="equality 'loop'"):
        arm.chain_pose(arm.keyframe("far"))  # at a crank of 3 rad the loop cannot close
    r = audit(arm, n_poses=20)
    (f,) = [f for f in r.findings if f.rule == "keyframe-loop-open"]
    assert f.element == "far" and "crank 3" in f.message
    assert [k.name for k in r.sections.keyframes] == ["near"]
    assert [k.keyframe for k in r.sections.contacts.keyframes] == ["near"]
    assert r.sections.joints.keyframe == "near"


def test_compare_of_coupled_files_compares_every_joint_and_the_couplings(tmp_path):
    same = rd.compare(GRIPPER, GRIPPER, frame_a="right_pad", frame_b="right_pad")
    assert same.verdict == "same robot" and same.n_poses > 0
    # The follower link 5 mm longer in B: its joint's anchor differs, a follower included.
    longer = POLY_MJCF.replace('<body name="l5" pos="0.1 0 0">', '<body name="l5" pos="0.105 0 0">')
    assert longer != POLY_MJCF
    a, b = tmp_path / "a.xml", tmp_path / "b.xml"
    a.write_text(POLY_MJCF)
    b.write_text(longer)
    diff = rd.compare(a, b, frame_a="tool", frame_b="tool")
    assert diff.verdict == "different"
    assert any("j5" in d.where for d in diff.differences), diff.differences
    # Another polynomial for j3: the coupling row names it.
    other = POLY_MJCF.replace('polycoef="0.05 0.8 0.3 0 0"', 'polycoef="0.05 0.8 0.31 0 0"')
    b.write_text(other)
    coupling = rd.compare(a, b, frame_a="tool", frame_b="tool")
    assert [d.where for d in coupling.differences if d.quantity == "coupling"] == ["joint 'j3'"]


def test_long_joint_names_stay_whole_in_the_joint_table(reports):
    lines = reports["2f85"].lines()
    start = lines.index("joints at the reference pose (qpos0):")
    block = lines[start : start + 7]
    for name in ("right_spring_link_joint", "right_follower_joint"):
        # Two tables, each naming the joint whole on its row.
        assert sum(line.split()[0] == name for line in block if line.strip()) == 2, block
    assert max(len(line) for line in lines) <= 100

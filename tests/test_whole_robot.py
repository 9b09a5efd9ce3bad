"""An arm inside a robot keeps the robot's rules: collision pairs, couplings, keyframes.

Ground truth is MuJoCo's model of the whole robot (``arm.robot_model``, the file compiled by
MuJoCo, every joint kept) with the held joints at the values the arm reports; never the
arm's reduced model checked against itself.
"""

from __future__ import annotations

import numpy as np
import pytest

import redundancy as rd
from redundancy.arm import random_poses
from redundancy.collision import check_path, checker, collision_statistics
from redundancy.models import EXAMPLE_ARMS

from .fullmodel import library_contacts, whole_robot_contacts

# -- one set of collision pairs: the whole robot's ---------------------------------------------

#: A humanoid's arm from a free-floating pelvis to the palm. The pelvis and torso capsules
#: overlap (parent and child in the robot: MuJoCo never tests them); the finger on the hand
#: slides and is held, and folding the wrist brings it onto the forearm (a pair the robot
#: tests, although the hand is the forearm's child).
PELVIS_TO_PALM = """
<mujoco model="pelvis to palm">
  <compiler angle="radian" autolimits="true"/>
  <default><geom type="capsule" size="0.03"/><joint range="-2 2"/></default>
  <worldbody>
    <body name="pelvis" pos="0 0 1">
      <freejoint name="root"/>
      <geom name="pelvis" fromto="0 0 0 0 0 0.2" size="0.08"/>
      <body name="torso" pos="0 0 0.2">
        <joint name="waist" axis="0 0 1"/>
        <geom name="torso" fromto="0 0 0 0 0 0.3" size="0.1"/>
        <body name="upper" pos="0 0.25 0.25">
          <joint name="shoulder" axis="0 1 0"/>
          <geom name="upper" fromto="0 0 0 0 0 -0.25"/>
          <body name="forearm" pos="0 0 -0.25">
            <joint name="elbow" axis="0 1 0"/>
            <geom name="forearm" fromto="0 0 0 0.25 0 0"/>
            <body name="hand" pos="0.25 0 0">
              <joint name="wrist" axis="0 1 0" range="-2.6 2.6"/>
              <geom name="hand" type="box" size="0.03 0.03 0.01" pos="0.03 0 0"/>
              <site name="palm" pos="0.06 0 0"/>
              <body name="finger" pos="0.06 0 0">
                <joint name="finger" type="slide" axis="1 0 0" range="0 0.05"/>
                <geom name="finger" fromto="0 0 0 0.08 0 0" size="0.01"/>
              </body>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _labels(pairs: object) -> set[str]:
    return {p.label for p in pairs}  # type: ignore[attr-defined]


def test_free_pelvis_and_its_torso_are_never_a_pair() -> None:
    """Held, the free pelvis is welded to the world in the arm's model, where MuJoCo's parent
    rule would no longer apply to it; the robot's rule does: no pelvis/torso pair anywhere."""
    arm = rd.load_string(PELVIS_TO_PALM, frame="palm")
    assert arm.joint_names == ("waist", "shoulder", "elbow", "wrist")
    assert "pelvis / torso" not in _labels(rd.collision_pairs(arm))
    assert "pelvis / torso" not in _labels(checker(arm).pairs)
    stats = collision_statistics(arm, n_poses=50, seed=0, keyframes=False)
    assert "pelvis / torso" not in {s.pair.label for s in stats.pairs if s.contacts}
    q = np.zeros(arm.nq)
    assert check_path(arm, [q, q + 0.1]).free


def test_held_finger_against_the_forearm_is_a_pair() -> None:
    """Held, the finger is welded into the hand, the forearm's child; in the robot it is its
    own body, and MuJoCo tests it against the forearm. Folding the wrist makes them touch."""
    arm = rd.load_string(PELVIS_TO_PALM, frame="palm")
    assert "finger" in arm.held
    assert "finger / forearm" in _labels(rd.collision_pairs(arm))
    assert rd.collision_pairs(arm) == checker(arm).pairs
    folded = np.array([0.0, 0.0, 0.0, 2.5])
    assert {c.pair.label for c in checker(arm).contacts(folded)} == {"finger / forearm"}
    assert library_contacts(arm, [folded]) == whole_robot_contacts(arm, [folded])
    assert not check_path(arm, [np.zeros(arm.nq), folded]).free


def _contact_lists_agree(arm: rd.Arm, n: int = 1000) -> None:
    Q = random_poses(arm, n, seed=0)
    whole, ours = whole_robot_contacts(arm, Q), library_contacts(arm, Q)
    differing = [k for k in range(n) if whole[k] != ours[k]]
    assert not differing, (differing[:5], whole[differing[0]], ours[differing[0]])


def test_contact_list_is_the_whole_robots_on_the_inline_humanoid() -> None:
    _contact_lists_agree(rd.load_string(PELVIS_TO_PALM, frame="palm"))


#: Published arms whose contact list is compared in the default suite: held hands (G1),
#: a held torso (Talos from its torso), a second arm (TIAGo dual), a quadruped (ANYmal) and
#: iCub, whose left arm's list differed from the robot's.
FEW = {
    ("g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf", "left_hand_palm_link", None),
    ("talos_data/robots/talos_full_v2.urdf", "gripper_left_base_link", "torso_2_link"),
    ("tiago_description/robots/tiago_dual.urdf", "hand_left_tool_link", None),
    ("anymal_b_simple_description/robots/anymal-kinova.urdf", "j2s6s200_end_effector", None),
    ("icub_description/robots/icub.urdf", "l_gripper", None),
}


def _arm_id(x: object) -> str:
    return str(x).split("/")[-1]


@pytest.mark.parametrize(("file", "tool", "base"), sorted(FEW, key=str), ids=_arm_id)
def test_contact_list_is_the_whole_robots(file: str, tool: str, base: str | None) -> None:
    """At 1000 random poses the checker's contacts are raw mj_collision of the whole robot."""
    _contact_lists_agree(rd.load(rd.example_robot_data(file), frame=tool, base=base))


@pytest.mark.slow
@pytest.mark.parametrize(
    ("file", "tool", "base"), [a for a in EXAMPLE_ARMS if a not in FEW], ids=_arm_id
)
def test_contact_list_of_every_published_arm_is_the_whole_robots(
    file: str, tool: str, base: str | None
) -> None:
    _contact_lists_agree(rd.load(rd.example_robot_data(file), frame=tool, base=base))


# -- held joints obey the file's couplings -------------------------------------------------------


def _link(name: str, com: str, mass: float) -> str:
    return (
        f'<link name="{name}"><inertial><origin xyz="{com}"/><mass value="{mass}"/>'
        '<inertia ixx="0.01" iyy="0.01" izz="0.002" ixy="0" ixz="0" iyz="0"/></inertial></link>'
    )


def _joint(name: str, parent: str, child: str, xyz: str, axis: str, extra: str = "") -> str:
    return (
        f'<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}"/><axis xyz="{axis}"/>'
        f'<limit lower="-2" upper="2" effort="50" velocity="1"/>{extra}</joint>'
    )


#: Two arm joints and a gripper of two held fingers; finger ``fb`` mimics ``fa`` with
#: multiplier -1 and offset 0.6, so with ``fa`` at rest (0) it stands at 0.6 rad.
MIMIC = f"""<robot name="mimic">
  <link name="base"/>
  {_link("l1", "0 0 0.15", 1.0)}{_link("l2", "0 0 0.1", 1.0)}
  {_link("finger_a", "0 0 0.08", 0.4)}{_link("finger_b", "0 0 0.08", 0.4)}
  {_joint("j1", "base", "l1", "0 0 0", "0 1 0")}
  {_joint("j2", "l1", "l2", "0 0 0.3", "0 1 0")}
  {_joint("fa", "l2", "finger_a", "0 0.03 0.2", "1 0 0")}
  {_joint("fb", "l2", "finger_b", "0 -0.03 0.2", "1 0 0", '<mimic joint="fa" multiplier="-1" offset="0.6"/>')}
</robot>"""


def _whole_robot_gravity(
    xml: str, q: np.ndarray, values: dict[str, float]
) -> dict[str, np.ndarray]:
    """Gravity on j1, j2 of the whole robot, compiled by MuJoCo and by Pinocchio from the text."""
    import mujoco
    import pinocchio as pin

    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    pm = pin.buildModelFromXML(xml)
    pd = pm.createData()
    qp = pin.neutral(pm)
    for name, value in {**values, "j1": q[0], "j2": q[1]}.items():
        d.qpos[m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)]] = value
        qp[pm.joints[pm.getJointId(name)].idx_q] = value
    mujoco.mj_forward(m, d)
    dofs = [m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n)] for n in ("j1", "j2")]
    idx = [pm.joints[pm.getJointId(n)].idx_v for n in ("j1", "j2")]
    return {
        "mujoco": d.qfrc_bias[dofs].copy(),
        "pinocchio": np.asarray(pin.computeGeneralizedGravity(pm, pd, qp))[idx],
    }


def test_a_held_mimic_finger_stands_where_its_leader_puts_it() -> None:
    arm = rd.load_string(MIMIC, frame="l2")
    assert arm.joint_names == ("j1", "j2")
    assert arm.held == {"fa": 0.0, "fb": 0.6}
    aside = {a.name: a.reason for a in arm.set_aside if a.what == "joint equality"}
    assert aside == {
        "fb = fa": "couples held joints only; their held values follow it (fb = 0.6 - 1 fa)"
    }
    for q in random_poses(arm, 5, seed=3):
        whole = _whole_robot_gravity(MIMIC, q, {"fa": 0.0, "fb": 0.6})
        assert np.allclose(whole["mujoco"], whole["pinocchio"], atol=1e-12, rtol=0)
        for engine in ("mujoco", "pinocchio"):
            assert np.allclose(arm.gravity(q, engine), whole["mujoco"], atol=1e-12, rtol=0)
    # A value for the leader moves the follower.
    moved = rd.load_string(MIMIC, frame="l2", rest={"fa": 0.2})
    assert moved.held["fb"] == pytest.approx(0.4, abs=1e-15)
    q = random_poses(moved, 1, seed=4)[0]
    whole = _whole_robot_gravity(MIMIC, q, {"fa": 0.2, "fb": 0.4})
    assert np.allclose(moved.gravity(q, "pinocchio"), whole["mujoco"], atol=1e-12, rtol=0)
    # Both given and consistent: accepted.
    assert rd.load_string(MIMIC, frame="l2", rest={"fa": 0.2, "fb": 0.4}).held == moved.held


def test_a_rest_that_contradicts_a_coupling_is_refused_naming_both_joints() -> None:
    with pytest.raises(rd.ParameterError) as err:
        rd.load_string(MIMIC, frame="l2", rest={"fb": 0.1})
    assert str(err.value) == (
        "rest['fb'] must be 0.6, the value its coupling to joint 'fa' gives (fb = 0.6 - 1 fa); "
        "set 'fa' and 'fb' follows, got 0.1"
    )
    with pytest.raises(rd.ParameterError, match=r"rest\['fb'\] must be 0.4, .* joint 'fa'"):
        rd.load_string(MIMIC, frame="l2", rest={"fa": 0.2, "fb": 0.2})


def test_panda_fingers_open_together() -> None:
    """example-robot-data's Panda: panda_finger_joint2 mimics panda_finger_joint1."""
    path = rd.example_robot_data("panda_description/urdf/panda.urdf")
    arm = rd.load(path, frame="panda_hand", rest={"panda_finger_joint1": 0.04})
    assert arm.held == {"panda_finger_joint1": 0.04, "panda_finger_joint2": 0.04}


def test_an_mjcf_joint_equality_polynomial_moves_its_held_follower() -> None:
    """MuJoCo's joint equality: fb - ref_b = c0 + c1 x + c2 x^2, x = fa - ref_a (refs apart
    from 0); the whole robot's constraint residual is 0 at the held values."""
    import mujoco

    xml = """
    <mujoco>
      <compiler angle="radian"/>
      <worldbody>
        <body name="l1"><joint name="j1" axis="0 1 0"/>
          <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.03"/>
          <site name="tool" pos="0 0 0.3"/>
          <body name="fa" pos="0 0.03 0.3"><joint name="fa" axis="1 0 0" ref="0.3"/>
            <geom type="box" size="0.01 0.01 0.04" pos="0 0 0.04"/></body>
          <body name="fb" pos="0 -0.03 0.3"><joint name="fb" axis="1 0 0" ref="-0.1"/>
            <geom type="box" size="0.01 0.01 0.04" pos="0 0 0.04"/></body>
        </body>
      </worldbody>
      <equality><joint joint1="fb" joint2="fa" polycoef="0.1 0.5 0.2 0 0"/></equality>
    </mujoco>"""
    for rest, fa in ((None, 0.3), ({"fa": 0.5}, 0.5)):
        arm = rd.load_string(xml, frame="tool", rest=rest)
        x = fa - 0.3
        assert arm.held["fa"] == fa
        assert arm.held["fb"] == pytest.approx(-0.1 + 0.1 + 0.5 * x + 0.2 * x**2, abs=1e-15)
        m = mujoco.MjModel.from_xml_string(xml)
        d = mujoco.MjData(m)
        d.qpos[:] = [0.2, arm.held["fa"], arm.held["fb"]]
        mujoco.mj_forward(m, d)
        assert abs(d.efc_pos[0]) < 1e-15  # the equality's residual
    with pytest.raises(rd.ParameterError, match=r"\(fb \+ 0.1\) = 0.1 \+ 0.5 \(fa - 0.3\) "):
        rd.load_string(xml, frame="tool", rest={"fb": 0.2})


# -- keyframes are the whole robot's -------------------------------------------------------------

#: A torso pitch joint held (base="torso"); keyframe "lean" leans it 1.2 rad with the arm
#: hanging in the torso's frame: the shoulder then needs (2 * 0.15 + 1.5 * 0.45) * 9.81 *
#: sin(1.2) = 8.9 N m against a 5 N m motor.
LEAN = """
<mujoco model="leaning torso">
  <compiler angle="radian" autolimits="true"/>
  <worldbody>
    <body name="hips" pos="0 0 0.8">
      <geom type="box" size="0.1 0.1 0.05"/>
      <body name="torso">
        <joint name="torso_pitch" axis="0 1 0" range="-1.5 1.5"/>
        <geom type="capsule" fromto="0 0 0.1 0 0 0.4" size="0.08" mass="10"/>
        <body name="upper" pos="0 0.15 0.4">
          <joint name="shoulder" axis="0 1 0" range="-3 3"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.04" mass="2"/>
          <body name="lower" pos="0 0 -0.3">
            <joint name="elbow" axis="0 1 0" range="-2.5 2.5"/>
            <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.035" mass="1.5"/>
            <site name="hand" pos="0 0 -0.3"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor name="torso" joint="torso_pitch" gear="100" ctrlrange="-1 1"/>
    <motor name="shoulder" joint="shoulder" gear="5" ctrlrange="-1 1"/>
    <motor name="elbow" joint="elbow" gear="5" ctrlrange="-1 1"/>
  </actuator>
  <keyframe>
    <key name="upright" qpos="0 0.3 0.2"/>
    <key name="lean" qpos="1.2 0 0"/>
  </keyframe>
</mujoco>
"""


def _whole_robot_gravity_at_key(xml: str, key: str, joints: tuple[str, ...]) -> np.ndarray:
    import mujoco

    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, key))
    mujoco.mj_forward(m, d)
    dofs = [m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n)] for n in joints]
    return d.qfrc_bias[dofs].copy()


def test_a_keyframe_that_moves_a_held_joint_is_judged_at_its_own_pose() -> None:
    from redundancy.collision import keyframe_clearance
    from redundancy.lab.sim import LabSim
    from redundancy.reports.audit import audit

    arm = rd.load_string(LEAN, frame="hand", base="torso")
    assert arm.joint_names == ("shoulder", "elbow") and arm.held == {"torso_pitch": 0.0}
    assert arm.keyframe_names == ("upright", "lean")
    assert arm.keyframe_moves("lean") == {"torso_pitch": 1.2}
    assert arm.keyframe_moves("upright") == {}
    # Never the keyframe's arm joints on another pose of the robot under its name.
    assert list(arm.keyframes) == ["upright"]
    with pytest.raises(rd.PoseError) as err:
        arm.keyframe("lean")
    assert str(err.value) == (
        "keyframe 'lean' moves held joints (torso_pitch = 1.2 (held at 0)): it is not a pose "
        "of this arm; arm.at_keyframe('lean') is the arm at it (or load with rest='lean')"
    )
    leaning = arm.at_keyframe("lean")
    assert leaning.held == {"torso_pitch": 1.2} and leaning.rest == "keyframe 'lean'"
    assert arm.at_keyframe("lean") is leaning and arm.at_keyframe("upright") is arm
    whole = _whole_robot_gravity_at_key(LEAN, "lean", arm.joint_names)
    assert abs(whole[0]) == pytest.approx((2 * 0.15 + 1.5 * 0.45) * 9.81 * np.sin(1.2), rel=1e-9)
    q = leaning.keyframe("lean")
    for engine in ("mujoco", "pinocchio"):
        assert np.allclose(leaning.gravity(q, engine), whole, atol=1e-12, rtol=0)
    # The audit judges it there: 8.9 N m at the shoulder against 5 N m.
    report = audit(arm, n_poses=20)
    row = next(k for k in report.sections.keyframes if k.name == "lean")
    assert row.moves_held == {"torso_pitch": 1.2}
    assert np.allclose(row.hold, whole, atol=1e-12, rtol=0)
    assert any(
        f.message.startswith("keyframe 'lean' cannot be held: joint 'shoulder' needs")
        for f in report.findings
    )
    assert (
        "  keyframe 'lean' is judged where it puts held joints: torso_pitch 1.2 (held at 0)"
    ) in report.lines()
    # The arm's model keeps the robot's parent rule as excludes, its own filter off: the file
    # did not turn it off, and the report does not say it did.
    assert not [line for line in report.lines() if "filterparent" in line]
    clearance = {k.keyframe: k for k in keyframe_clearance(arm)}
    assert clearance["lean"].moves_held == {"torso_pitch": 1.2}
    # The lab starts from the keyframe with the torso leaning.
    assert LabSim(arm, keyframe="lean").arm.held == {"torso_pitch": 1.2}


# -- what is frozen --------------------------------------------------------------------------------


def test_a_ball_joint_between_two_arm_hinges_is_listed_as_frozen() -> None:
    xml = """
    <mujoco><compiler angle="radian"/><worldbody>
      <body name="l1"><joint name="j1" axis="0 0 1"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.03"/>
        <body name="l2" pos="0 0 0.3"><joint name="wobble" type="ball"/>
          <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.03"/>
          <body name="l3" pos="0 0 0.3"><joint name="j3" axis="0 1 0"/>
            <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.03"/>
            <site name="tool" pos="0 0 0.3"/>
          </body>
        </body>
      </body>
    </worldbody></mujoco>"""
    arm = rd.load_string(xml, frame="tool")
    assert arm.joint_names == ("j1", "j3")
    assert arm.held == {"wobble": (1.0, 0.0, 0.0, 0.0)}
    assert arm.frozen == {
        "wobble": "a ball joint: held at its rest value (the arm's joints are the chain's "
        "hinges and slides); rest= sets it"
    }
    bent = rd.load_string(xml, frame="tool", rest={"wobble": (0.9, 0.1, 0.2, 0.0)})
    assert bent.frozen == arm.frozen and bent.held["wobble"] != arm.held["wobble"]
    from redundancy.reports.audit import audit

    lines = audit(arm, n_poses=10).lines()
    k = lines.index("frozen (the file lets them move, the arm does not): 1")
    assert lines[k + 1].startswith("  joint 'wobble': a ball joint: held at its rest value")


#: A URDF whose ``pan`` joint moves a link without mass: the loader makes it fixed.
MASSLESS_PAN = f"""<robot name="pan">
  <link name="base"/>{_link("l1", "0 0 0.15", 1.0)}<link name="pan_link"/>
  {_joint("j1", "base", "l1", "0 0 0", "0 1 0")}
  {_joint("pan", "base", "pan_link", "0.2 0 0", "0 0 1")}
</robot>"""


def test_a_joint_made_fixed_at_load_is_listed_and_rest_for_it_says_why() -> None:
    arm = rd.load_string(MASSLESS_PAN, frame="l1")
    assert arm.joint_names == ("j1",) and arm.held == {}
    assert arm.frozen == {"pan": "moves link 'pan_link', which has no mass: held as fixed at 0"}
    with pytest.raises(rd.ParameterError) as err:
        rd.load_string(MASSLESS_PAN, frame="l1", rest={"pan": 1.0})
    assert str(err.value) == (
        "rest['pan'] must be a held joint's value; joint 'pan' was made fixed at load (moves "
        "link 'pan_link', which has no mass: held as fixed at 0), so it has no value to set, "
        "got 1.0"
    )


def test_explicit_pairs_the_arm_cannot_change_are_dropped() -> None:
    """A file's <pair> between two held bodies never changes with the arm: not a pair of
    the arm; one between an arm body and a held body is kept, as the file wrote it."""
    xml = PELVIS_TO_PALM.replace(
        "</worldbody>",
        '</worldbody><contact><pair geom1="pelvis" geom2="torso"/>'
        '<pair geom1="finger" geom2="hand"/><pair geom1="pelvis" geom2="forearm"/></contact>',
    )
    arm = rd.load_string(xml, frame="palm", base="pelvis")
    pairs = {p.label: p for p in rd.collision_pairs(arm)}
    assert "finger / hand" not in pairs  # the finger is welded to the hand: never moves
    assert pairs["forearm / pelvis"].explicit
    assert "pelvis / torso" in pairs and pairs["pelvis / torso"].explicit  # the waist moves it
    _contact_lists_agree(arm, 200)

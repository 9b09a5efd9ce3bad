"""An arm inside a robot: published robots as published, the arm is the chain to the tool.

Real files: every arm of example-robot-data (PyPI) that the issue names, loaded as published.
MJCF robots written in MuJoCo Menagerie's patterns (a humanoid with a free base and hands, a
bimanual cell with two root bodies and included actuators, a mobile base on slide joints, a
gripper coupled by tendon and equality, a tool that is a body).
"""

from __future__ import annotations

import importlib.metadata
import pickle
import xml.etree.ElementTree as ET
from functools import cache
from pathlib import Path

import mujoco
import numpy as np
import pytest

import redundancy as rd
from redundancy.arm import random_poses
from redundancy.model.robot import difference_to_whole_robot
from redundancy.models import EXAMPLE_ARMS

from .fullmodel import largest_difference_to_full_model


@cache
def erd_robots() -> Path:
    """example-robot-data's ``robots`` directory (installed from PyPI with the test extra)."""
    files = importlib.metadata.files("example-robot-data") or []
    for f in files:
        parts = Path(str(f)).parts
        if "robots" in parts and str(f).endswith(".urdf"):
            located = Path(str(f.locate()))
            return located.parents[len(parts) - parts.index("robots") - 2]
    raise RuntimeError("example-robot-data is not installed (pip install -e '.[test]')")


#: (file under robots/, tool frame, base) for each published arm.
ERD_ARMS = list(EXAMPLE_ARMS)


def urdf_chain(path: Path, tool: str, base: str | None) -> list[str]:
    """The moving joints from the root (or ``base``) to ``tool``, read from the URDF itself."""
    root = ET.parse(path).getroot()
    child_of = {
        j.find("child").get("link"): (j.get("name"), j.get("type"), j.find("parent").get("link"))  # type: ignore[union-attr]
        for j in root.findall("joint")
    }
    out, link = [], tool
    while link in child_of and link != base:
        name, kind, link = child_of[link]
        if kind != "fixed":
            out.append(name)
    return out[::-1]


@pytest.mark.parametrize(("file", "tool", "base"), ERD_ARMS, ids=lambda x: str(x).split("/")[-1])
def test_published_arm_is_the_chain_to_its_tool(file: str, tool: str, base: str | None) -> None:
    path = erd_robots() / file
    arm = rd.load(path, frame=tool, base=base)
    assert list(arm.joint_names) == urdf_chain(path, tool, base)
    every = {j.get("name") for j in ET.parse(path).getroot().findall("joint")}
    moving = {
        j.get("name") for j in ET.parse(path).getroot().findall("joint") if j.get("type") != "fixed"
    }
    # Every other moving joint is held (or, massless, welded at 0 and said so).
    welded = {a.name for a in arm.set_aside if a.what == "joint"}
    assert set(arm.held) | welded == moving - set(arm.joint_names)
    assert set(arm.held) <= every
    # Drake reads every published arm of the survey itself: three engines, every pair ok.
    assert list(arm.engines) == ["mujoco", "pinocchio", "drake"], arm.absent_engines
    Q = random_poses(arm, 4, seed=3)
    assert rd.crosscheck(arm, Q).ok
    for q in Q[:2]:
        assert largest_difference_to_full_model(arm, q) < 1e-9


def test_g1_hand_is_ten_joints_with_a_four_dimensional_self_motion() -> None:
    """The issue's example: 43 joints in the file, 10 on the chain, null space of 4."""
    path = erd_robots() / "g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf"
    arm = rd.load(path, frame="left_hand_palm_link")
    assert arm.nq == 10 and len(arm.held) == 33
    q = random_poses(arm, 1, seed=0)[0]
    assert arm.nullspace_basis(q).shape == (10, 4)
    waist = rd.load(path, frame="left_hand_palm_link", base="torso_link")
    assert waist.nq == 7 and {"waist_yaw_joint", "waist_roll_joint"} <= set(waist.held)


def test_held_joints_rest_where_asked() -> None:
    """rest= a dict moves a held finger; the arm's mass matrix sees its mass there."""
    path = erd_robots() / "panda_description/urdf/panda.urdf"
    closed = rd.load(path, frame="panda_hand")
    opened = rd.load(path, frame="panda_hand", rest={"panda_finger_joint1": 0.04})
    assert closed.held["panda_finger_joint1"] == 0.0 and opened.held["panda_finger_joint1"] == 0.04
    q = closed.keyframes.get("home", random_poses(closed, 1, seed=1)[0])
    assert not np.allclose(closed.mass_matrix(q), opened.mass_matrix(q))
    assert largest_difference_to_full_model(opened, q) < 1e-9
    with pytest.raises(rd.UnknownNameError, match="unknown held joint 'panda_joint1'"):
        rd.load(path, frame="panda_hand", rest={"panda_joint1": 0.1})
    with pytest.raises(rd.UnknownNameError, match="unknown base body on the chain"):
        rd.load(path, frame="panda_hand", base="nowhere")


def test_held_arm_pickles_with_its_rest() -> None:
    path = erd_robots() / "panda_description/urdf/panda.urdf"
    arm = rd.load(path, frame="panda_hand", rest={"panda_finger_joint1": 0.03})
    again = pickle.loads(pickle.dumps(arm))
    assert again.held == arm.held and again.joint_names == arm.joint_names


# -- MJCF robots in Menagerie's patterns -------------------------------------------------------

HUMANOID = """
<mujoco model="humanoid with hands">
  <compiler angle="radian" autolimits="true"/>
  <default>
    <default class="robot">
      <joint damping="0.5" armature="0.01" range="-2 2"/>
      <geom type="capsule" size="0.03" contype="1" conaffinity="1"/>
    </default>
  </default>
  <worldbody>
    <body name="pelvis" pos="0.1 -0.2 0.9" quat="0.9659 0 0 0.2588" childclass="robot">
      <freejoint name="floating_base"/>
      <geom fromto="0 0 0 0 0 0.2" size="0.08"/>
      <body name="torso" pos="0 0 0.2">
        <joint name="waist_yaw" axis="0 0 1"/>
        <geom fromto="0 0 0 0 0 0.3" size="0.1"/>
        <body name="head" pos="0 0 0.4">
          <joint name="neck" axis="0 1 0"/>
          <geom type="sphere" size="0.09"/>
        </body>
        <body name="l_upper" pos="0 0.2 0.25">
          <joint name="l_shoulder_pitch" axis="0 1 0"/>
          <geom fromto="0 0 0 0 0 -0.25"/>
          <body name="l_lower" pos="0 0 -0.25">
            <joint name="l_elbow" axis="0 1 0"/>
            <geom fromto="0 0 0 0 0 -0.25"/>
            <body name="l_hand" pos="0 0 -0.27">
              <joint name="l_wrist" axis="0 0 1"/>
              <geom type="box" size="0.03 0.04 0.02"/>
              <site name="l_palm" pos="0 0 -0.03"/>
              <body name="l_finger" pos="0 0.03 -0.03">
                <joint name="l_finger_joint" axis="1 0 0" range="0 1"/>
                <geom fromto="0 0 0 0 0 -0.05" size="0.01"/>
              </body>
            </body>
          </body>
        </body>
        <body name="r_upper" pos="0 -0.2 0.25">
          <joint name="r_shoulder_pitch" axis="0 1 0"/>
          <geom fromto="0 0 0 0 0 -0.25"/>
          <body name="r_lower" pos="0 0 -0.25">
            <joint name="r_elbow" axis="0 1 0"/>
            <geom fromto="0 0 0 0 0 -0.25"/>
          </body>
        </body>
      </body>
      <body name="l_thigh" pos="0 0.1 0">
        <joint name="l_hip" axis="0 1 0"/>
        <geom fromto="0 0 0 0 0 -0.4" size="0.05"/>
        <body name="l_shin" pos="0 0 -0.4">
          <joint name="l_knee" axis="0 1 0" range="0 2"/>
          <geom fromto="0 0 0 0 0 -0.4" size="0.04"/>
        </body>
      </body>
    </body>
  </worldbody>
  <keyframe>
    <key name="crouch" qpos="0 0 0.8 1 0 0 0  0.3 0.1  0.2 0.5 0.1 0.5  0.2 0.4  -0.5 1"/>
  </keyframe>
</mujoco>
"""


def _humanoid(**kw: object) -> rd.Arm:
    return rd.load_string(HUMANOID, frame="l_palm", **kw)  # type: ignore[arg-type]


def test_humanoid_arm_with_free_base_legs_and_hand() -> None:
    arm = _humanoid()
    assert arm.joint_names == ("waist_yaw", "l_shoulder_pitch", "l_elbow", "l_wrist")
    assert set(arm.held) == {
        "floating_base",
        "neck",
        "l_finger_joint",
        "r_shoulder_pitch",
        "r_elbow",
        "l_hip",
        "l_knee",
    }
    # The free base rests at its pose in the file (MuJoCo's qpos0), w x y z.
    assert np.allclose(arm.held["floating_base"], (0.1, -0.2, 0.9, 0.9659, 0, 0, 0.2588), atol=1e-4)
    for q in random_poses(arm, 3, seed=2):
        assert largest_difference_to_full_model(arm, q) < 1e-9
    assert rd.crosscheck(arm, random_poses(arm, 5, seed=5)).ok


@pytest.mark.parametrize(
    "base_pose",
    [
        (0.0, 0.0, 0.8, 1.0, 0.0, 0.0, 0.0),
        (0.3, -0.1, 1.1, 0.7071068, 0.0, 0.7071068, 0.0),  # on its side: both conventions matter
        (-0.2, 0.4, 0.5, 0.5, 0.5, -0.5, 0.5),
    ],
)
def test_posed_rotated_free_base_in_both_quaternion_conventions(base_pose: tuple) -> None:
    """A free base held away from its file pose: MuJoCo's w x y z, Pinocchio's x y z w."""
    arm = _humanoid(rest={"floating_base": base_pose})
    for q in random_poses(arm, 3, seed=4):
        pos_mj, rot_mj = arm.site_pose(q, "mujoco")
        pos_pin, rot_pin = arm.site_pose(q, "pinocchio")
        assert np.allclose(pos_mj, pos_pin, atol=1e-12) and np.allclose(rot_mj, rot_pin, atol=1e-12)
        assert largest_difference_to_full_model(arm, q) < 1e-9
    # The gravity torque follows the base's orientation (lying on its side changes it).
    upright = _humanoid()
    q = random_poses(arm, 1, seed=9)[0]
    if base_pose[3] != 1.0:
        assert not np.allclose(arm.gravity(q), upright.gravity(q))


def test_keyframe_rest_and_base() -> None:
    arm = _humanoid(rest="crouch", base="torso")
    assert arm.joint_names == ("l_shoulder_pitch", "l_elbow", "l_wrist")
    assert arm.held["waist_yaw"] == 0.3 and arm.rest == "keyframe 'crouch'"
    for q in random_poses(arm, 2, seed=1):
        assert largest_difference_to_full_model(arm, q) < 1e-9
    # The keyframe keeps its name and the arm joints' values.
    assert np.allclose(arm.keyframe("crouch"), (0.2, 0.5, 0.1))


BIMANUAL_MAIN = """
<mujoco model="bimanual cell">
  <include file="actuators.xml"/>
  <worldbody>
    <body name="table" pos="0 0 -0.05"><geom type="box" size="0.6 0.4 0.05"/></body>
    {left}
    {right}
  </worldbody>
</mujoco>
"""
SIDE = """
    <body name="{s}_base" pos="{x} 0 0">
      <geom type="cylinder" size="0.05 0.05" contype="0" conaffinity="0"/>
      <body name="{s}_link1" pos="0 0 0.1">
        <joint name="{s}_joint1" axis="0 0 1" range="-3 3" armature="0.1"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.04"/>
        <body name="{s}_link2" pos="0 0 0.3">
          <joint name="{s}_joint2" axis="0 1 0" range="-2 2" armature="0.1"/>
          <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
          <body name="{s}_gripper" pos="0.3 0 0">
            <geom type="box" size="0.02 0.04 0.02"/>
            <body name="{s}_finger_a" pos="0 0.02 0">
              <joint name="{s}_finger_a" type="slide" axis="0 1 0" range="0 0.04"/>
              <geom type="box" size="0.01 0.005 0.03"/>
            </body>
            <body name="{s}_finger_b" pos="0 -0.02 0">
              <joint name="{s}_finger_b" type="slide" axis="0 -1 0" range="0 0.04"/>
              <geom type="box" size="0.01 0.005 0.03"/>
            </body>
          </body>
        </body>
      </body>
    </body>
"""
ACTUATORS = """
<mujoco>
  <tendon>
    <fixed name="left_split"><joint joint="left_finger_a" coef="0.5"/><joint joint="left_finger_b" coef="0.5"/></fixed>
    <fixed name="right_split"><joint joint="right_finger_a" coef="0.5"/><joint joint="right_finger_b" coef="0.5"/></fixed>
  </tendon>
  <equality>
    <joint joint1="left_finger_a" joint2="left_finger_b"/>
    <joint joint1="right_finger_a" joint2="right_finger_b"/>
  </equality>
  <actuator>
    <motor name="left_1" joint="left_joint1" gear="50" ctrlrange="-1 1"/>
    <motor name="left_2" joint="left_joint2" gear="50" ctrlrange="-1 1"/>
    <motor name="right_1" joint="right_joint1" gear="50" ctrlrange="-1 1"/>
    <position name="left_grip" tendon="left_split" kp="100" ctrlrange="0 0.04"/>
    <position name="right_grip" tendon="right_split" kp="100" ctrlrange="0 0.04"/>
  </actuator>
</mujoco>
"""


@pytest.fixture(scope="module")
def bimanual(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("bimanual")
    (d / "actuators.xml").write_text(ACTUATORS)
    main = BIMANUAL_MAIN.format(
        left=SIDE.format(s="left", x="-0.3"), right=SIDE.format(s="right", x="0.3")
    )
    (d / "cell.xml").write_text(main)
    return d / "cell.xml"


@pytest.mark.parametrize(("side", "tool"), [("left", "left_gripper"), ("right", "right_gripper")])
def test_bimanual_cell_with_two_roots_and_an_include(bimanual: Path, side: str, tool: str) -> None:
    """The tool on either tree (Pinocchio reads the first root only: it is given the arm's)."""
    arm = rd.load(bimanual, frame=tool)  # a body, not a site
    assert arm.joint_names == (f"{side}_joint1", f"{side}_joint2")
    asides = {(a.what, a.name) for a in arm.set_aside}
    assert ("include", "actuators.xml") in asides
    assert ("tendon", f"{side}_split") in asides
    other = "right" if side == "left" else "left"
    assert ("root body", f"{other}_base") in asides and ("root body", "table") in asides
    # The arm's motors are read through the include: effort limit = ctrlrange x gear.
    assert arm.effort_limit[0] == 50
    assert np.allclose(arm.armature(), [0.1, 0.1])
    # buildReducedModel drops armature (pinocchio#2746): carried over, not bridged afresh.
    assert np.allclose(arm.armature("pinocchio"), [0.1, 0.1])
    assert not [b for b in arm.bridges if b.quantity == "armature" and b.engine == "pinocchio"]
    for q in random_poses(arm, 3, seed=6):
        assert largest_difference_to_full_model(arm, q) < 1e-9
    assert rd.crosscheck(arm, random_poses(arm, 4, seed=7)).ok


def test_coupling_that_reaches_the_arm_makes_its_leader_a_coordinate() -> None:
    xml = (
        BIMANUAL_MAIN.replace('<include file="actuators.xml"/>', "")
        .format(left=SIDE.format(s="left", x="-0.3"), right="")
        .replace(
            "</worldbody>",
            '</worldbody><equality><joint joint1="left_joint2" joint2="left_finger_a"/></equality>',
        )
    )
    # Once refused: the chain's joint follows a finger off the chain, whose joint is then
    # the arm's coordinate (the leader the chain depends on).
    arm = rd.load_string(xml, frame="left_gripper")
    assert arm.joint_names == ("left_joint1", "left_finger_a")
    assert arm.followers == {"left_joint2": "joint equality left_joint2 = 1 left_finger_a"}
    assert difference_to_whole_robot(arm, rd.random_poses(arm, 1, seed=0)[0]) <= 1e-12
    # The same coupling is nothing for a tool before it: joint2 is then held, and set aside.
    short = rd.load_string(xml, frame="left_link1")
    assert short.joint_names == ("left_joint1",)
    asides = {(a.what, a.name) for a in short.set_aside}
    assert ("joint equality", "left_joint2 = left_finger_a") in asides


MOBILE = """
<mujoco model="mobile manipulator">
  <worldbody>
    <body name="base_x" pos="0 0 0.1">
      <joint name="base_x" type="slide" axis="1 0 0"/>
      <inertial pos="0 0 0" mass="1" diaginertia="0.01 0.01 0.01"/>
      <body name="base_y">
      <joint name="base_y" type="slide" axis="0 1 0"/>
      <inertial pos="0 0 0" mass="1" diaginertia="0.01 0.01 0.01"/>
      <body name="base">
      <joint name="base_th" axis="0 0 1"/>
      <geom type="box" size="0.3 0.2 0.1"/>
      <body name="shoulder" pos="0.1 0 0.2">
        <joint name="arm1" axis="0 0 1" range="-3 3"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.2" size="0.04"/>
        <body name="forearm" pos="0 0 0.2">
          <joint name="arm2" axis="0 1 0" range="-2 2"/>
          <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
          <site name="tcp" pos="0.3 0 0"/>
        </body>
      </body>
      </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_mobile_base_on_slides_is_held_or_part_of_the_arm() -> None:
    """Slide and hinge joints of a base are on the chain (a mobile manipulator); base= cuts."""
    whole = rd.load_string(MOBILE, frame="tcp")
    assert whole.joint_names == ("base_x", "base_y", "base_th", "arm1", "arm2")
    assert not whole.held
    arm = rd.load_string(MOBILE, frame="tcp", base="base")
    assert arm.joint_names == ("arm1", "arm2")
    assert set(arm.held) == {"base_x", "base_y", "base_th"}
    for q in random_poses(arm, 3, seed=8):
        assert largest_difference_to_full_model(arm, q) < 1e-9


def test_held_bodies_collide_with_the_arm_and_never_with_each_other(bimanual: Path) -> None:
    arm = rd.load(bimanual, frame="left_gripper")
    pairs = rd.collision_pairs(arm)
    names = {frozenset((p.body1, p.body2)) for p in pairs}
    # the arm against the table and against the other arm (held at rest)
    assert frozenset(("left_link2", "table")) in names
    assert frozenset(("left_link2", "right_link2")) in names
    # two held bodies never move: not checked
    assert frozenset(("table", "right_link2")) not in names
    assert frozenset(("right_link1", "right_link2")) not in names
    m = arm.robot_model
    assert m.nbody == arm.mj_model.nbody
    assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "right_joint1") >= 0


def test_arm_link_on_a_held_torso_is_its_child_not_a_collision() -> None:
    """base= the torso: the torso is held (welded to the world in the arm's model), yet the
    upper arm is still its child under MuJoCo's parent filter, as in the whole robot."""
    arm = _humanoid(base="torso")
    names = {frozenset((p.body1, p.body2)) for p in rd.collision_pairs(arm)}
    assert frozenset(("torso", "l_upper")) not in names
    assert frozenset(("head", "l_lower")) in names  # a held body against the arm
    assert frozenset(("head", "r_upper")) not in names  # two held bodies never move


def test_sensors_and_actuators_of_held_joints_leave_with_them() -> None:
    xml = MOBILE.replace(
        "</worldbody>",
        '</worldbody><actuator><motor name="drive" joint="base_x" gear="10" ctrlrange="-1 1"/>'
        '<motor name="m1" joint="arm1" gear="20" ctrlrange="-1 1"/></actuator>'
        '<sensor><jointpos name="s_base" joint="base_x"/><jointpos name="s_arm" joint="arm1"/>'
        '<actuatorfrc name="s_drive" actuator="drive"/></sensor>',
    )
    arm = rd.load_string(xml, frame="tcp", base="base")
    assert arm.mj_model.nu == 1 and arm.mj_model.nsensor == 1
    assert arm.effort_limit[0] == 20
    assert ("actuator", "drive") in {(a.what, a.name) for a in arm.set_aside}


def _audit_exit(file: str, tool: str, base: str | None, tmp: Path) -> int:
    from redundancy.cli import main

    args = ["audit", str(erd_robots() / file), "--frame", tool, "--poses", "200"]
    args += ["--json", str(tmp / "report.json")] + (["--base", base] if base else [])
    code = main(args)
    assert (tmp / "report.json").is_file()
    return code


def test_audit_of_an_arm_inside_a_robot(tmp_path: Path) -> None:
    """A CI gate on a published robot: the audit runs to its verdict (0 sound, 1 findings)."""
    assert _audit_exit("panda_description/urdf/panda.urdf", "panda_hand", None, tmp_path) in (0, 1)


@pytest.mark.slow
@pytest.mark.parametrize(("file", "tool", "base"), ERD_ARMS, ids=lambda x: str(x).split("/")[-1])
def test_audit_of_every_published_arm(
    file: str, tool: str, base: str | None, tmp_path: Path
) -> None:
    assert _audit_exit(file, tool, base, tmp_path) in (0, 1)


# -- published values MuJoCo rejects ----------------------------------------------------------


def _two_branch_urdf(arm_inertia: str, held_inertia: str) -> str:
    """A base with an arm link (j1) and a held finger link (j2, not on the way to the tool)."""

    def link(name: str, inertia: str) -> str:
        return (
            f'<link name="{name}"><inertial><origin xyz="0 0 0.1"/><mass value="1"/>'
            f"<inertia {inertia} ixy='0' ixz='0' iyz='0'/></inertial></link>"
        )

    good = 'ixx="0.01" iyy="0.01" izz="0.002"'
    return f"""<robot name="r"><link name="base"/>
      {link("l1", arm_inertia)}{link("l2", good)}{link("finger", held_inertia)}
      <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
        <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="5" velocity="1"/></joint>
      <joint name="j3" type="revolute"><parent link="l1"/><child link="l2"/>
        <origin xyz="0 0 0.3"/><axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="5" velocity="1"/></joint>
      <joint name="j2" type="prismatic"><parent link="base"/><child link="finger"/>
        <origin xyz="0.2 0 0"/><axis xyz="1 0 0"/><limit lower="0" upper="0.04" effort="5" velocity="1"/></joint>
    </robot>"""


BAD = 'ixx="0.001" iyy="0.001" izz="0.01"'  # A + B < C: PR2's sensor_mount_link
POINT = 'ixx="0" iyy="0" izz="0"'  # a point mass: valid physics MuJoCo cannot take


def test_invalid_inertia_on_the_arm_is_mended_in_both_engines_and_a_finding() -> None:
    from redundancy.reports.audit import audit

    arm = rd.load_string(_two_branch_urdf(BAD, BAD), frame="l2")
    assert arm.joint_names == ("j1", "j3") and set(arm.held) == {"j2"}
    assert arm.defects == (
        "link 'l1': published inertia invalid, A + B < C (0.001 + 0.001 < 0.01) [kg m^2]; "
        "replaced by 0.004 about each axis (balanceinertia)",
    )
    held = [a for a in arm.set_aside if a.name == "finger"]
    assert held and held[0].reason.startswith("the arm does not move it: A + B < C")
    # One replacement in both engines: the engines agree and equal MuJoCo's whole robot.
    Q = random_poses(arm, 3, seed=0)
    assert rd.crosscheck(arm, Q).ok
    assert max(largest_difference_to_full_model(arm, q) for q in Q) < 1e-9
    report = audit(arm, n_poses=20)
    assert [f.message for f in report.findings if f.kind == "published inertia"] == list(
        arm.defects
    )
    assert report.robot is not None and report.robot.held == {"j2": 0.0}


def test_point_mass_is_no_defect() -> None:
    arm = rd.load_string(_two_branch_urdf(POINT, POINT), frame="l2")
    assert arm.defects == ()
    assert {a.name for a in arm.set_aside if a.what == "degenerate inertia"} == {"l1", "finger"}
    assert rd.crosscheck(arm, random_poses(arm, 3, seed=0)).ok

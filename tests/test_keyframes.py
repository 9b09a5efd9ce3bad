"""Keyframes compare poses, not numbers: a quaternion and its negation are one rotation.

Ground truth: MuJoCo's own kinematics of the whole robot (``mj_kinematics`` on the file), where
a keyframe whose held base quaternion is negated puts every body exactly where the arm holds it.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import redundancy as rd
from redundancy.arm_keyframes import held_value_distance
from redundancy.reports.pose_sections import keyframes

# A free base (held: the arm's joints are the chain's hinges), a ball-jointed head (held), one
# arm joint. Key "negated": base and head quaternions negated (the same rotations), the arm
# joint moved. Key "turned": the base truly turned (another pose of the held joints).
ROBOT = """<mujoco>
  <worldbody>
    <body name="base" pos="0 0 1" quat="0.9238795 0 0 0.3826834">
      <freejoint name="root"/>
      <geom type="box" size="0.1 0.1 0.1" mass="3"/>
      <body name="l1">
        <joint name="j1" axis="0 0 1"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="1"/>
        <site name="tip" pos="0.3 0 0"/>
      </body>
      <body name="head" pos="0 0 0.2" quat="0 1 0 0">
        <joint name="neck" type="ball"/>
        <geom type="sphere" size="0.05" mass="0.5"/>
      </body>
    </body>
  </worldbody>
  <keyframe>
    <key name="negated" qpos="0 0 1 -0.9238795 0 0 -0.3826834 0.5 -1 0 0 0"/>
    <key name="turned" qpos="0 0 1 0.3826834 0 0 0.9238795 0.5 0 1 0 0"/>
  </keyframe>
</mujoco>"""


def _body_poses(model: mujoco.MjModel, qpos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    return data.xpos.copy(), data.xmat.copy()


def test_a_negated_quaternion_in_a_keyframe_is_the_pose_the_arm_holds() -> None:
    model = mujoco.MjModel.from_xml_string(ROBOT)
    key = model.key_qpos[0]
    # MuJoCo: the keyframe puts every body where qpos0 with the arm joint at 0.5 does.
    held_pose = model.qpos0.copy()
    held_pose[7] = key[7]
    (xa, Ra), (xb, Rb) = _body_poses(model, key), _body_poses(model, held_pose)
    np.testing.assert_allclose(xa, xb, rtol=0, atol=1e-15)
    np.testing.assert_allclose(Ra, Rb, rtol=0, atol=1e-15)
    assert key[3] < 0 < model.qpos0[3]  # the numbers differ: the quaternions are negated

    arm = rd.load_string(ROBOT, frame="tip")
    assert arm.joint_names == ("j1",)
    assert set(arm.held) == {"root", "neck"}
    assert arm.keyframe_moves("negated") == {}
    np.testing.assert_array_equal(arm.keyframe("negated"), [0.5])
    assert "negated" in arm.keyframes
    assert arm.at_keyframe("negated") is arm
    # The audit's keyframe section computes it on this arm, moving no held joint.
    (row,) = keyframes(arm, ("negated",))
    assert row.moves_held == {}
    np.testing.assert_array_equal(row.q, [0.5])


def test_a_keyframe_that_turns_a_held_joint_still_moves_it() -> None:
    model = mujoco.MjModel.from_xml_string(ROBOT)
    held_pose = model.qpos0.copy()
    held_pose[7] = model.key_qpos[1][7]
    (_, Ra), (_, Rb) = _body_poses(model, model.key_qpos[1]), _body_poses(model, held_pose)
    assert np.max(np.abs(Ra - Rb)) > 0.5  # MuJoCo: another pose of the robot

    arm = rd.load_string(ROBOT, frame="tip")
    assert set(arm.keyframe_moves("turned")) == {"root", "neck"}
    with pytest.raises(rd.PoseError, match=r"^keyframe 'turned' moves held joints \(root = "):
        arm.keyframe("turned")
    assert "turned" not in arm.keyframes


@pytest.mark.parametrize(
    ("a", "b", "distance"),
    [
        ((1.0, 0.0, 0.0, 0.0), (-1.0, 0.0, 0.0, 0.0), 0.0),
        ((0.0, 0.6, 0.0, 0.8), (0.0, -0.6, 0.0, -0.8), 0.0),
        ((0.0, 0.0, 2.0, 0.0), (0.0, 0.0, -1.0, 0.0), 0.0),  # normalised, as MuJoCo reads it
        ((0.0, 0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0), 0.0),  # mju_normalize4: the identity
        ((1.0, 2.0, 3.0, 1.0, 0.0, 0.0, 0.0), (1.0, 2.5, 3.0, -1.0, 0.0, 0.0, 0.0), 0.5),
        ((1.0, 0.0, 0.0, 0.0), (0.0, 1.0, 0.0, 0.0), 1.0),
        (0.25, -0.25, 0.5),
        ((1.0, 0.0, 0.0, 0.0), 1.0, float("inf")),
    ],
)
def test_held_value_distance(a: object, b: object, distance: float) -> None:
    assert held_value_distance(a, b) == distance  # type: ignore[arg-type]

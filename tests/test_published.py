"""`redundancy audit` as a CI gate on published robots (example-robot-data's URDFs).

Exit 0 for a sound published arm (what URDF cannot express is a note), 1 for findings, 2 for
bad input; every line of the report at most 100 characters. The files are found through the
installed package's file list (``rd.example_robot_data``), never by a path into an
environment.
"""

from __future__ import annotations

import json
import warnings

import pytest

import redundancy as rd
from redundancy.cli import main


def published(relative: str) -> str:
    """The path of ``robots/<relative>`` in the installed example-robot-data."""
    return str(rd.example_robot_data(relative))


def fits(lines: list[str], path: str) -> bool:
    """Every line at most 100 characters, but the model's path: it is kept whole on a line of
    its own, however long (a reader copies it)."""
    assert f"  {path}" in lines or f"audit of {path}" in lines
    return max(len(line) for line in lines if line.strip() != path) <= 100


def audit_cli(capsys, *args: str) -> tuple[int, list[str], dict]:
    status = main(["audit", *args, "--poses", "300", "--json", "-"])
    captured = capsys.readouterr()
    return status, captured.err.splitlines(), json.loads(captured.out) if status < 2 else {}


@pytest.mark.parametrize(
    ("robot", "frame"),
    [
        ("ur_description/urdf/ur5_robot.urdf", "tool0"),
        ("xarm_description/urdf/xarm7.urdf", None),  # one chain end: link_eef
    ],
)
def test_a_sound_published_arm_exits_0(robot, frame, capsys):
    args = [published(robot)] + (["--frame", frame] if frame else [])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow or other runtime warning
        status, lines, data = audit_cli(capsys, *args)
    assert status == 0, "\n".join(lines)
    assert data["findings"] == [] and data["format"] == "URDF"
    assert data["frame"] == (frame or "link_eef")
    # What URDF cannot express is said once each, as a note.
    assert [n["message"].split(":")[0] for n in data["notes"]] == [
        "URDF cannot express armature (a geared joint's rotor inertia N^2 J_rotor)",
        "URDF cannot express actuators",
        "URDF cannot express the timestep or the integrator",
    ]
    assert fits(lines, args[0])
    text = "\n".join(lines)
    for absent in ("np.float64", "e+308", "keyframe 'qpos0'", "lesson", "no actuator"):
        assert absent not in text
    assert "keyframes: none in the file" in lines
    assert "joints at the reference pose (qpos0):" in lines


def test_the_effort_limits_of_a_urdf_are_what_the_gravity_budget_uses(capsys):
    status, lines, data = audit_cli(capsys, published("xarm_description/urdf/xarm7.urdf"))
    assert status == 0
    effort = [(r["effort_lower"], r["effort_upper"]) for r in data["joints"]]
    assert effort == [(-50, 50), (-50, 50), (-30, 30), (-30, 30), (-30, 30), (-20, 20), (-20, 20)]
    assert data["gravity"]["limit_upper"] == [50, 50, 30, 30, 30, 20, 20]
    row = next(line for line in lines if line.startswith("  joint2 "))
    assert "[-50, 50]" in row


def test_kd_on_a_urdf_is_a_note_the_file_sets_no_timestep(capsys):
    status, _, data = audit_cli(capsys, published("xarm_description/urdf/xarm7.urdf"), "--kd", "5")
    assert status == 0
    timestep = [n["message"] for n in data["notes"] if n["kind"] == "timestep"]
    assert len(timestep) == 1 and timestep[0].startswith(
        "MuJoCo's default timestep 2 ms is above the h_max 0.0932 ms of joint 'joint7'"
    )


def test_srdf_on_the_command_line(capsys):
    xarm = published("xarm_description/urdf/xarm7.urdf")
    srdf = published("xarm_description/srdf/xarm7.srdf")
    _, _, without = audit_cli(capsys, xarm)
    _, _, with_srdf = audit_cli(capsys, xarm, "--srdf", srdf)
    assert (without["collision"]["n_pairs"], with_srdf["collision"]["n_pairs"]) == (21, 11)


def test_several_chain_ends_are_bad_input_listing_them(capsys):
    ur5 = published("ur_description/urdf/ur5_robot.urdf")
    assert main(["audit", ur5]) == 2
    assert capsys.readouterr().err == (
        f"redundancy: error: {ur5!r} has 2 chain ends: 'ee_link', 'tool0'; name the tool frame "
        "(--frame NAME on the command line, frame=NAME in Python)\n"
    )


def test_kinova_arm_inside_the_robot_exits_0(capsys):
    # Three chain ends (the arm's end effector and two finger tips): the frame is named. Its
    # meshes are COLLADA (.dae), read through trimesh and pycollada.
    kinova = published("kinova_description/robots/kinova.urdf")
    status, lines, data = audit_cli(capsys, kinova, "--frame", "j2s6s200_end_effector")
    assert status == 0, "\n".join(lines)
    assert data["findings"] == [] and len(data["joints"]) == 6
    assert fits(lines, kinova)


def test_a_published_arm_whose_effort_limits_gravity_exceeds_exits_1(capsys):
    # Baxter's shoulder (s1) is limited to 50 N m in its URDF; gravity needs up to 56 N m.
    baxter = published("baxter_description/urdf/baxter.urdf")
    status, lines, data = audit_cli(capsys, baxter, "--frame", "left_gripper")
    assert status == 1
    (finding,) = data["findings"]
    i = [j["name"] for j in data["joints"]].index("left_s1")
    g = data["gravity"]
    assert g["limit_lower"][i] == -50 and g["low"][i] < -50 and g["over_low"][i] > 0
    assert finding["message"] == (
        "gravity at joint 'left_s1' needs more negative torque than its <limit effort> allows "
        f"in {g['over_low'][i]} of 300 poses; worst: needs {g['worst_low'][i][0]:.3g} N m "
        "where the limit is -50 N m"
    )
    assert fits(lines, baxter)


def test_what_the_arm_moves_is_never_listed_as_set_aside(capsys):
    # TALOS's force-torque sensor links sit between the wrist and the tool, with a point-mass
    # inertia MuJoCo rejects: mended on links the arm moves, not "set aside".
    talos = published("talos_data/robots/talos_left_arm.urdf")
    status, lines, data = audit_cli(capsys, talos, "--frame", "gripper_left_base_link")
    assert status in (0, 1)
    robot = data["robot"]
    assert [m.split("'")[1] for m in robot["mended"]] == [
        "wrist_left_ft_link",
        "wrist_left_ft_tool_link",
    ]
    assert robot["set_aside"] == []
    assert "set aside (does not reach the arm)" not in "\n".join(lines)
    assert "read or mended for the engines (the arm depends on these): 2" in lines
    assert fits(lines, talos)


# -- collision findings a user can act on ---------------------------------------------------------
TALOS_ARM = ("talos_data/robots/talos_left_arm.urdf", "gripper_left_base_link")
SOLO_LEG = ("solo_description/robots/solo12.urdf", "FL_FOOT")


@pytest.mark.parametrize(
    ("robot", "pair"),
    [
        (TALOS_ARM, ("arm_left_5_link", "arm_left_7_link")),
        (SOLO_LEG, ("FL_UPPER_LEG", "base_link")),
    ],
    ids=["talos-left-arm", "solo12-front-left-leg"],
)
def test_a_pair_touching_at_every_pose_gets_a_note_naming_its_exclusion(
    robot, pair, capsys, tmp_path
):
    urdf, frame = published(robot[0]), robot[1]
    status, lines, data = audit_cli(capsys, urdf, "--frame", frame)
    assert status in (0, 1)
    c = data["collision"]
    a, b = pair
    srdf_line = f'<disable_collisions link1="{a}" link2="{b}" reason="Always"/>'
    assert c["share_with_contact"] == 1.0
    assert c["touching_everywhere"] == [
        {
            "pair": f"{a} / {b}",
            "poses": 300,
            "bodies": [a, b],
            "srdf": srdf_line,
            "disabled_collisions": [a, b],
        }
    ]
    (note,) = [n["message"] for n in data["notes"] if n["kind"] == "collision"]
    assert note.startswith(f"{a} / {b} touch in 300 of 300 poses: a pair in contact at (nearly)")
    assert "overlap where a joint joins them" in note
    assert srdf_line in note and f"disabled_collisions=[('{a}', '{b}')]" in note
    text = " ".join(line.strip() for line in lines)
    without = c["share_with_contact_without_them"]
    assert 0 < without < 1
    assert (
        f"100.0% of poses have a contact; {100 * without:.1f}% without the 1 pair in contact "
        "at every pose (see the notes)"
    ) in text
    assert any(srdf_line in line for line in lines)  # whole on one line, to be copied
    # The exclusion the note gives, applied: the pair is gone and the rate is the one given.
    srdf = tmp_path / "fix.srdf"
    srdf.write_text(f"<robot>{srdf_line}</robot>")
    _, _, fixed = audit_cli(capsys, urdf, "--frame", frame, "--srdf", str(srdf))
    assert fixed["collision"]["n_pairs"] == c["n_pairs"] - 1
    assert fixed["collision"]["share_with_contact"] == without
    assert fixed["collision"]["touching_everywhere"] == []
    assert not [n for n in fixed["notes"] if n["kind"] == "collision"]


def test_a_whole_robots_srdf_applies_to_one_arm_of_it(capsys):
    # TALOS's SRDF describes the whole humanoid; 113 of its 459 pairs are the left arm's.
    urdf, frame = published(TALOS_ARM[0]), TALOS_ARM[1]
    srdf = published("talos_data/srdf/talos.srdf")
    arm = rd.load(urdf, frame=frame, disabled_collisions=srdf)
    (skipped,) = [a for a in arm.set_aside if a.what == "SRDF pairs"]
    assert skipped.name == "talos.srdf"
    assert skipped.reason.startswith(
        "346 of its 459 pairs name links this URDF does not have (arm_right_1_link, "
    )
    assert skipped.reason.endswith("and 30 more): skipped, the 113 others applied")
    status, _, data = audit_cli(capsys, urdf, "--frame", frame, "--srdf", srdf)
    assert status in (0, 1)
    assert data["collision"]["touching_everywhere"] == []
    assert data["collision"]["share_with_contact"] < 0.05  # 100 % without it
    assert any(s.startswith("SRDF pairs 'talos.srdf': 346 of") for s in data["robot"]["set_aside"])


def test_an_srdf_of_which_no_pair_applies_names_the_unknown_link(tmp_path):
    # A misspelt link that matches nothing: still an error, with the valid names.
    urdf, frame = published(TALOS_ARM[0]), TALOS_ARM[1]
    srdf = tmp_path / "typo.srdf"
    srdf.write_text(
        '<robot name="talos"><disable_collisions link1="arm_left_5_lnk" '
        'link2="arm_left_7_link" reason="Always"/></robot>'
    )
    with pytest.raises(rd.UnknownNameError) as err:
        rd.load(urdf, frame=frame, disabled_collisions=srdf)
    assert str(err.value).startswith("unknown link 'arm_left_5_lnk'; valid link names: [")
    assert "'arm_left_5_link'" in str(err.value)
    # Listed pairs are the model's own: every link must exist, whatever the others.
    with pytest.raises(rd.UnknownNameError, match="unknown link 'arm_left_5_lnk'"):
        rd.load(
            urdf,
            frame=frame,
            disabled_collisions=[
                ("arm_left_5_link", "arm_left_7_link"),
                ("arm_left_5_lnk", "arm_left_7_link"),
            ],
        )


def test_the_tool_link_is_never_listed_as_set_aside():
    # TIAGo's tool link carries a point-mass inertia MuJoCo rejects: mended, and the arm moves it.
    from redundancy.reports.audit import RobotPart

    tiago = rd.load(
        published("tiago_description/robots/tiago_no_hand.urdf"), frame="wrist_ft_tool_link"
    )
    part = RobotPart.of(tiago)
    assert not any("wrist_ft_tool_link" in s for s in part.set_aside)
    assert any(s.startswith("degenerate inertia 'wrist_ft_tool_link'") for s in part.mended)
    # What the arm does not move stays set aside: the base's antennas.
    assert any(s.startswith("invalid inertia 'base_antenna_left_link'") for s in part.set_aside)

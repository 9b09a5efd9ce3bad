"""``rd.compare`` and ``redundancy compare``: deliberate differences caught, named and located;
the same robot in different clothes reported equivalent."""

from __future__ import annotations

import json
import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import redundancy as rd
from redundancy.analysis.compare import compare, read_joint_map
from redundancy.cli import main
from redundancy.model.ends import chain_ends, single_chain_end
from redundancy.model.scales import FLOOR, arm_scales

from .test_urdf import (
    MODELS,
    element,
    random_rotation,
    rotate_link_frame,
    shuffle_declarations,
    split_link,
    urdf_root,
    write,
)

ARM7_URDF, ARM7_XML = MODELS / "arm7.urdf", MODELS / "arm7.xml"
PANDA_URDF, PANDA_XML = MODELS / "panda.urdf", MODELS / "panda.xml"
#: The floor of the scale compare divides positions by: FLOOR x arm7's length (URDF) [m].
ARM7_LENGTH = FLOOR * arm_scales(rd.load(ARM7_URDF, frame="ee")).length


def quantities(result: rd.Comparison) -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    for d in result.differences:
        out.setdefault(d.quantity, []).append(d.where)
    return out


# -- the bundled pairs -------------------------------------------------------------------
@pytest.mark.parametrize(("urdf", "mjcf"), [(ARM7_URDF, ARM7_XML), (PANDA_URDF, PANDA_XML)])
def test_bundled_urdf_is_the_same_robot_as_its_mjcf(urdf: Path, mjcf: Path) -> None:
    result = compare(urdf, mjcf)
    assert result.equivalent, result.lines()
    assert result.verdict == "same robot" and result.chains_part is None
    assert result.n_poses == 200 + len(rd.load(mjcf).keyframes)
    # Armature, velocity limits and keyframes are listed as what one format cannot express.
    listed = {n.quantity: n for n in result.not_expressible}
    assert set(listed) == {"armature", "velocity limit", "keyframes"}
    assert listed["armature"].a is None and len(listed["armature"].b) == 7
    assert listed["velocity limit"].b is None
    assert max(result.largest.values()) < 1e-12
    assert "mass matrix (without armature)" in result.largest  # URDF has no armature


def test_a_file_is_the_same_robot_as_itself() -> None:
    result = compare(PANDA_XML, PANDA_XML)
    assert result.equivalent and not result.not_expressible
    assert max(result.largest.values()) == 0.0
    assert "mass matrix" in result.largest  # armature compared, so M with armature


def test_different_robots() -> None:
    result = compare(PANDA_URDF, ARM7_XML)
    assert not result.equivalent
    assert quantities(result)["presence"][0] == "joint 'joint1'"
    assert result.chains_part == "joint 'joint1'"
    assert result.n_poses == 0  # no pose can be mapped
    document = json.loads(json.dumps(result.to_dict()))
    assert document["differences"][0] == {
        "quantity": "presence",
        "where": "joint 'joint1'",
        "a": "present",
        "b": "absent",
        "error": None,  # infinite: null, as in every JSON document
        "note": "",
    }


# -- deliberate differences ---------------------------------------------------------------
def test_flipped_axis_is_caught_named_and_located(tmp_path: Path) -> None:
    root = urdf_root("arm7")
    element(root, "joint", "j4").find("axis").set("xyz", "0 -1 0")  # type: ignore[union-attr]
    result = compare(write(root, tmp_path / "flipped.urdf"), ARM7_XML)
    assert result.verdict == "different"
    found = quantities(result)
    assert found["joint axis (world)"] == ["joint 'j4'"]
    assert result.chains_part == "joint 'j4'"
    axis = next(d for d in result.differences if d.quantity == "joint axis (world)")
    np.testing.assert_array_equal(axis.a, [0, -1, 0])
    np.testing.assert_array_equal(axis.b, [0, 1, 0])
    assert axis.error == 2.0
    assert {"jacobian", "tool position", "gravity torque"} <= set(found)


def test_moved_centre_of_mass_is_caught_named_and_located(tmp_path: Path) -> None:
    root = urdf_root("arm7")
    origin = element(root, "link", "link3").find("inertial/origin")
    origin.set("xyz", "0 0 0.0955")  # type: ignore[union-attr]  # was 0.0855
    result = compare(write(root, tmp_path / "com.urdf"), ARM7_XML)
    found = quantities(result)
    assert found["centre of mass (world)"] == ["body 'link3' (moved by 'j3')"]
    com = next(d for d in result.differences if d.quantity == "centre of mass (world)")
    # Relative to the quantity's scale: max |A's value|, never below the arm's length.
    assert com.error == pytest.approx(0.01 / max(np.max(np.abs(com.a)), ARM7_LENGTH), abs=1e-12)
    assert result.chains_part is None  # the kinematics are the same
    assert "inertia about the centre of mass (world)" not in found
    assert {"mass matrix (without armature)", "gravity torque"} <= set(found)
    assert "jacobian" not in found and "tool position" not in found


def test_missing_armature_is_caught_named_and_located(tmp_path: Path) -> None:
    text = ARM7_XML.read_text().replace(
        '<joint name="j5" axis="0 0 1"/>', '<joint name="j5" axis="0 0 1" armature="0"/>'
    )
    path = tmp_path / "arm7_no_armature.xml"
    path.write_text(text)
    result = compare(ARM7_XML, path)
    found = quantities(result)
    assert found["armature"] == ["joint 'j5'"]
    armature = next(d for d in result.differences if d.quantity == "armature")
    assert (armature.a, armature.b) == (0.05, 0.0)
    mass = next(d for d in result.differences if d.quantity == "mass matrix")
    assert mass.error > result.tol and mass.where == "joint 'j5'"
    assert (mass.a - mass.b) == pytest.approx(0.05)
    assert set(found) == {"armature", "mass matrix"}
    assert result.chains_part is None


def test_gravity_switched_off_is_a_different_gravity_vector(tmp_path: Path) -> None:
    # The gravity compared is the one MuJoCo simulates: zero under <flag gravity="disable"/>.
    text = ARM7_XML.read_text().replace(
        '<option timestep="0.002" integrator="Euler"/>',
        '<option timestep="0.002" integrator="Euler"><flag gravity="disable"/></option>',
    )
    path = tmp_path / "arm7_no_gravity.xml"
    path.write_text(text)
    result = compare(ARM7_XML, path)
    assert not result.equivalent
    vector = next(d for d in result.differences if d.quantity == "gravity vector")
    assert np.array_equal(vector.b, [0.0, 0.0, 0.0])
    assert vector.a[2] == pytest.approx(-9.81)


def test_offset_tool_frame_is_a_tool_mount_said_once(tmp_path: Path) -> None:
    root = urdf_root("arm7")
    element(root, "joint", "link7_ee").find("origin").set("xyz", "0 0 0.135")  # type: ignore[union-attr]
    result = compare(write(root, tmp_path / "tool.urdf"), ARM7_XML)
    # B's tool sits 5 mm short of A's along the flange axis: one offset, and the rest
    # (tool poses and Jacobians at the mount) compared relative to it agree.
    assert [o.kind for o in result.offsets] == ["tool mount"]
    mount = result.offsets[0]
    np.testing.assert_allclose(mount.translation, [0, 0, -0.005], atol=1e-12)
    assert mount.angle == 0.0
    assert result.differences == () and result.chains_part is None
    assert result.verdict == "same robot, placed differently" and not result.equivalent
    assert max(result.largest.values()) < 1e-12
    assert "OFFSET  tool mount: B is A moved by [0 0 -0.005] m in A's tool frame" in (
        result.lines()
    )


def _moved_base(path: Path, tmp_path: Path, body: str, pos: str, extra: str = "") -> Path:
    text = path.read_text()
    moved = text.replace(f'<body name="{body}"', f'<body name="{body}" pos="{pos}" {extra}', 1)
    assert moved != text
    out = tmp_path / f"moved_{path.name}"
    out.write_text(moved)
    return out


def test_a_base_moved_up_is_one_offset_and_the_rest_is_the_same(tmp_path: Path) -> None:
    moved = _moved_base(PANDA_XML, tmp_path, "link0", "0 0 0.12")
    result = compare(PANDA_XML, moved)
    assert [str(o) for o in result.offsets] == [
        "base placement: B is A moved by [0 0 0.12] m in the world frame"
    ]
    np.testing.assert_allclose(result.offsets[0].translation, [0, 0, 0.12], atol=1e-12)
    np.testing.assert_allclose(result.offsets[0].rotation, np.eye(3), atol=1e-12)
    # Relative to the offset: axes, centres of mass, tool poses, Jacobians, mass matrices
    # and gravity torques all agree.
    assert result.differences == (), result.lines()
    assert result.verdict == "same robot, placed differently"
    assert max(result.largest.values()) < 1e-12
    # URDF against MJCF, as with a published robot's two files: the same single offset.
    urdf_vs_mjcf = compare(PANDA_URDF, moved)
    assert [o.kind for o in urdf_vs_mjcf.offsets] == ["base placement"]
    assert urdf_vs_mjcf.differences == ()


def test_a_turned_base_leaves_the_gravity_difference(tmp_path: Path) -> None:
    # Turned 90 deg about x: the arm hangs sideways, so gravity loads it differently: that
    # difference is physical and remains, after the offset; the kinematics agree.
    moved = _moved_base(
        ARM7_XML, tmp_path, "link1", "0 0.3 0", 'quat="0.7071067811865476 0.7071067811865476 0 0"'
    )
    result = compare(ARM7_XML, moved)
    assert [o.kind for o in result.offsets] == ["base placement"]
    base = result.offsets[0]
    assert math.degrees(base.angle) == pytest.approx(90, abs=1e-9)
    np.testing.assert_allclose(base.axis, [1, 0, 0], atol=1e-12)
    assert {d.quantity for d in result.differences} == {"gravity torque"}
    assert result.chains_part is None


def test_a_real_kinematic_difference_is_no_offset(tmp_path: Path) -> None:
    root = urdf_root("arm7")
    element(root, "joint", "j4").find("axis").set("xyz", "0 -1 0")  # type: ignore[union-attr]
    result = compare(write(root, tmp_path / "flipped.urdf"), ARM7_XML)
    assert result.offsets == ()
    assert result.chains_part == "joint 'j4'"


def test_an_extra_joint_is_named_and_the_rest_still_compared(tmp_path: Path) -> None:
    """A gripper finger in one file only: held (it is off the chain to the tool), named, and
    the poses compared over the arm joints."""
    root = urdf_root("panda")
    finger = ET.fromstring(
        '<joint name="finger" type="prismatic"><parent link="link7"/><child link="finger"/>'
        '<origin xyz="0 0 0.12"/><axis xyz="0 1 0"/>'
        '<limit lower="0" upper="0.04" effort="20" velocity="0.2"/></joint>'
    )
    link = ET.fromstring(
        '<link name="finger"><inertial><origin xyz="0 0 0.02"/><mass value="0.1"/>'
        '<inertia ixx="1e-5" iyy="1e-5" izz="1e-5" ixy="0" ixz="0" iyz="0"/></inertial></link>'
    )
    root.extend([finger, link])
    result = compare(write(root, tmp_path / "with_finger.urdf"), PANDA_XML, n_poses=20)
    found = quantities(result)
    assert found["presence"] == ["held joint 'finger'"]
    assert result.chains_part is None
    assert result.n_poses == 21
    assert "mass matrix (without armature)" in found  # the finger's mass on the arm joints
    assert "jacobian" not in found  # the flange frame does not move with the finger


def test_renamed_joints_need_a_map(tmp_path: Path) -> None:
    root = urdf_root("panda")
    for joint in root.findall("joint"):
        joint.set("name", joint.get("name", "").replace("joint", "panda_joint"))
    renamed = write(root, tmp_path / "renamed.urdf")
    assert not compare(renamed, PANDA_XML).equivalent
    mapping = tmp_path / "map.txt"
    mapping.write_text(
        "# renamed.urdf -> panda.xml\n" + "".join(f"panda_joint{i} joint{i}\n" for i in range(1, 8))
    )
    result = compare(renamed, PANDA_XML, joint_map=mapping)
    assert result.equivalent, result.lines()
    assert result.joint_map[0] == ("panda_joint1", "joint1")
    as_json = tmp_path / "map.json"
    as_json.write_text(json.dumps({f"panda_joint{i}": f"joint{i}" for i in range(1, 8)}))
    assert read_joint_map(as_json) == read_joint_map(mapping)


# -- same robot, different clothes ----------------------------------------------------------
def test_rotated_link_frames_are_equivalent(tmp_path: Path) -> None:
    root = urdf_root("panda")
    for k, link in enumerate(("link2", "link4", "link7")):
        rotate_link_frame(root, link, random_rotation(k))
    rotated = write(root, tmp_path / "rotated.urdf")
    for other in (PANDA_URDF, PANDA_XML):
        result = compare(rotated, other)
        assert result.equivalent, result.lines()
    # The frames really moved: the link's own axis and inertial are written differently.
    assert element(root, "joint", "joint4").find("axis").get("xyz") != "0 0 1"  # type: ignore[union-attr]


@given(link=st.sampled_from([f"link{i}" for i in range(1, 8)]), seed=st.integers(0, 2**16))
def test_any_rotated_link_frame_is_equivalent(link: str, seed: int) -> None:
    root = urdf_root("arm7")
    rotate_link_frame(root, link, random_rotation(seed))
    arm = rd.load_string(ET.tostring(root, encoding="unicode"), frame="ee")
    result = compare(arm, ARM7_URDF, n_poses=20)
    assert result.equivalent, result.lines()


def test_reordered_declarations_are_equivalent(tmp_path: Path) -> None:
    root = urdf_root("arm7")
    shuffle_declarations(root, seed=7)
    first = [c.get("name") for c in root if c.tag == "joint"][:3]
    assert first != ["j1", "j2", "j3"]
    result = compare(write(root, tmp_path / "shuffled.urdf"), ARM7_XML)
    assert result.equivalent, result.lines()


def test_fused_fixed_link_is_equivalent(tmp_path: Path) -> None:
    root = urdf_root("arm7")
    split_link(root, "link4")
    split_link(root, "link7")
    split = write(root, tmp_path / "split.urdf")
    # Three chain ends: without a frame, compare takes the one named "ee" (the command line
    # asks for --frame).
    assert chain_ends(split) == ("ee", "link4_extra", "link7_extra")
    assert single_chain_end(split) is None
    result = compare(split, ARM7_XML)
    assert result.equivalent, result.lines()


def _in_degrees(text: str) -> str:
    def convert(match: re.Match[str]) -> str:
        lo, hi = (float(np.degrees(float(x))) for x in match.group(1).split())
        return f'range="{lo!r} {hi!r}"'

    text = text.replace('angle="radian"', 'angle="degree"')
    return re.sub(r'(?<=\s)range="([^"]+)"', convert, text)


@pytest.mark.parametrize("name", ["arm7", "panda"])
def test_degrees_against_radians_are_equivalent(tmp_path: Path, name: str) -> None:
    path = tmp_path / f"{name}_degrees.xml"
    path.write_text(_in_degrees((MODELS / f"{name}.xml").read_text()))
    assert 'range="-166.' in path.read_text()
    result = compare(MODELS / f"{name}.xml", path)
    assert result.equivalent, result.lines()
    assert result.largest["joint range"] < 1e-14


# -- the command -------------------------------------------------------------------------------
def test_cli_same_robot(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["compare", str(PANDA_URDF), str(PANDA_XML), "--poses", "20"]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[-1] == "verdict: same robot"
    assert "NOT EXPRESSIBLE  armature of joints" in out


def test_cli_differences_and_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    root = urdf_root("arm7")
    element(root, "joint", "j4").find("axis").set("xyz", "0 -1 0")  # type: ignore[union-attr]
    flipped = write(root, tmp_path / "flipped.urdf")
    report = tmp_path / "report.json"
    assert main(["compare", str(flipped), str(ARM7_XML), "--json", str(report)]) == 1
    out = capsys.readouterr().out
    assert "the chains part at: joint 'j4'" in out
    data = json.loads(report.read_text())
    assert data["verdict"] == "different" and data["chains_part"] == "joint 'j4'"
    assert data["differences"][0]["quantity"] == "joint axis (world)"
    assert main(["compare", str(flipped), str(ARM7_XML), "--json", "-", "--poses", "5"]) == 1
    assert json.loads(capsys.readouterr().out)["equivalent"] is False


def test_cli_frames_and_joint_map(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    root = urdf_root("arm7")
    element(root, "link", "ee").set("name", "tool0")
    element(root, "joint", "link7_ee").find("child").set("link", "tool0")  # type: ignore[union-attr]
    element(root, "joint", "j7").set("name", "wrist3")
    path = write(root, tmp_path / "renamed.urdf")
    mapping = tmp_path / "map.json"
    mapping.write_text('{"wrist3": "j7"}')
    argv = ["compare", str(path), str(ARM7_XML), "--frame-a", "tool0", "--poses", "5"]
    assert main([*argv, "--joint-map", str(mapping)]) == 0
    assert "tool frame 'tool0'" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--poses", "-1"], "redundancy compare: error: argument --poses: must be >= 0, got -1"),
        (["--tol", "nan"], "redundancy: error: --tol must be a finite number > 0, got nan"),
        (["--frame-a", "tool9"], "redundancy: error: unknown link 'tool9'; valid link names: "),
        (["--joint-map", "/nonexistent/map"], "redundancy: error: cannot read the joint map"),
        (
            ["--json", "/nonexistent/dir/out.json"],
            "redundancy: error: directory '/nonexistent/dir' of '/nonexistent/dir/out.json' "
            "does not exist",
        ),
    ],
)
def test_cli_bad_input(extra: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["compare", str(ARM7_URDF), str(ARM7_XML), *extra]) == 2
    assert capsys.readouterr().err.startswith(message)


def test_cli_missing_file(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["compare", "/nonexistent.urdf", str(ARM7_XML)]) == 2
    assert (
        capsys.readouterr().err == "redundancy: error: model file not found: '/nonexistent.urdf'\n"
    )


def test_bad_arguments() -> None:
    with pytest.raises(rd.ModelError, match="tol must be a finite number > 0"):
        compare(ARM7_XML, ARM7_XML, tol=float("inf"))
    with pytest.raises(rd.ModelError, match="n_poses must be an integer >= 0"):
        compare(ARM7_XML, ARM7_XML, n_poses=-3)
    with pytest.raises(rd.UnknownNameError, match="unknown joint 'j9'"):
        compare(ARM7_XML, ARM7_XML, joint_map={"j9": "j1"})
    with pytest.raises(rd.ModelError, match="sends two joints of A to one joint of B"):
        compare(ARM7_XML, ARM7_XML, joint_map={"j1": "j2"})


# -- classes of input, not examples -------------------------------------------------------------
JOINTS7 = [f"j{i}" for i in range(1, 8)]


@given(joint=st.sampled_from(JOINTS7))
def test_any_flipped_axis_is_located_at_its_joint(joint: str) -> None:
    root = urdf_root("arm7")
    axis = element(root, "joint", joint).find("axis")
    axis.set("xyz", " ".join(str(-float(x)) for x in axis.get("xyz").split()))  # type: ignore[union-attr]
    result = compare(rd.load_string(ET.tostring(root, encoding="unicode")), ARM7_XML, n_poses=20)
    assert quantities(result)["joint axis (world)"] == [f"joint {joint!r}"]
    assert result.chains_part == f"joint {joint!r}"


@given(
    link=st.integers(1, 7),
    shift=st.tuples(*[st.floats(-0.05, 0.05)] * 3).filter(lambda v: max(map(abs, v)) > 1e-6),
)
def test_any_moved_centre_of_mass_is_located_at_its_link(
    link: int, shift: tuple[float, float, float]
) -> None:
    root = urdf_root("arm7")
    origin = element(root, "link", f"link{link}").find("inertial/origin")
    xyz = [float(x) + d for x, d in zip(origin.get("xyz").split(), shift, strict=True)]  # type: ignore[union-attr]
    origin.set("xyz", " ".join(repr(x) for x in xyz))  # type: ignore[union-attr]
    result = compare(rd.load_string(ET.tostring(root, encoding="unicode")), ARM7_XML, n_poses=20)
    com = [d for d in result.differences if d.quantity == "centre of mass (world)"]
    assert [d.where for d in com] == [f"body 'link{link}' (moved by 'j{link}')"]
    scale = max(np.max(np.abs(com[0].a)), ARM7_LENGTH)
    assert com[0].error == pytest.approx(max(map(abs, shift)) / scale, abs=1e-12)
    assert result.chains_part is None


@given(
    seed=st.integers(0, 2**16),
    links=st.sets(st.sampled_from([f"link{i}" for i in range(1, 8)]), max_size=3),
)
def test_panda_in_any_clothes_is_the_same_robot(seed: int, links: set[str]) -> None:
    """Rotated link frames, a split link and shuffled declarations at once."""
    root = urdf_root("panda")
    for k, link in enumerate(sorted(links)):
        rotate_link_frame(root, link, random_rotation(seed + k))
    split_link(root, f"link{seed % 7 + 1}")
    shuffle_declarations(root, seed)
    arm = rd.load_string(ET.tostring(root, encoding="unicode"), frame="ee")
    result = compare(arm, PANDA_XML, n_poses=20)
    assert result.equivalent, result.lines()


def test_cli_one_frame_for_both_and_the_default(capsys: pytest.CaptureFixture[str]) -> None:
    base = ["compare", str(PANDA_URDF), str(PANDA_XML), "--poses", "5"]
    assert main(base) == 0  # one chain end each: 'ee'
    assert main([*base, "--frame", "ee"]) == 0
    assert main([*base, "--frame", "nowhere", "--frame-a", "ee", "--frame-b", "ee"]) == 0
    out = capsys.readouterr().out
    assert out.count("A: ") == 3 and "tool frame 'ee'" in out
    assert main([*base, "--frame", "nowhere"]) == 2
    assert "unknown link 'nowhere'" in capsys.readouterr().err


def test_cli_base_offset_exits_1_and_says_it_once(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    moved = _moved_base(PANDA_XML, tmp_path, "link0", "0 0 0.12")
    assert main(["compare", str(PANDA_URDF), str(moved), "--poses", "5"]) == 1
    lines = capsys.readouterr().out.splitlines()
    assert [x for x in lines if x.startswith(("OFFSET", "DIFFERS"))] == [
        "OFFSET  base placement: B is A moved by [0 0 0.12] m in the world frame"
    ]
    assert lines[-1] == "verdict: same robot, placed differently"


# -- the dynamics the simulation adds: springs, gravity compensation, fluid, velocity limits
def two_links(joint: str = "", body: str = "", option: str = "") -> str:
    """Two links of 0.5 m on pitch hinges, ``joint`` and ``body`` attributes on each."""
    return f"""<mujoco><compiler angle="radian"/><option {option}/><worldbody>
  <body name="l1" {body}><joint name="j1" axis="0 1 0" range="-2 2" {joint}/>
    <geom type="capsule" fromto="0 0 0 0 0 0.5" size="0.05"/>
    <body name="l2" pos="0 0 0.5" {body}><joint name="j2" axis="0 1 0" range="-2 2" {joint}/>
      <geom type="capsule" fromto="0 0 0 0 0 0.5" size="0.05"/>
      <site name="tip" pos="0 0 0.5"/>
    </body>
  </body>
</worldbody><keyframe><key name="bent" qpos="0.8 -0.5"/></keyframe></mujoco>"""


def two_links_urdf(velocity: float) -> str:
    link = (
        '<inertial><origin xyz="0 0 0.25"/><mass value="1"/>'
        '<inertia ixx="0.02" iyy="0.02" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>'
    )
    limit = f'<limit lower="-2" upper="2" effort="10" velocity="{velocity}"/>'
    return f"""<robot name="two"><link name="base"/>
<link name="l1">{link}</link><link name="l2">{link}</link><link name="tip"/>
<joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
  <axis xyz="0 1 0"/>{limit}</joint>
<joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
  <origin xyz="0 0 0.5"/><axis xyz="0 1 0"/>{limit}</joint>
<joint name="tool" type="fixed"><parent link="l2"/><child link="tip"/><origin xyz="0 0 0.5"/></joint>
</robot>"""


@pytest.mark.parametrize(
    ("a", "b", "lines"),
    [
        (
            {},
            {"joint": 'stiffness="30" springref="0.5"'},
            [
                "joint stiffness of joint 'j1': A 0, B 30",
                "joint stiffness of joint 'j2': A 0, B 30",
                "spring and fluid force of joint 'j",
            ],
        ),
        (
            {"joint": 'stiffness="30" springref="0.5"'},
            {"joint": 'stiffness="30" springref="-0.5"'},
            ["spring reference of joint 'j1': A 0.5, B -0.5", "spring and fluid force of joint"],
        ),
        (
            {},
            {"body": 'gravcomp="1"'},
            [
                "gravity compensation of body 'l1' (moved by 'j1'): A 0, B 1",
                "gravity compensation of body 'l2' (moved by 'j2'): A 0, B 1",
                "gravity compensation torque of joint 'j1'",
            ],
        ),
        (
            {"body": 'gravcomp="1"'},
            {"body": 'gravcomp="1"', "joint": 'actuatorgravcomp="true"'},
            ["gravity compensation through the actuators of joint 'j1': A 0, B 1"],
        ),
        ({}, {"option": 'density="1000" viscosity="1"'}, ["spring and fluid force of joint"]),
    ],
    ids=["springs", "spring reference", "gravcomp", "actuatorgravcomp", "fluid"],
)
def test_the_simulated_dynamics_differ(
    a: dict[str, str],
    b: dict[str, str],
    lines: list[str],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    (tmp_path / "a.xml").write_text(two_links(**a))
    (tmp_path / "b.xml").write_text(two_links(**b))
    assert main(["compare", str(tmp_path / "a.xml"), str(tmp_path / "b.xml")]) == 1
    differs = [x for x in capsys.readouterr().out.splitlines() if x.startswith("DIFFERS  ")]
    for line in lines:
        assert any(d.startswith(f"DIFFERS  {line}") for d in differs), differs
    assert compare(tmp_path / "b.xml", tmp_path / "b.xml").equivalent


def test_the_spring_torque_at_a_keyframe_is_the_figure(tmp_path: Path) -> None:
    (tmp_path / "a.xml").write_text(two_links())
    (tmp_path / "b.xml").write_text(two_links(joint='stiffness="75" springref="0"'))
    result = compare(tmp_path / "a.xml", tmp_path / "b.xml", n_poses=0)  # the keyframe alone
    (force,) = [d for d in result.differences if d.quantity == "spring and fluid force"]
    assert (force.where, force.a, force.b) == ("joint 'j1'", 0.0, pytest.approx(-60.0))


def test_velocity_limits_between_two_urdfs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "slow.urdf").write_text(two_links_urdf(2.0))
    (tmp_path / "fast.urdf").write_text(two_links_urdf(20.0))
    assert main(["compare", str(tmp_path / "slow.urdf"), str(tmp_path / "fast.urdf")]) == 1
    out = capsys.readouterr().out
    assert "DIFFERS  velocity limit of joint 'j1': A 2, B 20 (|diff| 9)" in out
    assert "DIFFERS  velocity limit of joint 'j2': A 2, B 20 (|diff| 9)" in out
    assert compare(tmp_path / "slow.urdf", tmp_path / "slow.urdf").equivalent


def test_springs_and_gravcomp_are_what_urdf_cannot_express(tmp_path: Path) -> None:
    (tmp_path / "two.urdf").write_text(two_links_urdf(2.0))
    (tmp_path / "two.xml").write_text(
        two_links(joint='stiffness="30" springref="0.5"', body='gravcomp="0.5"')
    )
    result = compare(tmp_path / "two.urdf", tmp_path / "two.xml")
    listed = {n.quantity: n for n in result.not_expressible}
    assert listed["joint spring"].b == {
        "j1": "stiffness=30, springref=0.5",
        "j2": "stiffness=30, springref=0.5",
    }
    assert listed["gravity compensation"].b == {"l1": 0.5, "l2": 0.5}
    assert not {"joint stiffness", "gravity compensation"} & set(quantities(result))


# -- MuJoCo's damping polynomial (issue 35) ------------------------------------------------
def _motor(xml: str, damping: str) -> str:
    """``xml`` with a gear-2 motor on j1 whose ``damping`` is given."""
    motor = f'<actuator><motor joint="j1" gear="2" damping="{damping}"/></actuator>'
    return xml.replace("</worldbody>", "</worldbody>" + motor)


def _mujoco_damper(path: Path, v: float) -> float:
    """Raw MuJoCo: joint j1's damping force at speed ``v`` (the others still) [N m]."""
    import mujoco

    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    d.qvel[0] = v
    mujoco.mj_forward(m, d)
    return float(d.qfrc_damper[0])


@pytest.mark.parametrize(
    ("b", "poly", "joints"),
    [
        (two_links(joint='damping="0 2 3"'), [2.0, 3.0], ["j1", "j2"]),
        (_motor(two_links(), "0 0.5"), [2.0, 0.0], ["j1"]),  # gear^2 x 0.5
    ],
    ids=["joint", "actuator"],
)
def test_a_damping_polynomial_is_named(
    b: str, poly: list[float], joints: list[str], tmp_path: Path
) -> None:
    """Issue 35: a difference in MuJoCo's damping polynomial was a "spring and fluid force"
    difference while the damping row read 0. It is named, with MuJoCo's coefficients."""
    (tmp_path / "a.xml").write_text(two_links())
    (tmp_path / "b.xml").write_text(b)
    # Ground truth outside the library: MuJoCo's damping force is -(b1 v|v| + b2 v^3).
    for v in (0.5, -2.0):
        expected = -(poly[0] * v * abs(v) + poly[1] * v**3)
        assert _mujoco_damper(tmp_path / "b.xml", v) == pytest.approx(expected, rel=1e-12)
    result = compare(tmp_path / "a.xml", tmp_path / "b.xml")
    found = [(d.quantity, d.where, list(d.a), list(d.b)) for d in result.differences]
    assert found == [("damping polynomial", f"joint {j!r}", [0, 0], poly) for j in joints]
    assert result.differences[0].note == (
        "coefficients of v|v| and v^3 in MuJoCo's damping force, the actuators' included"
    )
    assert result.largest["damping"] == 0.0 and result.largest["spring and fluid force"] < 1e-12


def test_an_actuator_damping_difference_is_reported_once(tmp_path: Path) -> None:
    """An actuator's damping is in the damping row (gear^2 x it): it was in the spring and
    fluid force too."""
    (tmp_path / "a.xml").write_text(_motor(two_links(), "0.5"))
    (tmp_path / "b.xml").write_text(_motor(two_links(), "0.7"))
    assert _mujoco_damper(tmp_path / "b.xml", 0.5) == pytest.approx(-4 * 0.7 * 0.5)
    result = compare(tmp_path / "a.xml", tmp_path / "b.xml")
    assert [str(d) for d in result.differences] == [
        "damping of joint 'j1': A 2, B 2.8 (|diff| 0.4)"
    ]


def test_a_stiffness_polynomial_is_named(tmp_path: Path) -> None:
    (tmp_path / "a.xml").write_text(two_links())
    (tmp_path / "b.xml").write_text(two_links(joint='stiffness="0 0 5"'))
    result = compare(tmp_path / "a.xml", tmp_path / "b.xml")
    found = [d for d in result.differences if d.quantity == "stiffness polynomial"]
    assert [(d.where, list(d.b)) for d in found] == [("joint 'j1'", [0, 5]), ("joint 'j2'", [0, 5])]
    assert result.largest["joint stiffness"] == 0.0


def test_a_damping_polynomial_is_what_urdf_cannot_express(tmp_path: Path) -> None:
    (tmp_path / "two.urdf").write_text(two_links_urdf(2.0))
    (tmp_path / "two.xml").write_text(two_links(joint='damping="0 2 3" stiffness="0 1"'))
    result = compare(tmp_path / "two.urdf", tmp_path / "two.xml")
    listed = {n.quantity: n for n in result.not_expressible}
    assert listed["damping polynomial"].b == {"j1": "[2 3]", "j2": "[2 3]"}
    assert listed["joint spring"].b == {
        "j1": "stiffness=0, springref=0, stiffness polynomial=[1 0]",
        "j2": "stiffness=0, springref=0, stiffness polynomial=[1 0]",
    }
    assert "damping polynomial" not in quantities(result)


# -- couplings: URDF mimics and MJCF joint equalities ------------------------------------------

_LINK = '<inertial><mass value="{m}"/><inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial>'


def gripper_urdf(multiplier: float, offset: float) -> str:
    """A two-joint arm with a hand whose second finger mimics the first (held, off the chain)."""
    link = _LINK.format
    return f"""<robot name="g">
  <link name="base">{link(m=1)}</link><link name="l1">{link(m=1)}</link>
  <link name="l2">{link(m=1)}</link><link name="hand">{link(m=0.3)}</link>
  <link name="finger1">{link(m=0.05)}</link><link name="finger2">{link(m=0.05)}</link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="10" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0 0 0.3"/>
    <axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="10" velocity="1"/></joint>
  <joint name="h" type="fixed"><parent link="l2"/><child link="hand"/><origin xyz="0 0 0.3"/></joint>
  <joint name="f1" type="prismatic"><parent link="hand"/><child link="finger1"/>
    <axis xyz="1 0 0"/><limit lower="0" upper="0.04" effort="10" velocity="1"/></joint>
  <joint name="f2" type="prismatic"><parent link="hand"/><child link="finger2"/>
    <axis xyz="-1 0 0"/><limit lower="0" upper="0.04" effort="10" velocity="1"/>
    <mimic joint="f1" multiplier="{multiplier}" offset="{offset}"/></joint>
</robot>"""


def test_compare_sees_a_changed_mimic_multiplier_and_offset() -> None:
    """A finger's mimic written with another multiplier or offset is a coupling difference,
    named by the follower and both rules; the same mimic is none."""
    a = rd.load_string(gripper_urdf(1.0, 0.0), frame="hand")
    same = compare(a, rd.load_string(gripper_urdf(1.0, 0.0), frame="hand"))
    assert same.equivalent and same.largest["coupling"] == 0.0
    errors, truths = [], []
    for multiplier, offset, b_text in ((0.5, 0.0, "f2 = 0.5 f1"), (1.0, 0.01, "f2 = 0.01 + 1 f1")):
        other = rd.load_string(gripper_urdf(multiplier, offset), frame="hand")
        found = [d for d in compare(a, other).differences if d.quantity == "coupling"]
        assert [(d.where, d.a, d.b) for d in found] == [("joint 'f2'", "f2 = 1 f1", b_text)]
        errors.append(found[0].error)
        # Ground truth: the follower's largest difference over f1's range [0, 0.04] m.
        truths.append(max(abs((multiplier - 1.0) * x + offset) for x in (0.0, 0.04)))
    # Both errors are relative to one scale (A's): their ratio is the true ratio, 0.02/0.01.
    assert errors[0] / errors[1] == pytest.approx(truths[0] / truths[1], rel=1e-12)


def test_compare_sees_a_mimic_against_an_mjcf_polynomial() -> None:
    """A URDF mimic and an MJCF joint equality are one coupling when their polynomials agree
    (linear), a difference when the MJCF's has a quadratic term, and missing when it has none."""
    a = rd.load_string(gripper_urdf(0.5, 0.01), frame="hand")
    spec = rd.load_string(gripper_urdf(0.5, 0.01), frame="hand").robot_model
    assert spec.neq == 1  # the loader writes the mimic as MuJoCo's joint equality
    mjcf = mjcf_gripper("0.01 0.5 0 0 0")
    assert compare(a, rd.load_string(mjcf, frame="hand")).largest["coupling"] == 0.0
    quad = compare(a, rd.load_string(mjcf_gripper("0.01 0.5 3 0 0"), frame="hand"))
    assert [(d.where, d.b) for d in quad.differences if d.quantity == "coupling"] == [
        ("joint 'f2'", "f2 = 0.01 + 0.5 f1 + 3 f1^2")
    ]
    none = compare(a, rd.load_string(mjcf_gripper(None), frame="hand"))
    assert [(d.where, d.a, d.b, d.error) for d in none.differences if d.quantity == "coupling"] == [
        ("joint 'f2'", "f2 = 0.01 + 0.5 f1", None, math.inf)
    ]


def mjcf_gripper(polycoef: str | None) -> str:
    """`gripper_urdf` in MJCF, the finger coupled by a joint equality (None: uncoupled)."""
    inertia = 'diaginertia="1e-3 1e-3 1e-3"'
    eq = f'<equality><joint joint1="f2" joint2="f1" polycoef="{polycoef}"/></equality>'
    return f"""<mujoco><compiler angle="radian"/><worldbody>
<body name="l1"><joint name="j1" axis="0 0 1" range="-2 2"/><inertial pos="0 0 0" mass="1" {inertia}/>
<body name="l2" pos="0 0 0.3"><joint name="j2" axis="0 1 0" range="-2 2"/>
<inertial pos="0 0 0" mass="1" {inertia}/>
<body name="hand" pos="0 0 0.3"><inertial pos="0 0 0" mass="0.3" {inertia}/>
<body name="finger1"><joint name="f1" type="slide" axis="1 0 0" range="0 0.04"/>
<inertial pos="0 0 0" mass="0.05" {inertia}/></body>
<body name="finger2"><joint name="f2" type="slide" axis="-1 0 0" range="0 0.04"/>
<inertial pos="0 0 0" mass="0.05" {inertia}/></body>
</body></body></body></worldbody>{eq if polycoef else ""}</mujoco>"""

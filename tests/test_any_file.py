"""Files MuJoCo compiles as published are served, and read as MuJoCo reads them.

Each case is a class of published file (issue "any robot that MuJoCo compiles" and the fourth
hostile round), written out tiny in a temporary folder. The ground truth is raw MuJoCo on the
file as written (``MjSpec.from_file`` on the user's path, ``fusestatic`` off so a tool link
keeps its body): the tool position and J of the library's both engines must equal it.
"""

from __future__ import annotations

import os
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin
import pytest

import redundancy as rd

INERTIAL = (
    '<inertial><origin xyz="0 0 0.1"/><mass value="1"/>'
    '<inertia ixx="0.01" iyy="0.02" izz="0.03" ixy="0" ixz="0" iyz="0"/></inertial>'
)


def _link(name: str, body: str = INERTIAL) -> str:
    return f'<link name="{name}">{body}</link>'


def _joint(name: str, parent: str, child: str, xyz: str, axis: str, kind: str = "revolute") -> str:
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}"/><axis xyz="{axis}"/>'
        '<limit lower="-2" upper="2" effort="10" velocity="1"/></joint>'
    )


def two_link_urdf(root: str = "base", extra: str = "") -> str:
    """A two-joint URDF arm from ``root`` to ``tool`` (``extra``: more elements)."""
    return (
        '<robot name="r">'
        + _link("l1")
        + _joint("j1", root, "l1", "0 0 0.2", "0 0 1")
        + _link("l2")
        + _joint("j2", "l1", "l2", "0 0 0.3", "0 1 0")
        + '<link name="tool"/><joint name="jt" type="fixed"><parent link="l2"/>'
        '<child link="tool"/><origin xyz="0 0 0.25"/></joint>' + extra + "</robot>"
    )


def raw_mujoco(path: str | Path) -> mujoco.MjModel:
    """MuJoCo's model of the file as written (fixed links kept as bodies)."""
    spec = mujoco.MjSpec.from_file(str(path))
    spec.compiler.fusestatic = False
    return spec.compile()


def raw_tool(m: mujoco.MjModel, tool: str, values: dict[str, float], joints: list[str]):
    """Raw MuJoCo's tool body position and J (columns of ``joints``) at joint ``values``."""
    d = mujoco.MjData(m)
    for name, v in values.items():
        d.qpos[m.jnt_qposadr[m.joint(name).id]] = v
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    b = m.body(tool).id
    jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    mujoco.mj_jacBody(m, d, jp, jr, b)
    cols = [m.jnt_dofadr[m.joint(j).id] for j in joints]
    return d.xpos[b].copy(), np.vstack([jp, jr])[:, cols]


def assert_matches_raw(arm: rd.Arm, m: mujoco.MjModel, tool: str, q: np.ndarray) -> None:
    """Both engines' tool position and J equal raw MuJoCo's, at the arm's held values."""
    values = dict(zip(arm.joint_names, q, strict=True))
    pos, J = raw_tool(m, tool, values, list(arm.joint_names))
    for engine in arm.engines:
        np.testing.assert_allclose(arm.site_pose(q, engine)[0], pos, rtol=0, atol=1e-12)
        np.testing.assert_allclose(arm.jacobian(q, engine), J, rtol=0, atol=1e-12)


# ------------------------------------------------------------------------------------------
# The world root: an offset applied once
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("rpy", ["0 0 0", "0.3 0 0.5"])
def test_a_urdf_world_root_with_a_fixed_offset_places_the_tool_where_mujoco_does(
    tmp_path: Path, rpy: str
) -> None:
    """A bimanual stand's pattern: the root link is ``world``, a fixed joint places the base.

    Pinocchio's URDF parser applies the fixed joint itself; the root-pose bridge added it a
    second time (the tool 0.3 m off, J wrong once the offset turns).
    """
    stand = (
        '<link name="world"/>'
        + _link("stand")
        + '<joint name="fix" type="fixed"><parent link="world"/><child link="stand"/>'
        f'<origin xyz="0 0.3 0.1" rpy="{rpy}"/></joint>'
    )
    path = tmp_path / "stand.urdf"
    path.write_text(two_link_urdf("stand", stand))
    arm = rd.load(path, frame="tool")
    m = raw_mujoco(path)
    for q in rd.random_poses(arm, 5, seed=1):
        assert_matches_raw(arm, m, "tool", q)
    assert rd.crosscheck(arm, rd.random_poses(arm, 20, seed=2)).ok


# ------------------------------------------------------------------------------------------
# Meshes: the URDF's MuJoCo extension, glTF, and meshes found nowhere
# ------------------------------------------------------------------------------------------


def _collision(filename: str) -> str:
    return f'<collision><geometry><mesh filename="{filename}"/></geometry></collision>'


def _with_meshes(l1: str, l2: str, head: str = "") -> str:
    text = two_link_urdf(extra='<link name="base"/>')
    text = text.replace('<link name="l1">', '<link name="l1">' + _collision(l1))
    text = text.replace('<link name="l2">', '<link name="l2">' + _collision(l2))
    return text.replace('<robot name="r">', '<robot name="r">' + head)


def _box(path: Path, size: float) -> None:
    import trimesh

    path.parent.mkdir(parents=True, exist_ok=True)
    trimesh.creation.box((size, size, 2 * size)).export(path)


def _vertices(m: mujoco.MjModel) -> list[np.ndarray]:
    """Each compiled mesh's vertices in its mesh frame, sorted (order-free)."""
    out = []
    for k in range(m.nmesh):
        lo, n = m.mesh_vertadr[k], m.mesh_vertnum[k]
        out.append(np.sort(m.mesh_vert[lo : lo + n], axis=0))
    return out


@pytest.mark.parametrize(
    ("compiler", "a", "b"),
    [
        ('meshdir="meshes/" strippath="true"', "package://pkg/meshes/a.stl", "pkg/b.stl"),
        ('meshdir="meshes/"', "a.stl", "b.stl"),  # decoys of these names beside the URDF
    ],
)
def test_the_urdf_mujoco_extension_meshdir_is_where_meshes_are_read(
    tmp_path: Path, compiler: str, a: str, b: str
) -> None:
    """MuJoCo reads ``meshdir/<name>``; a package or a file of the same name elsewhere is not it."""
    for place, size in (("meshes", 0.05), ("pkg/meshes", 0.4), ("pkg", 0.3), (".", 0.2)):
        _box(tmp_path / place / "a.stl", size)
        _box(tmp_path / place / "b.stl", size)
    head = f"<mujoco><compiler {compiler}/></mujoco>"
    path = tmp_path / "r.urdf"
    path.write_text(_with_meshes(a, b, head))
    arm = rd.load(path, frame="tool")
    raw = _vertices(raw_mujoco(path))
    mine = _vertices(arm.robot_model)
    assert len(raw) == len(mine) == 2
    for x, y in zip(raw, mine, strict=True):
        np.testing.assert_allclose(x, y, rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.ptp(mine[1], axis=0), [0.05, 0.05, 0.1], atol=1e-9)


def test_a_gltf_mesh_is_read_with_trimesh(tmp_path: Path) -> None:
    _box(tmp_path / "m" / "a.glb", 0.05)
    _box(tmp_path / "m" / "b.stl", 0.05)
    path = tmp_path / "r.urdf"
    path.write_text(_with_meshes("m/a.glb", "m/b.stl"))
    arm = rd.load(path, frame="tool")
    assert [(a.what, a.name) for a in arm.set_aside] == [("glTF mesh", "a.glb")]
    verts = _vertices(arm.robot_model)
    np.testing.assert_allclose(np.ptp(verts[0], axis=0), [0.05, 0.05, 0.1], atol=1e-9)


def test_meshes_found_nowhere_leave_everything_but_collision(tmp_path: Path) -> None:
    """The arm is served; collision names the link, the file and the places looked in.

    Ground truth: raw MuJoCo on the same file with the missing mesh's geom removed.
    """
    from redundancy import collision

    _box(tmp_path / "m" / "a.stl", 0.05)
    missing = "package://not_installed_pkg/meshes/b.stl"
    path = tmp_path / "r.urdf"
    path.write_text(_with_meshes("m/a.stl", missing))
    arm = rd.load(path, frame="tool")
    assert [(m.link, m.file) for m in arm.missing_meshes] == [("l2", missing)]
    assert str(tmp_path / "not_installed_pkg" / "meshes" / "b.stl") in arm.missing_meshes[0].looked
    stripped = tmp_path / "stripped.urdf"
    stripped.write_text(path.read_text().replace(_collision(missing), ""))
    m = raw_mujoco(stripped)
    for q in rd.random_poses(arm, 3, seed=3):
        assert_matches_raw(arm, m, "tool", q)
    np.testing.assert_allclose(
        arm.mass_matrix(np.zeros(2)), arm.mass_matrix(np.zeros(2), engine="pinocchio"), atol=1e-15
    )
    with pytest.raises(rd.MissingMeshError) as err:
        collision.checker(arm)
    assert str(err.value).startswith(
        "collision needs the meshes the model names, and these are found nowhere: "
        f"link 'l2': '{missing}' (looked for: {tmp_path / 'not_installed_pkg/meshes/b.stl'}, "
    )
    copy = __import__("pickle").loads(__import__("pickle").dumps(arm))
    assert copy.missing_meshes == arm.missing_meshes


def test_the_audit_of_an_arm_with_meshes_found_nowhere_notes_the_sweep_it_skips(
    tmp_path: Path,
) -> None:
    """Everything but the self-collision sweep is audited; the note names link and file."""
    import json

    from redundancy.cli import main

    _box(tmp_path / "m" / "a.stl", 0.05)
    missing = "package://not_installed_pkg/meshes/b.stl"
    path = tmp_path / "r.urdf"
    path.write_text(_with_meshes("m/a.stl", missing))
    out = tmp_path / "report.json"
    code = main(["audit", str(path), "--frame", "tool", "--poses", "20", "--json", str(out)])
    report = json.loads(out.read_text())
    assert code in (0, 1)  # findings or none: the audit ran
    assert report["collision"] is None
    assert [n["message"] for n in report["notes"] if n["kind"] == "meshes"] == [
        f"skipped the self-collision sweep: the file names meshes found nowhere (link 'l2': "
        f"'{missing}'); install the package that ships them (or put it on ROS_PACKAGE_PATH)"
    ]


# ------------------------------------------------------------------------------------------
# MJCF files: which bytes are read (includes, attached models, meshes, encodings, links)
# ------------------------------------------------------------------------------------------

ARM_BODY = (
    '<mujoco><worldbody><body name="b1" pos="0 0 0.1"><joint name="j1" axis="0 0 1"/>'
    '<geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.03" mass="{m1}"/>'
    '<body name="b2" pos="0 0 0.3"><joint name="j2" axis="0 1 0"/>'
    '<geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="{m2}"/>'
    '<site name="tool" pos="0.3 0 0"/></body></body></worldbody></mujoco>'
)


def _arm_body(m1: float = 1.0, m2: float = 2.0) -> str:
    return ARM_BODY.format(m1=m1, m2=m2)


def raw_gravity(path: str | Path, q: np.ndarray) -> np.ndarray:
    """Raw MuJoCo's gravity torque (qfrc_bias at zero velocity) on the file as written."""
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_forward(m, d)
    return d.qfrc_bias.copy()


def _same_gravity(arm: rd.Arm, truth_file: str | Path) -> None:
    q = np.array([0.4, -0.7])
    truth = raw_gravity(truth_file, q)
    for engine in arm.engines:
        np.testing.assert_allclose(arm.gravity(q, engine=engine), truth, rtol=1e-12, atol=1e-12)


def test_a_mesh_named_through_dotdot_or_backslashes_compiles_as_mujoco_compiles_it(
    tmp_path: Path,
) -> None:
    """Fed under its written and its absolute name, MuJoCo refused the repeated file name."""
    import pickle

    _box(tmp_path / "assets" / "a.stl", 0.05)
    (tmp_path / "model").mkdir()
    for k, (name, compiler) in enumerate(
        [("../assets/a.stl", ""), ("a.stl", 'meshdir="../assets"'), ("..\\assets\\a.stl", "")]
    ):
        path = tmp_path / "model" / f"m{k}.xml"
        path.write_text(
            f'<mujoco><compiler {compiler}/><asset><mesh name="a" file="{name}"/></asset>'
            + _arm_body().replace('mass="1"', 'mass="1"/><geom type="mesh" mesh="a"')[8:]
        )
        arm = rd.load(path, frame="tool")
        _same_gravity(arm, path)
        assert _vertices(pickle.loads(pickle.dumps(arm)).robot_model)[0].shape == (8, 3)


def test_includes_are_read_beside_the_path_given_not_beside_a_links_target(
    tmp_path: Path,
) -> None:
    (tmp_path / "real").mkdir()
    (tmp_path / "real" / "model.xml").write_text('<mujoco><include file="body.xml"/></mujoco>')
    (tmp_path / "real" / "body.xml").write_text(_arm_body(1.0, 2.0))
    (tmp_path / "view").mkdir()
    (tmp_path / "view" / "body.xml").write_text(_arm_body(3.0, 5.0))
    link = tmp_path / "view" / "model.xml"
    link.symlink_to(tmp_path / "real" / "model.xml")
    arm = rd.load(link, frame="tool")
    _same_gravity(arm, link)  # MuJoCo reads view/body.xml
    assert not np.allclose(
        raw_gravity(link, np.zeros(2)), raw_gravity(tmp_path / "real" / "model.xml", np.zeros(2))
    )


def test_an_include_of_an_include_is_found_beside_its_includer(tmp_path: Path) -> None:
    (tmp_path / "parts").mkdir()
    (tmp_path / "model.xml").write_text('<mujoco><include file="parts/robot.xml"/></mujoco>')
    (tmp_path / "parts" / "robot.xml").write_text('<mujoco><include file="body.xml"/></mujoco>')
    (tmp_path / "parts" / "body.xml").write_text(_arm_body())
    arm = rd.load(tmp_path / "model.xml", frame="tool")
    _same_gravity(arm, tmp_path / "model.xml")


def test_a_model_in_another_encoding_reads_its_includes_from_its_own_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Handed the decoded text, MuJoCo looked for the include in the current directory."""
    (tmp_path / "robot").mkdir()
    text = '<?xml version="1.0" encoding="ISO-8859-1"?>\n<!-- bras léger --><mujoco><include file="body.xml"/></mujoco>'
    (tmp_path / "robot" / "model.xml").write_bytes(text.encode("latin-1"))
    (tmp_path / "robot" / "body.xml").write_text(_arm_body(1.0, 2.0))
    (tmp_path / "body.xml").write_text(_arm_body(4.0, 9.0))  # a decoy in the working directory
    monkeypatch.chdir(tmp_path)
    arm = rd.load(tmp_path / "robot" / "model.xml", frame="tool")
    same = tmp_path / "robot" / "utf8.xml"
    same.write_text('<mujoco><include file="body.xml"/></mujoco>')
    _same_gravity(arm, same)


def test_an_mjcf_read_from_a_pipe_is_served(tmp_path: Path) -> None:
    (tmp_path / "model.xml").write_text(_arm_body())
    r, w = os.pipe()
    os.write(w, (tmp_path / "model.xml").read_bytes())
    os.close(w)
    try:
        arm = rd.load(f"/dev/fd/{r}", frame="tool")
    finally:
        os.close(r)
    _same_gravity(arm, tmp_path / "model.xml")


def test_a_copy_of_an_attached_robot_keeps_the_bytes_it_was_loaded_from(tmp_path: Path) -> None:
    """The recipe recorded the main file only: a copy read the attached file as changed."""
    import copy
    import pickle

    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "arm.xml").write_text('<mujoco><include file="inc.xml"/></mujoco>')
    (tmp_path / "parts" / "inc.xml").write_text(_arm_body(1.0, 2.0))
    main = tmp_path / "scene.xml"
    main.write_text(
        '<mujoco><asset><model name="arm" file="parts/arm.xml"/></asset><worldbody>'
        '<body name="mount" pos="0 0 0.5"><attach model="arm" body="b1" prefix="a_"/></body>'
        "</worldbody></mujoco>"
    )
    arm = rd.load(main, frame="a_tool")
    before = tmp_path / "before.xml"
    before.write_text(main.read_text())
    _same_gravity(arm, main)
    old = raw_gravity(main, np.array([0.4, -0.7]))
    (tmp_path / "parts" / "inc.xml").write_text(_arm_body(5.0, 7.0))
    for again in (copy.deepcopy(arm), pickle.loads(pickle.dumps(arm))):
        np.testing.assert_allclose(again.gravity([0.4, -0.7]), old, rtol=1e-12)
        np.testing.assert_allclose(again.gravity([0.4, -0.7], engine="pinocchio"), old, rtol=1e-12)


# ------------------------------------------------------------------------------------------
# URDF text both engines load as published
# ------------------------------------------------------------------------------------------


def test_an_undeclared_namespace_prefix_is_tolerated_as_the_engines_tolerate_it(
    tmp_path: Path,
) -> None:
    """``drake:`` tags without their declaration: the XML parser refused the file."""
    extra = (
        '<link name="base"/><drake:collision_filter_group name="g">'
        '<drake:member link="l1"/></drake:collision_filter_group>'
    )
    text = two_link_urdf(extra=extra).replace(
        '<joint name="j2" type="revolute">',
        '<joint name="j2" type="revolute"><drake:rotor_inertia value="0.1"/>',
    )
    path = tmp_path / "r.urdf"
    path.write_text(text)
    arm = rd.load(path, frame="tool")
    m = raw_mujoco(path)
    assert_matches_raw(arm, m, "tool", np.array([0.3, -0.2]))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)  # raw MuJoCo at q = 0: the same mass matrix
    full = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, full)
    for engine in arm.engines:
        np.testing.assert_allclose(arm.mass_matrix(np.zeros(2), engine=engine), full, atol=1e-14)


def test_a_moving_link_with_an_inertial_of_mass_0_is_named_not_a_mujoco_error(
    tmp_path: Path,
) -> None:
    """The loader added a second <inertial>: "repeated element" at a line not in the file."""
    zero = (
        '<inertial><mass value="0"/>'
        '<inertia ixx="0" iyy="0" izz="0" ixy="0" ixz="0" iyz="0"/></inertial>'
    )
    text = two_link_urdf(extra='<link name="base"/>')
    text = text.replace(f'<link name="l2">{INERTIAL}', f'<link name="l2">{zero}')
    path = tmp_path / "r.urdf"
    path.write_text(text)
    arm = rd.load(path, frame="tool")
    assert arm.missing_inertia == ("l2",)
    named = [a for a in arm.set_aside if a.what == "links of mass 0"]
    assert [a.name for a in named] == ["l2"]
    with pytest.raises(rd.MissingInertiaError):
        arm.gravity(np.zeros(2))
    stripped = tmp_path / "kinematic.urdf"
    stripped.write_text(text.replace(zero, INERTIAL))  # the same kinematics
    assert_matches_raw(arm, raw_mujoco(stripped), "tool", np.array([0.5, 0.25]))


def test_a_mimic_follower_of_a_massless_leader_is_held_at_its_rules_value(
    tmp_path: Path,
) -> None:
    """The leader is made fixed at 0 (it moves no mass): the follower is held at
    ``multiplier x 0 + offset``, not at 0 with its mimic dropped."""
    gripper = (
        '<link name="base"/><link name="finger_a"/>'
        + _joint("fa", "tool", "finger_a", "0 0 0.02", "1 0 0", "prismatic")
        + _link("finger_b")
        + _joint("fb", "tool", "finger_b", "0 0 0.02", "1 0 0", "prismatic").replace(
            "</joint>", '<mimic joint="fa" multiplier="-1" offset="0.013"/></joint>'
        )
    )
    path = tmp_path / "r.urdf"
    path.write_text(two_link_urdf(extra=gripper))
    arm = rd.load(path, frame="tool")
    assert arm.held["fb"] == pytest.approx(0.013, abs=1e-15)
    assert any(a.what == "mimic" and a.name == "fb" for a in arm.set_aside)


# ------------------------------------------------------------------------------------------
# MJCF patterns both engines load: shared names
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("tool", ["b2", "j2"])
def test_sites_named_like_a_body_or_a_joint_are_served(tmp_path: Path, tool: str) -> None:
    """A site named after its body (simulation suites' pattern) or after a joint."""
    text = _arm_body().replace(
        '<site name="tool" pos="0.3 0 0"/>',
        '<site name="b2" pos="0.3 0 0"/><site name="j2" pos="0.1 0.05 0"/>',
    )
    text = text.replace(
        '<joint name="j1" axis="0 0 1"/>', '<joint name="j1" axis="0 0 1"/><site name="b1"/>'
    )
    path = tmp_path / "m.xml"
    path.write_text(text)
    arm = rd.load(path, frame=tool)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    q = np.array([0.3, -0.8])
    d.qpos[:] = q
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    jp, jr = np.zeros((3, 2)), np.zeros((3, 2))
    mujoco.mj_jacSite(m, d, jp, jr, m.site(tool).id)
    for engine in arm.engines:
        np.testing.assert_allclose(arm.site_pose(q, engine)[0], d.site(tool).xpos, atol=1e-14)
        np.testing.assert_allclose(arm.jacobian(q, engine), np.vstack([jp, jr]), atol=1e-14)


MOBILE = """<mujoco><worldbody>
  <body name="base" pos="0.2 -0.1 0.1" euler="0 0 20">
    <joint name="x" type="slide" axis="1 0 0" range="-2 2"/>
    <joint name="y" type="slide" axis="0 1 0" range="-2 2"/>
    <joint name="yaw" pos="0.05 0.02 0" axis="0 0.2 1" range="-3 3"/>
    <geom type="box" size="0.2 0.2 0.05" mass="10"/>
    <body name="arm_base" pos="0.1 0 0.1">
      <body name="l1"><joint name="j1" axis="0 0 1"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.03" mass="1"/>
        <body name="l2" pos="0 0 0.3"><joint name="j2" axis="0 1 0"/>
          <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1.5"/>
          <site name="tool" pos="0.3 0 0"/></body></body></body></body>
</worldbody></mujoco>"""


@pytest.mark.parametrize("base", [None, "arm_base"])
def test_a_mobile_base_with_its_joints_in_one_body_is_served(
    tmp_path: Path, base: str | None
) -> None:
    """TidyBot's pattern: x, y and yaw in the base's one body, MuJoCo's chain at one origin."""
    path = tmp_path / "mobile.xml"
    path.write_text(MOBILE)
    arm = rd.load(path, frame="tool", base=base)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    for q in rd.random_poses(arm, 5, seed=5):
        d.qpos[:] = 0
        for name, v in zip(arm.joint_names, q, strict=True):
            d.qpos[m.joint(name).qposadr[0]] = v
        mujoco.mj_forward(m, d)
        jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        mujoco.mj_jacSite(m, d, jp, jr, m.site("tool").id)
        cols = [m.joint(n).dofadr[0] for n in arm.joint_names]
        for engine in arm.engines:
            np.testing.assert_allclose(arm.site_pose(q, engine)[0], d.site("tool").xpos, atol=1e-13)
            np.testing.assert_allclose(
                arm.jacobian(q, engine), np.vstack([jp, jr])[:, cols], atol=1e-13
            )
            np.testing.assert_allclose(arm.gravity(q, engine=engine), d.qfrc_bias[cols], atol=1e-11)


@pytest.mark.parametrize(
    ("kind", "base"),
    [("floating", None), ("floating", "mid"), ("planar", None), ("planar", "mid")],
)
def test_a_floating_or_planar_urdf_base_is_held_where_the_file_puts_it(
    tmp_path: Path, kind: str, base: str | None
) -> None:
    stand = (
        '<link name="world"/>'
        + _link("body")
        + f'<joint name="fb" type="{kind}"><parent link="world"/><child link="body"/>'
        '<origin xyz="0.1 0 0.2" rpy="0.2 0 0.3"/><axis xyz="0 0 1"/></joint>'
        '<joint name="fm" type="fixed"><parent link="body"/><child link="mid"/>'
        '<origin xyz="0 0 0.1"/></joint>' + _link("mid")
    )
    path = tmp_path / "r.urdf"
    path.write_text(two_link_urdf("mid", stand))
    arm = rd.load(path, frame="tool", base=base)
    assert arm.joint_names == ("j1", "j2")
    m = raw_mujoco(path)
    for q in rd.random_poses(arm, 4, seed=6):
        assert_matches_raw(arm, m, "tool", q)


def test_a_planar_joint_below_the_chains_first_joint_names_the_base_that_holds_it(
    tmp_path: Path,
) -> None:
    """A planar base is held by default; below a moving joint it is on the arm: refused."""
    stand = (
        '<link name="world"/>'
        + _link("post")
        + _joint("turn", "world", "post", "0 0 0.1", "0 0 1")
        + _link("body")
        + '<joint name="fb" type="planar"><parent link="post"/><child link="body"/>'
        '<axis xyz="0 0 1"/></joint><joint name="fm" type="fixed"><parent link="body"/>'
        '<child link="mid"/></joint>' + _link("mid")
    )
    path = tmp_path / "r.urdf"
    path.write_text(two_link_urdf("mid", stand))
    with pytest.raises(rd.UnsupportedFeatureError) as err:
        rd.load(path, frame="tool")
    assert str(err.value) == (
        f"unsupported feature: planar joint on the arm's chain (joint 'fb' in {path}): the arm "
        "is a chain of revolute and prismatic joints; a planar base is held where the file "
        "puts it when the arm starts below it (base='body')"
    )


def test_a_planar_mobile_base_is_held_by_default_and_said(tmp_path: Path) -> None:
    """Roboplan's reachback: a planar joint from the world to the base, the arm above it."""
    stand = (
        '<link name="world"/>'
        + _link("body")
        + '<joint name="fb" type="planar"><parent link="world"/><child link="body"/>'
        '<origin xyz="0.1 0 0.2" rpy="0 0 0.3"/><axis xyz="0 0 1"/></joint>'
        '<joint name="fm" type="fixed"><parent link="body"/><child link="mid"/>'
        '<origin xyz="0 0 0.1"/></joint>' + _link("mid")
    )
    path = tmp_path / "r.urdf"
    path.write_text(two_link_urdf("mid", stand))
    arm = rd.load(path, frame="tool")
    assert [(a.what, a.name, a.reason) for a in arm.set_aside if a.what == "planar base"] == [
        (
            "planar base",
            "body",
            "a mobile base: held where the file puts it, the arm starts at its link "
            "(base='body', as a floating base is held)",
        )
    ]
    m = raw_mujoco(path)
    for q in rd.random_poses(arm, 4, seed=8):
        assert_matches_raw(arm, m, "tool", q)
    assert rd.crosscheck(arm, rd.random_poses(arm, 8, seed=8)).ok


ROBOT_IN_DEGREES = """<mujoco><compiler angle="degree"/><worldbody>
  <body name="b1" pos="0 0 0.1" euler="0 0 30"><joint name="j1" axis="0 0 1" range="-90 90"/>
    <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.03" mass="1"/>
    <body name="b2" pos="0 0 0.3" euler="20 0 0"><joint name="j2" axis="0 1 0" range="-45 45"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="2"/>
      <site name="tool" pos="0.3 0 0"/></body></body></worldbody></mujoco>"""


@pytest.mark.parametrize("strict", [True, False])
@pytest.mark.parametrize(
    "scene",
    [
        '<mujoco><compiler angle="radian"/><include file="robot.xml"/></mujoco>',
        '<mujoco><include file="robot.xml"/><compiler angle="radian"/></mujoco>',
    ],
)
def test_a_scene_and_its_robot_in_different_angle_units_are_read_in_mujocos(
    tmp_path: Path, scene: str, strict: bool
) -> None:
    """MuJoCo reads the whole model with the last <compiler angle>; Pinocchio's parser read
    each part with its own (the robot's degrees as radians, or the reverse)."""
    (tmp_path / "robot.xml").write_text(ROBOT_IN_DEGREES)
    path = tmp_path / "scene.xml"
    path.write_text(scene)
    arm = rd.load(path, frame="tool", strict=strict)
    m = mujoco.MjModel.from_xml_path(str(path))
    np.testing.assert_array_equal(arm.upper, m.jnt_range[:, 1])
    d = mujoco.MjData(m)
    for q in rd.random_poses(arm, 4, seed=7):
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        jp, jr = np.zeros((3, 2)), np.zeros((3, 2))
        mujoco.mj_jacSite(m, d, jp, jr, m.site("tool").id)
        for engine in arm.engines:
            np.testing.assert_allclose(arm.site_pose(q, engine)[0], d.site("tool").xpos, atol=1e-13)
            np.testing.assert_allclose(arm.jacobian(q, engine), np.vstack([jp, jr]), atol=1e-13)


def test_a_worker_without_ros_package_path_rebuilds_from_the_carried_meshes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The mesh was found through ROS_PACKAGE_PATH at load; the worker has none."""
    import pickle
    import subprocess
    import sys

    _box(tmp_path / "ws" / "my_pkg" / "meshes" / "a.stl", 0.05)
    _box(tmp_path / "ws" / "my_pkg" / "meshes" / "b.stl", 0.07)
    (tmp_path / "robot").mkdir()
    path = tmp_path / "robot" / "r.urdf"
    path.write_text(_with_meshes("package://my_pkg/meshes/a.stl", "package://my_pkg/meshes/b.stl"))
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "ws"))
    arm = rd.load(path, frame="tool")
    assert arm.missing_meshes == ()
    blob = tmp_path / "arm.pickle"
    blob.write_bytes(pickle.dumps(arm))
    env = {k: v for k, v in os.environ.items() if k != "ROS_PACKAGE_PATH"}
    script = (
        "import pickle, sys; import numpy as np\n"
        "arm = pickle.loads(open(sys.argv[1], 'rb').read())\n"
        "print(len(arm.missing_meshes), arm.robot_model.nmesh, arm.robot_model.mesh_vert.max())"
    )
    out = subprocess.run(
        [sys.executable, "-c", script, str(blob)],
        env=env,
        capture_output=True,
        text=True,
        cwd=tmp_path,
        check=False,
    )
    assert out.returncode == 0, out.stderr
    missing, nmesh, extent = out.stdout.split()
    assert (missing, nmesh) == ("0", "2")
    assert float(extent) == pytest.approx(0.07, abs=1e-7)  # b.stl's half height, float32


@pytest.mark.parametrize(
    ("compiler", "izz"),
    [('balanceinertia="true"', "0.05"), ('boundmass="1.5"', "0.01"), ('settotalmass="7"', "0.01")],
)
def test_the_urdf_mujoco_extensions_mass_options_are_mujocos_masses_in_both(
    tmp_path: Path, compiler: str, izz: str
) -> None:
    """MuJoCo applies them to the inertials; Pinocchio gets MuJoCo's compiled masses, bridged.

    Ground truth: raw MuJoCo's mass matrix and gravity on the file as written.
    """
    bad = (
        '<inertial><origin xyz="0 0 0.1"/><mass value="1"/>'
        f'<inertia ixx="0.01" iyy="0.01" izz="{izz}" ixy="0" ixz="0" iyz="0"/></inertial>'
    )
    text = two_link_urdf(extra='<link name="base"/>').replace(
        f'<link name="l2">{INERTIAL}', f'<link name="l2">{bad}'
    )
    path = tmp_path / "r.urdf"
    path.write_text(
        text.replace('<robot name="r">', f'<robot name="r"><mujoco><compiler {compiler}/></mujoco>')
    )
    arm = rd.load(path, frame="tool")
    m = raw_mujoco(path)
    d = mujoco.MjData(m)
    q = np.array([0.4, -0.9])
    d.qpos[:] = q
    mujoco.mj_forward(m, d)
    full = np.zeros((2, 2))
    mujoco.mj_fullM(m, d, full)
    for engine in arm.engines:
        np.testing.assert_allclose(arm.mass_matrix(q, engine=engine), full, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(
            arm.gravity(q, engine=engine), d.qfrc_bias, rtol=1e-12, atol=1e-14
        )


# ------------------------------------------------------------------------------------------
# Found by the survey of published packages (scripts/survey_robots.py --published)
# ------------------------------------------------------------------------------------------

#: Gymnasium-Robotics' pusher pattern: visual geoms by default, and other root bodies (the
#: object and the goal) beside the arm.
VISUAL_BY_DEFAULT = """<mujoco><default><geom contype="0" conaffinity="0"/></default><worldbody>
  <body name="a"><joint name="j1" axis="0 0 1"/>
    <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.05"/>
    <body name="b" pos="0.3 0 0"><joint name="j2" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.05"/>
      <site name="tip" pos="0.3 0 0"/></body></body>
  <body name="object" pos="1 0 0"><geom type="sphere" size="0.05"/></body>
  <body name="goal" pos="1 1 0"><joint name="slide" type="slide" axis="1 0 0"/>
    <geom type="sphere" size="0.05"/></body>
</worldbody></mujoco>"""


def test_inertias_from_visual_geoms_are_bridged_beside_other_root_bodies(tmp_path: Path) -> None:
    """Pinocchio's parser leaves visual geoms out of the inertia: bridged whatever the trees.

    Ground truth: raw MuJoCo's mass matrix on the file (Pinocchio's was all zeros).
    """
    path = tmp_path / "pusher.xml"
    path.write_text(VISUAL_BY_DEFAULT)
    arm = rd.load(path, frame="tip")
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    q = np.array([0.3, -0.7])
    d.qpos[[m.joint("j1").qposadr[0], m.joint("j2").qposadr[0]]] = q
    mujoco.mj_forward(m, d)
    full = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, full)
    cols = [m.joint("j1").dofadr[0], m.joint("j2").dofadr[0]]
    assert full[np.ix_(cols, cols)].min() < full[np.ix_(cols, cols)].max()  # a real mass matrix
    for engine in arm.engines:
        np.testing.assert_allclose(
            arm.mass_matrix(q, engine=engine), full[np.ix_(cols, cols)], rtol=1e-12, atol=1e-14
        )
    assert rd.crosscheck(arm, np.array([q])).ok


def test_an_engine_with_a_singular_mass_matrix_is_a_disagreement_not_a_crash(
    tmp_path: Path,
) -> None:
    """Where one engine's M cannot be inverted, M^-1's quantities disagree (NaN), no LinAlgError."""
    path = tmp_path / "pusher.xml"
    path.write_text(VISUAL_BY_DEFAULT)
    arm = rd.load(path, frame="tip")
    pm = arm.engines["pinocchio"].model
    for k in range(1, pm.njoints):  # what the bridge above mends: a model without masses
        pm.inertias[k] = pin.Inertia.Zero()
    report = rd.crosscheck(arm, np.array([[0.3, -0.7], [0.1, 0.2]]))
    assert not report.ok
    failed = {a.quantity for a in report.agreements if not a.ok}
    assert {"mass matrix", "dynamic manipulability"} <= failed
    assert not np.isfinite(report["dynamic manipulability"].max_error)


def test_a_tool_name_that_is_a_link_and_a_fixed_joint_says_which_it_read(tmp_path: Path) -> None:
    """Kinova's gen3 lite: link END_EFFECTOR and a fixed joint END_EFFECTOR to link DUMMY."""
    text = two_link_urdf(extra='<link name="base"/>').replace(
        '<link name="tool"/>',
        '<link name="tool"/><link name="DUMMY"/><joint name="tool" type="fixed">'
        '<parent link="tool"/><child link="DUMMY"/><origin xyz="0 0 0.13"/></joint>',
    )
    path = tmp_path / "r.urdf"
    path.write_text(text)
    arm = rd.load(path, frame="tool")
    notes = [a for a in arm.set_aside if a.what == "tool frame"]
    assert [(a.name, a.reason) for a in notes] == [
        (
            "tool",
            "names a link and a fixed joint (to link 'DUMMY'): the link is the tool; "
            "the joint's frame is frame='DUMMY'",
        )
    ]
    m = raw_mujoco(path)
    q = np.array([0.4, -0.9])
    assert_matches_raw(arm, m, "tool", q)
    assert_matches_raw(rd.load(path, frame="DUMMY"), m, "DUMMY", q)

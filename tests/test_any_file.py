"""Files MuJoCo compiles as published are served, and read as MuJoCo reads them.

Each case is a class of published file (issue "any robot that MuJoCo compiles" and the fourth
hostile round), written out tiny in a temporary folder. The ground truth is raw MuJoCo on the
file as written (``MjSpec.from_file`` on the user's path, ``fusestatic`` off so a tool link
keeps its body): the tool position and J of the library's both engines must equal it.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
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

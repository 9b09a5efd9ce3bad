"""URDF in both engines: the bundled URDFs, what each importer reads, and bad input.

The helpers at the top build URDF variants (rotated link frames, split links, shuffled
declarations) and are shared with ``test_compare.py``.
"""

from __future__ import annotations

import pickle
import subprocess
import sys
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import redundancy as rd
from redundancy.analysis.crosscheck import crosscheck
from redundancy.arm import random_poses, sampling_ranges
from redundancy.collision import collision_pairs
from redundancy.model.equivalence import compare_models

from .corpus import write_binary_stl
from .test_fuzz import VALUES, Worker

MODELS = Path(rd.model_path("arm7")).parent


# -- helpers: URDF text and variants -------------------------------------------------------
def urdf_root(name: str) -> ET.Element:
    """The bundled URDF ``name`` (arm7 or panda), parsed."""
    return ET.parse(MODELS / f"{name}.urdf").getroot()


def write(root: ET.Element, path: Path) -> Path:
    path.write_text(ET.tostring(root, encoding="unicode"))
    return path


def element(root: ET.Element, tag: str, name: str) -> ET.Element:
    found = root.find(f"{tag}[@name='{name}']")
    assert found is not None, (tag, name)
    return found


def _vec(text: str | None) -> np.ndarray:
    return np.array([float(x) for x in (text or "0 0 0").split()])


def _text(v: np.ndarray) -> str:
    return " ".join(repr(float(x)) for x in v)


def rpy_matrix(rpy: np.ndarray) -> np.ndarray:
    """URDF's fixed-axis roll, pitch, yaw: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = rpy
    cx, sx, cy, sy, cz, sz = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


def matrix_rpy(R: np.ndarray) -> np.ndarray:
    return np.array(
        [np.arctan2(R[2, 1], R[2, 2]), np.arcsin(-R[2, 0]), np.arctan2(R[1, 0], R[0, 0])]
    )


def _origin(el: ET.Element) -> ET.Element:
    origin = el.find("origin")
    if origin is None:
        origin = ET.SubElement(el, "origin", xyz="0 0 0", rpy="0 0 0")
    return origin


def rotate_link_frame(root: ET.Element, link: str, R: np.ndarray) -> None:
    """Express ``link`` in a frame rotated by ``R`` (same robot, different clothes).

    The link's frame becomes F R: its joint's origin turns by R, and everything written in
    the link's frame (joint axis, inertial, collisions, child joint origins) by R^T.
    """
    for joint in root.findall("joint"):
        origin = _origin(joint)
        rot = rpy_matrix(_vec(origin.get("rpy")))
        if joint.find("child").get("link") == link:  # type: ignore[union-attr]
            origin.set("rpy", _text(matrix_rpy(rot @ R)))
            axis = joint.find("axis")
            if axis is not None:
                axis.set("xyz", _text(R.T @ _vec(axis.get("xyz"))))
        if joint.find("parent").get("link") == link:  # type: ignore[union-attr]
            origin.set("xyz", _text(R.T @ _vec(origin.get("xyz"))))
            origin.set("rpy", _text(matrix_rpy(R.T @ rot)))
    el = element(root, "link", link)
    for part in [*el.findall("inertial"), *el.findall("collision"), *el.findall("visual")]:
        origin = _origin(part)
        origin.set("xyz", _text(R.T @ _vec(origin.get("xyz"))))
        origin.set("rpy", _text(matrix_rpy(R.T @ rpy_matrix(_vec(origin.get("rpy"))))))


def split_link(root: ET.Element, link: str) -> None:
    """Move half of ``link``'s inertial to a new link fixed to it (MuJoCo and Pinocchio fuse)."""
    el = element(root, "link", link)
    inertial = el.find("inertial")
    assert inertial is not None
    half = ET.fromstring(ET.tostring(inertial))
    for part in (inertial, half):
        mass = part.find("mass")
        mass.set("value", repr(float(mass.get("value")) / 2))  # type: ignore[union-attr, arg-type]
        inertia = part.find("inertia")
        for key, value in inertia.attrib.items():  # type: ignore[union-attr]
            inertia.set(key, repr(float(value) / 2))  # type: ignore[union-attr]
    extra = ET.SubElement(root, "link", name=f"{link}_extra")
    extra.append(half)
    joint = ET.SubElement(root, "joint", name=f"{link}_extra_joint", type="fixed")
    ET.SubElement(joint, "parent", link=link)
    ET.SubElement(joint, "child", link=f"{link}_extra")
    ET.SubElement(joint, "origin", xyz="0 0 0", rpy="0 0 0")


def shuffle_declarations(root: ET.Element, seed: int) -> None:
    """Declare links and joints in another order (URDF's tree comes from parent/child)."""
    children = [c for c in root if c.tag in ("link", "joint")]
    for c in children:
        root.remove(c)
    for i in np.random.default_rng(seed).permutation(len(children)):
        root.append(children[i])


def random_rotation(seed: int) -> np.ndarray:
    q = np.random.default_rng(seed).normal(size=4)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def tiny_urdf(body: str = "", joint_type: str = "revolute", extra: str = "") -> str:
    """A two-link URDF (base -> l1 -> tool) to vary one feature at a time."""
    limit = '<limit lower="-1" upper="1" effort="5" velocity="1"/>'
    return f"""<robot name="tiny">
  <link name="base"/>
  <joint name="j1" type="{joint_type}">
    <parent link="base"/><child link="l1"/><origin xyz="0 0 0.1"/><axis xyz="0 1 0"/>
    {limit if joint_type in ("revolute", "prismatic") else ""}
    <dynamics damping="0.2" friction="0.05"/>
    {extra}
  </joint>
  <link name="l1">
    {
        body
        or '''<inertial><origin xyz="0 0 0.1"/><mass value="1"/>
      <inertia ixx="0.01" iyy="0.01" izz="0.002" ixy="0" ixz="0" iyz="0"/></inertial>'''
    }
    <collision><origin xyz="0 0 0.1"/><geometry><box size="0.05 0.05 0.2"/></geometry></collision>
  </link>
  <joint name="tool_joint" type="fixed">
    <parent link="l1"/><child link="tool"/><origin xyz="0 0 0.25"/>
  </joint>
  <link name="tool"/>
</robot>"""


def write_stl(path: Path) -> None:
    """A binary STL tetrahedron (0.1 m edges)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    verts = 0.1 * np.array([(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)], dtype=float)
    write_binary_stl(path, verts, np.array([(0, 1, 2), (0, 3, 1), (0, 2, 3), (1, 3, 2)]))


# -- the bundled URDFs ---------------------------------------------------------------------
@pytest.mark.parametrize("name", ["arm7", "panda"])
def test_bundled_urdf_crosschecks(name: str) -> None:
    arm = rd.load(MODELS / f"{name}.urdf", frame="ee")
    assert arm.nq == 7 and arm.frame == "ee"
    assert arm.bridges == ()  # both importers read every value the library uses
    report = crosscheck(arm, random_poses(arm, 100, seed=3))
    assert report.ok, report.lines()
    for agreement in report.agreements:
        assert agreement.max_error <= 1e-9
    assert compare_models(arm).equivalent, compare_models(arm).lines()


@pytest.mark.parametrize("name", ["arm7", "panda"])
def test_bundled_urdf_is_its_mjcf_without_armature(name: str) -> None:
    urdf = rd.load(MODELS / f"{name}.urdf", frame="ee")
    mjcf = rd.load(MODELS / f"{name}.xml", frame="ee")
    for q in random_poses(mjcf, 20, seed=4):
        np.testing.assert_allclose(urdf.jacobian(q), mjcf.jacobian(q), atol=1e-12)
        np.testing.assert_allclose(
            urdf.mass_matrix(q), mjcf.mass_matrix(q, armature=False), atol=1e-12
        )
        np.testing.assert_allclose(urdf.gravity(q), mjcf.gravity(q), atol=1e-12)
    np.testing.assert_array_equal(urdf.effort_limit, mjcf.effort_limit)
    np.testing.assert_array_equal(urdf.damping(), mjcf.damping())
    np.testing.assert_array_equal(urdf.lower, mjcf.lower)
    assert not urdf.armature().any() and mjcf.armature().all()


def test_what_each_importer_reads() -> None:
    """Limits, effort, damping and friction reach both engines; velocity only Pinocchio."""
    arm = rd.load_string(tiny_urdf(), frame="tool")
    mj, pm = arm.mj_model, arm.pinocchio.model
    assert (arm.lower[0], arm.upper[0]) == (-1.0, 1.0)
    assert arm.effort_limit[0] == 5.0 == pm.effortLimit[0]
    assert arm.damping()[0] == 0.2 == pm.damping[0]
    assert mj.dof_frictionloss[0] == 0.05 == pm.friction[0]
    assert mj.dof_armature[0] == 0.0 == pm.armature[0]
    assert pm.velocityLimit[0] == 1.0  # MuJoCo has no velocity limit
    # The fixed tool link stays a body in MuJoCo (fusestatic off), carrying the tool site.
    assert "tool" in [mj.body(i).name for i in range(mj.nbody)]
    assert mj.site(arm.mujoco.site_id).name == "tool"
    # MuJoCo leaves URDF geoms unnamed; the library names them after their link.
    assert [mj.geom(i).name for i in range(mj.ngeom)] == ["l1"]


def test_tool_as_fixed_joint_name_and_unknown_tool() -> None:
    by_link = rd.load_string(tiny_urdf(), frame="tool")
    by_joint = rd.load_string(tiny_urdf(), frame="tool_joint")
    q = np.array([0.3])
    np.testing.assert_array_equal(by_link.site_pose(q)[0], by_joint.site_pose(q)[0])
    with pytest.raises(rd.UnknownNameError) as err:
        rd.load_string(tiny_urdf(), frame="flange")
    assert str(err.value) == "unknown link 'flange'; valid link names: ['base', 'l1', 'tool']"


def test_frame_argument_names_the_link_too() -> None:
    assert rd.load_string(tiny_urdf(), frame="tool").frame == "tool"


def test_continuous_joint_is_one_unbounded_angle() -> None:
    root = urdf_root("arm7")
    element(root, "joint", "j1").set("type", "continuous")
    j1 = element(root, "joint", "j1")
    j1.remove(j1.find("limit"))  # type: ignore[arg-type]
    arm = rd.load_string(ET.tostring(root, encoding="unicode"), frame="ee")
    assert arm.pinocchio.model.nq == 7  # not Pinocchio's (cos, sin) pair
    assert [(b.quantity, b.joint) for b in arm.bridges] == [("continuous joint as one angle", "j1")]
    assert (arm.lower[0], arm.upper[0]) == (-np.inf, np.inf)
    lo, hi = sampling_ranges(arm)
    assert (lo[0], hi[0]) == (-np.pi, np.pi)
    poses = random_poses(arm, 200, seed=5)
    assert poses[:, 0].min() < -3 and poses[:, 0].max() > 3
    assert crosscheck(arm, poses).ok
    # The same arm with j1 limited to +-pi: identical numbers inside the range.
    limited = rd.load(MODELS / "arm7.urdf", frame="ee")
    q = poses[0].copy()
    q[0] = 2.5
    np.testing.assert_allclose(arm.mass_matrix(q), limited.mass_matrix(q), atol=1e-15)
    np.testing.assert_allclose(
        arm.jacobian(q, engine="pinocchio"), limited.jacobian(q, engine="pinocchio"), atol=1e-15
    )


def test_unaligned_continuous_axis() -> None:
    text = tiny_urdf(joint_type="continuous").replace(
        '<axis xyz="0 1 0"/>', '<axis xyz="0.6 0 0.8"/>'
    )
    arm = rd.load_string(text, frame="tool")
    assert arm.pinocchio.model.nq == 1
    assert crosscheck(arm, np.linspace(-3, 3, 13)[:, None]).ok


def test_prismatic_joint() -> None:
    arm = rd.load_string(tiny_urdf(joint_type="prismatic"), frame="tool")
    assert arm.joint_types == ("slide",)
    assert crosscheck(arm, np.linspace(-1, 1, 9)[:, None]).ok


def test_pickle_rebuilds_a_urdf_arm() -> None:
    arm = rd.load(MODELS / "panda.urdf", frame="ee")
    copy = pickle.loads(pickle.dumps(arm))
    q = random_poses(arm, 1, seed=2)[0]
    np.testing.assert_array_equal(copy.gravity(q), arm.gravity(q))
    np.testing.assert_array_equal(copy.jacobian(q, "pinocchio"), arm.jacobian(q, "pinocchio"))


# -- collision: adjacent links and SRDF pairs ------------------------------------------------
def _body_pairs(arm: rd.Arm) -> set[frozenset[str]]:
    m = arm.mj_model
    return {
        frozenset((m.body(m.geom_bodyid[p.geom1]).name, m.body(m.geom_bodyid[p.geom2]).name))
        for p in collision_pairs(arm)
    }


def test_adjacent_links_never_collide() -> None:
    """URDF has no filter: links joined by a joint are excluded, the base included."""
    urdf = rd.load(MODELS / "panda.urdf", frame="ee")
    pairs = _body_pairs(urdf)
    assert frozenset(("link0", "link1")) not in pairs  # MuJoCo alone would keep this one
    for i in range(7):
        assert frozenset((f"link{i}", f"link{i + 1}")) not in pairs
    # The MJCF excludes link0/link1 explicitly: the two files give the same body pairs.
    assert pairs == _body_pairs(rd.load(MODELS / "panda.xml", frame="ee"))


def test_srdf_and_listed_disabled_pairs(tmp_path: Path) -> None:
    srdf = tmp_path / "panda.srdf"
    srdf.write_text(
        '<robot name="panda"><disable_collisions link1="link0" link2="link7" reason="Never"/>'
        '<disable_collisions link1="link1" link2="link6" reason="Never"/></robot>'
    )
    plain = _body_pairs(rd.load(MODELS / "panda.urdf", frame="ee"))
    assert {frozenset(("link0", "link7")), frozenset(("link1", "link6"))} <= plain
    by_file = _body_pairs(rd.load(MODELS / "panda.urdf", frame="ee", disabled_collisions=srdf))
    assert plain - by_file == {frozenset(("link0", "link7")), frozenset(("link1", "link6"))}
    listed = rd.load(
        MODELS / "panda.urdf",
        frame="ee",
        disabled_collisions=[("link7", "link0"), ("link1", "link6")],
    )
    assert _body_pairs(listed) == by_file
    assert pickle.loads(pickle.dumps(listed)).mj_model.nexclude == listed.mj_model.nexclude


def test_a_links_several_geoms_are_named_as_unnamed_mjcf_geoms() -> None:
    """One collision geom: the link's name (the lesson's "link2 / link4"); several: the
    README's convention for an unnamed geom, "link geom k" counted from 0 in the link."""
    second = (
        '<collision><origin xyz="0 0 0.2"/><geometry><sphere radius="0.03"/></geometry></collision>'
    )
    text = tiny_urdf().replace(
        '</link>\n  <joint name="tool_joint"', f'{second}</link>\n  <joint name="tool_joint"'
    )
    text = text.replace('<link name="tool"/>', '<link name="tool">' + second + "</link>")
    arm = rd.load_string(text, frame="tool")
    m = arm.mj_model
    names = {m.geom(g).name for g in range(m.ngeom)}
    assert {"l1 geom 0", "l1 geom 1", "tool"} <= names
    assert not any("/" in n for n in names)


def test_disabled_pairs_bad_input(tmp_path: Path) -> None:
    path = MODELS / "panda.urdf"
    with pytest.raises(rd.UnknownNameError, match="unknown link 'link9'"):
        rd.load(path, frame="ee", disabled_collisions=[("link0", "link9")])
    with pytest.raises(rd.ModelError, match="two link names"):
        rd.load(path, frame="ee", disabled_collisions=[("link0", "link1", "link2")])
    with pytest.raises(rd.ModelError, match="cannot read the SRDF file"):
        rd.load(path, frame="ee", disabled_collisions=tmp_path / "missing.srdf")
    with pytest.raises(rd.ModelError, match="disabled_collisions is for URDF"):
        rd.load(MODELS / "panda.xml", disabled_collisions=[("link0", "link1")])


def test_audit_runs_on_a_urdf(capsys: pytest.CaptureFixture[str]) -> None:
    from redundancy.cli import main

    code = main(["audit", str(MODELS / "arm7.urdf"), "--frame", "ee", "--poses", "200"])
    assert code in (0, 1)
    assert "Traceback" not in capsys.readouterr().err


# -- meshes ----------------------------------------------------------------------------------
def _mesh_urdf(filename: str) -> str:
    return tiny_urdf().replace(
        '<geometry><box size="0.05 0.05 0.2"/></geometry>',
        f'<geometry><mesh filename="{filename}"/></geometry>',
    )


@pytest.mark.parametrize(
    "filename", ["meshes/tet.stl", "package://mypkg/meshes/tet.stl", "file://{root}/meshes/tet.stl"]
)
def test_mesh_paths_resolve(tmp_path: Path, filename: str) -> None:
    pkg = tmp_path / "mypkg"
    write_stl(pkg / "meshes" / "tet.stl")
    (pkg / "urdf").mkdir()
    urdf = pkg / ("urdf/robot.urdf" if filename.startswith("package") else "robot.urdf")
    urdf.write_text(_mesh_urdf(filename.format(root=pkg)))
    arm = rd.load(urdf, frame="tool")
    assert arm.mj_model.nmesh == 1
    # The inertial is explicit: the mesh changes no mass in either engine.
    assert crosscheck(arm, np.linspace(-1, 1, 5)[:, None]).ok


def test_visual_meshes_are_not_opened(tmp_path: Path) -> None:
    """Visual geoms are discarded, so a visual mesh MuJoCo cannot read (or find) is harmless."""
    text = tiny_urdf().replace(
        "<collision>",
        '<visual><geometry><mesh filename="package://gone/l1.dae"/></geometry></visual><collision>',
    )
    arm = rd.load_string(text, frame="tool")
    assert arm.mj_model.nmesh == 0 and arm.mj_model.ngeom == 1


def test_collada_mesh_is_read_for_both_colliders(tmp_path: Path) -> None:
    """Collada collision meshes (common in ROS packages; the Kinova Gen2 of example-robot-data):
    MuJoCo has no decoder, so trimesh reads them and MuJoCo gets the same vertices."""
    import trimesh

    box = trimesh.creation.box(extents=(0.04, 0.05, 0.06))
    (tmp_path / "l1.dae").write_bytes(trimesh.exchange.dae.export_collada(box))
    urdf = tmp_path / "robot.urdf"
    urdf.write_text(_mesh_urdf("l1.dae"))
    arm = rd.load(urdf, frame="tool")
    m = arm.mj_model
    assert m.nmesh == 1
    verts = m.mesh_vert[m.mesh_vertadr[0] : m.mesh_vertadr[0] + m.mesh_vertnum[0]]
    # MuJoCo recentres a mesh at its centroid: the box's extents survive exactly.
    assert np.allclose(verts.max(axis=0) - verts.min(axis=0), (0.04, 0.05, 0.06), atol=1e-12)
    assert [(a.what, a.name) for a in arm.set_aside] == [("Collada mesh", "l1.dae")]


def test_broken_collada_mesh_is_the_librarys_error(tmp_path: Path) -> None:
    (tmp_path / "l1.dae").write_text("<COLLADA/>")
    urdf = tmp_path / "robot.urdf"
    urdf.write_text(_mesh_urdf("l1.dae"))
    with pytest.raises(rd.ModelError) as err:
        rd.load(urdf, frame="tool")
    assert str(err.value).startswith(
        f"URDF {urdf}: cannot read the Collada mesh '{tmp_path / 'l1.dae'}': "
    )


def test_unresolved_mesh_is_named_by_collision_not_by_the_load(tmp_path: Path) -> None:
    """A mesh found nowhere gives no collision geometry; the arm is served without it."""
    from redundancy import collision

    urdf = tmp_path / "robot.urdf"
    urdf.write_text(_mesh_urdf("package://nopkg/meshes/arm.stl"))
    arm = rd.load(urdf, frame="tool")
    with pytest.raises(rd.MissingMeshError) as err:
        collision.checker(arm)
    message = str(err.value)
    assert message.startswith(
        "collision needs the meshes the model names, and these are found nowhere: link "
    )
    assert "'package://nopkg/meshes/arm.stl' (looked for: " in message
    assert str(tmp_path / "nopkg" / "meshes" / "arm.stl") in message


# -- bad input ------------------------------------------------------------------------------
def test_missing_inertial_serves_kinematics_not_a_mujoco_mass_error() -> None:
    text = tiny_urdf(body="<visual><geometry><box size='0.1 0.1 0.1'/></geometry></visual>")
    arm = rd.load_string(text, frame="tool")
    assert arm.missing_inertia == ("l1",)
    with pytest.raises(rd.MissingInertiaError) as err:
        arm.mass_matrix(np.zeros(arm.nq))
    assert str(err.value) == (
        "mass matrix needs the inertia of every link the arm moves, and the model gives none "
        "for 'l1' (no <inertial>); kinematic quantities (Jacobian, SVD, manipulability, null "
        "space, self-motion, IK, collision) are served: add an <inertial> with mass, centre of "
        "mass and inertia to each of these links"
    )


def test_no_inertials_at_all(tmp_path: Path) -> None:
    root = urdf_root("arm7")
    for link in root.findall("link"):
        for inertial in link.findall("inertial"):
            link.remove(inertial)
    arm = rd.load(write(root, tmp_path / "arm7.urdf"), frame="ee")
    reference = rd.load(MODELS / "arm7.urdf", frame="ee")
    assert arm.missing_inertia == tuple(f"link{i}" for i in range(1, 8))
    for q in random_poses(arm, 10, seed=2):
        np.testing.assert_allclose(arm.jacobian(q, "pinocchio"), reference.jacobian(q), atol=1e-14)
    assert crosscheck(arm, random_poses(arm, 10, seed=2)).ok
    with pytest.raises(rd.MissingInertiaError, match="gravity needs the inertia"):
        arm.gravity(np.zeros(arm.nq))


def test_inertial_on_a_fixed_child_is_enough() -> None:
    """A moving link whose mass sits on a link fixed to it is fine (both engines fuse).

    link4 keeps its collision geom: MuJoCo's default would give it a mass from that geom
    (0.609 kg, measured), Pinocchio none; the library reads it as massless in both.
    """
    root = urdf_root("arm7")
    split_link(root, "link4")
    link4 = element(root, "link", "link4")
    link4.remove(link4.find("inertial"))  # type: ignore[arg-type]
    arm = rd.load_string(ET.tostring(root, encoding="unicode"), frame="ee")
    assert element(root, "link", "link4").find("collision") is not None
    assert crosscheck(arm, random_poses(arm, 20, seed=1)).ok
    half = rd.load(MODELS / "arm7.urdf", frame="ee").mj_model.body("link4").mass[0] / 2
    assert arm.mj_model.body("link4").mass[0] == 0.0
    assert arm.mj_model.body("link4_extra").mass[0] == half


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        (
            lambda t: t.replace('type="revolute"', 'type="floating"', 1),
            # Below a link that is not the world: MuJoCo itself refuses the file.
            "MuJoCo could not compile the URDF <string>: Error: free joint can only be used on "
            "top level\nElement name 'l1', id 2",
        ),
        (
            lambda t: t.replace('type="revolute"', 'type="planar"', 1),
            "unsupported feature: planar joint on the arm's chain (joint 'j1' in <string>): "
            "the arm is a chain of revolute and prismatic joints; a planar base is held where "
            "the file puts it when the arm starts below it (base='l1')",
        ),
        (
            lambda t: t.replace('type="revolute"', 'type="hinge"', 1),
            "URDF <string>: joint 'j1' has type 'hinge'; valid URDF joint types: "
            "['revolute', 'continuous', 'prismatic', 'fixed', 'floating', 'planar']",
        ),
        (
            lambda t: t.replace('lower="-1"', 'lower="nan"'),
            "URDF <string>: <limit lower='nan'> must be a finite number",
        ),
        (
            lambda t: t.replace('<axis xyz="0 1 0"/>', '<axis xyz="0 1"/>'),
            "URDF <string>: <axis xyz='0 1'> must be 3 finite numbers",
        ),
        (
            lambda t: t.replace('<origin xyz="0 0 0.1"/><axis', '<origin xyz="inf 0 0.1"/><axis'),
            "URDF <string>: <origin xyz='inf 0 0.1'> must be 3 finite numbers",
        ),
        (
            lambda t: t.replace('<mass value="1"/>', '<mass value="-1"/>'),
            "URDF <string>: link 'l1' has mass -1 [kg]; a mass must be >= 0",
        ),
        (
            lambda t: t.replace('name="j1"', 'name="universe"'),
            "unsupported feature: joint named 'universe' (joint 'universe' in <string>): "
            "Pinocchio reserves the name for its world joint and frame; rename it",
        ),
        (
            lambda t: t.replace('<link name="base"/>', '<link name="base"/><link name="stray"/>'),
            "URDF <string>: the links must form one tree with one root; "
            "roots found: ['base', 'stray']",
        ),
        (
            lambda t: t.replace('<child link="tool"/>', '<child link="tol"/>'),
            "unknown link 'tol'; valid link names: ['base', 'l1', 'tool']",
        ),
    ],
)
def test_bad_urdf(change: object, expected: str) -> None:
    with pytest.raises(rd.RedundancyError) as err:
        rd.load_string(change(tiny_urdf()), frame="tool")  # type: ignore[operator]
    assert str(err.value) == expected


def test_mimic_joint_on_the_arm_is_served_as_a_follower() -> None:
    # Once refused: joint7 mimicking joint6 is now a follower, the arm's coordinates joint1-6.
    root = urdf_root("panda")
    ET.SubElement(element(root, "joint", "joint7"), "mimic", joint="joint6", multiplier="1")
    arm = rd.load_string(ET.tostring(root, encoding="unicode"), frame="ee")
    assert arm.joint_names == tuple(f"joint{i}" for i in range(1, 7))
    assert arm.chain_joint_names[-1] == "joint7"
    assert arm.followers == {"joint7": "joint equality joint7 = 1 joint6"}
    q = rd.random_poses(arm, 1, seed=0)[0]
    assert arm.chain_pose(q)[-1] == q[-1]


@pytest.mark.parametrize(
    "text",
    [
        '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:property name="l" value="0.3"/><link name="base"/></robot>',
        '<robot name="r"><link name="base"><inertial><mass value="${m}"/></inertial></link></robot>',
    ],
)
@pytest.mark.parametrize(
    ("name", "command"),
    [
        ("arm.urdf.xacro", "`xacro arm.urdf.xacro > arm.urdf`"),
        ("fr3.urdf", "`xacro fr3.urdf > fr3_expanded.urdf`"),  # published under a .urdf name
    ],
)
def test_xacro_is_refused(tmp_path: Path, text: str, name: str, command: str) -> None:
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(rd.UnsupportedFeatureError) as err:
        rd.load(path, frame="base")
    assert "xacro macros" in str(err.value)
    assert str(err.value).endswith(
        f"this is a xacro file, not URDF; expand it first ({command}) and load the result"
    )


def test_tool_name_of_a_link_and_a_fixed_joint_is_one_frame() -> None:
    """Z1's ``gripperStator``: a link and the fixed joint to it share the name and the place."""
    text = tiny_urdf().replace('name="tool_joint"', 'name="tool"')
    arm = rd.load_string(text, frame="tool")
    plain = rd.load_string(tiny_urdf(), frame="tool")
    q = np.array([0.3])
    assert np.array_equal(arm.jacobian(q, "pinocchio"), plain.jacobian(q, "pinocchio"))
    assert crosscheck(arm, q).ok


def test_no_engine_abort_on_bad_urdf(tmp_path: Path) -> None:
    """Malformed variants end in the library's error, in a subprocess (an abort would show)."""
    cases = [
        tiny_urdf().replace('lower="-1"', 'lower="nan"'),
        tiny_urdf().replace('lower="-1"', 'lower="2"'),
        tiny_urdf().replace('<origin xyz="0 0 0.1"/><axis', '<origin xyz="inf 0 0.1"/><axis'),
        tiny_urdf().replace('<mass value="1"/>', '<mass value="-1"/>'),
        tiny_urdf().replace('izz="0.002"', 'izz="-0.002"'),
        tiny_urdf().replace('<axis xyz="0 1 0"/>', '<axis xyz="0 0 0"/>'),
        tiny_urdf().replace('<parent link="base"/>', ""),
        "<robot name='empty'/>",
    ]
    script = (
        "import sys, redundancy as rd\n"
        "try:\n"
        "    rd.load_string(open(sys.argv[1]).read(), frame='tool')\n"
        "    print('loaded')\n"
        "except rd.RedundancyError as e:\n"
        "    print('error', type(e).__name__)\n"
    )
    for i, text in enumerate(cases):
        path = tmp_path / f"case{i}.urdf"
        path.write_text(text)
        run = subprocess.run(
            [sys.executable, "-c", script, str(path)], capture_output=True, text=True, timeout=60
        )
        assert run.returncode == 0, (i, run.stderr[-2000:])
        assert run.stdout.startswith(("error", "loaded")), (i, run.stdout)


# -- fuzz: hostile URDFs end in the library's error or in agreement ---------------------------
URDF_NAMES = ("universe", "world", "ee", "j1", "link1", "base", "é")


@st.composite
def urdf_mutants(draw: st.DrawFn) -> tuple[bytes, str]:
    """arm7.urdf with one to three structural or value mutations, in some encoding."""
    root = urdf_root("arm7")
    done = []
    for _ in range(draw(st.integers(1, 3))):
        elements = [el for el in root.iter() if el is not root]
        el = draw(st.sampled_from(elements))
        kind = draw(st.sampled_from(["value", "name", "delete", "duplicate", "type"]))
        parent = next(p for p in root.iter() if el in list(p))
        if kind == "value" and el.attrib:
            attr = draw(st.sampled_from(sorted(el.attrib)))
            el.set(attr, draw(VALUES))
            done.append(f"<{el.tag} {attr}={el.get(attr)!r}>")
        elif kind == "name" and el.get("name") is not None:
            el.set("name", draw(st.sampled_from(URDF_NAMES)))
            done.append(f"<{el.tag}> renamed {el.get('name')!r}")
        elif kind == "delete":
            parent.remove(el)
            done.append(f"<{el.tag} {el.attrib}> deleted")
        elif kind == "duplicate":
            parent.append(ET.fromstring(ET.tostring(el)))
            done.append(f"<{el.tag} {el.attrib}> duplicated")
        elif kind == "type" and el.tag == "joint":
            el.set("type", draw(st.sampled_from(["continuous", "prismatic", "fixed", "planar"])))
            done.append(f"joint {el.get('name')!r} made {el.get('type')}")
    encoding = draw(st.sampled_from(["utf-8", "utf-16", "latin-1"]))
    text = ET.tostring(root, encoding="unicode")
    if encoding == "latin-1" and not all(ord(c) < 256 for c in text):
        encoding = "utf-8"
    head = f'<?xml version="1.0" encoding="{encoding}"?>\n'
    return (head + text).encode(encoding), f"{'; '.join(done)} ({encoding})"


@pytest.fixture(scope="module")
def fuzz_worker() -> Iterator[Worker]:
    """The guarded worker process of test_fuzz.py, closed when this module's tests end."""
    worker = Worker()
    yield worker
    worker.close()


@settings(
    max_examples=300 if settings().max_examples >= 1000 else 25,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(mutant=urdf_mutants())
def test_fuzzed_urdf(
    mutant: tuple[bytes, str], fuzz_worker: Worker, tmp_path_factory: pytest.TempPathFactory
) -> None:
    """Each mutant loads in a guarded worker: an engine abort fails the example, not pytest."""
    data, what = mutant
    path = tmp_path_factory.mktemp("urdf_fuzz") / "arm7.urdf"
    path.write_bytes(data)
    result = fuzz_worker.load(path, frame="ee")
    assert result["status"] in ("refused", "loaded"), f"{what}: {result}"
    if result["status"] == "refused":
        assert result["message"], what
    elif result["equivalent"] and result["finite"]:
        assert result["agree"], f"{what}:\n" + "\n".join(result["lines"])  # type: ignore[arg-type]


def _tree_urdf(links: list[str], joints: list[tuple[str, str, str]]) -> str:
    inertial = '<inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>'
    body = "".join(f'<link name="{n}">{inertial}</link>' for n in links)
    body += "".join(
        f'<joint name="{j}" type="revolute"><parent link="{p}"/><child link="{c}"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        for j, p, c in joints
    )
    return f'<robot name="r">{body}</robot>'


@pytest.mark.parametrize(
    ("links", "joints", "message"),
    [
        (
            ["base", "a", "a"],
            [("j1", "base", "a")],
            "URDF <string>: link names must be unique; repeated: ['a']",
        ),
        (
            ["base", "a", "b"],
            [("j1", "base", "a"), ("j1", "a", "b")],
            "URDF <string>: joint names must be unique; repeated: 'j1'",
        ),
        (
            ["base", "a", "b"],
            [("j1", "base", "a"), ("j2", "a", "b"), ("j3", "b", "a")],
            "URDF <string>: the links must form one tree; link 'a' is the child of several "
            "joints ['j1', 'j3'] (a loop)",
        ),
    ],
    ids=["duplicate link", "duplicate joint", "loop"],
)
def test_urdf_loops_and_duplicates_get_the_librarys_message(
    links: list[str],
    joints: list[tuple[str, str, str]],
    message: str,
    capfd: pytest.CaptureFixture[str],
) -> None:
    """The parsers' own text, and C++ output on stderr, before."""
    with pytest.raises(rd.ModelError) as err:
        rd.load_string(_tree_urdf(links, joints), frame="b" if "b" in links else "a")
    assert str(err.value) == message
    out, errtext = capfd.readouterr()
    assert (out, errtext) == ("", "")

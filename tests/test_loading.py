"""Reading model files: bytes decoded as XML says, paths versus text, the loader's errors."""

from __future__ import annotations

import codecs
import copy
import os
import pickle
import re
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

import redundancy as rd
from redundancy.arm import random_poses
from redundancy.model.loading import decode_xml, model_format

from .models import BLOCK, DEFAULTS, TWO_LINKS, write_two_links

MODELS = Path(rd.model_path("arm7")).parent
# Names and comments outside ASCII: a file in another encoding must reach both engines intact.
ACCENTED = ('<mujoco model="arm7">', '<mujoco model="arm7">\n  <!-- bras à sept axes -->')


def _arm7_text(kind: str) -> str:
    text = (MODELS / f"arm7.{kind}").read_text(encoding="utf-8")
    text = text.replace(*ACCENTED) if kind == "xml" else text.replace("<!--", "<!-- à", 1)
    assert not text.isascii()
    return text.replace('<?xml version="1.0"?>\n', "")


@pytest.mark.parametrize("kind", ["xml", "urdf"])
@pytest.mark.parametrize(
    ("encoding", "declared", "bom"),
    [
        ("utf-16", "UTF-16", b""),  # Python writes the BOM itself
        ("utf-16-le", "UTF-16", b""),  # no BOM: detected from "<\0"
        ("utf-16-be", "UTF-16", codecs.BOM_UTF16_BE),
        ("latin-1", "ISO-8859-1", b""),
        ("cp1252", "windows-1252", b""),
        ("utf-8", "UTF-8", codecs.BOM_UTF8),
    ],
)
def test_encodings_load_in_both_engines(
    tmp_path: Path, kind: str, encoding: str, declared: str, bom: bytes
) -> None:
    text = f'<?xml version="1.0" encoding="{declared}"?>\n' + _arm7_text(kind)
    path = tmp_path / f"arm7.{kind}"
    path.write_bytes(bom + text.encode(encoding))
    arm = rd.load(path, frame="ee")
    reference = rd.load(MODELS / f"arm7.{kind}", frame="ee")
    for q in random_poses(arm, 5, seed=2):
        for engine in ("mujoco", "pinocchio"):
            np.testing.assert_array_equal(
                arm.mass_matrix(q, engine=engine), reference.mass_matrix(q, engine=engine)
            )
            np.testing.assert_array_equal(
                arm.jacobian(q, engine=engine), reference.jacobian(q, engine=engine)
            )
    assert model_format(arm) == ("URDF" if kind == "urdf" else "MJCF")


def test_non_ascii_names_reach_both_engines(tmp_path: Path) -> None:
    text = '<?xml version="1.0" encoding="ISO-8859-1"?>\n' + _arm7_text("xml").replace(
        'name="ee"', 'name="outil_é"'
    )
    path = tmp_path / "arm7_latin1.xml"
    path.write_bytes(text.encode("latin-1"))
    arm = rd.load(path, frame="outil_é")
    assert arm.frame == "outil_é"
    q = arm.keyframe("home")
    np.testing.assert_allclose(arm.site_pose(q)[0], arm.site_pose(q, "pinocchio")[0], atol=1e-12)


def test_bytes_not_in_the_declared_encoding(tmp_path: Path) -> None:
    path = tmp_path / "bad.xml"
    path.write_bytes(_arm7_text("xml").encode("latin-1"))  # no declaration: UTF-8 assumed
    with pytest.raises(rd.ModelError) as err:
        rd.load(path)
    assert str(err.value).startswith(f"{path}: not valid utf-8 text: 'utf-8' codec can't decode")


def test_unknown_declared_encoding(tmp_path: Path) -> None:
    path = tmp_path / "bad.xml"
    path.write_bytes(b'<?xml version="1.0" encoding="klingon-8"?>\n<mujoco/>')
    with pytest.raises(rd.ModelError) as err:
        rd.load(path)
    assert str(err.value) == f"{path}: unknown encoding 'klingon-8' in the XML declaration"


def test_decode_xml_reports_whether_bytes_were_utf8() -> None:
    assert decode_xml(b'<?xml version="1.0" encoding="utf-8"?><a/>', "x") == ("<a/>", True)
    assert decode_xml("<a>é</a>".encode("utf-16"), "x") == ("<a>é</a>", False)
    assert decode_xml(codecs.BOM_UTF8 + b"<a/>", "x") == ("<a/>", False)  # the BOM goes


@pytest.mark.parametrize("kind", ["xml", "urdf"])
def test_xml_text_where_a_path_is_expected(kind: str) -> None:
    text = (MODELS / f"arm7.{kind}").read_text()
    with pytest.raises(rd.ModelError) as err:
        rd.load(text)
    assert str(err.value).startswith("load() takes a file path, and this looks like XML text (")
    assert str(err.value).endswith("...); use load_string() for model text")
    assert rd.load_string(text, frame="ee").nq == 7  # what the message suggests works


def test_bytes_where_a_path_is_expected() -> None:
    data = (MODELS / "arm7.urdf").read_bytes()
    with pytest.raises(rd.ModelError) as err:
        rd.load(data)  # type: ignore[arg-type]
    assert str(err.value) == "load() takes a file path; for XML text or bytes use load_string()"
    assert rd.load_string(data, frame="ee").nq == 7


@pytest.mark.parametrize(
    ("path", "message"),
    [
        ("/nonexistent/arm.xml", "model file not found: '/nonexistent/arm.xml'"),
        (".", "model path is a directory, not a file: '.'"),
    ],
)
def test_path_errors(path: str, message: str) -> None:
    with pytest.raises(rd.ModelError) as err:
        rd.load(path)
    assert str(err.value) == message


def test_path_of_wrong_type() -> None:
    with pytest.raises(rd.ModelError, match="load\\(\\) takes a file path, got int"):
        rd.load(3)  # type: ignore[arg-type]
    with pytest.raises(rd.ModelError, match="model text must be a str or bytes, got list"):
        rd.load_string(["<mujoco/>"])  # type: ignore[arg-type]


def test_urdf_without_inertials_is_the_librarys_error() -> None:
    """Not MuJoCo's mass error; kinematics served, dynamics the library's
    error naming the link."""
    text = (
        '<robot name="r"><link name="base"/><link name="l1"/>'
        '<joint name="j1" type="continuous"><parent link="base"/><child link="l1"/></joint>'
        "</robot>"
    )
    arm = rd.load_string(text, frame="l1")
    assert arm.jacobian([0.3]).shape == (6, 1)
    with pytest.raises(rd.MissingInertiaError, match="the model gives none for 'l1'"):
        arm.gravity([0.3])


def test_mjcf_site_and_frame() -> None:
    by_frame = rd.load(MODELS / "arm7.xml", frame="ee")
    assert by_frame.frame == "ee"
    with pytest.raises(
        rd.UnknownNameError,
        match="unknown site or body 'tool0'; valid site or body names: \\['ee', ",
    ):
        rd.load(MODELS / "arm7.xml", frame="tool0")


def test_an_existing_file_whose_name_starts_with_a_bracket_loads(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """'<arm7>.xml' was once refused as XML text; only a path to nothing can be text."""
    path = tmp_path / "<arm7>.xml"
    path.write_bytes(rd.model_path("arm7").read_bytes())
    assert rd.load(path, frame="ee").nq == 7
    assert rd.load(str(path), frame="ee").nq == 7
    with pytest.raises(rd.ModelError, match="looks like XML text"):
        rd.load("<arm7>.xml")  # no such file here: still the hint to load_string()
    monkeypatch.chdir(tmp_path)  # the name as typed in the file's folder (the case reported)
    assert rd.load("<arm7>.xml", frame="ee").nq == 7


def _urdf(*leaves: str) -> str:
    """A URDF whose base carries one revolute joint per leaf link named."""
    inertial = (
        '<inertial><mass value="1"/>'
        '<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>'
    )
    links = "".join(f'<link name="{n}">{inertial}</link>' for n in leaves)
    joints = "".join(
        f'<joint name="j_{n}" type="revolute"><parent link="base"/><child link="{n}"/>'
        f'<origin xyz="{0.2 * i} 0 0"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="10" velocity="1"/></joint>'
        for i, n in enumerate(leaves)
    )
    return f'<robot name="y"><link name="base"/>{links}{joints}</robot>'


def test_no_frame_takes_the_one_chain_end() -> None:
    """A model with one chain end needs no tool frame, in Python as on the command line."""
    arm = rd.load_string(_urdf("a"))
    assert (arm.frame, arm.joint_names) == ("a", ("j_a",))
    xarm = rd.load(rd.example_robot_data("xarm_description/urdf/xarm7.urdf"))
    assert (xarm.frame, xarm.nq) == ("link_eef", 7)


def test_no_frame_and_several_chain_ends_lists_them() -> None:
    with pytest.raises(
        rd.ModelError,
        match=r"^'<string>' has 2 chain ends: 'a', 'b'; name the tool frame \(--frame NAME on "
        r"the command line, frame=NAME in Python\)$",
    ):
        rd.load_string(_urdf("a", "b"))
    # A frame named "ee" among several ends is taken (the bundled models' tool site).
    arm = rd.load_string(_urdf("a", "ee"))
    assert (arm.frame, arm.joint_names) == ("ee", ("j_ee",))
    assert rd.load(rd.model_path("panda")).frame == "ee"


def test_a_scene_that_includes_its_robot_defaults_to_the_robots_chain_end(
    tmp_path: Path,
) -> None:
    """Menagerie's pattern: scene.xml holds the floor and light and includes the robot file;
    the chain end is in the included file."""
    (tmp_path / "arm7.xml").write_bytes(rd.model_path("arm7").read_bytes())
    (tmp_path / "scene.xml").write_text(
        '<mujoco model="scene"><include file="arm7.xml"/>'
        '<worldbody><light pos="0 0 3"/></worldbody></mujoco>',
        encoding="utf-8",
    )
    arm = rd.load(tmp_path / "scene.xml")
    assert (arm.frame, arm.nq) == ("ee", 7)


def test_a_second_worldbody_is_merged_for_pinocchio() -> None:
    """MuJoCo reads several <worldbody> sections as one world; Pinocchio's parser would read
    the first again for each: it is given them merged, in order (same bodies, same ids)."""
    xml = (
        rd.model_path("arm7")
        .read_text(encoding="utf-8")
        .replace(
            "</mujoco>",
            '<worldbody><geom name="rug" type="plane" size="2 2 0.1"/>'
            '<body name="table" pos="1 0 0.2"><geom type="box" size="0.3 0.3 0.2"/></body>'
            "</worldbody></mujoco>",
        )
    )
    arm = rd.load_string(xml, frame="ee")
    assert arm.nq == 7 and arm.mj_model.body("table").id == arm.mj_model.nbody - 1
    names = {(a.what, a.name) for a in arm.set_aside}
    assert ("worldbody", "2 <worldbody> sections") in names
    assert ("root body", "table") in names  # another tree: MuJoCo keeps it for collisions
    assert rd.crosscheck(arm, rd.random_poses(arm, 5, seed=3)).ok


# -- an Arm is what was loaded: copies and pickles rebuild it from the bytes read -----------

COPIES = {
    "copy": copy.copy,
    "deepcopy": copy.deepcopy,
    "pickle": lambda arm: pickle.loads(pickle.dumps(arm)),
}


def _numbers(arm: rd.Arm) -> list[np.ndarray]:
    q = np.array([0.3, -0.7])
    return [arm.gravity(q), arm.mass_matrix(q), arm.mj_model.mesh_vert.copy()]


def _same(a: list[np.ndarray], b: list[np.ndarray]) -> bool:
    return all(x.shape == y.shape and x.tobytes() == y.tobytes() for x, y in zip(a, b, strict=True))


@pytest.mark.parametrize("how", list(COPIES))
def test_a_copy_after_chdir_is_the_users_file_not_the_bundled_one_of_its_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, how: str
) -> None:
    heavier = re.sub(
        r'mass="([0-9.]+)"',
        lambda m: f'mass="{2 * float(m.group(1))!r}"',
        rd.model_path("panda").read_text(encoding="utf-8"),
    )
    (tmp_path / "panda.xml").write_text(heavier, encoding="utf-8")
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path)
    arm = rd.load("panda.xml", frame="ee")
    monkeypatch.chdir(tmp_path / "elsewhere")
    twin = COPIES[how](arm)
    q = arm.keyframe("home")
    assert twin.source == "panda.xml"
    assert twin.gravity(q).tobytes() == arm.gravity(q).tobytes()
    bundled = rd.load("panda", frame="ee").gravity(q)
    assert np.abs(arm.gravity(q) - bundled).max() > 1.0  # the user's panda is another robot


@pytest.mark.parametrize("how", list(COPIES))
@pytest.mark.parametrize("edited", ["model", "include", "mesh", "removed"])
def test_a_copy_is_the_robot_loaded_whatever_became_of_its_files(
    tmp_path: Path, how: str, edited: str
) -> None:
    path = write_two_links(tmp_path)
    arm = rd.load(path)
    before = _numbers(arm)
    if edited == "model":
        path.write_text(TWO_LINKS.format(meshdir="meshes", mass=7.0))
    elif edited == "include":
        (tmp_path / "defaults.xml").write_text(DEFAULTS.format(armature=0.9))
    elif edited == "mesh":
        (tmp_path / "meshes" / "block.obj").write_text(BLOCK.replace("0.4 ", "0.9 "))
    else:
        shutil.rmtree(tmp_path)
    if edited != "removed":
        assert not _same(_numbers(rd.load(path)), before)  # the edit changes the robot
    twin = COPIES[how](arm)
    assert _same(_numbers(twin), before)
    assert _same(_numbers(COPIES[how](twin)), before)  # and so does a copy of the copy


def test_the_recipe_names_every_file_read_absolutely(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    write_two_links(tmp_path)
    monkeypatch.chdir(tmp_path)
    recipe = rd.load("two.xml")._recipe[1][0]
    assert [p for p, _ in recipe.files] == [
        str(tmp_path / "two.xml"),
        str(tmp_path / "defaults.xml"),
        str(tmp_path / "meshes" / "block.obj"),
    ]
    assert recipe.model == str(tmp_path / "two.xml")
    # The identity covers the options: the same file with another tool is another arm.
    assert rd.load("two.xml", frame="l2")._recipe[1][0].digest != recipe.digest
    assert rd.load("two.xml")._recipe[1][0].digest == recipe.digest


@pytest.mark.parametrize("how", list(COPIES))
@pytest.mark.parametrize("fate", ["changed", "removed"])
def test_a_copy_fails_naming_a_file_it_cannot_rebuild_from_what_it_carries(
    tmp_path: Path, how: str, fate: str
) -> None:
    # A mesh folder given by absolute path is read where it is, even by a rebuild from the
    # bytes the arm carries: if that mesh changed or went, the robot cannot be rebuilt.
    meshes = tmp_path / "shared" / "meshes"
    path = write_two_links(tmp_path / "robot", meshdir=str(meshes))
    arm = rd.load(path)
    mesh = meshes / "block.obj"
    if fate == "changed":
        mesh.write_text(BLOCK.replace("0.4 ", "0.9 "))
        why = f"the file {str(mesh)!r} changed since the arm was loaded"
    else:
        mesh.unlink()
        why = f"cannot read {str(mesh)!r} (No such file or directory)"
    with pytest.raises(
        rd.ModelError,
        match="^"
        + re.escape(f"cannot rebuild the arm of {str(path)!r} as it was loaded: {why}")
        + "$",
    ):
        COPIES[how](arm)


def test_a_urdf_copy_keeps_the_meshes_and_srdf_it_was_loaded_with(tmp_path: Path) -> None:
    (tmp_path / "block.obj").write_text(BLOCK)
    urdf = tmp_path / "two.urdf"
    urdf.write_text(
        """<robot name="two">
  <link name="base"/>
  <link name="l1">
    <inertial><origin xyz="0.25 0 0"/><mass value="2"/>
      <inertia ixx="0.01" iyy="0.05" izz="0.05" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><mesh filename="block.obj"/></geometry></collision>
  </link>
  <link name="l2">
    <inertial><origin xyz="0.2 0 0"/><mass value="1"/>
      <inertia ixx="0.005" iyy="0.02" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><mesh filename="block.obj"/></geometry></collision>
  </link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.5 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
</robot>"""
    )
    srdf = tmp_path / "two.srdf"
    srdf.write_text('<robot name="two"><disable_collisions link1="base" link2="l2"/></robot>')
    arm = rd.load(urdf, frame="l2", disabled_collisions=srdf)
    files = [p for p, _ in arm._recipe[1][0].files]
    assert files == [str(urdf), str(srdf), str(tmp_path / "block.obj")]
    before = [*_numbers(arm), arm.mj_model.exclude_signature.copy()]
    (tmp_path / "block.obj").write_text(BLOCK.replace("0.4 ", "0.9 "))
    srdf.unlink()
    twin = pickle.loads(pickle.dumps(arm))
    assert _same([*_numbers(twin), twin.mj_model.exclude_signature.copy()], before)


def test_a_reload_compiles_a_mesh_edited_within_the_same_second(tmp_path: Path) -> None:
    # MuJoCo's asset cache knows a file by its name and modification time in whole
    # seconds: read by MuJoCo, the edited mesh would compile as it was before the edit.
    path = write_two_links(tmp_path)
    first = rd.load(path).mj_model.mesh_vert.copy()
    mesh = tmp_path / "meshes" / "block.obj"
    stamp = mesh.stat()
    mesh.write_text(BLOCK.replace("0.4 ", "0.9 "))
    os.utime(mesh, ns=(stamp.st_atime_ns, stamp.st_mtime_ns))  # an edit within the second
    again = rd.load(path).mj_model.mesh_vert
    assert np.ptp(first, axis=0).max() == pytest.approx(0.4, rel=1e-6)
    assert np.ptp(again, axis=0).max() == pytest.approx(0.9, rel=1e-6)


def test_a_copy_of_urdf_text_keeps_the_meshes_it_found_in_the_working_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    text = (MODELS / "arm7.urdf").read_text(encoding="utf-8")
    link = '<link name="link3">'
    assert link in text
    collision = '<collision><geometry><mesh filename="block.obj"/></geometry></collision>'
    text = text.replace(link, link + collision, 1)
    (tmp_path / "block.obj").write_text(BLOCK)
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path)
    arm = rd.load_string(text, frame="ee")
    monkeypatch.chdir(tmp_path / "elsewhere")
    twin = copy.deepcopy(arm)
    assert twin.mj_model.mesh_vert.tobytes() == arm.mj_model.mesh_vert.tobytes()
    assert twin.mj_model.nmesh == 1


def test_site_is_a_deprecated_name_of_frame(tmp_path: Path) -> None:
    """``site=`` still names the tool frame, with a DeprecationWarning at the caller's line;
    ``frame=`` alone warns of nothing, and wins when both are given."""
    path = write_two_links(tmp_path)
    message = r"^site= is deprecated: name the tool frame with frame=$"
    with pytest.warns(DeprecationWarning, match=message) as seen:
        arm = rd.load(path, site="ee")
    assert arm.frame == "ee" and seen[0].filename == __file__
    text = rd.model_path("arm7").read_text()
    with pytest.warns(DeprecationWarning, match=message) as seen:
        assert rd.load_string(text, site="ee").frame == "ee"
    assert seen[0].filename == __file__
    with pytest.warns(DeprecationWarning, match=message):
        assert rd.load_string(text, frame="ee", site="link7").frame == "ee"
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        assert rd.load(path, frame="ee").frame == "ee"
        assert rd.load(path, "ee").frame == "ee"  # the second parameter is the frame


def test_arm_site_is_a_deprecated_name_of_frame(arm7: rd.Arm) -> None:
    assert arm7.frame == "ee" and "frame='ee'" in repr(arm7)
    with pytest.warns(DeprecationWarning, match=r"^Arm.site is deprecated: use Arm.frame$") as seen:
        assert arm7.site == "ee"
    assert seen[0].filename == __file__

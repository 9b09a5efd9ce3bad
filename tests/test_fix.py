"""``redundancy audit --fix OUT``: a copy that excludes the pairs in contact at every pose.

The MJCF case is the bundled Panda with its one ``<exclude>`` (link0 / link1, whose capsules
overlap at every joint-1 angle) removed: the fix must give back a file that MuJoCo compiles to
the published model, field by field. The URDF case is TALOS's left arm (example-robot-data),
whose arm_left_5_link / arm_left_7_link touch at every pose (`test_published`): the URDF is
copied as it is and an SRDF is written beside the copy, which the audit then applies.
"""

from __future__ import annotations

import difflib
import json
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
import pytest

import redundancy as rd
from redundancy.cli import main
from redundancy.reports import fix
from redundancy.reports.audit import audit

MODELS = Path(__file__).resolve().parents[1] / "models"
PANDA = MODELS / "panda.xml"
EXCLUDE = '    <exclude body1="link0" body2="link1"/>\n'
TALOS = "talos_data/robots/talos_left_arm.urdf"
TALOS_FRAME = "gripper_left_base_link"
TALOS_PAIR = ("arm_left_5_link", "arm_left_7_link")
POSES = "100"


def run(capsys, *args: str) -> tuple[int, dict, str]:
    """The audit with its JSON on stdout: status, document, stderr."""
    status = main(["audit", *args, "--poses", POSES, "--json", "-"])
    out = capsys.readouterr()
    return status, (json.loads(out.out) if out.out.strip() else {}), out.err


def planted_panda(folder: Path) -> Path:
    """The bundled Panda without its exclude: link0 / link1 then touch at every pose."""
    text = PANDA.read_text()
    assert text.count(EXCLUDE) == 1
    path = folder / "panda.xml"
    path.write_text(text.replace(EXCLUDE, ""))
    return path


def talos_tree(folder: Path) -> Path:
    """TALOS's left arm in a tree of its own: the URDF copied, its meshes linked.

    Its meshes are ``package://example-robot-data/robots/talos_data/meshes/...``, found from
    a folder above the URDF; the copy can be written beside the URDF without touching the
    installed package.
    """
    source = Path(rd.example_robot_data(TALOS))
    data = folder / "example-robot-data" / "robots" / "talos_data"
    (data / "robots").mkdir(parents=True)
    (data / "meshes").symlink_to(source.parents[1] / "meshes")
    urdf = data / "robots" / source.name
    shutil.copyfile(source, urdf)
    return urdf


def model_fields(model: mujoco.MjModel) -> dict[str, np.ndarray]:
    """Every array and number of MuJoCo's compiled model, by name."""
    out = {}
    for name in dir(model):
        if name.startswith("_"):
            continue
        value = getattr(model, name)
        if isinstance(value, int | float | np.ndarray | bytes):
            out[name] = np.asarray(value)
    for struct in ("opt", "stat"):  # the options and statistics, field by field
        s = getattr(model, struct)
        for name in dir(s):
            value = getattr(s, name)
            if not name.startswith("_") and isinstance(value, int | float | np.ndarray):
                out[f"{struct}.{name}"] = np.asarray(value)
    return out


def differing(a: mujoco.MjModel, b: mujoco.MjModel) -> set[str]:
    fa, fb = model_fields(a), model_fields(b)
    assert fa.keys() == fb.keys()
    return {k for k in fa if not np.array_equal(fa[k], fb[k])}


def inserted_lines(before: bytes, after: bytes) -> list[str]:
    """The lines ``after`` adds to ``before``; fails when it removes or changes any."""
    a, b = before.decode().splitlines(), after.decode().splitlines()
    ops = difflib.SequenceMatcher(None, a, b, autojunk=False).get_opcodes()
    assert {op for op, *_ in ops} <= {"equal", "insert"}, ops
    return [line for op, _, _, j1, j2 in ops if op == "insert" for line in b[j1:j2]]


def without(tree: ET.Element, tag: str) -> ET.Element:
    """A copy of an XML tree without its root's children of ``tag`` that the fix adds."""
    copy = ET.fromstring(ET.tostring(tree))
    for child in list(copy):
        if child.tag == tag:
            copy.remove(child)
    return copy


def canonical(tree: ET.Element) -> str:
    return ET.canonicalize(ET.tostring(tree), strip_text=True)


# -- MJCF ------------------------------------------------------------------------------------------
def test_the_fixed_mjcf_compiles_to_the_published_model_and_audits_clean(tmp_path, capsys):
    planted = planted_panda(tmp_path)
    out = tmp_path / "fixed" / "panda.xml"
    out.parent.mkdir()
    status, data, err = run(capsys, str(planted), "--fix", str(out))
    assert status == 1  # the planted defect: keyframe 'home' in self-contact
    touching = data["collision"]["touching_everywhere"]
    assert [t["bodies"] for t in touching] == [["link0", "link1"]]
    assert f"fix of {planted}: wrote {out}: excludes link0 / link1" in " ".join(err.split())
    # MuJoCo compiles the fix to the published Panda, every field and option the same...
    assert (
        differing(mujoco.MjModel.from_xml_path(str(PANDA)), mujoco.MjModel.from_xml_path(str(out)))
        == set()
    )
    # ...and the planted file differs from it in the excludes (and the names' buffer) only.
    changed = differing(
        mujoco.MjModel.from_xml_path(str(planted)), mujoco.MjModel.from_xml_path(str(out))
    )
    assert {"nexclude", "exclude_signature"} <= changed
    assert {c for c in changed if "exclude" not in c and "name" not in c} <= {
        "signature",
        "nbuffer",
    }
    # The file: the planted one with lines inserted, a <contact> of one commented exclude.
    added = inserted_lines(planted.read_bytes(), out.read_bytes())
    assert added[0] == "  <contact>" and added[-1] == "  </contact>"
    assert added[-2] == '    <exclude body1="link0" body2="link1"/>'
    assert added[1].startswith("    <!-- link0 / link1: in contact in 100 of 100 random poses")
    assert added[2].endswith("every pose: excluded by its fix -->")
    assert canonical(without(ET.parse(out).getroot(), "contact")) == canonical(
        without(ET.parse(planted).getroot(), "contact")
    )
    # Its audit: no pair in contact everywhere, and the keyframe is no longer in contact.
    status, fixed, _ = run(capsys, str(out))
    assert fixed["collision"]["touching_everywhere"] == []
    assert not [n for n in fixed["notes"] if n["rule"] == "pair-always-touching"]
    assert fixed["collision"]["n_pairs"] == data["collision"]["n_pairs"] - 1
    assert status == 0 and fixed["findings"] == []


def test_a_model_with_nothing_to_exclude_is_copied_as_it_is(tmp_path, capsys):
    out = tmp_path / "arm7.xml"
    status, data, err = run(capsys, str(MODELS / "arm7.xml"), "--fix", str(out))
    assert status == 1 and data["collision"]["touching_everywhere"] == []
    assert out.read_bytes() == (MODELS / "arm7.xml").read_bytes()
    assert "a copy: no pair is in contact at every pose" in " ".join(err.split())


def test_an_explicit_pair_is_left_with_the_reason(tmp_path):
    # A <contact><pair> bypasses every filter, exclusions too: the fix cannot remove it.
    xml = """<mujoco>
      <worldbody>
        <body name="a">
          <joint name="j1" type="hinge" axis="0 0 1"/>
          <geom name="ga" type="capsule" size="0.05" fromto="0 0 0 0.3 0 0" mass="1"/>
          <body name="b" pos="0.3 0 0">
            <joint name="j2" type="hinge" axis="0 0 1"/>
            <geom name="gb" type="capsule" size="0.05" fromto="0 0 0 0.3 0 0" mass="1"/>
            <site name="ee" pos="0.3 0 0"/>
          </body>
        </body>
      </worldbody>
      <contact><pair geom1="ga" geom2="gb"/></contact>
    </mujoco>"""
    path = tmp_path / "pair.xml"
    path.write_text(xml)
    arm = rd.load(path)
    report = audit(arm, n_poses=50, seed=0)
    assert [p.pair.label for p in report.sections.touching.pairs] == ["ga / gb"]
    excluded, left = fix.exclusions(report, arm)
    assert excluded == []
    assert left == [("ga / gb", "a <contact><pair> of the file, which no exclude removes")]
    written = fix.write_fix(arm, report, tmp_path / "out.xml")
    assert written.left == tuple(left) and written.excluded == ()
    assert (tmp_path / "out.xml").read_bytes() == path.read_bytes()


# -- URDF ------------------------------------------------------------------------------------------
def test_the_fixed_urdf_is_the_urdf_and_an_srdf_beside_it_which_its_audit_applies(tmp_path, capsys):
    urdf = talos_tree(tmp_path)
    out = urdf.with_name("fixed.urdf")
    status, data, err = run(capsys, str(urdf), "--frame", TALOS_FRAME, "--fix", str(out))
    assert status == 1  # TALOS's gravity finding (test_published), which no fix touches
    a, b = TALOS_PAIR
    assert [t["bodies"] for t in data["collision"]["touching_everywhere"]] == [[a, b]]
    srdf = out.with_suffix(".srdf")
    assert f"wrote {out} and {srdf}: excludes {a} / {b}" in " ".join(err.split())
    assert out.read_bytes() == urdf.read_bytes()  # the URDF itself: nothing changed
    root = ET.parse(srdf).getroot()
    assert root.tag == "robot" and root.get("name") == ET.parse(urdf).getroot().get("name")
    assert [(e.get("link1"), e.get("link2"), e.get("reason")) for e in root] == [(a, b, "Always")]
    assert "in contact in 100 of 100 random poses" in srdf.read_text()
    # Audited as given: the SRDF beside it is applied, and says so.
    status, fixed, _ = run(capsys, str(out), "--frame", TALOS_FRAME)
    assert fixed["collision"]["touching_everywhere"] == []
    assert fixed["collision"]["n_pairs"] == data["collision"]["n_pairs"] - 1
    (note,) = [n for n in fixed["notes"] if n["rule"] == "srdf-beside"]
    assert note["file"] == str(srdf) and note["severity"] == "note"
    assert not [n for n in fixed["notes"] if n["rule"] == "pair-always-touching"]
    assert [f["rule"] for f in fixed["findings"]] == [f["rule"] for f in data["findings"]]


def test_the_srdf_the_audit_was_given_is_copied_with_the_pair_added(tmp_path, capsys):
    urdf = talos_tree(tmp_path)
    given = tmp_path / "given.srdf"
    given.write_text(
        '<?xml version="1.0"?>\n<robot name="talos">\n'
        '  <disable_collisions link1="arm_left_1_link" link2="arm_left_3_link" reason="Never"/>\n'
        "</robot>\n"
    )
    out = urdf.with_name("fixed.urdf")
    run(capsys, str(urdf), "--frame", TALOS_FRAME, "--srdf", str(given), "--fix", str(out))
    srdf = out.with_suffix(".srdf")
    added = inserted_lines(given.read_bytes(), srdf.read_bytes())
    a, b = TALOS_PAIR
    assert added[-1] == f'  <disable_collisions link1="{a}" link2="{b}" reason="Always"/>'
    assert canonical(ET.parse(given).getroot()) == canonical(
        _without_pair(ET.parse(srdf).getroot(), a, b)
    )


def _without_pair(root: ET.Element, a: str, b: str) -> ET.Element:
    for el in list(root):
        if el.get("link1") == a and el.get("link2") == b:
            root.remove(el)
    return root


def test_a_copy_that_would_lose_the_meshes_is_not_written(tmp_path, capsys):
    # The mesh paths count from a folder above the URDF: a copy elsewhere finds none.
    urdf = talos_tree(tmp_path / "tree")
    out = tmp_path / "elsewhere" / "talos.urdf"
    out.parent.mkdir()
    status, _, err = run(capsys, str(urdf), "--frame", TALOS_FRAME, "--fix", str(out))
    assert status == 2
    probe = tmp_path / "probe.urdf"  # the URDF elsewhere: the meshes it finds none of
    shutil.copyfile(urdf, probe)
    lost = {m.link for m in rd.load(probe, frame=TALOS_FRAME).missing_meshes}
    assert len(lost) > 10 and not rd.load(urdf, frame=TALOS_FRAME).missing_meshes
    probe.unlink()
    message = f"redundancy: error: the fixed copy {str(out)!r} would not find {len(lost)} meshes"
    assert message in err
    assert "(link 'arm_left_1_link': 'package://example-robot-data/robots/talos_data/" in err
    assert f"write it in the model's folder {str(urdf.parent)!r}" in err
    assert list(out.parent.iterdir()) == []  # neither file, and no temporary left


# -- refused targets -------------------------------------------------------------------------------
def test_fix_never_replaces_the_model_by_any_name(tmp_path, capsys):
    planted = planted_panda(tmp_path)
    before = planted.read_bytes()
    link = tmp_path / "link.xml"
    link.symlink_to(planted)
    for target in (planted, link, tmp_path / "sub" / ".." / "panda.xml"):
        (tmp_path / "sub").mkdir(exist_ok=True)
        assert main(["audit", str(planted), "--poses", "10", "--fix", str(target)]) == 2
        err = capsys.readouterr().err
        assert err == (
            f"redundancy: error: {str(target)!r} is the model file {str(planted)!r}: not replaced\n"
        )
    assert planted.read_bytes() == before


def test_fix_never_replaces_the_srdf_the_audit_reads(tmp_path, capsys):
    urdf = talos_tree(tmp_path)
    srdf = urdf.with_name("given.srdf")
    srdf.write_text('<robot name="talos"/>')
    out = urdf.with_name("given.urdf")  # its SRDF beside it is given.srdf: an input
    status, _, err = run(
        capsys, str(urdf), "--frame", TALOS_FRAME, "--srdf", str(srdf), "--fix", str(out)
    )
    assert status == 2
    assert f"{str(srdf)!r} is {str(srdf)!r}, a file the model" in err
    assert not out.exists() and srdf.read_text() == '<robot name="talos"/>'


def test_fix_in_a_missing_folder_fails_before_the_audit(tmp_path, capsys, monkeypatch):
    def no_audit(*args, **kwargs):
        raise AssertionError("audited before the target was checked")

    monkeypatch.setattr("redundancy.reports.audit.audit", no_audit)
    out = tmp_path / "missing" / "panda.xml"
    assert main(["audit", str(PANDA), "--fix", str(out)]) == 2
    err = capsys.readouterr().err
    assert err == (
        f"redundancy: error: directory {str(out.parent)!r} of {str(out)!r} does not exist\n"
    )


# -- several models: --fix names a folder ----------------------------------------------------------
def test_fix_of_a_folder_writes_each_copy_at_its_path_under_the_fix_folder(tmp_path, capsys):
    models = tmp_path / "models"
    (models / "sub").mkdir(parents=True)
    planted = planted_panda(models / "sub")
    shutil.copyfile(MODELS / "arm7.xml", models / "arm7.xml")
    out = tmp_path / "fixed"
    status = main(["audit", str(models), "--poses", POSES, "--quiet", "--fix", str(out)])
    text = capsys.readouterr().out
    assert status == 1
    assert sorted(str(p.relative_to(out)) for p in out.rglob("*.xml")) == [
        "arm7.xml",
        "sub/panda.xml",
    ]
    assert (out / "arm7.xml").read_bytes() == (models / "arm7.xml").read_bytes()
    assert inserted_lines(planted.read_bytes(), (out / "sub" / "panda.xml").read_bytes())
    assert "fixes: 2 copies written, 1 with pairs excluded" in text
    assert f" {out / 'sub' / 'panda.xml'}: excludes link0 / link1 " in " ".join(text.split())
    # The fixed folder: nothing in contact everywhere any more.
    status = main(["audit", str(out), "--poses", POSES, "--json", "-"])
    doc = json.loads(capsys.readouterr().out)
    assert [m["collision"]["touching_everywhere"] for m in doc["models"]] == [[], []]


def test_fix_folder_that_is_the_models_folder_is_refused(tmp_path, capsys):
    models = tmp_path / "models"
    models.mkdir()
    planted_panda(models)
    shutil.copyfile(MODELS / "arm7.xml", models / "arm7.xml")
    assert main(["audit", str(models), "--fix", str(models)]) == 2
    err = capsys.readouterr().err
    assert err == (
        f"redundancy: error: --fix {str(models)!r} would write {str(models / 'arm7.xml')!r}, "
        f"the model file {str(models / 'arm7.xml')!r}\n"
    )


@pytest.mark.parametrize("name", ["panda.xml", "panda.urdf"])
def test_fix_targets(tmp_path, name):
    arm = rd.load(MODELS / name)
    targets = fix.fix_targets(arm, tmp_path / "out.xml")
    assert targets == [tmp_path / "out.xml"] + (
        [tmp_path / "out.srdf"] if name.endswith("urdf") else []
    )

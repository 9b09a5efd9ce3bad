"""Model equivalence: each Pinocchio 4.1 MJCF-parser gap is caught, bridged or refused.

The gaps were found empirically with Pinocchio 4.1.0 and MuJoCo 4.0.0 (see the README's
"What Pinocchio's MJCF parser misses"); each test below holds a purpose-built model.
"""

from __future__ import annotations

import numpy as np
import pytest

import redundancy as rd

from .models import chain


def test_arm7_reports_nothing_but_the_bridged_motor_limits(arm7):
    report = rd.compare_models(arm7)
    assert report.equivalent, "\n".join(report.lines())
    assert {b.quantity for b in report.bridges} == {"effort limit"}
    # The lesson's torque limits, 80 80 60 60 20 20 10 N m (lesson 5.2, table (1)).
    assert [b.value for b in report.bridges] == [80, 80, 60, 60, 20, 20, 10]
    assert np.array_equal(
        np.asarray(arm7.pinocchio.model.effortLimit), [80, 80, 60, 60, 20, 20, 10]
    )


def _bridged(arm: rd.Arm, quantity: str) -> dict[str, object]:
    return {b.joint: b.value for b in arm.bridges if b.quantity == quantity}


def test_actuators_are_not_read_by_pinocchio_so_limits_are_bridged():
    xml = chain(
        extra='<actuator><motor joint="a" gear="3" forcerange="-5 5" forcelimited="true"/>'
        '<motor joint="b" ctrlrange="-2 2" ctrllimited="true" gear="4"/></actuator>'
    )
    arm = rd.load_string(xml, site="tip")
    assert _bridged(arm, "effort limit") == {"a": 15.0, "b": 8.0}
    assert rd.compare_models(arm).equivalent


def test_actuator_armature_and_damping_are_bridged_and_reach_the_mass_matrix():
    xml = chain(
        extra='<actuator><motor joint="a" gear="10" armature="0.001" damping="0.01"/></actuator>'
    )
    arm = rd.load_string(xml, site="tip")
    assert _bridged(arm, "armature") == {"a": pytest.approx(0.1)}
    assert _bridged(arm, "damping") == {"a": pytest.approx(1.0)}
    q = np.array([0.3, -0.2])
    assert np.allclose(arm.mass_matrix(q, engine="pinocchio"), arm.mass_matrix(q), atol=1e-12)
    assert rd.crosscheck(arm, q).ok


def test_gravity_option_is_bridged():
    xml = chain().replace("<mujoco>", '<mujoco><option gravity="1 2 -3"/>')
    arm = rd.load_string(xml, site="tip")
    assert _bridged(arm, "gravity") == {"model": (1.0, 2.0, -3.0)}
    assert rd.crosscheck(arm, np.array([0.4, 0.7])).ok


def test_slide_range_in_degree_mode_and_limited_false_are_bridged():
    # Pinocchio converts a slide's range as if it were in degrees, and ignores limited="false".
    xml = chain(joints='<joint name="a" type="slide" axis="0 0 1" range="-0.5 0.7"/>').replace(
        '<joint name="b" axis="0 1 0"/>',
        '<joint name="b" axis="0 1 0" range="-30 30" limited="false"/>',
    )
    arm = rd.load_string(xml, site="tip")
    assert _bridged(arm, "joint range") == {"a": (-0.5, 0.7), "b": (-np.inf, np.inf)}
    assert rd.compare_models(arm).equivalent


def test_site_defaults_are_bridged():
    xml = (
        chain()
        .replace("<mujoco>", '<mujoco><default><site pos="0 0 0.3"/></default>')
        .replace('<site name="tip" pos="0 0 0.3"/>', '<site name="tip"/>')
    )
    arm = rd.load_string(xml, site="tip")
    assert "tip" in _bridged(arm, "site placement")
    report = rd.crosscheck(arm, np.array([0.4, -1.1]))
    assert report.ok, report.lines()


def test_mesh_inertia_placeholder_is_refused_or_reported():
    mesh = (
        '<asset><mesh name="cube" vertex="0 0 0 .1 0 0 0 .1 0 .1 .1 0 0 0 .1 .1 0 .1 0 .1 .1 .1 .1 .1"/>'
        "</asset>"
    )
    xml = chain(body_extra='<geom type="mesh" mesh="cube"/>').replace("<mujoco>", "<mujoco>" + mesh)
    with pytest.raises(rd.UnsupportedFeatureError, match="mesh, sdf or height-field geom"):
        rd.load_string(xml, site="tip")
    report = rd.compare_models(rd.load_string(xml, site="tip", strict=False))
    # Pinocchio gives the mesh a unit-mass placeholder; MuJoCo integrates the hull (1 kg here).
    assert {(d.quantity, d.item) for d in report.differences} >= {("body mass", "body moved by b")}


def test_fixed_root_body_pose_is_refused_or_reported():
    xml = (
        chain()
        .replace(
            '<body name="l1" pos="0 0 0.1">',
            '<body name="base" pos="0 0 0.5" quat="0.9 0.3 0 0"><geom size="0.05"/><body name="l1" pos="0 0 0.1">',
        )
        .replace("</worldbody>", "</body></worldbody>")
    )
    with pytest.raises(rd.UnsupportedFeatureError, match="fixed root body with a pose"):
        rd.load_string(xml, site="tip")
    report = rd.compare_models(rd.load_string(xml, site="tip", strict=False))
    quantities = {d.quantity for d in report.differences}
    assert {"site position", "joint axis (world)", "centre of mass (world)"} <= quantities


def test_frame_contents_vanish_so_frames_are_refused_or_reported():
    xml = chain(body_extra='<frame pos="0 0 0.1"><geom size="0.05" mass="2"/></frame>')
    report = rd.compare_models(rd.load_string(xml, site="tip", strict=False))
    masses = {
        d.item: (d.mujoco, d.pinocchio) for d in report.differences if d.quantity == "body mass"
    }
    assert "body moved by b" in masses
    mj, pn = masses["body moved by b"]
    assert mj - pn == pytest.approx(2.0)


def test_several_joints_in_one_body_are_refused():
    # Pinocchio merges them into one composite joint named after the first; the others vanish.
    xml = chain(joints='<joint name="a" axis="0 1 0"/><joint name="a2" axis="1 0 0"/>')
    with pytest.raises(rd.UnsupportedFeatureError, match="several joints in one body"):
        rd.load_string(xml, site="tip", strict=False)


def test_second_root_body_is_refused():
    # Pinocchio reads only the first body under <worldbody>, silently.
    xml = chain().replace(
        "</worldbody>", '<body name="table" pos="1 0 0"><geom size="0.1"/></body></worldbody>'
    )
    with pytest.raises(rd.UnsupportedFeatureError, match="several root bodies"):
        rd.load_string(xml, site="tip", strict=False)


def test_visual_geom_mass_is_reported():
    # Pinocchio leaves contype=0 conaffinity=0 geoms out of the inertia; MuJoCo counts them.
    xml = chain(
        body_extra='<geom type="sphere" size="0.05" pos="0 0 0.35" contype="0" conaffinity="0" mass="0.5"/>'
    )
    report = rd.compare_models(rd.load_string(xml, site="tip"))
    diffs = {d.quantity: d for d in report.differences if d.item == "body moved by b"}
    assert diffs["body mass"].mujoco - diffs["body mass"].pinocchio == pytest.approx(0.5)
    assert not rd.crosscheck(rd.load_string(xml, site="tip"), np.array([0.2, 0.3])).ok


def test_extrinsic_euler_and_non_unit_axisangle_are_refused_or_reported():
    xml = (
        chain()
        .replace("<mujoco>", '<mujoco><compiler eulerseq="XYZ"/>')
        .replace(
            '<body name="l2" pos="0 0 0.3">', '<body name="l2" pos="0 0 0.3" euler="30 40 50">'
        )
    )
    with pytest.raises(rd.UnsupportedFeatureError, match="extrinsic eulerseq"):
        rd.load_string(xml, site="tip")
    assert not rd.compare_models(rd.load_string(xml, site="tip", strict=False)).equivalent
    xml = chain().replace(
        '<body name="l2" pos="0 0 0.3">', '<body name="l2" pos="0 0 0.3" axisangle="1 1 0 30">'
    )
    with pytest.raises(rd.UnsupportedFeatureError, match="axisangle with a non-unit axis"):
        rd.load_string(xml, site="tip")
    assert not rd.compare_models(rd.load_string(xml, site="tip", strict=False)).equivalent


def test_difference_report_carries_both_values():
    xml = chain(
        body_extra='<geom type="sphere" size="0.05" contype="0" conaffinity="0" mass="0.5"/>'
    )
    report = rd.compare_models(rd.load_string(xml, site="tip"))
    line = next(x for x in report.lines() if x.startswith("DIFFERS  body mass"))
    assert "MuJoCo" in line and "Pinocchio" in line

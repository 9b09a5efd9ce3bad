"""Model equivalence: each Pinocchio 4.1 MJCF-parser gap is caught, bridged or refused.

The gaps were found empirically with Pinocchio 4.1.0 and MuJoCo 4.0.0 (see the guide's
docs/guide/urdf-and-mjcf.md, "What Pinocchio's MJCF parser misses"); each test below holds a
purpose-built model.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin
import pytest

import redundancy as rd
from redundancy.model.bridges import _mujoco_joint_inertias

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
    arm = rd.load_string(xml, frame="tip")
    assert _bridged(arm, "effort limit") == {"a": 15.0, "b": 8.0}
    assert rd.compare_models(arm).equivalent


def test_actuator_armature_and_damping_are_bridged_and_reach_the_mass_matrix():
    xml = chain(
        extra='<actuator><motor joint="a" gear="10" armature="0.001" damping="0.01"/></actuator>'
    )
    arm = rd.load_string(xml, frame="tip")
    assert _bridged(arm, "armature") == {"a": pytest.approx(0.1)}
    assert _bridged(arm, "damping") == {"a": pytest.approx(1.0)}
    q = np.array([0.3, -0.2])
    assert np.allclose(arm.mass_matrix(q, engine="pinocchio"), arm.mass_matrix(q), atol=1e-12)
    assert rd.crosscheck(arm, q).ok


def test_gravity_option_is_bridged():
    xml = chain().replace("<mujoco>", '<mujoco><option gravity="1 2 -3"/>')
    arm = rd.load_string(xml, frame="tip")
    assert _bridged(arm, "gravity") == {"model": (1.0, 2.0, -3.0)}
    assert rd.crosscheck(arm, np.array([0.4, 0.7])).ok


def test_slide_range_in_degree_mode_and_limited_false_are_bridged():
    # Pinocchio converts a slide's range as if it were in degrees, and ignores limited="false".
    xml = chain(joints='<joint name="a" type="slide" axis="0 0 1" range="-0.5 0.7"/>').replace(
        '<joint name="b" axis="0 1 0"/>',
        '<joint name="b" axis="0 1 0" range="-30 30" limited="false"/>',
    )
    arm = rd.load_string(xml, frame="tip")
    assert _bridged(arm, "joint range") == {"a": (-0.5, 0.7), "b": (-np.inf, np.inf)}
    assert rd.compare_models(arm).equivalent


def test_site_defaults_are_bridged():
    xml = (
        chain()
        .replace("<mujoco>", '<mujoco><default><site pos="0 0 0.3"/></default>')
        .replace('<site name="tip" pos="0 0 0.3"/>', '<site name="tip"/>')
    )
    arm = rd.load_string(xml, frame="tip")
    assert "tip" in _bridged(arm, "site placement")
    report = rd.crosscheck(arm, np.array([0.4, -1.1]))
    assert report.ok, report.lines()


# ------------------------------------------------------------------------------------------
# The loader's reading rules, each on a tiny model: Pinocchio's own reading differs from MuJoCo's (the
# measurement that justifies the rule) or does not (the rule accepts without a bridge), and
# the library's arm agrees either way.
# ------------------------------------------------------------------------------------------

CUBE = (
    '<asset><mesh name="cube" vertex="0 0 0 .1 0 0 0 .1 0 .1 .1 0 0 0 .1 .1 0 .1 0 .1 .1 .1 .1 .1"/>'
    "</asset>"
)
INERTIAL = '<inertial pos="0 0 0.1" mass="2" diaginertia="0.01 0.02 0.03"/>'
POSES = np.array([[0.4, -1.1], [-2.0, 0.7], [1.3, 2.9]])


def _raw_pinocchio(xml: str) -> pin.Model:
    """The model Pinocchio's MJCF parser alone builds from ``xml`` (no bridges)."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "m.xml"
        path.write_text(xml)
        return pin.buildModelFromMJCF(str(path))


def _raw_pinocchio_inertia(xml: str, joint: str) -> tuple[float, np.ndarray]:
    """Mass and centre of mass of a joint's bodies as Pinocchio's parser alone reads them."""
    pm = _raw_pinocchio(xml)
    inertia = pm.inertias[pm.getJointId(joint)]
    return float(inertia.mass), np.array(inertia.lever)


def _mujoco_inertia(arm: rd.Arm, joint: str) -> tuple[float, np.ndarray]:
    """The same, from MuJoCo's compiled model (expressed in Pinocchio's joint frame)."""
    j = arm.joint_index(joint)
    inertia = _mujoco_joint_inertias(arm.mj_model)[j]
    return float(inertia.mass), np.array(inertia.lever)


def _agree(arm: rd.Arm) -> None:
    report = rd.compare_models(arm)
    assert report.equivalent, "\n".join(report.lines())
    cc = rd.crosscheck(arm, POSES)
    assert cc.ok, "\n".join(cc.lines())


def _raw_differs(xml: str, arm: rd.Arm, joint: str = "b") -> bool:
    (m_pin, c_pin), (m_mj, c_mj) = _raw_pinocchio_inertia(xml, joint), _mujoco_inertia(arm, joint)
    return abs(m_pin - m_mj) > 1e-9 or bool(np.max(np.abs(c_pin - c_mj)) > 1e-9)


INERTIA_RULES = [
    # (id, body_extra, extra head (assets, defaults, compiler), Pinocchio alone differs, cause)
    ("mesh beside an explicit inertial", INERTIAL + '<geom type="mesh" mesh="cube"/>', CUBE,
     False, None),
    ("visual mesh of mass 0", '<geom type="mesh" mesh="cube" contype="0" conaffinity="0" '
     'mass="0"/><geom size="0.05"/>', CUBE, False, None),
    ("visual mesh with a density (MuJoCo counts it)", '<geom type="mesh" mesh="cube" '
     'contype="0" conaffinity="0"/><geom size="0.05"/>', CUBE, True,
     "visual geom 'l2 geom 1' has mass in MuJoCo"),
    ("mesh feeding the inertia", '<geom type="mesh" mesh="cube" pos="0 0 0.2"/><geom size="0.05"/>',
     CUBE, True, "mesh geom 'l2 geom 1'"),
    ("mesh of mass 0 (Pinocchio's placeholder still counts)",
     '<geom type="mesh" mesh="cube" mass="0"/><geom size="0.05" pos="0 0 0.3"/>', CUBE, True,
     "placeholder inertia"),
    ("mesh outside inertiagrouprange",
     '<geom type="mesh" mesh="cube" group="4"/><geom size="0.05" pos="0 0 0.3"/>',
     CUBE + '<compiler inertiagrouprange="0 3"/>', True, "outside inertiagrouprange"),
    ("default-class geom mass, no inertial", '<geom class="heavy" size="0.05" pos="0 0 0.3"/>',
     '<default><default class="heavy"><geom mass="3"/></default></default>', True,
     "takes mass=3 from default class 'heavy'"),
    ("default-class geom mass beside an inertial",
     INERTIAL + '<geom class="heavy" size="0.05" pos="0 0 0.3"/>',
     '<default><default class="heavy"><geom mass="3"/></default></default>', False, None),
    ("visual geom with mass", '<geom size="0.05" pos="0 0 0.35" contype="0" conaffinity="0" '
     'mass="0.5"/><geom size="0.05"/>', "", True, "visual geom 'l2 geom 1' has mass in MuJoCo"),
    ("settotalmass", "", '<compiler settotalmass="9"/>', True, "settotalmass"),
    ("mesh beside an inertial under inertiafromgeom=true", INERTIAL + '<geom type="mesh" '
     'mesh="cube"/>', CUBE + '<compiler inertiafromgeom="true"/>', True, "mesh geom 'l2 geom 1'"),
]  # fmt: skip


@pytest.mark.parametrize(
    ("body_extra", "head", "pinocchio_alone_differs", "cause"),
    [pytest.param(*r[1:], id=r[0]) for r in INERTIA_RULES],
)
def test_inertia_rules(body_extra: str, head: str, pinocchio_alone_differs: bool, cause: str):
    xml = chain(body_extra=body_extra).replace("<mujoco>", "<mujoco>" + head)
    arm = rd.load_string(xml, frame="tip")  # strict: accepted
    assert _raw_differs(xml, arm) == pinocchio_alone_differs
    bridged = [b for b in arm.bridges if b.quantity == "body inertia"]
    if pinocchio_alone_differs:
        assert [b.joint for b in bridged] == ["l2"] or "settotalmass" in cause
        assert all(cause in b.source for b in bridged), [b.source for b in bridged]
        line = next(x for x in rd.compare_models(arm).lines() if "body inertia" in x)
        assert line.startswith("BRIDGED  body inertia") and cause in line
    else:
        assert not bridged
    _agree(arm)


def test_an_unnamed_body_pinocchio_loses_is_bridged():
    """Pinocchio names an unnamed body after its parent ("l2Bis") and, here, drops it."""
    xml = (
        chain()
        .replace(
            '<body name="l1" pos="0 0 0.1">',
            '<body name="l1" pos="0 0 0.1"><body><geom size="0.1"/></body>',
        )
        .replace(
            '<site name="tip" pos="0 0 0.3"/>',
            '<site name="tip" pos="0 0 0.3"/><body><inertial pos="0 0 0.2" mass="3" '
            'diaginertia=".1 .1 .1"/></body>',
        )
    )
    arm = rd.load_string(xml, frame="tip")
    assert _raw_differs(xml, arm)
    (bridged,) = [b for b in arm.bridges if b.joint == "l2, l2 body 0"]
    assert "unnamed body 'l2 body 0'" in bridged.source
    _agree(arm)


def test_an_explicit_inertial_is_never_overwritten():
    """A difference Pinocchio makes in an <inertial> it reads itself stays a difference."""
    xml = chain(body_extra=INERTIAL).replace("<mujoco>", '<mujoco><compiler eulerseq="XYZ"/>')
    xml = xml.replace(INERTIAL, INERTIAL.replace("/>", ' euler="0.3 0.2 0.1"/>'))
    arm = rd.load_string(xml, frame="tip", strict=False)
    assert not [b for b in arm.bridges if b.quantity == "body inertia"]
    assert "inertia about com (world)" in {d.quantity for d in rd.compare_models(arm).differences}


POSED_ROOT = (
    chain()
    .replace(
        '<body name="l1" pos="0 0 0.1">',
        '<body name="base" pos="0.5 0.2 0.3" quat="0.9 0.3 0.1 0.2"><geom size="0.05"/>'
        '<body name="fixture" pos="0 0.1 0" euler="0.1 0 0"><geom size="0.02"/></body>'
        '<body name="l1" pos="0 0 0.1">',
    )
    .replace("</worldbody>", "</body></worldbody>")
)


def test_posed_fixed_root_is_bridged_into_joint_placements_and_frames():
    raw = _raw_pinocchio(POSED_ROOT)
    arm = rd.load_string(POSED_ROOT, frame="tip")
    # Pinocchio alone drops the pose: its tool site is off by the root's offset.
    raw_data = raw.createData()
    pin.framesForwardKinematics(raw, raw_data, np.zeros(2))
    site_mj, _ = arm.site_pose(np.zeros(2))
    assert np.linalg.norm(raw_data.oMf[raw.getFrameId("tip")].translation - site_mj) > 0.3
    assert [(b.quantity, b.joint) for b in arm.bridges] == [("root pose", "base")]
    assert arm.bridges[0].value[:3] == (0.5, 0.2, 0.3)
    _agree(arm)
    # Every body frame Pinocchio holds sits where MuJoCo puts the body, at several poses.
    pm, pd = arm.pinocchio.model, arm.pinocchio.model.createData()
    mm = arm.mj_model
    data = mujoco.MjData(mm)
    for q in POSES:
        data.qpos[:] = q
        mujoco.mj_kinematics(mm, data)
        qp = np.zeros(pm.nq)
        qp[arm.pinocchio.perm] = q
        pin.framesForwardKinematics(pm, pd, qp)
        for body in ("base", "fixture", "l1", "l2"):
            b = mujoco.mj_name2id(mm, mujoco.mjtObj.mjOBJ_BODY, body)
            f = pd.oMf[pm.getFrameId(body, pin.FrameType.BODY)]
            assert np.allclose(f.translation, data.xpos[b], atol=1e-12), body
            assert np.allclose(f.rotation, data.xmat[b].reshape(3, 3), atol=1e-12), body


def test_frame_contents_are_bridged_where_they_feed_the_inertia():
    xml = chain(body_extra='<frame pos="0 0 0.1"><geom size="0.05" mass="2"/></frame>')
    arm = rd.load_string(xml, frame="tip", strict=False)
    assert _raw_differs(xml, arm)
    (bridged,) = [b for b in arm.bridges if b.quantity == "body inertia"]
    assert "<frame>" in bridged.source
    _agree(arm)


def test_several_joints_in_one_body_are_given_to_pinocchio_as_a_chain():
    # Pinocchio's parser merges them into one composite joint named after the first; it
    # gets MuJoCo's compiled model with one body per joint instead, in either mode.
    xml = chain(joints='<joint name="a" axis="0 1 0"/><joint name="a2" axis="1 0 0"/>')
    for strict in (True, False):
        arm = rd.load_string(xml, frame="tip", strict=strict)
        assert arm.joint_names == ("a", "a2", "b")
        assert [b.quantity for b in arm.bridges][:1] == ["whole model"]
        assert rd.crosscheck(arm, rd.random_poses(arm, 20, seed=4)).ok


@pytest.mark.parametrize("first", [True, False])
def test_second_root_body_is_set_aside_for_pinocchio(first: bool):
    # Pinocchio's parser reads only the first body under <worldbody>: it is handed the arm's
    # tree alone (the table first or second in the file), and the report says so.
    table = '<body name="table" pos="1 0 0"><geom size="0.1"/></body>'
    if first:
        xml = chain().replace("<worldbody>", "<worldbody>" + table)
    else:
        xml = chain().replace("</worldbody>", table + "</worldbody>")
    arm = rd.load_string(xml, frame="tip", strict=False)
    assert [(a.what, a.name) for a in arm.set_aside] == [("root body", "table")]
    assert arm.pinocchio.model.existFrame("l1") and not arm.pinocchio.model.existFrame("table")
    assert rd.crosscheck(arm, np.array([[0.3, -0.2], [1.0, 0.5]])).ok


def test_extrinsic_euler_and_non_unit_axisangle_are_served_or_reported():
    """Strict: Pinocchio gets MuJoCo's compiled model; lenient: its own reading, which differs."""
    xml = (
        chain()
        .replace("<mujoco>", '<mujoco><compiler eulerseq="XYZ"/>')
        .replace(
            '<body name="l2" pos="0 0 0.3">', '<body name="l2" pos="0 0 0.3" euler="30 40 50">'
        )
    )
    assert rd.compare_models(rd.load_string(xml, frame="tip")).equivalent
    assert not rd.compare_models(rd.load_string(xml, frame="tip", strict=False)).equivalent
    xml = chain().replace(
        '<body name="l2" pos="0 0 0.3">', '<body name="l2" pos="0 0 0.3" axisangle="1 1 0 30">'
    )
    assert rd.compare_models(rd.load_string(xml, frame="tip")).equivalent
    assert not rd.compare_models(rd.load_string(xml, frame="tip", strict=False)).equivalent


def test_difference_report_carries_both_values():
    xml = chain().replace(
        '<body name="l2" pos="0 0 0.3">', '<body name="l2" pos="0 0 0.3" axisangle="1 1 0 30">'
    )
    report = rd.compare_models(rd.load_string(xml, frame="tip", strict=False))
    line = next(x for x in report.lines() if x.startswith("DIFFERS  site position"))
    assert "MuJoCo" in line and "Pinocchio" in line
    assert report.largest["site position"] > 1e-3


# ------------------------------------------------------------------------------------------
# What MuJoCo simulates that neither engine's numbers include (the model side).
# ------------------------------------------------------------------------------------------


def _simulated(arm: rd.Arm) -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    for s in rd.compare_models(arm).simulated:
        out.setdefault(s.feature, []).append(f"{s.item}: {s.value}")
    return out


def test_gravcomp_is_listed_and_is_what_mujoco_applies():
    xml = (
        chain()
        .replace('<body name="l1"', '<body name="l1" gravcomp="1"')
        .replace('<body name="l2"', '<body name="l2" gravcomp="1"')
    )
    arm = rd.load_string(xml, frame="tip")
    assert _simulated(arm)["gravity compensation"] == ["body l1: gravcomp=1", "body l2: gravcomp=1"]
    # MuJoCo's simulation applies exactly the gravity torque as compensation: a motor would
    # hold nothing, while both engines' gravity numbers still say what gravity alone needs.
    q = np.array([0.7, -0.4])
    data = mujoco.MjData(arm.mj_model)
    data.qpos[:] = q
    mujoco.mj_forward(arm.mj_model, data)
    assert np.allclose(data.qfrc_gravcomp, arm.gravity(q), atol=1e-12)
    assert np.abs(arm.gravity(q)).max() > 1.0
    assert np.allclose(data.qacc, 0, atol=1e-9)  # it hangs still with zero motor torque


def test_asymmetric_ranges_are_listed_per_direction():
    xml = chain(
        joints='<joint name="a" axis="0 1 0" actuatorfrcrange="-5 9"/>',
        extra='<actuator><motor joint="a" ctrlrange="-10 80"/>'
        '<motor joint="b" forcerange="-3 4" ctrlrange="-1 1" gear="2"/>'
        '<position joint="b" kp="10" ctrlrange="0 1"/></actuator>',
    )
    arm = rd.load_string(xml, frame="tip")
    sim = _simulated(arm)
    assert sim["asymmetric control range"] == ["actuator actuator 0: [-10, 80]"]
    assert sim["asymmetric force range"] == ["actuator actuator 1: [-3, 4]"]
    assert sim["asymmetric actuator force range"] == ["joint a: [-5, 9]"]
    # A position servo's ctrlrange is a target range, not a torque: not listed.
    assert len(sim["asymmetric control range"]) == 1


def test_integrator_and_flags_are_listed():
    euler = chain(extra='<option integrator="Euler"><flag eulerdamp="disable"/></option>')
    lines = rd.compare_models(rd.load_string(euler, frame="tip")).lines()
    assert any(
        x.startswith("SIMULATED  integrator (model: Euler, timestep 0.002 s)") for x in lines
    )
    assert any("eulerdamp disabled" in x and "integrated explicitly" in x for x in lines)
    fast = chain(extra='<option integrator="implicitfast"><flag eulerdamp="disable"/></option>')
    sim = {s.feature: s for s in rd.compare_models(rd.load_string(fast, frame="tip")).simulated}
    assert "no effect under the implicitfast integrator" in sim["eulerdamp disabled"].effect
    assert "implicitly" in sim["integrator"].effect
    other = chain(extra='<option><flag contact="disable" frictionloss="disable"/></option>')
    sim = _simulated(rd.load_string(other, frame="tip"))
    assert "contact disabled" in sim and "frictionloss disabled" in sim


def test_friction_loss_and_springs_are_listed():
    xml = chain(
        joints='<joint name="a" axis="0 1 0" frictionloss="0.7" stiffness="3" springref="20"/>'
    )
    sim = _simulated(rd.load_string(xml, frame="tip"))
    assert sim["friction loss"] == ["joints: a=0.7"]
    assert sim["joint spring"] == [
        "joint a: stiffness=3, springref=0.349066"
    ]  # degrees in the file


def test_gravity_flag_is_bridged_and_listed():
    xml = chain(extra='<option gravity="0 0 -9.81"><flag gravity="disable"/></option>')
    arm = rd.load_string(xml, frame="tip")
    q = np.array([0.7, -0.4])
    # Pinocchio alone keeps 9.81 m/s^2: its gravity torque is not what MuJoCo simulates.
    raw = _raw_pinocchio(xml)
    assert np.abs(pin.computeGeneralizedGravity(raw, raw.createData(), q)).max() > 1.0
    assert [(b.quantity, b.value, b.source) for b in arm.bridges] == [
        ("gravity", (0.0, 0.0, 0.0), '<flag gravity="disable"/>')
    ]
    assert np.array_equal(arm.gravity(q), np.zeros(2))
    assert np.array_equal(arm.gravity(q, engine="pinocchio"), np.zeros(2))
    # MuJoCo's simulation agrees: released at rest with no torque, the arm does not move.
    data = mujoco.MjData(arm.mj_model)
    data.qpos[:] = q
    for _ in range(100):
        mujoco.mj_step(arm.mj_model, data)
    assert np.allclose(data.qpos, q, atol=1e-12)
    assert "gravity disabled" in _simulated(arm)
    _agree(arm)


def test_compare_models_rejects_a_bad_tolerance(arm7):
    for tol in (float("nan"), -1.0, float("inf"), "1e-9"):
        with pytest.raises(rd.RedundancyError, match="tol must be a finite number >= 0"):
            rd.compare_models(arm7, tol=tol)  # type: ignore[arg-type]


# ------------------------------------------------------------------------------------------
# Display names (model/names.py)
# ------------------------------------------------------------------------------------------


def test_display_names_of_unnamed_objects():
    from redundancy.model.names import body_name, display_names, geom_name

    m = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><geom type="plane" size="1 1 1"/><body name="link3"><joint/>'
        '<geom size=".1"/><geom size=".1" name="link3 geom 2"/><geom size=".1"/>'
        '<body><geom size=".1"/><site/></body></body></worldbody></mujoco>'
    )
    assert display_names(m, mujoco.mjtObj.mjOBJ_BODY) == ("world", "link3", "link3 body 0")
    assert display_names(m, mujoco.mjtObj.mjOBJ_GEOM) == (
        "world geom 0",
        "link3 geom 0",
        "link3 geom 2",
        "link3 geom 2 (#3)",  # the generated name is taken by a named geom: the id is added
        "link3 body 0 geom 0",
    )
    assert display_names(m, mujoco.mjtObj.mjOBJ_JOINT) == ("link3 joint 0",)
    assert display_names(m, mujoco.mjtObj.mjOBJ_SITE) == ("link3 body 0 site 0",)
    assert body_name(m, 2) == "link3 body 0" and geom_name(m, 1) == "link3 geom 0"

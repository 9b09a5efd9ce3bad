"""Bad input: every case raises the library's own exception with a message naming the cause."""

from __future__ import annotations

import numpy as np
import pytest

import redundancy as rd

from .models import SKEW7, chain

JOINTS = "['q1', 'q2', 'q3', 'q4', 'q5', 'q6', 'q7']"


def test_unknown_site_lists_the_valid_ones():
    with pytest.raises(rd.UnknownNameError) as exc:
        rd.load_string(SKEW7, frame="flange")
    assert str(exc.value) == (
        "unknown site or body 'flange'; valid site or body names: "
        "['tool', 'b1', 'b2', 'b3', 'b4', 'b5', 'b6', 'b7']"
    )
    assert exc.value.valid == ("tool", "b1", "b2", "b3", "b4", "b5", "b6", "b7")


def test_unknown_joint_and_keyframe(skew7: rd.Arm):
    with pytest.raises(
        rd.UnknownNameError, match=r"^unknown joint 'j1'; valid joint names: \['q1', 'q2'"
    ):
        skew7.joint_index("j1")
    with pytest.raises(
        rd.UnknownNameError, match=r"^unknown keyframe 'home'; valid keyframe names: \['bent'\]$"
    ):
        skew7.keyframe("home")


def test_unknown_bundled_model():
    with pytest.raises(rd.UnknownNameError, match=r"^unknown model 'arm8'; valid model names: \["):
        rd.model_path("arm8")


@pytest.mark.parametrize(
    ("q", "message"),
    [
        (np.zeros(6), f"pose must have shape (7,) for joints {JOINTS}, got shape (6,)"),
        (np.zeros((2, 7)), f"pose must have shape (7,) for joints {JOINTS}, got shape (2, 7)"),
        ([0, 0, np.nan, 0, 0, 0, 0], "pose has non-finite values: q3=nan"),
        ([np.inf, 0, 0, 0, 0, 0, -np.inf], "pose has non-finite values: q1=inf, q7=-inf"),
    ],
)
def test_bad_pose_shape_and_values(q, message, skew7: rd.Arm):
    for call in (skew7.jacobian, skew7.gravity, skew7.mass_matrix):
        with pytest.raises(rd.PoseError) as exc:
            call(q)
        assert str(exc.value) == message


def test_non_numeric_pose(skew7: rd.Arm):
    with pytest.raises(rd.PoseError, match=r"^pose must be numeric, got list"):
        skew7.jacobian(["a"] * 7)


def test_out_of_range_pose_when_range_matters(skew7: rd.Arm):
    q = np.zeros(7)
    q[1] = 2.0  # q2 range is +-90 degrees
    skew7.jacobian(q)  # kinematics is defined outside the range
    with pytest.raises(rd.OutOfRangeError) as exc:
        skew7.pose(q, check_range=True)
    assert str(exc.value) == "joint 'q2' = 2 is outside its range [-1.5708, 1.5708]"
    assert (exc.value.joint, exc.value.value) == ("q2", 2.0)


def test_missing_file():
    with pytest.raises(rd.ModelError, match=r"^model file not found: '/nonexistent/arm.xml'$"):
        rd.load("/nonexistent/arm.xml")


@pytest.mark.parametrize(
    ("xml", "match"),
    [
        ("not xml at all", r"^not well-formed XML: syntax error: line 1, column 0$"),
        ("<mujoco><worldbody>", r"^not well-formed XML: no element found: line 1, column 19$"),
        (
            "<mujoco><worldbody><body><joint bogus='1'/></body></worldbody></mujoco>",
            r"^MuJoCo could not compile the model: XML Error: Schema violation: unrecognized attribute: 'bogus'",
        ),
        (chain(body_extra='<geom size="nan"/>'), r"^MuJoCo could not compile the model: "),
        (
            chain(body_extra='<inertial pos="0 0 0" mass="-1" diaginertia="1 1 1"/>'),
            r"^MuJoCo could not compile the model: .*mass",
        ),
        (  # MuJoCo follows the include first, and names the file it cannot open
            chain().replace("<mujoco>", '<mujoco><include file="other.xml"/>'),
            r"^MuJoCo could not compile the model: .*other\.xml",
        ),
    ],
)
def test_malformed_models(xml, match):
    with pytest.raises(rd.ModelError, match=match):
        rd.load_string(xml, frame="tip")


@pytest.mark.parametrize(
    ("xml", "message"),
    [
        (
            "<mujoco><worldbody><body><geom size='0.1'/><site name='tip'/></body></worldbody></mujoco>",
            "unsupported feature: no joints (the chain from 'world' to 'tip'): an arm needs at least "
            "one hinge or slide joint on its chain",
        ),
        (
            chain(joints='<joint axis="0 1 0"/>'),
            "unsupported feature: unnamed joint (joint 'l1 joint 0'): joints are matched across engines by "
            "name; name every joint",
        ),
        (
            chain(
                extra='<tendon><fixed name="t"><joint joint="a" coef="1"/><joint joint="b" coef="1"/>'
                "</fixed></tendon>"
            ),
            "unsupported feature: tendon on an arm joint (tendon 't' (arm joint 'a')): Pinocchio has "
            "no tendons; the engines would see different arms",
        ),
        (
            chain(
                extra='<tendon><fixed name="t"><joint joint="a" coef="1"/></fixed></tendon>'
                '<equality><tendon tendon1="t"/></equality>'
            ),
            "unsupported feature: tendon coupling on the arm (equality 'equality 0' (tendon over "
            "joint 'a')): a tendon equality couples tendon lengths, not joints: the arm's joints "
            "are served with joint equalities (<equality><joint>), URDF <mimic> and loops closed "
            "by <connect> or <weld>",
        ),
    ],
)
def test_unsupported_features(xml, message):
    with pytest.raises(rd.UnsupportedFeatureError) as exc:
        rd.load_string(xml, frame="tip")
    assert str(exc.value) == message


def test_everything_is_a_redundancy_error():
    for cls in (
        rd.ModelError,
        rd.UnsupportedFeatureError,
        rd.UnknownNameError,
        rd.PoseError,
        rd.OutOfRangeError,
        rd.MissingDependencyError,
    ):
        assert issubclass(cls, rd.RedundancyError)


def test_bad_characteristic_length(skew7: rd.Arm):
    with pytest.raises(
        rd.ParameterError, match=r"^length must be a finite number > 0 \[m\], got 0$"
    ):
        skew7.manipulability(np.zeros(7), length=0)


def test_unknown_crosscheck_quantity_lists_the_valid_ones(skew7: rd.Arm):
    for check in (rd.crosscheck, rd.crosscheck_batch):
        with pytest.raises(
            rd.UnknownNameError,
            match=r"^unknown quantity 'jacobain'; valid quantity names: \['site position'",
        ):
            check(
                skew7,
                np.zeros(7) if check is rd.crosscheck else np.zeros((1, 7)),
                quantities=("jacobain",),
            )


def test_a_model_without_geoms_loads_and_is_checked():
    """A model with no geoms raised a bare ValueError in the loader's checks."""
    xml = (
        '<mujoco><worldbody><body name="l1"><joint name="a" axis="0 1 0"/>'
        '<inertial pos="0 0 0.1" mass="1" diaginertia=".1 .1 .1"/>'
        '<body name="l2" pos="0 0 .3"><joint name="b" axis="0 1 0"/>'
        '<inertial pos="0 0 0.1" mass="1" diaginertia=".1 .1 .1"/><site name="tip" pos="0 0 .2"/>'
        "</body></body></worldbody></mujoco>"
    )
    arm = rd.load_string(xml, frame="tip")
    assert arm.mj_model.ngeom == 0
    assert rd.compare_models(arm).equivalent
    assert rd.crosscheck(arm, np.array([[0.1, 0.2], [-1.0, 2.0]])).ok
    assert rd.collision_pairs(arm) == ()
    assert rd.collision_statistics(arm, n_poses=5).poses_with_contact == 0


def test_body_and_joint_may_share_a_name():
    """Pinocchio keeps a BODY and a JOINT frame of the same name apart by type."""
    xml = (
        chain(joints='<joint name="l1" axis="0 1 0"/>')
        .replace('<site name="tip" pos="0 0 0.3"/>', '<site name="tip"/>')
        .replace("<mujoco>", '<mujoco><default><site pos="0 0 0.3"/></default>')
    )
    arm = rd.load_string(xml, frame="tip")
    assert "site placement" in {b.quantity for b in arm.bridges}  # looks the body frame up
    assert rd.crosscheck(arm, np.array([0.3, -0.4])).ok


def test_a_misspelt_shared_keyword_is_refused_naming_the_valid_ones(arm7: rd.Arm):
    """Keywords that several functions share (``**options: Unpack[...]``) are checked: Python
    would let any name into ``**options`` silently."""
    q = arm7.keyframe("home")
    calls = [
        (
            lambda: arm7.effective_mass(q, [1, 0, 0], joint=["q1"]),
            "joint",
            "['armature', 'joints', 'engine']",
        ),
        (lambda: rd.batch.jacobians(arm7, q[None], threds=2), "threds", "['threads', 'executor']"),
        (
            lambda: rd.batch.operational_inertias(arm7, q[None], armatures=False),
            "armatures",
            "['armature', 'joints', 'engine', 'threads', 'executor']",
        ),
        (
            lambda: rd.crosscheck(arm7, q, chunks=2),
            "chunks",
            "['threads', 'executor', 'chunk', 'seed']",
        ),
        (
            lambda: rd.load("arm7", rests="home"),
            "rests",
            "['strict', 'site', 'disabled_collisions', 'base', 'rest']",
        ),
    ]
    for call, name, valid in calls:
        with pytest.raises(rd.UnknownNameError) as info:
            call()
        assert str(info.value) == f"unknown option {name!r}; valid option names: {valid}"

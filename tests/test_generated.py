"""Engine agreement on arms nobody hand-tuned: random MJCF from :mod:`redundancy.generate`.

Each drawn arm is loaded into both engines; the compiled models must be equivalent, and the
site pose, J, dJ/dq, M and gravity must agree at poses drawn inside the joint ranges, as must
the collision distances of MuJoCo's pair set (coal against ``mj_geomDistance``). A failure
shrinks to a small model. The number of models scales with the hypothesis profile: 100 by
default, 2000 under ``HYPOTHESIS_PROFILE=redundancy-thorough``.

Every class of disagreement these properties found has a regression test below, holding the
shrunk model: the library now refuses it with a clear error, or the disagreement is a known
engine difference that the property explains (MuJoCo's capsule-box collider,
``mj_geomDistance`` on two geoms with one centre, and both engines' rounding on nearly
parallel capsules).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import redundancy as rd
from redundancy import collision as col
from redundancy.generate import (
    HELD_FEATURES,
    REFUSED_FEATURES,
    RESOLVED_FEATURES,
    GeneratedArm,
    arms,
    held_arms,
    refused_arms,
    resolved_arms,
)
from redundancy.testing import PROFILES, poses

from .fullmodel import largest_difference_to_full_model

#: The loaded profile's examples per property: 60 under "redundancy-ci", 1000 under
#: "redundancy-thorough".
EXAMPLES = settings().max_examples
#: Generated models per run: 100 by default, 2000 under the thorough profile.
N_MODELS = 100 if EXAMPLES < PROFILES["redundancy-thorough"] else 2 * EXAMPLES
BAND = col.AMBIGUITY_BAND
TIGHT = 1e-9
CURVED = {"cylinder", "ellipsoid"}
#: Counts for the closing note (printed with -s): models checked and explained differences.
SEEN: dict[str, int] = {
    "models": 0,
    "capsule-box depth missed by MuJoCo": 0,
    "coincident geoms at distance 0 by MuJoCo": 0,
}


def _segment_crosses_box(p0: np.ndarray, p1: np.ndarray, half: np.ndarray) -> bool:
    """Whether the segment p0-p1 (box frame [m]) meets the box of half-sizes ``half``."""
    t0, t1 = 0.0, 1.0
    d = p1 - p0
    for k in range(3):
        if abs(d[k]) < 1e-15:
            if abs(p0[k]) > half[k]:
                return False
            continue
        a, b = sorted(((-half[k] - p0[k]) / d[k], (half[k] - p0[k]) / d[k]))
        t0, t1 = max(t0, a), min(t1, b)
        if t0 > t1:
            return False
    return True


def _placed(arm: rd.Arm, q: np.ndarray) -> Any:
    """A fresh MjData of the arm's model with its geoms placed at ``q`` (mj_kinematics)."""
    import mujoco

    d = mujoco.MjData(arm.mj_model)
    d.qpos[:] = q
    mujoco.mj_kinematics(arm.mj_model, d)
    return d


def _capsule_through_box(arm: rd.Arm, pair: col.GeomPair, q: np.ndarray) -> bool:
    """True when a capsule's segment passes through a box: they overlap by at least its radius.

    MuJoCo's capsule-box collider (and ``mj_geomDistance``) can miss such a deep overlap and
    report the pair apart; coal reports it. This independent check explains the difference.
    """
    if pair.types != frozenset({"capsule", "box"}):
        return False
    import mujoco

    m, d = arm.mj_model, _placed(arm, q)
    cap, box = (pair.geom1, pair.geom2)
    if int(m.geom_type[cap]) != int(mujoco.mjtGeom.mjGEOM_CAPSULE):
        cap, box = box, cap
    R = d.geom_xmat[box].reshape(3, 3)
    axis = d.geom_xmat[cap].reshape(3, 3)[:, 2] * m.geom_size[cap, 1]
    ends = [R.T @ (d.geom_xpos[cap] + s * axis - d.geom_xpos[box]) for s in (-1.0, 1.0)]
    return _segment_crosses_box(ends[0], ends[1], m.geom_size[box])


def _coincident_in_contact(arm: rd.Arm, pair: col.GeomPair, q: np.ndarray) -> bool:
    """True when the geoms' centres coincide and MuJoCo's own collider finds them overlapping.

    ``mj_geomDistance`` can return exactly 0 for two geoms whose centres coincide (its search
    starts along the line between them, which is then no direction); ``mj_collision``'s
    colliders do not start there, and list the pair in contact. This check explains the
    difference with MuJoCo's own answer (its box-box depth, per contact point, need not be
    coal's least translation out).
    """
    ch = col.checker(arm)
    contacts = [c for c in ch.contacts(q) if c.pair == pair]
    d = _placed(arm, q)
    same = np.array_equal(d.geom_xpos[pair.geom1], d.geom_xpos[pair.geom2])
    return same and any(c.distance < 0 for c in contacts)


def _parallel_capsules_tol(arm: rd.Arm, pair: col.GeomPair, q: np.ndarray) -> float:
    """The rounding bound of two capsules' distance where their axes are nearly parallel [m].

    The closest points of two segments at angle theta come from a 2 x 2 solve whose
    determinant is sin^2 theta, so rounding (eps) grows to about eps L / sin^2 theta: at
    sin theta = 7.3e-6 coal and MuJoCo each missed the exact 0.126 m by 2.3e-7, one on each
    side. Four times that bound; exactly parallel axes take the engines' own parallel branch.
    """
    m, d = arm.mj_model, _placed(arm, q)
    g1, g2 = pair.geom1, pair.geom2
    axes = [d.geom_xmat[g].reshape(3, 3)[:, 2] for g in (g1, g2)]
    sin2 = float(np.sum(np.cross(*axes) ** 2))
    if sin2 == 0.0:
        return TIGHT
    length = 2.0 * float(m.geom_size[g1, 1] + m.geom_size[g2, 1])
    return 4.0 * np.finfo(float).eps * length / sin2


def assert_distances_agree(arm: rd.Arm, q: np.ndarray) -> None:
    """coal against ``mj_geomDistance`` on every pair (tolerances as in test_collision)."""
    ch = col.checker(arm)
    ccd = max(float(arm.mj_model.opt.ccd_tolerance), TIGHT)
    d_coal = ch.distance_values(q, "coal")
    d_mj = ch.distance_values(q, "mujoco")
    for pair, a, b in zip(ch.pairs, d_coal, d_mj, strict=True):
        if a > BAND and b > BAND:
            tol = ccd if pair.types & CURVED else TIGHT
            if pair.types == {"capsule"}:  # capped at MuJoCo's own distance tolerance
                tol = max(tol, min(ccd, _parallel_capsules_tol(arm, pair, q)))
            assert abs(a - b) <= tol, (pair.label, a, b)
        elif (a < -BAND) != (b < -BAND) and max(abs(a), abs(b)) > BAND:
            if b == 0.0 and _coincident_in_contact(arm, pair, q):
                SEEN["coincident geoms at distance 0 by MuJoCo"] += 1
                continue
            assert a < 0 < b and _capsule_through_box(arm, pair, q), (pair.label, a, b)
            SEEN["capsule-box depth missed by MuJoCo"] += 1


def assert_engines_agree(gen: GeneratedArm, qs: list[np.ndarray]) -> rd.Arm:
    arm = rd.load_string(gen.xml, frame=gen.frame)
    report = rd.compare_models(arm)
    assert report.equivalent, "\n".join(report.lines())
    cc = rd.crosscheck(arm, np.array(qs))
    assert cc.ok, "\n".join(cc.lines())
    for q in qs:
        assert_distances_agree(arm, q)
    return arm


@settings(max_examples=N_MODELS, suppress_health_check=[HealthCheck.too_slow])
@given(arms(), st.data())
def test_generated_arms_agree(gen: GeneratedArm, data: st.DataObject) -> None:
    arm = rd.load_string(gen.xml, frame=gen.frame)
    qs = [data.draw(poses(arm), label="q") for _ in range(2)]
    assert_engines_agree(gen, qs)
    SEEN["models"] += 1


@pytest.mark.parametrize("feature", HELD_FEATURES)
def test_held_variants_agree_with_the_whole_robot(feature: str) -> None:
    """A ball or free joint, another tree, another root body: held, and the engines agree with
    each other and with MuJoCo's model of the whole robot at rest (1e-9)."""

    @settings(max_examples=max(3, EXAMPLES // len(REFUSED_FEATURES)))
    @given(held_arms((feature,)), st.data())
    def check(gen: GeneratedArm, data: st.DataObject) -> None:
        arm = rd.load_string(gen.xml, frame=gen.frame)
        qs = [data.draw(poses(arm), label="q") for _ in range(2)]
        assert_engines_agree(gen, qs)
        for q in qs:
            assert largest_difference_to_full_model(arm, q) < 1e-9
        if feature in ("ball joint", "free joint"):
            assert "j0" in arm.held and "j0" not in arm.joint_names
        if feature == "several root bodies":
            assert [a.name for a in arm.set_aside if a.what == "root body"] == ["other"]

    check()


@pytest.mark.parametrize("feature", REFUSED_FEATURES)
def test_refused_variants_are_refused(feature: str) -> None:
    """Each refusal, on random arms (the profile's examples shared among the features)."""

    @settings(max_examples=max(3, EXAMPLES // len(REFUSED_FEATURES)))
    @given(refused_arms((feature,)))
    def check(gen: GeneratedArm) -> None:
        with pytest.raises(rd.UnsupportedFeatureError) as exc:
            rd.load_string(gen.xml, frame=gen.frame)
        assert exc.value.feature == gen.refused == feature, str(exc.value)
        assert str(exc.value).startswith(f"unsupported feature: {feature} (")

    check()


@pytest.mark.parametrize("feature", RESOLVED_FEATURES)
def test_resolved_variants_agree_with_mujoco(feature: str) -> None:
    """What Pinocchio's parser reads differently, on random arms: Pinocchio is given MuJoCo's
    compiled model, the load says so, and both engines agree with MuJoCo's model (1e-9)."""

    @settings(max_examples=max(3, EXAMPLES // len(RESOLVED_FEATURES)))
    @given(resolved_arms((feature,)), st.data())
    def check(gen: GeneratedArm, data: st.DataObject) -> None:
        arm = rd.load_string(gen.xml, frame=gen.frame)
        assert "whole model" in {b.quantity for b in arm.bridges}
        qs = [data.draw(poses(arm), label="q") for _ in range(2)]
        assert_engines_agree(gen, qs)
        for q in qs:
            assert largest_difference_to_full_model(arm, q) < 1e-9

    check()


@pytest.fixture(scope="module", autouse=True)
def _closing_note() -> object:
    """Print what the generated arms showed (visible with ``pytest -s``)."""
    yield
    print(
        f"\ngenerated arms: {SEEN['models']} models agreed; pairs where MuJoCo's capsule-box "
        f"collider missed a capsule through a box: {SEEN['capsule-box depth missed by MuJoCo']}; "
        f"coincident geoms at distance 0: {SEEN['coincident geoms at distance 0 by MuJoCo']}"
    )


# ------------------------------------------------------------------------------------------
# Regression tests: the shrunk model of every class of disagreement found.
# ------------------------------------------------------------------------------------------

ONE_JOINT = """<mujoco>
  <worldbody>
    <body name="b0">
      <joint name="j0" type="hinge"/>
      <geom type="sphere" size="0.01"/>
      <site name="tip"/>
    </body>
  </worldbody>
</mujoco>
"""


def test_one_joint_arm() -> None:
    """Class 1: eigenpy returns Pinocchio's 6 x 1 Jacobians as vectors of shape (6,)."""
    arm = rd.load_string(ONE_JOINT, frame="tip")
    assert arm.jacobian([0.3], engine="pinocchio").shape == (6, 1)
    assert rd.compare_models(arm).equivalent
    assert rd.crosscheck(arm, np.array([[0.3], [-1.2]])).ok


def _model(
    default: str, body: str = "", joint: str = '<joint name="j0" axis="0 1 0"/>', top: str = ""
) -> str:
    return f"""<mujoco>{top}
  <default>{default}</default>
  <worldbody>
    <body name="b0" {body}>{joint}
      <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.03"/>
      <body name="b1" pos="0 0 0.3">
        <joint name="j1" axis="1 0 0"/>
        <geom type="box" size="0.05 0.02 0.1" pos="0 0 0.1"/>
        <site name="tip" pos="0 0 0.2"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


#: Shrunk models of each class Pinocchio 4.1 reads differently, the cause the strict load
#: names (Pinocchio is given MuJoCo's compiled model), and a quantity that differs when
#: Pinocchio reads the file itself (``strict=False``).
READ_DIFFERENTLY = [
    pytest.param(
        _model('<joint pos="0 0.1 0"/>'),
        "joint pos in <default class='main'> (Pinocchio's parser does not apply it)",
        "joint axis line offset",
        id="joint-pos-default",
    ),
    pytest.param(
        _model(
            '<default class="A"><joint type="slide" axis="1 0 0"/></default>'
            '<default class="B"><joint armature="0.1"/></default>',
            body='childclass="A"',
            joint='<joint name="j0" class="B"/>',
        ),
        "<joint name='j0' class='B'> inside childclass 'A' (Pinocchio's parser merges the two "
        "classes)",
        "joint type",
        id="class-merged-with-childclass",
    ),
]


@pytest.mark.parametrize(("xml", "message", "quantity"), READ_DIFFERENTLY)
def test_read_differently_is_served_or_reported(xml: str, message: str, quantity: str) -> None:
    arm = rd.load_string(xml, frame="tip")
    (note,) = [b for b in arm.bridges if b.quantity == "whole model"]
    assert note.source.endswith(f"because of {message}")
    assert rd.compare_models(arm).equivalent
    for q in ([0.1, 0.2], [-1.0, 0.7]):
        assert largest_difference_to_full_model(arm, np.array(q)) < 1e-12
    report = rd.compare_models(rd.load_string(xml, frame="tip", strict=False))
    assert quantity in {d.quantity for d in report.differences}, report.lines()


#: Shrunk models of classes Pinocchio 4.1 reads differently that the loader bridges:
#: accepted in strict mode, the bridge reported, the engines agreeing.
BRIDGED = [
    pytest.param(_model('<geom mass="3"/>'), "body inertia", id="geom-mass-default"),
    pytest.param(_model("", top='<compiler boundmass="10"/>'), "body inertia", id="boundmass"),
    pytest.param(_model("", top='<compiler boundinertia="1"/>'), "body inertia", id="boundinertia"),
]


@pytest.mark.parametrize(("xml", "quantity"), BRIDGED)
def test_read_differently_and_bridged(xml: str, quantity: str) -> None:
    arm = rd.load_string(xml, frame="tip")
    assert quantity in {b.quantity for b in arm.bridges}
    assert rd.compare_models(arm).equivalent
    assert rd.crosscheck(arm, np.array([[0.3, -0.4], [1.2, 2.0]])).ok


def test_class_refining_the_childclass_is_accepted() -> None:
    """A class that descends from the body's childclass is merged harmlessly (arm7 does it)."""
    xml = _model(
        '<default class="A"><joint type="slide" axis="1 0 0"/>'
        '<default class="B"><joint type="hinge" axis="0 0 1" armature="0.1"/></default></default>',
        body='childclass="A"',
        joint='<joint name="j0" class="B"/>',
    )
    arm = rd.load_string(xml, frame="tip")
    assert arm.joint_types == ("hinge", "slide")
    assert rd.compare_models(arm).equivalent
    assert rd.crosscheck(arm, np.array([0.4, 0.05])).ok


CAPSULE_THROUGH_BOX = """<mujoco>
  <compiler angle="radian" autolimits="true" eulerseq="zyx"/>
  <worldbody>
    <body name="b0">
      <geom type="sphere" size="0.062"/>
      <body name="b1">
        <geom type="capsule" size="0.016 0.125" euler="0 0 1"/>
        <body name="b2">
          <joint name="j0" type="hinge"/>
          <geom type="box" size="0.062 0.031 0.062"/>
          <site name="tip"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_mujoco_capsule_box_misses_a_capsule_through_the_box() -> None:
    """Class 2 (reported to collision.py's owner): a capsule whose axis passes through a box.

    coal gives the true depth (the capsule must move 0.078 m = half the box's 0.062 plus the
    radius 0.016 to get out); MuJoCo's capsule-box collider and ``mj_geomDistance`` say the
    geoms are 3 mm apart, and ``mj_collision`` lists no contact for the pair.
    """
    arm = rd.load_string(CAPSULE_THROUGH_BOX, frame="tip")
    ch = col.checker(arm)
    pair = next(p for p in ch.pairs if p.types == frozenset({"capsule", "box"}))
    k = ch.pairs.index(pair)
    q = np.zeros(1)
    assert _capsule_through_box(arm, pair, q)
    assert ch.distance_values(q, "coal")[k] == pytest.approx(-0.078, abs=1e-6)
    assert ch.distance_values(q, "mujoco")[k] > 0
    assert pair not in ch.contact_pairs(q)


#: Class 3: two boxes on two joints whose centres coincide at q = 0, turned off the axes (the
#: shrunk model of a 7-joint generated arm, thorough profile, seed 1).
COINCIDENT_BOXES = """
<mujoco>
  <worldbody>
    <body name="base" quat="0.9 0.1 0 0">
      <body name="b8"><joint name="j5"/><geom type="box" size="0.062 0.062 0.062"/></body>
      <body name="b9"><joint name="j6"/><geom type="box" size="0.062 0.062 0.062"/>
        <site name="tip"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_mujoco_geom_distance_puts_coincident_boxes_at_zero() -> None:
    """Class 3: ``mj_geomDistance`` of two boxes with one centre, turned, is exactly 0.

    coal and MuJoCo's own box-box collider (``mj_collision``) both give the true depth, the
    box's full width 0.124 m; the property explains the difference by them.
    """
    arm = rd.load_string(COINCIDENT_BOXES, frame="tip")
    ch = col.checker(arm)
    (pair,) = ch.pairs
    q = np.zeros(1)  # the arm is j6; j5 is held at 0
    coal = ch.distance_values(q, "coal")[0]
    assert coal == pytest.approx(-0.124, abs=1e-6)
    assert ch.distance_values(q, "mujoco")[0] == 0.0
    assert _coincident_in_contact(arm, pair, q)
    assert min(c.distance for c in ch.contacts(q)) == pytest.approx(coal, abs=1e-6)
    assert_distances_agree(arm, q)
    assert_distances_agree(arm, np.array([0.1]))  # b9 turned about the shared centre: they agree


#: Class 4: two capsules whose axes are 7.3e-6 rad from parallel (3.1416 for pi), 0.25 m
#: apart (the shrunk model of a 7-joint generated arm, thorough profile, seed 7).
_BALL = '<geom type="sphere" size="0.062"/>'
NEARLY_PARALLEL_CAPSULES = "".join(
    [
        '<mujoco><compiler angle="radian" eulerseq="zxz"/>',
        '<default><default class="A"><joint type="hinge"/><geom/></default></default>',
        '<worldbody><body name="b0" childclass="A">',
        *(f'<joint name="j{k}"/>{_BALL}<body name="b{k + 1}">' for k in range(2)),
        f'<joint name="j2"/>{_BALL}',
        *(f'<body name="b{k}"><joint name="j{k}"/>{_BALL}' for k in (3, 4)),
        '<body name="b5"><joint name="j5"/><geom type="capsule" size="0.062 0.031"/>',
        "</body></body></body>",
        '<body name="b6" pos="0 0.25 0"><joint name="j6"/><site name="tip"/>',
        '<geom type="capsule" size="0.062 0.125" euler="0 3.1416 0"/></body>',
        "</body></body></body></worldbody></mujoco>",
    ]
)


def test_nearly_parallel_capsules_are_held_to_their_rounding_bound() -> None:
    """Class 4: the exact distance is 0.25 - 2 x 0.062 = 0.126 m; each engine is within its
    segment solve's rounding bound of it (the property's tolerance for such pairs)."""
    arm = rd.load_string(NEARLY_PARALLEL_CAPSULES, frame="tip")
    ch = col.checker(arm)
    k, pair = next((k, p) for k, p in enumerate(ch.pairs) if p.label == "b5 geom 0 / b6 geom 0")
    q = np.zeros(arm.nq)
    bound = _parallel_capsules_tol(arm, pair, q)
    assert 1e-9 < bound < 1e-5
    for engine in ("coal", "mujoco"):
        assert abs(ch.distance_values(q, engine)[k] - 0.126) <= bound
    assert_distances_agree(arm, q)


def test_segment_box_helper() -> None:
    half = np.array([0.1, 0.2, 0.3])
    assert _segment_crosses_box(np.array([-1.0, 0, 0]), np.array([1.0, 0, 0]), half)
    assert not _segment_crosses_box(np.array([-1.0, 0.5, 0]), np.array([1.0, 0.5, 0]), half)
    assert _segment_crosses_box(np.zeros(3), np.zeros(3), half)


def test_generated_site_is_a_deprecated_name_of_frame() -> None:
    gen = GeneratedArm("<mujoco/>")
    assert gen.frame == "tip"
    with pytest.warns(
        DeprecationWarning, match=r"^GeneratedArm.site is deprecated: use GeneratedArm.frame$"
    ):
        assert gen.site == "tip"

"""Self-collision: MuJoCo's pair set, coal against MuJoCo, statistics, path checking.

Tolerances (each with its reason):

* ``TIGHT`` 1e-9 m: separated distances of sphere, capsule, box and plane pairs. MuJoCo
  computes these in closed form; coal too, or its GJK ends on a polytope feature, within its
  relative tolerance 1e-10 (``COAL_GJK_TOLERANCE``) otherwise: 1e-9 m covers distances up to
  a few metres. Measured differences are below 2e-11 m.
* ``ccd_tolerance`` (MuJoCo's ``opt.ccd_tolerance``, 1e-6 m by default): separated distances
  of pairs with a cylinder or an ellipsoid, curved shapes on which GJK converges only
  asymptotically. MuJoCo's GJK stops at ``ccd_tolerance``, coal's at a relative gap of
  1e-10; measured differences are below 1.5e-7 m.
* Penetration: equal to ``TIGHT`` only where both engines compute the exact penetration depth
  in closed form (sphere, capsule and box among themselves except capsule-box, anything
  against a plane). Elsewhere the engines' depth definitions differ and only the sign is
  compared: MuJoCo's primitive colliders (capsule-box, sphere-cylinder) report the depth of
  a contact point along a chosen normal, not the pair's minimum translation distance; coal's
  EPA computes the latter, and MuJoCo's own EPA stops at a different tolerance (measured
  differences: up to 8 cm for deep capsule-box overlaps, 1e-4 m for EPA pairs).
* ``AMBIGUITY_BAND`` 1e-6 m: a pair closer than this to its contact threshold may be
  reported as touching by one engine and not by the other without either being wrong (each
  is only that accurate), so it is left out of the exact touching-set comparison.
"""

from __future__ import annotations

import copy
import gc
import itertools
import os
import pickle
import re
import threading
import weakref
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import mujoco
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import redundancy as rd
from redundancy import collision as col
from redundancy.collision import pathcheck as pc
from redundancy.collision import statistics as colstats
from redundancy.testing import poses

from .corpus import write_binary_stl, write_obj

TIGHT = 1e-9
BAND = col.AMBIGUITY_BAND
CURVED = {"cylinder", "ellipsoid"}
EXACT_DEPTH = {
    frozenset(t)
    for t in [
        ("sphere",),
        ("sphere", "capsule"),
        ("capsule",),
        ("sphere", "box"),
        ("box",),
    ]
}


def separated_tol(pair: col.GeomPair, model: mujoco.MjModel) -> float:
    """Tolerance on a separated distance, by geom types (see the module docstring)."""
    if "plane" in pair.types or not (pair.types & CURVED):
        return TIGHT
    return max(float(model.opt.ccd_tolerance), TIGHT)


def exact_depth(pair: col.GeomPair) -> bool:
    """Both engines compute the exact penetration depth for this pair of types."""
    return "plane" in pair.types or pair.types in EXACT_DEPTH


# ==========================================================================================
# Models
# ==========================================================================================

#: Every primitive type, offsets and rotations on geoms and bodies, a welded body, a floor.
TYPED = """
<mujoco model="typed">
  <compiler angle="radian" autolimits="true"/>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1" pos="0 0 -0.05"/>
    <body name="base" pos="0 0 0.1">
      <joint name="j1" axis="0 0 1" range="-3 3"/>
      <geom name="base_box" type="box" size="0.08 0.06 0.05"/>
      <geom name="base_cyl" type="cylinder" size="0.04 0.06" pos="0.1 0 0.05" euler="0 1.2 0"/>
      <geom name="base_sph" type="sphere" size="0.04" pos="-0.1 0.05 0.06"/>
      <body name="upper" pos="0 0 0.1">
        <joint name="j2" axis="0 1 0" range="-2.5 2.5" pos="0 0 -0.02"/>
        <geom name="upper_cap" type="capsule" fromto="0 0 0 0 0 0.3" size="0.04"/>
        <body name="bracket" pos="0.05 0 0.15" quat="0.9238795 0 0.3826834 0">
          <geom name="bracket_ell" type="ellipsoid" size="0.03 0.05 0.02"/>
        </body>
        <body name="fore" pos="0 0 0.3">
          <joint name="j3" axis="1 0 0" range="-2.8 2.8"/>
          <geom name="fore_cyl" type="cylinder" fromto="0 0 0 0 0.05 0.25" size="0.035"/>
          <body name="hand" pos="0 0.05 0.25" euler="0.2 0 0">
            <joint name="j4" axis="0 1 0" range="-2.8 2.8"/>
            <geom name="hand_sph" type="sphere" size="0.05" pos="0 0 0.06"/>
            <geom name="hand_box" type="box" size="0.02 0.05 0.03" pos="0 0 0.13"
                  euler="0.3 0.2 0.1"/>
            <geom name="hand_cap" type="capsule" size="0.02" fromto="-0.05 0 0.1 0.05 0.02 0.1"/>
            <geom name="hand_cyl" type="cylinder" size="0.03 0.02" pos="0 0.06 0.1" euler="1 0 0"/>
            <geom name="hand_ell" type="ellipsoid" size="0.02 0.03 0.04" pos="0 -0.06 0.1"/>
            <site name="ee" pos="0 0 0.16"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

#: A telescoping arm: a slide joint between two hinges, for the path checker's motion bound.
SLIDER = """
<mujoco model="slider">
  <compiler angle="radian" autolimits="true"/>
  <worldbody>
    <body name="b1">
      <joint name="h1" axis="0 0 1" range="-3 3"/>
      <geom name="g1" type="box" size="0.05 0.05 0.1" pos="0 0 0.1"/>
      <body name="b2" pos="0 0 0.2">
        <joint name="h2" axis="0 1 0" range="-2.6 2.6"/>
        <geom name="g2" type="capsule" size="0.03" fromto="0 0 0 0 0 0.15"/>
        <body name="b3" pos="0 0 0.15">
          <joint name="s3" type="slide" axis="0 0 1" range="-0.1 0.2"/>
          <geom name="g3" type="cylinder" size="0.025 0.06" pos="0 0 0.06"/>
          <body name="b4" pos="0 0 0.12">
            <joint name="h4" axis="1 0 0" range="-2.8 2.8" pos="0 0 0.01"/>
            <geom name="g4" type="capsule" size="0.025" fromto="0 0 0 0.05 0 0.15"/>
            <geom name="g4b" type="sphere" size="0.04" pos="0 0 0.18"/>
            <site name="ee" pos="0 0 0.2"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def chain(extra: str = "", option: str = "", geom: str = 'type="sphere" size="0.3"') -> str:
    """Three bodies on hinges, a -> b -> c, overlapping geoms ga, gb, gc."""
    return f"""
<mujoco>
  {option}
  <worldbody>
    <body name="a"><joint name="ja" axis="0 0 1"/><geom name="ga" {geom}/>
      <body name="b" pos="0 0 0.1"><joint name="jb" axis="0 1 0"/><geom name="gb" {geom}/>
        <body name="c" pos="0 0 0.1"><joint name="jc" axis="0 1 0"/><geom name="gc" {geom}/>
          <site name="ee"/>
        </body>
      </body>
    </body>
  </worldbody>
  {extra}
</mujoco>
"""


def labels(model: mujoco.MjModel | rd.Arm) -> set[str]:
    return {p.label for p in col.collision_pairs(model)}


def mj(xml: str) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(xml)


def mujoco_contact_pairs(m: mujoco.MjModel) -> set[tuple[int, int]]:
    """Geom pairs in MuJoCo's contact list after mj_forward at qpos0."""
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    return {tuple(sorted(map(int, g))) for g in d.contact.geom[: d.ncon]}


@pytest.fixture(scope="module")
def typed() -> rd.Arm:
    return rd.load_string(TYPED)


@pytest.fixture(scope="module")
def slider() -> rd.Arm:
    return rd.load_string(SLIDER)


@pytest.fixture(scope="module")
def arm(request: pytest.FixtureRequest) -> rd.Arm:
    """The arm fixture named by the parameter (see :func:`on_arms`)."""
    return request.getfixturevalue(request.param)


def on_arms(*names: str) -> pytest.MarkDecorator:
    """Run a property test once per arm fixture so named, as its ``arm`` argument."""
    return pytest.mark.parametrize("arm", names, indirect=True)


# ==========================================================================================
# The pair set
# ==========================================================================================


def test_parent_filter_on_by_default_and_off_with_the_flag() -> None:
    assert labels(mj(chain())) == {"ga / gc"}
    off = mj(chain(option='<option><flag filterparent="disable"/></option>'))
    assert labels(off) == {"ga / gb", "gb / gc", "ga / gc"}
    # Both are what MuJoCo itself finds when every geom overlaps every other.
    for m in (mj(chain()), off):
        assert mujoco_contact_pairs(m) == {(p.geom1, p.geom2) for p in col.collision_pairs(m)}


def test_world_exception_to_the_parent_filter() -> None:
    xml = """
<mujoco><worldbody>
  <geom name="floor" type="plane" size="1 1 0.1"/>
  <geom name="post" type="sphere" size="0.3"/>
  <body name="plate"><geom name="plate" type="box" size="0.3 0.3 0.1"/></body>
  <body name="a"><joint axis="0 0 1"/><geom name="ga" type="sphere" size="0.3"/>
    <body name="b"><joint axis="0 1 0"/><geom name="gb" type="sphere" size="0.3"/></body>
  </body>
</worldbody></mujoco>"""
    m = mj(xml)
    got = labels(m)
    # a's parent is the world, yet a collides with world geoms and with the world-welded
    # plate (the parent filter never applies to the world's weld group).
    assert {"floor / ga", "ga / post", "ga / plate"} <= got
    assert {"floor / gb", "gb / post", "gb / plate"} <= got
    # Geoms welded to the world never collide with each other (plane-plane has no collider).
    assert not got & {"floor / post", "floor / plate", "plate / post"}
    assert "ga / gb" not in got
    assert mujoco_contact_pairs(m) == {(p.geom1, p.geom2) for p in col.collision_pairs(m)}


def test_welded_bodies_and_same_body_geoms_never_collide() -> None:
    xml = """
<mujoco><worldbody>
  <body name="a"><joint axis="0 0 1"/><geom name="a1" size="0.3"/><geom name="a2" size="0.3"/>
    <body name="w"><geom name="w" size="0.3"/>
      <body name="c"><joint axis="0 1 0"/><geom name="c" size="0.3"/>
        <body name="d"><joint axis="1 0 0"/><geom name="d" size="0.3"/></body>
      </body>
    </body>
  </body>
</worldbody></mujoco>"""
    m = mj(xml)
    got = labels(m)
    # w is welded to a (no joint): no a/w pair; c's parent w is in a's weld group, so the
    # parent filter removes c against a1, a2 and w alike.
    assert got == {"a1 / d", "a2 / d", "d / w"}
    assert mujoco_contact_pairs(m) == {(p.geom1, p.geom2) for p in col.collision_pairs(m)}


@pytest.mark.parametrize(
    ("t1", "a1", "t2", "a2", "tested"),
    [
        (1, 1, 1, 1, True),
        (1, 0, 0, 1, True),  # one-sided match is enough: contype1 & conaffinity2
        (0, 1, 1, 0, True),
        (1, 0, 1, 0, False),
        (2, 2, 1, 1, False),
        (3, 0, 0, 2, True),
        (0, 0, 1, 1, False),
    ],
)
def test_bitmasks_are_or_of_the_two_one_sided_matches(
    t1: int, a1: int, t2: int, a2: int, tested: bool
) -> None:
    xml = (
        chain(geom='type="sphere" size="0.3"')
        .replace(
            '<geom name="ga" type="sphere" size="0.3"/>',
            f'<geom name="ga" type="sphere" size="0.3" contype="{t1}" conaffinity="{a1}"/>',
        )
        .replace(
            '<geom name="gc" type="sphere" size="0.3"/>',
            f'<geom name="gc" type="sphere" size="0.3" contype="{t2}" conaffinity="{a2}"/>',
        )
    )
    m = mj(xml)
    assert ("ga / gc" in labels(m)) is tested
    assert mujoco_contact_pairs(m) == {(p.geom1, p.geom2) for p in col.collision_pairs(m)}


def test_exclude_removes_and_pair_adds_bypassing_every_filter() -> None:
    extra = """<contact>
      <exclude body1="c" body2="a"/>
      <pair geom1="gb" geom2="ga" margin="0.01" gap="0.002"/>
    </contact>"""
    m = mj(chain(extra))
    pairs = col.collision_pairs(m)
    assert [p.label for p in pairs] == ["ga / gb"]
    p = pairs[0]
    assert p.explicit and p.margin == 0.01 and p.gap == 0.002
    assert p.threshold == pytest.approx(0.012)
    # An explicit pair even between bitmask-less geoms, and replacing a filtered-in pair.
    m2 = mj(
        chain(
            '<contact><pair geom1="gc" geom2="ga"/></contact>',
            geom='type="sphere" size="0.3" contype="0"',
        )
    )
    assert [(q.label, q.explicit) for q in col.collision_pairs(m2)] == [("ga / gc", True)]
    m3 = mj(chain('<contact><pair geom1="gc" geom2="ga" margin="0.02"/></contact>'))
    assert [(q.label, q.explicit, q.margin) for q in col.collision_pairs(m3)] == [
        ("ga / gc", True, 0.02)
    ]
    for model in (m, m2, m3):
        assert mujoco_contact_pairs(model) == {
            (q.geom1, q.geom2) for q in col.collision_pairs(model)
        }


@pytest.mark.parametrize("flag", ["contact", "constraint"])
def test_no_pairs_when_contacts_are_disabled(flag: str) -> None:
    m = mj(
        chain(
            '<contact><pair geom1="ga" geom2="gb"/></contact>',
            option=f'<option><flag {flag}="disable"/></option>',
        )
    )
    assert col.collision_pairs(m) == ()
    assert mujoco_contact_pairs(m) == set()


def test_margins_and_gaps_follow_getmargin_and_override() -> None:
    geom = 'type="sphere" size="0.3" margin="0.01" gap="0.004"'
    p = col.collision_pairs(mj(chain(geom=geom)))[0]
    assert (p.margin, p.gap) == (pytest.approx(0.02), pytest.approx(0.008))
    over = mj(chain(geom=geom, option='<option o_margin="0.05"><flag override="enable"/></option>'))
    q = col.collision_pairs(over)[0]
    assert (q.margin, q.gap) == (pytest.approx(0.05), pytest.approx(0.008))


def test_contacts_are_listed_below_margin_plus_gap() -> None:
    """MuJoCo 4 lists a contact when dist < margin + gap; the pair's threshold says so."""
    xml = """
<mujoco><worldbody>
  <body name="a"><joint name="s" type="slide" axis="1 0 0"/>
    <geom name="ga" size="0.1" margin="0.01" gap="0.005"/><site name="ee"/></body>
  <body name="b" pos="0.3 0 0"><geom name="gb" size="0.1"/></body>
</worldbody></mujoco>"""
    m = mj(xml)
    (p,) = col.collision_pairs(m)
    d = mujoco.MjData(m)
    for gap in np.linspace(-0.02, 0.03, 51):
        d.qpos[0] = 0.3 - 0.2 - gap
        mujoco.mj_forward(m, d)
        if abs(gap - p.threshold) > 1e-9:
            assert (d.ncon > 0) == (gap < p.threshold), gap


@st.composite
def random_models(draw: st.DrawFn) -> str:
    """A random tree with random welds, bitmasks, excludes, pairs and filterparent flag."""
    nbody = draw(st.integers(1, 6))
    parents = [draw(st.integers(0, i)) for i in range(nbody)]  # body i+1's parent
    jointed = [draw(st.booleans()) for _ in range(nbody)]
    bits = st.integers(0, 3)
    geoms: dict[int, list[tuple[str, int, int]]] = {b: [] for b in range(nbody + 1)}
    n = 0
    for b in range(nbody + 1):
        for _ in range(draw(st.integers(0, 2))):
            geoms[b].append((f"g{n}", draw(bits), draw(bits)))
            n += 1
    world_plane = draw(st.booleans())
    names = [g[0] for b in geoms for g in geoms[b]]
    body_names = ["world"] + [f"b{i + 1}" for i in range(nbody)]
    excludes = draw(st.sets(st.tuples(st.integers(0, nbody), st.integers(0, nbody)), max_size=4))
    excludes = {tuple(sorted(e)) for e in excludes if e[0] != e[1]}
    pairs = set()
    if len(names) >= 2:
        raw = draw(st.sets(st.tuples(st.sampled_from(names), st.sampled_from(names)), max_size=3))
        pairs = {tuple(sorted(p)) for p in raw if p[0] != p[1]}
    filterparent = draw(st.booleans())
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))

    def geom_xml(b: int) -> str:
        out = []
        for name, ct, ca in geoms[b]:
            pos = " ".join(f"{x:.3f}" for x in rng.uniform(-0.05, 0.05, 3))
            out.append(
                f'<geom name="{name}" size="0.5" pos="{pos}" contype="{ct}" conaffinity="{ca}"/>'
            )
        return "".join(out)

    def body_xml(b: int) -> str:
        kids = "".join(body_xml(c + 1) for c in range(nbody) if parents[c] == b and c + 1 != b)
        joint = f'<joint axis="0 0 1" name="j{b}"/>' if jointed[b - 1] else ""
        inertial = '<inertial pos="0 0 0" mass="1" diaginertia="0.1 0.1 0.1"/>'
        return f'<body name="b{b}" pos="0 0 0.01">{joint}{inertial}{geom_xml(b)}{kids}</body>'

    world = geom_xml(0) + (
        '<geom name="floor" type="plane" size="1 1 0.1"/>' if world_plane else ""
    )
    world += "".join(body_xml(c + 1) for c in range(nbody) if parents[c] == 0)
    contact = "".join(
        f'<exclude body1="{body_names[a]}" body2="{body_names[b]}"/>' for a, b in sorted(excludes)
    ) + "".join(f'<pair geom1="{a}" geom2="{b}"/>' for a, b in sorted(pairs))
    flag = "" if filterparent else '<option><flag filterparent="disable"/></option>'
    return f"<mujoco>{flag}<worldbody>{world}</worldbody><contact>{contact}</contact></mujoco>"


@given(random_models())
def test_pair_set_is_what_mujoco_tests_on_random_models(xml: str) -> None:
    """Every geom overlaps every other at qpos0, so MuJoCo's contacts are its tested pairs."""
    m = mj(xml)
    ours = {(p.geom1, p.geom2) for p in col.collision_pairs(m)}
    assert mujoco_contact_pairs(m) == ours, xml


def test_arm7_pair_set_is_every_non_adjacent_link_pair(arm7: rd.Arm) -> None:
    m = arm7.mj_model
    pairs = col.collision_pairs(arm7)
    coll = [g for g in range(m.ngeom) if m.geom_contype[g] or m.geom_conaffinity[g]]
    bodies = sorted({int(m.geom_bodyid[g]) for g in coll})
    # One collision geom per moving body, in a chain: every pair but the parent-child ones.
    assert len(coll) == len(bodies)
    assert len(pairs) == len(coll) * (len(coll) - 1) // 2 - (len(coll) - 1)
    for p in pairs:
        b1, b2 = m.geom_bodyid[p.geom1], m.geom_bodyid[p.geom2]
        assert m.body_parentid[b1] != b2 and m.body_parentid[b2] != b1
        assert not p.explicit and p.threshold == 0.0
    assert "link2 / link4" in {p.label for p in pairs}


def test_contact_filter_callback_is_refused() -> None:
    m = mj(chain())
    mujoco.set_mjcb_contactfilter(lambda m, d, g1, g2: 0)
    try:
        with pytest.raises(rd.UnsupportedFeatureError, match="contact filter callback"):
            col.collision_pairs(m)
    finally:
        mujoco.set_mjcb_contactfilter(None)


def test_unknown_pair_lists_the_pairs() -> None:
    pairs = col.collision_pairs(mj(chain()))
    with pytest.raises(rd.UnknownNameError) as err:
        col.find_pair(pairs, "ga", "gb")
    assert str(err.value) == "unknown geom pair 'ga / gb'; valid geom pair names: ['ga / gc']"
    assert col.find_pair(pairs, "gc", "ga").label == "ga / gc"


# ==========================================================================================
# Both engines: placements, distances, contacts
# ==========================================================================================


@on_arms("typed", "arm7")
@given(data=st.data())
def test_pinocchio_places_geoms_where_mujoco_does(arm: rd.Arm, data: st.DataObject) -> None:
    q = data.draw(poses(arm))
    assert col.checker(arm).placement_error(q) < 1e-12


def assert_engines_agree(arm: rd.Arm, q: np.ndarray) -> None:
    """coal against mj_geomDistance and against MuJoCo's contact list, at one pose."""
    ch = col.checker(arm)
    m = arm.mj_model
    coal_d = ch.distances(q, "coal")
    mj_d = ch.distances(q, "mujoco")
    for c, k in zip(coal_d.pairs, mj_d.pairs, strict=True):
        p = c.pair
        if c.distance > BAND and k.distance > BAND:
            assert abs(c.distance - k.distance) <= separated_tol(p, m), (
                p.label,
                c.distance,
                k.distance,
            )
            # Nearest points: as far apart as the distance says, for both engines.
            for e in (c, k):
                assert np.linalg.norm(e.point2 - e.point1) == pytest.approx(e.distance, abs=1e-6)
        elif c.distance < -BAND and k.distance < -BAND:
            if exact_depth(p):
                assert abs(c.distance - k.distance) <= TIGHT, (p.label, c.distance, k.distance)
        else:
            # Opposite signs only inside the band where neither engine can tell.
            assert abs(c.distance) <= BAND and abs(k.distance) <= BAND, (
                p.label,
                c.distance,
                k.distance,
            )
    # The touching pairs by coal are exactly the pairs MuJoCo lists contacts for.
    unclear = {e.pair for e in coal_d.pairs + mj_d.pairs if abs(e.clearance) < BAND}
    by_coal = {e.pair for e in coal_d.touching} - unclear
    by_mujoco = ch.contact_pairs(q) - unclear
    assert by_coal == by_mujoco, (
        sorted(x.label for x in by_coal),
        sorted(x.label for x in by_mujoco),
    )
    # And MuJoCo agrees with itself: mj_geomDistance's sign against mj_collision's list.
    assert ch.touching_pairs(q, "mujoco") - unclear == by_mujoco


@on_arms("typed", "arm7")
@given(data=st.data())
def test_engines_agree(arm: rd.Arm, data: st.DataObject) -> None:
    """On every primitive type, and on arm7: the issue's acceptance property (>= 1000
    examples under HYPOTHESIS_PROFILE=redundancy-thorough)."""
    q = data.draw(poses(arm))
    assert_engines_agree(arm, q)


@given(data=st.data())
def test_fast_contacts_are_mj_forward_contacts(arm7: rd.Arm, data: st.DataObject) -> None:
    """mj_kinematics + mj_collision finds what the lesson's mj_forward finds."""
    q = data.draw(poses(arm7))
    m = arm7.mj_model
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_forward(m, d)
    expected = sorted(
        (tuple(sorted(map(int, g))), round(float(x), 12))
        for g, x in zip(d.contact.geom[: d.ncon], d.contact.dist[: d.ncon], strict=True)
    )
    got = sorted(
        ((c.pair.geom1, c.pair.geom2), round(c.distance, 12)) for c in col.contacts(arm7, q)
    )
    assert got == expected


def test_contact_normal_points_from_geom1_to_geom2() -> None:
    # Geom 0 is a capsule (on the world), geom 1 a sphere: MuJoCo lists the sphere first
    # (it orders a contact's geoms by type).
    xml = """
<mujoco><worldbody>
  <geom name="cap" type="capsule" size="0.1 0.2"/>
  <body name="a" pos="0.15 0 0">
    <joint name="j" axis="0 0 1"/><geom name="ball" size="0.1"/><site name="ee"/>
  </body>
</worldbody></mujoco>"""
    arm = rd.load_string(xml)
    (c,) = col.contacts(arm, [0.0])
    assert (c.pair.name1, c.pair.name2) == ("cap", "ball")
    np.testing.assert_allclose(c.normal, [1.0, 0.0, 0.0], atol=1e-12)
    assert c.distance == pytest.approx(-0.05)


def test_distances_name_lookup_and_closest(arm7: rd.Arm) -> None:
    q = arm7.keyframe("home").copy()
    q[arm7.joint_index("j4")] = 2.9  # the lesson's fully folded elbow
    d = col.distances(arm7, q)
    assert d.of("link4", "link2").touching
    assert d.closest is not None and d.closest.distance == d.values.min()
    assert not d.free
    with pytest.raises(rd.UnknownNameError, match="valid geom pair names"):
        d.of("link1", "link2")  # parent and child: never tested
    with pytest.raises(rd.UnknownNameError) as err:
        col.distances(arm7, q, engine="fcl")  # type: ignore[arg-type]
    assert (
        str(err.value)
        == "unknown distance engine 'fcl'; valid distance engine names: ['coal', 'mujoco']"
    )


@given(data=st.data())
def test_distances_depend_on_the_pose_alone(arm7: rd.Arm, data: st.DataObject) -> None:
    """No warm start: the same pose gives the same distances whatever was queried before."""
    qs = data.draw(st.lists(poses(arm7), min_size=2, max_size=4))
    ch = col.checker(arm7)
    first = ch.distance_values(qs[0])
    for q in qs[1:]:
        ch.distance_values(q)
    np.testing.assert_array_equal(ch.distance_values(qs[0]), first)


def test_unnamed_body_with_geoms_is_refused() -> None:
    xml = chain().replace('<body name="c" pos="0 0 0.1">', '<body pos="0 0 0.1">')
    arm = rd.load_string(xml)
    with pytest.raises(rd.UnsupportedFeatureError, match="name the body"):
        col.CollisionChecker(arm)


def test_placement_mismatch_is_caught() -> None:
    import pinocchio as pin

    arm = rd.load_string(TYPED)
    pm = arm.pinocchio.model
    fid = pm.getFrameId("fore", pin.FrameType.BODY)
    frame = pm.frames[fid]
    frame.placement = frame.placement * pin.SE3(np.eye(3), np.array([0.0, 0.0, 1e-3]))
    pm.frames[fid] = frame
    with pytest.raises(rd.ModelError, match="do not see the same bodies"):
        col.CollisionChecker(arm)


def test_failed_epa_is_redone(monkeypatch: pytest.MonkeyPatch) -> None:
    """coal's EPA reports a failure as -DBL_MAX: the pair is redone with a looser EPA, and
    if that fails too, the overlap is bounded by the sum of the bounding radii."""
    import coal

    arm = rd.load(rd.model_path("arm7"), frame="ee")
    ch = col.CollisionChecker(arm)
    q = arm.keyframe("home").copy()
    q[arm.joint_index("j4")] = 2.9
    good = ch.distances(q)
    k = ch.pairs.index(ch.pair("link2", "link4"))
    scene = ch.coal_scene()
    raw = scene._raw_values

    def failing(q: np.ndarray) -> np.ndarray:
        out = raw(q)
        out[k] = -np.finfo(float).max
        return out

    monkeypatch.setattr(scene, "_raw_values", failing)
    redone = ch.distances(q)
    # EPA to 1e-4 m instead of 1e-6 m.
    assert redone.pairs[k].distance == pytest.approx(good.pairs[k].distance, abs=1e-4)
    # The looser EPA's witness points: as far apart as its depth, and where a depth error of
    # 1e-4 m lets them slide on curved surfaces: up to sqrt(2 r 1e-4) for a radius r.
    r, e = redone.pairs[k], good.pairs[k]
    assert np.linalg.norm(r.point2 - r.point1) == pytest.approx(-r.distance, abs=1e-4)
    slide = np.sqrt(2 * col.shapes.bounding_radius(arm.mj_model, e.pair.geom1) * 1e-4)
    assert np.linalg.norm(r.point1 - e.point1) < slide
    np.testing.assert_array_equal(np.delete(redone.values, k), np.delete(good.values, k))
    monkeypatch.setattr(coal, "distance", lambda *a: -np.finfo(float).max)
    m = arm.mj_model
    radius = [col.shapes.bounding_radius(m, g) for g in (ch.pairs[k].geom1, ch.pairs[k].geom2)]
    assert ch.distance_values(q)[k] == pytest.approx(-sum(radius))


# ==========================================================================================
# Statistics
# ==========================================================================================


def test_random_poses_are_the_lessons_draws(arm7: rd.Arm) -> None:
    rng = np.random.default_rng(1)
    lo, hi = arm7.mj_model.jnt_range[:, 0], arm7.mj_model.jnt_range[:, 1]
    lesson = np.array([rng.uniform(lo, hi) for _ in range(200)])
    np.testing.assert_array_equal(col.random_poses(arm7, 200, seed=1), lesson)


def test_statistics_count_poses_and_contacts_as_the_lesson_loop(arm7: rd.Arm) -> None:
    n = 600
    stats = col.collision_statistics(arm7, n, seed=1, distances="coal")
    # The lesson's loop (mj_forward per pose), counting both poses and contacts per pair.
    m = arm7.mj_model
    d = mujoco.MjData(m)
    hits, poses_per, contacts_per = 0, {}, {}
    for q in col.random_poses(arm7, n, seed=1):
        d.qpos[:] = q
        mujoco.mj_forward(m, d)
        hits += bool(d.ncon)
        seen = set()
        for g1, g2 in d.contact.geom[: d.ncon]:
            key = " / ".join(sorted((m.geom(int(g1)).name, m.geom(int(g2)).name)))
            contacts_per[key] = contacts_per.get(key, 0) + 1
            seen.add(key)
        for key in seen:
            poses_per[key] = poses_per.get(key, 0) + 1
    assert stats.n_poses == n and stats.poses_with_contact == hits
    assert hits > 0  # the sample does contain self-contacts
    assert {p.pair.label: p.poses for p in stats.pairs if p.poses} == poses_per
    assert {p.pair.label: p.contacts for p in stats.pairs if p.contacts} == contacts_per
    assert all(p.contacts >= p.poses for p in stats.pairs)
    assert stats.disagreements == 0
    # Closest approach: negative exactly for the pairs that touched in some pose.
    for p in stats.pairs:
        assert (p.closest < 0) == (p.poses > 0), p
    # The same sweep with MuJoCo's distances: same counts, same closest approach.
    other = col.collision_statistics(arm7, n, seed=1, distances="mujoco")
    for a, b in zip(stats.pairs, other.pairs, strict=True):
        assert (a.poses, a.contacts) == (b.poses, b.contacts)
        if a.closest > BAND and b.closest > BAND:
            assert abs(a.closest - b.closest) <= separated_tol(a.pair, m)
        else:
            assert (
                np.sign(a.closest) == np.sign(b.closest)
                or max(abs(a.closest), abs(b.closest)) < BAND
            )
    # Keyframes: MuJoCo's contact count there.
    for k in stats.keyframes:
        d.qpos[:] = k.q
        mujoco.mj_forward(m, d)
        assert k.contacts == d.ncon
        assert k.closest is not None and k.closest.distance == min(col.distances(arm7, k.q).values)
    text = "\n".join(stats.lines())
    assert "poses" in text and "contacts" in text


def test_statistics_on_given_poses_and_without_distances(arm7: rd.Arm) -> None:
    q = arm7.keyframe("home").copy()
    q[arm7.joint_index("j4")] = 2.9
    stats = col.collision_statistics(arm7, poses=[arm7.keyframe("home"), q], distances=None)
    assert stats.n_poses == 2 and stats.poses_with_contact == 1 and stats.seed is None
    assert stats.disagreements == -1 and all(np.isnan(p.closest) for p in stats.pairs)
    assert stats.share_with_contact == 0.5
    assert stats.of("link4", "link2").poses == 1


@pytest.mark.parametrize("prune", [True, False])
def test_statistics_cross_check_catches_a_wrong_engine(
    arm7: rd.Arm, monkeypatch: pytest.MonkeyPatch, prune: bool
) -> None:
    scene = col.checker(arm7).coal_scene()  # the coal side, as the sweep calls it
    right, right_placed = scene.distance_values, scene.placed_values
    monkeypatch.setattr(scene, "distance_values", lambda q: right(q) + 0.01)
    monkeypatch.setattr(scene, "placed_values", lambda *a: right_placed(*a) + 0.01)
    stats = col.collision_statistics(arm7, 300, seed=1, prune=prune)
    assert stats.poses_with_contact > 0
    assert stats.disagreements > 0


def test_unlimited_slide_cannot_be_sampled() -> None:
    arm = rd.load_string(SLIDER.replace('range="-0.1 0.2"', 'limited="false"'))
    with pytest.raises(rd.PoseError, match="unlimited slide"):
        col.random_poses(arm, 3)


# ==========================================================================================
# Path checking
# ==========================================================================================


@st.composite
def segments(draw: st.DrawFn, arm: rd.Arm) -> tuple[np.ndarray, np.ndarray]:
    """A start pose and an end pose: one joint or all moving, tiny to range-wide steps."""
    qa = draw(poses(arm))
    qb = draw(poses(arm))
    if draw(st.booleans()):
        k = draw(st.integers(0, arm.nq - 1))
        qb = np.where(np.arange(arm.nq) == k, qb, qa)
    scale = draw(st.sampled_from([1e-3, 1e-2, 0.1, 1.0]))
    return qa, np.clip(qa + scale * (qb - qa), arm.lower, arm.upper)


def geom_points(m: mujoco.MjModel, d: mujoco.MjData, g: int) -> np.ndarray:
    """World points of a geom that include the farthest ones from any line (extreme points:
    box corners, cylinder rims, capsule end spheres, densely sampled sphere directions, the
    vertices of a mesh's hull)."""
    s = m.geom_size[g]
    t = mujoco.mjtGeom(m.geom_type[g])
    if t == mujoco.mjtGeom.mjGEOM_MESH:
        hull = col.shapes.mesh_hull(m, g).points
        return d.geom_xpos[g] + hull @ d.geom_xmat[g].reshape(3, 3).T
    u = np.random.default_rng(0).normal(size=(400, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    th = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    rim = np.stack([s[0] * np.cos(th), s[0] * np.sin(th), np.zeros_like(th)], axis=1)
    up = np.array([0.0, 0.0, s[1]])
    local = {
        mujoco.mjtGeom.mjGEOM_SPHERE: s[0] * u,
        mujoco.mjtGeom.mjGEOM_CAPSULE: np.vstack([s[0] * u + up, s[0] * u - up]),
        mujoco.mjtGeom.mjGEOM_CYLINDER: np.vstack([rim + up, rim - up]),
        mujoco.mjtGeom.mjGEOM_BOX: np.array(list(itertools.product(*[(-x, x) for x in s[:3]]))),
        mujoco.mjtGeom.mjGEOM_ELLIPSOID: s[:3] * u,
    }[t]
    return d.geom_xpos[g] + local @ d.geom_xmat[g].reshape(3, 3).T


def assert_reach_bounds(arm: rd.Arm, q: np.ndarray) -> None:
    """Every point of every geom lies within its bound of every hinge that moves it."""
    m = arm.mj_model
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_kinematics(m, d)
    for g in {p.geom1 for p in col.collision_pairs(m)} | {p.geom2 for p in col.collision_pairs(m)}:
        bounds = pc.reach_bounds(m, g)
        if not bounds:
            continue  # welded to the world (the floor): nothing moves it
        pts = geom_points(m, d, g)
        for j, bound in bounds.items():
            if m.jnt_type[j] != mujoco.mjtJoint.mjJNT_HINGE:
                assert bound == 1.0
                continue
            r = pts - d.xanchor[j]
            to_axis = np.linalg.norm(np.cross(d.xaxis[j], r), axis=1).max()
            assert to_axis <= bound + 1e-12, (m.geom(g).name, m.joint(j).name, to_axis, bound)


@on_arms("slider", "arm7", "typed", "meshes")
@given(data=st.data())
def test_reach_bounds_hold(arm: rd.Arm, data: st.DataObject) -> None:
    assert_reach_bounds(arm, data.draw(poses(arm)))


def assert_motion_bound(arm: rd.Arm, qa: np.ndarray, qb: np.ndarray) -> None:
    """No pair's distance shrinks faster than the weights allow along a straight step."""
    ch = col.checker(arm)
    w = pc.path_checker(arm).weights @ np.abs(qb - qa)
    da = ch.distance_values(qa)
    db = ch.distance_values(qb)
    # The bound is on the true signed distance; where coal's depth (EPA) is only as good as
    # its sign, max(db, 0) still obeys it: true d(qb) <= 0 there.
    ok = (da <= 0) | (np.maximum(db, 0.0) >= da - w - BAND)
    assert ok.all(), [
        (p.label, a, b, x) for p, a, b, x, o in zip(ch.pairs, da, db, w, ok, strict=True) if not o
    ]


@on_arms("arm7", "slider", "meshes")
@given(data=st.data())
def test_motion_bound_is_sound(arm: rd.Arm, data: st.DataObject) -> None:
    assert_motion_bound(arm, *data.draw(segments(arm)))


def first_sampled_contact(arm: rd.Arm, Q: np.ndarray, n: int) -> tuple[int, float] | None:
    """First (segment, s) among n + 1 samples per segment where MuJoCo lists a contact."""
    ch = col.checker(arm)
    for seg in range(max(len(Q) - 1, 1)):
        qa, qb = Q[seg], Q[min(seg + 1, len(Q) - 1)]
        for s in np.linspace(0.0, 1.0, n + 1):
            if ch.contact_pairs(qa + s * (qb - qa)):
                return seg, float(s)
    return None


def assert_path_check_sound(arm: rd.Arm, Q: np.ndarray, engine: str = "coal") -> pc.PathCheck:
    result = pc.check_path(arm, Q, engine=engine)  # type: ignore[arg-type]
    sampled = first_sampled_contact(arm, Q, 300)
    if sampled is not None:
        # Never misses what sampling finds, and reports no later than it.
        assert not result.free, (sampled, str(result))
        c = result.contact
        assert c is not None
        assert (c.segment, c.clear_until) <= sampled
    if not result.free:
        c = result.contact
        assert c is not None and c.clear_until <= c.s
        # What it reports is real, by MuJoCo's own distance.
        mj_d = col.checker(arm).distances(c.q, "mujoco").of(*c.pair.names).distance
        limit = c.pair.threshold + (BAND if c.touching else result.tol + BAND)
        assert mj_d < limit, (str(result), mj_d)
    return result


@on_arms("arm7", "slider", "meshes")
@given(data=st.data())
def test_path_checker_never_misses_what_dense_sampling_finds(
    arm: rd.Arm, data: st.DataObject
) -> None:
    Q = np.stack(data.draw(st.lists(poses(arm), min_size=2, max_size=3)))
    assert_path_check_sound(arm, Q)


def lesson_path(arm: rd.Arm) -> np.ndarray:
    """From home, fold the elbow to j4 = 2.5 (free, 1.0 mm clear), then roll the upper arm
    (j3) to 2.9 rad (free again, 0.7 mm clear): on the way the wide side of link2, an
    ellipsoid flatter in x than in y, turns into the folded forearm link4 (11 mm deep at
    j3 = pi/2)."""
    home = arm.keyframe("home")
    folded = home.copy()
    folded[arm.joint_index("j4")] = 2.5
    rolled = folded.copy()
    rolled[arm.joint_index("j3")] = 2.9
    return np.stack([home, folded, rolled])


@pytest.mark.parametrize("engine", ["coal", "mujoco"])
def test_lesson_path_folds_the_elbow_into_link2_between_free_waypoints(
    arm7: rd.Arm, engine: str
) -> None:
    Q = lesson_path(arm7)
    ch = col.checker(arm7)
    # The premise: every waypoint is free, and dense sampling finds link2 / link4 mid-path.
    for q in Q:
        assert not ch.contacts(q)
    sampled = first_sampled_contact(arm7, Q, 1000)
    assert sampled is not None and sampled[0] == 1 and 0.0 < sampled[1] < 1.0
    s = sampled[1]
    q = Q[1] + s * (Q[2] - Q[1])
    assert "link2 / link4" in {p.label for p in ch.contact_pairs(q)}
    result = assert_path_check_sound(arm7, Q, engine)
    c = result.contact
    assert c is not None and c.touching
    assert (c.segment, c.pair.label) == (1, "link2 / link4")
    assert 0.0 < c.s < 1.0
    # The first segment alone (folding to 2.5) is free, and said so.
    assert pc.check_path(arm7, Q[:2], engine=engine).free  # type: ignore[arg-type]
    assert "contact link2 / link4 at segment 1" in str(result)


def test_path_checker_edge_cases(arm7: rd.Arm) -> None:
    home = arm7.keyframe("home")
    one = pc.check_path(arm7, [home])
    assert one.free and one.evaluations == 1 and one.segments == 0
    q = home.copy()
    q[arm7.joint_index("j4")] = 2.9
    start = pc.check_path(arm7, [q, home])
    assert not start.free and start.contact is not None
    assert (start.contact.segment, start.contact.s) == (0, 0.0) and start.contact.touching
    still = pc.check_path(arm7, [home, home])
    assert still.free and still.evaluations == 2
    with pytest.raises(rd.ParameterError, match=r"tol must be a finite number > 1e-06 \[m\]"):
        pc.check_path(arm7, [home, q], tol=1e-7)
    with pytest.raises(rd.PoseError, match=r"poses must have shape \(n, 7\)"):
        pc.check_path(arm7, home)
    with pytest.raises(rd.PoseError, match=r"waypoints must have shape \(k, 7\) with k >= 1"):
        pc.check_path(arm7, np.zeros((0, 7)))
    with pytest.raises(rd.PoseError):
        pc.check_path(arm7, [home, home[:3]])
    with pytest.raises(rd.UnknownNameError, match="valid distance engine names"):
        pc.check_path(arm7, [home, q], engine="fcl")  # type: ignore[arg-type]


@pytest.mark.parametrize("gap", [5e-6, -5e-6, 3e-3])
def test_grazing_pass_is_a_near_miss_contact_or_free(gap: float) -> None:
    """A ball slides past a fixed ball; their closest approach is ``gap`` [m]."""
    xml = f"""
<mujoco><worldbody>
  <geom name="fixed" size="0.1" pos="0 {0.2 + gap} 0"/>
  <body name="cart"><joint name="x" type="slide" axis="1 0 0" range="-0.5 0.5"/>
    <geom name="ball" size="0.1"/><site name="ee"/></body>
</worldbody></mujoco>"""
    arm = rd.load_string(xml)
    path = [[-0.3], [0.3]]
    result = pc.check_path(arm, path, tol=1e-5)
    if gap > 1e-5:
        # The smallest clearance seen at the evaluated poses: never below the true one.
        assert result.free and gap - 1e-12 <= result.min_clearance < gap + 1e-4
        return
    c = result.contact
    assert not result.free and c is not None
    assert c.touching == (gap < 0)
    # Reported near x = 0, where the balls pass: within the distance tol [m] allows.
    assert abs(c.q[0]) < 0.01
    assert c.distance == pytest.approx(np.hypot(c.q[0], 0.2 + gap) - 0.2, abs=1e-12)
    assert c.clear_until <= c.s
    assert pc.check_path(arm, path, tol=2e-6).free == (gap > 2e-6)


def test_weights_ignore_joints_upstream_of_both_geoms(arm7: rd.Arm) -> None:
    w = pc.path_checker(arm7).weights
    ch = col.checker(arm7)
    j1, j2, j3 = (arm7.joint_index(n) for n in ("j1", "j2", "j3"))
    # j1 moves every link together: no pair's distance depends on it.
    assert not w[:, j1].any()
    k = ch.pairs.index(ch.pair("link2", "link4"))
    assert w[k, j2] == 0.0 and w[k, j3] > 0.0
    assert (w >= 0).all()


@pytest.mark.parametrize("name", ["typed", "slider"])
def test_path_checker_finds_a_contact_on_small_arms(
    name: str, request: pytest.FixtureRequest
) -> None:
    """A path from a free pose through a colliding one and back to a free one."""
    arm = request.getfixturevalue(name)
    Q = col.random_poses(arm, 400, seed=3)
    ch = col.checker(arm)
    free = [q for q in Q if not ch.contact_pairs(q)]
    hit = [q for q in Q if ch.contact_pairs(q)]
    assert len(free) >= 2 and hit
    path = np.stack([free[0], hit[0], free[1]])
    result = assert_path_check_sound(arm, path)
    assert not result.free and result.contact is not None and result.contact.segment == 0


def test_pair_combinations_in_typed_cover_every_type_pair(typed: rd.Arm) -> None:
    """The TYPED model exercises every pair of primitive types (so the per-type tests bite)."""
    have = {p.types for p in col.collision_pairs(typed)}
    kinds = ["sphere", "capsule", "box", "cylinder", "ellipsoid"]
    want = {frozenset(t) for t in itertools.combinations_with_replacement(kinds, 2)}
    want |= {frozenset(("plane", k)) for k in kinds}
    assert want <= have, sorted(map(sorted, want - have))


# ==========================================================================================
# Meshes: MuJoCo collides a mesh as its convex hull; coal is given the same hull
# ==========================================================================================

#: A tetrahedron (written as OBJ) and a triangular prism (written as binary STL).
TETRA = (
    np.array([[0, 0, 0], [0.09, 0, 0], [0, 0.08, 0], [0, 0, 0.07]], dtype=float),
    [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)],
)
PRISM = (
    np.array(
        [[0, 0, 0], [0.06, 0, 0], [0, 0.05, 0], [0, 0, 0.1], [0.06, 0, 0.1], [0, 0.05, 0.1]],
        dtype=float,
    ),
    [(0, 2, 1), (3, 4, 5), (0, 1, 4), (0, 4, 3), (1, 2, 5), (1, 5, 4), (2, 0, 3), (2, 3, 5)],
)
#: A non-convex star: six tips on the axes and four waist points near the centre (10
#: vertices, so MuJoCo hill-climbs its hull graph); its hull is the octahedron of the tips.
STAR = "0 0 0.06  0.012 0.012 0  0.06 0 0  0.012 -0.012 0  0 -0.06 0  -0.012 -0.012 0  -0.06 0 0  -0.012 0.012 0  0 0.06 0  0 0 -0.06"
#: A blob of 14 points (hill climbing), one of them inside the others' hull.
BLOB = (
    " ".join(
        f"{0.04 * np.cos(a) * np.cos(b):.5f} {0.03 * np.sin(a) * np.cos(b):.5f} {0.05 * np.sin(b):.5f}"
        for a, b in [(k * 0.9, (k % 3 - 1) * 0.7) for k in range(13)]
    )
    + " 0.001 0.002 0.003"
)
#: A tetrahedron with an interior point (5 vertices: MuJoCo searches every vertex).
TET5 = "0 0 0  0.08 0 0  0 0.09 0  0 0 0.07  0.01 0.01 0.01"


INERTIAL = '<inertial pos="0 0 0" mass="0.5" diaginertia="0.002 0.002 0.002"/>'

#: Mesh geoms against every primitive and against each other, posed and rotated so that
#: MuJoCo recentres and re-orients each mesh (geom_pos/geom_quat absorb its offset).
MESHES = f"""
<mujoco model="meshes">
  <compiler angle="radian" autolimits="true" meshdir="."/>
  <option ccd_iterations="200"/>  <!-- MuJoCo's EPA converges on deep curved overlaps -->
  <asset>
    <mesh name="tetra" file="tetra.obj"/>
    <mesh name="prism" file="prism.stl" scale="1.2 1 0.9"/>
    <mesh name="star" vertex="{STAR}"/>
    <mesh name="blob" vertex="{BLOB}"/>
    <mesh name="tet5" vertex="{TET5}"/>
  </asset>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1" pos="0 0 -0.12"/>
    <body name="base" pos="0 0 0.05">
      <joint name="j1" axis="0 0 1" range="-3 3"/>
      {INERTIAL}
      <geom name="base_star" type="mesh" mesh="star" pos="0.1 0 0" euler="0.3 0.2 0.1"/>
      <geom name="base_box" type="box" size="0.04 0.03 0.05" pos="-0.1 0 0"/>
      <geom name="base_cyl" type="cylinder" size="0.03 0.04" pos="0 0.11 0"/>
      <geom name="base_ell" type="ellipsoid" size="0.03 0.04 0.02" pos="0 -0.11 0"/>
      <geom name="base_tet5" type="mesh" mesh="tet5" pos="-0.05 -0.07 0.03"/>
      <body name="upper" pos="0 0 0.08">
        <joint name="j2" axis="0 1 0" range="-2.6 2.6"/>
        {INERTIAL}
        <geom name="upper_cap" type="capsule" fromto="0 0 0 0 0 0.2" size="0.025"/>
        <body name="fore" pos="0 0 0.2">
          <joint name="j3" axis="1 0 0" range="-2.8 2.8"/>
          {INERTIAL}
          <geom name="fore_tetra" type="mesh" mesh="tetra" pos="0 0 0.06" euler="0.4 0 0.3"/>
          <geom name="fore_prism" type="mesh" mesh="prism" pos="0 0.05 0.12" euler="1 0.2 0"/>
          <geom name="fore_sph" type="sphere" size="0.035" pos="0 -0.04 0.15"/>
          <geom name="fore_cap" type="capsule" size="0.015" fromto="-0.04 0 0.2 0.04 0 0.2"/>
          <body name="hand" pos="0 0 0.22">
            <joint name="j4" axis="0 1 0" range="-2.8 2.8"/>
            {INERTIAL}
            <geom name="hand_blob" type="mesh" mesh="blob" pos="0 0 0.05" euler="0 0.5 0.2"/>
            <geom type="mesh" mesh="star" pos="0.03 0 0.1"/>
            <site name="ee" pos="0 0 0.12"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def mesh_arm(folder: Path) -> rd.Arm:
    """The MESHES model with its mesh files written into ``folder``."""
    write_obj(folder / "tetra.obj", *TETRA)
    write_binary_stl(folder / "prism.stl", *PRISM)
    (folder / "meshes.xml").write_text(MESHES)
    # Strict loading refuses mesh geoms (Pinocchio's parser gives them placeholder inertia);
    # every body here has an explicit <inertial>, so both engines read the same masses.
    return rd.load(folder / "meshes.xml", strict=False)


@pytest.fixture(scope="module")
def meshes(tmp_path_factory: pytest.TempPathFactory) -> rd.Arm:
    return mesh_arm(tmp_path_factory.mktemp("meshes"))


def test_mesh_model_covers_every_type_against_a_mesh(meshes: rd.Arm) -> None:
    m = meshes.mj_model
    kinds = {p.types for p in col.checker(meshes).pairs if "mesh" in p.types}
    others = {"sphere", "capsule", "cylinder", "box", "ellipsoid", "plane", "mesh"}
    assert kinds == {frozenset(("mesh", t)) for t in others}
    # Both hull paths of MuJoCo's support function are exercised: graph and every vertex.
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_MESH, i) for i in range(m.nmesh)]
    climbs = {
        n: bool(m.mesh_graphadr[i] >= 0 and m.mesh_vertnum[i] >= col.shapes.HILLCLIMB_MIN)
        for i, n in enumerate(names)
    }
    assert climbs == {"tetra": False, "prism": False, "star": True, "blob": True, "tet5": False}
    # An unnamed geom is named by its body and its index there.
    assert "hand geom 1" in {n for p in col.checker(meshes).pairs for n in p.names}


def test_hull_is_mujocos_hull_in_the_geom_frame(meshes: rd.Arm) -> None:
    """The hull's points, placed at the geom's compiled pose, are MuJoCo's mesh vertices in
    the world; the star's four waist points are not on its hull."""
    m = meshes.mj_model
    d = mujoco.MjData(m)
    d.qpos[:] = [0.3, -0.4, 0.5, 0.6]
    mujoco.mj_kinematics(m, d)
    for g in range(m.ngeom):
        if m.geom_type[g] != mujoco.mjtGeom.mjGEOM_MESH:
            continue
        hull = col.shapes.mesh_hull(m, g)
        mesh = int(m.geom_dataid[g])
        verts = m.mesh_vert[m.mesh_vertadr[mesh] : m.mesh_vertadr[mesh] + m.mesh_vertnum[mesh]]
        world = d.geom_xpos[g] + hull.points @ d.geom_xmat[g].reshape(3, 3).T
        # MuJoCo's own support point in a few directions is a hull point.
        for u in np.eye(3).tolist() + (-np.eye(3)).tolist():
            best = (
                d.geom_xpos[g]
                + verts[np.argmax(verts @ (d.geom_xmat[g].reshape(3, 3).T @ u))]
                @ d.geom_xmat[g].reshape(3, 3).T
            )
            assert np.min(np.linalg.norm(world - best, axis=1)) < 1e-12
        if hull.mesh == "star":
            assert len(hull.points) == 6 and hull.faces is not None and len(hull.faces) == 8
        if hull.mesh == "tet5":
            assert hull.faces is None and len(hull.points) == 5


def test_non_convex_mesh_collides_as_its_hull_in_both_engines(tmp_path: Path) -> None:
    """A small sphere in a notch of the star (inside the hull, outside the star itself):
    both engines report an overlap, MuJoCo lists a contact."""
    xml = f"""
<mujoco>
  <asset><mesh name="star" vertex="{STAR}"/></asset>
  <worldbody>
    <body name="a"><joint name="ja" axis="0 0 1"/>{INERTIAL}
      <geom name="star" type="mesh" mesh="star"/>
      <body name="b" pos="0.2 0 0"><joint name="jb" axis="0 0 1"/>{INERTIAL}
        <body name="c" pos="-0.175 0.025 0"><joint name="jc" axis="0 0 1"/>{INERTIAL}
          <geom name="ball" type="sphere" size="0.004"/><site name="ee"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>"""
    (tmp_path / "star.xml").write_text(xml)
    arm = rd.load(tmp_path / "star.xml", strict=False)
    ch = col.checker(arm)
    q = np.zeros(3)
    # The ball's centre (0.025, 0.025, 0) lies between the star's x and y arms, outside the
    # star, 0.0058 m inside the hull's face x + y + z = 0.06 (vertices are single precision:
    # 1e-8 m; MuJoCo's EPA stops at ccd_tolerance).
    centre = np.array([0.025, 0.025, 0.0])
    inside = (0.06 - centre.sum()) / np.sqrt(3)
    for engine, tol in (("coal", 1e-8), ("mujoco", float(arm.mj_model.opt.ccd_tolerance))):
        d = ch.distances(q, engine).of("star", "ball").distance
        assert d == pytest.approx(-(inside + 0.004), abs=tol), engine
    assert {c.pair.label for c in ch.contacts(q)} == {"ball / star"}


#: Partners of a mesh on which both engines' GJK and EPA end on exact polytope features.
POLYTOPES = {"mesh", "box", "plane"}


def mesh_tol(pair: col.GeomPair, separated: bool, model: mujoco.MjModel) -> float:
    """Tolerance on a mesh pair's distance, by the other geom's type and the sign.

    * Against a polytope (mesh, box, plane), separated or overlapping: TIGHT (1e-9 m). Both
      engines run GJK/EPA on the same vertices (MuJoCo's single-precision values) and end on
      exact features.
    * Separated from a sphere or capsule: TIGHT. Both treat them as a point or a segment
      swept by a radius.
    * Separated from a cylinder or ellipsoid, and overlapping any curved shape:
      ``opt.ccd_tolerance`` (1e-6 m). Curved supports converge only asymptotically, and
      depths come from EPA, which MuJoCo stops at ccd_tolerance and coal at
      COAL_EPA_TOLERANCE (1e-6 m). MuJoCo's EPA is also capped by ``opt.ccd_iterations``:
      at its default of 35, deep ellipsoid-mesh overlaps came out up to 3.6e-5 m away from
      coal's (1.8e-7 m at 100 iterations), so the test model sets 200.
    """
    other = set(pair.types - {"mesh"}) or {"mesh"}
    if other <= POLYTOPES or (separated and other <= {"sphere", "capsule"}):
        return TIGHT
    return float(model.opt.ccd_tolerance)


def assert_mesh_engines_agree(arm: rd.Arm, q: np.ndarray, worst: dict | None = None) -> None:
    """coal against mj_geomDistance on mesh pairs (:func:`mesh_tol`), then touching sets."""
    ch = col.checker(arm)
    m = arm.mj_model
    coal_d = ch.distances(q, "coal")
    mj_d = ch.distances(q, "mujoco")
    for c, k in zip(coal_d.pairs, mj_d.pairs, strict=True):
        if "mesh" not in c.pair.types:
            continue
        if abs(c.distance) < BAND or abs(k.distance) < BAND:
            assert abs(c.distance) <= BAND and abs(k.distance) <= BAND, c.pair.label
            continue
        separated = c.distance > 0
        assert (k.distance > 0) == separated, (c.pair.label, c.distance, k.distance)
        err = abs(c.distance - k.distance)
        assert err <= mesh_tol(c.pair, separated, m), (c.pair.label, c.distance, k.distance)
        if worst is not None:
            key = (separated, "/".join(sorted(c.pair.types)))
            worst[key] = max(worst.get(key, 0.0), err)
    unclear = {e.pair for e in coal_d.pairs + mj_d.pairs if abs(e.clearance) < BAND}
    assert {e.pair for e in coal_d.touching} - unclear == ch.contact_pairs(q) - unclear


@given(data=st.data())
def test_mesh_engines_agree(meshes: rd.Arm, data: st.DataObject) -> None:
    assert_mesh_engines_agree(meshes, data.draw(poses(meshes)))


def test_mesh_engines_agree_on_a_sample(meshes: rd.Arm) -> None:
    """1000 random poses in the default suite (10 000 in the slow test below)."""
    sweep_mesh_agreement(meshes, 1000, seed=3)


@pytest.mark.slow
def test_mesh_engines_agree_on_ten_thousand_poses(meshes: rd.Arm) -> None:
    sweep_mesh_agreement(meshes, 10_000, seed=4)


def sweep_mesh_agreement(arm: rd.Arm, n: int, seed: int) -> None:
    worst: dict = {}
    Q = col.random_poses(arm, n, seed)
    for q in Q:
        assert_mesh_engines_agree(arm, q, worst)
    # Every type against a mesh, apart and overlapping.
    types = {"/".join(sorted(p.types)) for p in col.checker(arm).pairs if "mesh" in p.types}
    assert {t for s, t in worst if s} == types
    assert {t for s, t in worst if not s} == types
    stats = col.collision_statistics(arm, poses=Q, distances="coal")
    assert stats.disagreements == 0
    assert stats.poses_with_contact > n // 10
    print(f"mesh pairs, {n} poses: largest |coal - MuJoCo| {worst}")


# ==========================================================================================
# Threads, copies, memory, bad poses
# ==========================================================================================


def checker_answers(ch: col.CollisionChecker, Q: np.ndarray) -> list:
    """Everything a checker says at each pose, as plain numbers (for bit-for-bit equality)."""
    out = []
    for q in Q:
        contacts = [(c.pair.label, c.distance, *c.position, *c.normal) for c in ch.contacts(q)]
        coal = ch.distances(q, "coal")
        mj_ = ch.distances(q, "mujoco")
        out.append(
            (
                contacts,
                coal.values.tolist(),
                np.concatenate([[e.point1, e.point2] for e in coal.pairs]).tolist(),
                mj_.values.tolist(),
                ch.distance_values(q, "coal").tolist(),
            )
        )
    return out


def run_threads(n: int, work: Callable[[int], object]) -> list:
    """``work(i)`` for i < n, each on its own thread, started together; results in order."""
    barrier = threading.Barrier(n)

    def job(i: int) -> object:
        barrier.wait()
        return work(i)

    with ThreadPoolExecutor(n) as pool:
        return list(pool.map(job, range(n)))


@pytest.mark.parametrize("model", ["arm7", "meshes"])
def test_checker_from_eight_threads_gives_the_sequential_answers(
    model: str, tmp_path: Path
) -> None:
    """One fresh arm's checker hammered from 8 threads (each building its own scenes) gives
    the sequential numbers bit for bit: contacts, coal and MuJoCo distances, nearest points."""
    if model == "arm7":
        arm = rd.load(rd.model_path("arm7"), frame="ee")
    else:
        arm = mesh_arm(tmp_path)
    Q = col.random_poses(arm, 160, seed=11)
    if model == "arm7":
        Q[::7, 3] = 2.85  # folded elbows: contacts and overlaps too
    ch = col.checker(arm)
    parts = np.array_split(Q, 8)
    got = run_threads(8, lambda i: checker_answers(ch, parts[i]))
    assert [x for part in got for x in part] == checker_answers(ch, Q)


def test_statistics_from_threads_give_the_sequential_answer() -> None:
    """collision_statistics on one arm from 4 threads at once (this segfaulted before)."""
    arm = rd.load(rd.model_path("arm7"), frame="ee")

    def stats(i: int) -> tuple:
        s = col.collision_statistics(arm, 400, seed=i % 2, distances=("coal", "mujoco")[i % 2])
        return (s.poses_with_contact, s.pairs, s.disagreements)

    alone = [stats(0), stats(1)]
    assert run_threads(4, stats) == alone * 2


def test_batch_coal_distances_from_threads_are_right() -> None:
    """batch.distances(engine="coal") reads the checker's scene of the calling thread."""
    arm = rd.load(rd.model_path("arm7"), frame="ee")
    Q = col.random_poses(arm, 150, seed=5)
    expected = rd.batch.distances(arm, Q, engine="coal")
    got = run_threads(4, lambda i: rd.batch.distances(arm, Q, engine="coal"))
    for g in got:
        np.testing.assert_array_equal(g, expected)


def test_checker_cache_does_not_keep_the_arm_alive() -> None:
    arm = rd.load(rd.model_path("arm7"), frame="ee")
    col.collision_statistics(arm, 20, distances="coal")
    pc.check_path(arm, [arm.keyframe("zero"), arm.keyframe("home")])
    ref = weakref.ref(arm)
    del arm
    gc.collect()
    assert ref() is None


def rss_mb() -> float:
    """Resident memory of this process [MB] (Linux)."""
    pages = int(Path("/proc/self/statm").read_text().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 1e6


def test_memory_stays_bounded_over_many_loads_with_collision_use() -> None:
    """Loads of arm7, each used for distances, contacts and a path check, then dropped.

    Before the fix every Arm stayed in the checker cache (about 0.8 MB each)."""

    def use() -> None:
        arm = rd.load(rd.model_path("arm7"), frame="ee")
        q = arm.keyframe("home")
        col.distances(arm, q, "coal")
        col.distances(arm, q, "mujoco")
        col.contacts(arm, q)
        pc.check_path(arm, [arm.keyframe("zero"), q])

    for _ in range(20):  # warm up allocators and caches
        use()
    gc.collect()
    before = rss_mb()
    for _ in range(150):
        use()
    gc.collect()
    assert rss_mb() - before < 40.0


@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
def test_collision_works_on_a_copied_arm(arm7: rd.Arm, how: str) -> None:
    other = copy.deepcopy(arm7) if how == "deepcopy" else pickle.loads(pickle.dumps(arm7))
    assert col.checker(other) is not col.checker(arm7)
    Q = col.random_poses(arm7, 30, seed=9)
    assert checker_answers(col.checker(other), Q) == checker_answers(col.checker(arm7), Q)


def test_complex_poses_are_refused(arm7: rd.Arm) -> None:
    q = arm7.keyframe("home") + 0j
    with pytest.raises(rd.PoseError, match="complex"):
        col.distances(arm7, q)
    with pytest.raises(rd.PoseError, match="complex"):
        col.collision_statistics(arm7, poses=[q])
    with pytest.raises(rd.PoseError, match="complex"):
        pc.check_path(arm7, [q, q])


def test_a_model_without_collision_pairs_gives_empty_results() -> None:
    xml = """
<mujoco><compiler angle="radian"/><worldbody><body name="a"><joint name="j" axis="0 0 1" range="-1 1"/>
  <inertial pos="0 0 0" mass="1" diaginertia="0.1 0.1 0.1"/>
  <geom size="0.1" contype="0" conaffinity="0" mass="0"/><site name="ee"/>
</body></worldbody></mujoco>"""
    arm = rd.load_string(xml)
    ch = col.checker(arm)
    assert ch.pairs == () and ch.contacts([0.2]) == ()
    assert ch.distances([0.2]).closest is None and ch.distances([0.2], "mujoco").pairs == ()
    stats = col.collision_statistics(arm, 30)
    assert stats.pairs == () and stats.poses_with_contact == 0 and stats.disagreements == 0
    assert pc.check_path(arm, [[0.0], [1.0]]).free


# ==========================================================================================
# Statistics skip far pairs: same numbers, fewer distances
# ==========================================================================================


def sphere_chain(links: int = 7, per_link: int = 6) -> str:
    """A 7-joint arm (roll/pitch alternating) whose links are rows of spheres on their axes:
    many pairs, most far apart, several at a constant distance whatever the pose."""
    body = '<site name="ee" pos="0 0 0.2"/>'
    for i in reversed(range(links)):
        axis = "0 0 1" if i % 2 == 0 else "0 1 0"
        r = 0.06 - 0.005 * i
        spheres = "".join(
            f'<geom name="s{i}_{k}" type="sphere" size="{r:.3f}" pos="0 0 {0.2 * k / (per_link - 1):.3f}"/>'
            for k in range(per_link)
        )
        body = (
            f'<body name="l{i}" pos="0 0 {0.0 if i == 0 else 0.2}">'
            f'<joint name="j{i}" axis="{axis}" range="-2.9 2.9"/>{INERTIAL}{spheres}{body}</body>'
        )
    return f'<mujoco><compiler angle="radian"/><worldbody>{body}</worldbody></mujoco>'


def same_statistics(a: col.CollisionStatistics, b: col.CollisionStatistics) -> None:
    assert a.pairs == b.pairs  # poses, contacts, closest (exact floats) and closest_pose
    assert (a.poses_with_contact, a.disagreements, a.n_poses) == (
        b.poses_with_contact,
        b.disagreements,
        b.n_poses,
    )
    assert [(k.contacts, k.closest and k.closest.distance) for k in a.keyframes] == [
        (k.contacts, k.closest and k.closest.distance) for k in b.keyframes
    ]


@pytest.mark.parametrize("engine", ["coal", "mujoco"])
def test_pruned_statistics_equal_the_unpruned_ones(
    arm7: rd.Arm, meshes: rd.Arm, engine: str
) -> None:
    """Skipping far pairs changes no reported number: counts, closest approach and its pose
    index (ties included), the cross-check, over several chunks."""
    spheres = rd.load_string(sphere_chain())
    for arm, n in ((arm7, 2500), (meshes, 1200), (spheres, 1500)):
        Q = col.random_poses(arm, n, seed=21)
        if arm is arm7:
            Q[::5, 3] = 2.9  # folded elbows: many contacts
        Q[7] = Q[3]  # an exact tie: the first of the two poses is reported
        fast = col.collision_statistics(arm, poses=Q, distances=engine)
        slow = col.collision_statistics(arm, poses=Q, distances=engine, prune=False)
        same_statistics(fast, slow)
        assert fast.poses_with_contact > 0
        assert all(p.closest_pose != 7 for p in fast.pairs)


def test_pruning_skips_most_far_pairs(monkeypatch: pytest.MonkeyPatch) -> None:
    """On the sphere arm most pairs are far at most poses: most distances are skipped."""
    arm = rd.load_string(sphere_chain())
    ch = col.checker(arm)
    scene = ch.coal_scene()
    counted = [0]
    placed = scene.placed_values

    def counting(which: np.ndarray, apart: np.ndarray) -> np.ndarray:
        counted[0] += len(which)
        return placed(which, apart)

    monkeypatch.setattr(scene, "placed_values", counting)
    n = 2000
    stats = col.collision_statistics(arm, n, seed=2, distances="coal")
    assert stats.disagreements == 0
    share = counted[0] / (n * len(ch.pairs))
    print(f"sphere chain: {len(ch.pairs)} pairs, {share:.1%} of the pair distances computed")
    assert share < 0.3


def rod_chain(links: int = 7) -> str:
    """A 7-joint arm of long thin boxes and capsules (a rod 0.3 m long, 2 cm thick per link):
    bounding spheres as wide as the links are long, boxes as thin as the rods."""
    body = '<site name="ee" pos="0 0 0.3"/>'
    for i in reversed(range(links)):
        axis = "0 0 1" if i % 2 == 0 else "0 1 0"
        rod = (
            f'<geom name="r{i}" type="box" size="0.02 0.015 0.13" pos="0 0 0.15" euler="0 0 0.3"/>'
            if i % 2
            else f'<geom name="r{i}" type="capsule" size="0.02" fromto="0 0 0.03 0 0 0.27"/>'
        )
        body = (
            f'<body name="l{i}" pos="0 0 {0.0 if i == 0 else 0.3}">'
            f'<joint name="j{i}" axis="{axis}" range="-2.9 2.9"/>{INERTIAL}{rod}{body}</body>'
        )
    return f'<mujoco><compiler angle="radian"/><worldbody>{body}</worldbody></mujoco>'


def _bound_counts(
    monkeypatch: pytest.MonkeyPatch,
    arm: rd.Arm,
    engine: str,
    Q: np.ndarray,
    tighter: Callable[[pytest.MonkeyPatch], None] | None,
    looser: Callable[[pytest.MonkeyPatch], None],
) -> tuple[int, int]:
    """Sweeps of ``Q`` with two sets of bounds (a patch each; None: the library's own):
    both equal the unpruned sweep, the first finds contacts; the distances each computed."""
    scene = col.checker(arm).scene(engine)  # type: ignore[arg-type]
    counted = [0]
    placed = scene.placed_values

    def counting(which: np.ndarray, apart: np.ndarray | None = None) -> np.ndarray:
        counted[0] += len(which)
        return placed(which, apart)

    monkeypatch.setattr(scene, "placed_values", counting)
    slow = col.collision_statistics(arm, poses=Q, distances=engine, prune=False)  # type: ignore[arg-type]
    counts = []
    for patch in (tighter, looser):
        counted[0] = 0
        with monkeypatch.context() as m:
            if patch is not None:
                patch(m)
            stats = col.collision_statistics(arm, poses=Q, distances=engine)  # type: ignore[arg-type]
        same_statistics(stats, slow)
        if patch is tighter:
            assert stats.poses_with_contact > 0
        counts.append(counted[0])
    return counts[0], counts[1]


def _without_own_support(m: pytest.MonkeyPatch) -> None:
    """The axis bound with the bounding boxes only: the geoms' own support gives NaN."""
    axis_bound = colstats._Sweep._axis_bound

    def boxes_only(self, X, R, rows, cols):  # type: ignore[no-untyped-def]
        boxes, _ = axis_bound(self, X, R, rows, cols)
        return boxes, lambda mask: np.full(int(mask.sum()), np.nan)

    m.setattr(colstats._Sweep, "_axis_bound", boxes_only)


def _spheres_only(m: pytest.MonkeyPatch) -> None:
    """No axis bound at all: the bounding spheres alone."""
    m.setattr(
        colstats._Sweep,
        "_axis_bound",
        lambda self, X, R, rows, cols: (
            np.full(len(rows), np.nan),
            lambda mask: np.full(int(mask.sum()), np.nan),
        ),
    )


@pytest.mark.parametrize("engine", ["coal", "mujoco"])
def test_the_box_bound_skips_more_and_changes_nothing(
    monkeypatch: pytest.MonkeyPatch, engine: str
) -> None:
    """Long thin links: the bounding boxes rule out poses the bounding spheres cannot, and
    the statistics equal the unpruned sweep's and the sphere-only sweep's."""
    arm = rd.load_string(rod_chain())
    Q = col.random_poses(arm, 1500, seed=4)
    with_boxes, with_spheres = _bound_counts(
        monkeypatch, arm, engine, Q, _without_own_support, _spheres_only
    )
    print(f"rod chain ({engine}): {with_boxes} distances with boxes, {with_spheres} without")
    assert with_boxes < 0.7 * with_spheres


def test_listed_hull_pairs_far_above_their_closest_are_only_sided(
    monkeypatch: pytest.MonkeyPatch, meshes: rd.Arm
) -> None:
    """A pair of hulls MuJoCo lists at a pose, whose lower bound there exceeds its closest
    approach, is only tested against its threshold by coal: the statistics equal the
    unpruned sweep's, and the test is used."""
    scene = col.checker(meshes).coal_scene()
    within = scene.placed_within
    sided = [0]

    def counting(which: np.ndarray, limits: np.ndarray) -> np.ndarray:
        sided[0] += len(which)
        return within(which, limits)

    monkeypatch.setattr(scene, "placed_within", counting)
    Q = col.random_poses(meshes, 1500, seed=9)
    Q[::3, 3] = 2.9  # a folded hand: the same pairs listed at many poses
    fast = col.collision_statistics(meshes, poses=Q, distances="coal")
    slow = col.collision_statistics(meshes, poses=Q, distances="coal", prune=False)
    same_statistics(fast, slow)
    assert fast.poses_with_contact > 0
    print(f"{sided[0]} listed entries tested against their thresholds only")
    assert sided[0] > 30


#: Baxter's head sphere and forearm cylinder: the slide moves the forearm along its axis
#: through the sphere's centre, the hinge tilts it.
SWALLOW = f"""
<mujoco><compiler angle="radian"/><worldbody>
  <geom name="head" type="sphere" size="0.22" pos="0 0 0.6"/>
  <body name="upper"><joint name="j1" type="slide" axis="0 0 1" range="0 0.3"/>{INERTIAL}
    <body name="fore" pos="0 0 0.3"><joint name="j2" axis="0 1 0" range="-0.3 0.3"/>{INERTIAL}
      <geom name="forearm" type="cylinder" size="0.06 0.136" pos="0 0 0.15"/>
      <body name="hand" pos="0 0 0.3"><joint name="j3" axis="1 0 0" range="-3 3"/>{INERTIAL}
        <geom name="palm" type="capsule" size="0.04 0.08"/><site name="ee"/>
      </body>
    </body>
  </body>
</worldbody></mujoco>
"""


@pytest.mark.parametrize("engine", ["coal", "mujoco"])
def test_deep_overlaps_of_primitives_are_always_measured(engine: str) -> None:
    """A sphere swallowing a cylinder (Baxter's head and forearm): coal's closed form for
    the pair reports a deeper overlap than a separating axis allows, so a listed primitive
    pair is measured at every pose, and the statistics equal the unpruned sweep's."""
    arm = rd.load_string(SWALLOW)
    Q = col.random_poses(arm, 2000, seed=11)
    fast = col.collision_statistics(arm, poses=Q, distances=engine)  # type: ignore[arg-type]
    slow = col.collision_statistics(arm, poses=Q, distances=engine, prune=False)  # type: ignore[arg-type]
    same_statistics(fast, slow)
    swallowed = col.find_pair(col.checker(arm).pairs, "head", "forearm")
    row = next(p for p in fast.pairs if p.pair == swallowed)
    assert row.poses > 100 and row.closest < -0.1


def test_within_a_limit_is_the_distance_below_it(meshes: rd.Arm) -> None:
    """coal's test "nearer than the limit" agrees with its distance, for every pair near or
    touching at 200 poses and limits on both sides of the distance."""
    scene = col.checker(meshes).coal_scene()
    checked = 0
    for q in col.random_poses(meshes, 200, seed=10):
        scene.place(q)
        which = np.arange(len(scene.pairs))
        d = scene.placed_values(which)
        near = which[d < 0.02]
        for shift in (-1e-4, 1e-4, 1e-2):
            limits = d[near] + shift
            assert np.all(scene.placed_within(near, limits) == (shift > 0))
            checked += len(near)
    assert checked > 500


def octahedron_chain(links: int = 7) -> str:
    """A 7-joint arm of long octahedra (mesh hulls), each turned 45 degrees about two axes:
    their bounding boxes hold up to three times their support along a diagonal."""
    body = '<site name="ee" pos="0 0 0.3"/>'
    for i in reversed(range(links)):
        axis = "0 0 1" if i % 2 == 0 else "0 1 0"
        body = (
            f'<body name="l{i}" pos="0 0 {0.0 if i == 0 else 0.3}">'
            f'<joint name="j{i}" axis="{axis}" range="-2.9 2.9"/>{INERTIAL}'
            f'<geom name="o{i}" type="mesh" mesh="oct" pos="0 0 0.15" euler="0.785 0.785 0"/>'
            f"{body}</body>"
        )
    oct_ = "0.05 0 0  -0.05 0 0  0 0.05 0  0 -0.05 0  0 0 0.12  0 0 -0.12"
    return (
        f'<mujoco><compiler angle="radian"/><asset><mesh name="oct" vertex="{oct_}"/></asset>'
        f"<worldbody>{body}</worldbody></mujoco>"
    )


@pytest.mark.parametrize("engine", ["coal", "mujoco"])
def test_the_hulls_skip_more_than_their_boxes_and_change_nothing(
    monkeypatch: pytest.MonkeyPatch, engine: str
) -> None:
    """Mesh hulls far from box-shaped: the hull's own support function rules out poses its
    bounding box cannot, and the statistics equal the unpruned sweep's and the boxes'."""
    arm = rd.load_string(octahedron_chain(), strict=False)  # every body has its <inertial>
    Q = col.random_poses(arm, 1500, seed=5)
    with_hulls, with_boxes = _bound_counts(monkeypatch, arm, engine, Q, None, _without_own_support)
    print(f"octahedra ({engine}): {with_hulls} distances with hulls, {with_boxes} with boxes")
    assert with_hulls < 0.8 * with_boxes


def test_support_functions_bound_every_point_and_reach_the_solid(meshes: rd.Arm) -> None:
    """h(v) = max over the solid of v . p, for every geom type: no point of the solid (MuJoCo's
    closed forms sampled densely, a mesh's hull points) lies beyond it along v, and the
    samples reach it to within the sampling's resolution."""
    m = meshes.mj_model
    rng = np.random.default_rng(0)
    v = rng.normal(size=(3, 400))
    v /= np.linalg.norm(v, axis=0)
    # Points of each primitive's surface (unit directions, scaled by the closed forms).
    a = rng.normal(size=(3, 200_000))
    a /= np.linalg.norm(a, axis=0)
    t = rng.uniform(-1, 1, size=200_000)
    seen = set()
    for g in range(m.ngeom):
        kind = col.shapes.geom_type_name(m, g)
        s = m.geom_size[g]
        h = col.shapes.Support(m, g)(v)
        if kind == "plane":
            assert np.all(h == np.inf)
            seen.add(kind)
            continue
        if kind == "sphere":
            pts = s[0] * a
        elif kind == "capsule":
            pts = s[0] * a + np.array([0, 0, s[1]])[:, None] * np.sign(a[2])
        elif kind == "cylinder":
            rim = a[:2] / np.linalg.norm(a[:2], axis=0)
            pts = np.vstack([s[0] * rim, s[1] * np.sign(t)])
        elif kind == "box":
            pts = s[:3, None] * np.sign(a)  # the corners
        elif kind == "ellipsoid":
            pts = s[:3, None] * a
        else:
            pts = col.shapes.mesh_hull(m, g).points.T
        reach = (v.T @ pts).max(axis=1)
        assert np.all(reach <= h + 1e-12), kind
        assert np.all(h - reach < (1e-12 if kind in ("box", "mesh") else 5e-3 * s[0])), kind
        seen.add(kind)
    assert seen == {"sphere", "capsule", "cylinder", "box", "ellipsoid", "plane", "mesh"}


def test_a_model_without_geoms_gives_empty_results() -> None:
    xml = """
<mujoco><compiler angle="radian"/><worldbody><body name="a"><joint name="j" axis="0 0 1" range="-1 1"/>
  <inertial pos="0 0 0" mass="1" diaginertia="0.1 0.1 0.1"/><site name="ee"/>
</body></worldbody></mujoco>"""
    arm = rd.load_string(xml)
    assert col.collision_pairs(arm) == () and col.contacts(arm, [0.1]) == ()
    stats = col.collision_statistics(arm, 10, distances="mujoco")
    assert stats.pairs == () and stats.poses_with_contact == 0
    assert pc.check_path(arm, [[0.0], [0.5]]).free


def test_batch_mujoco_distances_count_slide_travel_from_qpos0() -> None:
    """The stacked distmax bounds a slide's displacement from qpos0 (its ``ref``), not its range."""
    xml = """<mujoco><worldbody>
    <body name="a"><geom name="ga" type="sphere" size="0.05"/>
      <body name="b"><joint name="s" type="slide" axis="1 0 0" range="0 0.1" ref="-2"/>
        <geom name="gb" type="sphere" size="0.05" pos="0.05 0 0"/>
        <body name="c"><joint name="h" type="hinge" axis="0 0 1" range="-1 1"/>
          <geom name="gc" type="sphere" size="0.05" pos="0.3 0 0"/><site name="tip"/>
        </body>
      </body>
      <body name="d" pos="0 0.5 0"><geom name="gd" type="sphere" size="0.05"/></body>
    </body></worldbody></mujoco>"""
    arm = rd.load_string(xml, frame="tip", strict=False)
    Q = np.array([[0.05, 0.2], [0.0, -0.5]])
    single = np.array([col.checker(arm).distance_values(q, "mujoco") for q in Q])
    assert np.array_equal(rd.batch.distances(arm, Q, engine="mujoco"), single)


def test_check_path_refuses_waypoints_outside_the_ranges(slider: rd.Arm) -> None:
    """The motion bound counts a slide's travel within its range only, so a path
    that leaves the range was called free through a contact; it is refused instead."""
    home = np.zeros(slider.nq)
    out = home.copy()
    out[slider.joint_index("s3")] = -0.5  # range [-0.1, 0.2]
    with pytest.raises(
        rd.OutOfRangeError,
        match=re.escape("waypoint 1: joint 's3' = -0.5 is outside its range [-0.1, 0.2]"),
    ) as err:
        pc.check_path(slider, [home, out])
    assert (err.value.joint, err.value.where) == ("s3", "waypoint 1")
    assert pc.check_path(slider, [home, home]).free  # within the ranges: checked as before


def test_check_path_tol_must_be_a_number(arm7: rd.Arm) -> None:
    home = arm7.keyframe("home")
    with pytest.raises(
        rd.ParameterError, match=re.escape("tol must be a finite number > 1e-06 [m], got '1e-3'")
    ):
        pc.check_path(arm7, [home, home], tol="1e-3")  # type: ignore[arg-type]


def test_coal_scenes_leave_the_process_wide_warning_filters_alone(
    arm7: rd.Arm, monkeypatch: pytest.MonkeyPatch
) -> None:
    # warnings.catch_warnings swaps the process-wide filter list: under another thread's
    # own catch_warnings, or while that thread warns, the user's filters would change.
    import warnings

    touched: list[str] = []
    for name in ("catch_warnings", "simplefilter", "filterwarnings", "resetwarnings"):
        real = getattr(warnings, name)
        monkeypatch.setattr(
            warnings, name, lambda *a, _n=name, _f=real, **k: touched.append(_n) or _f(*a, **k)
        )
    arm = copy.deepcopy(arm7)  # scenes are per arm: a fresh one builds its own
    q = arm.keyframe("home")
    col.checker(arm).distance_values(q, "coal")
    col.checker(arm).contact_pairs(q)
    assert touched == []


def test_pruned_sweep_equals_the_exhaustive_one_to_the_bit_on_a_humanoid() -> None:
    """The G1's left arm among the rest of its robot (interpenetrating mesh hulls, held arms):
    pruning changes no count, pose index or distance, not even in the last bit, because coal's
    answer for a pair does not depend on the calls before it (bounding-box initial guess)."""
    from .test_robot import erd_robots

    path = erd_robots() / "g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf"
    arm = rd.load(path, frame="left_hand_palm_link")
    Q = col.random_poses(arm, 300, seed=4)
    fast = col.collision_statistics(arm, poses=Q, keyframes=False)
    slow = col.collision_statistics(arm, poses=Q, prune=False, keyframes=False)
    same_statistics(fast, slow)
    assert fast.poses_with_contact > 0


def test_float32_support_bounds_the_exact_one_from_above(meshes: rd.Arm) -> None:
    """`Support.upper` (float32 projections plus their error bound) is never below the exact
    support function, and within 1e-6 m of it, on every geom and on hulls scaled up ten times
    (a larger error bound) and down (points near the origin)."""
    m = meshes.mj_model
    rng = np.random.default_rng(3)
    v = rng.normal(size=(3, 5000))
    v /= np.linalg.norm(v, axis=0)
    hulls = 0
    for g in range(m.ngeom):
        sup = col.shapes.Support(m, g)
        if col.shapes.geom_type_name(m, g) == "plane":
            continue
        for scale in (1.0, 10.0, 0.01) if sup.points is not None else (1.0,):
            if sup.points is not None:
                pts = (sup.points * scale).astype(np.float32).astype(float)
                sup.points, sup._points_t = pts, np.ascontiguousarray(pts.T)
                sup._points_32 = sup._points_t.astype(np.float32)
                sup._err_32 = 2.0**-21 * float(np.abs(pts).sum(axis=1).max())
                hulls += 1
            exact, upper = sup(v), sup.upper(v)
            assert np.all(upper >= exact), (g, scale)
            assert np.all(upper - exact <= 1e-6 * max(scale, 1.0)), (g, scale)
    assert hulls >= 3


def test_learnt_axis_bounds_stay_below_coals_distances_on_a_humanoid() -> None:
    """The bound along the axis a pair learns from coal's normal at one pose, taken at other
    poses, never exceeds coal's distance there (any axis bounds the distance; a wrong frame or
    an axis not of unit length would not), is tight (within the slack) where it was learnt,
    and the sweep that uses it equals the exhaustive one."""
    from .test_robot import erd_robots

    path = erd_robots() / "g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf"
    arm = rd.load(path, frame="left_hand_palm_link")
    ch = col.checker(arm)
    sweep = col.statistics._Sweep(ch, "coal", True)
    Q = col.random_poses(arm, 40, seed=8)
    mj, scene = ch.mujoco_scene(), ch.coal_scene()
    X = np.zeros((3, len(Q), len(sweep.used)))
    R = np.zeros((9, len(Q), len(sweep.used)))
    for i, q in enumerate(Q):
        mj.place(q)
        X[:, i] = mj.data.geom_xpos[sweep.used].T
        R[:, i] = mj.data.geom_xmat[sweep.used].T
    npair = len(ch.pairs)
    learn_at = np.zeros((len(Q), npair), dtype=bool)
    learn_at[np.arange(npair) % len(Q), np.arange(npair)] = True  # each pair at one pose
    D = np.full((len(Q), npair), np.inf)
    sweep._evaluate(Q, D, np.zeros(D.shape), learn_at, learn=R)
    assert not np.isnan(sweep.axis_h1).any()
    rows, cols = np.nonzero(learn_at)
    there = sweep._witness_bound(X, R, rows, cols)
    gap = D[rows, cols] - there
    assert np.all(gap >= 0) and np.median(gap) < 2 * col.statistics.PRUNE_SLACK
    rows, cols = np.nonzero(np.ones((len(Q), npair), dtype=bool))
    bound = sweep._witness_bound(X, R, rows, cols)
    exact = np.array([scene.distance_values(q) for q in Q])
    assert np.all(bound <= exact[rows, cols])
    fast = col.collision_statistics(arm, poses=Q, keyframes=False)
    slow = col.collision_statistics(arm, poses=Q, prune=False, keyframes=False)
    same_statistics(fast, slow)

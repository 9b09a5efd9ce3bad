"""Inverse kinematics: reaches, stays in the ranges, never claims a false success, and uses the
null space for objectives without costing the task."""

from __future__ import annotations

import importlib.metadata
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import redundancy as rd
from redundancy import batch, ik, linalg, objectives
from redundancy.analysis import selfmotion as sm
from redundancy.arm import random_poses

TOL = 1e-6


def _erd(relative: str) -> Path:
    """A URDF of example-robot-data (the test extra: its files sit in cmeel's prefix)."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("example-robot-data is not installed (pip install -e '.[test]')")
    return Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots"))) / relative


@pytest.fixture(scope="module")
def ur5() -> rd.Arm:
    return rd.load(_erd("ur_description/urdf/ur5_robot.urdf"), frame="tool0")


@pytest.fixture(scope="module")
def panda_erd() -> rd.Arm:
    """example-robot-data's Panda at its hand; the fingers are held (not on the path)."""
    return rd.load(_erd("panda_description/urdf/panda.urdf"), frame="panda_hand")


@pytest.fixture(scope="module")
def xarm7() -> rd.Arm:
    return rd.load(_erd("xarm_description/urdf/xarm7.urdf"), frame="link_eef")


def _errors(arm: rd.Arm, q: np.ndarray, p_t: np.ndarray, R_t: np.ndarray, engine: str):
    p, R = arm.site_pose(q, engine)
    c = np.clip((np.trace(R_t @ R.T) - 1) / 2, -1.0, 1.0)
    return float(np.linalg.norm(p - p_t)), math.acos(c)


def _sweep(arm: rd.Arm, n: int, seed: int, **kw):
    """Solve n reachable targets from random starts; check every answer in both engines."""
    Qt, Q0 = random_poses(arm, n, seed=seed), random_poses(arm, n, seed=seed + 1)
    results = []
    for qt, q0 in zip(Qt, Q0, strict=True):
        p_t, R_t = arm.site_pose(qt)
        r = arm.solve_ik((p_t, R_t), q0, **kw)
        assert np.all(r.q >= arm.lower) and np.all(r.q <= arm.upper)
        both = [_errors(arm, r.q, p_t, R_t, e) for e in ("mujoco", "pinocchio")]
        if r.success:  # no false success: within tolerance by both engines' kinematics
            assert all(pe <= TOL and (kw.get("position_only") or oe <= TOL) for pe, oe in both)
        assert r.position_error == pytest.approx(both[1][0], abs=1e-12)
        results.append(r)
    return results


@pytest.mark.parametrize("name", ["arm7", "panda"])
def test_random_reachable_targets_are_solved_inside_the_ranges(name: str, arms) -> None:
    results = _sweep(arms[name], 60, seed=7)
    assert all(r.success for r in results)
    assert all(r.checked_by == "pinocchio, drake" for r in results)


def test_published_arms_from_example_robot_data(
    ur5: rd.Arm, xarm7: rd.Arm, panda_erd: rd.Arm
) -> None:
    assert set(panda_erd.held) == {"panda_finger_joint1", "panda_finger_joint2"}
    for arm in (ur5, xarm7, panda_erd):
        assert all(r.success for r in _sweep(arm, 30, seed=3))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["arm7", "panda", "panda_erd", "ur5", "xarm7"])
def test_thousand_targets_per_arm(name: str, arms, request) -> None:
    arm = arms[name] if name in arms else request.getfixturevalue(name)
    results = _sweep(arm, 1000, seed=100)
    assert sum(r.success for r in results) >= 999


def test_the_joint_limit_objective_moves_away_from_the_limits_at_no_cost(arm7: rd.Arm) -> None:
    plain = _sweep(arm7, 25, seed=21)
    kept = _sweep(arm7, 25, seed=21, objective="joint_limits")
    assert all(r.success for r in plain) and all(r.success for r in kept)
    cost = ik.joint_limit_objective(arm7.lower, arm7.upper)
    before = [cost(r.q)[0] for r in plain]
    after = [r.objective for r in kept]
    assert all(b <= a + 1e-12 for a, b in zip(before, after, strict=True))  # never worse
    assert np.mean(after) < 0.9 * np.mean(before)
    clear = [ik.limit_clearance(r.q, arm7.lower, arm7.upper) for r in (plain, kept)[1]]
    clear0 = [ik.limit_clearance(r.q, arm7.lower, arm7.upper) for r in plain]
    assert np.mean(clear) > np.mean(clear0)


def test_manipulability_and_callable_objectives(arm7: rd.Arm) -> None:
    qt = random_poses(arm7, 1, seed=4)[0]
    target = arm7.site_pose(qt)
    q0 = random_poses(arm7, 1, seed=5)[0]
    plain = arm7.solve_ik(target, q0)
    best = arm7.solve_ik(target, q0, objective="manipulability")
    assert plain.success and best.success
    w = arm7.manipulability(best.q).full
    assert w >= arm7.manipulability(plain.q).full
    assert best.objective == pytest.approx(-w, rel=1e-12)

    def toward(x: np.ndarray) -> tuple[float, np.ndarray]:  # pull j3 toward 1 rad
        g = np.zeros(7)
        g[2] = x[2] - 1.0
        return 0.5 * g[2] ** 2, g

    pulled = arm7.solve_ik(target, q0, objective=toward)
    assert pulled.success
    assert abs(pulled.q[2] - 1.0) < abs(plain.q[2] - 1.0)


def test_an_objective_that_changes_its_argument_changes_nothing(arm7: rd.Arm) -> None:
    rest = arm7.keyframe("home")

    def in_place(q: np.ndarray) -> tuple[float, np.ndarray]:
        d = q
        d -= rest  # the argument itself, now q - rest
        return float(d @ d), 2.0 * d

    for i, qt in enumerate(random_poses(arm7, 4, seed=40)):
        p_t, R_t = arm7.site_pose(qt)
        r = arm7.solve_ik((p_t, R_t), random_poses(arm7, 1, seed=41 + i)[0], objective=in_place)
        # The errors and the success are those of the q returned.
        found = [ik.tool_errors(p_t, R_t, *arm7.site_pose(r.q, e)) for e in ("pinocchio", "drake")]
        pe, oe = max(f[0] for f in found), max(f[1] for f in found)
        assert (r.position_error, r.orientation_error) == (pe, oe)
        assert r.success and pe <= TOL and oe <= TOL
        assert r.objective == pytest.approx(float((r.q - rest) @ (r.q - rest)), rel=1e-12)


def test_a_gradient_array_the_objective_reuses_is_copied(arm7: rd.Arm) -> None:
    buffer = np.zeros(7)
    calls = []

    def reusing(q: np.ndarray) -> tuple[float, np.ndarray]:
        calls.append(1)
        buffer[:] = q - 1.0  # the same array every call: the solver must keep its own
        return float(buffer @ buffer), buffer

    target = arm7.site_pose(random_poses(arm7, 1, seed=44)[0])
    shared = arm7.solve_ik(target, objective=reusing)
    fresh = arm7.solve_ik(target, objective=lambda q: (float((q - 1) @ (q - 1)), 2.0 * (q - 1)))
    assert len(calls) > 2 and shared.success and fresh.success
    # Reused or fresh, the same steps (the gradients differ only by the factor 2, which the
    # step normalises away).
    np.testing.assert_array_equal(shared.q, fresh.q)


def _links(link: float, slide: bool = False) -> str:
    """Three links of ``link`` [m]: hinges y, z, y (the middle one a slide along x)."""
    a, r = link, link / 10
    inertial = f'<inertial pos="0 0 {a / 2}" mass="1" diaginertia="{a * a / 12} {a * a / 12} {a * a / 100}"/>'
    middle = f'type="slide" axis="1 0 0" range="{-a} {a}"' if slide else 'axis="0 0 1"'
    return f"""
<mujoco><compiler angle="radian"/><worldbody>
  <body name="l1"><joint name="j1" axis="0 1 0" range="-2 2"/>{inertial}
    <geom type="capsule" fromto="0 0 0 0 0 {a}" size="{r}" contype="0" conaffinity="0"/>
    <body name="l2" pos="0 0 {a}"><joint name="j2" {middle}/>{inertial}
      <geom type="capsule" fromto="0 0 0 0 0 {a}" size="{r}" contype="0" conaffinity="0"/>
      <body name="l3" pos="0 0 {a}"><joint name="j3" axis="0 1 0" range="-2 2"/>{inertial}
        <geom type="capsule" fromto="0 0 0 0 0 {a}" size="{r}" contype="0" conaffinity="0"/>
        <site name="tip" pos="0 0 {a}"/>
      </body>
    </body>
  </body>
</worldbody></mujoco>"""


@pytest.mark.parametrize(
    "settings",
    [{"restarts": 0}, {"position_only": True}, {"restarts": 0, "slide": True}],
    ids=["pose", "position", "slide"],
)
def test_an_arm_of_any_size_solves_the_same_targets(settings: dict) -> None:
    """Thirty reachable targets on arms of 1 m, 0.3 mm and 100 m links, tolerances scaled."""
    kw = dict(settings)
    slide = kw.pop("slide", False)
    solved = {}
    for link in (1.0, 3e-4, 100.0):
        arm = rd.load_string(_links(link, slide), frame="tip")
        Qt, Q0 = random_poses(arm, 30, seed=11), random_poses(arm, 30, seed=12)
        solved[link] = [
            arm.solve_ik(arm.site_pose(qt), q0, position_tol=TOL * link, **kw).success
            for qt, q0 in zip(Qt, Q0, strict=True)
        ]
    assert sum(solved[1.0]) >= 20
    assert solved[3e-4] == solved[1.0] and solved[100.0] == solved[1.0]


def test_position_only_frees_the_orientation(panda: rd.Arm) -> None:
    p_t = panda.site_pose(random_poses(panda, 1, seed=8)[0])[0]
    R_far = np.diag([1.0, -1.0, -1.0])
    r = panda.solve_ik((p_t, R_far), position_only=True)
    assert r.success and r.position_error <= TOL


def test_an_unreachable_target_fails_honestly(arm7: rd.Arm) -> None:
    r = arm7.solve_ik((np.array([3.0, 0.0, 0.5]), np.eye(3)), restarts=3)
    assert not r.success
    assert r.position_error > 1.0
    assert np.all(r.q >= arm7.lower) and np.all(r.q <= arm7.upper)
    assert r.restarts == 3


def test_absurdly_far_targets_fail_inside_the_ranges(arm7: rd.Arm) -> None:
    for far in (1e10, 1e200, 1e308):
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # no overflow warning escapes
            r = arm7.solve_ik((np.array([far, 0.0, 0.0]), np.eye(3)), restarts=2)
        assert not r.success and r.position_error == pytest.approx(far, rel=1e-6)
        assert np.all(r.q >= arm7.lower) and np.all(r.q <= arm7.upper)


def test_target_forms_engines_seeds_and_the_batch_agree(arm7: rd.Arm) -> None:
    Qt, Q0 = random_poses(arm7, 6, seed=30), random_poses(arm7, 6, seed=31)
    pairs = [arm7.site_pose(q) for q in Qt]
    T = np.tile(np.eye(4), (6, 1, 1))
    for Ti, (p, R) in zip(T, pairs, strict=True):
        Ti[:3, :3], Ti[:3, 3] = R, p
    a = arm7.solve_ik(T[0], Q0[0], seed=4)
    b = arm7.solve_ik(pairs[0], Q0[0], seed=4)
    np.testing.assert_array_equal(a.q, b.q)
    c = arm7.solve_ik(T[0], Q0[0], engine="pinocchio")
    assert c.success and (c.engine, c.checked_by) == ("pinocchio", "mujoco, drake")
    one = batch.solve_ik(arm7, T, Q0, seed=10)
    two = batch.solve_ik(arm7, pairs, Q0, seed=10, threads=2)
    for i, (x, y) in enumerate(zip(one, two, strict=True)):
        np.testing.assert_array_equal(x.q, y.q)
        np.testing.assert_array_equal(x.q, arm7.solve_ik(pairs[i], Q0[i], seed=10 + i).q)
    assert batch.solve_ik(arm7, []) == ()


def test_bad_inputs_raise_the_librarys_errors(arm7: rd.Arm) -> None:
    good = arm7.site_pose(arm7.keyframe("home"))
    valid = r"a 4 x 4 homogeneous pose or a \(position \[m\], 3 x 3 rotation matrix\) pair"
    skew = np.eye(4)
    skew[0, 1] = 0.5
    for bad in (np.eye(3), "pose", (good[0], 2 * good[1]), (good[0][:2], good[1]), skew):
        with pytest.raises(rd.ParameterError, match=rf"^target must be {valid}"):
            arm7.solve_ik(bad)
    with pytest.raises(rd.ParameterError, match=r"^target must be"):
        arm7.solve_ik((np.array([np.nan, 0, 0]), np.eye(3)))
    with pytest.raises(rd.UnknownNameError, match=r"^unknown objective 'limits'; valid"):
        arm7.solve_ik(good, objective="limits")
    with pytest.raises(rd.ParameterError, match=r"^objective must be None, one of"):
        arm7.solve_ik(good, objective=3)
    with pytest.raises(rd.ParameterError, match=r"^objective must be a callable returning"):
        arm7.solve_ik(good, objective=lambda q: (np.nan, q))
    with pytest.raises(rd.ParameterError, match=r"^position_tol must be a finite number > 0"):
        arm7.solve_ik(good, position_tol=0)
    with pytest.raises(rd.ParameterError, match=r"^restarts must be an integer >= 0"):
        arm7.solve_ik(good, restarts=-1)
    with pytest.raises(rd.PoseError, match=r"^pose must have shape \(7,\)"):
        arm7.solve_ik(good, q0=[0, 0])
    with pytest.raises(rd.ParameterError, match=r"^targets\[1\] must be"):
        batch.solve_ik(arm7, [good, "x"])
    with pytest.raises(rd.ParameterError, match=r"^Q0 must be None or one start per target"):
        batch.solve_ik(arm7, [good], np.zeros((2, 7)))


def test_rotation_error_handles_half_turns() -> None:
    R = np.diag([1.0, -1.0, -1.0])  # a half turn about x
    v = ik.rotation_error(R, np.eye(3))
    assert np.linalg.norm(v) == pytest.approx(math.pi)
    assert abs(v[0]) == pytest.approx(math.pi)
    assert ik.rotation_error(np.eye(3), np.eye(3)) == (0.0, 0.0, 0.0)


def test_joint_limit_cost_gradient_and_its_finite_value_at_a_limit() -> None:
    lo, hi = np.array([-1.0, -2.0, -np.inf]), np.array([2.0, 1.0, np.inf])
    cost = ik.joint_limit_objective(lo, hi)
    q = np.array([0.3, -1.5, 4.0])
    value, grad = cost(q)
    h = 1e-6
    numeric = [(cost(q + h * e)[0] - cost(q - h * e)[0]) / (2 * h) for e in np.eye(3)]
    np.testing.assert_allclose(grad, numeric, rtol=1e-6, atol=1e-12)
    assert grad[2] == 0.0  # an unlimited joint has no limit to keep away from
    middle, _ = cost(np.array([0.5, -0.5, 0.0]))
    at_limit, g = cost(np.array([2.0, -0.5, 0.0]))
    assert middle < value < at_limit < np.inf and np.all(np.isfinite(g))


# -- one objective convention: a value to raise, as self_motion takes -----------------------


def _toward_one(q: np.ndarray) -> float:
    """Raised when j3 nears 1 rad."""
    return -0.5 * (q[2] - 1.0) ** 2


def _toward_one_gradient(q: np.ndarray) -> np.ndarray:
    g = np.zeros(len(q))
    g[2] = 1.0 - q[2]
    return g


def test_the_same_objective_drives_self_motion_and_solve_ik(arm7: rd.Arm) -> None:
    toward = objectives.Objective("j3 near 1 rad [rad^2]", _toward_one, _toward_one_gradient)
    assert sm.Objective is objectives.Objective  # the old import still works
    qt = random_poses(arm7, 1, seed=4)[0]
    path = sm.self_motion(arm7, qt, 0.5, 0.01, objective=toward)
    assert path.objective[-1] > path.objective[0]
    target = arm7.site_pose(qt)
    q0 = random_poses(arm7, 1, seed=5)[0]
    plain = arm7.solve_ik(target, q0)
    for objective in (toward, _toward_one):  # analytic gradient, central differences
        pulled = arm7.solve_ik(target, q0, objective=objective)
        assert pulled.success and _toward_one(pulled.q) > _toward_one(plain.q)
        assert pulled.objective == -_toward_one(pulled.q)  # the cost lowered: minus the value


def test_a_legacy_tuple_objective_warns_and_matches_its_objective(arm7: rd.Arm) -> None:
    target = arm7.site_pose(random_poses(arm7, 1, seed=4)[0])
    q0 = random_poses(arm7, 1, seed=5)[0]

    def legacy(q: np.ndarray) -> tuple[float, np.ndarray]:
        return -_toward_one(q), -_toward_one_gradient(q)

    with pytest.warns(DeprecationWarning) as caught:
        old = arm7.solve_ik(target, q0, objective=legacy)
    assert [str(w.message) for w in caught] == [ik.LEGACY_WARNING]
    assert "pass an Objective or a callable returning the value to raise" in ik.LEGACY_WARNING
    toward = objectives.Objective("j3 near 1 rad", _toward_one, _toward_one_gradient)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        new = arm7.solve_ik(target, q0, objective=toward)
    np.testing.assert_array_equal(old.q, new.q)
    assert (old.objective, old.iterations) == (new.objective, new.iterations)


@pytest.mark.parametrize("name", ["arm7", "panda"])
def test_named_objectives_take_the_steps_of_their_former_costs(name: str, request) -> None:
    arm = request.getfixturevalue(name)
    with pytest.warns(DeprecationWarning, match="use redundancy.objectives.joint_limits"):
        limits = ik.joint_limit_objective(arm.lower, arm.upper)

    def manipulability(q: np.ndarray) -> tuple[float, np.ndarray]:  # as solve_ik lowered it
        J = arm.jacobian(q)
        return -linalg.yoshikawa(J), -arm.manipulability_gradient(q)

    Qt, Q0 = random_poses(arm, 8, seed=60), random_poses(arm, 8, seed=61)
    for qt, q0 in zip(Qt, Q0, strict=True):
        target = arm.site_pose(qt)
        for named, former in (("joint_limits", limits), ("manipulability", manipulability)):
            a = arm.solve_ik(target, q0, objective=named)
            with pytest.warns(DeprecationWarning):
                b = arm.solve_ik(target, q0, objective=former)
            np.testing.assert_array_equal(a.q, b.q)
            assert a.objective == b.objective


def test_the_joint_limits_objective_is_minus_the_former_cost() -> None:
    lo, hi = np.array([-1.0, -2.0, -np.inf]), np.array([2.0, 1.0, np.inf])
    raised = objectives.joint_limits(lo, hi)
    cost = objectives.joint_limit_cost(lo, hi)
    for q in (np.array([0.3, -1.5, 4.0]), np.array([2.0, -0.5, 0.0])):
        assert raised(q) == -cost(q)[0]
        np.testing.assert_array_equal(raised.gradient(q), -cost(q)[1])


def test_a_callable_returning_neither_a_number_nor_a_pair_is_blamed(arm7: rd.Arm) -> None:
    good = arm7.site_pose(arm7.keyframe("home"))
    with pytest.raises(
        rd.ParameterError,
        match=r"^objective must be a function of q returning a finite real number, got one",
    ):
        arm7.solve_ik(good, objective=lambda q: "high")

"""The mass a contact at the tool feels: operational inertia, effective mass, dynamic manipulability.

Properties on the core arms (hypothesis), the two engines against each other, and the effective
mass against MuJoCo simulating a force at the tool of the arm at rest.
"""

from __future__ import annotations

import copy

import mujoco
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import redundancy as rd
from redundancy import batch, linalg
from redundancy.arm import random_poses
from redundancy.testing import poses

from .conftest import ARM_NAMES

AXES = np.vstack([np.eye(3), -np.eye(3)])

directions = st.tuples(*[st.floats(-1.0, 1.0) for _ in range(3)]).filter(
    lambda u: np.linalg.norm(u) > 1e-3
)


def _simulated_effective_mass(arm: rd.Arm, q: np.ndarray, u: np.ndarray, armature: bool) -> float:
    """F / (u . a): MuJoCo's forward dynamics with a force F u at the site, arm at rest.

    A copy of the model with gravity, springs, dampers, actuation and constraints off; the
    force enters through mj_applyFT at the site's point, one mj_forward gives qacc, and
    mj_rnePostConstraint + mj_objectAcceleration the site's linear acceleration (no Jacobian
    of the library involved).
    """
    m = copy.deepcopy(arm.mj_model)
    if not armature:
        m.dof_armature[:] = 0.0
        m.actuator_armature[:] = 0.0
    off = mujoco.mjtDisableBit
    for bit in ("GRAVITY", "SPRING", "DAMPER", "ACTUATION", "CONSTRAINT"):
        m.opt.disableflags |= int(getattr(off, f"mjDSBL_{bit}"))
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_forward(m, d)  # site placement for the point of application
    site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, arm.frame)
    body = int(m.site_bodyid[site])
    F = 7.0  # [N]
    mujoco.mj_applyFT(m, d, F * u, np.zeros(3), d.site_xpos[site].copy(), body, d.qfrc_applied)
    mujoco.mj_forward(m, d)
    mujoco.mj_rnePostConstraint(m, d)
    acc = np.zeros(6)
    mujoco.mj_objectAcceleration(m, d, mujoco.mjtObj.mjOBJ_SITE, site, acc, 0)
    return float(F / (u @ acc[3:]))


@pytest.mark.parametrize("name", ARM_NAMES)
def test_effective_mass_equals_a_simulated_push_at_the_tool(name: str, arms) -> None:
    arm = arms[name]
    worst = 0.0
    for q in rd.arm.random_poses(arm, 6, seed=11):
        for u in AXES[:3]:
            for armature in (True, False):
                sim = _simulated_effective_mass(arm, q, u, armature)
                for engine in ("mujoco", "pinocchio"):
                    m = arm.effective_mass(q, u, armature=armature, engine=engine)
                    worst = max(worst, abs(m - sim) / sim)
    assert worst <= 1e-9


@pytest.mark.parametrize("name", ARM_NAMES)
def test_engines_agree_on_lambda_and_the_effective_mass(name: str, arms) -> None:
    arm = arms[name]
    Q = rd.arm.random_poses(arm, 20, seed=5)
    held = list(arm.joint_names[1:])  # one joint held rigid
    for q in Q:
        for kw in ({}, {"armature": False}):
            Lm = arm.operational_inertia(q, engine="mujoco", **kw)
            Lp = arm.operational_inertia(q, engine="pinocchio", **kw)
            assert np.max(np.abs(Lm - Lp)) <= 1e-9 * np.max(np.abs(Lm))
        for u in AXES:
            a = arm.effective_mass(q, u, joints=held)
            b = arm.effective_mass(q, u, joints=held, engine="pinocchio")
            assert abs(a - b) <= 1e-9 * a
    report = rd.crosscheck(arm, Q, ["operational inertia^-1", "dynamic manipulability"])
    assert report.ok, report.lines()


@pytest.mark.parametrize("name", ARM_NAMES)
def test_lambda_is_symmetric_positive_definite_and_the_inverse_of_j_minv_jt(
    name: str, arms
) -> None:
    arm = arms[name]

    @given(poses(arm, margin=0.05))
    def check(q: np.ndarray) -> None:
        try:
            L = arm.operational_inertia(q)
        except rd.SingularPoseError:
            assert arm.svd(q).rank < 6
            return
        np.testing.assert_array_equal(L, L.T)
        # Positive definite: Cholesky succeeds on Lambda scaled to unit diagonal (its
        # eigenvalues span J's condition number squared, beyond what eigvalsh resolves near
        # a singular pose; the scaled matrix is as well conditioned as M).
        d = 1.0 / np.sqrt(np.diag(L))
        np.linalg.cholesky(L * np.outer(d, d))
        J, M = arm.jacobian(q), arm.mass_matrix(q)
        if arm.svd(q).condition < 1e4:  # the product below squares it again
            np.testing.assert_allclose(L @ (J @ np.linalg.solve(M, J.T)), np.eye(6), atol=1e-6)

    check()


@pytest.mark.parametrize("name", ARM_NAMES)
def test_armature_and_held_joints_never_lower_the_effective_mass(name: str, arms) -> None:
    arm = arms[name]
    names = arm.joint_names

    @given(poses(arm), directions, st.sets(st.sampled_from(names), min_size=1))
    def check(q: np.ndarray, u: tuple[float, float, float], free: set[str]) -> None:
        with_rotors = arm.effective_mass(q, u)
        bare = arm.effective_mass(q, u, armature=False)
        held = arm.effective_mass(q, u, joints=sorted(free))
        assert with_rotors >= bare * (1 - 1e-12)
        assert held >= with_rotors * (1 - 1e-12)
        assert bare > 0

    check()


def test_range_brackets_every_direction_and_the_batch_matches(arm7: rd.Arm) -> None:
    Q = rd.arm.random_poses(arm7, 30, seed=2)
    rng = np.random.default_rng(0)
    U = rng.normal(size=(30, 3))
    ranges = batch.effective_mass_ranges(arm7, Q)
    masses = batch.effective_masses(arm7, Q, U)
    for q, u, (lo, hi), m in zip(Q, U, ranges, masses, strict=True):
        r = arm7.effective_mass_range(q)
        assert (r.min, r.max) == pytest.approx((lo, hi), rel=1e-12)
        assert lo * (1 - 1e-12) <= m <= hi * (1 + 1e-12)
        assert arm7.effective_mass(q, u) == pytest.approx(m, rel=1e-12)
        assert arm7.effective_mass(q, r.min_direction) == pytest.approx(r.min, rel=1e-9)
        assert arm7.effective_mass(q, r.max_direction) == pytest.approx(r.max, rel=1e-9)
    L = batch.operational_inertias(arm7, Q[:3], engine="pinocchio")
    np.testing.assert_allclose(L[1], arm7.operational_inertia(Q[1], engine="pinocchio"))
    dm = batch.dynamic_manipulabilities(arm7, Q[:3], armature=False)
    assert dm[2] == pytest.approx(arm7.dynamic_manipulability(Q[2], armature=False), rel=1e-12)


def test_dynamic_manipulability_is_yoshikawas_formula(arm7: rd.Arm) -> None:
    q = rd.arm.random_poses(arm7, 1, seed=3)[0]
    J, M = arm7.jacobian(q), arm7.mass_matrix(q)
    JMinv = J @ np.linalg.inv(M)
    expected = np.sqrt(np.linalg.det(JMinv @ JMinv.T))
    assert arm7.dynamic_manipulability(q) == pytest.approx(expected, rel=1e-9)
    # Fewer than six free joints: the tool loses directions, the measure is zero.
    assert arm7.dynamic_manipulability(q, joints=["j1", "j2", "j3"]) == 0.0


def test_singular_pose_names_the_lost_directions(arm7: rd.Arm) -> None:
    zero = arm7.keyframe("zero")
    with pytest.raises(
        rd.SingularPoseError,
        match=r"^operational inertia is undefined at a singular pose: the tool cannot move "
        r"along translation y, translation z, rotation x$",
    ) as exc:
        arm7.operational_inertia(zero)
    assert exc.value.lost == ("translation y", "translation z", "rotation x")
    # The effective mass exists there: infinite along a lost direction, finite elsewhere.
    assert arm7.effective_mass(zero, [0, 0, 1]) == np.inf
    assert np.isfinite(arm7.effective_mass(zero, [1, 0, 0]))
    assert arm7.effective_mass_range(zero).max == np.inf
    with pytest.raises(rd.SingularPoseError, match=r"\(pose 1\)$"):
        batch.operational_inertias(arm7, np.vstack([arm7.keyframe("home"), zero]))
    # Three free joints cannot span six directions.
    with pytest.raises(rd.SingularPoseError, match=r"cannot move along \["):
        arm7.operational_inertia(arm7.keyframe("home"), joints=["j1", "j2", "j3"])


WRIST = ["j5", "j6", "j7"]


@pytest.fixture(scope="module")
def wrist_centre() -> rd.Arm:
    """arm7 with its tool where the wrist's three axes meet (on j6, 0.08 m below j7)."""
    text = rd.model_path("arm7").read_text()
    return rd.load_string(text.replace('name="ee" pos="0 0 0.13"', 'name="ee" pos="0 0 -0.08"'))


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("engine", ["mujoco", "pinocchio"])
def test_a_point_the_free_joints_cannot_move_has_infinite_mass(
    wrist_centre: rd.Arm, engine: str
) -> None:
    # J_v of the wrist joints is rounding noise there (~1e-17 m/rad): no direction moves.
    Q = random_poses(wrist_centre, 12, seed=8)
    kw = {"joints": WRIST, "engine": engine}
    for q in Q:
        for u in [*AXES, [0.3, -0.5, 0.8]]:
            assert wrist_centre.effective_mass(q, u, **kw) == np.inf
        r = wrist_centre.effective_mass_range(q, **kw)
        assert (r.min, r.max) == (np.inf, np.inf)
        with pytest.raises(rd.SingularPoseError, match=r"translation x, translation y, transl"):
            wrist_centre.operational_inertia(q, **kw)
    assert np.all(batch.effective_masses(wrist_centre, Q, [1.0, 0.0, 0.0], **kw) == np.inf)
    assert np.all(batch.effective_mass_ranges(wrist_centre, Q, **kw) == np.inf)


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("joints", [["j2"], ["j2", "j4"]])
def test_fewer_than_three_free_joints_leave_the_greatest_mass_infinite(
    arm7: rd.Arm, joints: list[str]
) -> None:
    Q = random_poses(arm7, 8, seed=3)
    ranges = batch.effective_mass_ranges(arm7, Q, joints=joints)
    assert np.all(np.isfinite(ranges[:, 0])) and np.all(ranges[:, 1] == np.inf)
    for q, (low, _) in zip(Q, ranges, strict=True):
        r = arm7.effective_mass_range(q, joints=joints)
        assert r.min == pytest.approx(low, rel=1e-12) and r.max == np.inf


def test_the_floor_scales_with_the_arm() -> None:
    assert linalg.motion_floor(1.0) == 1024 * np.finfo(float).eps
    assert linalg.motion_floor(1e-4) == pytest.approx(1e-4 * linalg.motion_floor(1.0))
    # Given the floor, a J_v of noise is no motion; without it, the old relative test alone.
    J = np.zeros((6, 3))
    J[:3] = 1e-17 * np.array([[1.0, -2, 0.5], [0.3, 1, -1], [2, 0, 1]])
    J[3:] = np.eye(3)
    X = J.T.copy()  # M = I
    u = np.array([1.0, 0.0, 0.0])
    assert linalg.effective_mass(J, X, u, atol=linalg.motion_floor(1.4)) == np.inf
    assert 1e30 < linalg.effective_mass(J, X, u) < np.inf
    with pytest.raises(rd.ParameterError, match=r"^atol must be"):
        linalg.effective_mass(J, X, u, atol=-1.0)


def test_near_a_singular_pose_the_effective_mass_stays_exact(arm7: rd.Arm) -> None:
    # Approaching the zero pose, 1 / (g^T M^-1 g) agrees with an extended-precision reference.
    zero = arm7.keyframe("zero")
    for eps in (1e-3, 1e-5, 1e-7):
        q = zero + eps
        J = arm7.jacobian(q)
        M = arm7.mass_matrix(q)
        u = np.array([0.0, 0.0, 1.0])
        g = (u @ J[:3]).astype(np.longdouble)
        ref = 1.0 / float(g @ np.linalg.solve(M, J[:3].T @ u).astype(np.longdouble))
        assert arm7.effective_mass(q, u) == pytest.approx(ref, rel=1e-9)


def test_bad_inputs_raise_the_librarys_errors(arm7: rd.Arm) -> None:
    q = arm7.keyframe("home")
    valid = r"a finite nonzero real vector of shape \(3,\)"
    for bad in ([0, 0, 0], [np.nan, 0, 1], [1, 2], "x", [1j, 0, 0], [np.inf, 0, 0]):
        with pytest.raises(rd.ParameterError, match=rf"^direction must be {valid}, got "):
            arm7.effective_mass(q, bad)
    with pytest.raises(rd.UnknownNameError, match=r"^unknown joint 'elbow'; valid joint names"):
        arm7.effective_mass(q, [1, 0, 0], joints=["j1", "elbow"])
    for bad in ([], ["j1", "j1"], "j1", 3):
        with pytest.raises(rd.ParameterError, match=r"^joints must be None or a nonempty"):
            arm7.operational_inertia(q, joints=bad)
    with pytest.raises(rd.UnknownNameError, match=r"^unknown engine 'bullet'"):
        arm7.effective_mass_range(q, engine="bullet")
    with pytest.raises(rd.PoseError, match=r"^pose has non-finite values: j2=nan$"):
        arm7.dynamic_manipulability(np.array([0, np.nan, 0, 0, 0, 0, 0.0]))
    with pytest.raises(rd.ParameterError, match=r"^direction must be .* or \(2, 3\)"):
        batch.effective_masses(arm7, np.vstack([q, q]), np.zeros((2, 3)))


def test_linalg_effective_mass_needs_no_engine() -> None:
    # A point mass of 2 kg on a slide along x: 2 kg along x, inf along y.
    J = np.zeros((6, 1))
    J[0, 0] = 1.0
    X = np.linalg.solve(np.array([[2.0]]), J.T)
    assert linalg.effective_mass(J, X, np.array([1.0, 0.0, 0.0])) == pytest.approx(2.0)
    assert linalg.effective_mass(J, X, np.array([0.0, 1.0, 0.0])) == np.inf


def test_the_audit_section_against_ts_15066(panda: rd.Arm) -> None:
    from redundancy.reports import sections

    c = sections.contact_mass(panda, 300, seed=4)
    m = panda.mj_model
    moving = m.body_weldid != 0  # bodies not welded to the world (the base link stays)
    assert c.moving_mass == pytest.approx(float(np.sum(m.body_mass[moving])), rel=1e-12)
    assert c.estimate == pytest.approx(0.5 * c.moving_mass)
    Q = rd.arm.random_poses(panda, 300, seed=4)
    samples = np.concatenate([batch.effective_masses(panda, Q, u) for u in np.eye(3)])
    assert c.with_armature == pytest.approx(
        (samples.min(), np.median(samples), samples.max()), rel=1e-12
    )
    assert c.below_estimate == pytest.approx(np.mean(samples > c.estimate))
    bare = np.concatenate([batch.effective_masses(panda, Q, u, armature=False) for u in np.eye(3)])
    assert c.without_armature[1] == pytest.approx(np.median(bare), rel=1e-12)
    lines = c.lines()
    assert lines[0].startswith("effective mass at the tool (ISO/TS 15066 transient contact)")
    assert f"= {c.estimate:.3g} kg" in lines[-1]


def test_pinocchios_inverse_mass_is_taken_at_the_pose_asked(arm7: rd.Arm) -> None:
    # integrate() writes the engine's pose buffer without moving its cache key: the mobility
    # must not read that buffer (it once did, and returned M^-1 of the wrong pose).
    a, b = rd.arm.random_poses(arm7, 2, seed=9)
    arm7.pinocchio.site_jacobian(b)
    arm7.pinocchio.integrate(a, np.zeros(7))
    u = np.array([1.0, 0.0, 0.0])
    assert arm7.effective_mass(b, u, engine="pinocchio") == pytest.approx(
        arm7.effective_mass(b, u), rel=1e-12
    )


def test_the_published_panda_at_its_hand_fingers_held() -> None:
    from redundancy.reports import sections

    from .test_ik import _erd

    arm = rd.load(_erd("panda_description/urdf/panda.urdf"), frame="panda_hand")
    worst = 0.0
    for q in rd.arm.random_poses(arm, 4, seed=12):
        for u in AXES[:3]:
            sim = _simulated_effective_mass(arm, q, u, True)
            for engine in ("mujoco", "pinocchio"):
                worst = max(worst, abs(arm.effective_mass(q, u, engine=engine) - sim) / sim)
    assert worst <= 1e-9
    # Its links from link1 to the hand and fingers weigh 16.8 kg: TS 15066 says 8.41 kg.
    c = sections.contact_mass(arm, 50, seed=0)
    assert c.estimate == pytest.approx(8.41, abs=0.005)

"""The two-engine core: agreement, algebraic laws and finite differences, pose by pose."""

from __future__ import annotations

import copy

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

import redundancy as rd
from redundancy import linalg
from redundancy.engines.mujoco import MujocoEngine
from redundancy.engines.pinocchio import PinocchioEngine
from redundancy.testing import poses

from .conftest import ARM_NAMES

# Tolerances. Engines: both evaluate the same rigid-body algorithms in double precision, so
# 1e-9 (relative to the quantity's scale, model.scales) leaves five orders of magnitude for rounding. Central
# finite differences with step 1e-6 have truncation error ~ eps^2 * |third derivative| and
# rounding ~ 1e-16 / eps, so 1e-7 absolute is their floor.
ENGINE_TOL = 1e-9
FD_STEP = 1e-6
FD_TOL = 1e-7


EACH_ARM = pytest.mark.parametrize("name", ARM_NAMES)


@EACH_ARM
@given(data=st.data())
def test_engines_agree(arms, engine_log, name, data):
    q = data.draw(poses(arms[name]))
    report = rd.crosscheck(arms[name], q)
    engine_log.record(name, report)
    assert report.ok, "\n".join(report.lines())


@EACH_ARM
@pytest.mark.parametrize("engine", rd.engines.ENGINES)
@given(data=st.data())
def test_jacobian_matches_finite_differences(arms, name, engine, data):
    q = data.draw(poses(arms[name]))
    arm = arms[name]
    eng = arm.engine(engine)
    J = eng.site_jacobian(q)
    fd = np.zeros_like(J)
    for k in range(arm.nq):
        dq = np.zeros(arm.nq)
        dq[k] = FD_STEP
        p1, R1 = eng.site_pose(eng.integrate(q, dq))
        p0, R0 = eng.site_pose(eng.integrate(q, -dq))
        fd[:3, k] = (p1 - p0) / (2 * FD_STEP)
        fd[3:, k] = pin.log3(R1 @ R0.T) / (2 * FD_STEP)  # world-frame rotation vector
    assert np.max(np.abs(J - fd)) < FD_TOL


@EACH_ARM
@pytest.mark.parametrize("engine", rd.engines.ENGINES)
@given(data=st.data())
def test_manipulability_gradient_matches_finite_differences(arms, name, engine, data):
    q = data.draw(poses(arms[name]))
    arm = arms[name]
    # w = prod(sigma) has a kink where a singular value reaches 0 (like |x| at 0): keep the
    # finite-difference stencil well away from singular poses.
    assume(linalg.jacobian_svd(arm.jacobian(q)).sigma[-1] > 1e-3)
    g = arm.manipulability_gradient(q, engine)
    fd = np.array(
        [
            (
                linalg.yoshikawa(arm.jacobian(q + FD_STEP * e, engine))
                - linalg.yoshikawa(arm.jacobian(q - FD_STEP * e, engine))
            )
            / (2 * FD_STEP)
            for e in np.eye(arm.nq)
        ]
    )
    assert np.max(np.abs(g - fd)) < FD_TOL


@EACH_ARM
@pytest.mark.parametrize("engine", rd.engines.ENGINES)
@given(data=st.data())
def test_singular_values_and_projector_laws(arms, name, engine, data):
    q = data.draw(poses(arms[name]))
    J = arms[name].jacobian(q, engine)
    s = linalg.jacobian_svd(J)
    assert np.all(s.sigma >= 0) and np.all(np.diff(s.sigma) <= 0)
    # prod(sigma)^2 = det(J J^T); det's rounding error is ~ eps * sigma_max^12, so compare
    # the squares with an absolute floor on that scale (at singular poses det is pure noise).
    with np.errstate(divide="ignore", invalid="ignore"):  # exactly singular J J^T
        det = np.linalg.det(J @ J.T)
    assert np.isclose(np.prod(s.sigma) ** 2, det, rtol=1e-9, atol=1e-13 * s.sigma[0] ** 12)
    N = linalg.nullspace_projector(J)
    # J^+ carries rounding amplified by the condition number of the kept singular values;
    # singular values below the rank tolerance are treated as 0, so J N and J B keep them.
    dropped = s.sigma[s.rank] if s.rank < len(s.sigma) else 0.0
    tol = 1e-13 * s.sigma[0] / s.sigma[s.rank - 1] + 1.01 * dropped
    assert np.max(np.abs(J @ N)) < tol
    assert np.max(np.abs(N @ N - N)) < tol
    assert np.max(np.abs(N - N.T)) < tol
    B = linalg.nullspace_basis(J)
    assert B.shape[1] == J.shape[1] - s.rank
    assert np.allclose(B.T @ B, np.eye(B.shape[1]), atol=1e-12)
    assert np.max(np.abs(J @ B)) < tol


@EACH_ARM
@pytest.mark.parametrize("engine", rd.engines.ENGINES)
@given(data=st.data())
def test_mass_matrix_symmetric_positive_definite(arms, name, engine, data):
    q = data.draw(poses(arms[name]))
    M = arms[name].mass_matrix(q, engine=engine)
    assert np.array_equal(M, M.T)
    assert np.linalg.eigvalsh(M)[0] > 0


def _without_armature(arm: rd.Arm) -> tuple[MujocoEngine, PinocchioEngine]:
    """Both engines rebuilt with every armature set to zero in the engine's own model."""
    mm = copy.copy(arm.mj_model)
    mm.dof_armature[:] = 0.0
    mm.actuator_armature[:] = 0.0
    pm = arm.pinocchio.model.copy()
    pm.armature[:] = 0.0
    return MujocoEngine(mm, arm.frame, np.zeros(arm.nq)), PinocchioEngine(
        pm, arm.frame, arm.joint_names
    )


@pytest.fixture(scope="module")
def bare(arms):
    return {name: _without_armature(a) for name, a in arms.items()}


@EACH_ARM
@given(data=st.data())
def test_armature_changes_only_the_diagonal_by_its_value(arms, bare, name, data):
    q = data.draw(poses(arms[name]))
    arm = arms[name]
    for eng, bare_eng in zip((arm.mujoco, arm.pinocchio), bare[name], strict=True):
        delta = eng.mass_matrix(q) - bare_eng.mass_matrix(q)
        assert np.allclose(delta, np.diag(arm.armature("mujoco")), rtol=0, atol=1e-12)
        assert np.allclose(
            eng.mass_matrix(q, armature=False), bare_eng.mass_matrix(q), rtol=0, atol=1e-12
        )


def test_arm7_zero_pose_loses_exactly_the_lessons_three_directions(arm7):
    # Lesson 5.2, "Why the straight-up pose has rank 3": translation along y and z and
    # rotation about x are lost.
    for engine in rd.engines.ENGINES:
        s = arm7.svd(arm7.keyframe("zero"), engine)
        assert s.rank == 3
        assert s.lost_direction_names() == ["translation y", "translation z", "rotation x"]
        assert s.condition == float("inf")
        assert s.manipulability == pytest.approx(0.0, abs=1e-15)


def test_home_pose_is_full_rank_and_damped_inverse_is_bounded(arm7):
    J = arm7.jacobian(arm7.keyframe("home"))
    assert linalg.jacobian_svd(J).rank == 6
    J0 = arm7.jacobian(arm7.keyframe("zero"))
    lam = 0.05
    D = linalg.damped_pinv(J0, lam)
    # Each singular value s maps to s / (s^2 + lam^2) <= 1 / (2 lam).
    assert np.linalg.norm(D, 2) <= 1 / (2 * lam) + 1e-12
    assert np.allclose(linalg.damped_pinv(J, 0.0), np.linalg.pinv(J), atol=1e-10)


@given(data=st.data())
def test_dynamically_consistent_nullspace_produces_no_tool_acceleration(arm7, data):
    q = data.draw(poses(arm7))
    J, M = arm7.jacobian(q), arm7.mass_matrix(q)
    assume(linalg.jacobian_svd(J).sigma[-1] > 1e-3)  # Lambda is undefined at a singular pose
    N = linalg.dynamic_nullspace_projector(J, M)
    tau = np.linspace(-1, 1, 7)
    # Tool acceleration from torque N^T tau is J M^-1 N^T tau = 0.
    assert np.max(np.abs(J @ np.linalg.solve(M, N.T @ tau))) < 1e-9 * np.linalg.cond(M)


def test_manipulability_blocks_and_scaling(arm7):
    J = arm7.jacobian(arm7.keyframe("home"))
    m = linalg.manipulability(J, length=0.5)
    assert m.full == pytest.approx(np.sqrt(np.linalg.det(J @ J.T)), rel=1e-12)
    assert m.position == pytest.approx(np.sqrt(np.linalg.det(J[:3] @ J[:3].T)), rel=1e-12)
    assert m.orientation == pytest.approx(np.sqrt(np.linalg.det(J[3:] @ J[3:].T)), rel=1e-12)
    # Dividing three rows by L divides the product of singular values by L^3.
    assert m.scaled == pytest.approx(m.full / 0.5**3, rel=1e-12)
    mm = linalg.manipulability(np.vstack([J[:3] * 1000, J[3:]]))  # lengths in mm
    assert mm.full == pytest.approx(m.full * 1000**3, rel=1e-9)


#: Arms with fewer joints than tool directions: 3 (yaw, pitch, pitch) and 5 (a wrist added).
SHORT_ARMS = {
    n: rd.load_string(
        f"""
<mujoco><compiler angle="radian"/><worldbody>
  <body name="l1"><joint name="j1" axis="0 0 1"/>
    <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.04"/>
    <body name="l2" pos="0 0 0.3"><joint name="j2" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.04"/>
      <body name="l3" pos="0.3 0 0"><joint name="j3" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.03"/>
        {
            '<body name="l4" pos="0.25 0 0"><joint name="j4" axis="1 0 0"/>'
            '<geom type="sphere" size="0.03" pos="0.05 0 0"/>'
            '<body name="l5" pos="0.1 0 0"><joint name="j5" axis="0 0 1"/>'
            '<geom type="sphere" size="0.02" pos="0.05 0 0.02"/><site name="tip" pos="0.1 0 0.03"/>'
            "</body></body>"
            if n == 5
            else '<site name="tip" pos="0.25 0 0"/>'
        }
      </body>
    </body>
  </body>
</worldbody></mujoco>""",
        frame="tip",
    )
    for n in (3, 5)
}


@pytest.mark.parametrize("n", sorted(SHORT_ARMS))
@pytest.mark.parametrize("engine", rd.engines.ENGINES)
@given(data=st.data())
def test_manipulability_of_short_arms_is_one_value_with_its_gradient(n, engine, data):
    """With fewer than 6 joints, value (product of the singular values, which is
    sqrt(det J^T J) there), stacks and gradient are one definition; the gradient was 0."""
    arm = SHORT_ARMS[n]
    assert arm.nq == n
    q = data.draw(poses(arm))
    J = arm.jacobian(q, engine)
    assume(linalg.jacobian_svd(J).sigma[-1] > 1e-3)  # away from the kink, as above
    w = arm.manipulability(q, engine=engine).full
    assert w > 0
    assert w == pytest.approx(np.sqrt(np.linalg.det(J.T @ J)), rel=1e-9)
    assert arm.svd(q, engine).manipulability == pytest.approx(w, rel=1e-12)
    assert rd.batch.manipulabilities(arm, q[None], engine=engine)[0] == pytest.approx(w, 1e-12)
    g = arm.manipulability_gradient(q, engine)
    fd = np.array(
        [
            (
                arm.manipulability(q + FD_STEP * e, engine=engine).full
                - arm.manipulability(q - FD_STEP * e, engine=engine).full
            )
            / (2 * FD_STEP)
            for e in np.eye(n)
        ]
    )
    assert np.max(np.abs(g - fd)) < FD_TOL


def test_short_arm_manipulability_gradient_is_not_zero():
    """The value changes with the elbow: the gradient was once [0, 0, 0]."""
    arm = SHORT_ARMS[3]
    g = arm.manipulability_gradient([0.3, 0.4, 0.5])
    assert abs(g[2]) > 1e-3 and abs(g[0]) < 1e-12  # the yaw about the base changes nothing

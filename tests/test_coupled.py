"""Coupled joints on the chain: URDF mimics and MJCF polynomial joint equalities.

Ground truth is outside the library: the followers' values and G = dx/dq from the
polynomials written in the files (computed here), MuJoCo's model of the whole robot
(``arm.robot_model``, every joint free) for positions, the full mass matrix (``mj_fullM``)
and gravity (``qfrc_bias`` at rest); the Jacobian by central differences of raw MuJoCo site
positions and rotations.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import redundancy as rd

#: A 5-joint arm: j3 a quadratic of j2 (both with a ref), the slide j5 a line of j3 (a
#: follower of a follower); the arm's coordinates are j1, j2, j4.
POLY_MJCF = """<mujoco model="poly"><compiler angle="radian"/>
<worldbody>
<body name="l1" pos="0 0 0.1"><joint name="j1" axis="0 0 1" range="-2 2"/>
 <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.04" mass="2"/>
 <body name="l2" pos="0 0 0.3"><joint name="j2" axis="0 1 0" range="-1.5 1.5" ref="0.1"/>
  <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1.5"/>
  <body name="l3" pos="0.3 0 0">
   <joint name="j3" axis="0 1 0" range="-2 1.2" ref="-0.2" armature="0.01"/>
   <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.03" mass="1"/>
   <body name="l4" pos="0.25 0 0"><joint name="j4" axis="1 0 0" range="-3 3"/>
    <geom type="box" size="0.03 0.02 0.02" mass="0.5"/>
    <body name="l5" pos="0.1 0 0">
     <joint name="j5" type="slide" axis="1 0 0" range="-0.1 0.1" armature="0.2"/>
     <geom type="box" size="0.02 0.02 0.02" mass="0.2"/><site name="tool" pos="0.05 0.02 0"/>
    </body></body></body></body></body>
</worldbody>
<equality><joint name="elbow" joint1="j3" joint2="j2" polycoef="0.05 0.8 0.3 0 0"/>
<joint joint1="j5" joint2="j3" polycoef="0.01 0.03 0 0 0"/></equality>
</mujoco>"""


def poly_followers(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """POLY_MJCF's chain pose (j1..j5) and G, from its polynomials."""
    j1, j2, j4 = q
    t2 = j2 - 0.1
    j3 = -0.2 + 0.05 + 0.8 * t2 + 0.3 * t2**2
    d3 = 0.8 + 0.6 * t2
    j5 = 0.01 + 0.03 * (j3 + 0.2)
    x = np.array([j1, j2, j3, j4, j5])
    G = np.zeros((5, 3))
    G[0, 0] = G[1, 1] = G[3, 2] = 1.0
    G[2, 1] = d3
    G[4, 1] = 0.03 * d3
    return x, G


def _link(name: str, mass: float, length: float) -> str:
    return (
        f'<link name="{name}"><inertial><origin xyz="{length / 2} 0 0"/><mass value="{mass}"/>'
        f'<inertia ixx="0.001" iyy="{mass * length**2 / 12 + 0.001}" '
        f'izz="{mass * length**2 / 12 + 0.001}" ixy="0" ixz="0" iyz="0"/></inertial></link>'
    )


#: The URDF twin: j3 mimics j2 (multiplier -0.7, offset 0.15), the slide j5 mimics j4.
MIMIC_URDF = f"""<robot name="mimic">
<link name="base"/>{_link("l1", 2.0, 0.3)}{_link("l2", 1.5, 0.3)}{_link("l3", 1.0, 0.25)}
{_link("l4", 0.5, 0.1)}{_link("l5", 0.2, 0.05)}<link name="tool"/>
<joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
 <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="10" velocity="1"/></joint>
<joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
 <origin xyz="0 0 0.3"/><axis xyz="0 1 0"/><limit lower="-1.5" upper="1.5" effort="10" velocity="1"/></joint>
<joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/>
 <origin xyz="0.3 0 0"/><axis xyz="0 1 0"/><limit lower="-2" upper="1.2" effort="10" velocity="1"/>
 <mimic joint="j2" multiplier="-0.7" offset="0.15"/></joint>
<joint name="j4" type="revolute"><parent link="l3"/><child link="l4"/>
 <origin xyz="0.25 0 0"/><axis xyz="1 0 0"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
<joint name="j5" type="prismatic"><parent link="l4"/><child link="l5"/>
 <origin xyz="0.1 0 0"/><axis xyz="1 0 0"/><limit lower="-0.1" upper="0.1" effort="10" velocity="1"/>
 <mimic joint="j4" multiplier="0.02"/></joint>
<joint name="tool_joint" type="fixed"><parent link="l5"/><child link="tool"/>
 <origin xyz="0.05 0.02 0"/></joint>
</robot>"""


def mimic_followers(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """MIMIC_URDF's chain pose and G, from its mimics."""
    j1, j2, j4 = q
    x = np.array([j1, j2, -0.7 * j2 + 0.15, j4, 0.02 * j4])
    G = np.zeros((5, 3))
    G[0, 0] = G[1, 1] = G[3, 2] = 1.0
    G[2, 1] = -0.7
    G[4, 2] = 0.02
    return x, G


CASES = {
    "mjcf polynomial": (POLY_MJCF, "tool", poly_followers),
    "urdf mimic": (MIMIC_URDF, "tool", mimic_followers),
}


@pytest.fixture(scope="module", params=list(CASES))
def case(request: pytest.FixtureRequest) -> tuple[rd.Arm, object]:
    xml, tool, followers = CASES[request.param]
    return rd.load_string(xml, frame=tool), followers


def _raw(arm: rd.Arm, x: np.ndarray) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """Raw MuJoCo's whole model at chain pose ``x`` (kinematics and dynamics at rest)."""
    m = arm.robot_model
    d = mujoco.MjData(m)
    for name, value in zip(arm.chain_joint_names, x, strict=True):
        d.qpos[m.jnt_qposadr[m.joint(name).id]] = value
    mujoco.mj_forward(m, d)
    return m, d


def _site(arm: rd.Arm, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    m, d = _raw(arm, x)
    sid = m.site(arm.frame).id
    return d.site_xpos[sid].copy(), d.site_xmat[sid].reshape(3, 3).copy()


def fd_jacobian(arm: rd.Arm, followers: object, q: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """Central differences of raw MuJoCo's tool position and rotation along each coordinate."""
    J = np.zeros((6, len(q)))
    for k in range(len(q)):
        e = np.zeros(len(q))
        e[k] = h
        pp, Rp = _site(arm, followers(q + e)[0])  # type: ignore[operator]
        pm, Rm = _site(arm, followers(q - e)[0])  # type: ignore[operator]
        J[:3, k] = (pp - pm) / (2 * h)
        W = (Rp @ Rm.T - Rm @ Rp.T) / 2  # sin of the rotation between them, skew
        J[3:, k] = np.array([W[2, 1], W[0, 2], W[1, 0]]) / (2 * h)
    return J


def test_the_arm_is_its_independent_joints(case: tuple[rd.Arm, object]) -> None:
    arm, _ = case
    assert arm.joint_names == ("j1", "j2", "j4")
    assert arm.chain_joint_names == ("j1", "j2", "j3", "j4", "j5")
    assert set(arm.followers) == {"j3", "j5"}
    assert arm.nq == 3
    assert arm.mass_matrix(np.zeros(3)).shape == (3, 3)


def test_followers_say_what_determines_them() -> None:
    arm = rd.load_string(POLY_MJCF, frame="tool")
    assert arm.followers["j3"] == (
        "joint equality (j3 + 0.2) = 0.05 + 0.8 (j2 - 0.1) + 0.3 (j2 - 0.1)^2"
    )
    assert arm.followers["j5"] == "joint equality j5 = 0.01 + 0.03 (j3 + 0.2)"
    urdf = rd.load_string(MIMIC_URDF, frame="tool")
    assert urdf.followers["j3"] == "joint equality j3 = 0.15 - 0.7 j2"


@pytest.mark.parametrize("seed", range(5))
def test_chain_pose_and_G_are_the_files_couplings(case: tuple[rd.Arm, object], seed: int) -> None:
    arm, followers = case
    q = rd.random_poses(arm, 1, seed=seed)[0]
    x, G = followers(q)  # type: ignore[operator]
    assert np.max(np.abs(arm.chain_pose(q) - x)) <= 1e-15
    assert np.max(np.abs(arm.coupling_jacobian(q) - G)) <= 1e-15


@pytest.mark.parametrize("engine", ["mujoco", "pinocchio"])
def test_jacobian_against_finite_differences_of_raw_mujoco(
    case: tuple[rd.Arm, object], engine: str
) -> None:
    arm, followers = case
    for q in rd.random_poses(arm, 10, seed=3):
        assert np.max(np.abs(arm.jacobian(q, engine) - fd_jacobian(arm, followers, q))) <= 1e-7


@pytest.mark.parametrize("engine", ["mujoco", "pinocchio"])
def test_mass_matrix_and_gravity_are_GT_M_G_of_raw_mujoco(
    case: tuple[rd.Arm, object], engine: str
) -> None:
    arm, followers = case
    for q in rd.random_poses(arm, 10, seed=4):
        x, G = followers(q)  # type: ignore[operator]
        m, d = _raw(arm, x)
        dofs = [int(m.jnt_dofadr[m.joint(n).id]) for n in arm.chain_joint_names]
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M)
        M_ref = G.T @ M[np.ix_(dofs, dofs)] @ G
        g_ref = G.T @ d.qfrc_bias[dofs]
        M_arm = arm.mass_matrix(q, engine=engine)
        assert np.max(np.abs(M_arm - M_ref)) <= 1e-10 * np.max(np.abs(M_ref))
        assert np.max(np.abs(arm.gravity(q, engine) - g_ref)) <= 1e-10 * np.max(np.abs(g_ref))


def test_crosscheck_ok_over_200_poses(case: tuple[rd.Arm, object]) -> None:
    arm, _ = case
    report = rd.crosscheck(arm, rd.random_poses(arm, 200, seed=7))
    assert report.ok, report.summary()


def test_random_poses_keep_followers_in_their_ranges() -> None:
    arm = rd.load_string(POLY_MJCF, frame="tool")
    Q = rd.random_poses(arm, 300, seed=2)
    X = np.array([poly_followers(q)[0] for q in Q])
    lo, hi = arm.reference.inner.limits
    assert np.all((X >= lo - 1e-9) & (X <= hi + 1e-9))
    # j3's range [-2, 1.2] cuts the quadratic of j2 in [-1.5, 1.5]: some draws were refused.
    raw = np.random.default_rng(2).uniform(arm.lower, arm.upper, size=(300, 3))
    assert any(poly_followers(q)[0][2] > 1.2 for q in raw)
    assert not np.array_equal(raw, Q)
    assert Q.shape == (300, 3) and np.all((Q >= arm.lower) & (Q <= arm.upper))


# -- dynamics, inverse kinematics, stacks ------------------------------------------------------


@pytest.mark.parametrize("engine", ["mujoco", "pinocchio"])
def test_coriolis_with_the_rate_of_G(engine: str) -> None:
    # The quadratic coupling makes G move: dM/dt = C + C^T needs G^T M dG/dt in C, and C v
    # is the reduced bias G^T (C_x G v + M_x dG/dt v) of raw MuJoCo's whole model.
    arm = rd.load_string(POLY_MJCF, frame="tool")
    h = 1e-6
    rng = np.random.default_rng(0)
    for q in rd.random_poses(arm, 5, seed=8):
        v = rng.normal(size=3)
        C = arm.coriolis(q, v, engine=engine)
        dM = (arm.mass_matrix(q + h * v) - arm.mass_matrix(q - h * v)) / (2 * h)
        assert np.max(np.abs(C + C.T - dM)) <= 1e-7 * np.max(np.abs(arm.mass_matrix(q)))
        # Raw MuJoCo: the chain moving at x' = G v, accelerating at dG/dt v (v constant).
        x, G = poly_followers(q)
        Gdot = (poly_followers(q + h * v)[1] - poly_followers(q - h * v)[1]) / (2 * h)
        m = arm.robot_model
        d = mujoco.MjData(m)
        dofs = [int(m.jnt_dofadr[m.joint(n).id]) for n in arm.chain_joint_names]
        d.qpos[dofs] = x
        d.qvel[dofs] = G @ v
        d.qacc[dofs] = Gdot @ v
        m0 = copy_without_gravity(m)
        mujoco.mj_inverse(m0, d)
        assert np.max(np.abs(C @ v - G.T @ d.qfrc_inverse[dofs])) <= 1e-6 * max(
            1.0, np.max(np.abs(C @ v))
        )


def copy_without_gravity(m: mujoco.MjModel) -> mujoco.MjModel:
    import copy

    m0 = copy.copy(m)
    m0.opt.gravity[:] = 0.0
    m0.dof_damping[:] = 0.0
    m0.jnt_stiffness[:] = 0.0
    return m0


def test_effective_mass_is_that_of_the_reduced_J_and_M(case: tuple[rd.Arm, object]) -> None:
    arm, _ = case
    u = np.array([0.0, 0.0, 1.0])
    for q in rd.random_poses(arm, 5, seed=9):
        J, M = arm.jacobian(q)[:3], arm.mass_matrix(q)
        expected = 1.0 / (u @ J @ np.linalg.solve(M, J.T) @ u)
        assert arm.effective_mass(q, u) == pytest.approx(expected, rel=1e-10)
        assert arm.effective_mass(q, u, engine="pinocchio") == pytest.approx(expected, rel=1e-9)


def test_inverse_kinematics_in_the_independent_coordinates(case: tuple[rd.Arm, object]) -> None:
    arm, followers = case
    goal = rd.random_poses(arm, 1, seed=10)[0]
    target = _site(arm, followers(goal)[0])  # type: ignore[operator]
    result = arm.solve_ik(target, position_only=True)
    assert result.success, result
    x, _ = followers(result.q)  # type: ignore[operator]
    assert np.linalg.norm(_site(arm, x)[0] - target[0]) <= 1e-5


def test_batch_stacks_equal_the_single_pose_quantities(case: tuple[rd.Arm, object]) -> None:
    arm, _ = case
    Q = rd.random_poses(arm, 20, seed=11)
    J = rd.batch.jacobians(arm, Q)
    M = rd.batch.mass_matrices(arm, Q)
    for q, Ji, Mi in zip(Q, J, M, strict=True):
        assert np.max(np.abs(Ji - arm.jacobian(q))) <= 1e-14
        assert np.max(np.abs(Mi - arm.mass_matrix(q))) <= 1e-14 * np.max(np.abs(Mi))


# -- refusals -----------------------------------------------------------------------------------


def test_circular_couplings_are_refused_naming_the_joints() -> None:
    xml = POLY_MJCF.replace(
        '<joint joint1="j5" joint2="j3"',
        '<joint joint1="j2" joint2="j5" polycoef="0 1 0 0 0"/><joint joint1="j5" joint2="j3"',
    )
    with pytest.raises(rd.ModelError) as err:
        rd.load_string(xml, frame="tool")
    assert str(err.value) == (
        "circular couplings: joints 'j2' -> 'j5' -> 'j3' -> 'j2' follow each other (URDF "
        "<mimic> or MJCF joint equalities); one of them must be a free leader"
    )


def test_contradictory_couplings_are_refused_naming_the_joint() -> None:
    xml = POLY_MJCF.replace(
        '<joint joint1="j5" joint2="j3"',
        '<joint name="again" joint1="j3" joint2="j1" polycoef="0 2 0 0 0"/><joint joint1="j5" joint2="j3"',
    )
    with pytest.raises(rd.ModelError) as err:
        rd.load_string(xml, frame="tool")
    assert str(err.value).startswith(
        "contradictory couplings: joint 'j3' follows two joint equalities, 'elbow' ("
    )
    assert "'again' ((j3 + 0.2) = 2 j1)" in str(err.value)


def test_the_observers_momentum_terms_are_the_reduced_lagrangians(case) -> None:
    """p = M_q v and beta = dM_q/dt v - (C_q v + g_q), from raw MuJoCo and the file's G.

    Ground truth: M_x and the bias C_x x' + g_x of raw MuJoCo's whole model, the file's G;
    dM_q/dt and dG/dt by central differences along v; C_q v = G^T (C_x x' + M_x dG/dt v).
    """
    from redundancy.analysis.observer import MomentumObserver

    arm, followers = case
    MomentumObserver(arm, 20.0)  # builds on a coupled arm
    rng = np.random.default_rng(3)

    def raw(q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        x, G = followers(q)  # type: ignore[operator]
        m, d = _raw(arm, x)
        dofs = [int(m.jnt_dofadr[m.joint(n).id]) for n in arm.chain_joint_names]
        d.qvel[:] = 0
        for i, dof in enumerate(dofs):
            d.qvel[dof] = (G @ v)[i]
        mujoco.mj_forward(m, d)
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M)
        return M[np.ix_(dofs, dofs)], d.qfrc_bias[dofs].copy(), G

    h = 1e-6
    for q in rd.random_poses(arm, 5, seed=9):
        v = rng.normal(size=arm.nq)
        Mx, bias, G = raw(q, v)
        Mq = G.T @ Mx @ G
        Mp, _, Gp = raw(q + h * v, v)
        Mm, _, Gm = raw(q - h * v, v)
        dMq = (Gp.T @ Mp @ Gp - Gm.T @ Mm @ Gm) / (2 * h)
        dG = (Gp - Gm) / (2 * h)
        Cv_g = G.T @ (bias + Mx @ dG @ v)  # C_q v + g_q
        p, beta = arm.mujoco.momentum_terms(q, v)
        scale = np.max(np.abs(Mq)) * (1 + np.abs(v).max()) ** 2
        assert np.max(np.abs(p - Mq @ v)) <= 1e-10 * scale
        assert np.max(np.abs(beta - (dMq @ v - Cv_g))) <= 1e-6 * scale

"""Closed loops on the chain: a planar four-bar closed by ``<equality><connect>``.

Ground truth is the four-bar's closed form: Freudenstein's relation for the rocker angle
from the crank's, the coupler's angle from the two, and the velocity analysis for G; raw
MuJoCo's model of the whole robot for positions (finite differences for J), the full mass
matrix and gravity.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import redundancy as rd


def _quat_z(t: float) -> str:
    return f"{float(np.cos(t / 2))!r} 0 0 {float(np.sin(t / 2))!r}"


class FourBar:
    """A planar four-bar: crank a from the origin, coupler b, rocker c from (d, 0), hinges on z.

    The chain is crank -> coupler (the tool on the coupler); the rocker hangs from the world
    and the loop is closed by a connect at the coupler's tip. Gravity lies in the plane.
    """

    def __init__(self, a: float, b: float, c: float, d: float, crank_range: str = "") -> None:
        self.a, self.b, self.c, self.d = a, b, c, d
        t3, t4 = self.angles(0.0)
        self.t3_0, self.t4_0 = t3, t4
        rng = f' range="{crank_range}"' if crank_range else ""
        self.xml = f"""<mujoco model="four-bar"><compiler angle="radian"/>
<option gravity="0 -9.81 0"/>
<worldbody><body name="ground">
 <body name="crank"><joint name="crank" axis="0 0 1"{rng}/>
  <geom type="capsule" fromto="0 0 0 {a} 0 0" size="0.01" mass="0.2"/>
  <body name="coupler" pos="{a} 0 0" quat="{_quat_z(t3)}"><joint name="coupler" axis="0 0 1"/>
   <geom type="capsule" fromto="0 0 0 {b} 0 0" size="0.01" mass="0.5"/>
   <site name="tip" pos="{b / 2} 0.05 0"/></body></body>
 <body name="rocker" pos="{d} 0 0" quat="{_quat_z(t4)}"><joint name="rocker" axis="0 0 1"/>
  <geom type="capsule" fromto="0 0 0 {c} 0 0" size="0.01" mass="0.3"/></body>
</body></worldbody>
<equality><connect name="loop" body1="coupler" body2="rocker" anchor="{b} 0 0"/></equality>
</mujoco>"""

    def freudenstein(self, t2: float) -> tuple[float, float]:
        """The rocker's two angles at crank angle t2 (Freudenstein's relation, both branches)."""
        a, b, c, d = self.a, self.b, self.c, self.d
        K1, K2, K3 = d / a, d / c, (a * a - b * b + c * c + d * d) / (2 * a * c)
        A = np.cos(t2) - K1 - K2 * np.cos(t2) + K3
        B = -2 * np.sin(t2)
        C = K1 - (K2 + 1) * np.cos(t2) + K3
        root = np.sqrt(B * B - 4 * A * C)
        return 2 * np.arctan2(-B + root, 2 * A), 2 * np.arctan2(-B - root, 2 * A)

    def angles(self, t2: float) -> tuple[float, float]:
        """Coupler and rocker world angles at crank angle t2 (the branch with the tip above BD)."""
        B = self.a * np.array([np.cos(t2), np.sin(t2)])
        D = np.array([self.d, 0.0])
        cands = []
        for t4 in self.freudenstein(t2):
            C = D + self.c * np.array([np.cos(t4), np.sin(t4)])
            side = (D - B)[0] * (C - B)[1] - (D - B)[1] * (C - B)[0]
            cands.append((side, t4, C))
        _, t4, C = max(cands, key=lambda s: s[0])
        return float(np.arctan2(C[1] - B[1], C[0] - B[0])), float(t4)

    def chain(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(crank, coupler, rocker) joint values and G at crank q, from the closed form."""
        t2 = float(q[0])
        t3, t4 = self.angles(t2)
        x = np.array([t2, t3 - t2 - self.t3_0, t4 - self.t4_0])
        # a e^{i t2} + b e^{i t3} - c e^{i t4} = d: its rate, solved for the other two rates.
        lhs = np.array(
            [
                [-self.b * np.sin(t3), self.c * np.sin(t4)],
                [self.b * np.cos(t3), -self.c * np.cos(t4)],
            ]
        )
        rhs = np.array([self.a * np.sin(t2), -self.a * np.cos(t2)])
        w3, w4 = np.linalg.solve(lhs, rhs)
        return x, np.array([[1.0], [w3 - 1.0], [w4]])


CRANK_ROCKER = FourBar(0.1, 0.3, 0.25, 0.3)  # Grashof: the crank turns all the way
TRIPLE_ROCKER = FourBar(0.2, 0.2, 0.2, 0.35, crank_range="-3.1 3.1")  # it cannot


@pytest.fixture(scope="module")
def fourbar() -> rd.Arm:
    return rd.load_string(CRANK_ROCKER.xml, frame="tip")


def _raw(arm: rd.Arm, x: np.ndarray) -> tuple[mujoco.MjModel, mujoco.MjData]:
    m = arm.robot_model
    d = mujoco.MjData(m)
    for name, value in zip(arm.chain_joint_names, x, strict=True):
        d.qpos[m.jnt_qposadr[m.joint(name).id]] = value
    mujoco.mj_forward(m, d)
    return m, d


def test_the_crank_is_the_arm_and_the_rest_follow(fourbar: rd.Arm) -> None:
    assert fourbar.joint_names == ("crank",)
    assert fourbar.chain_joint_names == ("crank", "coupler", "rocker")
    assert set(fourbar.followers) == {"coupler", "rocker"}
    assert "'loop'" in fourbar.followers["rocker"]


def test_rocker_follows_freudensteins_relation(fourbar: rd.Arm) -> None:
    for t2 in np.linspace(-np.pi, np.pi, 41):
        x = fourbar.chain_pose([t2])
        ref, _ = CRANK_ROCKER.chain(np.array([t2]))
        rocker = x[2] + CRANK_ROCKER.t4_0
        assert (
            min(abs(np.angle(np.exp(1j * (rocker - t4)))) for t4 in CRANK_ROCKER.freudenstein(t2))
            <= 1e-10
        )
        assert np.max(np.abs(np.angle(np.exp(1j * (x - ref))))) <= 1e-10


def test_the_loop_closes_to_1e_12_m_in_raw_mujoco(fourbar: rd.Arm) -> None:
    for q in rd.random_poses(fourbar, 50, seed=1):
        m, d = _raw(fourbar, fourbar.chain_pose(q))
        tip = d.xpos[m.body("coupler").id] + d.xmat[m.body("coupler").id].reshape(3, 3) @ [
            CRANK_ROCKER.b,
            0,
            0,
        ]
        end = d.xpos[m.body("rocker").id] + d.xmat[m.body("rocker").id].reshape(3, 3) @ [
            CRANK_ROCKER.c,
            0,
            0,
        ]
        assert np.linalg.norm(tip - end) <= 1e-12


def test_G_is_the_velocity_analysis(fourbar: rd.Arm) -> None:
    for q in rd.random_poses(fourbar, 20, seed=2):
        G = fourbar.coupling_jacobian(q)
        assert np.max(np.abs(G - CRANK_ROCKER.chain(q)[1])) <= 1e-10


@pytest.mark.parametrize("engine", ["mujoco", "pinocchio"])
def test_jacobian_mass_and_gravity_against_raw_mujoco(fourbar: rd.Arm, engine: str) -> None:
    h = 1e-6
    for q in rd.random_poses(fourbar, 10, seed=3):
        x, G = CRANK_ROCKER.chain(q)
        m, d = _raw(fourbar, x)
        sid = m.site("tip").id
        plus = _raw(fourbar, CRANK_ROCKER.chain(q + h)[0])[1].site_xpos[sid].copy()
        minus = _raw(fourbar, CRANK_ROCKER.chain(q - h)[0])[1].site_xpos[sid].copy()
        J = fourbar.jacobian(q, engine)
        assert np.max(np.abs(J[:3, 0] - (plus - minus) / (2 * h))) <= 1e-7
        # The planar tool turns with the coupler: its angular rate is the coupler's.
        assert np.max(np.abs(J[3:, 0] - [0, 0, G[0, 0] + G[1, 0]])) <= 1e-7
        dofs = [int(m.jnt_dofadr[m.joint(n).id]) for n in fourbar.chain_joint_names]
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M)
        M_ref = G.T @ M[np.ix_(dofs, dofs)] @ G
        g_ref = G.T @ d.qfrc_bias[dofs]
        assert np.max(np.abs(fourbar.mass_matrix(q, engine=engine) - M_ref)) <= 1e-10 * np.max(
            np.abs(M_ref)
        )
        assert np.max(np.abs(fourbar.gravity(q, engine) - g_ref)) <= 1e-10 * np.max(np.abs(g_ref))


def test_crosscheck_ok_over_200_poses(fourbar: rd.Arm) -> None:
    report = rd.crosscheck(fourbar, rd.random_poses(fourbar, 200, seed=5))
    assert report.ok, report.summary()


def test_coriolis_is_the_christoffel_form_of_the_reduced_mass_matrix(fourbar: rd.Arm) -> None:
    # dM/dt = C + C^T, dM/dt by a central difference of the reduced M along v.
    h = 1e-6
    for q, v in zip(rd.random_poses(fourbar, 5, seed=6), [0.7, -1.3, 2.0, 0.4, -0.9], strict=True):
        v = np.array([v])
        C = fourbar.coriolis(q, v)
        dM = (fourbar.mass_matrix(q + h * v) - fourbar.mass_matrix(q - h * v)) / (2 * h)
        assert np.max(np.abs(C + C.T - dM)) <= 1e-6 * np.max(np.abs(fourbar.mass_matrix(q)))


def test_a_pose_the_loop_cannot_reach_raises_naming_the_constraint() -> None:
    arm = rd.load_string(TRIPLE_ROCKER.xml, frame="tip")
    # At a crank of 3 rad the coupler and rocker (0.4 m together) cannot span 0.54 m.
    with pytest.raises(rd.PoseError) as err:
        arm.chain_pose([3.0])
    assert str(err.value).startswith("the loop closed by equality 'loop' cannot close at this pose")
    with pytest.raises(rd.PoseError, match="equality 'loop'"):
        arm.jacobian([3.0])
    Q = rd.random_poses(arm, 100, seed=0)
    assert np.max(np.abs(Q)) < 3.0  # the draws past the reach are not drawn
    for q in Q[:10]:
        wrapped = np.angle(np.exp(1j * (arm.chain_pose(q) - TRIPLE_ROCKER.chain(q)[0])))
        assert np.max(np.abs(wrapped)) <= 1e-10


# -- a Robotiq 2F-85-style gripper, in MuJoCo Menagerie's pattern -----------------------------

GRIPPER = "examples/gripper_2f85.xml"


@pytest.fixture(scope="module")
def gripper() -> rd.Arm:
    from pathlib import Path

    return rd.load(Path(__file__).resolve().parents[1] / GRIPPER, frame="right_pad")


def test_the_gripper_finger_is_its_two_chain_joints(gripper: rd.Arm) -> None:
    # The finger's loop leaves two freedoms (the adaptive finger): its two chain joints.
    assert gripper.joint_names == ("right_spring_link_joint", "right_follower_joint")
    assert set(gripper.followers) == {
        "right_driver_joint",
        "right_coupler_joint",
        "left_driver_joint",
        "left_spring_link_joint",
        "left_follower_joint",
    }
    assert gripper.followers["right_coupler_joint"].startswith(
        "closes the loop of equality 'right_loop'; moved by"
    )
    # The other finger's passive freedom moves nothing on the chain: held at rest.
    assert gripper.held == {"left_coupler_joint": 0.0}
    assert {a.name for a in gripper.set_aside} >= {"right_loop", "left_loop", "drivers", "split"}


def test_the_gripper_loops_close_in_raw_mujoco(gripper: rd.Arm) -> None:
    m = gripper.robot_model
    for q in rd.random_poses(gripper, 20, seed=1):
        _, d = _raw(gripper, gripper.chain_pose(q))
        for k in range(m.neq):
            if m.eq_type[k] != mujoco.mjtEq.mjEQ_CONNECT:
                continue
            b1, b2 = m.eq_obj1id[k], m.eq_obj2id[k]
            p1 = d.xpos[b1] + d.xmat[b1].reshape(3, 3) @ m.eq_data[k][:3]
            p2 = d.xpos[b2] + d.xmat[b2].reshape(3, 3) @ m.eq_data[k][3:6]
            assert np.linalg.norm(p1 - p2) <= 1e-12
        names = gripper.chain_joint_names
        x = gripper.chain_pose(q)
        assert x[names.index("right_driver_joint")] == pytest.approx(
            x[names.index("left_driver_joint")], abs=1e-12
        )


@pytest.mark.parametrize("engine", ["mujoco", "pinocchio"])
def test_the_gripper_against_raw_mujoco(gripper: rd.Arm, engine: str) -> None:
    h = 1e-6
    m = gripper.robot_model
    sid = m.site("right_pad").id
    for q in rd.random_poses(gripper, 5, seed=2):
        J = gripper.jacobian(q, engine)
        for k in range(2):
            e = np.eye(2)[k] * h
            plus = _raw(gripper, gripper.chain_pose(q + e))[1].site_xpos[sid].copy()
            minus = _raw(gripper, gripper.chain_pose(q - e))[1].site_xpos[sid].copy()
            assert np.max(np.abs(J[:3, k] - (plus - minus) / (2 * h))) <= 1e-7
        G = gripper.coupling_jacobian(q)
        _, d = _raw(gripper, gripper.chain_pose(q))
        dofs = [int(m.jnt_dofadr[m.joint(n).id]) for n in gripper.chain_joint_names]
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M)
        M_ref = G.T @ M[np.ix_(dofs, dofs)] @ G
        M_arm = gripper.mass_matrix(q, engine=engine)
        assert np.max(np.abs(M_arm - M_ref)) <= 1e-10 * np.max(np.abs(M_ref))
        g_ref = G.T @ d.qfrc_bias[dofs]
        assert np.max(np.abs(gripper.gravity(q, engine) - g_ref)) <= 1e-10 * np.max(np.abs(g_ref))


def test_the_gripper_crosscheck_ok_over_200_poses(gripper: rd.Arm) -> None:
    Q = rd.random_poses(gripper, 200, seed=3)
    lo, hi = gripper.reference.inner.limits
    X = np.array([gripper.chain_pose(q) for q in Q])
    assert np.all((X >= lo - 1e-9) & (X <= hi + 1e-9))  # the drivers' 0..0.8 kept
    report = rd.crosscheck(gripper, Q)
    assert report.ok, report.summary()


def test_the_small_normal_equations_solve_is_numpys_least_squares():
    from redundancy.engines.coupling import _least_squares

    rng = np.random.default_rng(5)
    for rows, k in [(3, 1), (3, 2), (6, 3), (9, 6), (12, 7)]:
        A, b = rng.normal(size=(rows, k)), rng.normal(size=rows)
        ref = np.linalg.lstsq(A, b, rcond=None)[0]
        assert np.max(np.abs(_least_squares(A, b) - ref)) <= 1e-12 * np.max(np.abs(ref))
    # Rank-deficient (two equal columns): the factor refuses, the SVD's minimum-norm answer.
    A = rng.normal(size=(4, 2))
    A[:, 1] = A[:, 0]
    b = rng.normal(size=4)
    assert np.array_equal(_least_squares(A, b), np.linalg.lstsq(A, b, rcond=None)[0])

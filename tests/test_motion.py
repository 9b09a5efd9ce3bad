"""Motion: the Coriolis matrix, dM/dt, the whole robot's centre of mass and momentum.

Ground truth is MuJoCo's model of the WHOLE robot (``arm.robot_model``, every joint free) at
rest with the arm's pose and velocity put in (held joints still), never the arm's reduced
models; the two engines are also held to each other.
"""

from __future__ import annotations

import multiprocessing
import re
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

import mujoco
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import redundancy as rd
from redundancy import batch
from redundancy.analysis.crosscheck import crosscheck_velocities
from redundancy.model.names import display_names
from redundancy.testing import states

from .test_robot import ACTUATORS, BIMANUAL_MAIN, HUMANOID, SIDE

ENGINES = ("mujoco", "pinocchio")

#: Published robots with held joints: the Panda's fingers (and its base link welded to the
#: world), Talos's arm on its held torso (legs, head, other arm, free base held), the G1's
#: left arm from the pelvis (waist, legs, hands held).
HELD = (
    ("panda_description/urdf/panda.urdf", "panda_hand", None),
    ("talos_data/robots/talos_full_v2.urdf", "gripper_left_base_link", "torso_2_link"),
    ("g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf", "left_hand_palm_link", None),
)

#: Two links swinging about parallel axes, link 1 of length l1 = 0.5, link 2's centre of mass
#: lc2 = 0.3 along it, m2 = 2: C = h [[-qd2, -(qd1 + qd2)], [qd1, 0]], h = m2 l1 lc2 sin q2,
#: whatever the links' inertias (the textbook's planar two-link arm).
TWO_LINK = """
<mujoco>
  <worldbody>
    <body name="l1">
      <joint name="j1" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.02" mass="0"/>
      <inertial pos="0.25 0 0" mass="1" diaginertia="0.01 0.02 0.03"/>
      <body name="l2" pos="0.5 0 0">
        <joint name="j2" axis="0 1 0"/>
        <inertial pos="0.3 0 0" mass="2" diaginertia="0.02 0.05 0.04"/>
        <site name="ee" pos="0.6 0 0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

#: A slide joint between two hinges, a base welded to the world with mass, an offset axis.
SLIDER = """
<mujoco>
  <worldbody>
    <body name="base" pos="0.1 0 0.2">
      <inertial pos="0 0.05 0" mass="3" diaginertia="0.1 0.1 0.1"/>
      <body name="a">
        <joint name="hinge1" axis="0 0 1"/>
        <inertial pos="0.1 0 0" mass="1" diaginertia="0.01 0.02 0.03"/>
        <body name="b" pos="0.2 0 0" euler="0.3 0 0">
          <joint name="slide" type="slide" axis="1 0 0" range="-0.2 0.2"/>
          <inertial pos="0.05 0.02 0" mass="0.7" diaginertia="0.01 0.01 0.02"/>
          <body name="c" pos="0.1 0 0">
            <joint name="hinge2" axis="0 1 1"/>
            <inertial pos="0.1 0.01 0.02" mass="0.4" diaginertia="0.004 0.005 0.006"/>
            <site name="ee" pos="0.2 0 0"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.fixture(scope="module")
def held_arms() -> dict[str, rd.Arm]:
    return {
        tool: rd.load(rd.example_robot_data(f), frame=tool, base=base) for f, tool, base in HELD
    }


@pytest.fixture(scope="module")
def small(tmp_path_factory: pytest.TempPathFactory) -> dict[str, rd.Arm]:
    cell = tmp_path_factory.mktemp("cell")
    (cell / "actuators.xml").write_text(ACTUATORS)
    sides = {s: SIDE.format(s=s, x=x) for s, x in (("left", "-0.3"), ("right", "0.3"))}
    (cell / "cell.xml").write_text(BIMANUAL_MAIN.format(**sides))
    return {
        "two_link": rd.load_string(TWO_LINK, frame="ee"),
        "slider": rd.load_string(SLIDER, frame="ee"),
        # a table and the other arm (held) welded to the world, outside Pinocchio's tree
        "cell": rd.load(cell / "cell.xml", frame="right_gripper"),
        "humanoid": rd.load_string(HUMANOID, frame="l_palm"),  # a held free base
    }


def all_arms(arms: dict[str, rd.Arm], held_arms: dict[str, rd.Arm], small: dict) -> list:
    return [*arms.values(), *held_arms.values(), *small.values()]


class Whole:
    """MuJoCo's model of the whole robot with the held joints at rest and the arm's q, v."""

    def __init__(self, arm: rd.Arm, q: np.ndarray, v: np.ndarray | None = None) -> None:
        m = self.m = arm.robot_model
        d = self.d = mujoco.MjData(m)
        names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or "" for j in range(m.njnt)]
        shown = display_names(m, mujoco.mjtObj.mjOBJ_JOINT)
        d.qpos[:] = m.qpos0
        for name, value in arm.held.items():
            j = names.index(name) if name in names else shown.index(name)
            adr = int(m.jnt_qposadr[j])
            d.qpos[adr : adr + np.size(value)] = value
        ids = [names.index(n) for n in arm.joint_names]
        d.qpos[m.jnt_qposadr[ids]] = q
        self.dofs = m.jnt_dofadr[ids]
        self.v = np.zeros(m.nv)
        if v is not None:
            self.v[self.dofs] = v
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)

    def bias(self, v_full: np.ndarray) -> np.ndarray:
        """mj_rne's bias (C v + g) at the whole robot's velocity ``v_full``."""
        self.d.qvel[:] = v_full
        mujoco.mj_comVel(self.m, self.d)
        out = np.zeros(self.m.nv)
        mujoco.mj_rne(self.m, self.d, 0, out)
        return out

    def coriolis_times_v(self) -> np.ndarray:
        """C v at the arm's dofs: the bias at v minus the bias at rest (gravity)."""
        return (self.bias(self.v) - self.bias(0 * self.v))[self.dofs]

    def mass_matrix_along(self, q_step: float, arm: rd.Arm, q: np.ndarray) -> np.ndarray:
        """The arm's block of the whole robot's M at q + q_step v."""
        w = Whole(arm, q + q_step * self.v[self.dofs])
        M = np.zeros((w.m.nv, w.m.nv))
        mujoco.mj_crb(w.m, w.d)
        mujoco.mj_fullM(w.m, w.d, M)
        return M[np.ix_(w.dofs, w.dofs)]


def rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))


def drawn(arm: rd.Arm, n: int, seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
    Q = rd.random_poses(arm, n, seed=seed)
    V = np.random.default_rng(seed).uniform(-2.0, 2.0, Q.shape)
    return list(zip(Q, V, strict=True))


# -- the Coriolis matrix and dM/dt ------------------------------------------------------------


def test_two_link_coriolis_is_the_textbook_matrix(small: dict) -> None:
    arm = small["two_link"]
    for q, v in drawn(arm, 5, seed=4):
        h = 2.0 * 0.5 * 0.3 * np.sin(q[1])
        expected = h * np.array([[-v[1], -(v[0] + v[1])], [v[0], 0.0]])
        for engine in ENGINES:
            C = arm.coriolis(q, v, engine=engine)
            assert np.max(np.abs(C - expected)) < 1e-12 * max(1.0, np.max(np.abs(expected)))


def test_coriolis_times_velocity_is_bias_minus_gravity_of_the_whole_robot(
    arms: dict, held_arms: dict, small: dict
) -> None:
    for arm in all_arms(arms, held_arms, small):
        for q, v in drawn(arm, 3, seed=7):
            truth = Whole(arm, q, v).coriolis_times_v()
            for engine in ENGINES:
                Cv = arm.coriolis(q, v, engine=engine) @ v
                assert rel(Cv, truth) < 1e-9, (arm, engine)


def test_mass_matrix_derivative_is_C_plus_CT_and_central_differences_of_M(
    arms: dict, held_arms: dict, small: dict
) -> None:
    h = 1e-5  # central differences: O(h^2) truncation, eps |M| / h rounding
    for arm in all_arms(arms, held_arms, small):
        for q, v in drawn(arm, 2, seed=9):
            whole = Whole(arm, q, v)
            fd = (whole.mass_matrix_along(h, arm, q) - whole.mass_matrix_along(-h, arm, q)) / (
                2 * h
            )
            for engine in ENGINES:
                C = arm.coriolis(q, v, engine=engine)
                dM = arm.mass_matrix_derivative(q, v, engine=engine)
                assert np.array_equal(dM, C + C.T)
                S = dM - 2 * C
                assert np.max(np.abs(S + S.T)) <= 1e-12 * np.max(np.abs(dM))
                assert rel(dM, fd) < 1e-7, (arm, engine, rel(dM, fd))


def test_engines_agree_on_the_coriolis_matrix(arms: dict, held_arms: dict, small: dict) -> None:
    for arm in all_arms(arms, held_arms, small):
        for q, v in drawn(arm, 4, seed=11):
            a = arm.coriolis(q, v)
            b = arm.coriolis(q, v, engine="pinocchio")
            assert rel(b, a) < 1e-9, arm


def test_coriolis_is_zero_at_rest_and_linear_in_velocity(arm7: rd.Arm) -> None:
    q, v = drawn(arm7, 1, seed=2)[0]
    assert not arm7.coriolis(q, np.zeros(7)).any()
    assert rel(arm7.coriolis(q, 3.0 * v), 3.0 * arm7.coriolis(q, v)) < 1e-14
    # tiny and huge velocities keep their relative accuracy (the step scales with |v|)
    for s in (1e-9, 1e6):
        assert rel(arm7.coriolis(q, s * v), arm7.coriolis(q, s * v, engine="pinocchio")) < 1e-9


def test_coriolis_leaves_the_pose_queries_as_they_were(arm7: rd.Arm) -> None:
    """Gravity and M at the same pose after a Coriolis call: the data is at rest again."""
    q, v = drawn(arm7, 1, seed=3)[0]
    g, M, J = arm7.gravity(q), arm7.mass_matrix(q), arm7.jacobian(q)
    arm7.coriolis(q, v)
    assert np.array_equal(arm7.gravity(q), g)
    assert np.array_equal(arm7.mass_matrix(q), M)
    assert np.array_equal(arm7.jacobian(q), J)


def test_bad_velocity_is_a_pose_error_naming_it(arm7: rd.Arm) -> None:
    q = np.zeros(7)
    names = list(arm7.joint_names)
    for engine in ENGINES:
        shape = f"velocity must have shape (7,) for joints {names}, got shape (6,)"
        with pytest.raises(rd.PoseError, match=f"^{re.escape(shape)}$"):
            arm7.coriolis(q, np.zeros(6), engine=engine)
        bad = np.zeros(7)
        bad[2] = np.nan
        with pytest.raises(rd.PoseError, match=r"^velocity has non-finite values: j3=nan$"):
            arm7.mass_matrix_derivative(q, bad, engine=engine)
        with pytest.raises(rd.PoseError, match="velocity must be numeric"):
            arm7.coriolis(q, "fast", engine=engine)
        with pytest.raises(rd.PoseError, match="velocity must be real, got complex values"):
            arm7.coriolis(q, np.ones(7) * 1j, engine=engine)
        with pytest.raises(rd.PoseError, match="pose has non-finite values"):
            arm7.coriolis(np.full(7, np.inf), np.zeros(7), engine=engine)
    with pytest.raises(rd.UnknownNameError, match="unknown engine 'bullet'"):
        arm7.coriolis(q, q, engine="bullet")  # type: ignore[arg-type]


# -- stacks --------------------------------------------------------------------------------------


def test_batch_coriolis_equals_the_single_calls_bit_for_bit(
    arm7: rd.Arm, held_arms: dict, small: dict
) -> None:
    for arm in (arm7, held_arms["gripper_left_base_link"], small["slider"]):
        pairs = drawn(arm, 9, seed=5)
        Q = np.array([q for q, _ in pairs])
        V = np.array([v for _, v in pairs])
        V[4] = 0.0  # a state at rest: C = 0
        for engine in ENGINES:
            single = np.array(
                [arm.coriolis(q, v, engine=engine) for q, v in zip(Q, V, strict=True)]
            )
            assert np.array_equal(batch.coriolis(arm, Q, V, engine=engine), single)
            assert np.array_equal(batch.coriolis(arm, Q, V, engine=engine, threads=2), single)
    assert batch.coriolis(arm7, np.empty((0, 7)), np.empty((0, 7))).shape == (0, 7, 7)


def test_batch_coriolis_on_executors_equals_the_serial_stack(arm7: rd.Arm) -> None:
    pairs = drawn(arm7, 6, seed=8)
    Q, V = np.array([q for q, _ in pairs]), np.array([v for _, v in pairs])
    serial = batch.coriolis(arm7, Q, V)
    with ThreadPoolExecutor(2) as pool:
        assert np.array_equal(batch.coriolis(arm7, Q, V, executor=pool), serial)
        assert batch.coriolis(arm7, Q[:0], V[:0], executor=pool).shape == (0, 7, 7)
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        assert np.array_equal(batch.coriolis(arm7, Q, V, executor=pool), serial)


def test_batch_coriolis_refuses_velocities_that_do_not_match(arm7: rd.Arm) -> None:
    Q = np.zeros((3, 7))
    names = list(arm7.joint_names)
    shape = (
        f"velocities must have shape (3, 7), one row per pose, for joints {names}, got shape (2, 7)"
    )
    with pytest.raises(rd.PoseError, match=f"^{re.escape(shape)}$"):
        batch.coriolis(arm7, Q, np.zeros((2, 7)))
    V = np.zeros((3, 7))
    V[1, 4] = np.inf
    with pytest.raises(rd.PoseError, match=r"^velocities row 1 has non-finite values: j5=inf$"):
        batch.coriolis(arm7, Q, V)
    with pytest.raises(rd.PoseError, match="pose 2 has non-finite values: j1=nan"):
        batch.coriolis(arm7, np.where(np.arange(3)[:, None] == 2, np.nan, Q), Q)
    with pytest.raises(rd.ParameterError, match="executor must be None or a concurrent"):
        batch.coriolis(arm7, Q, Q, executor="dask")  # type: ignore[arg-type]


# -- the cross-check and property tests ----------------------------------------------------------


@given(st.data())
def test_property_engines_agree_on_coriolis_and_it_is_the_bias(arms: dict, data) -> None:  # type: ignore[no-untyped-def]
    for name, arm in arms.items():
        q, v = data.draw(states(arm), label=name)
        a = arm.coriolis(q, v)
        b = arm.coriolis(q, v, engine="pinocchio")
        size = max(np.max(np.abs(a)), 1e-3 * np.max(np.abs(arm.mass_matrix(q))))
        assert np.max(np.abs(a - b)) <= 1e-9 * size
        truth = Whole(arm, q, v).coriolis_times_v()
        assert np.max(np.abs(a @ v - truth)) <= 1e-9 * max(np.max(np.abs(truth)), size)


def test_crosscheck_reports_coriolis_the_same_in_any_chunk(arm7: rd.Arm) -> None:
    Q = rd.random_poses(arm7, 7, seed=6)
    whole = rd.crosscheck_batch(arm7, Q, ["coriolis"])
    assert whole.ok and whole["coriolis"].tol == 1e-9
    assert rd.crosscheck_batch(arm7, Q, ["coriolis"], chunk=3) == whole
    with ThreadPoolExecutor(2) as pool:
        assert rd.crosscheck_batch(arm7, Q, ["coriolis"], chunk=3, executor=pool) == whole
    assert rd.crosscheck(arm7, Q[2], ["coriolis"], seed=4).ok
    with pytest.raises(rd.ParameterError, match="seed must be an integer >= 0, got -1"):
        rd.crosscheck(arm7, Q, ["coriolis"], seed=-1)


def test_crosscheck_velocities_depend_on_the_pose_and_seed_only(arm7: rd.Arm) -> None:
    Q = rd.random_poses(arm7, 5, seed=1)
    V = crosscheck_velocities(Q, 0)
    assert V.shape == Q.shape and np.all(np.abs(V) <= 1.0)
    assert np.array_equal(crosscheck_velocities(Q[3:], 0), V[3:])
    assert not np.array_equal(crosscheck_velocities(Q, 1), V)


# -- the whole robot's centre of mass and momentum ------------------------------------------------


def body_sums(arm: rd.Arm, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, ...]:
    """Centre of mass, its Jacobian, linear and angular momentum about it, summed over the
    whole robot's bodies from raw MuJoCo data (body masses, xipos, ximat, velocities)."""
    w = Whole(arm, q, v)
    m, d = w.m, w.d
    d.qvel[:] = w.v
    mujoco.mj_comVel(m, d)
    mass = m.body_mass[1:].sum()
    com = (m.body_mass[1:, None] * d.xipos[1:]).sum(axis=0) / mass
    J = np.zeros((3, m.nv))
    P, L = np.zeros(3), np.zeros(3)
    for b in range(1, m.nbody):
        jp = np.zeros((3, m.nv))
        mujoco.mj_jacBodyCom(m, d, jp, None, b)
        J += m.body_mass[b] * jp / mass
        vel = np.zeros(6)  # [angular; linear] at the body's centre of mass, world axes
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, b, vel, 0)
        R = d.ximat[b].reshape(3, 3)
        p = m.body_mass[b] * vel[3:]
        P += p
        L += R @ np.diag(m.body_inertia[b]) @ R.T @ vel[:3] + np.cross(d.xipos[b] - com, p)
    return com, J[:, w.dofs], P, L


def test_com_and_momentum_are_the_sums_over_the_whole_robots_bodies(
    arms: dict, held_arms: dict, small: dict
) -> None:
    for arm in all_arms(arms, held_arms, small):
        for q, v in drawn(arm, 2, seed=13):
            com, J, P, L = body_sums(arm, q, v)
            size = arm.robot_model.body_mass.sum()
            for engine in ENGINES:
                assert rel(arm.com(q, engine=engine), com) < 1e-12, (arm, engine)
                assert np.max(np.abs(arm.com_jacobian(q, engine=engine) - J)) < 1e-12
                A = arm.centroidal_momentum_matrix(q, engine=engine)
                assert A.shape == (6, arm.nq)
                assert np.max(np.abs(A[:3] @ v - P)) <= 1e-12 * size, (arm, engine)
                assert np.max(np.abs(A[3:] @ v - L)) <= 1e-12 * size, (arm, engine)


def test_fixed_mass_counts_in_the_com_and_not_in_the_momentum(small: dict, arm7: rd.Arm) -> None:
    """SLIDER's base (3 kg, welded to the world, posed): in the centre of mass, no momentum."""
    arm = small["slider"]
    q = np.array([0.4, 0.1, -0.3])
    moving = rd.load_string(SLIDER.replace('mass="3"', 'mass="0"'), frame="ee")
    base = np.array([0.1, 0.05, 0.2])  # the base's centre of mass in the world
    expected = (3.0 * base + 2.1 * moving.com(q)) / 5.1
    for engine in ENGINES:
        assert np.max(np.abs(arm.com(q, engine=engine) - expected)) < 1e-15
        A = arm.centroidal_momentum_matrix(q, engine=engine)
        assert np.max(np.abs(A[:3] - 5.1 * arm.com_jacobian(q, engine=engine))) < 1e-14
        assert (
            np.max(np.abs(A[:3] - moving.centroidal_momentum_matrix(q, engine=engine)[:3])) < 1e-14
        )
    # Pinocchio's parser has the cell's right tree only: the table and the left arm, welded
    # to the world in MuJoCo's model, are bridged; the arms with their base in the tree are not.
    (world,) = [b for b in small["cell"].bridges if b.quantity == "world mass"]
    assert world.joint == "world" and world.value[0] == pytest.approx(100.4601707256)
    assert not [b for b in arm7.bridges + arm.bridges if b.quantity == "world mass"]


def test_com_queries_check_the_pose(arm7: rd.Arm) -> None:
    for engine in ENGINES:
        for method in (arm7.com, arm7.com_jacobian, arm7.centroidal_momentum_matrix):
            with pytest.raises(rd.PoseError, match=r"pose must have shape \(7,\)"):
                method(np.zeros(3), engine=engine)
            with pytest.raises(rd.PoseError, match="pose has non-finite values: j2=nan"):
                method(np.array([0, np.nan, 0, 0, 0, 0, 0.0]), engine=engine)


def test_observer_terms_are_the_whole_robots(arms: dict, held_arms: dict, small: dict) -> None:
    """p = M v and beta = C^T v - g + passive against the whole robot: M, C by polarization
    of its bias, gravity, and qfrc_passive from mj_forward (held joints still)."""
    for arm in all_arms(arms, held_arms, small):
        for q, v in drawn(arm, 2, seed=17):
            w = Whole(arm, q, v)
            m, d, dofs = w.m, w.d, w.dofs
            C = np.empty((len(dofs), len(dofs)))
            for col, j in enumerate(dofs):
                e = np.zeros(m.nv)
                e[j] = 1.0
                C[:, col] = ((w.bias(w.v + e) - w.bias(w.v - e)) / 4.0)[dofs]
            g = w.bias(0 * w.v)[dofs]
            d.qvel[:] = w.v
            mujoco.mj_forward(m, d)
            M = np.zeros((m.nv, m.nv))
            mujoco.mj_fullM(m, d, M)
            truth = C.T @ v - g + d.qfrc_passive[dofs]
            p, beta = arm.mujoco.momentum_terms(q, v)
            assert rel(p, M[np.ix_(dofs, dofs)] @ v) < 1e-12, arm
            assert rel(beta, truth) < 1e-9, (arm, rel(beta, truth))
            # C^T v itself against Pinocchio's C (no springs or gravity compensation here)
            C_pin = arm.coriolis(q, v, engine="pinocchio")
            assert rel(C.T @ v, C_pin.T @ v) < 1e-9

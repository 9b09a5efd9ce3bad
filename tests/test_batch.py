"""Batched evaluation (redundancy.batch) equals the single-pose path, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

import redundancy as rd
from redundancy import batch
from redundancy.analysis.crosscheck import BATCH_QUANTITIES, TOLERANCES, worst
from redundancy.checks import check_threads
from redundancy.collision import checker, random_poses
from redundancy.engines import ENGINES
from redundancy.engines.contract import Engine, Stacks
from redundancy.engines.pinocchio import PinocchioEngine
from redundancy.engines.threads import MIN_POSES_PER_THREAD, spans

from .models import SKEW7


@pytest.fixture(scope="module", params=["arm7", "panda", "skew7"])
def arm(request: pytest.FixtureRequest) -> rd.Arm:
    if request.param == "skew7":
        return rd.load_string(SKEW7, frame="tool")
    return rd.load(rd.model_path(request.param), frame="ee")


def sample(arm: rd.Arm, n: int = 120, seed: int = 3) -> np.ndarray:
    """Random poses plus every keyframe (arm7's zero pose is singular, rank 3)."""
    keys = list(arm.keyframes.values())
    Q = random_poses(arm, n, seed)
    return np.vstack([*keys, Q]) if keys else Q


def stack(f, Q):
    return np.array([f(q) for q in Q])


# -- equality with the single-pose path --------------------------------------------------


@pytest.mark.parametrize("engine", ENGINES)
def test_jacobians_equal_single_pose(arm: rd.Arm, engine: str) -> None:
    Q = sample(arm)
    J = batch.jacobians(arm, Q, engine)
    assert J.shape == (len(Q), 6, arm.nq)
    assert np.array_equal(J, stack(lambda q: arm.jacobian(q, engine), Q))


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("armature", [True, False])
def test_mass_matrices_equal_single_pose(arm: rd.Arm, engine: str, armature: bool) -> None:
    Q = sample(arm)
    M = batch.mass_matrices(arm, Q, armature, engine)
    assert M.shape == (len(Q), arm.nq, arm.nq)
    assert np.array_equal(M, stack(lambda q: arm.mass_matrix(q, armature, engine), Q))


@pytest.mark.parametrize("engine", ENGINES)
def test_gravities_equal_single_pose(arm: rd.Arm, engine: str) -> None:
    Q = sample(arm)
    G = batch.gravities(arm, Q, engine)
    assert G.shape == (len(Q), arm.nq)
    assert G.flags.c_contiguous
    assert np.array_equal(G, stack(lambda q: arm.gravity(q, engine), Q))


@pytest.mark.parametrize("engine", ENGINES)
def test_singular_values_equal_single_pose(arm: rd.Arm, engine: str) -> None:
    Q = sample(arm)
    S = batch.singular_values(arm, Q, engine)
    assert S.shape == (len(Q), 6)
    # Bit for bit with the values-only SVD of each J (what yoshikawa uses)...
    ref = stack(lambda q: np.linalg.svd(arm.jacobian(q, engine), compute_uv=False), Q)
    assert np.array_equal(S, ref)
    # ...and to rounding with Arm.svd, whose SVD also computes the vectors.
    sigma = stack(lambda q: arm.svd(q, engine).sigma, Q)
    assert np.abs(S - sigma).max() <= 1e-12 * max(1.0, np.abs(sigma).max())


def test_singular_values_keep_the_rank_at_a_singular_pose(arm7: rd.Arm) -> None:
    S = batch.singular_values(arm7, arm7.keyframe("zero")[None])[0]
    assert int(np.sum(S > rd.linalg.RANK_RTOL * S[0])) == 3
    assert S[3:].max() < 1e-14


@pytest.mark.parametrize("kind", batch.MANIPULABILITY_KINDS)
def test_manipulabilities_equal_single_pose(arm: rd.Arm, kind: str) -> None:
    Q = sample(arm, 60)
    w = batch.manipulabilities(arm, Q, kind=kind, length=0.5)
    ref = stack(lambda q: getattr(arm.manipulability(q, length=0.5), kind), Q)
    assert w.shape == (len(Q),)
    assert np.array_equal(w, ref)


@pytest.mark.parametrize("engine", ["coal", "mujoco"])
def test_distances_equal_single_pose(arm: rd.Arm, engine: str) -> None:
    Q = sample(arm, 80)
    ch = checker(arm)
    D = batch.distances(arm, Q, engine)
    assert D.shape == (len(Q), len(ch.pairs))
    assert np.array_equal(D, stack(lambda q: ch.distance_values(q, engine), Q))


def test_crosscheck_batch_equals_crosscheck(arm: rd.Arm) -> None:
    Q = sample(arm, 80)
    names = BATCH_QUANTITIES
    report = rd.crosscheck_batch(arm, Q, names)
    assert report == rd.crosscheck(arm, Q, names)
    assert report.ok
    assert report.n_poses == len(Q)


def test_crosscheck_batch_delegates_the_other_quantities(arm7: rd.Arm) -> None:
    Q = sample(arm7, 5)
    names = ("manipulability gradient", "gravity", "jacobian derivative")
    report = rd.crosscheck_batch(arm7, Q, names, tolerances={"gravity": 1e-10})
    assert [a.quantity for a in report.agreements] == list(names)
    assert report == rd.crosscheck(arm7, Q, names, tolerances={"gravity": 1e-10})
    assert report["gravity"].tol == 1e-10
    assert [a.quantity for a in rd.crosscheck_batch(arm7, Q[:2]).agreements] == list(TOLERANCES)


def test_worst_pose_follows_crosscheck_rules() -> None:
    assert worst(np.array([0.0, 2.0, 1.0, 2.0])) == (2.0, 1)  # first maximum
    assert worst(np.zeros(3)) == (0.0, 0)
    assert worst(np.zeros(0)) == (0.0, 0)
    err, where = worst(np.array([1.0, np.inf, 5.0, np.nan, 7.0]))
    assert np.isnan(err) and where == 3  # the last non-finite error wins


# -- threads -----------------------------------------------------------------------------


def test_threads_give_identical_results(arm7: rd.Arm) -> None:
    Q = random_poses(arm7, 2 * MIN_POSES_PER_THREAD + 10, seed=5)
    assert len(spans(len(Q), 2)) == 2
    for engine in ENGINES:
        assert np.array_equal(
            batch.jacobians(arm7, Q, engine), batch.jacobians(arm7, Q, engine, threads=2)
        )
        assert np.array_equal(
            batch.mass_matrices(arm7, Q, False, engine),
            batch.mass_matrices(arm7, Q, False, engine, threads=2),
        )
        assert np.array_equal(
            batch.gravities(arm7, Q, engine), batch.gravities(arm7, Q, engine, threads=3)
        )
        assert np.array_equal(
            batch.singular_values(arm7, Q, engine),
            batch.singular_values(arm7, Q, engine, threads=2),
        )
    assert np.array_equal(
        batch.distances(arm7, Q, "mujoco"), batch.distances(arm7, Q, "mujoco", threads=2)
    )
    names = ("jacobian", "mass matrix", "mass matrix (bare)", "gravity", "site position")
    assert rd.crosscheck_batch(arm7, Q, names) == rd.crosscheck_batch(arm7, Q, names, threads=2)


@pytest.mark.parametrize("chunk", [MIN_POSES_PER_THREAD, MIN_POSES_PER_THREAD - 1])
def test_crosscheck_keeps_within_its_threads(
    arm7: rd.Arm, monkeypatch: pytest.MonkeyPatch, chunk: int
) -> None:
    # MuJoCo's worker thread is one of the threads: Pinocchio's OpenMP gravity gets the
    # others (OpenMP workers beside it, busy-waiting after each call, took the CPU from it),
    # and none below MIN_POSES_PER_THREAD poses.
    Q = random_poses(arm7, 2 * MIN_POSES_PER_THREAD, seed=6)
    names = ("jacobian", "gravity")
    expected = rd.crosscheck_batch(arm7, Q, names, chunk=chunk)
    seen: set[tuple[str, int]] = set()
    for engine in (arm7.mujoco, arm7.pinocchio):

        def spy(Q: np.ndarray, out: Stacks, threads: int = 1, engine: Engine = engine) -> None:
            seen.add((engine.name, threads))
            type(engine).evaluate(engine, Q, out, threads)

        monkeypatch.setattr(engine, "evaluate", spy)
    for threads in (2, 3):
        seen.clear()
        assert rd.crosscheck_batch(arm7, Q, names, threads=threads, chunk=chunk) == expected
        k = check_threads(threads)
        beside = k > 1 and chunk >= MIN_POSES_PER_THREAD
        assert seen == {("mujoco", 1), ("pinocchio", k - 1 if beside else 1)}


@pytest.mark.parametrize("threads", [1, 2])
def test_pinocchio_stacks_follow_a_joint_order_other_than_its_own(
    arm7: rd.Arm, threads: int
) -> None:
    # The loaders' arms keep Pinocchio's order; an engine given the joints in another order
    # must permute every stack as its single-pose methods do (the permuted branches).
    eng = PinocchioEngine(arm7.pinocchio.model, arm7.frame, arm7.joint_names[::-1])
    assert not eng.identity
    Q = random_poses(arm7, 2 * MIN_POSES_PER_THREAD, seed=9)
    n, nv = Q.shape
    for armature in (True, False):
        out = Stacks(
            X=np.empty((n, 3)),
            R=np.empty((n, 3, 3)),
            J=np.empty((n, 6, nv)),
            M=np.empty((n, nv, nv)),
            G=np.empty((n, nv)),
            armature=armature,
        )
        eng.evaluate(Q, out, threads)
        assert np.array_equal(out.X, stack(lambda q: eng.site_pose(q)[0], Q))
        assert np.array_equal(out.R, stack(lambda q: eng.site_pose(q)[1], Q))
        assert np.array_equal(out.J, stack(eng.site_jacobian, Q))
        assert np.array_equal(out.M, stack(lambda q, a=armature: eng.mass_matrix(q, a), Q))
        assert np.array_equal(out.G, stack(eng.gravity, Q))


@pytest.mark.parametrize(("n", "threads"), [(10, 2), (MIN_POSES_PER_THREAD - 1, 2), (600, 2)])
def test_pinocchio_gravity_runs_as_many_openmp_threads_as_spans(
    arm7: rd.Arm, monkeypatch: pytest.MonkeyPatch, n: int, threads: int
) -> None:
    # OpenMP workers on a small stack cost more than they save (and busy-wait after the call).
    import pinocchio as pin

    Q = random_poses(arm7, n, seed=8)
    expected = np.zeros((n, arm7.nq))
    arm7.pinocchio.evaluate(Q, Stacks(G=expected))
    seen: list[int] = []
    real = pin.rneaInParallel

    def spy(k: int, *args: object) -> object:
        seen.append(k)
        return real(k, *args)

    monkeypatch.setattr(pin, "rneaInParallel", spy)
    G = np.zeros((n, arm7.nq))
    arm7.pinocchio.evaluate(Q, Stacks(G=G), threads)
    assert seen == [len(spans(n, threads))]
    assert np.array_equal(G, expected)


def test_batch_between_single_pose_calls_changes_nothing(arm7: rd.Arm) -> None:
    # The engines keep the last pose's kinematics per thread; a stack evaluated in the same
    # thread must invalidate them, so the next single-pose query recomputes.
    q = arm7.keyframe("home")
    for engine in ENGINES:
        J, g = arm7.jacobian(q, engine), arm7.gravity(q, engine)
        batch.jacobians(arm7, random_poses(arm7, 10), engine)
        batch.gravities(arm7, random_poses(arm7, 10), engine)
        assert np.array_equal(arm7.jacobian(q, engine), J)
        assert np.array_equal(arm7.gravity(q, engine), g)
        assert np.array_equal(arm7.site_pose(q, engine)[0], arm7.site_pose(q, engine)[0])


# -- shapes and errors -------------------------------------------------------------------


def test_empty_stack(arm7: rd.Arm) -> None:
    Q = np.zeros((0, 7))
    assert batch.jacobians(arm7, Q).shape == (0, 6, 7)
    assert batch.singular_values(arm7, Q, "pinocchio").shape == (0, 6)
    assert batch.mass_matrices(arm7, Q, engine="pinocchio").shape == (0, 7, 7)
    assert batch.gravities(arm7, Q, "pinocchio").shape == (0, 7)
    assert batch.distances(arm7, Q).shape == (0, len(checker(arm7).pairs))
    assert rd.crosscheck_batch(arm7, Q, BATCH_QUANTITIES).n_poses == 0


def test_accepts_lists(arm7: rd.Arm) -> None:
    q = arm7.keyframe("home")
    assert np.array_equal(batch.gravities(arm7, [q.tolist()])[0], arm7.gravity(q))


@pytest.mark.parametrize(
    ("Q", "match"),
    [
        (np.zeros(7), r"poses must have shape \(n, 7\) for joints \['j1'.*got shape \(7,\)"),
        (np.zeros((3, 6)), r"got shape \(3, 6\)"),
        (np.zeros((2, 3, 7)), r"got shape \(2, 3, 7\)"),
        ([["a"] * 7], "poses must be numeric"),
        (np.array([[0.0] * 7, [0.0, np.nan, 0, 0, 0, np.inf, 0]]), r"pose 1 .*j2=nan, j6=inf"),
    ],
)
def test_bad_poses(arm7: rd.Arm, Q: object, match: str) -> None:
    with pytest.raises(rd.PoseError, match=match):
        batch.jacobians(arm7, Q)  # type: ignore[arg-type]
    if np.ndim(Q) != 1:  # one pose is a valid input to a cross-check
        with pytest.raises(rd.PoseError):
            rd.crosscheck_batch(arm7, Q)  # type: ignore[arg-type]


def test_bad_arguments(arm7: rd.Arm) -> None:
    Q = np.zeros((2, 7))
    with pytest.raises(rd.UnknownNameError, match="valid engine names"):
        batch.jacobians(arm7, Q, "bullet")  # type: ignore[arg-type]
    with pytest.raises(rd.UnknownNameError, match="'coal', 'mujoco'"):
        batch.distances(arm7, Q, "pinocchio")  # type: ignore[arg-type]
    with pytest.raises(rd.UnknownNameError, match="manipulability kind"):
        batch.manipulabilities(arm7, Q, kind="volume")  # type: ignore[arg-type]
    with pytest.raises(
        rd.ParameterError, match=r"^length must be a finite number > 0 \[m\], got 0.0$"
    ):
        batch.manipulabilities(arm7, Q, kind="scaled", length=0.0)
    with pytest.raises(rd.RedundancyError, match="threads must be an integer >= 1"):
        batch.gravities(arm7, Q, threads=0)
    with pytest.raises(rd.UnknownNameError, match="unknown quantity 'torque'"):
        rd.crosscheck_batch(arm7, Q, ("torque",))

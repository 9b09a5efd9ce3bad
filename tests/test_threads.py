"""Safe under ordinary use: one Arm shared by threads, copied, pickled, sent to processes.

The contract (docs/guide/from-python.md, "Threads, copies and
processes"): every public method of an Arm may be
called from any number of threads and returns, bit for bit, what sequential calls return;
an Arm pickles as its recipe and is rebuilt on arrival; caches never keep an Arm alive; MuJoCo's
warning callback is the user's after any number of threads loaded.
"""

from __future__ import annotations

import concurrent.futures as cf
import copy
import gc
import multiprocessing
import os
import pickle
import threading
import weakref

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import redundancy as rd
from redundancy import batch
from redundancy.checks import check_threads, max_threads
from redundancy.testing import poses

from .models import SKEW7

THREADS = 8
#: Examples per threaded property: 5 under "redundancy-ci" (60), 83 under "redundancy-thorough".
HAMMER_EXAMPLES = max(3, settings.default.max_examples // 12)


def quantities(arm: rd.Arm, q: np.ndarray) -> list[np.ndarray]:
    """Every single-pose quantity of the Arm, from both engines, as arrays."""
    out: list[np.ndarray] = []
    for engine in rd.engines.ENGINES:
        p, R = arm.site_pose(q, engine)
        out += [p, R, arm.jacobian(q, engine), arm.mass_matrix(q, True, engine)]
        out += [arm.mass_matrix(q, False, engine), arm.gravity(q, engine)]
        out += [arm.svd(q, engine).sigma, arm.nullspace_projector(q, engine)]
        out += [np.array([arm.manipulability(q, 0.5, engine).scaled])]
        mr = arm.effective_mass_range(q, engine=engine)
        out += [np.array([arm.effective_mass(q, [0.3, -0.2, 1.0], engine=engine), mr.min])]
        out += [np.array([arm.dynamic_manipulability(q, armature=False, engine=engine)])]
        out += [np.array([arm.effective_mass(q, [1.0, 0, 0], joints=arm.joint_names[:5])])]
    out.append(arm.solve_ik(arm.site_pose(q), restarts=5).q)  # its kernel runs in this thread
    out.append(arm.manipulability_gradient(q))
    ch = rd.collision.checker(arm)
    for engine in rd.collision.DISTANCE_ENGINES:
        out.append(ch.distance_values(q, engine))
    out.append(np.array(sorted(p.label for p in ch.contact_pairs(q)), dtype=object))
    out.append(np.array([(c.pair.label, c.distance, *c.position) for c in ch.contacts(q)]))
    return out


def hammer(work, n_items: int, threads: int = THREADS) -> list[dict[int, object]]:
    """Run ``work(i)`` for every item in every thread, each thread in its own order."""
    barrier = threading.Barrier(threads)
    results: list[dict[int, object]] = [{} for _ in range(threads)]
    errors: list[BaseException] = []

    def run(k: int) -> None:
        try:
            barrier.wait()
            order = np.random.default_rng(k).permutation(n_items)
            for i in order.tolist():
                results[k][i] = work(i)
        except BaseException as err:  # reported by the test
            errors.append(err)

    workers = [threading.Thread(target=run, args=(k,)) for k in range(threads)]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    assert not errors, errors
    return results


def same(a: list[np.ndarray], b: list[np.ndarray]) -> bool:
    return len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))


@settings(max_examples=HAMMER_EXAMPLES)
@given(data=st.data())
def test_one_arm_from_eight_threads_equals_sequential(arm7, data):
    Q = data.draw(st.lists(poses(arm7), min_size=8, max_size=24))
    expected = [quantities(arm7, q) for q in Q]
    for got in hammer(lambda i: quantities(arm7, Q[i]), len(Q)):
        assert all(same(got[i], expected[i]) for i in range(len(Q)))


@settings(max_examples=max(3, HAMMER_EXAMPLES // 4))
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(300, 600))
def test_batched_calls_from_threads_equal_sequential(arm7, seed, n):
    # Stacks long enough that threads=2 splits them (MIN_POSES_PER_THREAD = 256).
    Q = rd.collision.random_poses(arm7, n, seed=seed)
    calls = [
        lambda: batch.jacobians(arm7, Q, threads=2),
        lambda: batch.jacobians(arm7, Q, "pinocchio"),
        lambda: batch.mass_matrices(arm7, Q, False, threads=2),
        lambda: batch.gravities(arm7, Q, "pinocchio", threads=2),
        lambda: batch.singular_values(arm7, Q, threads=2),
        lambda: batch.distances(arm7, Q[:100], "coal"),
        lambda: batch.distances(arm7, Q[:100], "mujoco", threads=2),
        lambda: np.array(
            [(p.poses, p.contacts, p.closest) for p in rd.collision_statistics(arm7, 200).pairs]
        ),
    ]
    expected = [f() for f in calls]
    for got in hammer(lambda i: calls[i](), len(calls), threads=4):
        assert all(np.array_equal(got[i], expected[i]) for i in range(len(calls)))
    report = rd.crosscheck_batch(arm7, Q, threads=2)
    assert all(
        r == report
        for r in hammer(lambda i: rd.crosscheck_batch(arm7, Q, threads=2), 1, 4)[0].values()
    )


def test_thread_counts_beyond_the_cpus_are_capped(arm7):
    assert check_threads(8192) == max_threads()
    Q = rd.collision.random_poses(arm7, 600, seed=2)
    assert np.array_equal(batch.gravities(arm7, Q, threads=8192), batch.gravities(arm7, Q))
    with pytest.raises(rd.ParameterError, match=r"^threads must be an integer >= 1, got 0$"):
        batch.gravities(arm7, Q, threads=0)
    with pytest.raises(rd.ParameterError, match=r"^threads must be an integer >= 1, got 2.0$"):
        batch.gravities(arm7, Q, threads=2.0)  # type: ignore[arg-type]


# -- copies, pickles, processes ------------------------------------------------------------


def _numbers(arm: rd.Arm) -> list[np.ndarray]:
    Q = rd.collision.random_poses(arm, 20, seed=4)
    return [x for q in Q for x in quantities(arm, q)]


@pytest.mark.parametrize("how", ["deepcopy", "copy", "pickle"])
def test_copies_and_pickles_give_the_same_numbers(arm7, skew7, how):
    for arm in (arm7, skew7):
        twin = {
            "deepcopy": copy.deepcopy,
            "copy": copy.copy,
            "pickle": lambda a: pickle.loads(pickle.dumps(a)),
        }[how](arm)
        assert twin is not arm
        assert twin.mujoco.model is not arm.mujoco.model  # independent engines
        assert (twin.source, twin.frame, twin.joint_names) == (
            arm.source,
            arm.frame,
            arm.joint_names,
        )
        assert twin.bridges == arm.bridges
        assert same(_numbers(twin), _numbers(arm))


def test_pickled_arm_keeps_its_load_options(tmp_path):
    arm = rd.load_string(SKEW7, frame="tool", strict=False)
    twin = pickle.loads(pickle.dumps(arm))
    assert twin.frame == "tool" and twin.source == "<string>"


def _gravity_in_worker(arm: rd.Arm, Q: np.ndarray) -> np.ndarray:
    return np.array([arm.gravity(q) for q in Q])


@pytest.mark.parametrize("method", ["spawn", "fork"])
def test_process_pool_workers_give_the_parents_numbers(arm7, method):
    Q = rd.collision.random_poses(arm7, 50, seed=6)
    expected = _gravity_in_worker(arm7, Q)
    ctx = multiprocessing.get_context(method)
    with cf.ProcessPoolExecutor(2, mp_context=ctx) as pool:
        got = list(pool.map(_gravity_in_worker, [arm7, arm7], [Q, Q]))
    assert all(np.array_equal(g, expected) for g in got)
    assert np.abs(expected).max() > 1.0  # gravity is not all zeros


# -- no leaks ------------------------------------------------------------------------------


def _use(arm: rd.Arm) -> None:
    q = arm.keyframe("home")
    arm.jacobian(q)
    arm.gravity(q, "pinocchio")
    Q = rd.collision.random_poses(arm, 300, seed=1)
    batch.jacobians(arm, Q, threads=2)
    batch.gravities(arm, Q, "pinocchio", threads=2)
    rd.crosscheck_batch(arm, Q[:5])
    rd.selfmotion.self_motion(arm, q, total=0.05, step=0.01)
    rd.collision.checker(arm).distances(q)
    rd.collision.checker(arm).contacts(q)
    batch.distances(arm, Q[:50], "mujoco", threads=2)
    rd.collision_statistics(arm, 100)
    rd.check_path(arm, np.array([q, q + 0.1]))


def test_no_cache_keeps_an_arm_alive():
    # Collision checkers and path checkers are cached per Arm; the caches hold it weakly.
    refs = []
    for _ in range(5):
        arm = rd.load(rd.model_path("arm7"))
        _use(arm)
        refs.append(weakref.ref(arm))
        del arm
    gc.collect()
    assert [r() for r in refs] == [None] * 5


def _threaded_stack_in_worker(arm: rd.Arm, Q: np.ndarray) -> np.ndarray:
    return batch.jacobians(arm, Q, threads=2)


def test_forked_worker_runs_threaded_stacks_after_the_parent_did(arm7):
    # The parent's worker threads do not survive fork: the child must start its own.
    Q = rd.collision.random_poses(arm7, 600, seed=9)
    expected = batch.jacobians(arm7, Q, threads=2)  # the parent's pool is up
    ctx = multiprocessing.get_context("fork")
    with cf.ProcessPoolExecutor(1, mp_context=ctx) as pool:
        got = pool.submit(_threaded_stack_in_worker, arm7, Q).result(timeout=120)
    assert np.array_equal(got, expected)


#: Every path that starts threads (MuJoCo's in the library's pool, Pinocchio's OpenMP team,
#: coal's in the pool), each run with 2 threads before a fork and again in the child.
THREADED_PATHS = {
    "gravities pinocchio": "batch.gravities(arm, Q, engine='pinocchio', threads=2)",
    "gravities mujoco": "batch.gravities(arm, Q, engine='mujoco', threads=2)",
    "mass matrices pinocchio": "batch.mass_matrices(arm, Q, engine='pinocchio', threads=2)",
    "singular values": "batch.singular_values(arm, Q, threads=2)",
    "distances coal": "batch.distances(arm, Q[:600], threads=2)",
    "crosscheck_batch": "rd.crosscheck_batch(arm, Q, quantities=['gravity'], threads=2)",
}

FORK_SCRIPT = """
import multiprocessing, os, sys
import mujoco
import numpy as np
import redundancy as rd
from redundancy import batch

arm = rd.load(rd.model_path("arm7"), frame="ee")
Q = rd.arm.random_poses(arm, 1024)
call = lambda: {call}
call()  # threads started in the parent
pid = os.fork()
if pid == 0:
    call()  # the child, with the parent's threads gone
    os._exit(0)
_, status = os.waitpid(pid, 0)
assert status == 0, status
# A pool of the default (fork) start method after the threads ran: its workers too.
with multiprocessing.get_context("fork").Pool(1) as pool:
    assert pool.apply(call_in_worker) == "ok"
print("ok")
"""


@pytest.mark.parametrize("path", list(THREADED_PATHS))
def test_a_fork_after_each_threaded_path_leaves_the_child_usable(path: str) -> None:
    """A fork after batch.gravities(engine="pinocchio", threads=2) hung the child
    (libgomp's pool does not survive fork). Run in a subprocess: a hang fails the test at
    the timeout (a bound for a hung child, not a measured time) instead of blocking."""
    import subprocess
    import sys

    call = THREADED_PATHS[path]
    script = FORK_SCRIPT.format(call=call).replace(
        "import redundancy as rd\n",
        f"import redundancy as rd\ndef call_in_worker():\n    {call}\n    return 'ok'\n",
    )
    try:
        done = subprocess.run(
            [sys.executable, "-c", script], capture_output=True, text=True, timeout=300
        )
    except subprocess.TimeoutExpired:
        pytest.fail(f"{path}: the forked child hung")
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip().endswith("ok")


# -- no process-wide state left behind -----------------------------------------------------

UNSTABLE = '<mujoco><worldbody><body><joint/><geom size="0.1"/></body></worldbody></mujoco>'


def _unstable_step() -> None:
    """One mj_step with a NaN speed: MuJoCo warns "Nan, Inf or huge value in QVEL"."""
    m = mujoco.MjModel.from_xml_string(UNSTABLE)
    d = mujoco.MjData(m)
    d.qvel[:] = np.nan
    mujoco.mj_step(m, d)


@pytest.fixture
def users_warnings():
    """A warning callback of the user's, installed for the test and removed after it."""
    before = mujoco.get_mju_user_warning()
    heard: list[str] = []
    mujoco.set_mju_user_warning(heard.append)
    try:
        yield heard
    finally:
        mujoco.set_mju_user_warning(before)


def test_captures_that_overlap_in_threads_leave_the_users_warning_callback(users_warnings):
    from redundancy.engines.mujoco import captured_warnings

    mine = mujoco.get_mju_user_warning()
    entered = [threading.Event() for _ in range(2)]
    leave = [threading.Event() for _ in range(2)]
    caught: dict[int, list[str]] = {}

    def capture(k: int) -> None:
        with captured_warnings() as messages:
            entered[k].set()
            if k == 0:
                _unstable_step()  # this thread's warning: its own capture's
            leave[k].wait()
        caught[k] = messages

    threads = [threading.Thread(target=capture, args=(k,)) for k in range(2)]
    threads[0].start()
    entered[0].wait()
    threads[1].start()
    entered[1].wait()
    _unstable_step()  # a warning of a thread that captures nothing: the user's callback's
    leave[0].set()  # the first capture ends before the second
    threads[0].join()
    leave[1].set()
    threads[1].join()
    assert mujoco.get_mju_user_warning() is mine
    assert [len(caught[0]), len(caught[1])] == [1, 0]
    assert caught[0][0].startswith("Nan, Inf or huge value in QVEL")
    assert len(users_warnings) == 1
    _unstable_step()
    assert len(users_warnings) == 2


def test_loads_from_threads_leave_the_users_warning_callback(users_warnings):
    mine = mujoco.get_mju_user_warning()
    barrier = threading.Barrier(3)

    def loads() -> None:
        for _ in range(4):
            barrier.wait()
            rd.load(rd.model_path("arm7"), frame="ee")

    with cf.ThreadPoolExecutor(3) as pool:
        for f in [pool.submit(loads) for _ in range(3)]:
            f.result()
    assert mujoco.get_mju_user_warning() is mine
    _unstable_step()
    assert len(users_warnings) == 1 and users_warnings[0].startswith("Nan, Inf or huge")


def test_a_child_forked_during_another_threads_capture_has_the_users_callback(users_warnings):
    from redundancy.engines.mujoco import captured_warnings

    mine = mujoco.get_mju_user_warning()
    inside, leave = threading.Event(), threading.Event()

    def capture() -> None:
        with captured_warnings():
            inside.set()
            leave.wait()

    other = threading.Thread(target=capture)
    other.start()
    inside.wait()
    try:
        pid = os.fork()
        if pid == 0:  # the child: the capturing thread is gone
            ok = mujoco.get_mju_user_warning() is mine
            rd.load(rd.model_path("arm7"), frame="ee")  # the capture works in the child too
            os._exit(0 if ok and mujoco.get_mju_user_warning() is mine else 1)
        _, status = os.waitpid(pid, 0)
    finally:
        leave.set()
        other.join()
    assert os.waitstatus_to_exitcode(status) == 0
    assert mujoco.get_mju_user_warning() is mine

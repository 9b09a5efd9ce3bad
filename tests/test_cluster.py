"""``executor=`` on every batch function and on crosscheck_batch: a Dask cluster of two worker
processes, and a process pool, give the serial results bit for bit.

An arm reaches a worker as its recipe (:mod:`redundancy.model.content`): the worker rebuilds
the robot that was loaded, from the files if they still hold the same bytes, else from the
bytes the caller sends; workers keep arms by that identity. A failure on a worker fails the
call with the library's error and leaves the executor usable.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import copy
import inspect
import multiprocessing
import pickle
import re
import threading
import typing
from collections.abc import Callable, Iterator
from concurrent.futures import Executor, ThreadPoolExecutor
from pathlib import Path
from unittest import mock

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import redundancy as rd
from redundancy import batch

from .models import BLOCK, TWO_LINKS, write_two_links

distributed = pytest.importorskip("distributed")

#: Every public function of redundancy.batch that computes over a stack of poses.
BATCH_FUNCTIONS = (
    batch.jacobians,
    batch.singular_values,
    batch.manipulabilities,
    batch.mass_matrices,
    batch.gravities,
    batch.distances,
)


@pytest.fixture(scope="module")
def dask_executor() -> Iterator[Executor]:
    cluster = distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address="127.0.0.1:0"
    )
    client = distributed.Client(cluster)
    try:
        yield client.get_executor()
    finally:
        client.close()
        cluster.close()


@pytest.fixture(scope="module")
def process_pool() -> Iterator[Executor]:
    with cf.ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as pool:
        yield pool


@pytest.fixture(scope="module", params=["process pool", "dask"])
def executor(request: pytest.FixtureRequest) -> Executor:
    name = "process_pool" if request.param == "process pool" else "dask_executor"
    return request.getfixturevalue(name)


@pytest.fixture(scope="module")
def stack(arm7: rd.Arm) -> np.ndarray:
    # 2500 poses: three chunks of at least EXECUTOR_MIN_CHUNK, so both workers get some.
    return rd.random_poses(arm7, 2500, seed=7)


def _keywords(f) -> set[str]:
    """The keywords ``f`` takes, those of a ``**options: Unpack[SomeTypedDict]`` included."""
    names = set(inspect.signature(f).parameters)
    for name, hint in typing.get_type_hints(f).items():
        if typing.get_origin(hint) is typing.Unpack:
            names |= set(typing.get_args(hint)[0].__annotations__) - {name}
    return names


def test_every_batch_function_takes_an_executor() -> None:
    # The batch module's public functions, wherever they are defined (some live in the
    # batch_* modules it re-exports).
    public = [
        f
        for f in (getattr(batch, name) for name in batch.__all__)
        if inspect.isfunction(f)
        and getattr(f, "__module__", "").startswith(batch.__name__)
        and "Q" in f.__code__.co_varnames[: f.__code__.co_argcount]
    ]
    missing = [f.__name__ for f in public if "executor" not in _keywords(f)]
    assert missing == ["poses"]  # validation only: nothing to distribute
    assert set(BATCH_FUNCTIONS) <= set(public)


@pytest.mark.parametrize("fn", BATCH_FUNCTIONS, ids=lambda f: f.__name__)
def test_dask_equals_serial_bit_for_bit(
    fn, arm7: rd.Arm, stack: np.ndarray, dask_executor: Executor
) -> None:
    serial = fn(arm7, stack)
    distributed_ = fn(arm7, stack, executor=dask_executor)
    assert distributed_.shape == serial.shape
    assert distributed_.tobytes() == serial.tobytes()


def test_dask_options_reach_the_workers(
    arm7: rd.Arm, stack: np.ndarray, dask_executor: Executor
) -> None:
    for kind in ("position", "scaled"):
        serial = batch.manipulabilities(arm7, stack, kind=kind, length=0.3)
        out = batch.manipulabilities(arm7, stack, kind=kind, length=0.3, executor=dask_executor)
        assert out.tobytes() == serial.tobytes()
    bare = batch.mass_matrices(
        arm7, stack, armature=False, engine="pinocchio", executor=dask_executor
    )
    assert (
        bare.tobytes()
        == batch.mass_matrices(arm7, stack, armature=False, engine="pinocchio").tobytes()
    )


def test_crosscheck_batch_on_dask_equals_serial(
    arm7: rd.Arm, stack: np.ndarray, dask_executor: Executor
) -> None:
    Q = stack[:400]
    serial = rd.crosscheck_batch(arm7, Q, chunk=64)
    # Worst poses are merged across the workers' chunks as across chunks in one process.
    out = rd.crosscheck_batch(arm7, Q, chunk=64, executor=dask_executor)
    assert out == serial
    assert out.n_poses == 400 and out.ok
    assert [a.worst_pose for a in out.agreements] == [a.worst_pose for a in serial.agreements]


def test_a_string_arm_travels_too(dask_executor: Executor) -> None:
    from .models import SKEW7

    arm = rd.load_string(SKEW7, frame="tool")
    Q = rd.random_poses(arm, 1500, seed=3)
    assert (
        batch.gravities(arm, Q, executor=dask_executor).tobytes()
        == batch.gravities(arm, Q).tobytes()
    )


def test_empty_stack_and_thread_pool(arm7: rd.Arm, stack: np.ndarray) -> None:
    with ThreadPoolExecutor(2) as pool:
        assert batch.jacobians(arm7, stack[:0], executor=pool).shape == (0, 6, 7)
        assert (
            batch.gravities(arm7, stack, executor=pool).tobytes()
            == batch.gravities(arm7, stack).tobytes()
        )
        report = rd.crosscheck_batch(arm7, stack[:0], executor=pool)
        assert not report.checked


def test_bad_executor_and_bad_arguments_raise_here(arm7: rd.Arm, stack: np.ndarray) -> None:
    with pytest.raises(
        rd.ParameterError,
        match=r"^executor must be None or a concurrent\.futures\.Executor \(e\.g\. a Dask Client\(\.\.\.\)\.get_executor\(\), a ProcessPoolExecutor\), got .dask.$",
    ):
        batch.jacobians(arm7, stack, executor="dask")  # type: ignore[arg-type]
    with ThreadPoolExecutor(1) as pool:
        with pytest.raises(rd.UnknownNameError, match="engine"):
            batch.gravities(arm7, stack, engine="bullet", executor=pool)  # type: ignore[arg-type]
        with pytest.raises(rd.PoseError):
            batch.gravities(arm7, stack[:, :3], executor=pool)


# -- the same arm everywhere ---------------------------------------------------------------


def _within(call: Callable[[], object]) -> object:
    """``call()``, failing the test if it never returns (a hung executor).

    The bound is for a hang, not a measured time: the call takes well under a second.
    """
    out: list[object] = []
    worker = threading.Thread(target=lambda: out.append(_outcome(call)), daemon=True)
    worker.start()
    worker.join(300)
    assert out, "the executor hung"
    if isinstance(out[0], BaseException):
        raise out[0]
    return out[0]


def _outcome(call: Callable[[], object]) -> object:
    try:
        return call()
    except BaseException as err:  # handed to the test's thread
        return err


def _small_chunks() -> mock._patch:
    # Many chunks per call, so each worker of the executor computes some of every call.
    return mock.patch.object(batch, "EXECUTOR_MIN_CHUNK", 16)


def test_a_reloaded_file_is_computed_as_reloaded_by_workers_that_served_the_old_one(
    tmp_path: Path, executor: Executor
) -> None:
    path = write_two_links(tmp_path)
    old = rd.load(path)
    Q = rd.random_poses(old, 300, seed=1)
    with _small_chunks():
        assert _within(lambda: batch.gravities(old, Q, executor=executor)).tobytes() == (
            batch.gravities(old, Q).tobytes()
        )
        path.write_text(TWO_LINKS.format(meshdir="meshes", mass=7.0))
        new = rd.load(path)
        serial = batch.gravities(new, Q)
        assert np.abs(serial - batch.gravities(old, Q)).max() > 1.0
        assert _within(lambda: batch.gravities(new, Q, executor=executor)).tobytes() == (
            serial.tobytes()
        )


@pytest.mark.parametrize("gone", ["removed", "relative path, elsewhere"])
def test_a_worker_without_the_file_computes_the_robot_loaded(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, executor: Executor, gone: str
) -> None:
    # A relative path means nothing in another directory (the workers' own); a temporary
    # file may be gone before the call: the caller sends the bytes the arm was loaded from.
    folder = tmp_path / "robot"
    write_two_links(folder, mass=3.5)
    monkeypatch.chdir(folder)
    arm = rd.load("two.xml")
    if gone == "removed":
        for p in sorted(folder.rglob("*"), reverse=True):
            p.rmdir() if p.is_dir() else p.unlink()
    else:
        (folder / "two.xml").rename(folder / "moved.xml")  # nor there for a worker in here
    Q = rd.random_poses(arm, 100, seed=2)
    with _small_chunks():
        for fn in (batch.gravities, batch.distances):
            got = _within(lambda fn=fn: fn(arm, Q, executor=executor))
            assert got.tobytes() == fn(arm, Q).tobytes()


def test_a_failure_on_a_worker_fails_the_call_with_the_librarys_error(
    tmp_path: Path, executor: Executor
) -> None:
    # A mesh folder named by absolute path is read where it is: when that mesh changed, no
    # worker can rebuild the robot loaded, and the call says so.
    meshes = tmp_path / "shared"
    path = write_two_links(tmp_path / "robot", meshdir=str(meshes))
    arm = rd.load(path)
    (meshes / "block.obj").write_text(BLOCK.replace("0.4 ", "0.9 "))
    Q = rd.random_poses(arm, 40, seed=3)
    mesh = str(meshes / "block.obj")
    with pytest.raises(
        rd.ModelError,
        match=f"^cannot rebuild the arm of {str(path)!r} as it was loaded: the file {mesh!r} "
        "changed since the arm was loaded$",
    ):
        _within(lambda: batch.gravities(arm, Q, executor=executor))
    # An error raised by the computation itself, with attributes its constructor sets.
    arm = rd.load(write_two_links(tmp_path / "intact"))
    singular = np.zeros((3, arm.nq))  # both links along x: the tool cannot move along x
    with pytest.raises(rd.SingularPoseError) as serial:
        batch.operational_inertias(arm, singular)
    with pytest.raises(rd.SingularPoseError) as remote:
        _within(lambda: batch.operational_inertias(arm, singular, executor=executor))
    assert str(remote.value) == str(serial.value)
    assert remote.value.lost == serial.value.lost
    # The executor is still usable.
    arm7 = rd.load(rd.model_path("arm7"), frame="ee")
    Q7 = rd.random_poses(arm7, 50, seed=4)
    assert _within(lambda: batch.gravities(arm7, Q7, executor=executor)).tobytes() == (
        batch.gravities(arm7, Q7).tobytes()
    )


# -- what crosses to a worker is checked and made plain first -------------------------------


def _joint_arguments(arm: rd.Arm) -> dict[str, Callable[[], object]]:
    brakes = {name: 1.0 for name in arm.joint_names[1:]}
    return {
        "dict keys": lambda: brakes.keys(),
        "generator": lambda: (j for j in brakes),
        "array of names": lambda: np.array(list(brakes)),
        "set": lambda: set(brakes),
        "unknown name in a generator": lambda: (j for j in ["j2", "wrist"]),
        "empty generator": lambda: (j for j in []),
        "name twice": lambda: iter(["j2", "j2"]),
        "not names": lambda: iter([1, 2]),
        "a name, not a collection": lambda: "j2",
    }


def _serial_and_executor(call: Callable[..., object], executor: Executor) -> list[object]:
    return [_outcome(lambda: call(None)), _outcome(lambda: _within(lambda: call(executor)))]


def _same_outcome(serial: object, remote: object) -> None:
    if isinstance(serial, BaseException):
        assert type(remote) is type(serial) and str(remote) == str(serial), (serial, remote)
    else:
        assert isinstance(remote, np.ndarray), remote
        assert remote.tobytes() == serial.tobytes()  # type: ignore[attr-defined]


@pytest.mark.parametrize(
    "fn",
    [
        batch.operational_inertias,
        batch.effective_mass_ranges,
        batch.dynamic_manipulabilities,
        lambda arm, Q, **kw: batch.effective_masses(arm, Q, [0.2, -0.3, 1.0], **kw),
    ],
    ids=["operational_inertias", "effective_mass_ranges", "dynamic_manipulabilities", "masses"],
)
def test_joints_given_as_any_collection_give_the_serial_answer_or_error(
    fn: Callable[..., np.ndarray], arm7: rd.Arm, executor: Executor
) -> None:
    Q = rd.random_poses(arm7, 60, seed=5)
    with _small_chunks():
        for name, joints in _joint_arguments(arm7).items():
            serial, remote = _serial_and_executor(
                lambda ex, joints=joints: fn(arm7, Q, joints=joints(), executor=ex), executor
            )
            try:
                _same_outcome(serial, remote)
            except AssertionError as err:
                raise AssertionError(f"joints as {name}: {err}") from None


def test_plain_values_and_per_pose_directions_cross_as_they_are_used_here(
    arm7: rd.Arm, executor: Executor
) -> None:
    Q = rd.random_poses(arm7, 60, seed=6)
    U = np.random.default_rng(6).normal(size=(60, 3))
    calls = {
        "numpy scalars": lambda ex: batch.manipulabilities(
            arm7,
            Q,
            kind=np.str_("scaled"),
            length=np.float32(0.3),
            threads=np.int64(2),
            executor=ex,
        ),
        "numpy flag": lambda ex: batch.mass_matrices(
            arm7, Q, armature=np.bool_(False), executor=ex
        ),
        "a direction per pose": lambda ex: batch.effective_masses(arm7, Q, U, executor=ex),
        "directions as a list": lambda ex: batch.effective_masses(arm7, Q, U.tolist(), executor=ex),
        "a direction per pose, too few": lambda ex: batch.effective_masses(
            arm7, Q, U[:5], executor=ex
        ),
        "a zero direction": lambda ex: batch.effective_masses(arm7, Q, [0, 0, 0], executor=ex),
        "poses as a generator": lambda ex: batch.gravities(arm7, (q for q in Q), executor=ex),
        "a bad flag": lambda ex: batch.mass_matrices(arm7, Q, armature="no", executor=ex),
    }
    with _small_chunks():
        for name, call in calls.items():
            serial, remote = _serial_and_executor(call, executor)
            try:
                _same_outcome(serial, remote)
            except AssertionError as err:
                raise AssertionError(f"{name}: {err}") from None


# -- serial and executor results are bit-equal, whichever way the arm came -----------------

#: Examples of the property: 5 under "redundancy-ci" (60), 83 under "redundancy-thorough".
TRAVEL_EXAMPLES = max(3, settings.default.max_examples // 12)
#: Every function with ``executor=``, as (arm, Q, executor) -> a result to compare.
EXECUTOR_CALLS: dict[str, Callable[..., object]] = {
    **{
        fn.__name__: lambda arm, Q, executor, fn=fn: fn(arm, Q, executor=executor)
        for fn in (
            *BATCH_FUNCTIONS,
            batch.operational_inertias,
            batch.effective_mass_ranges,
            batch.dynamic_manipulabilities,
        )
    },
    "effective_masses": lambda arm, Q, executor: batch.effective_masses(
        arm, Q, np.cos(np.arange(3 * len(Q)) + 0.5).reshape(-1, 3), executor=executor
    ),
    "crosscheck_batch": lambda arm, Q, executor: rd.crosscheck_batch(
        arm, Q, chunk=16, executor=executor
    ),
}


def _write_model(folder: Path, which: str, mass: float) -> Path:
    """The two-link arm (an include, a mesh) or arm7 as files, the first link of ``mass``."""
    if which == "two links":
        return write_two_links(folder, mass=mass)
    text = rd.model_path("arm7").read_text(encoding="utf-8")
    path = folder / "arm7.xml"
    path.write_text(re.sub(r'mass="[0-9.]+"', f'mass="{mass!r}"', text, count=1))
    return path


def _same_result(serial: object, remote: object) -> None:
    if isinstance(serial, np.ndarray):
        assert isinstance(remote, np.ndarray), remote
        assert remote.shape == serial.shape and remote.tobytes() == serial.tobytes()
    elif isinstance(serial, BaseException):
        assert type(remote) is type(serial) and str(remote) == str(serial), (serial, remote)
    else:
        assert remote == serial


@settings(
    max_examples=TRAVEL_EXAMPLES,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(
    which=st.sampled_from(["two links", "arm7"]),
    how=st.sampled_from(["relative path", "reloaded file", "copy", "pickled copy"]),
    mass=st.floats(0.5, 20.0),
    call=st.sampled_from(sorted(EXECUTOR_CALLS)),
    n=st.integers(0, 70),
    seed=st.integers(0, 2**16),
)
def test_executor_results_equal_serial_ones_bit_for_bit(
    tmp_path_factory: pytest.TempPathFactory,
    process_pool: Executor,
    dask_executor: Executor,
    which: str,
    how: str,
    mass: float,
    call: str,
    n: int,
    seed: int,
) -> None:
    folder = tmp_path_factory.mktemp("robot")
    path = _write_model(folder, which, mass)
    with contextlib.chdir(folder):
        arm = rd.load(path.name) if how == "relative path" else rd.load(path)
    if how == "reloaded file":
        # The workers compute the first version, then the file changes and is loaded again.
        for executor in (process_pool, dask_executor):
            with _small_chunks():
                _within(
                    lambda ex=executor: batch.gravities(arm, np.zeros((40, arm.nq)), executor=ex)
                )
        _write_model(folder, which, mass + 1.0)
        arm = rd.load(path)
    elif how == "copy":
        arm = copy.deepcopy(arm)
    elif how == "pickled copy":
        arm = pickle.loads(pickle.dumps(arm))
    Q = rd.random_poses(arm, n, seed=seed)
    fn = EXECUTOR_CALLS[call]
    serial = _outcome(lambda: fn(arm, Q, None))
    with _small_chunks():
        for executor in (process_pool, dask_executor):
            _same_result(serial, _outcome(lambda ex=executor: _within(lambda: fn(arm, Q, ex))))

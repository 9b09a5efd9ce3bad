"""``executor=`` on every batch function and on crosscheck_batch: a Dask cluster of two worker
processes gives the serial results bit for bit."""

from __future__ import annotations

from collections.abc import Iterator
from concurrent.futures import Executor, ThreadPoolExecutor

import numpy as np
import pytest

import redundancy as rd
from redundancy import batch

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
def stack(arm7: rd.Arm) -> np.ndarray:
    # 2500 poses: three chunks of at least EXECUTOR_MIN_CHUNK, so both workers get some.
    return rd.random_poses(arm7, 2500, seed=7)


def test_every_batch_function_takes_an_executor() -> None:
    public = [
        f
        for name, f in vars(batch).items()
        if callable(f)
        and not name.startswith("_")
        and getattr(f, "__module__", "") == batch.__name__
        and "Q" in f.__code__.co_varnames[: f.__code__.co_argcount]
    ]
    missing = [f.__name__ for f in public if "executor" not in f.__code__.co_varnames]
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

    arm = rd.load_string(SKEW7, site="tool")
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

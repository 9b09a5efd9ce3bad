"""The registry of cross-checked quantities: one entry per quantity, read by the cross-check,
the audit and the guide; the engines as a set, compared with the reference one by one."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import redundancy as rd
from redundancy.analysis.crosscheck import (
    BATCH_QUANTITIES,
    DYNAMIC_QUANTITIES,
    M_INVERSE_QUANTITIES,
    TOLERANCES,
)
from redundancy.engines import REFERENCE
from redundancy.engines.contract import Engine, Stacks
from redundancy.quantities import QUANTITIES, QUANTITY

from .models import chain

GUIDE = Path(__file__).resolve().parents[1] / "docs" / "guide" / "from-python.md"


def test_the_crosschecks_constants_are_read_from_the_registry() -> None:
    assert TOLERANCES == {q.name: q.tol for q in QUANTITIES}
    assert DYNAMIC_QUANTITIES == tuple(q.name for q in QUANTITIES if q.dynamic)
    assert M_INVERSE_QUANTITIES == ("operational inertia^-1", "dynamic manipulability")
    assert BATCH_QUANTITIES == tuple(q.name for q in QUANTITIES if q.field is not None)
    assert list(QUANTITY) == [q.name for q in QUANTITIES]  # one entry per name


def test_each_quantity_is_an_engine_method_in_every_engine(arm7: rd.Arm) -> None:
    for q in QUANTITIES:
        assert hasattr(Engine, q.method), q.name
        for engine in arm7.engines.values():
            assert callable(getattr(engine, q.method)), (q.name, engine.name)
        assert q.field in (None, *Stacks.__dataclass_fields__), q.name


def test_the_guide_tolerance_table_is_the_registry() -> None:
    rows = re.findall(r"^\| ([^|]+?) \| ([^|]+?) \| (\de-\d+) \|", GUIDE.read_text(), re.M)
    assert [(name, unit, float(tol)) for name, unit, tol in rows] == [
        (q.name, q.unit, q.tol) for q in QUANTITIES
    ]


class Skewed:
    """A third engine: Pinocchio's numbers with gravity off by one part in a million."""

    name = "skewed"

    def __init__(self, inner: Any) -> None:
        self._inner = inner

    def __getattr__(self, attr: str) -> Any:
        return getattr(self._inner, attr)

    def evaluate(self, Q: np.ndarray, out: Stacks, threads: int = 1) -> None:
        self._inner.evaluate(Q, out, threads)
        if out.G is not None:
            out.G *= 1 + 1e-6


def test_a_third_engine_is_compared_with_the_reference_and_confirms_ik() -> None:
    arm = rd.load_string(chain(), frame="tip")
    arm.engines["skewed"] = Skewed(arm.pinocchio)
    assert arm.reference is arm.engines[REFERENCE] is arm.mujoco
    Q = np.array([[0.3, -0.4], [1.0, 0.5], [-2.0, 1.2]])
    report = rd.crosscheck(arm, Q, ["jacobian", "gravity"])
    assert report["jacobian"].ok
    assert not report["gravity"].ok  # the skewed engine's 1e-6, beyond 1e-9
    assert report["gravity"].max_error == pytest.approx(1e-6, rel=1e-3)
    result = arm.solve_ik(arm.site_pose([0.4, 0.3]), position_only=True)
    assert result.success
    assert (result.engine, result.checked_by) == ("mujoco", "pinocchio, drake, skewed")
    with pytest.raises(
        rd.UnknownNameError,
        match=r"^unknown engine 'nope'; valid engine names: \['mujoco', 'pinocchio', 'drake', 'skewed'\]$",
    ):
        arm.engine("nope")


@pytest.mark.parametrize("quantities", [["jacobian"], ["operational inertia^-1"]])
def test_a_report_equals_itself_through_a_pickle(arm7: rd.Arm, quantities: list[str]) -> None:
    """A report is a value: the same after crossing to a worker or a file, whether or not a
    quantity through M^-1 measured cond(M) (a NaN for "not measured" broke this)."""
    import pickle

    report = rd.crosscheck_batch(arm7, rd.random_poses(arm7, 4, seed=0), quantities)
    assert (report.mass_condition is None) == (quantities == ["jacobian"])
    assert pickle.loads(pickle.dumps(report)) == report

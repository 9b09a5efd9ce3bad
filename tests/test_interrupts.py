"""An exception at any engine call leaves the per-thread cache honest.

Each engine's module reaches its engine through module attributes (``mujoco`` and the hot
path's bound ``mj_*`` functions; ``pin``). The test replaces them by a proxy that raises
KeyboardInterrupt at the k-th engine call, for every k that a query at a new pose makes,
then asks for every quantity at the previous pose: the numbers must be that pose's, bit for
bit.
"""

from __future__ import annotations

from collections.abc import Callable
from types import ModuleType
from typing import Any

import numpy as np
import pytest

import redundancy as rd
from redundancy.engines import mujoco as mj_engine
from redundancy.engines import pinocchio as pin_engine

QUERIES = ("site_pose", "site_jacobian", "mass_matrix", "gravity", "jacobian_derivatives")


class Tripwire:
    """Counts engine calls; the call numbered ``at`` raises KeyboardInterrupt instead."""

    def __init__(self, at: int) -> None:
        self.at = at
        self.calls = 0

    def wrap(self, f: Callable[..., Any]) -> Callable[..., Any]:
        def call(*args: Any, **kwargs: Any) -> Any:
            self.calls += 1
            if self.calls == self.at:
                raise KeyboardInterrupt
            return f(*args, **kwargs)

        return call


class ModuleProxy:
    """A module whose callables go through a :class:`Tripwire`."""

    def __init__(self, module: ModuleType, wire: Tripwire) -> None:
        self._module, self._wire = module, wire

    def __getattr__(self, name: str) -> Any:
        value = getattr(self._module, name)
        if callable(value) and not isinstance(value, type) and name[:1].islower():
            return self._wire.wrap(value)
        return value


def patch_engine(monkeypatch: pytest.MonkeyPatch, engine: str, wire: Tripwire) -> None:
    if engine == "mujoco":
        monkeypatch.setattr(mj_engine, "mujoco", ModuleProxy(mj_engine.mujoco, wire))
        for name in ("_kinematics", "_com_pos", "_jac_site"):
            monkeypatch.setattr(mj_engine, name, wire.wrap(getattr(mj_engine, name)))
    else:
        monkeypatch.setattr(pin_engine, "pin", ModuleProxy(pin_engine.pin, wire))


def everything(eng: Any, q: np.ndarray) -> list[np.ndarray]:
    out: list[np.ndarray] = []
    for name in QUERIES:
        value = getattr(eng, name)(q)
        out.extend(value if isinstance(value, tuple) else (value,))
    return out


@pytest.mark.parametrize("engine", ["mujoco", "pinocchio"])
@pytest.mark.parametrize("query", QUERIES)
def test_interrupt_at_every_engine_call_leaves_the_cache_honest(
    skew7: rd.Arm, engine: str, query: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    eng = skew7.engine(engine)
    a = skew7.keyframe("bent")
    b = a + 0.37
    expected = dict(zip(QUERIES, (getattr(eng, n)(a) for n in QUERIES), strict=True))
    interrupted = 0
    # The last query at pose a decides what the cache holds when the query at b starts.
    for before in QUERIES:
        for at in range(1, 200):
            everything(eng, a)
            getattr(eng, before)(a)
            wire = Tripwire(at)
            with monkeypatch.context() as m:
                patch_engine(m, engine, wire)
                try:
                    getattr(eng, query)(b)
                except KeyboardInterrupt:
                    interrupted += 1
                else:
                    break  # every engine call of the query has been interrupted once
            # The query that was interrupted first, then every other one, at pose a.
            for name in (query, *QUERIES):
                got, want = getattr(eng, name)(a), expected[name]
                for g, w in zip(
                    *(v if isinstance(v, tuple) else (v,) for v in (got, want)), strict=True
                ):
                    np.testing.assert_array_equal(
                        g, w, err_msg=f"{name} after {before}, {query} interrupted at call {at}"
                    )
    assert interrupted >= len(QUERIES)

"""The engines' single-pose entry: validation, the per-thread pose cache and its fast path.

Every single-pose engine method validates its pose (an engine may be called directly), and
``MujocoEngine.site_jacobian`` carries its own copy of the check's fast path for speed: these
tests hold both to :func:`redundancy.checks.check_pose`, input by input.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import redundancy as rd
from redundancy.checks import check_pose
from redundancy.engines import ENGINES
from redundancy.engines.contract import Engine

from .models import SKEW7

NQ = 7  # the joints of SKEW7, the ``skew7`` fixture's arm


def _single_pose_calls(engine: Engine) -> dict[str, Callable[[object], object]]:
    return {
        "site_pose": engine.site_pose,
        "site_jacobian": engine.site_jacobian,
        "mass_matrix": engine.mass_matrix,
        "gravity": engine.gravity,
        "jacobian_derivatives": engine.jacobian_derivatives,
        "link_inertias": engine.link_inertias,
        "joint_axes": engine.joint_axes,
        "integrate": lambda q: engine.integrate(q, np.zeros(NQ)),
        "integrate (dq)": lambda q: engine.integrate(np.zeros(NQ), q),
        "coriolis": lambda q: engine.coriolis(q, np.ones(NQ)),
        "com": engine.com,
        "com_jacobian": engine.com_jacobian,
        "centroidal_momentum_matrix": engine.centroidal_momentum_matrix,
    }


def _outcome(call: Callable[[], object]) -> tuple[str, object]:
    """("ok", value) or ("error", message); any exception but PoseError fails the test."""
    try:
        return "ok", call()
    except rd.PoseError as err:
        return "error", str(err)


def _same(a: object, b: object) -> bool:
    if isinstance(a, tuple):
        return isinstance(b, tuple) and len(a) == len(b) and all(map(_same, a, b))
    return bool(np.array_equal(np.asarray(a), np.asarray(b)))


#: Inputs of every kind a caller may pass where a pose is expected.
BAD = {
    "complex": np.full(NQ, 0.1 + 1j),
    "complex, zero imaginary part": np.zeros(NQ, dtype=complex),
    "NaN": np.array([0.0, 0, np.nan, 0, 0, 0, 0]),
    "inf": np.array([np.inf, 0, 0, 0, 0, 0, -np.inf]),
    "short": np.zeros(NQ - 1),
    "row": np.zeros((1, NQ)),
    "column": np.zeros((NQ, 1)),
    "scalar": np.float64(0.0),
    "None": None,
    "text": "0 0 0 0 0 0 0",
    "words": ["a"] * NQ,
    "ragged": [[0, 0, 0], [0, 0, 0, 0]],
    "dict": {},
    "object array with None": np.array([0.0] * (NQ - 1) + [None], dtype=object),
    "masked value": np.ma.masked_array(np.zeros(NQ), mask=[0] * (NQ - 1) + [1]),
}


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("kind", list(BAD))
def test_every_single_pose_method_refuses_what_check_pose_refuses(
    skew7: rd.Arm, engine: str, kind: str
) -> None:
    q = BAD[kind]
    expected = _outcome(lambda: check_pose(q, skew7.joint_names))
    for name, call in _single_pose_calls(skew7.engine(engine)).items():  # type: ignore[arg-type]
        got = _outcome(lambda call=call: call(q))  # type: ignore[misc]
        assert got[0] == expected[0], (name, got, expected)
        if expected[0] == "error":
            assert got[1] == expected[1], name


def _poses() -> st.SearchStrategy[object]:
    """Poses and near-poses: float64 and other dtypes, other shapes, non-finite values,
    values whose sum overflows, array subclasses, lists and tuples."""
    value = st.one_of(
        st.floats(-3.0, 3.0),
        st.sampled_from([np.nan, np.inf, -np.inf, 1e308, -1e308, 0.0, -0.0, 5e-324]),
    )
    values = st.lists(value, min_size=NQ, max_size=NQ)
    dtype = st.sampled_from(
        [np.float64, np.float64, np.float32, np.int64, np.complex128, bool, object, ">f8"]
    )
    shape = st.sampled_from([(NQ,), (NQ,), (NQ,), (1, NQ), (NQ, 1)])

    @st.composite
    def arrays(draw: st.DrawFn) -> object:
        x = np.array(draw(values))
        kind = draw(dtype)
        with np.errstate(invalid="ignore", over="ignore"):
            x = x.astype(kind) if kind is not object else x.astype(object)
        x = x.reshape(draw(shape))
        wrap = draw(st.sampled_from(["array", "array", "list", "tuple", "masked", "slice"]))
        if wrap == "list":
            return x.tolist()
        if wrap == "tuple":
            return tuple(x.ravel().tolist()) if x.ndim == 1 else x.tolist()
        if wrap == "masked":
            return np.ma.masked_array(x)
        if wrap == "slice":  # a non-contiguous view of the same values
            y = np.repeat(x, 2, axis=-1)
            return y[..., ::2]
        return x

    return arrays()


@pytest.mark.parametrize("engine", ENGINES)
@given(q=_poses())
def test_site_jacobian_fast_path_agrees_with_check_pose(
    skew7: rd.Arm, engine: str, q: object
) -> None:
    eng = skew7.engine(engine)  # type: ignore[arg-type]
    eng.site_jacobian(np.full(NQ, 0.25))  # hold another pose: q must miss the cache
    expected = _outcome(lambda: eng.site_jacobian(check_pose(q, skew7.joint_names)))
    eng.site_jacobian(np.full(NQ, 0.25))
    got = _outcome(lambda: eng.site_jacobian(q))
    assert got[0] == expected[0], (got, expected)
    assert _same(got[1], expected[1]) if got[0] == "ok" else got[1] == expected[1]


@pytest.mark.parametrize("engine", ENGINES)
def test_pose_cache_follows_values_not_objects(skew7: rd.Arm, engine: str) -> None:
    eng = skew7.engine(engine)  # type: ignore[arg-type]
    q = np.full(NQ, 0.3)
    first = eng.site_jacobian(q)
    q[1] += 0.5  # the same array, changed in place
    moved = eng.site_jacobian(q)
    assert not np.array_equal(first, moved)
    assert np.array_equal(moved, eng.site_jacobian(q.copy()))
    # What the caller got is theirs: changing it changes nothing the engine holds.
    moved[:] = 7.0
    assert np.array_equal(eng.site_jacobian(q), eng.site_jacobian(q.tolist()))
    assert not np.any(eng.site_jacobian(q) == 7.0)


@pytest.mark.parametrize("engine", ENGINES)
def test_a_refused_pose_leaves_the_held_pose_intact(skew7: rd.Arm, engine: str) -> None:
    eng = skew7.engine(engine)  # type: ignore[arg-type]
    q = np.linspace(-0.4, 0.4, NQ)
    J, M, g = eng.site_jacobian(q), eng.mass_matrix(q), eng.gravity(q)
    bad = q.copy()
    bad[2] = np.nan
    for call in (eng.site_jacobian, eng.mass_matrix, eng.gravity, eng.site_pose):
        with pytest.raises(rd.PoseError, match=r"^pose has non-finite values: q3=nan$"):
            call(bad)
    assert np.array_equal(eng.site_jacobian(q), J)
    assert np.array_equal(eng.mass_matrix(q), M)
    assert np.array_equal(eng.gravity(q), g)


def test_queries_in_any_order_read_one_kinematics_pass(skew7: rd.Arm) -> None:
    """J, M, gravity and the site pose at one pose, in every order, equal fresh answers."""
    eng = skew7.mujoco
    q = np.linspace(0.5, -0.5, NQ)
    fresh = rd.load_string(SKEW7, frame="tool").mujoco
    want = {
        "J": fresh.site_jacobian(q),
        "M": fresh.mass_matrix(q),
        "g": fresh.gravity(q),
        "x": fresh.site_pose(q)[0],
    }
    calls = {
        "J": eng.site_jacobian,
        "M": eng.mass_matrix,
        "g": eng.gravity,
        "x": lambda q: eng.site_pose(q)[0],
    }
    for order in (["J", "M", "g", "x"], ["x", "g", "M", "J"], ["M", "J", "J", "g"]):
        eng.site_jacobian(np.zeros(NQ))
        for name in order:
            assert np.array_equal(calls[name](q), want[name]), (order, name)

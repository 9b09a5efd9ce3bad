"""The hypothesis strategies of `redundancy.testing` and `redundancy.generate` check their
arguments when called, through the library's validators: a bad one is the library's error, with
its exact text, never hypothesis's, numpy's or Python's (nor a silently different strategy).

The largest margin is read from MuJoCo's own joint ranges of the file (outside the library).
"""

from __future__ import annotations

import re
from contextlib import AbstractContextManager

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings

import redundancy as rd
from redundancy import generate, testing

from .models import chain

# Joint a in [-30, 40] degrees (MuJoCo's default unit), b unlimited.
TWO = chain(joints='<joint name="a" axis="0 1 0" range="-30 40"/>')


@pytest.fixture(scope="module")
def arm() -> rd.Arm:
    return rd.load_string(TWO, frame="tip")


def _refused(error: type[Exception], text: str) -> AbstractContextManager[object]:
    return pytest.raises(error, match="^" + re.escape(text) + "$")


def _half_narrowest_range() -> float:
    model = mujoco.MjModel.from_xml_string(TWO)
    return float((model.jnt_range[0, 1] - model.jnt_range[0, 0]) / 2)  # b has no range


def test_poses_velocities_and_states_check_their_arguments(arm: rd.Arm) -> None:
    not_an_arm = "arm must be an Arm (from redundancy.load or load_string), got 'arm.xml'"
    for strategy in (testing.poses, testing.velocities, testing.states):
        with _refused(rd.ParameterError, not_an_arm):
            strategy("arm.xml")  # type: ignore[arg-type]
    for bad in (-0.1, float("nan"), "0.1"):
        text = f"margin must be a finite number >= 0 [rad or m], got {bad!r}"
        with _refused(rd.ParameterError, text):
            testing.poses(arm, margin=bad)  # type: ignore[arg-type]
        with _refused(rd.ParameterError, text):
            testing.states(arm, margin=bad)  # type: ignore[arg-type]
    half = _half_narrowest_range()
    wide = f"margin must be a finite number in [0, {half:g}] [rad or m], got 0.7"
    with _refused(rd.ParameterError, wide):
        testing.poses(arm, margin=0.7)
    with _refused(rd.ParameterError, "unlimited must be a finite number > 0 [rad], got 0.0"):
        testing.poses(arm, unlimited=0.0)
    for bad in (-1.0, float("inf"), float("nan"), "fast"):
        text = f"speed must be a finite number >= 0 [rad/s or m/s], got {bad!r}"
        with _refused(rd.ParameterError, text):
            testing.velocities(arm, speed=bad)  # type: ignore[arg-type]
        with _refused(rd.ParameterError, text):
            testing.states(arm, speed=bad)  # type: ignore[arg-type]


def test_register_profiles_names_the_profiles() -> None:
    text = (
        "unknown hypothesis profile '5'; valid hypothesis profile names: "
        "['redundancy-ci', 'redundancy-thorough']"
    )
    with _refused(rd.UnknownNameError, text):
        testing.register_profiles(5)  # type: ignore[arg-type]


def test_the_generated_arms_check_their_arguments() -> None:
    for bad in (0, -2, 2.5, "3", True):
        text = f"max_joints must be an integer >= 1, got {bad!r}"
        with _refused(rd.ParameterError, text):
            generate.arms(max_joints=bad)  # type: ignore[arg-type]
        with _refused(rd.ParameterError, text):
            generate.resolved_arms(max_joints=bad)  # type: ignore[arg-type]
    with _refused(rd.ParameterError, "branching must be True or False, got 'no'"):
        generate.arms(branching="no")  # type: ignore[arg-type]
    strategies = (
        (generate.held_arms, "held feature", generate.HELD_FEATURES),
        (generate.refused_arms, "refused feature", generate.REFUSED_FEATURES),
        (generate.resolved_arms, "resolved feature", generate.RESOLVED_FEATURES),
    )
    for strategy, kind, valid in strategies:
        for bad in ((), "ball joint", 5, None):
            text = f"features must be a nonempty tuple of names from {list(valid)}, got {bad!r}"
            with _refused(rd.ParameterError, text):
                strategy(bad)  # type: ignore[arg-type]
        # A feature of another strategy (or none) is not drawn as a plain arm labelled with it.
        other = "tail" if kind == "held feature" else "ball joint"
        with pytest.raises(rd.UnknownNameError) as info:
            strategy((valid[0], other))
        names = ", ".join(repr(v) for v in valid)
        assert str(info.value) == f"unknown {kind} {other!r}; valid {kind} names: [{names}]"


def test_the_widest_margin_is_half_the_narrowest_range_and_still_draws(arm: rd.Arm) -> None:
    half = _half_narrowest_range()
    assert half == pytest.approx(np.radians(35), abs=1e-15)

    @settings(max_examples=20, database=None)
    @given(testing.poses(arm, margin=half))
    def draws(q: np.ndarray) -> None:
        assert q[0] == pytest.approx(np.radians(5), abs=1e-12)  # the middle of a's range
        assert -np.pi <= q[1] <= np.pi  # b unlimited: no margin

    draws()

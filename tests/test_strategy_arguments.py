"""The hypothesis strategies of `redundancy.testing` and `redundancy.generate` check their
arguments when called, through the library's validators: a bad one is the library's error, with
its exact text, never hypothesis's, numpy's or Python's (nor a silently different strategy).

The largest margin is read from MuJoCo's own joint ranges of the file (outside the library).
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings

import redundancy as rd
from redundancy import generate, testing

# Two hinges: j1 in [-0.5, 0.7] (narrowest, 1.2 rad wide), j2 in [-2, 2].
TWO = """<mujoco>
  <compiler angle="radian"/>
  <worldbody>
    <body name="l1">
      <joint name="j1" axis="0 0 1" range="-0.5 0.7"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
      <body name="l2" pos="0.3 0 0">
        <joint name="j2" axis="0 1 0" range="-2 2"/>
        <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02"/>
        <site name="tip" pos="0.2 0 0"/>
      </body>
    </body>
  </worldbody>
</mujoco>"""


@pytest.fixture(scope="module")
def arm() -> rd.Arm:
    return rd.load_string(TWO, frame="tip")


NOT_AN_ARM = r"^arm must be an Arm \(from redundancy.load or load_string\), got 'arm.xml'$"
MARGIN = r"^margin must be a finite number >= 0 \[rad or m\], got "
SPEED = r"^speed must be a finite number >= 0 \[rad/s or m/s\], got "

CASES: list[tuple[str, Callable[[rd.Arm], object], type[Exception], str]] = [
    ("poses arm", lambda a: testing.poses("arm.xml"), rd.ParameterError, NOT_AN_ARM),  # type: ignore[arg-type]
    (
        "poses margin < 0",
        lambda a: testing.poses(a, margin=-0.1),
        rd.ParameterError,
        MARGIN + r"-0.1$",
    ),
    (
        "poses margin nan",
        lambda a: testing.poses(a, margin=float("nan")),
        rd.ParameterError,
        MARGIN + "nan$",
    ),
    (
        "poses margin str",
        lambda a: testing.poses(a, margin="0.1"),
        rd.ParameterError,
        MARGIN + "'0.1'$",
    ),  # type: ignore[arg-type]
    (
        "poses margin too wide",
        lambda a: testing.poses(a, margin=0.61),
        rd.ParameterError,
        r"^margin must be a finite number in \[0, 0.6\] \[rad or m\], got 0.61$",
    ),
    (
        "poses unlimited",
        lambda a: testing.poses(a, unlimited=0.0),
        rd.ParameterError,
        r"^unlimited must be a finite number > 0 \[rad\], got 0.0$",
    ),
    ("velocities arm", lambda a: testing.velocities("arm.xml"), rd.ParameterError, NOT_AN_ARM),  # type: ignore[arg-type]
    (
        "velocities speed < 0",
        lambda a: testing.velocities(a, speed=-1.0),
        rd.ParameterError,
        SPEED + r"-1.0$",
    ),
    (
        "velocities speed inf",
        lambda a: testing.velocities(a, speed=float("inf")),
        rd.ParameterError,
        SPEED + "inf$",
    ),
    (
        "velocities speed str",
        lambda a: testing.velocities(a, speed="fast"),
        rd.ParameterError,
        SPEED + "'fast'$",
    ),  # type: ignore[arg-type]
    (
        "states speed nan",
        lambda a: testing.states(a, speed=float("nan")),
        rd.ParameterError,
        SPEED + "nan$",
    ),
    ("states margin", lambda a: testing.states(a, margin=-1), rd.ParameterError, MARGIN + "-1$"),
    (
        "register_profiles",
        lambda a: testing.register_profiles(5),  # type: ignore[arg-type]
        rd.UnknownNameError,
        r"^unknown hypothesis profile '5'; valid hypothesis profile names: "
        r"\['redundancy-ci', 'redundancy-thorough'\]$",
    ),
    (
        "arms max_joints 0",
        lambda a: generate.arms(max_joints=0),
        rd.ParameterError,
        r"^max_joints must be an integer >= 1, got 0$",
    ),
    (
        "arms max_joints float",
        lambda a: generate.arms(max_joints=2.5),  # type: ignore[arg-type]
        rd.ParameterError,
        r"^max_joints must be an integer >= 1, got 2.5$",
    ),
    (
        "arms max_joints str",
        lambda a: generate.arms(max_joints="3"),  # type: ignore[arg-type]
        rd.ParameterError,
        r"^max_joints must be an integer >= 1, got '3'$",
    ),
    (
        "arms branching",
        lambda a: generate.arms(branching="no"),  # type: ignore[arg-type]
        rd.ParameterError,
        r"^branching must be True or False, got 'no'$",
    ),
    (
        "held_arms unknown feature",
        lambda a: generate.held_arms(("tail",)),
        rd.UnknownNameError,
        r"^unknown held feature 'tail'; valid held feature names: \['several root bodies', "
        r"'several kinematic trees', 'ball joint', 'free joint'\]$",
    ),
    (
        "held_arms a string",
        lambda a: generate.held_arms("ball joint"),  # type: ignore[arg-type]
        rd.ParameterError,
        r"^features must be a nonempty tuple of names from \['several root bodies', "
        r"'several kinematic trees', 'ball joint', 'free joint'\], got 'ball joint'$",
    ),
    (
        "held_arms none",
        lambda a: generate.held_arms(()),
        rd.ParameterError,
        r"^features must be a nonempty tuple of names from \['several root bodies', "
        r"'several kinematic trees', 'ball joint', 'free joint'\], got \(\)$",
    ),
    (
        "refused_arms a held feature",
        lambda a: generate.refused_arms(("ball joint",)),
        rd.UnknownNameError,
        r"^unknown refused feature 'ball joint'; valid refused feature names: "
        r"\['several joints in one body', 'tendon on an arm joint', 'joint coupling on the "
        r"arm', 'unnamed joint', 'no joints', 'shell inertia'\]$",
    ),
    (
        "resolved_arms not names",
        lambda a: generate.resolved_arms(5),  # type: ignore[arg-type]
        rd.ParameterError,
        r"^features must be a nonempty tuple of names from \['extrinsic eulerseq', "
        r"'axisangle with a non-unit axis', '<frame> element', 'class inside a different "
        r"childclass', 'joint pos in a default class', '<replicate> element'\], got 5$",
    ),
    (
        "resolved_arms max_joints",
        lambda a: generate.resolved_arms(max_joints=-2),
        rd.ParameterError,
        r"^max_joints must be an integer >= 1, got -2$",
    ),
]


@pytest.mark.parametrize(
    ("call", "error", "text"), [c[1:] for c in CASES], ids=[c[0] for c in CASES]
)
def test_a_bad_argument_is_the_librarys_error_when_the_strategy_is_made(
    arm: rd.Arm, call: Callable[[rd.Arm], object], error: type[Exception], text: str
) -> None:
    with pytest.raises(error, match=text):
        call(arm)


def test_the_widest_margin_is_half_the_narrowest_range_and_still_draws(arm: rd.Arm) -> None:
    model = mujoco.MjModel.from_xml_string(TWO)
    half = float(np.min(model.jnt_range[:, 1] - model.jnt_range[:, 0]) / 2)
    assert half == pytest.approx(0.6, abs=1e-15)

    @settings(max_examples=20, database=None)
    @given(testing.poses(arm, margin=half))
    def draws(q: np.ndarray) -> None:
        assert q[0] == pytest.approx(0.1, abs=1e-12)  # the middle of j1's range
        assert -2 + half <= q[1] <= 2 - half

    draws()

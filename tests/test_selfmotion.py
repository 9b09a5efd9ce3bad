"""Self-motion: wrist singularity, null-space drift, contact escape, the scripts.

Every number the two scripts print rests on a test here; nothing is compared with a stored
result, only with the geometry (collinear axes, equal columns) or with orders of convergence.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

import redundancy as rd
from redundancy import linalg
from redundancy.analysis.selfmotion import (
    STOP_MAXIMUM,
    Objective,
    joint_limit_objective,
    manipulability_objective,
    no_contact,
    rotation_log,
    self_motion,
)
from redundancy.testing import poses

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"
J6 = 5  # index of j6 in arm7's joint order (checked in test_arm7_joint_indices)
WRIST = [4, 5, 6]  # j5, j6, j7


def test_arm7_joint_indices(arm7):
    assert arm7.joint_index("j6") == J6
    assert [arm7.joint_index(n) for n in ("j5", "j6", "j7")] == WRIST


# Tolerances and their reasons.
# Rank loss: a singular value that is exactly 0 in exact arithmetic comes out of LAPACK at
# ~1e-16 times sigma_max (~1 here); 1e-12 leaves four orders of magnitude.
SINGULAR_TOL = 1e-12
# Corrected self-motion: each step ends with Newton corrections until |e| <= 1e-12 (the
# default tol), measured from the start pose, so the drift does not add up; 1e-9 m leaves
# three orders of magnitude for rounding in forward kinematics (~1e-16 m per evaluation).
CORRECTED_DRIFT = 1e-9
# Convergence orders: the ratio of drifts at steps h and h/2 tends to 2^order; at h = 0.02
# and 0.01 rad the measured ratios differ from it by < 0.5 %, and 5 % leaves room for the
# next-order term while still telling order 1 (ratio 2) from order 2 (ratio 4).
RATIO_TOL = 0.05
# The challenge's bound on the tool motion while escaping a contact.
ESCAPE_DRIFT = 1e-3


def load_script(name: str) -> ModuleType:
    """Import scripts/<name>.py as a module (scripts/ is not a package)."""
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, SCRIPTS / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses resolve annotations through sys.modules
    spec.loader.exec_module(module)
    return module


EXERCISE = load_script("exercise_wrist_singularity")
CHALLENGE = load_script("challenge_self_motion")


def with_j6(q: np.ndarray, value: float) -> np.ndarray:
    q = q.copy()
    q[J6] = value
    return q


# ------------------------------------------------------------------------------------------
# The exercise: the wrist singularity
# ------------------------------------------------------------------------------------------


def test_wrist_block_is_singular_at_j6_zero_on_the_home_sweep(arm7):
    HOME = arm7.keyframe("home")
    values = np.linspace(arm7.lower[J6], arm7.upper[J6], 441)  # step 0.01, includes 0
    sweep = EXERCISE.sweep(arm7, HOME, "j6", values)
    wrist = sweep.series("wrist_orientation")
    i = int(np.argmin(wrist))
    assert abs(values[i]) < 0.5 * (values[1] - values[0])
    assert wrist[i] < SINGULAR_TOL
    # Away from the singular point it is far from 0: the minimum is isolated.
    assert np.all(wrist[np.abs(values) > 0.1] > 0.05)
    # The position block never comes near losing rank over the sweep: its smallest singular
    # value stays above 0.2 m/rad (the 0.21 m wrist-to-tool lever and the 0.4-0.44 m links).
    assert sweep.series("position").min() > 0.2
    # The refined minimiser is 0 to the golden-section tolerance.
    j6_star = EXERCISE.refine_minimum(
        lambda v: EXERCISE.blocks(arm7, with_j6(HOME, v)).wrist_orientation, -0.01, 0.01
    )
    assert abs(j6_star) < 1e-9


def test_j5_and_j7_are_the_collinear_axes_at_the_wrist_singularity(arm7):
    HOME = arm7.keyframe("home")
    q = with_j6(HOME, 0.0)
    assert EXERCISE.collinear_axes(arm7, q) == [("j5", "j7")]
    J = arm7.jacobian(q)
    c5, c7 = arm7.joint_index("j5"), arm7.joint_index("j7")
    assert np.max(np.abs(J[3:, c5] - J[3:, c7])) < SINGULAR_TOL
    # Their position columns vanish: the tool point is on their common axis.
    assert np.linalg.norm(J[:3, c5]) < SINGULAR_TOL
    assert np.linalg.norm(J[:3, c7]) < SINGULAR_TOL
    # The full 3 x 7 orientation block keeps rank 3: j1..j4 supply the lost rotation.
    assert linalg.jacobian_svd(J[3:]).rank == 3
    assert EXERCISE.collinear_axes(arm7, HOME) == []


@given(data=st.data(), j6=st.floats(0.05, 2.2) | st.floats(-2.2, -0.05))
def test_j5_j7_collinear_exactly_when_j6_is_zero(arm7, data, j6):
    q = data.draw(poses(arm7))
    singular, regular = with_j6(q, 0.0), with_j6(q, j6)
    assert ("j5", "j7") in EXERCISE.collinear_axes(arm7, singular)
    assert EXERCISE.blocks(arm7, singular).wrist_orientation < SINGULAR_TOL
    assert ("j5", "j7") not in EXERCISE.collinear_axes(arm7, regular)
    # sigma_min of the wrist block grows like |sin j6| / sqrt(2) near 0; 0.03 is below
    # sin(0.05) / sqrt(2) = 0.035, the smallest value the strategy allows.
    assert EXERCISE.blocks(arm7, regular).wrist_orientation > 0.03


# ------------------------------------------------------------------------------------------
# Self-motion: drift with and without the correction
# ------------------------------------------------------------------------------------------


def test_corrected_self_motion_keeps_the_tool_over_one_radian(arm7):
    HOME = arm7.keyframe("home")
    path = self_motion(arm7, HOME, total=1.0, step=0.01)
    assert path.stopped == ""
    assert path.total == pytest.approx(1.0, abs=1e-3)  # corrections shorten steps by O(h^2)
    assert path.max_position_drift < CORRECTED_DRIFT
    assert path.max_orientation_drift < CORRECTED_DRIFT
    # The arm did move: the elbow is lower by centimetres and j3 turned.
    assert path.elbow_height[0] - path.elbow_height[-1] > 0.01
    assert abs(path.q[-1][2] - HOME[2]) > 0.3


def drift(arm7, step: float, integrator: str, total: float = 1.0) -> float:
    HOME = arm7.keyframe("home")
    path = self_motion(arm7, HOME, total, step, correct=False, integrator=integrator)
    assert path.stopped == ""
    return float(path.position_drift[-1])


def test_uncorrected_drift_is_second_order_per_step(arm7):
    # One step of h moves the tool by O(h^2): halving h divides the drift by 4.
    ratio = drift(arm7, 0.02, "euler", total=0.02) / drift(arm7, 0.01, "euler", total=0.01)
    assert ratio == pytest.approx(4.0, rel=RATIO_TOL)


def test_uncorrected_euler_drift_over_one_radian_is_first_order(arm7):
    # 1/h steps of O(h^2) each: O(h) over the whole motion, halving h halves the drift.
    ratio = drift(arm7, 0.02, "euler") / drift(arm7, 0.01, "euler")
    assert ratio == pytest.approx(2.0, rel=RATIO_TOL)


def test_uncorrected_midpoint_drift_over_one_radian_is_second_order(arm7):
    ratio = drift(arm7, 0.02, "midpoint") / drift(arm7, 0.01, "midpoint")
    assert ratio == pytest.approx(4.0, rel=RATIO_TOL)


@given(data=st.data(), direction=st.sampled_from([1, -1]))
def test_corrected_self_motion_keeps_the_tool_from_any_regular_pose(arm7, data, direction):
    q = data.draw(poses(arm7, margin=0.3))
    assume(arm7.svd(q).sigma[-1] > 0.05)  # away from singular poses, where J^+ blows up
    path = self_motion(arm7, q, total=0.2, step=0.02, direction=direction)
    assert path.max_position_drift < CORRECTED_DRIFT
    assert path.max_orientation_drift < CORRECTED_DRIFT
    if not path.stopped:
        assert path.total == pytest.approx(0.2, abs=1e-3)


# ------------------------------------------------------------------------------------------
# Objectives and the contact escape
# ------------------------------------------------------------------------------------------


def asymmetric_start(arm7) -> np.ndarray:
    HOME = arm7.keyframe("home")
    # Home is mirror-symmetric, so every symmetric objective is stationary there.
    return self_motion(arm7, HOME, total=0.5, step=0.05).q[-1]


@pytest.mark.parametrize("make", [manipulability_objective, joint_limit_objective])
def test_objective_rises_along_the_self_motion_to_its_maximum(arm7, make):
    objective: Objective = make(arm7)
    path = self_motion(arm7, asymmetric_start(arm7), total=3.0, step=0.02, objective=objective)
    assert path.stopped == STOP_MAXIMUM
    assert path.objective[-1] > path.objective[0]
    assert path.max_position_drift < CORRECTED_DRIFT
    # At the stop, a further null-space step either way does not raise it by more than the
    # change over one step (the maximum lies within one step).
    basis = arm7.nullspace_basis(path.q[-1])[:, 0]
    best = max(objective(path.q[-1] + 0.02 * basis), objective(path.q[-1] - 0.02 * basis))
    assert best - path.objective[-1] < np.max(np.abs(np.diff(path.objective)))


# arm7's link2 is an ellipsoid flatter in x: with the upper arm rolled by less than about
# 0.9 rad the folded forearm meets it near the face's middle, where the self-motion cannot
# raise the clearance (measured: escapes fail for |j3| < 0.9 at 3 mm, succeed from 0.9 to 1.5).
@given(st.floats(0.9, 1.5), st.floats(0.5e-3, 3e-3))
def test_self_motion_escapes_a_link2_link4_contact_within_one_millimetre(arm7, roll, depth):
    q = CHALLENGE.contact_pose(arm7, roll, depth)
    result = CHALLENGE.escape(arm7, q, margin=1e-3, step=0.01)
    assert "link2 / link4" in result.start_contacts
    assert result.start_depth == pytest.approx(depth, abs=1e-9)  # bisection to 1e-12 rad
    assert not result.final_contacts
    assert no_contact(arm7)(result.path.q[-1])
    # Out of contact; up to the 1 mm margin unless the clearance peaks below it on the way.
    assert result.final_clearance > 0
    if result.path.stopped != STOP_MAXIMUM:
        assert result.final_clearance >= 1e-3
    assert np.isfinite(result.free_at) and result.free_at <= result.path.total
    assert result.tool_drift < ESCAPE_DRIFT
    assert result.tool_drift < CORRECTED_DRIFT  # what the correction actually achieves
    # The elbow angle is set by the shoulder-to-wrist distance: the self-motion keeps it.
    k4 = arm7.joint_index("j4")
    assert abs(result.path.q[-1][k4] - q[k4]) < 1e-9


def test_no_contact_predicate_for_one_pair(arm7):
    q = CHALLENGE.contact_pose(arm7, 0.6, 2e-3)
    assert not no_contact(arm7)(q)
    assert not no_contact(arm7, ("link4", "link2"))(q)
    assert no_contact(arm7, ("flange", "link1"))(q)


# ------------------------------------------------------------------------------------------
# Building blocks and errors
# ------------------------------------------------------------------------------------------


def rodrigues(w: np.ndarray) -> np.ndarray:
    angle = np.linalg.norm(w)
    if angle == 0:
        return np.eye(3)
    k = w / angle
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


unit = st.tuples(*[st.floats(-1, 1)] * 3).map(np.array).filter(lambda v: np.linalg.norm(v) > 0.1)


@given(unit, st.floats(0.0, np.pi))
def test_rotation_log_inverts_the_exponential(axis, angle):
    w = angle * axis / np.linalg.norm(axis)
    got = rotation_log(rodrigues(w))
    # At pi the axis sign is arbitrary (R is the same); elsewhere the log is unique. 1e-7 rad:
    # arccos near 0 and pi loses half the digits (sqrt(1e-16)), the branches avoid most of it.
    if np.pi - angle < 1e-6:
        assert min(np.linalg.norm(got - w), np.linalg.norm(got + w)) < 1e-7
    else:
        assert np.linalg.norm(got - w) < 1e-7


def test_bad_arguments_raise_library_errors(arm7):
    HOME = arm7.keyframe("home")
    with pytest.raises(
        rd.ParameterError, match=r"^step must be a finite number in \[1e-05, 1\] \[rad\], got 0.0$"
    ):
        self_motion(arm7, HOME, total=1.0, step=0.0)
    # An endless walk is refused up front: infinite total, or a step too small to finish.
    with pytest.raises(
        rd.ParameterError, match=r"^total must be a finite number > 0 \[rad\], got inf$"
    ):
        self_motion(arm7, HOME, total=float("inf"))
    with pytest.raises(rd.ParameterError, match=r"^step must be a finite number in \[1e-05, 1\]"):
        self_motion(arm7, HOME, total=1.0, step=1e-12)
    with pytest.raises(rd.RedundancyError, match="direction must be"):
        self_motion(arm7, HOME, direction=0)
    with pytest.raises(rd.UnknownNameError, match="valid integrator names"):
        self_motion(arm7, HOME, integrator="rk4")  # type: ignore[arg-type]
    with pytest.raises(rd.UnknownNameError, match="valid joint names"):
        self_motion(arm7, HOME, elbow="elbow")
    with pytest.raises(rd.PoseError):
        self_motion(arm7, HOME[:6])


def test_joint_limit_stops_the_motion(arm7):
    HOME = arm7.keyframe("home")
    q = HOME.copy()
    q[2] = arm7.upper[2] - 0.05  # j3 near its limit; the self-motion turns j3
    up = self_motion(arm7, q, total=2.0, step=0.02, direction=1)
    down = self_motion(arm7, q, total=2.0, step=0.02, direction=-1)
    stops = {up.stopped, down.stopped}
    assert any(s.startswith("joint limit") for s in stops)
    for path in (up, down):
        assert np.all(path.q <= arm7.upper + 1e-12) and np.all(path.q >= arm7.lower - 1e-12)


# ------------------------------------------------------------------------------------------
# The scripts run and write their plots
# ------------------------------------------------------------------------------------------


def test_exercise_script_writes_its_plot(tmp_path, capsys):
    assert EXERCISE.main(["--out", str(tmp_path), "--points", "45"]) == 0
    out = capsys.readouterr().out
    assert "collinear joint axes there: j5 and j7" in out
    assert (tmp_path / "wrist_singularity.png").stat().st_size > 10_000


def test_challenge_script_writes_its_plots(tmp_path, capsys):
    assert CHALLENGE.main(["--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "contacts at the end: none" in out
    for name in ("self_motion_drift.png", "self_motion_escape.png"):
        assert (tmp_path / name).stat().st_size > 10_000

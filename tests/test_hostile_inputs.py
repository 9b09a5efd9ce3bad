"""Issue 21: bad arguments get the library's errors, naming the argument and the valid range.

First the cases the hostile round found (exact messages), then a hypothesis sweep feeding
every public function NaN, inf, empty, wrong-shape and wrong-type arguments and allowing
only :class:`redundancy.RedundancyError` out.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import redundancy as rd
from redundancy import linalg
from redundancy.analysis import selfmotion as sm


def raises(match: str) -> pytest.RaisesContext[rd.ParameterError]:
    return pytest.raises(rd.ParameterError, match=re.escape(match))


# ==========================================================================================
# inertia.py: negative, NaN and infinite inputs
# ==========================================================================================


def test_inertia_helpers_refuse_negative_nan_and_inf() -> None:
    """They returned -0.44 s, -999.5, -1 and NaN."""
    pos = "a finite number (or array of them) > 0 [kg m^2]"
    nonneg = "a finite number (or array of them) >= 0"
    with raises(f"inertia must be {pos}, got -1.0"):
        rd.max_stable_timestep(-1.0, 10.0, 0.0)
    with raises(f"kd must be {nonneg} [N m s/rad], got nan"):
        rd.max_stable_timestep(1.0, float("nan"), 0.0)
    with raises(f"damping must be {nonneg} [N m s/rad], got inf"):
        rd.max_stable_timestep([1.0, 2.0], 5.0, [0.5, np.inf])
    with raises("timestep must be a finite number > 0 [s], got -0.001"):
        rd.max_stable_kd(1.0, -0.001, 0.5)
    with raises(f"damping must be {nonneg} [N m s/rad], got -1.0"):
        rd.max_stable_kd(1.0, 0.001, -1.0)
    with raises(f"rotor_inertia must be {nonneg} [kg m^2], got -1.0"):
        rd.reflected_inertia(-1.0, 10.0)
    with raises(f"gear_ratio must be {nonneg.replace(' >= 0', '')}, got nan"):
        rd.reflected_inertia(1e-5, float("nan"))
    with raises("gear_ratio must be a finite nonzero number (or array), got 0"):
        rd.rotor_inertia(0.1, 0)
    with raises("inertia, kd, damping must be arrays of shapes that broadcast together"):
        rd.max_stable_timestep([1.0, 2.0], [1.0, 2.0, 3.0], 0.0)
    with raises(f"kd must be {nonneg} [N m s/rad], got '10'"):
        rd.max_stable_timestep(1.0, "10", 0.0)
    # Valid input: the numbers as before.
    assert rd.max_stable_timestep(0.5, 11.0, 1.0) == pytest.approx(0.1)
    assert rd.max_stable_kd(0.5, 0.1, 1.0) == pytest.approx(11.0)
    np.testing.assert_allclose(rd.reflected_inertia(2e-5, [10, -100]), [2e-3, 0.2])


# ==========================================================================================
# linalg.py: singular, NaN, inf and empty matrices, bad damping
# ==========================================================================================

MATRIX = "a non-empty real array of finite numbers"


def test_damped_pinv_refuses_what_it_cannot_invert() -> None:
    with raises("damping must be > 0 for a rank-deficient J (singular values [0. 0. 0.]), got 0.0"):
        linalg.damped_pinv(np.zeros((3, 4)), 0.0)
    with raises("damping must be a finite number >= 0, got -0.1"):
        linalg.damped_pinv(np.eye(3), -0.1)
    with raises("damping must be a finite number >= 0, got inf"):
        linalg.damped_pinv(np.eye(3), float("inf"))
    nan = np.eye(3, 4)
    nan[1, 2] = np.nan
    with raises(f"J must be {MATRIX} with 2 dimensions, got nan at index (1, 2)"):
        linalg.damped_pinv(nan, 0.1)
    with raises(f"J must be {MATRIX} with 2 dimensions, got shape (0, 7)"):
        linalg.damped_pinv(np.zeros((0, 7)), 0.1)
    # A huge damping was an OverflowError; it is the limit, a zero inverse.
    np.testing.assert_array_equal(linalg.damped_pinv(np.eye(3), 1e300), np.zeros((3, 3)))
    J = np.arange(12.0).reshape(3, 4) + np.eye(3, 4)
    np.testing.assert_allclose(linalg.damped_pinv(J, 0.0), np.linalg.pinv(J), atol=1e-12)
    lam = 0.3
    direct = J.T @ np.linalg.inv(J @ J.T + lam**2 * np.eye(3))
    np.testing.assert_allclose(linalg.damped_pinv(J, lam), direct, atol=1e-12)


def test_dynamic_projector_refuses_singular_and_indefinite_matrices() -> None:
    J, M = np.eye(2, 3), np.diag([1.0, 2.0, 3.0])
    with raises(
        "M must be a symmetric positive definite matrix, got a matrix that is not positive definite"
    ):
        linalg.dynamic_nullspace_projector(J, -M)
    with raises(
        "M must be a symmetric positive definite matrix, got a matrix that is not symmetric"
    ):
        linalg.dynamic_nullspace_projector(J, M + np.triu(np.ones((3, 3)), 1))
    with raises(f"M must be {MATRIX} of shape (3, 3), got shape (2, 2)"):
        linalg.dynamic_nullspace_projector(J, np.eye(2))
    with raises("J must be of full row rank, got an array of shape (2, 3) and dtype float64"):
        linalg.dynamic_nullspace_projector(np.ones((2, 3)), M)
    with raises(f"M must be {MATRIX} of shape (3, 3), got inf at index (0, 0)"):
        linalg.dynamic_nullspace_projector(J, np.diag([np.inf, 2.0, 3.0]))
    N = linalg.dynamic_nullspace_projector(J, M)
    np.testing.assert_allclose(J @ N, 0.0, atol=1e-15)


def test_svd_helpers_refuse_nan_inf_empty_and_text() -> None:
    with raises(f"J must be {MATRIX} with 2 dimensions, got inf at index (0, 0)"):
        linalg.jacobian_svd(np.full((6, 7), np.inf))
    with raises(f"J must be {MATRIX} with 2 dimensions, got shape (0,)"):
        linalg.nullspace_basis([])
    with raises(f"J must be {MATRIX} with 2 dimensions, got 'abc'"):
        linalg.nullspace_projector("abc")  # type: ignore[arg-type]
    with raises(f"J must be {MATRIX} of shape (6, n), got shape (3, 7)"):
        linalg.manipulability(np.ones((3, 7)))
    with raises(f"dJ must be {MATRIX} of shape (7, 6, 7), got shape (6, 7)"):
        linalg.manipulability_gradient(np.eye(6, 7), np.eye(6, 7))
    with raises("atol must be a finite number > 0, got nan"):
        linalg.jacobian_svd(np.eye(6, 7)).lost_direction_names(float("nan"))


# ==========================================================================================
# selfmotion.py: objectives returning NaN or a non-number
# ==========================================================================================


def test_self_motion_blames_an_objective_that_returns_nan_or_text(arm7: rd.Arm) -> None:
    q = arm7.keyframe("home")
    blame = (
        "objective must be a function of q returning a finite real number, got one that returned"
    )
    with raises(f"{blame} nan at q = ["):
        sm.self_motion(arm7, q, 0.1, 0.01, objective=lambda q: float("nan"))
    with raises(f"{blame} 'high' at q = ["):
        sm.self_motion(arm7, q, 0.1, 0.01, objective=lambda q: "high")
    with raises(f"{blame} None at q = ["):
        sm.self_motion(arm7, q, 0.1, 0.01, objective=sm.Objective("none", lambda q: None))
    with raises(f"objective gradient must be {MATRIX} of shape (7,), got shape (3,)"):
        bad = sm.Objective("short gradient", lambda q: 1.0, lambda q: np.zeros(3))
        sm.self_motion(arm7, q, 0.1, 0.01, objective=bad)
    with raises("objective must be an Objective or a callable q -> float, got 5"):
        sm.self_motion(arm7, q, 0.1, 0.01, objective=5)  # type: ignore[arg-type]
    with raises("stop must be a callable q -> bool, or None, got 'now'"):
        sm.self_motion(arm7, q, 0.1, 0.01, stop="now")  # type: ignore[arg-type]
    # A plain objective still drives the motion.
    path = sm.self_motion(arm7, q, 0.05, 0.01, objective=sm.joint_limit_objective(arm7))
    assert len(path.objective) == len(path.q) and np.all(np.isfinite(path.objective))

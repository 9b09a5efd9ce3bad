"""Bad arguments get the library's errors, naming the argument and the valid range.

First the cases the hostile round found (exact messages), then a hypothesis sweep feeding
every public function NaN, inf, empty, wrong-shape and wrong-type arguments and allowing
only :class:`redundancy.RedundancyError` out.
"""

from __future__ import annotations

import re
import warnings

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


def test_inertia_helpers_take_huge_finite_values_to_their_limits_quietly() -> None:
    """Beyond 1e308 the bounds are inf and a rotor's share 0, without numpy's warnings."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # an overflow warning fails the test
        assert rd.reflected_inertia(1e300, 1e200) == np.inf
        assert rd.rotor_inertia(1.0, 1e200) == 0.0
        assert rd.max_stable_timestep(1e308, 1e-300, 0.0) == np.inf
        assert rd.max_stable_kd(1e308, 1e-300, 0.0) == np.inf


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


# ==========================================================================================
# Every public function, every argument: only the library's errors come out
# ==========================================================================================

import inspect  # noqa: E402
from collections.abc import Callable  # noqa: E402
from concurrent.futures import Executor, Future  # noqa: E402
from typing import Any  # noqa: E402

from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from hypothesis.extra import numpy as hnp  # noqa: E402

from redundancy import batch, collision, inertia  # noqa: E402

#: The arm every call is made on: three hinges, small and quick (tests.test_core).
from .test_core import SHORT_ARMS  # noqa: E402

ARM = SHORT_ARMS[3]
NQ = ARM.nq
Q0 = np.array([0.3, 0.4, 0.5])
QS = np.array([Q0, Q0 + 0.1])
J0 = ARM.jacobian(Q0)
M0 = ARM.mass_matrix(Q0)
P0, R0 = ARM.site_pose(Q0)
SVD = linalg.jacobian_svd(J0)
ARM7_PATH = str(rd.model_path("arm7"))
#: Seven joints, for what needs the tool's six directions (operational-space inertia).
ARM7 = rd.load(ARM7_PATH)
Q7 = np.array([0.1, 0.5, -0.2, -1.2, 0.3, 0.8, 0.1])
Q7S = np.array([Q7, Q7 + 0.05])
J7 = ARM7.jacobian(Q7)
X7 = np.linalg.solve(ARM7.mass_matrix(Q7), J7.T)  # M^-1 J^T
T7 = ARM7.site_pose(Q7 + 0.05)


def _signature_cases() -> dict[str, tuple[Callable[..., Any], dict[str, Any]]]:
    """Public function -> (callable, valid keyword arguments): each runs as given."""
    a = ARM
    return {
        # the package's own functions (rd.__all__)
        "rd.check_path": (
            rd.check_path,
            {"arm": a, "waypoints": QS, "tol": 1e-3, "engine": "coal"},
        ),
        "rd.collision_pairs": (rd.collision_pairs, {"model": a}),
        "rd.collision_statistics": (
            rd.collision_statistics,
            {
                "arm": a,
                "n_poses": 5,
                "seed": 1,
                "distances": "coal",
                "poses": None,
                "prune": True,
                "keyframes": True,
            },
        ),
        "rd.compare": (
            rd.compare,
            {
                "a": a,
                "b": a,
                "frame_a": None,
                "frame_b": None,
                "joint_map": None,
                "n_poses": 2,
                "seed": 0,
                "tol": 1e-9,
            },
        ),
        "rd.compare_models": (rd.compare_models, {"arm": a, "q": Q0, "tol": 1e-9}),
        "rd.crosscheck": (
            rd.crosscheck,
            {"arm": a, "poses": QS, "quantities": None, "tolerances": None, "seed": 0},
        ),
        "rd.crosscheck_batch": (
            rd.crosscheck_batch,
            {
                "arm": a,
                "Q": QS,
                "quantities": ["gravity"],
                "tolerances": None,
                "threads": 1,
                "chunk": 2048,
                "seed": 0,
            },
        ),
        "rd.load": (
            rd.load,
            {
                "path": ARM7_PATH,
                "frame": "ee",
                "strict": True,
                "site": None,
                "disabled_collisions": None,
            },
        ),
        "rd.load_string": (
            rd.load_string,
            {"xml": "<mujoco/>", "frame": "ee", "strict": True, "site": None},
        ),
        "rd.max_stable_kd": (rd.max_stable_kd, {"inertia": 1.0, "timestep": 0.002, "damping": 0.5}),
        "rd.max_stable_timestep": (
            rd.max_stable_timestep,
            {"inertia": 1.0, "kd": 5.0, "damping": 0.5},
        ),
        "rd.model_path": (rd.model_path, {"name": "arm7"}),
        "rd.reflected_inertia": (
            rd.reflected_inertia,
            {"rotor_inertia": 1e-5, "gear_ratio": 100.0},
        ),
        "rd.rotor_inertia": (rd.rotor_inertia, {"armature": 0.1, "gear_ratio": 100.0}),
        # Arm methods
        "Arm.armature": (a.armature, {"engine": "mujoco"}),
        "Arm.damping": (a.damping, {"engine": "mujoco"}),
        "Arm.engine": (a.engine, {"name": "mujoco"}),
        "Arm.gravity": (a.gravity, {"q": Q0, "engine": "pinocchio"}),
        "Arm.chain_pose": (a.chain_pose, {"q": Q0}),
        "Arm.coupling_jacobian": (a.coupling_jacobian, {"q": Q0}),
        "Arm.jacobian": (a.jacobian, {"q": Q0, "engine": "mujoco"}),
        "Arm.joint_index": (a.joint_index, {"name": "j1"}),
        "Arm.keyframe": (a.keyframe, {"name": "x"}),
        "Arm.keyframe_moves": (a.keyframe_moves, {"name": "x"}),
        "Arm.at_keyframe": (a.at_keyframe, {"name": "x"}),
        "Arm.manipulability": (a.manipulability, {"q": Q0, "length": 1.0, "engine": "mujoco"}),
        "Arm.manipulability_gradient": (a.manipulability_gradient, {"q": Q0, "engine": "mujoco"}),
        "Arm.mass_matrix": (a.mass_matrix, {"q": Q0, "armature": True, "engine": "mujoco"}),
        "Arm.nullspace_basis": (a.nullspace_basis, {"q": Q0, "engine": "mujoco"}),
        "Arm.nullspace_projector": (a.nullspace_projector, {"q": Q0, "engine": "mujoco"}),
        "Arm.pose": (a.pose, {"q": Q0, "check_range": True, "tol": 1e-9}),
        "Arm.site_pose": (a.site_pose, {"q": Q0, "engine": "pinocchio"}),
        "Arm.svd": (a.svd, {"q": Q0, "engine": "mujoco", "rtol": 1e-9}),
        # batch
        "batch.distances": (batch.distances, {"arm": a, "Q": QS, "engine": "coal", "threads": 1}),
        "batch.gravities": (
            batch.gravities,
            {"arm": a, "Q": QS, "engine": "pinocchio", "threads": 1},
        ),
        "batch.jacobians": (batch.jacobians, {"arm": a, "Q": QS, "engine": "mujoco", "threads": 1}),
        "batch.manipulabilities": (
            batch.manipulabilities,
            {"arm": a, "Q": QS, "engine": "mujoco", "kind": "scaled", "length": 1.0, "threads": 1},
        ),
        "batch.mass_matrices": (
            batch.mass_matrices,
            {"arm": a, "Q": QS, "armature": True, "engine": "mujoco", "threads": 1},
        ),
        "batch.singular_values": (
            batch.singular_values,
            {"arm": a, "Q": QS, "engine": "mujoco", "threads": 1},
        ),
        # linalg
        "linalg.damped_pinv": (linalg.damped_pinv, {"J": J0, "damping": 0.1}),
        "linalg.dynamic_nullspace_projector": (
            linalg.dynamic_nullspace_projector,
            {"J": J0[:3], "M": M0},
        ),
        "linalg.jacobian_svd": (linalg.jacobian_svd, {"J": J0, "rtol": 1e-9}),
        "linalg.motion_floor": (linalg.motion_floor, {"length": 1.25}),
        "linalg.manipulability": (linalg.manipulability, {"J": J0, "length": 1.0}),
        "linalg.manipulability_gradient": (
            linalg.manipulability_gradient,
            {"J": J0, "dJ": ARM.mujoco.jacobian_derivatives(Q0)},
        ),
        "linalg.nullspace_basis": (linalg.nullspace_basis, {"J": J0, "rtol": 1e-9}),
        "linalg.nullspace_projector": (linalg.nullspace_projector, {"J": J0, "rtol": 1e-9}),
        "linalg.yoshikawa": (linalg.yoshikawa, {"J": J0}),
        "JacobianSVD.lost_direction_names": (SVD.lost_direction_names, {"atol": 1e-6}),
        # inertia
        "inertia.rotor_inertia": (inertia.rotor_inertia, {"armature": 0.1, "gear_ratio": 10.0}),
        # selfmotion
        "selfmotion.self_motion": (
            sm.self_motion,
            {
                "arm": a,
                "q0": Q0,
                "total": 0.02,
                "step": 0.01,
                "direction": 1,
                "objective": None,
                "elbow": None,
                "engine": "mujoco",
                "stop": None,
                "integrator": "euler",
                "tol": 1e-12,
                "max_corrections": 5,
                "fd_step": 1e-4,
            },
        ),
        "selfmotion.pose_error": (
            sm.pose_error,
            {"arm": a, "q": Q0, "p0": P0, "R0": R0, "engine": "mujoco"},
        ),
        "selfmotion.rotation_log": (sm.rotation_log, {"R": R0}),
        "selfmotion.manipulability_objective": (
            sm.manipulability_objective,
            {"arm": a, "engine": "mujoco"},
        ),
        "selfmotion.joint_limit_objective": (sm.joint_limit_objective, {"arm": a}),
        "selfmotion.collision_objective": (sm.collision_objective, {"arm": a, "engine": "mujoco"}),
        "selfmotion.no_contact": (sm.no_contact, {"arm": a, "pair": None}),
        # collision
        "collision.checker": (collision.checker, {"arm": a}),
        "collision.contacts": (collision.contacts, {"arm": a, "q": Q0}),
        "collision.distances": (collision.distances, {"arm": a, "q": Q0, "engine": "coal"}),
        "collision.keyframe_clearance": (
            collision.keyframe_clearance,
            {"arm": a, "engine": "coal"},
        ),
        "collision.random_poses": (collision.random_poses, {"arm": a, "n": 3, "seed": 1}),
        "collision.sampling_ranges": (
            collision.sampling_ranges,
            {"arm": a, "unlimited": np.pi, "unlimited_slide": None},
        ),
        "collision.distance_stack": (
            collision.distance_stack,
            {"ch": collision.checker(ARM7), "Q": Q7S, "engine": "coal", "threads": 1},
        ),
        "collision.find_pair": (
            collision.find_pair,
            {"pairs": collision.collision_pairs(ARM7), "name1": "link1", "name2": "link4"},
        ),
        "rd.example_robot_data": (
            rd.example_robot_data,
            {"path": "ur_description/urdf/ur5_robot.urdf"},
        ),
        # inverse kinematics and the mass a contact feels
        **_contact_cases(),
        # motion: the Coriolis matrix, the centre of mass and momentum, the observer
        **_motion_cases(),
        # the executor plumbing of the batch functions
        "batch.map_chunks": (
            batch.map_chunks,
            {"executor": _Inline(), "fn": batch.jacobians, "arm": a, "Q": QS, "chunk": None},
        ),
        "batch.scatter": (
            batch.scatter,
            {"executor": _Inline(), "fn": batch.jacobians, "arm": a, "Q": QS},
        ),
    }


class _Inline(Executor):
    """An executor that runs each call at once, in the caller's thread."""

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future[Any]:
        future: Future[Any] = Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as err:
            future.set_exception(err)
        return future


def _contact_cases() -> dict[str, tuple[Callable[..., Any], dict[str, Any]]]:
    """The operational-space inertia, effective mass and IK functions, on arm7."""
    a = ARM7
    dyn = {"armature": True, "joints": None, "engine": "mujoco"}
    stack = {"arm": a, "Q": Q7S, **dyn, "threads": 1, "executor": None}
    ik = {
        "objective": None,
        "position_only": False,
        "position_tol": 1e-6,
        "orientation_tol": 1e-6,
        "restarts": 2,
        "seed": 0,
        "engine": "mujoco",
    }
    up = np.array([0.0, 0.0, 1.0])
    return {
        "Arm.operational_inertia": (a.operational_inertia, {"q": Q7, **dyn}),
        "Arm.effective_mass": (a.effective_mass, {"q": Q7, "direction": up, **dyn}),
        "Arm.effective_mass_range": (a.effective_mass_range, {"q": Q7, **dyn}),
        "Arm.dynamic_manipulability": (a.dynamic_manipulability, {"q": Q7, **dyn}),
        "Arm.solve_ik": (a.solve_ik, {"target": T7, "q0": Q7, **ik}),
        "Arm.ik_objective": (a.ik_objective, {"objective": "joint_limits", "engine": "mujoco"}),
        "batch.solve_ik": (
            batch.solve_ik,
            {"arm": a, "targets": [T7, T7], "Q0": None, **ik, "threads": 1},
        ),
        "batch.operational_inertias": (batch.operational_inertias, stack),
        "batch.effective_masses": (batch.effective_masses, {**stack, "direction": up}),
        "batch.effective_mass_ranges": (batch.effective_mass_ranges, stack),
        "batch.dynamic_manipulabilities": (batch.dynamic_manipulabilities, stack),
        "batch.poses": (batch.poses, {"arm": a, "Q": Q7S}),
        "linalg.operational_inertia": (
            linalg.operational_inertia,
            {"J": J7, "X": X7, "rtol": 1e-9},
        ),
        "linalg.effective_mass": (linalg.effective_mass, {"J": J7, "X": X7, "u": up, "rtol": 1e-9}),
        "linalg.effective_mass_range": (
            linalg.effective_mass_range,
            {"J": J7, "X": X7, "rtol": 1e-9},
        ),
        "linalg.effective_mass_ranges": (
            linalg.effective_mass_ranges,
            {"J": J7[None], "X": X7[None], "rtol": 1e-9},
        ),
        "linalg.effective_masses": (
            linalg.effective_masses,
            {"J": J7[None], "X": X7[None], "U": up[None], "rtol": 1e-9},
        ),
        "linalg.dynamic_manipulability": (linalg.dynamic_manipulability, {"X": X7}),
        "linalg.manipulability_rows": (
            linalg.manipulability_rows,
            {"J": J7, "kind": "scaled", "length": 1.0},
        ),
        "linalg.mobility": (linalg.mobility, {"J": J7, "X": X7}),
    }


def _motion_cases() -> dict[str, tuple[Callable[..., Any], dict[str, Any]]]:
    """The Coriolis matrix, the whole robot's centre of mass and momentum, the observer."""
    a, v, e = ARM, np.array([0.2, -0.1, 0.3]), {"engine": "mujoco"}
    states = {"arm": a, "Q": QS, "V": QS}
    return {
        "Arm.coriolis": (a.coriolis, {"q": Q0, "v": v, **e}),
        "Arm.mass_matrix_derivative": (a.mass_matrix_derivative, {"q": Q0, "v": v, **e}),
        "Arm.com": (a.com, {"q": Q0, **e}),
        "Arm.com_jacobian": (a.com_jacobian, {"q": Q0, **e}),
        "Arm.centroidal_momentum_matrix": (a.centroidal_momentum_matrix, {"q": Q0, **e}),
        "batch.coriolis": (
            batch.coriolis,
            {**states, **e, "threads": 1, "executor": None},
        ),
        "batch.external_torques": (
            batch.external_torques,
            {**states, "TAU": QS, "dt": 0.01, "gain": 10.0, "executor": None},
        ),
        "rd.MomentumObserver": (rd.MomentumObserver, {"arm": a, "gain": 10.0}),
        "MomentumObserver.update": (
            rd.MomentumObserver(a, 10.0).update,
            {"q": Q0, "v": v, "tau": v, "dt": 0.01},
        ),
    }


CASES = _signature_cases()
ARGUMENTS = [(name, arg) for name, (_, kwargs) in CASES.items() for arg in kwargs]

#: What a new user passes by mistake: NaN, infinities, empty and wrong-shape arrays, text,
#: None, other types.
HOSTILE: list[Any] = [
    float("nan"),
    float("inf"),
    -float("inf"),
    -1,
    0,
    1e308,
    True,
    None,
    "x",
    "1e-3",
    b"<mujoco/>",
    [],
    {},
    np.zeros(0),
    np.zeros((0, NQ)),
    np.zeros((2, 3, 4)),
    np.full(NQ, np.nan),
    np.full((2, NQ), np.inf),
    np.ones(NQ + 1),
    np.ones(NQ) * 1j,
    np.array(["a"] * NQ),
    [[1.0, 2.0], [3.0]],
    object(),
    lambda q: "not a number",
]


def call_hostile(name: str, arg: str, value: Any) -> None:
    """Call ``name`` with ``arg`` replaced by ``value``: a result or a RedundancyError."""
    fn, kwargs = CASES[name]
    with warnings.catch_warnings():
        if arg == "site":  # the deprecated name of frame=: checked too, its warning expected
            warnings.simplefilter("ignore", DeprecationWarning)
        try:
            fn(**{**kwargs, arg: value})
        except rd.RedundancyError:
            pass


def _public_functions() -> dict[str, Callable[..., Any]]:
    """Every public function of the package: its top level, Arm's methods and the modules
    a user imports (by their own definitions, not the names they import)."""
    found: dict[str, Callable[..., Any]] = {}

    def add(module: Any, prefix: str, names: list[str] | None = None) -> None:
        own = names is None
        for n in names if names is not None else dir(module):
            f = getattr(module, n, None)
            if n.startswith("_") or not inspect.isfunction(f):
                continue
            if not own or f.__module__ == module.__name__:
                found[f"{prefix}.{n}"] = f

    add(rd, "rd", list(rd.__all__))
    found.update(
        {f"Arm.{n}": f for n, f in inspect.getmembers(rd.Arm, inspect.isfunction) if n[0] != "_"}
    )
    for module, prefix in ((batch, "batch"), (linalg, "linalg"), (inertia, "inertia")):
        add(module, prefix)
    add(sm, "selfmotion")
    add(collision, "collision", list(collision.__all__))
    return found


def test_every_public_function_is_in_the_sweep() -> None:
    """A public function added without a case here fails: its inputs are not yet shown to be
    validated."""
    swept = {getattr(f, "__func__", f) for f, _ in CASES.values()}
    found = _public_functions()
    assert len(found) > 80
    assert [name for name, f in found.items() if f not in swept] == []


def test_every_case_runs_as_given() -> None:
    """The valid arguments are valid: each case's call returns (or raises only the library's
    error where the case is a lookup of a missing name)."""
    for name, (fn, kwargs) in CASES.items():
        if name in ("rd.load_string", "Arm.keyframe", "Arm.keyframe_moves", "Arm.at_keyframe"):
            with pytest.raises(rd.RedundancyError):
                fn(**kwargs)
        else:
            fn(**kwargs)


@pytest.mark.parametrize(("name", "arg"), ARGUMENTS, ids=[f"{n}:{a}" for n, a in ARGUMENTS])
def test_each_argument_refuses_nonsense_with_the_librarys_error(name: str, arg: str) -> None:
    for value in HOSTILE:
        try:
            call_hostile(name, arg, value)
        except Exception as err:  # what is asserted: nothing but a RedundancyError
            pytest.fail(f"{name}({arg}={value!r}): {type(err).__name__}: {err}")


@settings(max_examples=200, deadline=None)
@given(
    case=st.sampled_from(ARGUMENTS),
    value=st.one_of(
        hnp.arrays(
            dtype=st.sampled_from([np.float64, np.float32, np.int64, np.complex128, np.bool_]),
            shape=hnp.array_shapes(min_dims=0, max_dims=4, min_side=0, max_side=7),
        ),
        hnp.arrays(np.float64, st.sampled_from([(NQ,), (2, NQ), (6, NQ), (NQ, NQ), (3, 3)])),
        st.floats(),
        # Small integers: a huge count is a valid request for a huge amount of work.
        st.integers(-10, 50),
        st.text(max_size=5),
        st.none(),
        st.lists(st.floats(), max_size=5),
    ),
)
def test_random_nonsense_gets_only_the_librarys_errors(case: tuple[str, str], value: Any) -> None:
    """Hypothesis draws the argument and the value (derandomized in CI: the default profile)."""
    name, arg = case
    try:
        call_hostile(name, arg, value)
    except Exception as err:
        pytest.fail(f"{name}({arg}={value!r}): {type(err).__name__}: {err}")


def test_more_random_poses_than_memory_holds_is_the_librarys_error(arm7: rd.Arm) -> None:
    """numpy's MemoryError (497 PiB: more than any address space, whatever the overcommit
    policy) and its ValueError (more bytes than an address can count) escaped."""
    for n, size in ((10**16, "5.6e+17"), (10**18, "5.6e+19")):
        with raises(
            f"n must be a count of poses that fits in memory ({n} x 7 float64: {size} bytes), "
            f"got {n}"
        ):
            rd.random_poses(arm7, n)


def test_huge_finite_matrices_are_valid_and_quiet() -> None:
    """The fast path of the matrix check must not mistake huge finite values for inf (nor
    warn of an overflow): 1e308 is a finite number."""
    from redundancy.checks import check_matrix

    J = np.full((6, 3), 1e308)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert check_matrix("J", J, (6, None)) is J
    with raises(f"J must be {MATRIX} with 2 dimensions, got nan at index (0, 1)"):
        check_matrix("J", np.array([[1.0, np.nan]]))
    with raises(f"J must be {MATRIX} of shape (6, n), got inf at index (2, 0)"):
        check_matrix("J", np.where(np.arange(18).reshape(6, 3) == 6, np.inf, 1.0), (6, None))

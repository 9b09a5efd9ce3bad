"""redundancy: analysis of redundant (7-DOF) arms, every number from MuJoCo and Pinocchio.

Example:
    >>> import redundancy as rd
    >>> arm = rd.load(rd.model_path("arm7"), frame="ee")
    >>> arm.svd(arm.keyframe("zero")).rank
    3
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError
from importlib.metadata import version as _version

from . import collision, engines
from .analysis import batch, selfmotion
from .analysis.compare import Comparison, compare
from .analysis.crosscheck import (
    TOLERANCES,
    Agreement,
    CrossCheckReport,
    crosscheck,
    crosscheck_batch,
)
from .analysis.observer import MomentumObserver
from .arm import Arm, random_poses
from .arm_mass import ToolMassOptions
from .collision import (
    CollisionChecker,
    check_path,
    collision_pairs,
    collision_statistics,
    pathcheck,
)
from .errors import (
    MissingDependencyError,
    MissingInertiaError,
    MissingMeshError,
    ModelError,
    OutOfRangeError,
    ParameterError,
    PoseError,
    RedundancyError,
    SingularPoseError,
    UnknownNameError,
    UnsupportedFeatureError,
)
from .ik import IKResult
from .inertia import max_stable_kd, max_stable_timestep, reflected_inertia, rotor_inertia
from .linalg import EffectiveMassRange, JacobianSVD, Manipulability
from .model.bridges import Bridge
from .model.equivalence import Difference, EquivalenceReport, compare_models
from .model.loading import LoadOptions, load, load_string
from .models import example_robot_data, model_path

try:  # the installed distribution's version: one number, in pyproject.toml
    __version__: str = _version("redundancy")
except PackageNotFoundError:  # pragma: no cover - a source tree on sys.path, not installed
    __version__ = "0+unknown"

__all__ = [
    "TOLERANCES",
    "Agreement",
    "Arm",
    "Bridge",
    "CollisionChecker",
    "Comparison",
    "CrossCheckReport",
    "Difference",
    "EffectiveMassRange",
    "EquivalenceReport",
    "IKResult",
    "JacobianSVD",
    "LoadOptions",
    "Manipulability",
    "MissingDependencyError",
    "MissingInertiaError",
    "MissingMeshError",
    "ModelError",
    "MomentumObserver",
    "OutOfRangeError",
    "ParameterError",
    "PoseError",
    "RedundancyError",
    "SingularPoseError",
    "ToolMassOptions",
    "UnknownNameError",
    "UnsupportedFeatureError",
    "__version__",
    "batch",
    "check_path",
    "collision",
    "collision_pairs",
    "collision_statistics",
    "compare",
    "compare_models",
    "crosscheck",
    "crosscheck_batch",
    "engines",
    "example_robot_data",
    "load",
    "load_string",
    "max_stable_kd",
    "max_stable_timestep",
    "model_path",
    "pathcheck",
    "random_poses",
    "reflected_inertia",
    "rotor_inertia",
    "selfmotion",
]

"""Self-collision under MuJoCo's contact rules, with distances from coal and from MuJoCo.

* `pairs`: the geom pairs MuJoCo tests;
* `checker`: distances and contacts at one pose, from both engines;
* `statistics`: statistics over random poses, keyframe clearance;
* `pathcheck`: conservative checking of a straight joint path.

Only this package calls coal.
"""

from __future__ import annotations

from ..arm import random_poses, sampling_ranges
from .checker import (
    DISTANCE_ENGINES,
    CollisionChecker,
    Contact,
    DistanceEngine,
    Distances,
    PairDistance,
    checker,
    contacts,
    distances,
)
from .pairs import AMBIGUITY_BAND, GeomPair, collision_pairs, find_pair
from .pathcheck import PathCheck, PathChecker, check_path
from .stacks import distance_stack
from .statistics import (
    CollisionStatistics,
    KeyframeClearance,
    PairStatistics,
    collision_statistics,
    keyframe_clearance,
)

__all__ = [
    "AMBIGUITY_BAND",
    "DISTANCE_ENGINES",
    "CollisionChecker",
    "CollisionStatistics",
    "Contact",
    "DistanceEngine",
    "Distances",
    "GeomPair",
    "KeyframeClearance",
    "PairDistance",
    "PairStatistics",
    "PathCheck",
    "PathChecker",
    "check_path",
    "checker",
    "collision_pairs",
    "collision_statistics",
    "contacts",
    "distance_stack",
    "distances",
    "find_pair",
    "keyframe_clearance",
    "random_poses",
    "sampling_ranges",
]

"""Is a joint-space path free of self-collision? Conservative advancement, never sampling.

A path is a list of waypoints joined by straight joint-space segments
``q(s) = q_a + s (q_b - q_a)``, ``s`` in [0, 1]. Checking a few samples can step over a
contact; this module instead takes steps that provably cannot.

**Only relative motion counts.** The distance between geoms ``g1`` (on body ``b1``) and
``g2`` (on ``b2``) does not change when both move rigidly together, so it depends only on
the joints between the two bodies: with ``J(b)`` the joints from the root down to ``b``,
the joints in ``J(b1) - J(b2)`` and ``J(b2) - J(b1)``. Seen from the last body the two
share, a point ``p`` of ``g1`` moves at speed ``|sum_j J_j(p) qdot_j|`` over the joints in
``J(b1) - J(b2)``, where ``|J_j(p)| = |axis_j x (p - a_j)|`` for a hinge (``a_j`` its
anchor), at most ``|p - a_j|``, and ``|J_j(p)| = 1`` for a slide.

**The reach bound.** ``|p - a_j|`` is bounded over every configuration by walking the chain
of anchors from ``j`` down to the geom: two consecutive hinge anchors keep their distance
whatever the joints do (a hinge's anchor is fixed in its parent's frame as well as in its own
body's, so both anchors are fixed in one rigid group), a slide in the chain adds its travel,
and the last anchor is rigidly attached to the geom, whose points lie within its bounding
radius of its centre: ``R_j(g) = sum |a_{k+1} - a_k| + travel + |c_g - a_last| + rbound_g``.
On the joint's own body the distance of the centre to the axis line plus the bounding radius
is used instead (it is constant there). So a straight step ``ds`` changes the pair's distance
by at most ``ds * sum_j w_j |q_b,j - q_a,j|``, with ``w_j = R_j(g1)`` for ``j`` in
``J(b1) - J(b2)``, ``R_j(g2)`` for ``j`` in ``J(b2) - J(b1)``, 0 for the shared joints.

**The step.** At ``s``, with every pair's clearance ``c_p`` (distance minus contact threshold) known
to within ``eps`` (the engines' accuracy, `AMBIGUITY_BAND`), no pair can reach contact before ``s +
min_p (c_p - eps) / rate_p``; the checker jumps there. It stops at the first evaluated point whose
smallest clearance is below ``tol``: everything before it is free. Since every step is at least
``(tol - eps) / max rate``, it always terminates. If that point is a near miss rather than a
contact, the checker walks on in steps that move no geom by more than ``tol`` to report the contact
that usually follows; either way the path is not declared free (it errs on the side of reporting).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..arm import check_arm
from ..arm_coupled import ChainView
from ..caching import PerObject
from ..checks import check_choice, check_count, check_in_range, check_number, check_poses
from ..errors import PoseError, UnsupportedFeatureError
from .checker import CollisionChecker, checker
from .pairs import AMBIGUITY_BAND, DISTANCE_ENGINES, DistanceEngine, GeomPair, NearPair
from .shapes import bounding_radius

if TYPE_CHECKING:
    from ..arm import Arm
    from .coal_scene import CoalScene
    from .mujoco_scene import MujocoScene

Array = NDArray[np.float64]

#: Default clearance below which a path point is reported [m]: 10 um, ten times the
#: engines' accuracy, so that steps stay long enough near grazing contacts.
DEFAULT_TOL = 1e-5
#: Steps the checker walks past a near miss looking for the contact that follows [-].
NEAR_MISS_WALK = 1000


# ==========================================================================================
# Motion bounds from the kinematic chain (MuJoCo's compiled model, at qpos0)
# ==========================================================================================


def _joint_chain(model: mujoco.MjModel, body: int) -> list[int]:
    """Joints from the root down to ``body`` (inclusive), root first."""
    chain: list[int] = []
    b = body
    while b > 0:
        adr, num = int(model.body_jntadr[b]), int(model.body_jntnum[b])
        chain[:0] = list(range(adr, adr + num))
        b = int(model.body_parentid[b])
    return chain


def _travel(model: mujoco.MjModel, j: int) -> float:
    """Largest displacement of a slide joint from its reference position qpos0 [m]."""
    q0 = float(model.qpos0[model.jnt_qposadr[j]])
    if not model.jnt_limited[j]:
        return float("inf")
    lo, hi = model.jnt_range[j]
    return float(max(abs(hi - q0), abs(lo - q0)))


def reach_bounds(model: mujoco.MjModel, geom: int) -> dict[int, float]:
    """For every joint moving ``geom``: how fast a point of the geom can move per unit of it.

    For a hinge, a bound on the distance from any point of the geom to the joint's axis,
    valid at every configuration [m/rad]: the distance to the anchor through the chain (see
    the module docstring), or, on the joint's own rigid body, the distance to the axis line
    itself. For a slide, 1 [m/m]. Keys are joint ids.

    Raises:
        UnsupportedFeatureError: Ball or free joints on the chain (not bounded here).
    """
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0
    # mj_kinematics at the reference pose gives the anchors (xanchor) and geom centres; the
    # distances read from them are the pose-independent lengths of the chain.
    mujoco.mj_kinematics(model, data)
    chain = _joint_chain(model, int(model.geom_bodyid[geom]))
    out: dict[int, float] = {}
    centre = data.geom_xpos[geom]
    tail = bounding_radius(model, geom)
    reach_prev = 0.0
    for i in range(len(chain) - 1, -1, -1):
        j = chain[i]
        kind = int(model.jnt_type[j])
        if kind not in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
            raise UnsupportedFeatureError(
                "ball or free joint",
                f"joint #{j}",
                "path checking bounds hinge and slide chains only",
            )
        if i == len(chain) - 1:
            # The geom is rigid with this joint's body: its points' distance to the axis
            # line is fixed, at most the centre's distance plus the bounding radius.
            r = centre - data.xanchor[j]
            reach = float(np.linalg.norm(r)) + tail
            speed = float(np.linalg.norm(np.cross(data.xaxis[j], r))) + tail
        else:
            nxt = chain[i + 1]
            link = float(np.linalg.norm(data.xanchor[nxt] - data.xanchor[j]))
            if model.jnt_type[nxt] == mujoco.mjtJoint.mjJNT_SLIDE:
                link += _travel(model, nxt)
            reach = speed = link + reach_prev
        out[j] = 1.0 if kind == mujoco.mjtJoint.mjJNT_SLIDE else speed
        reach_prev = reach
    return out


def motion_weights(model: mujoco.MjModel, pairs: tuple[GeomPair, ...]) -> Array:
    """Per pair, per dof: how fast the pair's distance can shrink per unit joint motion.

    Row ``p`` gives ``w`` such that a straight joint step ``dq`` changes pair ``p``'s distance
    by at most ``w @ |dq|`` [m per rad or m per m]. Joints upstream of both geoms get 0.

    Raises:
        UnsupportedFeatureError: A plane that moves relative to the geom it is paired with
            (a plane has no bounding radius).
    """
    W = np.zeros((len(pairs), model.nv))
    cache: dict[int, dict[int, float]] = {}
    for k, p in enumerate(pairs):
        for g in (p.geom1, p.geom2):
            if g not in cache:
                cache[g] = reach_bounds(model, g)
        j1 = set(_joint_chain(model, int(model.geom_bodyid[p.geom1])))
        j2 = set(_joint_chain(model, int(model.geom_bodyid[p.geom2])))
        for g, own, other in ((p.geom1, j1, j2), (p.geom2, j2, j1)):
            for j in own - other:
                w = cache[g][j]
                if not np.isfinite(w):
                    raise UnsupportedFeatureError(
                        "unbounded geom motion",
                        f"pair {p.label}",
                        "a moving plane or an unlimited slide has no motion bound",
                    )
                W[k, model.jnt_dofadr[j]] += w
    return W


# ==========================================================================================
# The path checker
# ==========================================================================================


@dataclass(frozen=True)
class PathContact(NearPair):
    """Where a path first meets a contact (or comes within ``tol`` of one).

    Attributes:
        segment: Index of the segment (from waypoint ``segment`` to ``segment + 1``; 0 for
            a path of a single waypoint).
        s: Fraction along the segment of the reported point, in [0, 1].
        q: The pose there [rad or m].
        pair: The pair with the smallest clearance there.
        distance: Its signed distance there [m].
        clear_until: Fraction along the segment before which the path is proven free: the
            first point found within ``tol`` of contact (``clear_until <= s``).
    """

    segment: int
    s: float
    q: Array
    pair: GeomPair
    distance: float
    clear_until: float


@dataclass(frozen=True)
class PathCheck:
    """Result of [`check_path`][redundancy.check_path].

    Attributes:
        free: True when no point of any segment comes within ``tol`` of a contact.
        contact: The first contact, or near miss if no contact follows it closely (None when
            free).
        evaluations: Poses at which all pair distances were computed.
        segments: Number of segments checked (waypoints - 1).
        tol: Clearance below which a point is reported [m].
        engine: Distance engine used.
        min_clearance: Smallest clearance over the evaluated poses [m].
    """

    free: bool
    contact: PathContact | None
    evaluations: int
    segments: int
    tol: float
    engine: str
    min_clearance: float

    def __str__(self) -> str:
        if self.free:
            return (
                f"free: {self.segments} segments, {self.evaluations} distance evaluations, "
                f"smallest clearance {self.min_clearance:.4g} m"
            )
        c = self.contact
        assert c is not None
        what = "contact" if c.touching else f"near miss (within {self.tol:g} m)"
        return (
            f"{what} {c.pair.label} at segment {c.segment}, s = {c.s:.4f} "
            f"(distance {c.distance:.4g} m), after {self.evaluations} distance evaluations"
        )


class PathChecker:
    """Conservative-advancement path checker for one arm (see the module docstring).

    Args:
        arm: The arm, or a [`CollisionChecker`][redundancy.CollisionChecker] of it (whose pair set
            is then used).

    Attributes:
        weights: Per pair, per dof, the bound on how fast the pair's distance shrinks per unit joint
            motion, shape (npairs, nq) [m/rad or m/m] (see `motion_weights`).
    """

    def __init__(self, arm: Arm | CollisionChecker) -> None:
        self.checker: CollisionChecker = arm if isinstance(arm, CollisionChecker) else checker(arm)
        self.pairs: tuple[GeomPair, ...] = self.checker.pairs
        self.weights: Array = motion_weights(self.arm.mj_model, self.pairs)
        self.thresholds: Array = np.array([p.threshold for p in self.pairs])

    @property
    def arm(self) -> Arm:
        """The arm (held by the collision checker, weakly when cached)."""
        return self.checker.arm

    def check(
        self,
        waypoints: ArrayLike,
        tol: float = DEFAULT_TOL,
        engine: DistanceEngine = "coal",
        max_evaluations: int = 1_000_000,
    ) -> PathCheck:
        """Check the straight joint-space segments between consecutive waypoints.

        The segments are advanced by provably safe steps until a point comes within ``tol``
        of contact (everything before it is free). If that point is a near miss, the
        checker then walks on in steps that move no geom by more than ``tol``, to report
        the contact that usually follows; if none follows before the clearance exceeds
        ``tol`` again, the near miss itself is reported. Either way the path is not free.

        Args:
            waypoints: Shape (k, nq), k >= 1 [rad or m].
            tol: A point whose clearance is below this is reported [m]; must exceed the engines'
                accuracy, `AMBIGUITY_BAND`.
            engine: Distance engine, ``"coal"`` (fast) or ``"mujoco"``.
            max_evaluations: Give up (PoseError) after this many distance evaluations.

        Raises:
            PoseError: Bad waypoints, or the evaluation budget exhausted.
            OutOfRangeError: A waypoint outside a joint's range (the message names both).
            ParameterError: ``tol`` not a number above the engines' accuracy, or
                ``max_evaluations`` not a positive integer.
        """
        Q, X, tol, max_evaluations = self._validated(waypoints, tol, engine, max_evaluations)
        eps = AMBIGUITY_BAND
        nseg = len(Q) - 1
        thr = self.thresholds
        # The waypoints are validated and every pose below is made from them: this thread's
        # scene is called directly, without validating each evaluated pose again.
        clearance = _Clearance(self.checker.scene(engine), thr, max_evaluations)

        def report(seg: int, s0: float, c: Array, rate: Array) -> PathCheck:
            end = min(seg + 1, len(Q) - 1)
            c, s = _walk_on(clearance, X[seg], X[end], c, s0, tol, rate)
            k = int(np.argmin(c))
            q = Q[seg] + s * (Q[end] - Q[seg])
            contact = PathContact(seg, s, q, self.pairs[k], float(c[k] + thr[k]), s0)
            evals, least = clearance.evals, float(clearance.least)
            return PathCheck(False, contact, evals, nseg, tol, engine, least)

        if not self.pairs:
            return PathCheck(True, None, 0, nseg, tol, engine, float("inf"))
        c = clearance(X[0])
        if c.min() < tol:
            dq0 = X[1] - X[0] if len(X) > 1 else np.zeros(X.shape[1])
            return report(0, 0.0, c, self.weights @ np.abs(dq0))
        for seg in range(len(X) - 1):
            qa, qb = X[seg], X[seg + 1]
            dq = qb - qa
            # Largest rate at which each pair's distance can shrink per unit s [m].
            rate = self.weights @ np.abs(dq)
            moving = rate > 0
            s = 0.0
            while s < 1.0:
                if not moving.any():
                    s = 1.0
                else:
                    # No pair can lose more than its clearance (less the engines' error)
                    # before s + step: the largest step that cannot skip a contact.
                    with np.errstate(over="ignore"):  # a subnormal rate: the step is inf
                        step = float(np.min((c[moving] - eps) / rate[moving]))
                    s = min(1.0, s + step)
                c = clearance(qa + s * dq if s < 1.0 else qb)
                if c.min() < tol:
                    return report(seg, s, c, rate)
        return PathCheck(True, None, clearance.evals, nseg, tol, engine, float(clearance.least))

    def _validated(
        self, waypoints: ArrayLike, tol: float, engine: DistanceEngine, max_evaluations: int
    ) -> tuple[Array, Array, float, int]:
        """The waypoints, ``tol`` and ``max_evaluations`` of `check`, checked.

        Returns the waypoints, what the scenes place for them (a linear coupling's chain
        poses, whose joints move on straight segments too; else the waypoints), ``tol`` and
        ``max_evaluations``.
        """
        check_choice("distance engine", engine, DISTANCE_ENGINES)
        # tol must exceed the engines' accuracy, or the safe steps could shrink to nothing.
        tol = check_number("tol", tol, AMBIGUITY_BAND, low_open=True, unit="m")
        max_evaluations = check_count("max_evaluations", max_evaluations, 1)
        arm = self.arm
        Q = check_poses(waypoints, arm.joint_names)
        if not len(Q):
            raise PoseError(f"waypoints must have shape (k, {arm.nq}) with k >= 1, got (0,)")
        # The motion bounds assume every joint within its range (a slide's travel is part of
        # the reach of the links beyond it): a path outside the ranges is not covered.
        check_in_range(Q, arm.joint_names, arm.lower, arm.upper, "waypoint")
        if arm.coupling is not None:
            _check_linear(arm)
        X = self.checker.scene_poses(Q)
        if arm.coupling is not None:  # the followers' ranges too
            chain = ChainView(arm)
            check_in_range(X, chain.joint_names, chain.lower, chain.upper, "waypoint")
        return Q, X, tol, max_evaluations


class _Clearance:
    """Each pair's distance less its threshold at a pose [m], evaluations counted.

    Attributes:
        evals: Evaluations so far.
        least: The smallest clearance seen so far [m] (``inf`` before the first).
    """

    def __init__(
        self, scene: MujocoScene | CoalScene, thresholds: Array, max_evaluations: int
    ) -> None:
        self.scene, self.thresholds, self.max_evaluations = scene, thresholds, max_evaluations
        self.evals = 0
        self.least = np.inf

    def __call__(self, q: Array) -> Array:
        self.evals += 1
        if self.evals > self.max_evaluations:
            raise PoseError(f"path check gave up after {self.max_evaluations} distance evaluations")
        c = self.scene.distance_values(q) - self.thresholds
        self.least = min(self.least, float(c.min()))
        return c


def _check_linear(arm: Arm) -> None:
    """A coupled arm's path is checked where its chain moves on the straight segments.

    Raises:
        UnsupportedFeatureError: A nonlinear coupling or a loop: the chain's joints then
            follow curves between the waypoints, which the motion bounds do not cover.
    """
    if not arm.coupling.linear:  # type: ignore[union-attr]
        raise UnsupportedFeatureError(
            "a path of nonlinear couplings",
            f"followers {', '.join(repr(n) for n in arm.followers)}",
            "between waypoints the followers of a nonlinear coupling or a closed loop move "
            "on curves, which the path checker's motion bounds do not cover; check the poses "
            "along the path (collision.distances or collision_statistics(poses=...))",
        )


def _walk_on(
    clearance: _Clearance, qa: Array, qb: Array, c: Array, s: float, tol: float, rate: Array
) -> tuple[Array, float]:
    """From a point within ``tol`` of contact at ``s``, the contact that follows, if any.

    A near miss (no pair in contact) is walked on in steps that move every pair by at most
    ``tol``, until a pair is in contact (its clearances and ``s`` are returned) or the clearance
    exceeds ``tol`` again, or the segment ends (the near miss itself is returned).
    """
    if c.min() >= 0 and rate.max() > 0:
        h = tol / float(rate.max())
        cs, ss = c, s
        for _ in range(NEAR_MISS_WALK):
            if cs.min() >= tol or ss >= 1.0:
                break
            ss = min(1.0, ss + h)
            cs = clearance(qa + ss * (qb - qa))
            if cs.min() < 0:
                return cs, ss
    return c, s


def check_path(
    arm: Arm, waypoints: ArrayLike, tol: float = DEFAULT_TOL, engine: DistanceEngine = "coal"
) -> PathCheck:
    """Whether the straight joint-space segments between waypoints are free of self-contact.

    Uses the arm's cached pair set (see [`PathChecker`][redundancy.collision.PathChecker] for the
    method and guarantees): a contact anywhere on the path is never missed. When the path is not
    free, ``contact.clear_until`` is at or before the first real contact (the path is proven free up
    to there) and ``contact.s`` is the first contact found, or a near miss within ``tol`` when none
    follows closely (``contact.touching`` says which).

    Args:
        arm: The arm.
        waypoints: Shape (k, nq) [rad or m].
        tol: Clearance below which a point is reported [m].
        engine: ``"coal"`` or ``"mujoco"``.
    """
    return path_checker(arm).check(waypoints, tol, engine)


_PATH_CHECKERS: PerObject[Arm, PathChecker] = PerObject(lambda arm: PathChecker(checker(arm)))


def path_checker(arm: Arm) -> PathChecker:
    """The `PathChecker` of an arm with its full pair set, built once and cached.

    The cache never keeps an arm alive (the cached checker holds its arm weakly).
    """
    return _PATH_CHECKERS.get(check_arm(arm))

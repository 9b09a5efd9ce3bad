"""Self-collision: the geom pairs MuJoCo tests, and their distances from two engines.

Three parts, one per question:

* **Which pairs?** :func:`collision_pairs` reproduces, from the compiled ``MjModel``, the
  rules by which ``mj_collision`` picks the geom pairs it sends to narrow phase: the
  contype/conaffinity bitmasks, bodies welded together, the parent filter (with its
  world-body exception and its ``filterparent`` off switch), ``<contact><exclude>``, explicit
  ``<pair>`` elements and the global contact switches. Both engines use this one list.
* **How far apart?** :class:`CollisionChecker` gives the signed distance and nearest points
  of every pair at a pose, from coal (geoms placed by Pinocchio's forward kinematics) or from
  MuJoCo (``mj_geomDistance``), and MuJoCo's own contact list (``mj_collision``).
* **How often?** :func:`collision_statistics` counts, over random poses, the poses with a
  contact and, per pair, both the poses and the contacts (MuJoCo may list several contacts
  for one pair), with the closest approach per pair and the clearance at the keyframes.

Sign convention: a distance is positive when the geoms are apart and negative when they
overlap [m]. MuJoCo lists a contact for a pair when the distance is below the pair's
``threshold`` (margin + gap, zero unless the model sets them); "touching" here means the same.

Path checking (conservative advancement) lives in :mod:`redundancy.pathcheck`.
"""

from __future__ import annotations

import warnings
import weakref
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import (
    ModelError,
    RedundancyError,
    UnknownNameError,
    UnsupportedFeatureError,
)

if TYPE_CHECKING:
    import coal
    import pinocchio as pin

    from ..arm import Arm

from .pairs import (
    _G,
    COAL_EPA_TOLERANCE,
    COAL_GJK_TOLERANCE,
    COAL_MAX_ITERATIONS,
    DISTANCE_ENGINES,
    Array,
    DistanceEngine,
    GeomPair,
    collision_pairs,
    find_pair,
    geom_type_name,
)


@dataclass(frozen=True)
class PairDistance:
    """Signed distance between the two geoms of a pair at one pose.

    Attributes:
        pair: The pair.
        distance: Signed distance, negative when the geoms overlap [m].
        point1: Nearest (witness) point on ``pair.geom1``, world frame [m].
        point2: Nearest (witness) point on ``pair.geom2``, world frame [m].
    """

    pair: GeomPair
    distance: float
    point1: Array
    point2: Array

    @property
    def touching(self) -> bool:
        """True when MuJoCo would list a contact: distance below the pair's threshold."""
        return self.distance < self.pair.threshold

    @property
    def clearance(self) -> float:
        """Distance left before contact: distance minus the pair's threshold [m]."""
        return self.distance - self.pair.threshold


@dataclass(frozen=True)
class Distances:
    """Every pair's signed distance at one pose, from one engine.

    Attributes:
        q: The pose [rad or m].
        engine: ``"coal"`` or ``"mujoco"``.
        pairs: One entry per pair of the pair set, in its order.
    """

    q: Array
    engine: str
    pairs: tuple[PairDistance, ...]

    @property
    def values(self) -> Array:
        """The signed distances as an array, in pair order [m]."""
        return np.array([p.distance for p in self.pairs])

    @property
    def closest(self) -> PairDistance | None:
        """The pair with the smallest clearance (None when there are no pairs)."""
        return min(self.pairs, key=lambda p: p.clearance, default=None)

    @property
    def touching(self) -> tuple[PairDistance, ...]:
        """The pairs below their contact threshold."""
        return tuple(p for p in self.pairs if p.touching)

    @property
    def free(self) -> bool:
        """True when no pair touches."""
        return not self.touching

    def of(self, name1: str, name2: str) -> PairDistance:
        """The entry of the pair of geoms so named (either order)."""
        pair = find_pair([p.pair for p in self.pairs], name1, name2)
        return next(p for p in self.pairs if p.pair == pair)


@dataclass(frozen=True)
class Contact:
    """One contact in MuJoCo's contact list (``mj_collision``).

    Attributes:
        pair: The geom pair (MuJoCo may list several contacts for one pair).
        distance: MuJoCo's contact distance, negative for penetration [m]. For primitive
            colliders (capsule-box, box-box, sphere-cylinder) it is the depth of this contact
            point along its normal, not the pair's penetration depth.
        position: Contact point, world frame [m].
        normal: Unit contact normal, pointing from ``pair.geom1`` to ``pair.geom2``.
    """

    pair: GeomPair
    distance: float
    position: Array
    normal: Array


# ==========================================================================================
# Engines: MuJoCo
# ==========================================================================================


class _MujocoScene:
    """MuJoCo's own answers: ``mj_geomDistance`` per pair and ``mj_collision``'s contacts."""

    def __init__(self, model: mujoco.MjModel, pairs: Sequence[GeomPair]) -> None:
        self.model = model
        # A private MjData: the contact list and geom poses here never disturb the Arm's.
        self.data = mujoco.MjData(model)
        self.pairs = tuple(pairs)
        self.g1 = np.array([p.geom1 for p in pairs], dtype=int)
        self.g2 = np.array([p.geom2 for p in pairs], dtype=int)
        # index[g1, g2] = position of the pair in the set (-1: not a pair).
        self.index = np.full((model.ngeom, model.ngeom), -1, dtype=int)
        self.index[self.g1, self.g2] = np.arange(len(pairs))
        self.index[self.g2, self.g1] = np.arange(len(pairs))
        self._fromto = np.zeros(6)
        self._pairs_list = list(zip(self.g1.tolist(), self.g2.tolist(), strict=True))

    def kinematics(self, q: Array) -> None:
        self.data.qpos[:] = q
        # mj_kinematics is all collision needs: geom_xpos/xmat for the colliders and
        # xipos/ximat for the bodies' bounding boxes (broad and mid phase).
        mujoco.mj_kinematics(self.model, self.data)

    def collide(self, q: Array) -> tuple[NDArray[np.int_], Array]:
        """Run MuJoCo's collision pipeline; return (pair index, distance) per contact."""
        self.kinematics(q)
        # mj_collision: broad phase, the pair filters and narrow phase, as in mj_forward.
        mujoco.mj_collision(self.model, self.data)
        n = self.data.ncon
        if n == 0:
            return np.zeros(0, dtype=int), np.zeros(0)
        geoms = self.data.contact.geom[:n]
        idx = self.index[geoms[:, 0], geoms[:, 1]]
        if (idx < 0).any() or (geoms < 0).any():
            bad = geoms[np.flatnonzero((idx < 0) | (geoms < 0).any(axis=1))[0]]
            raise RedundancyError(
                f"MuJoCo listed a contact between geoms {bad.tolist()}, which is not in the pair "
                "set built from its filtering rules; please report this model"
            )
        return idx, self.data.contact.dist[:n].copy()

    def contacts(self, q: Array) -> tuple[Contact, ...]:
        idx, dist = self.collide(q)
        out = []
        for c in range(len(idx)):
            pair = self.pairs[idx[c]]
            normal = self.data.contact.frame[c, :3].copy()
            # MuJoCo orders a contact's geoms by type; report normals from geom1 to geom2.
            if int(self.data.contact.geom[c, 0]) != pair.geom1:
                normal = -normal
            out.append(Contact(pair, float(dist[c]), self.data.contact.pos[c].copy(), normal))
        return tuple(out)

    def distances(self, q: Array) -> tuple[Array, Array, Array]:
        """Signed distance and nearest points of every pair from ``mj_geomDistance``."""
        self.kinematics(q)
        m, d = self.model, self.data
        n = len(self.pairs)
        dist, p1, p2 = np.zeros(n), np.zeros((n, 3)), np.zeros((n, 3))
        # distmax caps the answer; the distance never exceeds the centres' separation (each
        # centre is inside its convex geom, or on its plane), so this cap never binds.
        xpos = d.geom_xpos
        caps = (np.linalg.norm(xpos[self.g1] - xpos[self.g2], axis=1) + 1.0).tolist()
        fromto = self._fromto
        geom_distance = mujoco.mj_geomDistance
        for k, (g1, g2) in enumerate(self._pairs_list):
            dist[k] = geom_distance(m, d, g1, g2, caps[k], fromto)
            p1[k], p2[k] = fromto[:3], fromto[3:]
        return dist, p1, p2


# ==========================================================================================
# Engines: Pinocchio places the geoms, coal measures them
# ==========================================================================================


def coal_shape(model: mujoco.MjModel, geom: int) -> coal.ShapeBase:
    """A coal shape equal to a MuJoCo primitive geom, in the geom's own frame.

    MuJoCo's compiled ``geom_size`` holds half-sizes: sphere (r), capsule and cylinder
    (r, half-length along z), box (half-sides), ellipsoid (semi-axes); a plane is the
    half-space z <= 0 of its frame. coal's constructors take full lengths.

    Raises:
        UnsupportedFeatureError: Mesh, height field or SDF geoms.
    """
    import coal

    t = int(model.geom_type[geom])
    s = model.geom_size[geom]
    if t == _G.mjGEOM_SPHERE:
        return coal.Sphere(s[0])
    if t == _G.mjGEOM_CAPSULE:
        return coal.Capsule(s[0], 2 * s[1])
    if t == _G.mjGEOM_CYLINDER:
        return coal.Cylinder(s[0], 2 * s[1])
    if t == _G.mjGEOM_BOX:
        return coal.Box(2 * s[0], 2 * s[1], 2 * s[2])
    if t == _G.mjGEOM_ELLIPSOID:
        return coal.Ellipsoid(s[0], s[1], s[2])
    if t == _G.mjGEOM_PLANE:
        return coal.Halfspace(np.array([0.0, 0.0, 1.0]), 0.0)
    name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, geom) or f"#{geom}"
    raise UnsupportedFeatureError(
        f"{geom_type_name(model, geom)} geom",
        f"geom {name!r}",
        "distances are computed for primitive geoms only",
    )


def distance_request() -> coal.DistanceRequest:
    """The coal distance request this module uses: signed, tight GJK, robust EPA."""
    import coal

    req = coal.DistanceRequest()
    req.enable_signed_distance = True  # penetration depth (EPA) instead of 0 on overlap
    req.gjk_tolerance = COAL_GJK_TOLERANCE
    req.gjk_max_iterations = COAL_MAX_ITERATIONS
    req.epa_tolerance = COAL_EPA_TOLERANCE
    req.epa_max_iterations = COAL_MAX_ITERATIONS
    req.gjk_initial_guess = coal.GJKInitialGuess.DefaultGuess  # no warm start: reproducible
    return req


class _CoalScene:
    """coal distances with the geoms placed by Pinocchio's forward kinematics.

    Each geom becomes a Pinocchio ``GeometryObject`` attached to the BODY frame that
    Pinocchio's MJCF parser creates for the geom's body, at MuJoCo's compiled geom pose in
    that body (``geom_pos``, ``geom_quat``). Only the geom shapes and their offsets in their
    bodies come from MuJoCo; every body pose comes from Pinocchio.
    """

    def __init__(self, arm: Arm, pairs: Sequence[GeomPair]) -> None:
        import pinocchio as pin

        m = arm.mj_model
        self.arm = arm
        self.pin_model: pin.Model = arm.pinocchio.model
        self.pin_data = self.pin_model.createData()  # private: never disturbs the Arm's
        self.perm = arm.pinocchio.perm
        self._qp = np.zeros(self.pin_model.nq)
        self.pairs = tuple(pairs)
        used = sorted({p.geom1 for p in pairs} | {p.geom2 for p in pairs})
        self.geom_model = pin.GeometryModel()
        self.slot: dict[int, int] = {}  # MuJoCo geom id -> GeometryObject index
        for g in used:
            self.slot[g] = self.geom_model.addGeometryObject(self._geometry_object(m, g))
        for p in pairs:
            self.geom_model.addCollisionPair(
                pin.CollisionPair(self.slot[p.geom1], self.slot[p.geom2])
            )
        self.geom_data = pin.GeometryData(self.geom_model)
        # GeometryData owns one request per pair; computeDistances reads them.
        for req in self.geom_data.distanceRequests:
            ref = distance_request()
            req.enable_signed_distance = ref.enable_signed_distance
            req.gjk_tolerance = ref.gjk_tolerance
            req.gjk_max_iterations = ref.gjk_max_iterations
            req.epa_tolerance = ref.epa_tolerance
            req.epa_max_iterations = ref.epa_max_iterations
            req.gjk_initial_guess = ref.gjk_initial_guess
            # Pinocchio turns on GJK warm starts from the previous call, which makes a
            # distance depend on the poses queried before it (by up to 1e-6 m for EPA
            # depths); off, every distance is a function of the pose alone, and faster.
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", DeprecationWarning)
                if hasattr(req, "enable_cached_gjk_guess"):
                    req.enable_cached_gjk_guess = False
        # Pair k of the GeometryModel must be pair k of the set.
        for k, p in enumerate(pairs):
            cp = self.geom_model.collisionPairs[k]
            assert {cp.first, cp.second} == {self.slot[p.geom1], self.slot[p.geom2]}
        self._retried: dict[int, tuple[float, Array, Array]] = {}
        # References into GeometryData's result vector, listed once: building the Python
        # wrappers anew for every pose would cost more than the distances themselves.
        self._results = list(self.geom_data.distanceResults)
        self._swapped = [
            self.geom_model.collisionPairs[k].first != self.slot[p.geom1]
            for k, p in enumerate(pairs)
        ]

    def _geometry_object(self, m: mujoco.MjModel, g: int) -> pin.GeometryObject:
        import pinocchio as pin

        body = int(m.geom_bodyid[g])
        gname = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g}"
        local = pin.SE3(_quat_matrix(m.geom_quat[g]), m.geom_pos[g].copy())
        if body == 0:
            # The world body is Pinocchio's universe: joint 0, frame 0, identity placement.
            return pin.GeometryObject(gname, 0, 0, local, coal_shape(m, g))
        bname = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, body)
        if not bname or not self.pin_model.existFrame(bname, pin.FrameType.BODY):
            raise UnsupportedFeatureError(
                "body Pinocchio does not name",
                f"body {bname or f'#{body}'!r} (carries geom {gname!r})",
                "geoms are placed on Pinocchio's BODY frame of the same name; name the body",
            )
        fid = self.pin_model.getFrameId(bname, pin.FrameType.BODY)
        frame = self.pin_model.frames[fid]
        # GeometryObject placements are relative to the parent *joint*: compose the body
        # frame's placement in its joint with the geom's placement in its body.
        return pin.GeometryObject(
            gname, frame.parentJoint, fid, frame.placement * local, coal_shape(m, g)
        )

    def update(self, q: Array) -> None:
        import pinocchio as pin

        self._qp[self.perm] = q
        # forwardKinematics fills oMi; updateGeometryPlacements composes oMg = oMi * placement.
        pin.forwardKinematics(self.pin_model, self.pin_data, self._qp)
        pin.updateGeometryPlacements(self.pin_model, self.pin_data, self.geom_model, self.geom_data)

    def geom_pose(self, g: int) -> tuple[Array, Array]:
        """World position [m] and rotation of geom ``g`` after :meth:`update`."""
        oMg = self.geom_data.oMg[self.slot[g]]
        return oMg.translation.copy(), oMg.rotation.copy()

    def _raw_values(self, q: Array) -> Array:
        import pinocchio as pin

        self._qp[self.perm] = q
        # computeDistances = forwardKinematics + updateGeometryPlacements + coal.distance on
        # every collision pair, in one C++ loop.
        pin.computeDistances(
            self.pin_model, self.pin_data, self.geom_model, self.geom_data, self._qp
        )
        return np.array([r.min_distance for r in self._results])

    def distance_values(self, q: Array) -> Array:
        """Signed distance of every pair [m] (fast path: no nearest points)."""
        out = self._raw_values(q)
        # EPA failures come back as -DBL_MAX (or non-finite): redo those pairs.
        bad = ~np.isfinite(out) | (out < -1e6)
        self._retried = {int(k): self._retry(int(k)) for k in np.flatnonzero(bad)}
        for k, (d, _, _) in self._retried.items():
            out[k] = d
        return out

    def distances(self, q: Array) -> tuple[Array, Array, Array]:
        dist = self.distance_values(q)
        n = len(self.pairs)
        p1, p2 = np.zeros((n, 3)), np.zeros((n, 3))
        for k, r in enumerate(self._results):
            a, b = r.getNearestPoint1(), r.getNearestPoint2()
            if k in self._retried:
                a, b = self._retried[k][1], self._retried[k][2]
            p1[k], p2[k] = (b, a) if self._swapped[k] else (a, b)
        return dist, p1, p2

    def _retry(self, k: int) -> tuple[float, Array, Array]:
        """Recompute pair ``k`` with a looser EPA after a failure (coal returns -DBL_MAX).

        EPA can fail on deep overlaps of curved shapes; the geoms then overlap for sure, so a
        depth from a looser EPA is kept, and if that fails too, the (negative) opposite of
        the sum of the bounding radii, a bound no overlap can exceed.
        """
        import coal

        pair = self.pairs[k]
        objs = [self.geom_model.geometryObjects[self.slot[g]] for g in (pair.geom1, pair.geom2)]
        tfs = [self.geom_data.oMg[self.slot[g]] for g in (pair.geom1, pair.geom2)]
        req = distance_request()
        req.epa_tolerance = 1e-4
        res = coal.DistanceResult()
        d = coal.distance(
            objs[0].geometry,
            coal.Transform3s(tfs[0].rotation, tfs[0].translation),
            objs[1].geometry,
            coal.Transform3s(tfs[1].rotation, tfs[1].translation),
            req,
            res,
        )
        if np.isfinite(d) and d > -1e6:
            return float(d), res.getNearestPoint1(), res.getNearestPoint2()
        m = self.arm.mj_model
        return (
            -float(m.geom_rbound[pair.geom1] + m.geom_rbound[pair.geom2]),
            tfs[0].translation,
            tfs[1].translation,
        )


def _quat_matrix(quat: ArrayLike) -> Array:
    """Rotation matrix of a MuJoCo quaternion (w, x, y, z)."""
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, np.asarray(quat, dtype=float))
    return mat.reshape(3, 3)


# ==========================================================================================
# The checker: one arm, both engines
# ==========================================================================================


class CollisionChecker:
    """Self-collision queries on one arm: pair set, distances (coal, MuJoCo), contacts.

    Build it once per arm (or let the module functions cache one per arm); it owns private
    ``MjData``, Pinocchio ``Data`` and coal objects, so the arm's own data is left alone.

    Args:
        arm: The loaded arm.
        pairs: The pairs to check; defaults to :func:`collision_pairs` of the arm's model.

    Attributes:
        arm: The arm.
        pairs: The pair set, shared by both engines.

    Raises:
        UnsupportedFeatureError: Flex objects, or a geom on an unnamed body.
        ModelError: Pinocchio's geom placements differ from MuJoCo's (self-check at build).
    """

    #: Largest difference allowed between the engines' geom placements in the self-check.
    PLACEMENT_TOL = 1e-9

    def __init__(self, arm: Arm, pairs: Sequence[GeomPair] | None = None) -> None:
        m = arm.mj_model
        if m.nflex:
            raise UnsupportedFeatureError(
                "flex", f"{m.nflex} in the model", "only rigid geoms are checked"
            )
        self.arm = arm
        self.pairs: tuple[GeomPair, ...] = tuple(collision_pairs(m) if pairs is None else pairs)
        self._mj = _MujocoScene(m, self.pairs)
        self._coal = _CoalScene(arm, self.pairs)
        for q in (m.qpos0.copy(), _probe_pose(arm)):
            err = self.placement_error(q)
            if err > self.PLACEMENT_TOL:
                raise ModelError(
                    f"Pinocchio and MuJoCo place the collision geoms differently at q = "
                    f"{np.round(q, 4).tolist()} (largest difference {err:.3g} in a position [m] "
                    "or a rotation-matrix entry); the engines do not see the same bodies"
                )

    # -- checks --------------------------------------------------------------------------
    def _q(self, q: ArrayLike) -> Array:
        return self.arm.pose(q)

    def placement_error(self, q: ArrayLike) -> float:
        """Largest difference between Pinocchio's and MuJoCo's geom poses at ``q``.

        Positions [m] and rotation-matrix entries compared, max over the geoms in the pairs.
        """
        q = self._q(q)
        self._coal.update(q)
        self._mj.kinematics(q)
        err = 0.0
        for g in self._coal.slot:
            p, R = self._coal.geom_pose(g)
            err = max(
                err,
                float(np.abs(p - self._mj.data.geom_xpos[g]).max()),
                float(np.abs(R - self._mj.data.geom_xmat[g].reshape(3, 3)).max()),
            )
        return err

    # -- queries ---------------------------------------------------------------------------
    def distances(self, q: ArrayLike, engine: DistanceEngine = "coal") -> Distances:
        """Signed distance and nearest points of every pair at ``q``.

        Args:
            q: Joint configuration [rad or m].
            engine: ``"coal"`` (geoms placed by Pinocchio) or ``"mujoco"`` (``mj_geomDistance``).
        """
        q = self._q(q)
        if engine == "coal":
            dist, p1, p2 = self._coal.distances(q)
        elif engine == "mujoco":
            dist, p1, p2 = self._mj.distances(q)
        else:
            raise UnknownNameError("distance engine", str(engine), DISTANCE_ENGINES)
        entries = tuple(
            PairDistance(p, float(dist[k]), p1[k].copy(), p2[k].copy())
            for k, p in enumerate(self.pairs)
        )
        return Distances(q.copy(), engine, entries)

    def distance_values(self, q: ArrayLike, engine: DistanceEngine = "coal") -> Array:
        """Signed distance of every pair at ``q``, in pair order, without nearest points [m]."""
        q = self._q(q)
        if engine == "coal":
            return self._coal.distance_values(q)
        if engine == "mujoco":
            return self._mj.distances(q)[0]
        raise UnknownNameError("distance engine", str(engine), DISTANCE_ENGINES)

    def contacts(self, q: ArrayLike) -> tuple[Contact, ...]:
        """MuJoCo's contact list at ``q`` (``mj_kinematics`` + ``mj_collision``)."""
        return self._mj.contacts(self._q(q))

    def contact_pairs(self, q: ArrayLike) -> frozenset[GeomPair]:
        """The pairs for which MuJoCo lists at least one contact at ``q``."""
        idx, _ = self._mj.collide(self._q(q))
        return frozenset(self.pairs[i] for i in idx)

    def touching_pairs(self, q: ArrayLike, engine: DistanceEngine = "coal") -> frozenset[GeomPair]:
        """The pairs below their contact threshold at ``q``, by the engine's distances."""
        dist = self.distance_values(q, engine)
        return frozenset(p for p, d in zip(self.pairs, dist, strict=True) if d < p.threshold)

    def pair(self, name1: str, name2: str) -> GeomPair:
        """The pair of the geoms so named (either order)."""
        return find_pair(self.pairs, name1, name2)

    def __repr__(self) -> str:
        return f"CollisionChecker({self.arm!r}, {len(self.pairs)} pairs)"


def _probe_pose(arm: Arm) -> Array:
    """A fixed, unremarkable pose inside the joint ranges (for the placement self-check)."""
    lo = np.where(np.isfinite(arm.lower), arm.lower, -1.0)
    hi = np.where(np.isfinite(arm.upper), arm.upper, 1.0)
    frac = (np.arange(arm.nq) * 0.618034 + 0.3) % 1.0
    return lo + frac * (hi - lo)


_CHECKERS: weakref.WeakKeyDictionary[Arm, CollisionChecker] = weakref.WeakKeyDictionary()


def checker(arm: Arm) -> CollisionChecker:
    """The :class:`CollisionChecker` of an arm with its full pair set, built once and cached."""
    ch = _CHECKERS.get(arm)
    if ch is None:
        ch = _CHECKERS[arm] = CollisionChecker(arm)
    return ch


def distances(arm: Arm, q: ArrayLike, engine: DistanceEngine = "coal") -> Distances:
    """Signed distance and nearest points of every pair at ``q`` (see :class:`CollisionChecker`)."""
    return checker(arm).distances(q, engine)


def contacts(arm: Arm, q: ArrayLike) -> tuple[Contact, ...]:
    """MuJoCo's contact list at ``q`` (see :class:`CollisionChecker`)."""
    return checker(arm).contacts(q)


# ==========================================================================================
# Statistics over random poses
# ==========================================================================================

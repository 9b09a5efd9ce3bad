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

import time
import warnings
import weakref
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

# Random poses are the arm's business; re-exported here, where the lesson's sample is drawn.
from .arm import random_poses as random_poses
from .arm import sampling_ranges as sampling_ranges
from .errors import (
    ModelError,
    PoseError,
    RedundancyError,
    UnknownNameError,
    UnsupportedFeatureError,
)

if TYPE_CHECKING:
    import coal
    import pinocchio as pin

    from .arm import Arm

Array = NDArray[np.float64]
DistanceEngine = Literal["coal", "mujoco"]
DISTANCE_ENGINES: tuple[DistanceEngine, ...] = ("coal", "mujoco")

#: Width of the band around a pair's contact threshold inside which the two engines may
#: legitimately disagree on "touching" [m]: MuJoCo's GJK/EPA stops at ``opt.ccd_tolerance``
#: (1e-6 m by default), coal's at the tolerances below; a pair this close to the threshold is
#: reported as touching by one engine and not the other without either being wrong.
AMBIGUITY_BAND = 1e-6

#: coal's GJK stops when its relative convergence gap is below this. At 1e-9 a capsule end
#: facing a box face almost squarely came out 2.4e-9 (relative) short; at 1e-10 separated
#: distances of polytope-like pairs match MuJoCo's closed forms to 1e-16 m, and curved ones
#: (cylinders, ellipsoids) to MuJoCo's own GJK tolerance. Below 1e-11 GJK stops converging.
COAL_GJK_TOLERANCE = 1e-10
#: coal's EPA (penetration depth) tolerance [m]; tighter values make EPA fail on deep overlaps.
COAL_EPA_TOLERANCE = 1e-6
#: Iteration caps for coal's GJK and EPA (its defaults, 128 and 64, are too few at these
#: tolerances on curved shapes).
COAL_MAX_ITERATIONS = 1000

_G = mujoco.mjtGeom
# Geom types that have no collision function with each other in MuJoCo (mjCOLLISIONFUNC
# holds NULL for plane/hfield against plane/hfield), so MuJoCo never tests such a pair.
_NO_COLLIDER = {int(_G.mjGEOM_PLANE), int(_G.mjGEOM_HFIELD)}


def geom_type_name(model: mujoco.MjModel, geom: int) -> str:
    """MuJoCo's short name of a geom's type (``"capsule"``...)."""
    return mujoco.mjtGeom(model.geom_type[geom]).name.removeprefix("mjGEOM_").lower()


# ==========================================================================================
# The pair set: MuJoCo's rules, read from the compiled model
# ==========================================================================================


@dataclass(frozen=True)
class GeomPair:
    """One geom pair that MuJoCo tests for contact.

    Attributes:
        geom1: Geom id, the smaller of the two.
        geom2: Geom id, the larger.
        name1: Name of ``geom1`` (``""`` if unnamed).
        name2: Name of ``geom2``.
        body1: Name of the body carrying ``geom1``.
        body2: Name of the body carrying ``geom2``.
        type1: Geom type of ``geom1`` (``"capsule"``...).
        type2: Geom type of ``geom2``.
        explicit: True for a ``<contact><pair>`` element (which bypasses every filter).
        margin: Distance at which MuJoCo's contact becomes active [m].
        gap: Extra distance over ``margin`` at which MuJoCo already lists the contact [m].
    """

    geom1: int
    geom2: int
    name1: str
    name2: str
    body1: str
    body2: str
    type1: str
    type2: str
    explicit: bool
    margin: float
    gap: float

    @property
    def threshold(self) -> float:
        """MuJoCo lists a contact for the pair when the distance is below this [m]."""
        return self.margin + self.gap

    @property
    def names(self) -> tuple[str, str]:
        """The two geom names (``#id`` for an unnamed geom), in id order."""
        return (self.name1 or f"#{self.geom1}", self.name2 or f"#{self.geom2}")

    @property
    def label(self) -> str:
        """``"link2 / link4"``: geom names sorted alphabetically, as the lesson prints them."""
        return " / ".join(sorted(self.names))

    @property
    def types(self) -> frozenset[str]:
        """The set of the two geom types."""
        return frozenset((self.type1, self.type2))

    def matches(self, name1: str, name2: str) -> bool:
        """True when the pair is made of the geoms so named, in either order."""
        return {name1, name2} == set(self.names) and (
            name1 != name2 or self.names[0] == self.names[1]
        )

    def __str__(self) -> str:
        return self.label


def _name(model: mujoco.MjModel, obj: mujoco.mjtObj, i: int) -> str:
    return mujoco.mj_id2name(model, obj, i) or ""


def _margin_gap(model: mujoco.MjModel, g1: int, g2: int, ipair: int) -> tuple[float, float]:
    """Margin and gap of a pair as engine_collision_driver.c's getMargin/getGap compute them."""
    if model.opt.enableflags & mujoco.mjtEnableBit.mjENBL_OVERRIDE:
        # mj_assignMargin: the override replaces every margin (the gap is not overridden).
        margin = float(model.opt.o_margin)
    elif ipair >= 0:
        margin = float(model.pair_margin[ipair])
    else:
        margin = float(model.geom_margin[g1] + model.geom_margin[g2])
    gap = (
        float(model.pair_gap[ipair])
        if ipair >= 0
        else float(model.geom_gap[g1] + model.geom_gap[g2])
    )
    return margin, gap


def _bodies_filtered(model: mujoco.MjModel, b1: int, b2: int) -> bool:
    """MuJoCo's body-pair filter (filterBodyPair in engine_collision_driver.c).

    Bodies welded together (same ``body_weldid``, which includes a body and itself) never
    collide. With ``filterparent`` on (the default), a body does not collide with its parent,
    where both are taken as weld groups: the parent of a weld group is the weld group of the
    parent of its root body. The world exception: the parent filter only applies when
    neither weld group is the world's, so a body attached to the world by a joint does
    collide with geoms welded to the world (a floor, a base plate).
    """
    w1, w2 = int(model.body_weldid[b1]), int(model.body_weldid[b2])
    if w1 == w2:
        return True
    if model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_FILTERPARENT:
        return False
    if w1 == 0 or w2 == 0:
        return False
    pw1 = int(model.body_weldid[model.body_parentid[w1]])
    pw2 = int(model.body_weldid[model.body_parentid[w2]])
    return w1 == pw2 or w2 == pw1


def collision_pairs(model: mujoco.MjModel | Arm) -> tuple[GeomPair, ...]:
    """The geom pairs MuJoCo's ``mj_collision`` tests for contact, sorted by geom ids.

    Reproduces engine_collision_driver.c from the compiled model (pose-independent rules
    only; the bounding-sphere and bounding-box tests that follow are geometric shortcuts that
    never drop a touching pair):

    * none at all when ``<flag contact="disable"/>`` or ``constraint="disable"``;
    * every ``<contact><pair>``, whatever its geoms' bitmasks, bodies or exclusions;
    * otherwise geoms on bodies that pass the body filter (not welded together, not parent
      and child unless ``filterparent`` is disabled or one side is welded to the world), whose
      bodies are not listed in a ``<contact><exclude>``, and whose bitmasks match:
      ``(contype1 & conaffinity2) | (contype2 & conaffinity1) != 0``. A pair also named in a
      ``<pair>`` element is tested once, with the element's parameters.
    * never plane or height field against plane or height field (MuJoCo has no collider).

    Not modelled: sleeping bodies (``<flag sleep="enable"/>``), which MuJoCo skips pose by
    pose, and flex objects.

    Args:
        model: MuJoCo's compiled model, or an :class:`~redundancy.Arm`.

    Raises:
        UnsupportedFeatureError: A contact-filter callback is installed
            (``mujoco.set_mjcb_contactfilter``): it replaces the bitmask test with user code
            this function cannot reproduce.
    """
    m: mujoco.MjModel = model if isinstance(model, mujoco.MjModel) else model.mj_model
    dsbl = m.opt.disableflags
    if dsbl & (mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT):
        return ()
    if mujoco.get_mjcb_contactfilter() is not None:
        raise UnsupportedFeatureError(
            "contact filter callback",
            "mujoco.set_mjcb_contactfilter",
            "a user callback replaces MuJoCo's bitmask test; the pair set cannot be reproduced",
        )
    found: dict[tuple[int, int], int] = {}  # (g1, g2) -> ipair (-1: from the filters)
    for k in range(m.npair):
        g1, g2 = sorted((int(m.pair_geom1[k]), int(m.pair_geom2[k])))
        found.setdefault((g1, g2), k)
    # exclude_signature packs the two body ids as (smaller << 16) + larger.
    excluded = {(int(s) >> 16, int(s) & 0xFFFF) for s in m.exclude_signature}
    for g1 in range(m.ngeom):
        for g2 in range(g1 + 1, m.ngeom):
            if (g1, g2) in found:
                continue
            b1, b2 = int(m.geom_bodyid[g1]), int(m.geom_bodyid[g2])
            if _bodies_filtered(m, b1, b2):
                continue
            if (min(b1, b2), max(b1, b2)) in excluded:
                continue
            if not (
                m.geom_contype[g1] & m.geom_conaffinity[g2]
                or m.geom_contype[g2] & m.geom_conaffinity[g1]
            ):
                continue
            found[(g1, g2)] = -1
    pairs = []
    for (g1, g2), ipair in sorted(found.items()):
        if int(m.geom_type[g1]) in _NO_COLLIDER and int(m.geom_type[g2]) in _NO_COLLIDER:
            continue
        margin, gap = _margin_gap(m, g1, g2, ipair)
        pairs.append(
            GeomPair(
                geom1=g1,
                geom2=g2,
                name1=_name(m, mujoco.mjtObj.mjOBJ_GEOM, g1),
                name2=_name(m, mujoco.mjtObj.mjOBJ_GEOM, g2),
                body1=_name(m, mujoco.mjtObj.mjOBJ_BODY, int(m.geom_bodyid[g1])),
                body2=_name(m, mujoco.mjtObj.mjOBJ_BODY, int(m.geom_bodyid[g2])),
                type1=geom_type_name(m, g1),
                type2=geom_type_name(m, g2),
                explicit=ipair >= 0,
                margin=margin,
                gap=gap,
            )
        )
    return tuple(pairs)


def find_pair(pairs: Sequence[GeomPair], name1: str, name2: str) -> GeomPair:
    """The pair of the geoms so named (either order).

    Raises:
        UnknownNameError: No such pair in ``pairs`` (the message lists the pairs).
    """
    for p in pairs:
        if p.matches(name1, name2):
            return p
    raise UnknownNameError("geom pair", f"{name1} / {name2}", [p.label for p in pairs])


# ==========================================================================================
# Results
# ==========================================================================================


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


@dataclass(frozen=True)
class PairStatistics:
    """One pair over a sample of poses.

    Attributes:
        pair: The pair.
        poses: Poses in which MuJoCo lists at least one contact for the pair.
        contacts: Contacts MuJoCo lists for the pair, summed over the poses (a capsule pair
            can give two per pose, a box pair up to eight).
        closest: Smallest signed distance over the poses [m] (``nan`` without distances).
        closest_pose: Index of that pose in the sample (-1 without distances).
    """

    pair: GeomPair
    poses: int
    contacts: int
    closest: float
    closest_pose: int


@dataclass(frozen=True)
class KeyframeClearance:
    """Self-collision at one keyframe.

    Attributes:
        keyframe: Keyframe name.
        q: Its pose [rad or m].
        contacts: Number of contacts MuJoCo lists there.
        closest: The pair with the smallest clearance, with its distance (None: no pairs).
    """

    keyframe: str
    q: Array
    contacts: int
    closest: PairDistance | None


@dataclass(frozen=True)
class CollisionStatistics:
    """Self-collision over random poses, as the lesson's table (4), labelled honestly.

    Attributes:
        n_poses: Number of poses drawn.
        seed: Seed of ``np.random.default_rng``.
        distance_engine: Engine of the distances (``None``: contacts only).
        poses_with_contact: Poses in which MuJoCo lists at least one contact.
        pairs: Per pair, in pair-set order.
        keyframes: Clearance at each keyframe.
        disagreements: Poses where the distance engine's touching pairs differ from MuJoCo's
            contact pairs, not counting pairs within :data:`AMBIGUITY_BAND` of their threshold
            (0 expected; -1 without distances).
        seconds: Wall time of the sweep [s].
    """

    n_poses: int
    seed: int | None
    distance_engine: str | None
    poses_with_contact: int
    pairs: tuple[PairStatistics, ...]
    keyframes: tuple[KeyframeClearance, ...]
    disagreements: int
    seconds: float

    @property
    def share_with_contact(self) -> float:
        """Fraction of the poses with at least one contact, in [0, 1]."""
        return self.poses_with_contact / self.n_poses if self.n_poses else 0.0

    def of(self, name1: str, name2: str) -> PairStatistics:
        """The statistics of the pair of geoms so named (either order)."""
        pair = find_pair([p.pair for p in self.pairs], name1, name2)
        return next(p for p in self.pairs if p.pair == pair)

    def ranked(self) -> list[PairStatistics]:
        """Pairs that touched at least once, most poses first (ties: most contacts)."""
        hit = [p for p in self.pairs if p.poses]
        return sorted(hit, key=lambda p: (-p.poses, -p.contacts, p.pair.label))

    def lines(self, top: int | None = None) -> list[str]:
        """The table as text lines: share of poses, then per pair poses and contacts."""
        out = [
            f"{self.n_poses} random poses (seed {self.seed}): {100 * self.share_with_contact:.1f}% "
            f"have at least one self-contact (MuJoCo's contact list)"
        ]
        dist = self.distance_engine is not None
        head = f"  {'pair':<24}{'poses':>7}{'contacts':>10}"
        out.append(head + (f"{'closest (m)':>13}" if dist else ""))
        rows = (
            self.ranked() if not dist else sorted(self.pairs, key=lambda p: (-p.poses, p.closest))
        )
        for p in rows[:top]:
            line = f"  {p.pair.label:<24}{p.poses:>7}{p.contacts:>10}"
            out.append(line + (f"{p.closest:>13.4f}" if dist else ""))
        for k in self.keyframes:
            c = k.closest
            near = f", closest {c.pair.label} at {c.distance:.4f} m" if c is not None else ""
            out.append(f"  at the {k.keyframe} pose: {k.contacts} contacts{near}")
        if dist:
            out.append(
                f"  distances by {self.distance_engine}; poses where its touching pairs differ "
                f"from MuJoCo's contacts: {self.disagreements}"
            )
        return out


def collision_statistics(
    arm: Arm,
    n_poses: int = 10000,
    seed: int | None = 1,
    distances: DistanceEngine | None = "coal",
    poses: ArrayLike | None = None,
) -> CollisionStatistics:
    """Self-collision over random poses: contacts by MuJoCo, closest approach by an engine.

    Contacts are MuJoCo's (``mj_kinematics`` + ``mj_collision`` per pose, as the lesson's
    ``mj_forward`` finds them). With ``distances`` set, every pair's signed distance is also
    computed at every pose, giving the closest approach per pair and a cross-check: the
    engine's touching pairs must equal MuJoCo's contact pairs at every pose (pairs within
    :data:`AMBIGUITY_BAND` of their threshold aside).

    Args:
        arm: The arm.
        n_poses: Number of random poses (ignored when ``poses`` is given).
        seed: Seed; ``seed=1`` with 10000 poses is the lesson's sample.
        distances: ``"coal"``, ``"mujoco"`` or ``None`` (contacts only, fastest).
        poses: Explicit poses, shape (n, nq) [rad or m], instead of random ones.
    """
    ch = checker(arm)
    if poses is None:
        Q = random_poses(arm, n_poses, seed)
    else:
        try:
            Q = np.asarray(poses, dtype=float)
        except (TypeError, ValueError) as err:
            raise PoseError(f"poses must be an array of shape (n, {arm.nq}): {err}") from err
        if Q.ndim != 2 or Q.shape[1] != arm.nq:
            raise PoseError(f"poses must have shape (n, {arm.nq}), got {Q.shape}")
        Q = np.array([arm.pose(q) for q in Q]).reshape(-1, arm.nq)
    if distances is not None and distances not in DISTANCE_ENGINES:
        raise UnknownNameError("distance engine", str(distances), DISTANCE_ENGINES)
    npair = len(ch.pairs)
    thr = np.array([p.threshold for p in ch.pairs])
    pose_hits = np.zeros(npair, dtype=int)
    contact_hits = np.zeros(npair, dtype=int)
    closest = np.full(npair, np.inf)
    closest_at = np.full(npair, -1)
    with_contact = 0
    disagree = 0
    # The poses are validated above: call the engines' scenes directly, without per-pose checks.
    measure = None
    if distances == "coal":
        measure = ch._coal.distance_values
    elif distances == "mujoco":

        def measure(q: Array) -> Array:
            return ch._mj.distances(q)[0]

    t0 = time.perf_counter()
    for i, q in enumerate(Q):
        idx, _ = ch._mj.collide(q)
        if len(idx):
            with_contact += 1
            np.add.at(contact_hits, idx, 1)
            touched = np.zeros(npair, dtype=bool)
            touched[idx] = True
            pose_hits += touched
        if measure is not None:
            d = measure(q)
            better = d < closest
            closest[better] = d[better]
            closest_at[better] = i
            # Cross-check: the engine's touching pairs against MuJoCo's contact pairs.
            fuzzy = np.abs(d - thr) < AMBIGUITY_BAND
            listed = np.zeros(npair, dtype=bool)
            listed[idx] = True
            if (((d < thr) != listed) & ~fuzzy).any():
                disagree += 1
    seconds = time.perf_counter() - t0
    stats = tuple(
        PairStatistics(
            p,
            int(pose_hits[k]),
            int(contact_hits[k]),
            float(closest[k]) if distances is not None and len(Q) else float("nan"),
            int(closest_at[k]),
        )
        for k, p in enumerate(ch.pairs)
    )
    return CollisionStatistics(
        n_poses=len(Q),
        seed=seed if poses is None else None,
        distance_engine=distances,
        poses_with_contact=with_contact,
        pairs=stats,
        keyframes=keyframe_clearance(arm, distances or "coal"),
        disagreements=disagree if distances is not None else -1,
        seconds=seconds,
    )


def keyframe_clearance(arm: Arm, engine: DistanceEngine = "coal") -> tuple[KeyframeClearance, ...]:
    """Contacts and the closest pair at every keyframe of the model."""
    ch = checker(arm)
    out = []
    for name, q in arm.keyframes.items():
        out.append(KeyframeClearance(name, q, len(ch.contacts(q)), ch.distances(q, engine).closest))
    return tuple(out)

"""coal distances for a pair set, the geoms placed by Pinocchio's forward kinematics.

Each geom becomes a Pinocchio ``GeometryObject`` attached to the BODY frame that Pinocchio's MJCF
parser creates for the geom's body, at MuJoCo's compiled geom pose in that body (``geom_pos``,
``geom_quat``, which for a mesh include MuJoCo's recentring of the mesh). Only the shapes and their
offsets in their bodies come from MuJoCo; every body pose comes from Pinocchio. A mesh geom becomes
a coal convex polytope spanned by the vertices MuJoCo's own support function searches (`mesh_hull`):
both engines collide the same convex solid, which for a non-convex mesh is its hull, not the mesh.

`CoalPairs` (shapes, ``GeometryModel``) is built once and only read; each thread gets a `CoalScene`
with its own Pinocchio ``Data`` and ``GeometryData``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import UnsupportedFeatureError
from ..model.names import display_names, geom_name
from .pairs import GeomPair
from .shapes import bounding_radius, geom_type_name, mesh_hull

if TYPE_CHECKING:
    import coal
    import pinocchio as pin

Array = NDArray[np.float64]
Index = NDArray[np.int_]

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
#: coal reports a failed EPA as -DBL_MAX (or a non-finite value); a distance below this is
#: such a failure, no overlap of the geoms here being anywhere near that deep [m].
EPA_FAILURE = -1e6

_G = mujoco.mjtGeom


def coal_shape(model: mujoco.MjModel, geom: int) -> coal.CollisionGeometry:
    """A coal shape for a geom (`_coal_shape`), its local bounding box computed (GJK's guess)."""
    shape = _coal_shape(model, geom)
    shape.computeLocalAABB()
    return shape


def _coal_shape(model: mujoco.MjModel, geom: int) -> coal.CollisionGeometry:
    """A coal shape equal to the solid MuJoCo collides for a geom, in the geom's own frame.

    MuJoCo's compiled ``geom_size`` holds half-sizes: sphere (r), capsule and cylinder (r,
    half-length along z), box (half-sides), ellipsoid (semi-axes); a plane is the half-space z <= 0
    of its frame. coal's constructors take full lengths. A mesh is the convex polytope of
    `mesh_hull`: MuJoCo's hull graph where MuJoCo climbs it, else the hull of every vertex (computed
    by coal's qhull).

    Raises:
        UnsupportedFeatureError: Height field or SDF geoms, or a mesh whose vertices span
            no solid (all in one plane).
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
    if t == _G.mjGEOM_MESH:
        return _convex(model, geom)
    raise UnsupportedFeatureError(
        f"{geom_type_name(model, geom)} geom",
        f"geom {geom_name(model, geom)!r}",
        "distances are computed for primitive and mesh geoms only",
    )


def _convex(model: mujoco.MjModel, geom: int) -> coal.ConvexBase:
    """The coal polytope of a mesh geom's hull (see `coal_shape`)."""
    import coal

    hull = mesh_hull(model, geom)
    points = coal.StdVec_Vec3s()
    for p in hull.points:
        points.append(p)
    # coal keeps at most 255 neighbours per vertex (a uint8) and raises "Too many neighbors"
    # on a hull where more faces meet at one vertex (a fan-triangulated cap of a scanned
    # part: Centauro's arm, 566 faces at one vertex); qhull's own triangulation of the same
    # points spans the same solid.
    if hull.faces is not None and np.bincount(hull.faces.ravel()).max(initial=0) <= 255:
        triangles = coal.StdVec_Triangle()
        for a, b, c in hull.faces.tolist():
            triangles.append(coal.Triangle(a, b, c))
        return coal.Convex(points, triangles)
    try:
        # MuJoCo searches every vertex: the solid is their hull, whatever the mesh's faces.
        return coal.ConvexBase.convexHull(points, False, None)
    except Exception as err:  # qhull's errors come through as bare C++ exceptions
        raise UnsupportedFeatureError(
            "flat mesh",
            f"geom {geom_name(model, geom)!r} (mesh {hull.mesh!r})",
            f"its {hull.vertices} vertices span no solid for coal's convex hull ({err})",
        ) from err


def epa_failed(d: ArrayLike) -> NDArray[np.bool_]:
    """Where coal's distances ``d`` are EPA failures: below `EPA_FAILURE` or not finite."""
    d = np.asarray(d)
    return ~np.isfinite(d) | (d < EPA_FAILURE)


def distance_request() -> coal.DistanceRequest:
    """The coal distance request this package uses: signed, tight GJK, robust EPA."""
    import coal

    req = coal.DistanceRequest()
    req.enable_signed_distance = True  # penetration depth (EPA) instead of 0 on overlap
    req.gjk_tolerance = COAL_GJK_TOLERANCE
    req.gjk_max_iterations = COAL_MAX_ITERATIONS
    req.epa_tolerance = COAL_EPA_TOLERANCE
    req.epa_max_iterations = COAL_MAX_ITERATIONS
    # GJK starts from the shapes' bounding boxes (computed in `coal_shape`), not from the
    # last call's answer on the pair (coal's default): the same pose gives the same distance
    # whatever was asked before, so a pruned sweep equals an exhaustive one to the bit, and
    # it converges in fewer steps on the G1's meshes (2.1 vs 2.9 ms per pose, all pairs).
    req.gjk_initial_guess = coal.GJKInitialGuess.BoundingVolumeGuess
    return req


def _quat_matrix(quat: ArrayLike) -> Array:
    """Rotation matrix of a MuJoCo quaternion (w, x, y, z)."""
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, np.asarray(quat, dtype=float))
    return mat.reshape(3, 3)


class CoalPairs:
    """The shapes and Pinocchio ``GeometryModel`` of a pair set, shared by every thread.

    Args:
        model: MuJoCo's compiled model (shapes and their offsets in their bodies).
        pin_model: Pinocchio's model of the same arm (body poses).
        perm: ``perm[i]`` is Pinocchio's configuration index of the library's joint ``i``.
        pairs: The pair set.

    Raises:
        UnsupportedFeatureError: A geom coal cannot represent, or one on a body Pinocchio
            does not name.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        pin_model: pin.Model,
        perm: NDArray[np.int_],
        pairs: Sequence[GeomPair],
    ) -> None:
        import pinocchio as pin

        self.model = model
        self.pin_model = pin_model
        self.perm: NDArray[np.int_] = np.asarray(perm)
        self.pairs: tuple[GeomPair, ...] = tuple(pairs)
        used = sorted({p.geom1 for p in self.pairs} | {p.geom2 for p in self.pairs})
        self._names = display_names(model, mujoco.mjtObj.mjOBJ_GEOM)
        self.geom_model: pin.GeometryModel = pin.GeometryModel()
        self.slot: dict[int, int] = {}  # MuJoCo geom id -> GeometryObject index
        for g in used:
            self.slot[g] = self.geom_model.addGeometryObject(self._geometry_object(g))
        for p in self.pairs:
            self.geom_model.addCollisionPair(
                pin.CollisionPair(self.slot[p.geom1], self.slot[p.geom2])
            )
        # Pair k of the GeometryModel must be pair k of the set; coal may store it swapped.
        for k, p in enumerate(self.pairs):
            cp = self.geom_model.collisionPairs[k]
            assert {cp.first, cp.second} == {self.slot[p.geom1], self.slot[p.geom2]}
        self.swapped: list[bool] = [
            self.geom_model.collisionPairs[k].first != self.slot[p.geom1]
            for k, p in enumerate(self.pairs)
        ]
        self.radius: dict[int, float] = {g: bounding_radius(model, g) for g in used}

    def _geometry_object(self, g: int) -> pin.GeometryObject:
        import pinocchio as pin

        m = self.model
        body = int(m.geom_bodyid[g])
        gname = self._names[g]
        local = pin.SE3(_quat_matrix(m.geom_quat[g]), m.geom_pos[g].copy())
        if body == 0:
            # The world body is Pinocchio's universe: joint 0, frame 0, identity placement.
            return pin.GeometryObject(gname, 0, 0, local, coal_shape(m, g))
        bname = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, body)
        if m.body_weldid[body] == 0 and not (
            bname and self.pin_model.existFrame(bname, pin.FrameType.BODY)
        ):
            # A body welded to the world that Pinocchio was not given (another tree of the
            # robot, held): it never moves, so its place is its fixed pose in the file.
            return pin.GeometryObject(gname, 0, 0, _static_pose(m, body) * local, coal_shape(m, g))
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


def _static_pose(m: mujoco.MjModel, body: int) -> pin.SE3:
    """World pose of a body welded to the world: its placements in its parents, composed."""
    import pinocchio as pin

    pose = pin.SE3.Identity()
    while body != 0:
        pose = pin.SE3(_quat_matrix(m.body_quat[body]), m.body_pos[body].copy()) * pose
        body = int(m.body_parentid[body])
    return pose


class CoalScene:
    """One thread's coal workspace for a pair set (see `CoalPairs`)."""

    def __init__(self, shared: CoalPairs) -> None:
        import pinocchio as pin

        self.shared = shared
        self.pairs: tuple[GeomPair, ...] = shared.pairs
        self.pin_data: pin.Data = shared.pin_model.createData()  # private: never disturbs the Arm's
        self.geom_data: pin.GeometryData = pin.GeometryData(shared.geom_model)
        self._qp = np.zeros(shared.pin_model.nq)
        # GeometryData owns a distance request per pair, which computeDistance(s) reads, and a
        # collision request per pair, which placed_within's computeCollision reads: GJK as
        # tight in both, EPA for the distances only. Pinocchio's own requests turn on GJK warm
        # starts from the previous call, which makes a result depend on the poses queried
        # before it (by up to 1e-6 m for EPA depths); fresh coal requests have them off (so
        # every result is a function of the pose alone, and faster) and replace them whole:
        # the warm-start flag itself is deprecated, and silencing its warning would change the
        # process-wide warning filters under the user's other threads.
        import coal

        ref = distance_request()
        collide = coal.CollisionRequest()
        collide.enable_contact = False
        collide.gjk_tolerance = ref.gjk_tolerance
        collide.gjk_max_iterations = ref.gjk_max_iterations
        collide.gjk_initial_guess = ref.gjk_initial_guess
        for k in range(len(self.geom_data.distanceRequests)):
            self.geom_data.distanceRequests[k] = ref
        for k in range(len(self.geom_data.collisionRequests)):
            self.geom_data.collisionRequests[k] = collide
        # References into GeometryData's result vector, listed once: building the Python
        # wrappers anew for every pose would cost more than the distances themselves.
        self._results = list(self.geom_data.distanceResults)
        self._retried: dict[int, tuple[float, Array, Array]] = {}

    @property
    def pin_model(self) -> pin.Model:
        """Pinocchio's model (shared, read only)."""
        return self.shared.pin_model

    @property
    def geom_model(self) -> pin.GeometryModel:
        """The pair set's ``GeometryModel`` (shared, read only)."""
        return self.shared.geom_model

    def place(self, q: Array) -> None:
        """Place the geoms at ``q`` (library joint order)."""
        import pinocchio as pin

        s = self.shared
        self._qp[s.perm] = q
        # forwardKinematics fills oMi; updateGeometryPlacements composes oMg = oMi * placement.
        pin.forwardKinematics(s.pin_model, self.pin_data, self._qp)
        pin.updateGeometryPlacements(s.pin_model, self.pin_data, s.geom_model, self.geom_data)

    def geom_pose(self, g: int) -> tuple[Array, Array]:
        """World position [m] and rotation of geom ``g`` after `place`."""
        oMg = self.geom_data.oMg[self.shared.slot[g]]
        return oMg.translation.copy(), oMg.rotation.copy()

    def distance_values(self, q: Array) -> Array:
        """Signed distance of every pair at ``q`` [m] (no nearest points)."""
        out = self._raw_values(q)
        return self._redo_failures(out, np.arange(len(out)))

    def _raw_values(self, q: Array) -> Array:
        self._qp[self.shared.perm] = q
        return np.array(self.pin_values(self._qp))

    def pin_values(self, qp: Array) -> list[float]:
        """Signed distance of every pair at ``qp``, in Pinocchio's joint order [m].

        As coal reports them: an EPA failure is not redone (see `epa_failed`).
        """
        import pinocchio as pin

        s = self.shared
        # computeDistances = forwardKinematics + updateGeometryPlacements + coal.distance on
        # every collision pair, in one C++ loop.
        pin.computeDistances(s.pin_model, self.pin_data, s.geom_model, self.geom_data, qp)
        return [r.min_distance for r in self._results]

    def placed_values(self, which: Index, apart: Array | None = None) -> Array:
        """Signed distances of the pairs in ``which`` at the pose last placed [m].

        The same coal call, request and result as `distance_values`, pair by pair (``apart`` is
        accepted for the MuJoCo scene's signature and not needed).
        """
        import pinocchio as pin

        s = self.shared
        compute = pin.computeDistance
        out = np.array(
            [compute(s.geom_model, self.geom_data, k).min_distance for k in which.tolist()],
            dtype=float,
        )
        return self._redo_failures(out, which)

    def placed_normals(self, which: Index) -> Array:
        """Unit normals of the last distances of the pairs in ``which``, shape (len, 3).

        World frame, from each pair's ``geom1`` to its ``geom2`` as coal reports them (for a
        separated pair the direction between the nearest points, for an overlap the direction
        of least penetration); NaN where the distance was redone after an EPA failure.
        """
        res, swapped, retried = self._results, self.shared.swapped, self._retried
        out = np.empty((len(which), 3))
        for n, k in enumerate(which.tolist()):
            if k in retried:
                out[n] = np.nan
                continue
            out[n] = res[k].normal
            if swapped[k]:
                out[n] *= -1.0
        return out

    def placed_within(self, which: Index, limits: Array) -> NDArray[np.bool_]:
        """Whether each pair in ``which`` is nearer than its limit at the pose last placed.

        coal's collision test with the limit as its security margin [m]: GJK at the distance
        requests' tolerance, stopping once it finds the geoms within the margin, with no EPA
        depth (separated geoms run to convergence, as ``distance_upper_bound`` is left
        unbounded); a pair within about that tolerance of its limit may come out either way.
        """
        import pinocchio as pin

        s, reqs = self.shared, self.geom_data.collisionRequests
        compute = pin.computeCollision
        out = np.zeros(len(which), dtype=bool)
        for n, (k, limit) in enumerate(zip(which.tolist(), limits.tolist(), strict=True)):
            reqs[k].security_margin = limit
            out[n] = compute(s.geom_model, self.geom_data, k)
        return out

    def _redo_failures(self, out: Array, which: Index) -> Array:
        self._retried = {}
        if not len(out) or np.min(out) > EPA_FAILURE:  # NaN fails the test too
            return out
        bad = epa_failed(out)
        self._retried = {int(which[i]): self._retry(int(which[i])) for i in np.flatnonzero(bad)}
        for i in np.flatnonzero(bad):
            out[i] = self._retried[int(which[i])][0]
        return out

    def distances(self, q: Array) -> tuple[Array, Array, Array]:
        """Signed distance and nearest points (world frame) of every pair at ``q`` [m]."""
        dist = self.distance_values(q)
        n = len(self.pairs)
        p1, p2 = np.zeros((n, 3)), np.zeros((n, 3))
        for k, r in enumerate(self._results):
            if k in self._retried:  # already in the pair's geom order
                p1[k], p2[k] = self._retried[k][1], self._retried[k][2]
                continue
            a, b = r.getNearestPoint1(), r.getNearestPoint2()
            p1[k], p2[k] = (b, a) if self.shared.swapped[k] else (a, b)
        return dist, p1, p2

    def _retry(self, k: int) -> tuple[float, Array, Array]:
        """Recompute pair ``k`` with a looser EPA after a failure (coal returns -DBL_MAX).

        EPA can fail on deep overlaps of curved shapes; the geoms then overlap for sure, so a
        depth from a looser EPA is kept, and if that fails too, the (negative) opposite of
        the sum of the bounding radii, a bound no overlap can exceed.
        """
        import coal

        s = self.shared
        pair = self.pairs[k]
        slots = [s.slot[pair.geom1], s.slot[pair.geom2]]
        objs = [s.geom_model.geometryObjects[i] for i in slots]
        tfs = [self.geom_data.oMg[i] for i in slots]
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
        if not epa_failed(d):
            return float(d), res.getNearestPoint1(), res.getNearestPoint2()
        return (
            -(s.radius[pair.geom1] + s.radius[pair.geom2]),
            tfs[0].translation.copy(),
            tfs[1].translation.copy(),
        )

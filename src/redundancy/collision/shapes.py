"""The shapes MuJoCo collides, read from its compiled model: sizes, mesh hulls, bounding radii.

MuJoCo collides a mesh geom as the convex hull of its vertices. The compiler recentres and
re-orients every mesh (its vertices are stored in the mesh's own frame, ``mesh_vert``, in
single precision) and folds that offset into the geom's compiled ``geom_pos``/``geom_quat``,
so the hull below, placed at the geom's compiled pose, is the solid MuJoCo collides.

Which vertices span that hull is MuJoCo's support-function rule (``mjc_initCCDObj`` in
engine_collision_convex.c): a mesh with a convex-hull graph (``mesh_graphadr >= 0``) and at least
`HILLCLIMB_MIN` vertices is searched by hill climbing over the graph's vertices; otherwise every
vertex is searched. A support function determines a convex solid, so a polytope spanned by the same
vertices is the same solid whatever its faces.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from ..errors import UnsupportedFeatureError
from ..model.names import geom_name

Array = NDArray[np.float64]

_G = mujoco.mjtGeom

#: MuJoCo's ``mjMESH_HILLCLIMB_MIN``: meshes with fewer vertices are searched exhaustively.
HILLCLIMB_MIN = 10


def geom_type_name(model: mujoco.MjModel, geom: int) -> str:
    """MuJoCo's short name of a geom's type (``"capsule"``...)."""
    return mujoco.mjtGeom(model.geom_type[geom]).name.removeprefix("mjGEOM_").lower()


@dataclass(frozen=True)
class Hull:
    """The convex solid MuJoCo collides for a mesh geom, in the geom's frame.

    Attributes:
        points: Vertices that span it, shape (n, 3) [m] (MuJoCo's single-precision values).
        faces: Triangles over ``points`` from MuJoCo's hull graph, shape (f, 3); None where MuJoCo
            searches every vertex (no graph, or fewer than `HILLCLIMB_MIN`).
        mesh: Name of the mesh asset.
        vertices: Number of vertices of the mesh as written (the hull may use fewer).
    """

    points: Array
    faces: NDArray[np.int_] | None
    mesh: str
    vertices: int

    @property
    def radius(self) -> float:
        """Largest distance of a hull point from the geom's origin [m]."""
        return float(np.linalg.norm(self.points, axis=1).max())


def mesh_hull(model: mujoco.MjModel, geom: int) -> Hull:
    """The hull MuJoCo collides for mesh geom ``geom`` (see the module docstring).

    Raises:
        UnsupportedFeatureError: ``geom`` is not a mesh geom.
    """
    if int(model.geom_type[geom]) != _G.mjGEOM_MESH:
        raise UnsupportedFeatureError(
            f"{geom_type_name(model, geom)} geom",
            f"geom {geom_name(model, geom)!r}",
            "only mesh geoms have a hull",
        )
    mesh = int(model.geom_dataid[geom])
    vadr, nvert = int(model.mesh_vertadr[mesh]), int(model.mesh_vertnum[mesh])
    verts = model.mesh_vert[vadr : vadr + nvert].astype(float)
    name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_MESH, mesh) or f"mesh {mesh}"
    adr = int(model.mesh_graphadr[mesh])
    if adr < 0 or nvert < HILLCLIMB_MIN:
        return Hull(verts, None, name, nvert)
    # mesh_graph layout (user_mesh.cc): numvert, numface, vert_edgeadr[numvert],
    # vert_globalid[numvert], edge_localid[numvert + 3 numface], face_globalid[3 numface];
    # global ids index this mesh's vertices.
    graph = model.mesh_graph
    nv, nf = int(graph[adr]), int(graph[adr + 1])
    globalid = np.asarray(graph[adr + 2 + nv : adr + 2 + 2 * nv], dtype=int)
    start = adr + 2 + 3 * nv + 3 * nf
    faces = np.asarray(graph[start : start + 3 * nf], dtype=int).reshape(nf, 3)
    local = np.full(nvert, -1, dtype=int)
    local[globalid] = np.arange(nv)
    return Hull(verts[globalid], local[faces], name, nvert)


def bounding_radius(model: mujoco.MjModel, geom: int) -> float:
    """Radius of a sphere about the geom's origin that contains the geom [m].

    Exact for every primitive, the largest hull-vertex norm for a mesh (tighter than
    MuJoCo's ``geom_rbound``, which bounds the mesh's bounding box), infinite for a plane.
    """
    t = int(model.geom_type[geom])
    s = model.geom_size[geom]
    if t == _G.mjGEOM_SPHERE:
        return float(s[0])
    if t == _G.mjGEOM_CAPSULE:
        return float(s[0] + s[1])
    if t == _G.mjGEOM_CYLINDER:
        return float(np.hypot(s[0], s[1]))
    if t == _G.mjGEOM_BOX:
        return float(np.linalg.norm(s[:3]))
    if t == _G.mjGEOM_ELLIPSOID:
        return float(np.max(s[:3]))
    if t == _G.mjGEOM_MESH:
        return mesh_hull(model, geom).radius
    if t == _G.mjGEOM_PLANE:
        return float("inf")
    return float(model.geom_rbound[geom])


def bounding_box(model: mujoco.MjModel, geom: int) -> tuple[Array, Array]:
    """A box in the geom's frame that contains the geom: its centre and half sizes [m].

    Exact for every primitive and for a mesh's hull (the hull points' extent); infinite
    half sizes for a plane and any other unbounded type.
    """
    t = int(model.geom_type[geom])
    s = model.geom_size[geom].astype(float)
    zero = np.zeros(3)
    if t == _G.mjGEOM_SPHERE:
        return zero, np.full(3, s[0])
    if t == _G.mjGEOM_CAPSULE:
        return zero, np.array([s[0], s[0], s[0] + s[1]])
    if t == _G.mjGEOM_CYLINDER:
        return zero, np.array([s[0], s[0], s[1]])
    if t in (_G.mjGEOM_BOX, _G.mjGEOM_ELLIPSOID):
        return zero, s[:3].copy()
    if t == _G.mjGEOM_MESH:
        pts = mesh_hull(model, geom).points
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        return 0.5 * (lo + hi), 0.5 * (hi - lo)
    return zero, np.full(3, np.inf)


#: Directions per block in `Support` for a mesh.
_BLOCK = 64


class Support:
    """The support function of the solid MuJoCo collides for a geom, in the geom's frame.

    ``h(v) = max over the solid's points p of v . p`` for directions ``v`` (unit vectors,
    one coordinate per row, shape (3, k)) [m]: closed forms for the primitives, the largest
    projection of the hull's points for a mesh, ``inf`` for a plane and any other unbounded
    type.
    """

    def __init__(self, model: mujoco.MjModel, geom: int) -> None:
        self.type: int = int(model.geom_type[geom])
        self.size = model.geom_size[geom].astype(float)
        self.points = mesh_hull(model, geom).points if self.type == _G.mjGEOM_MESH else None
        self._points_t = None if self.points is None else np.ascontiguousarray(self.points.T)
        # The hull's points are MuJoCo's single-precision values: exact in float32.
        self._points_32 = None if self.points is None else self._points_t.astype(np.float32)
        # float32's error on a projection v . p (|v| = 1): the rounding of v and of the three
        # products and two sums, each within 2^-24 of its value, is at most 4 * 2^-24 * |p|_1;
        # twice that covers it (`upper`) [m].
        self._err_32 = (
            0.0 if self.points is None else 2.0**-21 * float(np.abs(self.points).sum(axis=1).max())
        )

    def __call__(self, v: Array) -> Array:
        """``h`` at each column of ``v`` [m]."""
        t, s = self.type, self.size
        if t == _G.mjGEOM_SPHERE:
            return np.full(v.shape[1], s[0])
        if t == _G.mjGEOM_CAPSULE:
            return s[0] + s[1] * np.abs(v[2])
        if t == _G.mjGEOM_CYLINDER:
            return s[0] * np.sqrt(v[0] * v[0] + v[1] * v[1]) + s[1] * np.abs(v[2])
        if t == _G.mjGEOM_BOX:
            return s[0] * np.abs(v[0]) + s[1] * np.abs(v[1]) + s[2] * np.abs(v[2])
        if t == _G.mjGEOM_ELLIPSOID:
            return np.sqrt((s[0] * v[0]) ** 2 + (s[1] * v[1]) ** 2 + (s[2] * v[2]) ** 2)
        if self._points_t is not None:
            # Directions a block at a time, each block's projections a small row-major
            # (block x points) array reduced along its rows: it stays in cache and BLAS
            # stays single-threaded, where one (points x k) product does neither (10x slower
            # for a 2000-point hull and 20000 directions).
            vt = np.ascontiguousarray(v.T)
            out = np.empty(vt.shape[0])
            for s in range(0, len(vt), _BLOCK):
                out[s : s + _BLOCK] = (vt[s : s + _BLOCK] @ self._points_t).max(axis=1)
            return out
        return np.full(v.shape[1], np.inf)

    def upper(self, v: Array) -> Array:
        """An upper bound of ``h`` at each column of ``v`` (unit vectors), within 1e-6 of it [m].

        ``h`` itself for the primitives; for a mesh, the projections computed in float32 (the
        hull's points are exact there, twice as many products per second) plus a bound of
        float32's error.
        """
        if self._points_32 is None:
            return self(v)
        vt = np.ascontiguousarray(v.T, dtype=np.float32)
        out = np.empty(vt.shape[0])
        for s in range(0, len(vt), _BLOCK):
            out[s : s + _BLOCK] = (vt[s : s + _BLOCK] @ self._points_32).max(axis=1)
        out += self._err_32
        return out

"""What the lab draws: each geom as a triangle mesh, a colour per link, rotations as quaternions.

Pure functions of MuJoCo's compiled model (sizes, meshes, the body tree); the page places the
meshes where the simulation puts the geoms.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from ..errors import MissingDependencyError

try:
    import trimesh
except ImportError as _err:  # pragma: no cover - exercised only without the extra
    raise MissingDependencyError("trimesh", "lab") from _err

Array = NDArray[np.float64]

__all__ = [
    "BASE_COLOR",
    "LINK_COLORS",
    "drawn_geoms",
    "geom_mesh",
    "link_colors",
    "mat_to_quat",
    "quat_to_mat",
    "rgb",
]

#: One colour per link (cycled), and the colour of geoms on bodies without joints.
LINK_COLORS = (
    (76, 114, 176),
    (221, 132, 82),
    (85, 168, 104),
    (196, 78, 82),
    (129, 114, 179),
    (147, 120, 96),
    (218, 139, 195),
    (140, 140, 140),
    (204, 185, 116),
    (100, 181, 205),
)
BASE_COLOR = (120, 120, 125)


def rgb(rgba: Array) -> tuple[int, int, int]:
    """An RGBA colour in [0, 1] as 8-bit RGB."""
    r, g, b = (round(255 * float(c)) for c in rgba[:3])
    return r, g, b


def geom_mesh(model: mujoco.MjModel, g: int) -> trimesh.Trimesh | None:
    """A triangle mesh of a primitive geom in its own frame (None for planes and others)."""
    size = model.geom_size[g]
    kind = mujoco.mjtGeom(model.geom_type[g])
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return trimesh.creation.box(extents=2 * size)
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return trimesh.creation.icosphere(subdivisions=2, radius=size[0])
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        return trimesh.creation.capsule(height=2 * size[1], radius=size[0], count=[24, 12])
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return trimesh.creation.cylinder(radius=size[0], height=2 * size[1], sections=32)
    if kind == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
        mesh.apply_scale(size)
        return mesh
    if kind == mujoco.mjtGeom.mjGEOM_MESH:
        mid = int(model.geom_dataid[g])
        v0, nv = int(model.mesh_vertadr[mid]), int(model.mesh_vertnum[mid])
        f0, nf = int(model.mesh_faceadr[mid]), int(model.mesh_facenum[mid])
        # MuJoCo stores a mesh's vertices in the geom's frame (re-centred on compile).
        return trimesh.Trimesh(
            model.mesh_vert[v0 : v0 + nv].copy(),
            model.mesh_face[f0 : f0 + nf].copy(),
            process=False,
        )
    return None


def drawn_geoms(model: mujoco.MjModel) -> list[int]:
    """Geoms to draw: the visual ones (no collision bits) if any, else every drawable geom."""
    drawable = [g for g in range(model.ngeom) if geom_mesh(model, g) is not None]
    visual = [g for g in drawable if model.geom_contype[g] == 0 and model.geom_conaffinity[g] == 0]
    return visual or drawable


def link_colors(model: mujoco.MjModel) -> dict[int, tuple[int, int, int]]:
    """A colour per body that moves (a palette cycled in tree order); fixed bodies grey."""
    out: dict[int, tuple[int, int, int]] = {}
    k = 0
    for b in range(1, model.nbody):
        moving = model.body_weldid[b] != 0
        if moving and model.body_jntnum[b] > 0:
            out[b] = LINK_COLORS[k % len(LINK_COLORS)]
            k += 1
        elif moving:  # welded to a moving parent: the parent's colour
            out[b] = out.get(int(model.body_weldid[b]), BASE_COLOR)
        else:
            out[b] = BASE_COLOR
    return out


def quat_to_mat(wxyz: Any) -> Array:
    """The rotation matrix of a unit quaternion (w, x, y, z)."""
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, np.asarray(wxyz, dtype=float))
    return R.reshape(3, 3)


def mat_to_quat(R: Array) -> Array:
    """The unit quaternion (w, x, y, z) of a rotation matrix."""
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R, dtype=float).reshape(9))
    return q

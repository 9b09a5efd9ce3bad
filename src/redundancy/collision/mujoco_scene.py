"""MuJoCo's own answers for a pair set: ``mj_geomDistance`` per pair, ``mj_collision``'s contacts.

A `MujocoScene` owns one ``MjData`` and is used by one thread at a time (the checker keeps one per
thread); the compiled model is shared and only read.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from ..errors import RedundancyError
from .pairs import GeomPair
from .shapes import bounding_radius

Array = NDArray[np.float64]
Index = NDArray[np.int_]


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


class MujocoPairs:
    """What every thread's scene shares: the model and the pair set's geom ids (read only).

    Args:
        model: MuJoCo's compiled model.
        pairs: The pair set.
    """

    def __init__(self, model: mujoco.MjModel, pairs: Sequence[GeomPair]) -> None:
        self.model = model
        self.pairs: tuple[GeomPair, ...] = tuple(pairs)
        self.g1: NDArray[np.int_] = np.array([p.geom1 for p in self.pairs], dtype=int)
        self.g2: NDArray[np.int_] = np.array([p.geom2 for p in self.pairs], dtype=int)
        # index[g1, g2] = position of the pair in the set (-1: not a pair).
        self.index: NDArray[np.int_] = np.full((model.ngeom, model.ngeom), -1, dtype=int)
        self.index[self.g1, self.g2] = np.arange(len(self.pairs))
        self.index[self.g2, self.g1] = np.arange(len(self.pairs))
        # mj_geomDistance returns min(distance, distmax). The distance never exceeds
        # |c1 - c2| + r1 + r2 (each geom lies within its bounding radius of its origin; a
        # plane's origin is on it, so 0 there), so a cap of that plus 1 m never binds.
        plane = int(mujoco.mjtGeom.mjGEOM_PLANE)
        radius = np.array(
            [
                0.0 if int(model.geom_type[g]) == plane else bounding_radius(model, g)
                for g in range(model.ngeom)
            ]
        )
        self.cap_offset: Array = radius[self.g1] + radius[self.g2] + 1.0
        self.ids: list[tuple[int, int]] = list(zip(self.g1.tolist(), self.g2.tolist(), strict=True))


class MujocoScene:
    """One thread's MuJoCo workspace for a pair set (see `MujocoPairs`)."""

    def __init__(self, shared: MujocoPairs) -> None:
        self.shared = shared
        self.model: mujoco.MjModel = shared.model
        self.pairs: tuple[GeomPair, ...] = shared.pairs
        # A private MjData: the contact list and geom poses here never disturb the Arm's.
        self.data: mujoco.MjData = mujoco.MjData(shared.model)
        self._fromto = np.zeros(6)

    @property
    def g1(self) -> Index:
        """First geom id of every pair."""
        return self.shared.g1

    @property
    def g2(self) -> Index:
        """Second geom id of every pair."""
        return self.shared.g2

    def place(self, q: Array) -> None:
        """Place the geoms at ``q`` (``data.geom_xpos``/``geom_xmat``), as the coal scene does."""
        self.data.qpos[:] = q
        # mj_kinematics is all collision needs: geom_xpos/xmat for the colliders and
        # xipos/ximat for the bodies' bounding boxes (broad and mid phase).
        mujoco.mj_kinematics(self.model, self.data)

    def collide(self, q: Array) -> tuple[Index, Array]:
        """Run MuJoCo's collision pipeline at ``q``; (pair index, distance) per contact."""
        m, d = self.model, self.data
        d.qpos[:] = q  # `place`, inline: this runs once per pose of every sweep
        mujoco.mj_kinematics(m, d)
        # mj_collision: broad phase, the pair filters and narrow phase, as in mj_forward.
        mujoco.mj_collision(m, d)
        n = d.ncon
        if n == 0:
            return np.zeros(0, dtype=int), np.zeros(0)
        contact = d.contact  # one view of the contact list (each access builds one)
        geoms = contact.geom[:n]
        idx = self.shared.index[geoms[:, 0], geoms[:, 1]]
        if idx.min() < 0 or geoms.min() < 0:
            bad = geoms[np.flatnonzero((idx < 0) | (geoms < 0).any(axis=1))[0]]
            raise RedundancyError(
                f"MuJoCo listed a contact between geoms {bad.tolist()}, which is not in the pair "
                "set built from its filtering rules; please report this model"
            )
        return idx, contact.dist[:n].copy()

    def contacts(self, q: Array) -> tuple[Contact, ...]:
        """MuJoCo's contact list at ``q``, normals from each pair's ``geom1`` to ``geom2``."""
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

    def caps(self, which: Index | None = None) -> list[float]:
        """``distmax`` per pair (all, or those in ``which``) after `place`."""
        s = self.shared
        sel = slice(None) if which is None else which
        xpos = self.data.geom_xpos
        return (
            np.linalg.norm(xpos[s.g1[sel]] - xpos[s.g2[sel]], axis=1) + s.cap_offset[sel]
        ).tolist()

    def distances(self, q: Array) -> tuple[Array, Array, Array]:
        """Signed distance and nearest points of every pair from ``mj_geomDistance``."""
        self.place(q)
        m, d = self.model, self.data
        n = len(self.pairs)
        dist, p1, p2 = np.zeros(n), np.zeros((n, 3)), np.zeros((n, 3))
        fromto = self._fromto
        geom_distance = mujoco.mj_geomDistance
        for k, ((g1, g2), cap) in enumerate(zip(self.shared.ids, self.caps(), strict=True)):
            dist[k] = geom_distance(m, d, g1, g2, cap, fromto)
            p1[k], p2[k] = fromto[:3], fromto[3:]
        return dist, p1, p2

    def distance_values(self, q: Array) -> Array:
        """Signed distance of every pair at ``q`` [m]."""
        self.place(q)
        return self.placed_values(np.arange(len(self.pairs)))

    def placed_values(self, which: Index, apart: Array | None = None) -> Array:
        """Signed distances of the pairs in ``which`` at the pose last placed [m].

        Args:
            which: Pair indices.
            apart: The geoms' origins' separation per pair in ``which``, if known [m]
                (``|geom_xpos[g1] - geom_xpos[g2]|``, as `caps` computes it).
        """
        m, d, ids = self.model, self.data, self.shared.ids
        geom_distance = mujoco.mj_geomDistance
        if apart is None:
            caps = self.caps(which)
        else:
            caps = (apart + self.shared.cap_offset[which]).tolist()
        pairs = zip(which.tolist(), caps, strict=True)
        return np.array([geom_distance(m, d, *ids[k], c, None) for k, c in pairs], dtype=float)

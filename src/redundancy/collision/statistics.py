"""Collision statistics over random poses and clearance at the keyframes."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..arm import random_pose_chunks
from ..checks import check_choice, check_count, check_flag, check_poses
from .checker import CollisionChecker, checker
from .coal_scene import CoalScene
from .mujoco_scene import Index, MujocoScene
from .pairs import AMBIGUITY_BAND, DISTANCE_ENGINES, Array, DistanceEngine
from .results import CollisionStatistics, ContactShare, KeyframeClearance, PairStatistics
from .shapes import Support, bounding_box, bounding_radius

if TYPE_CHECKING:
    from ..arm import Arm

__all__ = [
    "CHUNK",
    "CollisionStatistics",
    "ContactShare",
    "KeyframeClearance",
    "PairStatistics",
    "collision_statistics",
    "keyframe_clearance",
]


#: Poses per chunk of the sweep: memory stays flat in the number of poses.
CHUNK = 1024

#: Slack subtracted from the bounding-sphere lower bound of a pair's distance before a pair
#: is skipped [m]. It covers what separates the bound (from MuJoCo's geom positions) from the
#: engine's computed distance: the engines' placements agree to 1e-9 m (checked when a checker
#: is built), and a separated distance from GJK is the length of a point of the Minkowski
#: difference, never below the true distance by more than rounding.
PRUNE_SLACK = 1e-6


def collision_statistics(
    arm: Arm,
    n_poses: int = 10000,
    seed: int | None = 1,
    distances: DistanceEngine | None = "coal",
    poses: ArrayLike | None = None,
    prune: bool = True,
    keyframes: bool = True,
) -> CollisionStatistics:
    """Self-collision over random poses: contacts by MuJoCo, closest approach by an engine.

    Contacts are MuJoCo's (``mj_kinematics`` + ``mj_collision`` per pose, as the lesson's
    ``mj_forward`` finds them). With ``distances`` set, every pair's signed distance enters the
    closest approach per pair and a cross-check: the engine's touching pairs must equal MuJoCo's
    contact pairs at every pose (pairs within `AMBIGUITY_BAND` of their threshold aside).

    Far pairs are skipped (``prune``): a pair's distance is at least ``|c1 - c2| - r1 - r2`` (geom
    origins, bounding radii), and at least the gap between the two geoms projected on the line
    through their bounding boxes' centres: first with the boxes' extent along it (the tighter bound
    for long links), then with the geoms' own (a mesh's hull points; closed forms for primitives),
    each computed only where the previous one does not decide. A pair whose bound, less
    `PRUNE_SLACK`, exceeds its closest approach so far, its contact threshold (plus the ambiguity
    band) and zero, and that MuJoCo does not list, can change neither its closest approach, nor its
    pose index, nor the cross-check, so its distance is not computed. A pair of mesh hulls that
    MuJoCo lists, whose bound exceeds its closest approach so far, can change only the cross-check:
    coal's collision test (GJK, no penetration depth) against its threshold plus the band stands in
    for its distance (with coal: its EPA never reports an overlap deeper than a separating axis
    allows, which its closed forms for primitives can). Poses go in chunks of `CHUNK`; in each,
    every pair is first measured at the pose with its smallest bound, so that the closest approach
    is known early. The cost then grows with the pairs that come near, and every count and pose
    index equals the unpruned sweep's (``prune=False``), and so does every distance, to the bit:
    coal's GJK starts from the two shapes' bounding boxes (`distance_request`), never from the
    previous call's answer, so a pair's distance at a pose does not depend on which calls came
    before (coal's default guess does: up to 1.9e-7 m on the G1's interpenetrating hulls).

    Args:
        arm: The arm.
        n_poses: Number of random poses (ignored when ``poses`` is given).
        seed: Seed; ``seed=1`` with 10000 poses is the lesson's sample.
        distances: ``"coal"``, ``"mujoco"`` or ``None`` (contacts only, fastest).
        poses: Explicit poses, shape (n, nq) [rad or m], instead of random ones.
        prune: Skip far pairs (same results); False computes every pair at every pose.
        keyframes: Measure the clearance at the keyframes (False: ``keyframes`` is empty,
            for a caller that sweeps a sample in several calls and measures them once).
    """
    if distances is not None:
        check_choice("distance engine", distances, DISTANCE_ENGINES)
    ch = checker(arm)
    prune, keyframes = check_flag("prune", prune), check_flag("keyframes", keyframes)
    chunks, n, seed = _pose_chunks(arm, n_poses, seed, poses)
    sweep = _Sweep(ch, distances, prune)
    t0 = time.perf_counter()
    for block in chunks:
        sweep.run(ch.scene_poses(block))
    seconds = time.perf_counter() - t0
    stats = tuple(
        PairStatistics(
            p,
            int(sweep.pose_hits[k]),
            int(sweep.contact_hits[k]),
            float(sweep.closest[k]) if distances is not None and n else float("nan"),
            int(sweep.closest_at[k]),
        )
        for k, p in enumerate(ch.pairs)
    )
    return CollisionStatistics(
        n_poses=n,
        seed=seed if poses is None else None,
        distance_engine=distances,
        poses_with_contact=sweep.with_contact,
        pairs=stats,
        keyframes=keyframe_clearance(arm, distances or "coal") if keyframes else (),
        disagreements=sweep.disagree if distances is not None else -1,
        seconds=seconds,
    )


def _pose_chunks(
    arm: Arm, n_poses: int, seed: int | None, poses: ArrayLike | None
) -> tuple[Iterable[Array], int, int | None]:
    """The sweep's poses in chunks of `CHUNK` (random unless ``poses`` is given), checked.

    Returns:
        The chunks, the number of poses and the seed (as checked).
    """
    if poses is None:
        n = check_count("n_poses", n_poses, 0)
        if seed is not None:
            seed = check_count("seed", seed, 0)
        chunks: Iterable[Array] = random_pose_chunks(arm, n, seed, CHUNK)
    else:
        Q = check_poses(poses, arm.joint_names)
        n = len(Q)
        chunks = (Q[i : i + CHUNK] for i in range(0, n, CHUNK))
    return chunks, n, seed


class _Sweep:
    """The running counts of `collision_statistics`, fed one chunk of poses at a time.

    The poses are validated before they get here, so the engines' scenes are called
    directly. Every array is per pair, in pair-set order.
    """

    def __init__(self, ch: CollisionChecker, engine: DistanceEngine | None, prune: bool) -> None:
        self.mj = ch.mujoco_scene()
        self.scene: MujocoScene | CoalScene | None = None if engine is None else ch.scene(engine)
        self.prune = prune
        pairs = ch.pairs
        npair = len(pairs)
        self.thr = np.array([p.threshold for p in pairs])
        self.pose_hits = np.zeros(npair, dtype=int)
        self.contact_hits = np.zeros(npair, dtype=int)
        self.closest = np.full(npair, np.inf)
        self.closest_at = np.full(npair, -1)
        self.with_contact = 0
        self.disagree = 0
        self.done = 0  # poses swept before this chunk
        # A pair below this can touch or sit in the ambiguity band: never skipped.
        self.floor = np.maximum(self.thr + AMBIGUITY_BAND, 0.0)
        # Pairs whose overlap depth the engine finds by EPA, which grows a polytope inside
        # the two solids' Minkowski difference: the depth it reports is never more than the
        # true one, so its signed distance never falls below a separating-axis bound. coal
        # does so for two hulls; its closed forms for primitives need not (a sphere of radius
        # 0.22 m swallowing a cylinder on Baxter: coal -0.261 m, the bound -0.234 m, MuJoCo
        # -0.228 m). Only these pairs, listed by MuJoCo, are ever judged by their side alone.
        model = ch.arm.mj_model
        mesh = model.geom_type == mujoco.mjtGeom.mjGEOM_MESH
        self.epa = np.array(
            [engine == "coal" and bool(mesh[p.geom1] and mesh[p.geom2]) for p in pairs], dtype=bool
        )
        used = sorted({p.geom1 for p in pairs} | {p.geom2 for p in pairs})
        col = {g: i for i, g in enumerate(used)}
        self.used = np.array(used, dtype=int)
        self.c1 = np.array([col[p.geom1] for p in pairs], dtype=int)
        self.c2 = np.array([col[p.geom2] for p in pairs], dtype=int)
        radius = np.array([bounding_radius(model, g) for g in used])
        self.rsum = radius[self.c1] + radius[self.c2] + PRUNE_SLACK if npair else np.zeros(0)
        boxes = [bounding_box(model, g) for g in used]
        self.box_centre = np.array([b[0] for b in boxes]).reshape(-1, 3)
        self.box_half = np.array([b[1] for b in boxes]).reshape(-1, 3)
        self.support = [Support(model, g) for g in used]
        # Per pair, a separating axis learnt from the engine (coal's normal at the pair's
        # last seed, in geom1's frame: it turns with geom1) and geom1's support along it;
        # NaN until the pair is measured (see `_witness_bound`).
        self.axis = np.full((npair, 3), np.nan)
        self.axis_h1 = np.full(npair, np.nan)

    def run(self, Q: Array) -> None:
        """Sweep one chunk of poses."""
        npair = len(self.thr)
        listed = np.zeros((len(Q), npair), dtype=bool)
        # The pruning bounds' inputs, read only by a pruned sweep with distances: geom
        # origins and rotations (row-major), one coordinate per plane.
        pruned = self.prune and self.scene is not None and npair > 0
        # Every geom's pose copied whole per pose (a plain copy), the used ones gathered and
        # laid out once per chunk; the contacts' pair indices counted once per chunk too.
        ngeom = self.mj.model.ngeom if pruned else 0
        xpos, xmat = np.empty((len(Q), ngeom, 3)), np.empty((len(Q), ngeom, 9))
        data = self.mj.data
        found: list[Index] = []
        for i, q in enumerate(Q):
            idx, _ = self.mj.collide(q)
            if pruned:
                xpos[i] = data.geom_xpos
                xmat[i] = data.geom_xmat
            if len(idx):
                self.with_contact += 1
                found.append(idx)
                listed[i, idx] = True
        if found:
            np.add.at(self.contact_hits, np.concatenate(found), 1)
        if pruned:
            X = np.ascontiguousarray(np.take(xpos, self.used, axis=1).transpose(2, 0, 1))
            R = np.ascontiguousarray(np.take(xmat, self.used, axis=1).transpose(2, 0, 1))
        else:
            X, R = np.zeros((3, len(Q), 0)), np.zeros((9, len(Q), 0))
        self.pose_hits += listed.sum(axis=0)
        if self.scene is not None and npair:
            D = self._measure(Q, X, R, listed) if self.prune else self._measure_all(Q)
            self._fold(D, listed)
        self.done += len(Q)

    def _measure_all(self, Q: Array) -> Array:
        """Every pair's distance at every pose of the chunk."""
        assert self.scene is not None
        return np.array([self.scene.distance_values(q) for q in Q]).reshape(len(Q), -1)

    def _measure(self, Q: Array, X: Array, R: Array, listed: NDArray[np.bool_]) -> Array:
        """The distances that can matter; ``inf`` where a pair is skipped (see above)."""
        scene = self.scene
        assert scene is not None
        D = np.full(listed.shape, np.inf)
        # Origins' separation per pose and pair, as the MuJoCo scene computes it for its
        # mj_geomDistance caps (the same sum of squares in the same order, so the same
        # numbers), one coordinate at a time: far faster than a norm over a length-3 axis.
        # np.take along the geom axis gathers columns far faster than fancy indexing does.
        c1, c2 = self.c1, self.c2
        sq = []
        for x in X:
            d = np.take(x, c1, axis=1)
            d -= np.take(x, c2, axis=1)
            sq.append(d * d)
        apart = np.sqrt(sq[0] + sq[1] + sq[2])
        bound = apart - self.rsum
        # Seed: each pair at the pose of its smallest bound, unless even that bound rules the
        # pair out for the whole chunk.
        cols = np.arange(listed.shape[1])
        at = np.argmin(bound, axis=0)
        worth = bound[at, cols] <= np.maximum(self.closest, self.floor)
        seeds = np.zeros(listed.shape, dtype=bool)
        seeds[at[worth], cols[worth]] = True
        self._evaluate(Q, D, apart, seeds, learn=R)
        # The chunk's smallest distance per pair is at most the seed's: a pair whose bound
        # exceeds that (and its threshold, and zero) at a pose cannot matter there.
        best = np.minimum(self.closest, D.min(axis=0))
        ceiling = np.maximum(best, self.floor)
        todo = bound <= ceiling
        todo |= listed
        todo &= ~seeds
        # One separating axis, where the spheres did not rule the pair out: the boxes'
        # bound, then the geoms' own where the boxes' did not. A pair MuJoCo lists is
        # measured for the cross-check; where its bound exceeds the best distance so far (and
        # the engine's depth respects the bound: `epa`), the distance cannot be the closest
        # approach and only its side of the threshold counts.
        rows, cols = np.nonzero(todo)
        boxes, own = self._axis_bound(X, R, rows, cols)
        lower = boxes
        on_list = listed[rows, cols]
        limit = np.where(on_list, np.where(self.epa[cols], best[cols], np.inf), ceiling[cols])
        near = ~(boxes > limit)
        lower[near] = np.fmax(boxes[near], own(near))
        # A listed pair of hulls left to measure would cost coal's EPA (tens of us): first
        # the bound along the pair's learnt axis (one support function, the tighter bound
        # near the pose it was learnt at), which can leave only its side to test.
        near = ~(lower > limit) & on_list & self.epa[cols] & ~np.isnan(self.axis_h1[cols])
        lower[near] = np.fmax(lower[near], self._witness_bound(X, R, rows[near], cols[near]))
        far = lower > limit
        # A second seed: each pair still to measure at the pose of its smallest bound, first
        # (the bound of the separating axis is far tighter than the spheres' that chose the
        # first seed). The best distance it finds (a measured one) rules out more of the rest.
        keep = np.flatnonzero(~far)
        if len(keep):
            order = keep[np.lexsort((lower[keep], cols[keep]))]
            first = order[np.r_[True, cols[order][1:] != cols[order][:-1]]]
            again = np.zeros(listed.shape, dtype=bool)
            again[rows[first], cols[first]] = True
            self._evaluate(Q, D, apart, again)
            todo &= ~again
            best = np.minimum(best, D.min(axis=0))
            ceiling = np.maximum(best, self.floor)
            limit = np.where(on_list, np.where(self.epa[cols], best[cols], np.inf), ceiling[cols])
            far = lower > limit
            far[first] = False
        todo[rows[far], cols[far]] = False
        # Those listed pairs start with their bound in D, kept if the engine finds them
        # within their threshold plus the band (see _evaluate).
        sided = far & on_list
        side = np.zeros(listed.shape, dtype=bool)
        side[rows[sided], cols[sided]] = True
        D[rows[sided], cols[sided]] = lower[sided]
        self._evaluate(Q, D, apart, todo, side)
        return D

    def _axis_bound(
        self, X: Array, R: Array, rows: NDArray[np.int_], cols: NDArray[np.int_]
    ) -> tuple[Array, Callable[[NDArray[np.bool_]], Array]]:
        """Lower bounds of pairs ``cols`` at poses ``rows`` along one separating axis [m].

        The axis is the unit vector u from the first geom's bounding-box centre to the second's.
        Every point of the first geom lies at most ``h1(R1^T u)`` beyond its origin o1 along u,
        every point of the second at least ``h2(-R2^T u)`` short of o2 (``h`` the support function
        of the geom in its frame, R its rotation), so the geoms are at least ``u . (o2 - o1) - h1 -
        h2`` apart, less `PRUNE_SLACK`; for overlapping geoms, that is a lower bound of the signed
        distance too. Returns the bound with the bounding boxes' support functions (a few flops per
        entry) and a function that gives the bound with the geoms' own (`Support`: exact for every
        primitive and for a mesh's hull, the solid both engines collide; dearer) at the entries a
        mask selects. NaN (never a skip) where the box centres coincide, -inf where a geom is
        unbounded.
        """
        centre, half = self.box_centre, self.box_half
        g1, g2 = self.c1[cols], self.c2[cols]
        # The entries' geoms' poses, gathered by flat (pose, geom) index.
        at1, at2 = rows * X.shape[2] + g1, rows * X.shape[2] + g2
        flat_x, flat_r = X.reshape(3, -1), R.reshape(9, -1)
        o1, r1 = np.take(flat_x, at1, axis=1), np.take(flat_r, at1, axis=1)
        o2, r2 = np.take(flat_x, at2, axis=1), np.take(flat_r, at2, axis=1)

        def local(r: Array, w: Array) -> Array:  # R^T w, one coordinate per row
            return np.array([w[0] * r[i] + w[1] * r[3 + i] + w[2] * r[6 + i] for i in range(3)])

        def world(o: Array, r: Array, c: Array) -> Array:  # o + R c
            return np.array([o[a] + sum(r[3 * a + i] * c[i] for i in range(3)) for a in range(3)])

        d = world(o2, r2, centre[g2].T) - world(o1, r1, centre[g1].T)
        with np.errstate(divide="ignore", invalid="ignore"):
            u = d / np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
            gap = u[0] * (o2[0] - o1[0]) + u[1] * (o2[1] - o1[1]) + u[2] * (o2[2] - o1[2])
            v1, v2 = local(r1, u), -local(r2, u)

            def box(v: Array, g: NDArray[np.int_]) -> Array:
                c, h = centre[g].T, half[g].T
                return sum(v[i] * c[i] + h[i] * np.abs(v[i]) for i in range(3))

            boxes = gap - box(v1, g1) - box(v2, g2) - PRUNE_SLACK

        def own(mask: NDArray[np.bool_]) -> Array:
            h = np.zeros(int(mask.sum()))
            for g, v in ((g1[mask], v1[:, mask]), (g2[mask], v2[:, mask])):
                # The entries grouped by geom: one call of its support function per group.
                order = np.argsort(g, kind="stable")
                cut = np.flatnonzero(np.diff(g[order])) + 1
                for at in np.split(order, cut):
                    if len(at):
                        h[at] += self.support[int(g[at[0]])].upper(v[:, at])
            with np.errstate(invalid="ignore"):
                return gap[mask] - h - PRUNE_SLACK

        return boxes, own

    def _witness_bound(
        self, X: Array, R: Array, rows: NDArray[np.int_], cols: NDArray[np.int_]
    ) -> Array:
        """Lower bounds of pairs ``cols`` at poses ``rows`` along their learnt axes [m].

        The axis a turns with the first geom: u = R1 a in the world, so the first geom's
        support along it is the constant ``h1(a)``; the bound is ``u . (o2 - o1) - h1(a) -
        h2(-R2^T u)``, less `PRUNE_SLACK`, as in `_axis_bound` (any unit vector gives one).
        Near the pose the axis was learnt at, it is close to the distance itself.
        """
        g1, g2 = self.c1[cols], self.c2[cols]
        at1, at2 = rows * X.shape[2] + g1, rows * X.shape[2] + g2
        flat_x, flat_r = X.reshape(3, -1), R.reshape(9, -1)
        o1, r1 = np.take(flat_x, at1, axis=1), np.take(flat_r, at1, axis=1)
        o2, r2 = np.take(flat_x, at2, axis=1), np.take(flat_r, at2, axis=1)
        a = self.axis[cols].T
        u = np.array([sum(r1[3 * i + j] * a[j] for j in range(3)) for i in range(3)])  # R1 a
        u /= np.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
        gap = u[0] * (o2[0] - o1[0]) + u[1] * (o2[1] - o1[1]) + u[2] * (o2[2] - o1[2])
        v2 = -np.array([u[0] * r2[i] + u[1] * r2[3 + i] + u[2] * r2[6 + i] for i in range(3)])
        h = self.axis_h1[cols].copy()
        order = np.argsort(g2, kind="stable")
        cut = np.flatnonzero(np.diff(g2[order])) + 1
        for grp in np.split(order, cut):
            if len(grp):
                h[grp] += self.support[int(g2[grp[0]])].upper(v2[:, grp])
        return gap - h - PRUNE_SLACK

    def _learn(self, learnt: list[NDArray[np.int_]]) -> None:
        """Geom1's support along the axes just learnt by pairs ``learnt`` (see `_evaluate`)."""
        if not learnt:
            return
        k = np.concatenate(learnt)
        g1 = self.c1[k]
        h = np.full(len(k), np.nan)
        order = np.argsort(g1, kind="stable")
        cut = np.flatnonzero(np.diff(g1[order])) + 1
        a = self.axis[k].T
        for grp in np.split(order, cut):
            if len(grp):
                h[grp] = self.support[int(g1[grp[0]])].upper(a[:, grp])
        self.axis_h1[k] = h

    def _evaluate(
        self,
        Q: Array,
        D: Array,
        apart: Array,
        todo: NDArray[np.bool_],
        side: NDArray[np.bool_] | None = None,
        learn: Array | None = None,
    ) -> None:
        """Fill ``D`` pose by pose where ``todo`` or ``side`` holds.

        ``todo``: the distance. ``side``: a listed pair whose lower bound, already in ``D``,
        exceeds its closest approach so far; the bound stays where the engine finds the pair
        within its threshold plus the band (a stand-in that folds as the distance would:
        above the closest approach, touching or in the band for the cross-check), else the
        distance replaces it.
        """
        scene = self.scene
        assert scene is not None
        either = todo if side is None else todo | side
        rows, cols = np.nonzero(either)
        if not len(rows):
            return
        # One slice of `cols` per pose: where each pose's entries start and end.
        edges = np.flatnonzero(np.diff(rows)) + 1
        starts = np.concatenate(([0], edges))
        ends = np.concatenate((edges, [len(rows)]))
        learnt: list[NDArray[np.int_]] = []
        for a, b in zip(starts.tolist(), ends.tolist(), strict=True):
            i, which = int(rows[a]), cols[a:b]
            scene.place(Q[i])
            if side is not None:
                check = side[i, which]
                if check.any():
                    assert isinstance(scene, CoalScene)  # `epa` pairs are coal's only
                    pick = which[check]
                    inside = scene.placed_within(pick, self.thr[pick] + AMBIGUITY_BAND)
                    which = np.concatenate((which[~check], pick[~inside]))
            if len(which):
                D[i, which] = scene.placed_values(which, apart[i, which])
                if learn is not None and isinstance(scene, CoalScene):
                    # coal's normals, turned into geom1's frame: a_j = sum_i R1[i, j] n_i.
                    n = scene.placed_normals(which).T
                    r1 = learn[:, i, self.c1[which]]
                    axis = np.array([sum(r1[3 * i + j] * n[i] for i in range(3)) for j in range(3)])
                    axis /= np.sqrt((axis * axis).sum(axis=0))
                    self.axis[which] = axis.T
                    learnt.append(which)
        self._learn(learnt)

    def _fold(self, D: Array, listed: NDArray[np.bool_]) -> None:
        """Fold a chunk's distances (``inf`` where skipped) into the running results."""
        # Closest approach: the first pose reaching the smallest distance, as a sequential
        # loop with a strict comparison finds it (NaN never wins).
        finite = np.where(np.isnan(D), np.inf, D)
        at = np.argmin(finite, axis=0)
        low = finite[at, np.arange(D.shape[1])]
        better = low < self.closest
        self.closest[better] = low[better]
        self.closest_at[better] = self.done + at[better]
        # Cross-check: the engine's touching pairs against MuJoCo's contact pairs. A skipped
        # pair is neither touching nor listed nor in the band, as its real distance.
        fuzzy = np.abs(D - self.thr) < AMBIGUITY_BAND
        self.disagree += int((((D < self.thr) != listed) & ~fuzzy).any(axis=1).sum())


def keyframe_clearance(arm: Arm, engine: DistanceEngine = "coal") -> tuple[KeyframeClearance, ...]:
    """Contacts and the closest pair at every keyframe of the model.

    A keyframe that moves held joints is measured on the arm at it
    (`at_keyframe`): the robot's real pose under the keyframe's name.
    """
    checker(arm)  # the arm checked, its checker built
    out = []
    for name in arm._reachable_keyframes():  # a loop open there: no pose to measure
        at = arm.at_keyframe(name)
        ch, q = checker(at), at.keyframe(name)
        out.append(
            KeyframeClearance(
                name,
                q,
                len(ch.contacts(q)),
                ch.distances(q, engine).closest,
                arm.keyframe_moves(name),
            )
        )
    return tuple(out)

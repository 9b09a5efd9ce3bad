"""Distances of every collision pair over a stack of poses, from coal or from MuJoCo."""

from __future__ import annotations

import mujoco
import numpy as np
from numpy.typing import NDArray

from ..arm import Arm
from ..checks import check_choice, check_poses, check_threads, describe
from ..engines.threads import run_split
from ..errors import ParameterError
from .checker import CollisionChecker
from .coal_scene import epa_failed
from .pairs import DISTANCE_ENGINES, DistanceEngine
from .pathcheck import _travel

Array = NDArray[np.float64]


def distance_stack(
    ch: CollisionChecker, Q: Array, engine: DistanceEngine = "coal", threads: int = 1
) -> Array:
    """Signed distances of ``ch.pairs`` at each pose of a stack, shape (n, npairs) [m].

    Args:
        ch: The arm's collision checker (`checker`).
        Q: Poses, shape (n, nq) [rad or m].
        engine: ``"coal"`` or ``"mujoco"``.
        threads: Worker threads (MuJoCo only), >= 1.

    Raises:
        ParameterError: ``ch`` not a collision checker, a bad engine or thread count.
        PoseError: ``Q`` not finite poses of shape (n, nq).
    """
    if not isinstance(ch, CollisionChecker):
        raise ParameterError(
            "ch", ch, "a CollisionChecker (redundancy.collision.checker(arm))", describe(ch)
        )
    Q = check_poses(Q, ch.arm.joint_names)
    check_choice("distance engine", engine, DISTANCE_ENGINES)
    return _distance_stack(ch, Q, engine, check_threads(threads))


def _distance_stack(ch: CollisionChecker, Q: Array, engine: DistanceEngine, threads: int) -> Array:
    """`distance_stack` on checked input: Q C-contiguous float64 (n, nq)."""
    out = np.empty((len(Q), len(ch.pairs)))
    Q = ch.scene_poses(Q)
    if engine == "coal":
        _coal_distances(ch, Q, out)
    else:
        _mj_distances(ch.arm, ch, Q, out, threads)
    return out


def _distmax(arm: Arm, g1: NDArray[np.int_], g2: NDArray[np.int_], offset: Array) -> Array | None:
    """A per-pair cap for ``mj_geomDistance`` that no pose can reach, or None.

    A geom's origin is never further from the world origin than the sum of the body offsets
    along its chain, the geom's offset in its body and the travel of slide joints on the way
    (from ``qpos0``, where ``body_pos`` puts them); the distance never exceeds the origins'
    separation plus both bounding radii (0 for a plane, whose origin is on it). So the cap
    never binds and the result is the single-pose one (``mj_geomDistance`` returns the
    distance itself whenever it is below the cap). None when an unlimited slide joint makes
    the reach unbounded.
    """
    m = arm.mj_model
    reach = np.zeros(m.nbody)
    for b in range(1, m.nbody):
        joints = range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b])
        slides = [j for j in joints if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE]
        # The path checker's rule: the displacement from qpos0, infinite when unlimited.
        travel = sum(_travel(m, j) for j in slides)
        if not np.isfinite(travel):
            return None
        reach[b] = reach[m.body_parentid[b]] + float(np.linalg.norm(m.body_pos[b])) + travel
    geom = reach[m.geom_bodyid] + np.linalg.norm(m.geom_pos, axis=1)
    return geom[g1] + geom[g2] + offset


def _coal_distances(ch: CollisionChecker, Q: Array, out: Array) -> None:
    # The checker's private scene: its GeometryData holds one distance request per pair,
    # set up as the single-pose path uses them.
    scene = ch.coal_scene()
    values = scene.pin_values
    for qp, row in zip(ch.scene_pinocchio._order(Q), out, strict=True):
        row[:] = values(qp)
    # Redo the poses with a failed EPA through the scene, whose retry with a looser EPA
    # needs the geoms placed at that pose.
    bad = np.flatnonzero(epa_failed(out).any(axis=1))
    for i in bad:
        out[i] = scene.distance_values(Q[i])


def _mj_distances(arm: Arm, ch: CollisionChecker, Q: Array, out: Array, threads: int) -> None:
    m = arm.mj_model
    shared = ch.mujoco_scene().shared
    g1, g2, ids = shared.g1, shared.g2, shared.ids
    offset = shared.cap_offset  # both radii + 1 m per pair
    cap = _distmax(arm, g1, g2, offset)
    kin, dist = mujoco.mj_kinematics, mujoco.mj_geomDistance

    # With a fixed cap, the (geom, geom, cap) triples are built once, not once per pose.
    fixed = (
        None if cap is None else [(a, b, c) for (a, b), c in zip(ids, cap.tolist(), strict=True)]
    )

    def body(lo: int, hi: int) -> None:
        d = mujoco.MjData(m)  # this span's own data: threads never share one
        qpos, xpos = d.qpos, d.geom_xpos
        for q, row in zip(Q[lo:hi], out[lo:hi], strict=True):
            qpos[:] = q
            kin(m, d)
            # mj_kinematics gives geom_xpos/xmat, all mj_geomDistance reads.
            if fixed is not None:
                row[:] = [dist(m, d, a, b, c, None) for a, b, c in fixed]
                continue
            caps = (np.linalg.norm(xpos[g1] - xpos[g2], axis=1) + offset).tolist()
            row[:] = [dist(m, d, a, b, c, None) for (a, b), c in zip(ids, caps, strict=True)]

    run_split(len(Q), threads, body)

"""Batched evaluation over a stack of poses, at close to the engines' own speed.

Every function takes a stack of joint configurations ``Q`` of shape (n, nq) and returns
stacked arrays, equal to what the single-pose methods of :class:`~redundancy.Arm` return
pose by pose (bit for bit; the tests hold them to it). What makes them fast:

* **No per-pose Python objects on the hot path.** MuJoCo writes straight into the rows of
  preallocated output stacks (``mj_jacSite``, ``mj_fullM`` and ``mj_rne`` take output
  arrays); the engine wrappers in :mod:`redundancy.mujoco_engine` copy and stack per call,
  so the loops here call :mod:`mujoco` directly. Pinocchio returns a new array per call,
  copied into the stack; its post-processing (symmetrising ``crba``'s upper triangle,
  removing armature, reordering joints) is done once on the whole stack.
* **One call where the engine has one.** Pinocchio's gravity comes from
  ``pinocchio.rneaInParallel`` (RNEA with v = a = 0: the same sums as
  ``computeGeneralizedGravity``), one C++ call for the whole stack, on ``threads`` OpenMP
  threads. Singular values come from one ``np.linalg.svd`` call on the (n, 6, nv) stack.
* **Threads where the GIL allows.** MuJoCo's bindings release the GIL inside ``mj_*``;
  Pinocchio's never do. With ``threads > 1`` MuJoCo loops run on that many threads, each
  with its own ``MjData`` (a 7-dof chain's calls are 0.5-4 us, so the Python glue between
  them, which holds the GIL, limits the gain); NumPy's SVD releases the GIL, so
  :func:`singular_values` overlaps the SVD of one chunk with the Jacobians of the next.
  Results do not depend on ``threads``: each pose is computed by one thread, start to end.

The singular values are NumPy's SVD (LAPACK ``gesdd`` without vectors), not the square roots
of the eigenvalues of the 6 x 6 Gram matrix J J^T: that closed form is faster but squares
the condition number, so near a singular pose the small singular values come out as
sqrt(eps) * sigma_max (about 1e-8 instead of 1e-16) and the rank is wrong (``scripts/bench.py``
measures both).
"""

from __future__ import annotations

import itertools
import queue
import threading
import weakref
from collections.abc import Callable, Sequence
from typing import Literal

import mujoco
import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from ..arm import ENGINES, Arm, EngineName
from ..collision import DISTANCE_ENGINES, CollisionChecker, DistanceEngine, checker
from ..errors import PoseError, RedundancyError, UnknownNameError
from .crosscheck import TOLERANCES, Agreement, CrossCheckReport, crosscheck, quantity_names

Array = NDArray[np.float64]
ManipulabilityKind = Literal["full", "position", "orientation", "scaled"]
MANIPULABILITY_KINDS: tuple[ManipulabilityKind, ...] = ("full", "position", "orientation", "scaled")

#: Quantities :func:`crosscheck_batch` evaluates on whole stacks; the others of
#: :data:`~redundancy.crosscheck.TOLERANCES` go through :func:`~redundancy.crosscheck`.
BATCH_QUANTITIES: tuple[str, ...] = (
    "site position",
    "site rotation",
    "jacobian",
    "mass matrix",
    "mass matrix (bare)",
    "gravity",
)

#: Fewest poses per thread: below this a thread costs more than it saves.
MIN_POSES_PER_THREAD = 256

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


# ==========================================================================================
# Input, workspaces, threads
# ==========================================================================================


def poses(arm: Arm, Q: ArrayLike) -> Array:
    """Validate a stack of joint configurations; return it as C-contiguous float64 (n, nq).

    Args:
        arm: The arm.
        Q: Joint values, one pose per row, in the order of ``arm.joint_names`` [rad or m].

    Raises:
        PoseError: Not numeric, not of shape (n, nq), or with NaN or infinite values (the
            message names the first bad pose and its joints).
    """
    try:
        arr = np.asarray(Q, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise PoseError(f"poses must be numeric, got {type(Q).__name__}: {err}") from err
    if arr.ndim != 2 or arr.shape[1] != arm.nq:
        raise PoseError(
            f"poses must have shape (n, {arm.nq}) for joints {list(arm.joint_names)}, "
            f"got shape {arr.shape}"
        )
    bad = ~np.isfinite(arr)
    if bad.any():
        row = int(np.flatnonzero(bad.any(axis=1))[0])
        which = [f"{arm.joint_names[j]}={arr[row, j]}" for j in np.flatnonzero(bad[row])]
        raise PoseError(f"pose {row} has non-finite values: {', '.join(which)}")
    return np.ascontiguousarray(arr)


def _check_threads(threads: int) -> int:
    if not isinstance(threads, int | np.integer) or threads < 1:
        raise RedundancyError(f"threads must be an integer >= 1, got {threads!r}")
    return int(threads)


def _engine_name(engine: str, valid: Sequence[str] = ENGINES) -> None:
    if engine not in valid:
        raise UnknownNameError("engine", str(engine), valid)


class _Workspace:
    """Engine data objects of one arm, lent to one caller (or worker thread) at a time.

    The Arm's own ``MjData`` and ``pinocchio.Data`` are left alone, so batched calls never
    disturb the single-pose wrappers, and concurrent callers never share a data object.
    """

    def __init__(self, arm: Arm) -> None:
        self._lock = threading.Lock()
        self._mj_model = arm.mj_model
        self._pin_model = arm.pinocchio.model
        self._mj: list[mujoco.MjData] = []
        self._pin: list[pin.Data] = []
        self._pools: dict[int, pin.ModelPool] = {}

    def take_mj(self, k: int) -> list[mujoco.MjData]:
        with self._lock:
            got = [self._mj.pop() for _ in range(min(k, len(self._mj)))]
        return got + [mujoco.MjData(self._mj_model) for _ in range(k - len(got))]

    def give_mj(self, datas: list[mujoco.MjData]) -> None:
        with self._lock:
            self._mj.extend(datas)

    def take_pin(self) -> pin.Data:
        with self._lock:
            if self._pin:
                return self._pin.pop()
        return self._pin_model.createData()

    def give_pin(self, data: pin.Data) -> None:
        with self._lock:
            self._pin.append(data)

    def take_pool(self, threads: int) -> pin.ModelPool:
        with self._lock:
            pool = self._pools.pop(threads, None)
        return pool if pool is not None else pin.ModelPool(self._pin_model, threads)

    def give_pool(self, threads: int, pool: pin.ModelPool) -> None:
        with self._lock:
            self._pools[threads] = pool


_WORKSPACES: weakref.WeakKeyDictionary[Arm, _Workspace] = weakref.WeakKeyDictionary()
_WORKSPACES_LOCK = threading.Lock()


def _workspace(arm: Arm) -> _Workspace:
    with _WORKSPACES_LOCK:
        ws = _WORKSPACES.get(arm)
        if ws is None:
            ws = _WORKSPACES[arm] = _Workspace(arm)
    return ws


def _spans(n: int, threads: int) -> list[tuple[int, int]]:
    """Contiguous row ranges, one per thread (fewer for small n; at least one)."""
    k = max(1, min(threads, n // MIN_POSES_PER_THREAD))
    edges = np.linspace(0, n, k + 1).round().astype(int)
    return [(int(a), int(b)) for a, b in itertools.pairwise(edges)]


def _run_mujoco(
    arm: Arm, n: int, threads: int, body: Callable[[mujoco.MjData, int, int], None]
) -> None:
    """Run ``body(data, lo, hi)`` over rows [0, n), split over threads, one MjData each."""
    spans = _spans(n, threads)
    ws = _workspace(arm)
    datas = ws.take_mj(len(spans))
    try:
        if len(spans) == 1:
            body(datas[0], *spans[0])
            return
        errors: list[BaseException] = []

        def run(k: int) -> None:
            try:
                body(datas[k], *spans[k])
            except BaseException as err:  # re-raised in the caller's thread
                errors.append(err)

        workers = [threading.Thread(target=run, args=(k,)) for k in range(1, len(spans))]
        for w in workers:
            w.start()
        run(0)
        for w in workers:
            w.join()
        if errors:
            raise errors[0]
    finally:
        ws.give_mj(datas)


# ==========================================================================================
# MuJoCo loops. They call mujoco directly instead of MujocoEngine's methods, which copy and
# stack their outputs per pose: here mj_jacSite, mj_fullM and mj_rne write straight into the
# rows of the output stacks. A private MjData keeps qvel = cvel = 0, so mj_rne returns
# gravity alone, as MujocoEngine.gravity does.
# ==========================================================================================


def _mj_jacobians(arm: Arm, Q: Array, out: Array, threads: int) -> None:
    m, sid = arm.mj_model, arm.mujoco.site_id
    kin, com, jac = mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_jacSite

    def body(d: mujoco.MjData, lo: int, hi: int) -> None:
        qpos = d.qpos
        for q, J in zip(Q[lo:hi], out[lo:hi], strict=True):
            qpos[:] = q
            kin(m, d)
            com(m, d)
            jac(m, d, J[:3], J[3:], sid)

    _run_mujoco(arm, len(Q), threads, body)


def _mj_mass_matrices(arm: Arm, Q: Array, out: Array, threads: int) -> None:
    m = arm.mj_model
    kin, com, crb, full = mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_crb, mujoco.mj_fullM

    def body(d: mujoco.MjData, lo: int, hi: int) -> None:
        qpos = d.qpos
        for q, M in zip(Q[lo:hi], out[lo:hi], strict=True):
            qpos[:] = q
            kin(m, d)
            com(m, d)
            crb(m, d)
            full(m, d, M)

    _run_mujoco(arm, len(Q), threads, body)


def _mj_gravities(arm: Arm, Q: Array, out: Array, threads: int) -> None:
    m = arm.mj_model
    kin, com, rne = mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_rne

    def body(d: mujoco.MjData, lo: int, hi: int) -> None:
        qpos = d.qpos
        for q, g in zip(Q[lo:hi], out[lo:hi], strict=True):
            qpos[:] = q
            kin(m, d)
            com(m, d)
            rne(m, d, 0, g)

    _run_mujoco(arm, len(Q), threads, body)


def _mj_all(
    arm: Arm,
    Q: Array,
    threads: int,
    X: Array | None,
    R: Array | None,
    J: Array | None,
    M: Array | None,
    G: Array | None,
) -> None:
    """Any of site position (n, 3), rotation (n, 9), J, M and gravity, one kinematics pass."""
    m, sid = arm.mj_model, arm.mujoco.site_id
    kin, com, jac = mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_jacSite
    crb, full, rne = mujoco.mj_crb, mujoco.mj_fullM, mujoco.mj_rne

    def body(d: mujoco.MjData, lo: int, hi: int) -> None:
        qpos, sx, sm = d.qpos, d.site_xpos, d.site_xmat
        for i in range(lo, hi):
            qpos[:] = Q[i]
            kin(m, d)
            if X is not None:
                X[i] = sx[sid]
            if R is not None:
                R[i] = sm[sid]
            if J is None and M is None and G is None:
                continue
            com(m, d)
            if J is not None:
                Ji = J[i]
                jac(m, d, Ji[:3], Ji[3:], sid)
            if M is not None:
                crb(m, d)
                full(m, d, M[i])
            if G is not None:
                rne(m, d, 0, G[i])

    _run_mujoco(arm, len(Q), threads, body)


# ==========================================================================================
# Pinocchio: its own joint order, mapped by arm.pinocchio.perm (identity for serial chains
# whose MJCF lists joints in tree order, the usual case, and then skipped).
# ==========================================================================================


def _pin_order(arm: Arm, Q: Array) -> Array:
    perm = arm.pinocchio.perm
    if np.array_equal(perm, np.arange(len(perm))):
        return Q
    Qp = np.empty_like(Q)
    Qp[:, perm] = Q
    return Qp


def _identity(arm: Arm) -> bool:
    perm = arm.pinocchio.perm
    return bool(np.array_equal(perm, np.arange(len(perm))))


def _pin_jacobians(arm: Arm, Q: Array) -> Array:
    pe = arm.pinocchio
    model, fid = pe.model, pe.frame_id
    out = np.empty((len(Q), 6, pe.nv))
    cfj = pin.computeFrameJacobian
    ws = _workspace(arm)
    data = ws.take_pin()
    try:
        for i, q in enumerate(_pin_order(arm, Q)):
            out[i] = cfj(model, data, q, fid, _LWA).reshape(6, -1)  # (6,) with one joint
    finally:
        ws.give_pin(data)
    return out if _identity(arm) else out[:, :, pe.perm]


def _pin_mass_matrices(arm: Arm, Q: Array, armature: bool) -> Array:
    pe = arm.pinocchio
    model, nv = pe.model, pe.nv
    out = np.empty((len(Q), nv, nv))
    crba = pin.crba
    ws = _workspace(arm)
    data = ws.take_pin()
    try:
        for i, q in enumerate(_pin_order(arm, Q)):
            out[i] = crba(model, data, q)
    finally:
        ws.give_pin(data)
    # crba fills the upper triangle (armature on the diagonal); as PinocchioEngine.mass_matrix.
    M = np.triu(out) + np.triu(out, 1).transpose(0, 2, 1)
    if not armature:
        k = np.arange(nv)
        M[:, k, k] -= model.armature
    return M if _identity(arm) else M[:, pe.perm][:, :, pe.perm]


def _pin_gravities(arm: Arm, Q: Array, threads: int) -> Array:
    pe = arm.pinocchio
    n, nv = len(Q), pe.nv
    if n == 0:
        return np.empty((0, nv))
    # rneaInParallel takes (nq, n) column stacks: the transpose of a C-contiguous (n, nq)
    # stack is one, without a copy; tau is written in place.
    Qp = _pin_order(arm, Q)
    zeros = np.zeros((nv, n), order="F")
    tau = np.zeros((nv, n), order="F")
    ws = _workspace(arm)
    pool = ws.take_pool(threads)
    try:
        pin.rneaInParallel(threads, pool, Qp.T, zeros, zeros, tau)
    finally:
        ws.give_pool(threads, pool)
    G = tau.T
    return G if _identity(arm) else np.ascontiguousarray(G[:, pe.perm])


def _pin_site_poses(arm: Arm, Q: Array) -> tuple[Array, Array]:
    pe = arm.pinocchio
    model, fid = pe.model, pe.frame_id
    X, R = np.empty((len(Q), 3)), np.empty((len(Q), 3, 3))
    ws = _workspace(arm)
    data = ws.take_pin()
    try:
        ffk, oMf = pin.framesForwardKinematics, data.oMf
        for i, q in enumerate(_pin_order(arm, Q)):
            ffk(model, data, q)
            T = oMf[fid]
            X[i], R[i] = T.translation, T.rotation
    finally:
        ws.give_pin(data)
    return X, R


# ==========================================================================================
# Public API
# ==========================================================================================


def jacobians(arm: Arm, Q: ArrayLike, engine: EngineName = "mujoco", threads: int = 1) -> Array:
    """Site Jacobians of a stack of poses, as :meth:`Arm.jacobian <redundancy.Arm.jacobian>`.

    Args:
        arm: The arm.
        Q: Poses, shape (n, nq) [rad or m].
        engine: ``"mujoco"`` or ``"pinocchio"``.
        threads: Worker threads (MuJoCo only; Pinocchio holds the GIL).

    Returns:
        Jacobians, shape (n, 6, nq): linear rows [m/rad] then angular [rad/rad], world axes.
    """
    _engine_name(engine)
    threads = _check_threads(threads)
    Q = poses(arm, Q)
    if engine == "pinocchio":
        return _pin_jacobians(arm, Q)
    out = np.empty((len(Q), 6, arm.nq))
    _mj_jacobians(arm, Q, out, threads)
    return out


def _svd_values(J: Array) -> Array:
    if len(J) == 0:
        return np.empty((0, min(J.shape[1:])))
    return np.linalg.svd(J, compute_uv=False)


def _jacobians_and_singular_values(
    arm: Arm, Q: Array, engine: EngineName, threads: int
) -> tuple[Array, Array]:
    """J of every pose and its singular values.

    With threads > 1 the SVD of one chunk runs in a worker thread (NumPy releases the GIL)
    while the engine computes the next chunk's Jacobians.
    """
    n = len(Q)
    m = min(6, arm.nq)
    if threads == 1 or n < 2 * MIN_POSES_PER_THREAD:
        J = jacobians(arm, Q, engine)
        return J, _svd_values(J)
    J = np.empty((n, 6, arm.nq))
    S = np.empty((n, m))
    chunk = max(MIN_POSES_PER_THREAD, n // 8)
    todo: queue.SimpleQueue[tuple[int, int] | None] = queue.SimpleQueue()
    errors: list[BaseException] = []

    def svd_worker() -> None:
        while (span := todo.get()) is not None:
            lo, hi = span
            try:
                S[lo:hi] = np.linalg.svd(J[lo:hi], compute_uv=False)
            except BaseException as err:  # re-raised in the caller's thread
                errors.append(err)

    worker = threading.Thread(target=svd_worker)
    worker.start()
    try:
        for lo in range(0, n, chunk):
            hi = min(n, lo + chunk)
            if engine == "pinocchio":
                J[lo:hi] = _pin_jacobians(arm, Q[lo:hi])
            else:
                _mj_jacobians(arm, Q[lo:hi], J[lo:hi], threads - 1)
            todo.put((lo, hi))
    finally:
        todo.put(None)
        worker.join()
    if errors:
        raise errors[0]
    return J, S


def singular_values(
    arm: Arm, Q: ArrayLike, engine: EngineName = "mujoco", threads: int = 1
) -> Array:
    """Singular values of the site Jacobian at each pose, descending.

    Equal to ``linalg.yoshikawa``'s factors (``np.linalg.svd(J, compute_uv=False)``) bit for
    bit, and to :meth:`Arm.svd <redundancy.Arm.svd>`'s ``sigma`` to rounding (1e-15
    relative: that SVD also computes the vectors, by another LAPACK path).

    Args:
        arm: The arm.
        Q: Poses, shape (n, nq) [rad or m].
        engine: ``"mujoco"`` or ``"pinocchio"``.
        threads: With 2 or more, the SVD runs in a worker thread alongside the Jacobians.

    Returns:
        Singular values, shape (n, min(6, nq)) [mixed units: m/rad and rad/rad].
    """
    _engine_name(engine)
    threads = _check_threads(threads)
    return _jacobians_and_singular_values(arm, poses(arm, Q), engine, threads)[1]


def manipulabilities(
    arm: Arm,
    Q: ArrayLike,
    engine: EngineName = "mujoco",
    kind: ManipulabilityKind = "full",
    length: float = 1.0,
    threads: int = 1,
) -> Array:
    """Yoshikawa's manipulability sqrt(det(J J^T)) at each pose, as :func:`linalg.manipulability`.

    Args:
        arm: The arm.
        Q: Poses, shape (n, nq) [rad or m].
        engine: ``"mujoco"`` or ``"pinocchio"``.
        kind: ``"full"`` (6 x n J, mixed units), ``"position"`` (linear rows [m^3/rad^3]),
            ``"orientation"`` (angular rows) or ``"scaled"`` (linear rows divided by
            ``length``, dimensionless); the fields of :class:`~redundancy.Manipulability`.
        length: Characteristic length for ``"scaled"`` [m].
        threads: As in :func:`singular_values` (``"full"`` only).

    Returns:
        Manipulability per pose, shape (n,).
    """
    _engine_name(engine)
    threads = _check_threads(threads)
    if kind not in MANIPULABILITY_KINDS:
        raise UnknownNameError("manipulability kind", str(kind), MANIPULABILITY_KINDS)
    if not length > 0:
        raise RedundancyError(f"characteristic length must be > 0 m, got {length!r}")
    Q = poses(arm, Q)
    if kind == "full":
        S = _jacobians_and_singular_values(arm, Q, engine, threads)[1]
        return np.prod(S, axis=1)
    J = jacobians(arm, Q, engine)
    if kind == "position":
        J = J[:, :3]
    elif kind == "orientation":
        J = J[:, 3:]
    else:
        J[:, :3] /= length
    return np.prod(_svd_values(J), axis=1)


def mass_matrices(
    arm: Arm,
    Q: ArrayLike,
    armature: bool = True,
    engine: EngineName = "mujoco",
    threads: int = 1,
) -> Array:
    """Joint-space mass matrices, as :meth:`Arm.mass_matrix <redundancy.Arm.mass_matrix>`.

    Args:
        arm: The arm.
        Q: Poses, shape (n, nq) [rad or m].
        armature: Include armature on the diagonal.
        engine: ``"mujoco"`` or ``"pinocchio"``.
        threads: Worker threads (MuJoCo only).

    Returns:
        Mass matrices, shape (n, nq, nq) [kg m^2].
    """
    _engine_name(engine)
    threads = _check_threads(threads)
    Q = poses(arm, Q)
    if engine == "pinocchio":
        return _pin_mass_matrices(arm, Q, armature)
    nv = arm.nq
    out = np.empty((len(Q), nv, nv))
    _mj_mass_matrices(arm, Q, out, threads)
    if not armature:
        k = np.arange(nv)
        out[:, k, k] -= arm.mujoco.armature
    return out


def gravities(arm: Arm, Q: ArrayLike, engine: EngineName = "mujoco", threads: int = 1) -> Array:
    """Gravity torques to hold each pose, as :meth:`Arm.gravity <redundancy.Arm.gravity>`.

    Args:
        arm: The arm.
        Q: Poses, shape (n, nq) [rad or m].
        engine: ``"mujoco"`` or ``"pinocchio"`` (``rneaInParallel`` on ``threads`` threads).
        threads: Worker threads.

    Returns:
        Torques, shape (n, nq) [N m or N].
    """
    _engine_name(engine)
    threads = _check_threads(threads)
    Q = poses(arm, Q)
    if engine == "pinocchio":
        return _pin_gravities(arm, Q, threads)
    out = np.empty((len(Q), arm.nq))
    _mj_gravities(arm, Q, out, threads)
    return out


# ==========================================================================================
# Collision distances
# ==========================================================================================


def _distmax(arm: Arm, g1: NDArray[np.int_], g2: NDArray[np.int_]) -> Array | None:
    """A per-pair cap for ``mj_geomDistance`` that no pose can reach, or None.

    The collision checker passes |centre1 - centre2| + 1 m per pose; a centre is never
    further from the world origin than the sum of the body offsets along its chain, the
    geom's offset in its body and the travel of slide joints on the way. The distance never
    exceeds the centres' separation, so the cap never binds and the result is the same
    (``mj_geomDistance`` returns the distance itself whenever it is below the cap). None when
    an unlimited slide joint makes the reach unbounded.
    """
    m = arm.mj_model
    reach = np.zeros(m.nbody)
    for b in range(1, m.nbody):
        travel = 0.0
        for j in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b]):
            if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE:
                if not m.jnt_limited[j]:
                    return None
                travel += float(np.max(np.abs(m.jnt_range[j])))
        reach[b] = reach[m.body_parentid[b]] + float(np.linalg.norm(m.body_pos[b])) + travel
    geom = reach[m.geom_bodyid] + np.linalg.norm(m.geom_pos, axis=1)
    return geom[g1] + geom[g2] + 1.0


def distances(arm: Arm, Q: ArrayLike, engine: DistanceEngine = "coal", threads: int = 1) -> Array:
    """Signed distance of every collision pair at each pose.

    Equal to :meth:`CollisionChecker.distance_values
    <redundancy.collision.CollisionChecker.distance_values>` pose by pose; the pairs are
    ``redundancy.collision.checker(arm).pairs``, in that order.

    Args:
        arm: The arm.
        Q: Poses, shape (n, nq) [rad or m].
        engine: ``"coal"`` (geoms placed by Pinocchio) or ``"mujoco"`` (``mj_geomDistance``).
        threads: Worker threads (MuJoCo only).

    Returns:
        Distances, shape (n, npairs), negative where the geoms overlap [m].
    """
    _engine_name(engine, DISTANCE_ENGINES)
    threads = _check_threads(threads)
    Q = poses(arm, Q)
    ch = checker(arm)
    out = np.empty((len(Q), len(ch.pairs)))
    if engine == "coal":
        _coal_distances(ch, Q, out)
    else:
        _mj_distances(arm, ch, Q, out, threads)
    return out


def _coal_distances(ch: CollisionChecker, Q: Array, out: Array) -> None:
    # The checker's private scene: its GeometryData holds one distance request per pair,
    # set up as the single-pose path uses them.
    scene = ch._coal
    model, data, gmodel, gdata = scene.pin_model, scene.pin_data, scene.geom_model, scene.geom_data
    # The elements of distanceResults are references into GeometryData's vector: listing them
    # once saves building 15+ wrappers per pose (the costliest part of reading the results).
    results = list(gdata.distanceResults)
    compute = pin.computeDistances
    for q, row in zip(_pin_order(ch.arm, Q), out, strict=True):
        compute(model, data, gmodel, gdata, q)
        row[:] = [r.min_distance for r in results]
    # coal reports a failed EPA as -DBL_MAX (or non-finite): redo those poses through the
    # checker, whose retry with a looser EPA needs the geoms placed at that pose.
    bad = np.flatnonzero((~np.isfinite(out) | (out < -1e6)).any(axis=1))
    for i in bad:
        out[i] = scene.distance_values(Q[i])


def _mj_distances(arm: Arm, ch: CollisionChecker, Q: Array, out: Array, threads: int) -> None:
    m = arm.mj_model
    g1, g2 = ch._mj.g1, ch._mj.g2
    cap = _distmax(arm, g1, g2)
    kin, dist = mujoco.mj_kinematics, mujoco.mj_geomDistance
    ids = list(zip(g1.tolist(), g2.tolist(), strict=True))

    def body(d: mujoco.MjData, lo: int, hi: int) -> None:
        qpos, xpos = d.qpos, d.geom_xpos
        for q, row in zip(Q[lo:hi], out[lo:hi], strict=True):
            qpos[:] = q
            kin(m, d)
            # mj_kinematics gives geom_xpos/xmat, all mj_geomDistance reads.
            caps = (np.linalg.norm(xpos[g1] - xpos[g2], axis=1) + 1.0) if cap is None else cap
            row[:] = [
                dist(m, d, a, b, c, None) for (a, b), c in zip(ids, caps.tolist(), strict=True)
            ]

    _run_mujoco(arm, len(Q), threads, body)


# ==========================================================================================
# Two-engine cross-check
# ==========================================================================================


def _errors(a: Array, b: Array) -> Array:
    """Per pose max |a - b| / max(1, |a|), the measure of :func:`redundancy.crosscheck`."""
    n = len(a)
    if n == 0:
        return np.zeros(0)
    a, b = a.reshape(n, -1), b.reshape(n, -1)
    return np.max(np.abs(a - b) / np.maximum(1.0, np.abs(a)), axis=1)


def _worst(err: Array) -> tuple[float, int]:
    """Largest error and its pose, with :func:`redundancy.crosscheck`'s tie and NaN rules.

    That loop keeps the first strict maximum, and a non-finite error replaces whatever was
    kept (so the last non-finite one wins).
    """
    if len(err) == 0:
        return 0.0, 0
    nonfinite = np.flatnonzero(~np.isfinite(err))
    if len(nonfinite):
        p = int(nonfinite[-1])
        return float(err[p]), p
    p = int(np.argmax(err))
    if err[p] > 0.0:
        return float(err[p]), p
    return 0.0, 0


def crosscheck_batch(
    arm: Arm,
    Q: ArrayLike,
    quantities: tuple[str, ...] | None = None,
    tolerances: dict[str, float] | None = None,
    threads: int = 1,
) -> CrossCheckReport:
    """:func:`redundancy.crosscheck` over a stack of poses, with the same report.

    The quantities in :data:`BATCH_QUANTITIES` are computed on the whole stack (MuJoCo in
    one kinematics pass per pose, Pinocchio's gravity by ``rneaInParallel``); the others
    (Jacobian derivatives, manipulability gradient) pose by pose by
    :func:`redundancy.crosscheck`. Errors, worst poses and the report equal crosscheck's.

    Args:
        arm: The arm.
        Q: Poses, shape (n, nq) [rad or m].
        quantities: Subset of :data:`~redundancy.crosscheck.TOLERANCES` keys; all by default.
        tolerances: Overrides for :data:`~redundancy.crosscheck.TOLERANCES`.
        threads: With 2 or more, the MuJoCo part runs in a worker thread (its ``mj_*`` calls
            release the GIL) while the caller's thread runs Pinocchio, and Pinocchio's
            gravity uses that many OpenMP threads.

    Raises:
        UnknownNameError: A quantity that is not a key of ``TOLERANCES``.
    """
    threads = _check_threads(threads)
    tols = {**TOLERANCES, **(tolerances or {})}
    names = quantity_names(quantities)
    Q = poses(arm, Q)
    n, nv = len(Q), arm.nq
    fast = [q for q in names if q in BATCH_QUANTITIES]
    slow = tuple(q for q in names if q not in BATCH_QUANTITIES)

    want = set(fast)
    need_m = bool(want & {"mass matrix", "mass matrix (bare)"})

    def buf(cond: bool, *shape: int) -> Array | None:
        return np.empty((n, *shape)) if cond else None

    mj = {
        "X": buf("site position" in want, 3),
        "R": buf("site rotation" in want, 9),
        "J": buf("jacobian" in want, 6, nv),
        "M": buf(need_m, nv, nv),
        "G": buf("gravity" in want, nv),
    }

    def run_mujoco() -> None:
        _mj_all(arm, Q, 1, mj["X"], mj["R"], mj["J"], mj["M"], mj["G"])

    worker: threading.Thread | None = None
    errors: list[BaseException] = []
    if threads > 1 and n >= MIN_POSES_PER_THREAD and fast:

        def run() -> None:
            try:
                run_mujoco()
            except BaseException as err:  # re-raised in the caller's thread
                errors.append(err)

        worker = threading.Thread(target=run)
        worker.start()
    elif fast:
        run_mujoco()

    pn: dict[str, Array] = {}
    try:
        if "jacobian" in want:
            pn["jacobian"] = _pin_jacobians(arm, Q)
        if need_m:
            pn["mass matrix"] = _pin_mass_matrices(arm, Q, True)
        if "gravity" in want:
            pn["gravity"] = _pin_gravities(arm, Q, threads)
        if want & {"site position", "site rotation"}:
            pn["site position"], pn["site rotation"] = _pin_site_poses(arm, Q)
    finally:
        if worker is not None:
            worker.join()
    if errors:
        raise errors[0]

    ours: dict[str, Array] = {}
    if mj["X"] is not None:
        ours["site position"] = mj["X"]
    if mj["R"] is not None:
        ours["site rotation"] = mj["R"].reshape(n, 3, 3)
    if mj["J"] is not None:
        ours["jacobian"] = mj["J"]
    if mj["M"] is not None:
        ours["mass matrix"] = mj["M"]
        if "mass matrix (bare)" in want:
            k = np.arange(nv)
            bare = mj["M"].copy()
            bare[:, k, k] -= arm.mujoco.armature
            ours["mass matrix (bare)"] = bare
            pbare = pn["mass matrix"].copy()
            # As PinocchioEngine.mass_matrix(q, False): armature removed in Pinocchio's order.
            pbare[:, k, k] -= np.asarray(arm.pinocchio.model.armature)[arm.pinocchio.perm]
            pn["mass matrix (bare)"] = pbare
    if mj["G"] is not None:
        ours["gravity"] = mj["G"]

    found: dict[str, Agreement] = {}
    for name in fast:
        worst, where = _worst(_errors(ours[name], pn[name]))
        found[name] = Agreement(name, worst, tols[name], where)
    if slow:
        for a in crosscheck(arm, Q, slow, tolerances).agreements:
            found[a.quantity] = a
    return CrossCheckReport(tuple(found[q] for q in names), arm.bridges, n)

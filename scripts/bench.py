"""Benchmark: batched quantities against the bare engine loops they wrap, and the controller path.

For every batched quantity of :mod:`redundancy.batch` the script times, in the same process
and interleaved round by round (so that other load on the machine hits both alike):

* the **bare loop**: the engine's own functions in a tight Python loop, nothing else,
  outputs preallocated (MuJoCo writes into them; Pinocchio's returned arrays are copied in);
* the **batched call** of the library, with its input validation and post-processing.

It prints medians over the rounds and the median of the per-round ratios batched / bare.
Then the single-pose path of a null-space controller (J, projector, one step) against bare
``mj_kinematics + mj_comPos + mj_jacSite + np.linalg.pinv``, the Gram-matrix shortcut for
singular values against the SVD (speed and accuracy near singular poses), and the two-engine
cross-check of J, M and gravity against the sum of its six bare loops.

Usage: ``python scripts/bench.py [--model arm7] [--n 10000] [--repeats 7] [--calls 2000]``
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable

import mujoco
import numpy as np
import pinocchio as pin

import redundancy as rd
from redundancy import batch, linalg
from redundancy.collision import checker, random_poses
from redundancy.reports.audit import audit
from timing import machine, ms, per_call_us, ratio, rounds

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


# ------------------------------------------------------------------------------------------
# Bare loops: the engines' own functions, nothing else
# ------------------------------------------------------------------------------------------


class Bare:
    """Tight loops over a pose stack with the engines' functions and preallocated outputs."""

    def __init__(self, arm: rd.Arm, Q: np.ndarray) -> None:
        self.Q = Q
        self.m = arm.mj_model
        self.d = mujoco.MjData(self.m)
        self.sid = arm.mujoco.site_id
        self.pm = arm.pinocchio.model
        self.pd = self.pm.createData()
        self.fid = arm.pinocchio.frame_id
        self.drake = arm.engines.get("drake")  # None without pydrake: its row is left out
        n, nv = len(Q), self.m.nv
        self.J, self.M, self.G = np.empty((n, 6, nv)), np.empty((n, nv, nv)), np.empty((n, nv))
        ch = checker(arm)
        self.coal = ch.coal_scene()
        self.g1, self.g2 = ch.mujoco_scene().g1.tolist(), ch.mujoco_scene().g2.tolist()
        self.D = np.empty((n, len(ch.pairs)))

    def mj_jacobians(self) -> None:
        """mj_kinematics + mj_comPos + mj_jacSite per pose."""
        m, d, sid, qpos = self.m, self.d, self.sid, self.d.qpos
        kin, com, jac = mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_jacSite
        for q, J in zip(self.Q, self.J, strict=True):
            qpos[:] = q
            kin(m, d)
            com(m, d)
            jac(m, d, J[:3], J[3:], sid)

    def mj_mass(self) -> None:
        """mj_kinematics + mj_comPos + mj_crb + mj_fullM per pose."""
        m, d, qpos = self.m, self.d, self.d.qpos
        kin, com, crb, full = mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_crb, mujoco.mj_fullM
        for q, M in zip(self.Q, self.M, strict=True):
            qpos[:] = q
            kin(m, d)
            com(m, d)
            crb(m, d)
            full(m, d, M)

    def mj_gravity(self) -> None:
        """mj_kinematics + mj_comPos + mj_rne per pose."""
        m, d, qpos = self.m, self.d, self.d.qpos
        kin, com, rne = mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_rne
        for q, g in zip(self.Q, self.G, strict=True):
            qpos[:] = q
            kin(m, d)
            com(m, d)
            rne(m, d, 0, g)

    def pin_jacobians(self) -> None:
        """Pinocchio computeFrameJacobian (LOCAL_WORLD_ALIGNED) per pose."""
        pm, pd, fid, J, cfj = self.pm, self.pd, self.fid, self.J, pin.computeFrameJacobian
        for i, q in enumerate(self.Q):
            J[i] = cfj(pm, pd, q, fid, LWA)

    def drake_jacobians(self) -> None:
        """Pydrake SetPositions and CalcJacobianSpatialVelocity (tool origin, world) per pose."""
        from pydrake.multibody.tree import JacobianWrtVariable

        plant, frame = self.drake.plant, self.drake.tool
        ctx, world, kv, p = (
            plant.CreateDefaultContext(),
            plant.world_frame(),
            JacobianWrtVariable.kV,
            np.zeros(3),
        )
        J, jac, set_q = self.J, plant.CalcJacobianSpatialVelocity, plant.SetPositions
        for i, q in enumerate(self.Q):
            set_q(ctx, q)
            J[i] = jac(ctx, kv, frame, p, world, world)

    def pin_mass(self) -> None:
        """Pinocchio crba per pose (upper triangle, as Pinocchio returns it)."""
        pm, pd, M, crba = self.pm, self.pd, self.M, pin.crba
        for i, q in enumerate(self.Q):
            M[i] = crba(pm, pd, q)

    def pin_gravity(self) -> None:
        """Pinocchio computeGeneralizedGravity per pose."""
        pm, pd, G, grav = self.pm, self.pd, self.G, pin.computeGeneralizedGravity
        for i, q in enumerate(self.Q):
            G[i] = grav(pm, pd, q)

    def svd(self) -> None:
        """One SVD (numpy) of the stored Jacobian stack, values only."""
        np.linalg.svd(self.J, compute_uv=False)

    def mj_singular_values(self) -> None:
        """The MuJoCo Jacobian loop, then one SVD of the stack."""
        self.mj_jacobians()
        np.linalg.svd(self.J, compute_uv=False)

    def coal_distances(self) -> None:
        """Pinocchio computeDistances per pose, then min_distance of each result."""
        s = self.coal
        pm, pd, gm, gd, compute = (
            s.pin_model,
            s.pin_data,
            s.geom_model,
            s.geom_data,
            pin.computeDistances,
        )
        results = list(gd.distanceResults)  # references into the vector: no wrapper per pose
        for q, row in zip(self.Q, self.D, strict=True):
            compute(pm, pd, gm, gd, q)
            row[:] = [r.min_distance for r in results]

    def mj_distances(self) -> None:
        """mj_kinematics + mj_geomDistance per pair, per pose."""
        m, d, qpos = self.m, self.d, self.d.qpos
        kin, dist = mujoco.mj_kinematics, mujoco.mj_geomDistance
        pairs = list(zip(self.g1, self.g2, strict=True))
        for q, row in zip(self.Q, self.D, strict=True):
            qpos[:] = q
            kin(m, d)
            row[:] = [dist(m, d, a, b, 10.0, None) for a, b in pairs]


# ------------------------------------------------------------------------------------------
# Sections
# ------------------------------------------------------------------------------------------


def table(
    title: str,
    times: dict[str, list[float]],
    rows: list[tuple[str, str, str | list[str], float]],
) -> list[str]:
    """Rows (label, batched case, bare case(s), target ratio) as text."""
    out = [title, f"  {'quantity':<42}{'bare ms':>9}{'batched ms':>12}{'ratio':>8}{'target':>8}"]
    for label, num, den, target in rows:
        dens = [den] if isinstance(den, str) else den
        bare = sum(ms(times, d) for d in dens)
        r = ratio(times, num, den)
        flag = "ok" if r <= target else "OVER"
        out.append(
            f"  {label:<42}{bare:>9.1f}{ms(times, num):>12.1f}{r:>8.2f}{target:>7.2f}  {flag}"
        )
    return out


def batched_section(arm: rd.Arm, Q: np.ndarray, repeats: int) -> list[str]:
    b = Bare(arm, Q)
    cases: dict[str, Callable[[], object]] = {
        "bare mj J": b.mj_jacobians,
        "bare mj M": b.mj_mass,
        "bare mj g": b.mj_gravity,
        "bare pin J": b.pin_jacobians,
        "bare pin M": b.pin_mass,
        "bare pin g": b.pin_gravity,
        "bare svd": b.svd,
        "bare mj J+svd": b.mj_singular_values,
        "bare coal d": b.coal_distances,
        "bare mj d": b.mj_distances,
        "J mj": lambda: batch.jacobians(arm, Q),
        "J mj 2t": lambda: batch.jacobians(arm, Q, threads=2),
        "J pin": lambda: batch.jacobians(arm, Q, "pinocchio"),
        **(
            {
                "bare drake J": b.drake_jacobians,
                "J drake": lambda: batch.jacobians(arm, Q, engine="drake"),
            }
            if b.drake is not None
            else {}
        ),
        "sv mj": lambda: batch.singular_values(arm, Q),
        "sv mj 2t": lambda: batch.singular_values(arm, Q, threads=2),
        "sv pin 2t": lambda: batch.singular_values(arm, Q, "pinocchio", threads=2),
        "w mj": lambda: batch.manipulabilities(arm, Q),
        "M mj": lambda: batch.mass_matrices(arm, Q),
        "M mj bare": lambda: batch.mass_matrices(arm, Q, armature=False),
        "M mj 2t": lambda: batch.mass_matrices(arm, Q, threads=2),
        "M pin": lambda: batch.mass_matrices(arm, Q, engine="pinocchio"),
        "g mj": lambda: batch.gravities(arm, Q),
        "g mj 2t": lambda: batch.gravities(arm, Q, threads=2),
        "g pin": lambda: batch.gravities(arm, Q, "pinocchio"),
        "g pin 2t": lambda: batch.gravities(arm, Q, "pinocchio", threads=2),
        "d coal": lambda: batch.distances(arm, Q, "coal"),
        "d mj": lambda: batch.distances(arm, Q, "mujoco"),
        "d mj 2t": lambda: batch.distances(arm, Q, "mujoco", threads=2),
    }
    t = rounds(cases, repeats)
    rows: list[tuple[str, str, str | list[str], float]] = [
        ("jacobians, mujoco", "J mj", "bare mj J", 1.5),
        ("jacobians, mujoco, 2 threads", "J mj 2t", "bare mj J", 1.5),
        ("jacobians, pinocchio", "J pin", "bare pin J", 1.5),
        *([("jacobians, drake", "J drake", "bare drake J", 1.5)] if b.drake is not None else []),
        ("singular values, mujoco (vs J loop + svd)", "sv mj", "bare mj J+svd", 1.5),
        ("singular values, mujoco, 2 thr (vs J + svd)", "sv mj 2t", "bare mj J+svd", 1.5),
        ("singular values, mujoco, 2 thr (vs J loop)", "sv mj 2t", "bare mj J", 1.5),
        ("singular values, pinocchio, 2 thr (vs J loop)", "sv pin 2t", "bare pin J", 1.5),
        ("manipulability, mujoco (vs J loop + svd)", "w mj", "bare mj J+svd", 1.5),
        ("mass matrices, mujoco", "M mj", "bare mj M", 1.5),
        ("mass matrices without armature, mujoco", "M mj bare", "bare mj M", 1.5),
        ("mass matrices, mujoco, 2 threads", "M mj 2t", "bare mj M", 1.5),
        ("mass matrices, pinocchio", "M pin", "bare pin M", 1.5),
        ("gravity, mujoco", "g mj", "bare mj g", 1.5),
        ("gravity, mujoco, 2 threads", "g mj 2t", "bare mj g", 1.5),
        ("gravity, pinocchio (rneaInParallel)", "g pin", "bare pin g", 1.5),
        ("gravity, pinocchio, 2 OpenMP threads", "g pin 2t", "bare pin g", 1.5),
        ("distances, coal", "d coal", "bare coal d", 1.5),
        ("distances, mujoco", "d mj", "bare mj d", 1.5),
        ("distances, mujoco, 2 threads", "d mj 2t", "bare mj d", 1.5),
    ]
    out = table(f"Batched quantities, {len(Q)} poses, medians of {repeats} rounds", t, rows)
    out.append(
        f"  (numpy's SVD of the ({len(Q)}, 6, {arm.nq}) stack alone: {ms(t, 'bare svd'):.1f} ms)"
    )
    return out


def crosscheck_section(arm: rd.Arm, Q: np.ndarray, repeats: int) -> list[str]:
    b = Bare(arm, Q)
    names = ("jacobian", "mass matrix", "gravity")
    small = Q[: max(1, len(Q) // 20)]
    scale = len(Q) / len(small)
    cases: dict[str, Callable[[], object]] = {
        "bare mj J": b.mj_jacobians,
        "bare mj M": b.mj_mass,
        "bare mj g": b.mj_gravity,
        "bare pin J": b.pin_jacobians,
        "bare pin M": b.pin_mass,
        "bare pin g": b.pin_gravity,
        "cc 1t": lambda: rd.crosscheck_batch(arm, Q, names),
        "cc 2t": lambda: rd.crosscheck_batch(arm, Q, names, threads=2),
        "per pose (1/20)": lambda: rd.crosscheck(arm, small, names),
    }
    t = rounds(cases, repeats)
    parts = [k for k in cases if k.startswith("bare")]
    rows: list[tuple[str, str, str | list[str], float]] = [
        ("crosscheck J, M, g (vs sum of 6 bare loops)", "cc 1t", parts, 1.0),
        ("crosscheck J, M, g, 2 threads (vs sum)", "cc 2t", parts, 1.0),
    ]
    out = table(f"Two-engine cross-check of J, M and gravity, {len(Q)} poses", t, rows)
    out.append(
        "  bare parts [ms]: "
        + ", ".join(f"{k.removeprefix('bare ')} {ms(t, k):.1f}" for k in parts)
    )
    out.append(
        f"  rd.crosscheck pose by pose (timed on {len(small)} poses, scaled): "
        f"{ms(t, 'per pose (1/20)') * scale:.0f} ms"
    )
    report = rd.crosscheck_batch(arm, Q, names)
    out += ["  " + line for line in report.lines()]
    return out


def gram_section(arm: rd.Arm, Q: np.ndarray, repeats: int) -> list[str]:
    J = batch.jacobians(arm, Q)

    def gram() -> np.ndarray:
        lam = np.linalg.eigvalsh(J @ J.transpose(0, 2, 1))[:, ::-1]
        return np.sqrt(np.maximum(lam, 0.0))

    t = rounds({"svd": lambda: np.linalg.svd(J, compute_uv=False), "gram": gram}, repeats)
    S = np.linalg.svd(J, compute_uv=False)
    rel = np.abs(gram() - S) / S[:, :1]
    out = [
        "Singular values: SVD of J against sqrt(eig(J J^T)) (the Gram shortcut)",
        f"  time on {len(Q)} poses: svd {ms(t, 'svd'):.1f} ms, gram {ms(t, 'gram'):.1f} ms "
        f"(ratio {ratio(t, 'gram', 'svd'):.2f})",
        f"  random poses: largest |gram - svd| / sigma_max = {rel.max():.1e}; "
        f"relative error of sigma_min up to {(np.abs(gram() - S) / S)[:, -1].max():.1e}",
    ]
    if "zero" in arm.keyframes:
        q0 = arm.keyframe("zero")
        for label, q in (
            ("zero pose", q0),
            ("zero pose + 1e-4 rad on j4", q0 + 1e-4 * np.eye(arm.nq)[3]),
        ):
            Jq = arm.jacobian(q)
            s = np.linalg.svd(Jq, compute_uv=False)
            g = np.sqrt(np.maximum(np.linalg.eigvalsh(Jq @ Jq.T)[::-1], 0.0))
            rank = [int(np.sum(x > linalg.RANK_RTOL * x[0])) for x in (s, g)]
            k = rank[0] - 1  # the smallest non-zero singular value
            out.append(
                f"  {label}: rank svd {rank[0]}, gram {rank[1]}; smallest non-zero sigma svd "
                f"{s[k]:.6e}, gram {g[k]:.6e} (relative error {abs(g[k] - s[k]) / s[k]:.1e})"
            )
    out.append(
        "  -> not used: its small singular values miss the 1e-12 batched results are held to"
    )
    return out


def controller_section(arm: rd.Arm, calls: int, repeats: int) -> list[str]:
    m, d, sid = arm.mj_model, mujoco.MjData(arm.mj_model), arm.mujoco.site_id
    qs = random_poses(arm, calls, seed=7)
    v = np.linspace(-0.5, 0.5, arm.nq)
    dt = 1e-3
    J6 = np.zeros((6, arm.nq))
    jp, jr = J6[:3], J6[3:]
    eye = np.eye(arm.nq)
    qpos = d.qpos
    kin, com, jac, pinv = mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_jacSite, np.linalg.pinv

    def bare_J() -> None:
        for q in qs:
            qpos[:] = q
            kin(m, d)
            com(m, d)
            jac(m, d, jp, jr, sid)

    def bare_step() -> None:
        for q in qs:
            qpos[:] = q
            kin(m, d)
            com(m, d)
            jac(m, d, jp, jr, sid)
            N = eye - pinv(J6, rcond=linalg.RANK_RTOL) @ J6
            q + dt * (N @ v)

    def lib_step() -> None:
        for q in qs:
            J = arm.jacobian(q)
            N = linalg.nullspace_projector(J)
            q + dt * (N @ v)

    def lib_J() -> None:
        for q in qs:
            arm.jacobian(q)

    def lib_pose() -> None:
        for q in qs:
            arm.pose(q)

    def bare_pinv() -> None:
        for _ in qs:
            eye - pinv(J6, rcond=linalg.RANK_RTOL) @ J6

    def lib_projector() -> None:
        for _ in qs:
            linalg.nullspace_projector(J6)

    cases = {
        "bare step": bare_step,
        "lib step": lib_step,
        "bare J": bare_J,
        "lib J": lib_J,
        "arm.pose": lib_pose,
        "bare pinv": bare_pinv,
        "lib projector": lib_projector,
    }
    t = rounds(cases, repeats)

    def us(k: str) -> float:
        return per_call_us(t, k, calls)

    r = ratio(t, "lib step", "bare step")
    rj = ratio(t, "lib J", "bare J")
    return [
        f"Single-pose controller path (J, N = I - J^+ J, one null-space step), {calls} calls",
        f"  bare (mj_kinematics + mj_comPos + mj_jacSite + np.linalg.pinv): "
        f"{us('bare step'):6.2f} us",
        f"  library (arm.jacobian + linalg.nullspace_projector):            "
        f"{us('lib step'):6.2f} us   ratio {r:.2f} (target 2.00) {'ok' if r <= 2 else 'OVER'}",
        f"  of which: J bare {us('bare J'):.2f} us, arm.jacobian {us('lib J'):.2f} us "
        f"(arm.pose alone {us('arm.pose'):.2f} us); pinv projector bare {us('bare pinv'):.2f} us, "
        f"linalg {us('lib projector'):.2f} us",
        f"  arm.jacobian / bare J: ratio {rj:.2f} (target 1.50) {'ok' if rj <= 1.5 else 'OVER'}",
    ]


def motion_section(arm: rd.Arm, calls: int, repeats: int) -> list[str]:
    """The Coriolis matrix and the momentum observer against their targets.

    arm.coriolis against the bare MuJoCo calls it needs, batch.coriolis against a loop of
    arm.coriolis, and the time of one MomentumObserver update.
    """
    m, d = arm.mj_model, mujoco.MjData(arm.mj_model)
    n = arm.nq
    qs = random_poses(arm, calls, seed=7)
    vs = np.random.default_rng(7).uniform(-1.0, 1.0, qs.shape)
    taus = np.random.default_rng(8).uniform(-1.0, 1.0, qs.shape)
    H = np.empty((2, n, n))
    qpos, qvel = d.qpos, d.qvel
    kin, com, vel, rne = mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_comVel, mujoco.mj_rne

    def bare_coriolis() -> None:
        # The calls C needs: one kinematics pass, then 2 n biases at v +- e_j.
        for q, v in zip(qs, vs, strict=True):
            qpos[:] = q
            kin(m, d)
            com(m, d)
            for j in range(n):
                qvel[:] = v
                qvel[j] += 1.0
                vel(m, d)
                rne(m, d, 0, H[0, j])
                qvel[j] -= 2.0
                vel(m, d)
                rne(m, d, 0, H[1, j])

    def lib_coriolis() -> None:
        for q, v in zip(qs, vs, strict=True):
            arm.coriolis(q, v)

    observer = rd.MomentumObserver(arm, 50.0)

    def lib_observer() -> None:
        observer.reset()
        for q, v, tau in zip(qs, vs, taus, strict=True):
            observer.update(q, v, tau, 1e-3)

    cases = {
        "bare C": bare_coriolis,
        "arm.coriolis": lib_coriolis,
        "batch.coriolis": lambda: batch.coriolis(arm, qs, vs),
        "observer": lib_observer,
    }
    t = rounds(cases, repeats)

    def us(k: str) -> float:
        return per_call_us(t, k, calls)

    rc = ratio(t, "arm.coriolis", "bare C")
    rb = ratio(t, "batch.coriolis", "arm.coriolis")
    return [
        f"Motion ({calls} states): the Coriolis matrix and the momentum observer",
        f"  arm.coriolis {us('arm.coriolis'):.1f} us, bare mj_kinematics + mj_comPos + "
        f"{2 * n} x (mj_comVel + mj_rne) {us('bare C'):.1f} us: ratio {rc:.2f} (target 2.00) "
        f"{'ok' if rc <= 2 else 'OVER'}",
        f"  batch.coriolis {us('batch.coriolis'):.1f} us per state against a loop of "
        f"arm.coriolis: ratio {rb:.2f} (target 1.00) {'ok' if rb <= 1 else 'OVER'}",
        f"  MomentumObserver.update {us('observer'):.1f} us per step (target 30) "
        f"{'ok' if us('observer') <= 30 else 'OVER'}",
    ]


def rtb_section(calls: int, repeats: int) -> list[str]:
    """arm.manipulability on the panda against Robotics Toolbox's on its Panda, one process."""
    try:
        import roboticstoolbox as rtb  # the `bench` extra
    except ImportError:
        return ["Manipulability against Robotics Toolbox: not run (pip install '.[bench]')"]
    robot = rtb.models.Panda()
    arm = rd.load(rd.model_path("panda"), frame="ee")
    qs = random_poses(arm, calls, seed=11)
    qs_list = [np.array(q) for q in qs]

    def ours() -> None:
        for q in qs_list:
            _ = arm.manipulability(q).full

    def theirs() -> None:
        for q in qs_list:
            robot.manipulability(q)

    t = rounds({"ours": ours, "rtb": theirs}, repeats)
    r = ratio(t, "ours", "rtb")

    def us(k: str) -> float:
        return per_call_us(t, k, calls)

    return [
        f"Manipulability on the Panda, {calls} random poses: arm.manipulability(q).full "
        f"{us('ours'):.2f} us, Robotics Toolbox {rtb.__version__} Panda.manipulability(q) "
        f"{us('rtb'):.2f} us",
        f"  ratio {r:.2f} (target 1.00) {'ok' if r <= 1 else 'OVER'}",
    ]


def _erd(path: str) -> str:
    """A file of example-robot-data (the test extra installs it from PyPI)."""
    import importlib.metadata

    for f in importlib.metadata.files("example-robot-data") or []:
        if str(f).endswith(path):
            return str(f.locate())
    raise SystemExit(f"example-robot-data has no {path}: pip install -e '.[test]'")


def chain_only_urdf(path: str, tool: str) -> str:
    """The URDF cut to what the arm to ``tool`` moves: the arm written as its own file.

    Kept: the path from the root to ``tool`` and every link below its first moving joint
    (the other arm on a moving torso, the head, the hand); the moving joints off the chain
    become fixed at 0, where an arm inside the robot holds them by default. Gone: the links
    no arm joint moves (legs under the pelvis), which change none of the arm's numbers.
    """
    import xml.etree.ElementTree as ET

    root = ET.parse(path).getroot()
    joints = root.findall("joint")
    ends = {
        j.get("name"): (j.find("parent").get("link"), j.find("child").get("link")) for j in joints
    }  # type: ignore[union-attr]
    child_of = {c: name for name, (_, c) in ends.items()}
    path_joints, link = [], tool
    while link in child_of:
        path_joints.append(child_of[link])
        link = ends[child_of[link]][0]
    path_joints.reverse()
    moving = [
        j
        for j in path_joints
        if next(x for x in joints if x.get("name") == j).get("type") != "fixed"
    ]
    keep = {ends[j][0] for j in path_joints} | {tool}
    stack = [ends[moving[0]][1]]
    while stack:  # everything the first arm joint moves
        link = stack.pop()
        keep.add(link)
        stack += [c for p, c in ends.values() if p == link]
    for j in joints:
        if ends[j.get("name")][1] not in keep:
            root.remove(j)
        elif j.get("name") not in moving:
            j.set("type", "fixed")
            for sub in j.findall("mimic"):
                j.remove(sub)
    for el in root.findall("link"):
        if el.get("name") not in keep:
            root.remove(el)
    return ET.tostring(root, encoding="unicode")


def robot_section(repeats: int, calls: int = 2000, n: int = 2000) -> list[str]:
    """The G1's left arm inside the whole robot (10 joints of 43) against the chain alone."""
    path = _erd("g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf")
    tool = "left_hand_palm_link"
    inside = rd.load(path, frame=tool)
    # The chain as its own file, without meshes (the dynamics are timed, not mesh loading).
    alone = rd.load_string(_meshless(chain_only_urdf(path, tool)), frame=tool)
    Q = random_poses(inside, n, seed=0)
    worst = max(
        float(np.max(np.abs(f(inside, q) - f(alone, q))))
        for q in Q[:20]
        for f in (
            lambda a, q: a.jacobian(q),
            lambda a, q: a.mass_matrix(q),
            lambda a, q: a.gravity(q),
        )
    )
    qs = list(Q[:calls])

    def single(arm: rd.Arm, what: str) -> Callable[[], object]:
        f = {"J": arm.jacobian, "M": arm.mass_matrix, "G": arm.gravity}[what]

        def run() -> None:
            for q in qs:
                f(q)

        return run

    cases: dict[str, Callable[[], object]] = {}
    for what in ("J", "M", "G"):
        for label, arm in (("inside", inside), ("alone", alone)):
            cases[f"{what} {label}"] = single(arm, what)
            stack = {"J": batch.jacobians, "M": batch.mass_matrices, "G": batch.gravities}[what]
            cases[f"{what} batch {label}"] = lambda stack=stack, arm=arm: stack(arm, Q)
    # The audit, collisions with the rest of the body included, against arm7's at as many poses.
    arm7 = rd.load(rd.model_path("arm7"), frame="ee")
    cases["audit inside"] = lambda: audit(inside, n_poses=n)
    cases["audit arm7"] = lambda: audit(arm7, n_poses=n)
    times = rounds(cases, repeats)
    out = [
        f"G1 left arm: {inside.nq} joints inside the whole robot ({inside.robot_model.njnt} "
        f"joints, {inside.mj_model.nbody} bodies) against the chain as its own file "
        f"({alone.mj_model.nbody} bodies); largest difference of J, M, gravity {worst:.1e}",
        f"  {'quantity':<42}{'alone ms':>9}{'inside ms':>12}{'ratio':>8}{'target':>8}",
    ]
    for what, name in (("J", "jacobian"), ("M", "mass matrix"), ("G", "gravity")):
        for kind, key in (("single pose", ""), ("batched", "batch ")):
            r = ratio(times, f"{what} {key}inside", f"{what} {key}alone")
            alone_ms = ms(times, f"{what} {key}alone")
            label = f"{name}, {kind} ({calls if not key else n} poses)"
            out.append(
                f"  {label:<42}{alone_ms:>9.1f}{ms(times, f'{what} {key}inside'):>12.1f}"
                f"{r:>8.2f}{2.0:>7.2f}  {'ok' if r <= 2 else 'OVER'}"
            )
    r = ratio(times, "audit inside", "audit arm7")
    label = f"audit ({n} poses; 'alone' is arm7's audit)"
    out.append(
        f"  {label:<42}{ms(times, 'audit arm7'):>9.1f}{ms(times, 'audit inside'):>12.1f}"
        f"{r:>8.2f}{3.0:>7.2f}  {'ok' if r <= 3 else 'OVER'}"
    )
    return out


def _meshless(text: str) -> str:
    """The URDF without collision geometry (timing the dynamics, not mesh loading)."""
    import xml.etree.ElementTree as ET

    root = ET.fromstring(text)
    for link in root.findall("link"):
        for tag in ("collision", "visual"):
            for el in link.findall(tag):
                link.remove(el)
    return ET.tostring(root, encoding="unicode")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", default="arm7", help="arm7 or panda (site 'ee')")
    p.add_argument("--n", type=int, default=10000, help="poses per batch")
    p.add_argument("--repeats", type=int, default=7, help="rounds; medians are reported")
    p.add_argument("--calls", type=int, default=2000, help="single-pose calls per round")
    p.add_argument("--ik", type=int, default=1000, help="IK targets per arm (CLIK: a fifth)")
    args = p.parse_args(argv)
    arm = rd.load(rd.model_path(args.model), frame="ee")
    Q = random_poses(arm, args.n, seed=0)
    t0 = time.perf_counter()
    lines = [
        f"redundancy {rd.__version__} benchmark: {args.model}, {args.n} random poses (seed 0)",
        *machine(),
        "ratios are medians over rounds of (batched time / bare time) measured in the same round",
        "",
    ]
    print("\n".join(lines), flush=True)
    for section in (batched_section, crosscheck_section, gram_section):
        print("\n".join(section(arm, Q, args.repeats)) + "\n", flush=True)
    print("\n".join(controller_section(arm, args.calls, args.repeats)) + "\n", flush=True)
    print("\n".join(motion_section(arm, args.calls, args.repeats)) + "\n", flush=True)
    print("\n".join(rtb_section(args.calls, args.repeats)) + "\n", flush=True)
    print("\n".join(robot_section(args.repeats)), flush=True)
    # Inverse kinematics against its peers and the effective mass (scripts/bench_ik.py).
    import bench_ik

    print("\n".join(bench_ik.ik_section(list(bench_ik.ARMS), args.ik, args.ik // 5)), flush=True)
    print("\n".join(bench_ik.effective_mass_section(args.n, args.repeats)), flush=True)
    # A coupled arm's J against its chain alone (scripts/bench_coupled.py).
    import bench_coupled

    print("\n" + "\n".join(bench_coupled.coupled_section(args.calls, args.repeats)), flush=True)
    print(f"\n(total {time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Benchmark: inverse kinematics against its peers, the effective mass against bare engine loops.

Inverse kinematics, per arm (arm7, the bundled Panda, and example-robot-data's Panda at its hand
with the fingers held, UR5 and xArm7), on the
same reachable targets (forward kinematics of random poses) from the same random starts:

* this library: ``arm.solve_ik(target, q0)`` with default settings;
* Robotics Toolbox's C++ ``ik_LM`` with ``tol=1e-13`` (the tolerance at which it meets 1e-6;
  its default is on half the squared error), on the same URDF;
* Pinocchio's documented CLIK loop (damped least squares on log6, ``pin.integrate``, DT 0.1,
  1000 iterations), with eps 1e-6;
* mink's documented loop, if mink is installed (it is not a dependency).

Every answer is judged the same way: position error <= 1e-6 m and orientation error <= 1e-6 rad
by forward kinematics in MuJoCo and in Pinocchio, and every joint inside its range. The table
gives the success rate, the answers claimed solved that are not ("false"), and the median and
95th percentile of the time per solve. Solves of the libraries alternate target by target, so
that other load on the machine hits them alike, and times are the solving thread's CPU time
(``time.thread_time``): on a shared machine wall time also counts the waits for a core.

The effective mass: one pose (``arm.effective_mass``) against the bare MuJoCo calls it wraps,
and ``batch.effective_masses`` against bare loops of each engine; then the agreement of the two
engines and of a MuJoCo simulation (a force at the tool of the arm at rest, zero gravity).

Usage: ``python scripts/bench_ik.py [--n 1000] [--arms arm7,panda,ur5,xarm7] [--clik 200]``
"""

from __future__ import annotations

import argparse
import copy
import importlib.metadata
import io
import math
import statistics
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin

import redundancy as rd
from redundancy import batch
from redundancy.arm import random_poses

TOL = 1e-6
#: The arms of the IK rows.
ARMS = ("arm7", "panda", "panda-erd", "ur5", "xarm7")
ROOT = Path(__file__).resolve().parents[1]


def _share() -> Path | None:
    """Cmeel's share directory holding example-robot-data (the test extra), or None."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        return None
    return Path(str(dist.locate_file("cmeel.prefix/share")))


def arms() -> dict[str, tuple[Callable[[], rd.Arm], Path, str]]:
    """Arm name -> (loader, URDF for the peers, tool frame)."""
    out: dict[str, tuple[Callable[[], rd.Arm], Path, str]] = {
        "arm7": (
            lambda: rd.load(rd.model_path("arm7"), frame="ee"),
            ROOT / "models/arm7.urdf",
            "ee",
        ),
        "panda": (
            lambda: rd.load(rd.model_path("panda"), frame="ee"),
            ROOT / "models/panda.urdf",
            "ee",
        ),
    }
    share = _share()
    if share is not None:
        robots = share / "example-robot-data/robots"
        for name, rel, tool in (
            # The Panda of example-robot-data at its hand, the fingers held (rd.load holds
            # every joint off the path to the tool).
            ("panda-erd", "panda_description/urdf/panda.urdf", "panda_hand"),
            ("ur5", "ur_description/urdf/ur5_robot.urdf", "tool0"),
            ("xarm7", "xarm_description/urdf/xarm7.urdf", "link_eef"),
        ):
            path = robots / rel
            out[name] = (lambda p=path, t=tool: rd.load(p, frame=t), path, tool)
    return out


def judge(arm: rd.Arm, q: np.ndarray, p_t: np.ndarray, R_t: np.ndarray) -> bool:
    """Within 1e-6 m and 1e-6 rad by both engines' forward kinematics, inside the ranges."""
    if not (np.all(np.isfinite(q)) and np.all(q >= arm.lower) and np.all(q <= arm.upper)):
        return False
    for engine in ("mujoco", "pinocchio"):
        p, R = arm.site_pose(q, engine)
        c = min(1.0, max(-1.0, (float(np.trace(R_t @ R.T)) - 1.0) / 2.0))
        # acos loses precision near 0: the angle from the skew part instead.
        S = R_t @ R.T - (R_t @ R.T).T
        angle = math.atan2(0.5 * float(np.linalg.norm([S[2, 1], S[0, 2], S[1, 0]])), c)
        if np.linalg.norm(p - p_t) > TOL or angle > TOL:
            return False
    return True


def rtb_robot(urdf: Path, share: Path | None):
    import roboticstoolbox as rtb  # the `bench` extra
    from roboticstoolbox.models.URDF.URDFRobot import URDF_file

    text = urdf.read_text()
    if share is not None:
        text = text.replace("package://", f"{share}/")  # meshes, which RTB insists exist
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        elinks, name, _ = URDF_file(io.StringIO(text))
    return rtb.Robot(elinks, name=name)


def clik(arm: rd.Arm, p_t: np.ndarray, R_t: np.ndarray, q0: np.ndarray) -> np.ndarray:
    """Pinocchio's documented CLIK loop (examples/inverse-kinematics.py), on the tool frame."""
    model = arm.pinocchio.model
    data = model.createData()
    fid = arm.pinocchio.frame_id
    perm = arm.pinocchio.perm
    oMdes = pin.SE3(R_t, p_t)
    q = np.zeros(model.nq)
    q[perm] = q0
    eps, it_max, dt, damp = TOL, 1000, 1e-1, 1e-12
    for _ in range(it_max):
        pin.framesForwardKinematics(model, data, q)
        iMd = data.oMf[fid].actInv(oMdes)
        err = pin.log(iMd).vector
        if np.linalg.norm(err) < eps:
            break
        J = pin.computeFrameJacobian(model, data, q, fid)
        J = -np.dot(pin.Jlog6(iMd.inverse()), J)
        v = -J.T.dot(np.linalg.solve(J.dot(J.T) + damp * np.eye(6), err))
        q = pin.integrate(model, q, v * dt)
    return q[perm]


class MinkIK:
    """mink's documented loop (``converge_ik`` of its examples), to 1e-6 m and 1e-6 rad.

    solve_ik with damping 1e-3 and the joint limits as constraints, then integrate, until the
    frame task's error meets the tolerance or 200 iterations.
    """

    def __init__(self, arm: rd.Arm) -> None:
        import mink  # optional peer, not a dependency

        self.mink = mink
        self.config = mink.Configuration(arm.mj_model)
        self.task = mink.FrameTask(
            frame_name=arm.frame, frame_type="site", position_cost=1.0, orientation_cost=1.0
        )
        self.limits = [mink.ConfigurationLimit(arm.mj_model)]

    def __call__(self, p_t: np.ndarray, R_t: np.ndarray, q0: np.ndarray) -> np.ndarray:
        """Solve from ``q0``; the last configuration."""
        mink, config, task = self.mink, self.config, self.task
        task.set_target(mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(R_t), p_t))
        config.update(q0)
        dt = 0.01
        for _ in range(200):
            vel = mink.solve_ik(config, [task], dt, "daqp", damping=1e-3, limits=self.limits)
            config.integrate_inplace(vel, dt)
            err = task.compute_error(config)
            if np.linalg.norm(err[:3]) <= TOL and np.linalg.norm(err[3:]) <= TOL:
                break
        return config.q.copy()


def ik_section(names: list[str], n: int, n_clik: int) -> list[str]:
    share = _share()
    table = arms()
    try:
        import roboticstoolbox as rtb

        rtb_version = rtb.__version__
    except ImportError:
        rtb_version = None
    try:
        import mink  # noqa: F401 - optional peer

        have_mink = True
    except ImportError:
        have_mink = False
    lines = [
        f"Inverse kinematics: {n} reachable targets per arm from random starts (CLIK and mink "
        f"on the first {n_clik}); success = 1e-6 m and 1e-6 rad by both engines' FK, inside "
        "the ranges",
        f"  {'arm':<10}{'solver':<34}{'success':>9}{'false':>7}{'in range':>10}"
        f"{'median ms':>11}{'p95 ms':>9}   (CPU time of the solving thread)",
    ]
    for name in names:
        if name not in table:
            lines.append(f"  {name:<10}not run (pip install -e '.[test]' for example-robot-data)")
            continue
        loader, urdf, tool = table[name]
        arm = loader()
        Qt, Q0 = random_poses(arm, n, seed=1), random_poses(arm, n, seed=2)
        targets = [arm.site_pose(q) for q in Qt]
        robot = rtb_robot(urdf, share) if rtb_version else None
        res: dict[str, list[tuple[bool, bool, bool, float]]] = {
            "ours": [],
            "rtb": [],
            "clik": [],
            "mink": [],
        }
        peer = MinkIK(arm) if have_mink else None
        for i, ((p_t, R_t), q0) in enumerate(zip(targets, Q0, strict=True)):
            t = time.thread_time()
            r = arm.solve_ik((p_t, R_t), q0)
            dt = time.thread_time() - t
            ok = judge(arm, r.q, p_t, R_t)
            inr = bool(np.all(r.q >= arm.lower) and np.all(r.q <= arm.upper))
            res["ours"].append((ok, r.success and not ok, inr, dt))
            if robot is not None:
                T = np.eye(4)
                T[:3, :3], T[:3, 3] = R_t, p_t
                t = time.thread_time()
                sol = robot.ik_LM(T, end=tool, q0=q0, tol=1e-13)
                dt = time.thread_time() - t
                q = np.asarray(sol.q, dtype=float)
                ok = judge(arm, q, p_t, R_t)
                inr = bool(np.all(q >= arm.lower) and np.all(q <= arm.upper))
                res["rtb"].append((ok, bool(sol.success) and not ok, inr, dt))
            if i < n_clik:
                t = time.thread_time()
                q = clik(arm, p_t, R_t, q0)
                dt = time.thread_time() - t
                inr = bool(np.all(q >= arm.lower) and np.all(q <= arm.upper))
                res["clik"].append((judge(arm, q, p_t, R_t), False, inr, dt))
            if i < n_clik and peer is not None:
                t = time.thread_time()
                q = peer(p_t, R_t, q0)
                dt = time.thread_time() - t
                inr = bool(np.all(q >= arm.lower) and np.all(q <= arm.upper))
                res["mink"].append((judge(arm, q, p_t, R_t), False, inr, dt))
        labels = {
            "ours": "redundancy solve_ik (defaults)",
            "rtb": f"RTB {rtb_version} ik_LM tol=1e-13",
            "clik": "Pinocchio CLIK (documented)",
            "mink": "mink solve_ik loop (documented)",
        }
        for key, rows in res.items():
            if not rows:
                lines.append(f"  {name:<10}{labels[key]:<34}not run")
                continue
            ok, false, inr, dt = (np.array(c) for c in zip(*rows, strict=True))
            lines.append(
                f"  {name:<10}{labels[key]:<34}{100 * ok.mean():>8.1f}%{int(false.sum()):>7d}"
                f"{100 * inr.mean():>9.1f}%{1e3 * np.median(dt):>11.3f}"
                f"{1e3 * np.percentile(dt, 95):>9.3f}"
            )
        # The joint-limit objective: farther from the limits, at no loss of success.
        m = min(n, 100)
        plain = [arm.solve_ik(targets[i], Q0[i]) for i in range(m)]
        kept = [arm.solve_ik(targets[i], Q0[i], objective="joint_limits") for i in range(m)]
        clear = [
            np.mean([rd.ik.limit_clearance(r.q, arm.lower, arm.upper) for r in rs])
            for rs in (plain, kept)
        ]
        lines.append(
            f"  {name:<10}objective='joint_limits' on {m}: success {sum(r.success for r in kept)}"
            f"/{m} (without: {sum(r.success for r in plain)}), mean clearance to the nearest "
            f"limit {clear[1]:.3f} of the range (without: {clear[0]:.3f})"
        )
    if not have_mink:
        lines.append("  mink: not installed (optional), not run")
    return lines


def _simulated(arm: rd.Arm, q: np.ndarray, u: np.ndarray) -> float:
    """F / (u . a) from MuJoCo's forward dynamics, a force at the site, arm at rest."""
    m = copy.deepcopy(arm.mj_model)
    off = mujoco.mjtDisableBit
    for bit in ("GRAVITY", "SPRING", "DAMPER", "ACTUATION", "CONSTRAINT"):
        m.opt.disableflags |= int(getattr(off, f"mjDSBL_{bit}"))
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_forward(m, d)
    site = arm.mujoco.site_id
    mujoco.mj_applyFT(
        m, d, u, np.zeros(3), d.site_xpos[site].copy(), arm.mujoco.site_body, d.qfrc_applied
    )
    mujoco.mj_forward(m, d)
    mujoco.mj_rnePostConstraint(m, d)
    acc = np.zeros(6)
    mujoco.mj_objectAcceleration(m, d, mujoco.mjtObj.mjOBJ_SITE, site, acc, 0)
    return float(1.0 / (u @ acc[3:]))


def effective_mass_section(n: int, repeats: int) -> list[str]:
    from timing import ratio, rounds  # the benchmarks' round-robin timing

    lines = [f"Effective mass at the tool (panda, {n} random poses, direction z):"]
    arm = rd.load(rd.model_path("panda"), frame="ee")
    Q = random_poses(arm, n, seed=3)
    u = np.array([0.0, 0.0, 1.0])
    m, d = arm.mj_model, mujoco.MjData(arm.mj_model)
    sid = arm.mujoco.site_id
    jac, X = np.zeros((6, m.nv)), np.zeros((6, m.nv))
    calls = min(n, 2000)

    def bare_one(q: np.ndarray) -> float:
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_jacSite(m, d, jac[:3], jac[3:], sid)
        mujoco.mj_crb(m, d)
        mujoco.mj_factorM(m, d)
        mujoco.mj_solveM(m, d, X, jac)
        g = u.dot(jac[:3])
        return 1.0 / g.dot(X[:3].T.dot(u))

    # One pose: the thread's CPU time per call, median over rounds (wall time on a shared
    # machine also counts the waits for a core).
    per: dict[str, list[float]] = {"ours": [], "bare": []}
    for _ in range(repeats):
        t = time.thread_time()
        for q in Q[:calls]:
            arm.effective_mass(q, u)
        per["ours"].append(time.thread_time() - t)
        t = time.thread_time()
        for q in Q[:calls]:
            bare_one(q)
        per["bare"].append(time.thread_time() - t)
    us = {k: 1e6 * statistics.median(v) / calls for k, v in per.items()}
    r1 = statistics.median(a / b for a, b in zip(per["ours"], per["bare"], strict=True))
    lines.append(
        f"  one pose (CPU time): arm.effective_mass {us['ours']:.1f} us (target <= 50 us "
        f"{'ok' if us['ours'] <= 50 else 'OVER'}), bare MuJoCo calls {us['bare']:.1f} us, "
        f"ratio {r1:.2f}"
    )
    pm, pd = arm.pinocchio.model, arm.pinocchio.model.createData()
    fid = arm.pinocchio.frame_id

    def bare_mujoco() -> None:
        out = np.empty(n)
        for i, q in enumerate(Q):
            out[i] = bare_one(q)

    def bare_pinocchio() -> None:
        out = np.empty(n)
        for i, q in enumerate(Q):
            Jp = pin.computeFrameJacobian(pm, pd, q, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
            Minv = pin.computeMinverse(pm, pd, q)
            Minv = np.triu(Minv) + np.triu(Minv, 1).T
            g = u.dot(Jp[:3])
            out[i] = 1.0 / g.dot(Minv.dot(g))

    t = rounds(
        {
            "batch mujoco": lambda: batch.effective_masses(arm, Q, u),
            "bare mujoco": bare_mujoco,
            "batch pinocchio": lambda: batch.effective_masses(arm, Q, u, engine="pinocchio"),
            "bare pinocchio": bare_pinocchio,
        },
        repeats,
    )
    for engine in ("mujoco", "pinocchio"):
        r = ratio(t, f"batch {engine}", f"bare {engine}")
        lines.append(
            f"  batched, {engine}: {1e3 * statistics.median(t[f'batch {engine}']):.1f} ms, bare "
            f"loop {1e3 * statistics.median(t[f'bare {engine}']):.1f} ms, ratio {r:.2f} "
            f"(target 1.00) {'ok' if r <= 1.0 else 'OVER'}"
        )
    # Agreement: the engines over the six axis directions, and the simulation on 50 poses.
    worst_engines = worst_sim = 0.0
    for v in np.vstack([np.eye(3), -np.eye(3)]):
        a = batch.effective_masses(arm, Q, v)
        b = batch.effective_masses(arm, Q, v, engine="pinocchio")
        worst_engines = max(worst_engines, float(np.max(np.abs(a - b) / a)))
    for q in Q[:50]:
        for v in np.eye(3):
            s = _simulated(arm, q, v)
            worst_sim = max(worst_sim, abs(arm.effective_mass(q, v) - s) / s)
    lines.append(
        f"  agreement: MuJoCo vs Pinocchio {worst_engines:.1e} relative over {n} poses x 6 "
        f"directions; vs a simulated push (F / a, MuJoCo forward dynamics) {worst_sim:.1e} over "
        f"50 poses x 3 axes (target 1e-9)"
    )
    return lines


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=1000, help="targets per arm")
    p.add_argument("--arms", default=",".join(ARMS))
    p.add_argument("--clik", type=int, default=200, help="targets for Pinocchio's CLIK loop")
    p.add_argument("--poses", type=int, default=10000, help="poses for the effective mass")
    p.add_argument("--repeats", type=int, default=5)
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    from timing import machine  # the benchmarks' machine and load lines

    print("\n".join(machine()) + "\n", flush=True)
    print("\n".join(ik_section(args.arms.split(","), args.n, args.clik)) + "\n", flush=True)
    print("\n".join(effective_mass_section(args.poses, args.repeats)), flush=True)
    print(f"\n(total {time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    sys.exit(main())

"""Benchmark: the project's lesson script against a straightforward per-pose loop.

The baseline computes the same six tables the plain way, MuJoCo only, one pose or one step
at a time: ``mj_forward`` for every random pose (gravity from ``qfrc_bias``, contacts from
``data.contact``), ``mj_forward`` + ``mj_step`` for every simulation step, and every kd on
the grid for table (6). Both run in this process, alternately, ``--repeat`` times; the
script prints the medians, their ratio, and whether the two produced the same numbers.

Run: python scripts/bench_lesson.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import io
import platform
import statistics
import sys
import time
from contextlib import redirect_stdout

import mujoco
import numpy as np


def baseline(path: str, n_poses: int = 10_000) -> dict[str, object]:
    """The six tables' numbers, computed by a plain per-pose / per-step MuJoCo loop."""
    model = mujoco.MjModel.from_xml_path(path)
    data = mujoco.MjData(model)
    home = model.key("home").id
    out: dict[str, object] = {}

    mujoco.mj_resetDataKeyframe(model, data, home)
    mujoco.mj_forward(model, data)
    full = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, full)
    out["M_ii"] = np.diag(full).copy()

    svs = []
    for key in ("zero", "home"):
        mujoco.mj_resetDataKeyframe(model, data, model.key(key).id)
        mujoco.mj_forward(model, data)
        jp, jr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
        mujoco.mj_jacSite(model, data, jp, jr, model.site("ee").id)
        svs.append(np.linalg.svd(np.vstack([jp, jr]), compute_uv=False))
    out["sigma"] = svs

    lo, hi = model.jnt_range[:, 0], model.jnt_range[:, 1]
    rng = np.random.default_rng(0)
    peak = np.zeros(model.nv)
    for _ in range(n_poses):
        data.qpos[:] = rng.uniform(lo, hi)
        data.qvel[:] = 0
        mujoco.mj_forward(model, data)
        peak = np.maximum(peak, np.abs(data.qfrc_bias))
    out["gravity_peak"] = peak

    rng = np.random.default_rng(1)
    hits, counts = 0, {}
    for _ in range(n_poses):
        data.qpos[:] = rng.uniform(lo, hi)
        mujoco.mj_forward(model, data)
        hits += data.ncon > 0
        for c in data.contact[: data.ncon]:
            pair = tuple(sorted((model.geom(c.geom[0]).name, model.geom(c.geom[1]).name)))
            counts[pair] = counts.get(pair, 0) + 1
    out["contact_poses"] = hits
    out["contacts"] = counts

    def hold(
        armature: float,
        integrator: int,
        kp: float,
        kd: float,
        seconds: float,
        tail: float,
        flags: int = 0,
    ) -> np.ndarray:
        m = mujoco.MjModel.from_xml_path(path)
        m.dof_armature[:] = armature
        m.opt.integrator = integrator
        m.opt.disableflags |= flags
        d = mujoco.MjData(m)
        mujoco.mj_resetDataKeyframe(m, d, home)
        target = m.key_qpos[home].copy()
        d.qvel[:] = 0.01
        n = round(seconds / m.opt.timestep)
        peak = np.zeros(m.nv)
        for i in range(n):
            mujoco.mj_forward(m, d)
            d.ctrl[:] = d.qfrc_bias + kp * (target - d.qpos) - kd * d.qvel
            mujoco.mj_step(m, d)
            if i > tail * n:
                peak = np.maximum(peak, np.abs(d.qvel))
        return peak

    euler, implicit = mujoco.mjtIntegrator.mjINT_EULER, mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    out["hold"] = [
        hold(0.0, euler, 0, 0, 2.0, -1).max(),
        hold(0.0, euler, 0, 0, 2.0, -1, int(mujoco.mjtDisableBit.mjDSBL_EULERDAMP)).max(),
        hold(0.05, euler, 100, 5, 2.0, -1).max(),
        hold(0.0, euler, 100, 5, 2.0, -1).max(),
        hold(0.0, implicit, 100, 5, 2.0, -1).max(),
    ]
    thresholds = {}
    for kp in (0.0, 100.0):
        stable = [
            kd
            for kd in np.arange(0.50, 0.81, 0.02)
            if hold(0.0, euler, kp, kd, 4.0, 0.75)[6] < 1e-3
        ]
        thresholds[kp] = max(stable)
    out["thresholds"] = thresholds
    return out


def project(path: str, n_poses: int = 10_000) -> dict[str, object]:
    """The same numbers from the library, through ``lesson.print_tables``'s functions."""
    import redundancy as rd
    from redundancy.reports import lesson

    arm = rd.load(path, frame="ee")
    with redirect_stdout(io.StringIO()):
        lesson.print_tables(arm, n_poses)
    # print_tables computes and prints; for the comparison re-use its building blocks.
    g = lesson.gravity_budget(arm, n_poses, 0)
    c = lesson.contact_table(arm, n_poses, 1)
    w = lesson.wrist_threshold(arm)
    return {
        "gravity_peak": g.peak,
        "contact_poses": c.poses_with_contact,
        "contacts": {tuple(sorted(p.pair.names)): p.contacts for p in c.pairs if p.contacts},
        "thresholds": w.stable_up_to,
    }


def _timed(fn, *args) -> float:
    t0 = time.perf_counter()
    with redirect_stdout(io.StringIO()):
        fn(*args)
    return time.perf_counter() - t0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--model", default=None, help="MJCF file (default: bundled arm7)")
    args = parser.parse_args(argv)

    import redundancy as rd
    from redundancy.reports import lesson

    path = str(args.model or rd.model_path("arm7"))
    arm = rd.load(path, frame="ee")
    print(
        f"machine: {platform.processor() or platform.machine()}, {platform.system()} "
        f"{platform.release()}, "
        f"Python {platform.python_version()}, mujoco {mujoco.__version__}"
    )
    t_project, t_base = [], []
    for _ in range(args.repeat):
        t_project.append(_timed(lesson.print_tables, arm))
        t_base.append(_timed(baseline, path))
    a, b = statistics.median(t_project), statistics.median(t_base)
    print(
        f"lesson tables, medians of {args.repeat} runs: project {a:.3f} s, per-pose loop "
        f"{b:.3f} s, "
        f"speed-up {b / a:.2f}x"
    )
    ref, ours = baseline(path), project(path)
    same = (
        np.array_equal(np.round(ref["gravity_peak"], 2), np.round(ours["gravity_peak"], 2))
        and ref["contact_poses"] == ours["contact_poses"]
        and ref["contacts"] == ours["contacts"]
        and all(abs(ref["thresholds"][k] - ours["thresholds"][k]) < 1e-9 for k in ref["thresholds"])
    )
    print(
        f"same tables (gravity peaks, contact poses and per-pair contacts, kd thresholds): {same}"
    )
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())

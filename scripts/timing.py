"""Timing for the benchmark scripts: round-robin rounds, ratios of medians, the machine's line.

`bench.py` and `bench_ik.py` both time with these, so neither imports the other for them.
"""

from __future__ import annotations

import os
import platform
import statistics
import time
from collections.abc import Callable

import coal
import mujoco
import numpy as np
import pinocchio as pin


def machine() -> list[str]:
    """Lines describing the machine and the software versions."""
    cpu = platform.processor() or "?"
    try:
        with open("/proc/cpuinfo") as f:
            names = [ln.split(":", 1)[1].strip() for ln in f if ln.startswith("model name")]
        cpu = names[0] if names else cpu
    except OSError:
        pass
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    return [
        f"machine: {platform.node()} {platform.platform()}",
        f"cpu: {cpu}, {os.cpu_count()} logical cores, {usable} usable; "
        f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}",
        f"python {platform.python_version()}, numpy {np.__version__}, mujoco {mujoco.__version__}, "
        f"pinocchio {pin.__version__}, coal {getattr(coal, '__version__', '?')}",
    ]


def rounds(cases: dict[str, Callable[[], object]], repeats: int) -> dict[str, list[float]]:
    """Run every case once per round, ``repeats`` rounds; wall times [s] per case."""
    for f in cases.values():  # warm-up: workspaces, pools, caches
        f()
    times: dict[str, list[float]] = {k: [] for k in cases}
    for _ in range(repeats):
        for k, f in cases.items():
            t = time.perf_counter()
            f()
            times[k].append(time.perf_counter() - t)
    return times


def ratio(times: dict[str, list[float]], num: str, den: str | list[str]) -> float:
    """Median over rounds of time(num) / time(den) (den: one case or the sum of several)."""
    dens = [den] if isinstance(den, str) else den
    per_round = [a / sum(times[d][i] for d in dens) for i, a in enumerate(times[num])]
    return statistics.median(per_round)


def ms(times: dict[str, list[float]], k: str) -> float:
    """Median wall time of case ``k`` [ms]."""
    return 1e3 * statistics.median(times[k])


def per_call_us(times: dict[str, list[float]], k: str, calls: int) -> float:
    """Median wall time of case ``k`` per call, for a case that makes ``calls`` calls [us]."""
    return 1e6 * statistics.median(times[k]) / calls

"""Long run: a million poses through the batched APIs, with memory measured as it goes.

Sweeps ``--poses`` random arm7 poses in chunks through ``batch.jacobians``,
``batch.singular_values``, ``batch.mass_matrices``, ``batch.gravities`` and (every
``--distance-every``-th chunk) ``batch.distances``, keeping only running maxima, and prints the
process's resident memory after the first 10 000 poses and at the end. It also checks that
results do not depend on the number of threads.

Run: python scripts/soak.py [--poses 1000000] [--chunk 10000]
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np


def rss_mib() -> float:
    """Resident set size of this process [MiB] (Linux /proc)."""
    with open("/proc/self/statm") as f:
        pages = int(f.read().split()[1])
    import os

    return pages * os.sysconf("SC_PAGE_SIZE") / 2**20


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=1_000_000)
    parser.add_argument("--chunk", type=int, default=10_000)
    parser.add_argument("--distance-every", type=int, default=10)
    args = parser.parse_args(argv)

    import redundancy as rd
    from redundancy import batch

    arm = rd.load(rd.model_path("arm7"), frame="ee")
    rng = np.random.default_rng(7)
    peak_sigma = np.zeros(6)
    peak_tau = np.zeros(arm.nq)
    closest = np.inf
    baseline = None
    t0 = time.perf_counter()
    for i, start in enumerate(range(0, args.poses, args.chunk)):
        Q = rng.uniform(arm.lower, arm.upper, size=(min(args.chunk, args.poses - start), arm.nq))
        batch.jacobians(arm, Q)
        peak_sigma = np.maximum(peak_sigma, batch.singular_values(arm, Q).max(axis=0))
        batch.mass_matrices(arm, Q)
        peak_tau = np.maximum(peak_tau, np.abs(batch.gravities(arm, Q)).max(axis=0))
        if i % args.distance_every == 0:
            closest = min(closest, float(batch.distances(arm, Q, "mujoco").min()))
        if start + len(Q) >= 10_000 and baseline is None:
            baseline = rss_mib()
            print(f"after {start + len(Q)} poses: RSS {baseline:.1f} MiB", flush=True)
    final = rss_mib()
    print(
        f"after {args.poses} poses: RSS {final:.1f} MiB ({100 * (final / baseline - 1):+.2f} %), "
        f"{time.perf_counter() - t0:.1f} s"
    )
    print(
        f"peak sigma_max {peak_sigma[0]:.4f}, peak |gravity| {np.round(peak_tau, 2)}, "
        f"closest pair distance {closest:.4f} m"
    )
    Q = rng.uniform(arm.lower, arm.upper, size=(4096, arm.nq))
    same = all(
        np.array_equal(f(arm, Q, threads=1), f(arm, Q, threads=2))
        for f in (batch.jacobians, batch.mass_matrices, batch.gravities)
    )
    print(f"threads=1 and threads=2 give identical J, M and gravity: {same}")
    ok = same and final <= 1.10 * baseline
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

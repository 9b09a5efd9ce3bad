"""Benchmark: self-collision statistics on many-pair arms against arm7.

The audit's collision section sweeps random poses: MuJoCo's contact list at every pose and
every pair's distance (the audit uses MuJoCo's ``mj_geomDistance``). A ~40-sphere arm has
hundreds of pairs against arm7's 15, so computing every distance costs in proportion; the
statistics skip pairs whose bounding spheres are far (``prune=True``, the default) with
identical results. This script times, in one process, for arm7 and two ~40-sphere arms:

* contacts only (``distances=None``): MuJoCo's broad phase and narrow phase;
* the statistics with distances by ``mujoco`` and by ``coal``, pruned and unpruned;
* the audit's own collision section (:func:`redundancy.reports.sections.contacts`);

and checks that pruned and unpruned statistics are equal. Times are CPU seconds of this
process (``time.process_time``), best of ``--repeats``: other load on a shared machine
inflates wall time but not these. It then measures what a per-thread scene costs against a
lock for the shortest checker call, ``contacts(q)``.

Usage: ``python scripts/bench_collision.py [--n 10000] [--repeats 3]``
"""

from __future__ import annotations

import argparse
import sys
import threading
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path
from tempfile import TemporaryDirectory

import numpy as np

import redundancy as rd
from redundancy.collision import checker, collision_statistics
from redundancy.reports import sections

ROOT = Path(__file__).resolve().parent.parent


def sphere_arm7(per_link: int = 7) -> str:
    """arm7 with each collision geom replaced by spheres along its axis (37 spheres).

    Capsules and cylinders get spheres of their radius from end to end (inset by the radius
    for cylinders), the ellipsoid spheres of its smallest semi-axis along its long axis.
    """
    root = ET.parse(rd.model_path("arm7")).getroot()
    for body in root.iter("body"):
        for g in list(body.findall("geom")):
            if g.get("class") != "collision":
                continue
            body.remove(g)
            size = [float(x) for x in (g.get("size") or "").split()]
            r = size[0]
            if g.get("fromto"):
                ft = np.array([float(x) for x in (g.get("fromto") or "").split()])
                a, b = ft[:3], ft[3:]
            else:
                c = np.array([float(x) for x in g.get("pos", "0 0 0").split()])
                if g.get("type") == "ellipsoid":
                    half = np.array([0.0, 0.0, size[2] - size[0]])
                else:  # the shoulder cylinder, along y
                    half = np.array([0.0, size[1], 0.0])
                a, b = c - half, c + half
            length = float(np.linalg.norm(b - a))
            if g.get("type") == "cylinder":
                u = (b - a) / length
                a, b = (a + r * u, b - r * u) if length > 2 * r else ((a + b) / 2, (a + b) / 2)
            k = per_link if np.linalg.norm(b - a) > 0.05 else 3
            for i, s in enumerate(np.linspace(0.0, 1.0, k)):
                p = a + s * (b - a)
                ET.SubElement(
                    body,
                    "geom",
                    {
                        "name": f"{g.get('name')}_s{i}",
                        "class": "collision",
                        "type": "sphere",
                        "size": f"{r:.4f}",
                        "pos": " ".join(f"{x:.5f}" for x in p),
                    },
                )
    return ET.tostring(root, encoding="unicode")


def best(repeats: int, f: Callable[[], object]) -> tuple[float, object]:
    """Smallest CPU time of ``f()`` over ``repeats`` runs [s], and its last result."""
    times, out = [], None
    for _ in range(repeats):
        t = time.process_time()
        out = f()
        times.append(time.process_time() - t)
    return min(times), out


def same(a: rd.CollisionStatistics, b: rd.CollisionStatistics) -> bool:
    return (a.pairs, a.poses_with_contact, a.disagreements) == (
        b.pairs,
        b.poses_with_contact,
        b.disagreements,
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=10000, help="random poses")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    n, reps = args.n, args.repeats

    arms = {"arm7": rd.load(rd.model_path("arm7"))}
    arms["arm7 spheres"] = rd.load_string(sphere_arm7())
    tmp = TemporaryDirectory()
    sys.path.insert(0, str(ROOT))
    try:  # the corpus's iiwa14 (tests/corpus.py), when run from a checkout
        from tests import corpus

        model = corpus.MODELS["iiwa14"]
        arms["iiwa14 (corpus)"] = rd.load(model.write(Path(tmp.name)), frame=model.site)
    except ImportError:
        pass

    print(f"self-collision statistics over {n} random poses, CPU seconds (best of {reps})")
    head = (
        f"{'model':<17}{'geoms':>6}{'pairs':>6}{'contacts':>10}"
        f"{'mujoco':>9}{'unpruned':>10}{'coal':>8}{'unpruned':>10}{'audit':>8}  equal"
    )
    print(head)
    audit_cost: dict[str, float] = {}
    for name, arm in arms.items():
        ch = checker(arm)
        geoms = len({p.geom1 for p in ch.pairs} | {p.geom2 for p in ch.pairs})
        row = [f"{name:<17}{geoms:>6}{len(ch.pairs):>6}"]
        t, _ = best(reps, lambda arm=arm: collision_statistics(arm, n, 1, distances=None))
        row.append(f"{t:>10.3f}")
        equal = True
        for engine in ("mujoco", "coal"):
            tp, fast = best(reps, lambda a=arm, e=engine: collision_statistics(a, n, 1, e))
            tu, slow = best(
                reps, lambda a=arm, e=engine: collision_statistics(a, n, 1, e, prune=False)
            )
            equal &= same(fast, slow)  # type: ignore[arg-type]
            row.append(f"{tp:>9.3f}{tu:>10.3f}" if engine == "mujoco" else f"{tp:>8.3f}{tu:>10.3f}")
        ta, _ = best(reps, lambda arm=arm: sections.contacts(arm, n, 1))
        audit_cost[name] = ta
        row.append(f"{ta:>8.3f}  {'yes' if equal else 'NO'}")
        print("".join(row))
    base = audit_cost["arm7"]
    for name, t in audit_cost.items():
        if name != "arm7":
            print(f"audit collision section, {name} / arm7: {t / base:.2f}x")

    # Thread safety of the shortest call: a per-thread scene against a lock.
    arm = arms["arm7"]
    ch = checker(arm)
    q = arm.keyframe("home")
    calls = 20000
    t, _ = best(reps, lambda: [ch.contacts(q) for _ in range(calls)])
    lock = threading.Lock()

    def locked() -> None:
        for _ in range(calls):
            with lock:
                pass

    tl, _ = best(reps, lambda: [ch.mujoco_scene() for _ in range(calls)])
    tk, _ = best(reps, locked)
    print(
        f"checker.contacts(q) on arm7: {1e6 * t / calls:.2f} us per call; per-thread scene "
        f"lookup {1e6 * tl / calls:.3f} us, lock acquire+release {1e6 * tk / calls:.3f} us"
    )
    tmp.cleanup()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

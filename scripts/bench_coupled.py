"""Benchmark: the Jacobian of an arm with coupled joints against the same chain uncoupled.

A coupled arm's J is the chain model's J times G (`redundancy.engines.coupled`): the cost over
the chain alone is the coupling map (the followers' polynomials, or a loop's Newton solve,
cached per pose) and one matrix product. Timed on three arms of the guide and the tests, each
against its own file with the couplings removed (every chain joint free), at as many new poses:

* the mimic arm: two linear couplings (a URDF ``<mimic>``'s multiplier and offset), G constant;
* the polynomial arm: a quadratic joint equality and a follower of it, G per pose;
* the 2F-85-style gripper (``examples/gripper_2f85.xml``): two loops closed by Newton's method,
  reported for what a loop costs (no target: the solve is the point).

Usage: ``python scripts/bench_coupled.py [--calls 2000] [--repeats 7]``
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

import numpy as np

import redundancy as rd
from timing import machine, per_call_us, ratio, rounds

ROOT = Path(__file__).resolve().parents[1]

#: The polynomial arm of tests/test_coupled.py (j3 quadratic in j2, the slide j5 linear in j3).
POLY = (ROOT / "tests" / "test_coupled.py").read_text()


def _poly_mjcf() -> str:
    text = POLY[POLY.index('POLY_MJCF = """') + len('POLY_MJCF = """') :]
    return text[: text.index('"""')]


def _uncoupled(xml: str) -> str:
    """The MJCF with its <equality> removed: every chain joint free."""
    return re.sub(r"^\s*<equality>.*?</equality>", "", xml, flags=re.S | re.M)


def _linear(xml: str) -> str:
    """The polynomial arm with its couplings made linear (a mimic's multiplier and offset)."""
    return xml.replace('polycoef="0.05 0.8 0.3 0 0"', 'polycoef="0.05 0.8 0 0 0"')


def coupled_section(calls: int, repeats: int) -> list[str]:
    """Rows: J of each coupled arm against the chain alone, per call, at new poses each round."""
    poly = _poly_mjcf()
    gripper = (ROOT / "examples" / "gripper_2f85.xml").read_text()
    arms = {
        "linear couplings (mimic)": (_linear(poly), "tool", 2.0),
        "polynomial couplings": (poly, "tool", 2.0),
        "2F-85-style gripper (two loops)": (gripper, "right_pad", None),
    }
    cases = {}
    sizes = {}
    for label, (xml, tool, _) in arms.items():
        coupled = rd.load_string(xml, frame=tool)
        alone = rd.load_string(_uncoupled(xml), frame=tool)
        Q = rd.random_poses(coupled, calls, seed=0)
        # The chain alone at the same poses (its joints' values; the gripper's others held).
        pick = [coupled.chain_joint_names.index(n) for n in alone.joint_names]
        X = np.array([coupled.chain_pose(q)[pick] for q in Q])
        sizes[label] = (coupled.nq, alone.nq)
        state = {"k": 0}

        def lib(arm: rd.Arm = coupled, Q: np.ndarray = Q, state: dict = state) -> None:
            # New poses each round: the coupling map's per-pose cache is not what is timed.
            shift = 1e-9 * state["k"]
            state["k"] += 1
            for q in Q:
                arm.jacobian(q + shift)

        def chain(arm: rd.Arm = alone, X: np.ndarray = X) -> None:
            for x in X:
                arm.jacobian(x)

        cases[f"{label} coupled"] = lib
        cases[f"{label} alone"] = chain
    t = rounds(cases, repeats)
    out = [f"Jacobian of a coupled arm against its chain alone, {calls} new poses per round"]
    out.append(f"  {'arm':<36}{'alone us':>10}{'coupled us':>12}{'ratio':>8}{'target':>8}")
    for label, (_, _, target) in arms.items():
        r = ratio(t, f"{label} coupled", f"{label} alone")
        nq, nx = sizes[label]
        flag = "" if target is None else ("  ok" if r <= target else "  OVER")
        shown = "-" if target is None else f"{target:.2f}"
        out.append(
            f"  {label + f' ({nq} of {nx})':<36}{per_call_us(t, f'{label} alone', calls):>10.2f}"
            f"{per_call_us(t, f'{label} coupled', calls):>12.2f}{r:>8.2f}{shown:>8}{flag}"
        )
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--calls", type=int, default=2000, help="single-pose calls per round")
    p.add_argument("--repeats", type=int, default=7, help="rounds; medians are reported")
    args = p.parse_args(argv)
    print("\n".join([*machine(), *coupled_section(args.calls, args.repeats)]))
    return 0


if __name__ == "__main__":
    sys.exit(main())

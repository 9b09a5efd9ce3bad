"""Screenshot of the lab for the guide (docs/lab.png), and its real-time factor with one browser.

``python scripts/lab_screenshot.py [OUT.png] [--rtf SECONDS]``

Starts the lab for arm7, opens it in headless Chromium (Debian's ``chromium``; see
``redundancy.lab.browser``), folds the elbow past link2 / link4's contact (the links in
contact highlighted and named), removes the armature and nudges the arm (j7 buzzes in the
speed and torque plots, sigma_min's plot shows the fold), and saves the page (default:
``docs/lab.png``). Before saving it checks, in the browser, that every plot holds data inside
its window.

With ``--rtf SECONDS`` it then keeps the browser connected for that long and prints the
real-time factor (simulated over wall-clock time, each sample over the runner's last 2 s)
every second, with its minimum, median and maximum.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import redundancy as rd
from redundancy.lab import page as lab
from redundancy.lab.browser import LabBrowser

OUT = Path(__file__).resolve().parents[1] / "docs" / "lab.png"


def check_plots(b: LabBrowser) -> None:
    """Every plot has data, and its data lies inside its x window (as the tests assert)."""
    for title, p in b.plots().items():
        x = p["x"]
        if len(x) < 2 or not (p["min"] <= x[0] and x[-1] <= p["max"] and x[-1] > p["max"] - 0.1):
            where = f"data [{x[:1]}..{x[-1:]}], window [{p['min']}, {p['max']}]"
            raise RuntimeError(f"plot {title!r}: {where}")


def main(out: Path = OUT, rtf_seconds: float = 0.0) -> Path:
    arm = rd.load(rd.model_path("arm7"), frame="ee")
    with (
        lab.LabServer(arm, port=0) as server,
        LabBrowser(server.url, viewport=(1500, 1400)) as b,
    ):
        b.set_slider("j1 (rad)", 0.6)
        b.set_slider("j4 (rad)", 2.7)
        b.wait_readout("contacts", lambda s: "link2 / link4" in s, what="link2 / link4")
        b.select(lab.ARMATURE_LABEL, lab.ARMATURE_ZERO)
        b.click(lab.NUDGE_LABEL)
        b.wait_readout("peak", lambda s: float(s) > 13.0, what="j7 buzzing")
        time.sleep(2.5)
        check_plots(b)
        path = b.screenshot(out)
        print(f"saved {path}")
        if rtf_seconds > 0:
            b.click(lab.RESET_ALL_LABEL)
            samples = []
            t_end = time.monotonic() + rtf_seconds
            while time.monotonic() < t_end:
                time.sleep(1.0)
                samples.append(server.runner.real_time_factor)
                print(f"real-time factor {samples[-1]:.3f}", flush=True)
            good = [s for s in samples[2:] if s == s]  # the first 2 s fill the window
            print(
                f"real-time factor over {len(good)} s with one browser: min {min(good):.3f}, "
                f"median {statistics.median(good):.3f}, max {max(good):.3f}"
            )
    return path


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", nargs="?", type=Path, default=OUT)
    ap.add_argument("--rtf", type=float, default=0.0, metavar="SECONDS")
    args = ap.parse_args()
    main(args.out, args.rtf)

"""Screenshot of the lab for the README: ``python scripts/lab_screenshot.py [OUT.png]``.

Starts the lab for arm7, opens it in headless Chromium (Debian's ``chromium``; see
``redundancy.lab_browser``), turns the shoulder and folds the elbow to its limit (trail and
seven contact pairs), then removes the armature and nudges the arm (j7 buzzes in the plot),
and saves the page (default: ``docs/lab.png``).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import redundancy as rd
from redundancy import lab
from redundancy.lab.browser import LabBrowser

OUT = Path(__file__).resolve().parents[1] / "docs" / "lab.png"


def main(out: Path = OUT) -> Path:
    arm = rd.load(rd.model_path("arm7"), site="ee")
    with lab.LabServer(arm, port=0) as server, LabBrowser(server.url) as b:
        b.set_checkbox("joint axes", True)
        b.set_slider("j1 (rad)", 0.9)
        time.sleep(1.5)
        b.set_slider("j4 (rad)", 2.9)
        b.wait_readout("contacts", lambda s: len(s.split(", ")) == 7, what="seven pairs")
        b.select(lab.ARMATURE_LABEL, lab.ARMATURE_ZERO)
        b.click(lab.NUDGE_LABEL)
        b.wait_readout("peak", lambda s: float(s) > 13.0, what="j7 buzzing")
        time.sleep(2.0)
        path = b.screenshot(out)
    print(f"saved {path}")
    return path


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else OUT)

"""Driving the lab's page in a headless browser (Playwright with a system Chromium).

Used by the lab's browser test and by ``scripts/lab_screenshot.py``. Playwright's own browser
download is not needed: the browser is the system's Chromium (Debian's ``chromium``
package), found at ``$REDUNDANCY_CHROMIUM``, ``/usr/bin/chromium`` or on ``PATH``.

Controls are found by their labels (`redundancy.lab.page` exports them), readouts by their
``data-readout`` keys.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any

from ..errors import MissingDependencyError

if TYPE_CHECKING:
    from playwright.sync_api import Locator

#: Chromium flags needed in containers and offline machines (no sandbox, no GPU, no QUIC,
#: no background traffic).
CHROMIUM_ARGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
)


def find_chromium() -> str | None:
    """Path of a system Chromium: ``$REDUNDANCY_CHROMIUM``, ``/usr/bin/chromium`` or PATH."""
    env = os.environ.get("REDUNDANCY_CHROMIUM")
    if env:
        return env if Path(env).is_file() else None
    for candidate in ("/usr/bin/chromium", "chromium", "chromium-browser", "google-chrome"):
        found = shutil.which(candidate)
        if found:
            return found
    return None


def project(
    points: Any,
    position: Any,
    wxyz: Any,
    fov: float,
    box: dict[str, float],
) -> list[tuple[float, float]]:
    """Page coordinates of world points seen by a viser camera [CSS px].

    Args:
        points: World points, shape (n, 3) [m].
        position: Camera position [m].
        wxyz: Camera orientation: R in p_world = R p_camera + position, with viser's
            OpenCV-style camera axes (+z forward, +y down).
        fov: Vertical field of view [rad].
        box: The canvas on the page (`LabBrowser.scene_box`).
    """
    import numpy as np

    w, x, y, z = (float(c) for c in wxyz)
    R = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
    cam = (np.asarray(points, dtype=float).reshape(-1, 3) - np.asarray(position, float)) @ R
    f = 0.5 * box["height"] / np.tan(0.5 * fov)
    cx, cy = box["x"] + 0.5 * box["width"], box["y"] + 0.5 * box["height"]
    return [(cx + f * p[0] / p[2], cy + f * p[1] / p[2]) for p in cam]


class LabBrowser:
    """A headless Chromium page on the lab, with helpers to set controls and read readouts.

    Args:
        url: The lab's address.
        executable: Chromium binary (default: `find_chromium`).
        viewport: Page size (width, height) [CSS px].
        timeout: Default wait for page elements [s].

    Raises:
        MissingDependencyError: Playwright is not installed.
        FileNotFoundError: No Chromium was found.
    """

    def __init__(
        self,
        url: str,
        executable: str | None = None,
        viewport: tuple[int, int] = (1400, 860),
        timeout: float = 30.0,
    ) -> None:
        try:
            from playwright.sync_api import sync_playwright
        except ImportError as err:
            raise MissingDependencyError("playwright", "browser") from err
        exe = executable or find_chromium()
        if exe is None:
            raise FileNotFoundError(
                "no Chromium found: install Debian's `chromium` package or set REDUNDANCY_CHROMIUM"
            )
        self.url = url
        self.timeout = timeout
        self._profile = tempfile.TemporaryDirectory(prefix="redundancy-lab-chromium-")
        self._pw = sync_playwright().start()
        try:
            self._context = self._pw.chromium.launch_persistent_context(
                self._profile.name,
                executable_path=exe,
                args=list(CHROMIUM_ARGS),
                headless=True,
                viewport={"width": viewport[0], "height": viewport[1]},
            )
            self._context.set_default_timeout(timeout * 1000)
            self.page = self._context.new_page()
            self.open()
        except BaseException:
            self.close()
            raise

    # -- life cycle ------------------------------------------------------------------------
    def open(self) -> None:
        """(Re)load the page and wait until the readouts are shown and moving."""
        self.page.goto(self.url)
        self.page.wait_for_selector("[data-readout=time]")
        t0 = self.readout_float("time")
        self.wait_readout("time", lambda s: float(s) > t0, what="simulated time to advance")
        self.dismiss_notifications()

    def reload(self) -> None:
        """Reload the page: a disconnect and a reconnect."""
        self.page.reload()
        self.page.wait_for_selector("[data-readout=time]")
        t0 = self.readout_float("time")
        self.wait_readout("time", lambda s: float(s) > t0, what="simulated time to advance")
        self.dismiss_notifications()

    def close(self) -> None:
        """Close the browser and Playwright."""
        try:
            if hasattr(self, "_context"):
                self._context.close()
        finally:
            self._pw.stop()
            self._profile.cleanup()

    def __enter__(self) -> LabBrowser:
        return self

    def __exit__(
        self, tp: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    def dismiss_notifications(self) -> None:
        """Close viser's notifications (e.g. "software WebGL rendering detected")."""
        for button in self.page.locator(".mantine-Notification-closeButton").all():
            try:
                button.click(timeout=2000)
            except Exception:  # a notification that closed itself is fine
                pass

    # -- controls --------------------------------------------------------------------------
    def _control_id(self, label: str) -> str:
        loc = self.page.locator(f'xpath=//label[normalize-space(.)="{label}"]')
        loc.first.wait_for()
        uuid = loc.first.get_attribute("for")
        if not uuid:
            raise LookupError(f"no control labelled {label!r}")
        return uuid

    def slider_input(self, label: str) -> Locator:
        """The number box next to the slider labelled ``label``."""
        uuid = self._control_id(label)
        return (
            self.page.locator(f'[id="{uuid}"]')
            .locator("xpath=..")
            .locator("input:not([type=hidden])")
        )

    def set_slider(self, label: str, value: float) -> None:
        """Type ``value`` into the number box of the slider labelled ``label``."""
        box = self.slider_input(label)
        box.fill(f"{value:g}")
        box.press("Enter")
        box.blur()  # (Tab would focus, and so open, the next control)

    def slider_value(self, label: str) -> float:
        """The value shown in the slider's number box."""
        return float(self.slider_input(label).input_value())

    def select(self, label: str, option: str) -> None:
        """Choose ``option`` in the dropdown labelled ``label``."""
        uuid = self._control_id(label)
        self.page.locator(f'[id="{uuid}"]').click()
        self.page.get_by_role("option", name=option, exact=True).click()

    def click(self, label: str) -> None:
        """Click the button labelled ``label``."""
        self.page.get_by_role("button", name=label, exact=True).click()

    def set_checkbox(self, label: str, on: bool) -> None:
        """Tick or untick the checkbox labelled ``label``."""
        box = self.page.locator(f'[id="{self._control_id(label)}"]')
        if box.is_checked() != on:
            box.click()

    # -- readouts --------------------------------------------------------------------------
    def readout(self, key: str) -> str:
        """The text of the readout ``key`` (see `redundancy.lab.READOUT_KEYS`)."""
        return self.page.locator(f'[data-readout="{key}"]').inner_text().strip()

    def readout_float(self, key: str) -> float:
        """The readout ``key`` as a number (its first word)."""
        return float(self.readout(key).split()[0])

    def wait_readout(
        self,
        key: str,
        ok: Callable[[str], bool],
        timeout: float | None = None,
        what: str = "",
    ) -> str:
        """Poll the readout ``key`` until ``ok(text)`` holds, and return the text.

        Raises:
            TimeoutError: Not within ``timeout`` [s] (the message has the last value).
        """
        limit = time.monotonic() + (self.timeout if timeout is None else timeout)
        last = ""
        while True:
            last = self.readout(key)
            try:
                if ok(last):
                    return last
            except ValueError:
                pass
            if time.monotonic() > limit:
                raise TimeoutError(
                    f"readout {key!r}: waited for {what or 'a value'}; last {last!r}"
                )
            self.page.wait_for_timeout(200)

    # -- plots ----------------------------------------------------------------------------
    def plots(self) -> dict[str, dict[str, Any]]:
        """Each live plot's data and x window, as the browser holds them, by title.

        Read from the uPlot charts that viser's client registers for tests
        (``window.__viserTestpoints.uplots``).

        Returns:
            ``{title: {"x": [...], "y": [...], "min": x_min, "max": x_max, "ymin": ...,
            "ymax": ..., "created": times the chart was built}}``.
        """
        return self.page.evaluate(
            """() => {
              const out = {};
              const reg = (window.__viserTestpoints || {}).uplots || {};
              for (const {chart, createCount} of Object.values(reg)) {
                const title = chart.root.querySelector('.u-title')?.textContent || '';
                out[title] = {
                  x: Array.from(chart.data[0] || []),
                  y: Array.from(chart.data[1] || []),
                  min: chart.scales.x.min, max: chart.scales.x.max,
                  ymin: chart.scales.y.min, ymax: chart.scales.y.max,
                  created: createCount,
                };
              }
              return out;
            }"""
        )

    # -- the 3D scene --------------------------------------------------------------------
    def scene_box(self) -> dict[str, float]:
        """The 3D view's canvas on the page: x, y, width, height [CSS px]."""
        box = self.page.evaluate(
            """() => {
              let best = null;
              for (const c of document.querySelectorAll('canvas')) {
                if (c.closest('.uplot')) continue;
                const r = c.getBoundingClientRect();
                if (!best || r.width * r.height > best.width * best.height) best = r;
              }
              return best && {x: best.x, y: best.y, width: best.width, height: best.height};
            }"""
        )
        if not box:
            raise LookupError("no 3D canvas on the page")
        return box

    def drag(self, start: tuple[float, float], end: tuple[float, float], steps: int = 12) -> None:
        """Press the left button at ``start``, move to ``end`` in steps, release [CSS px]."""
        mouse = self.page.mouse
        mouse.move(*start)
        self.page.wait_for_timeout(200)  # let the scene see the pointer over the handle
        mouse.down()
        self.page.wait_for_timeout(100)
        for k in range(1, steps + 1):
            f = k / steps
            mouse.move(start[0] + f * (end[0] - start[0]), start[1] + f * (end[1] - start[1]))
            self.page.wait_for_timeout(50)
        mouse.up()

    def screenshot(self, path: str | os.PathLike[str]) -> Path:
        """Save a PNG of the page and return its path."""
        out = Path(path)
        out.parent.mkdir(parents=True, exist_ok=True)
        self.page.screenshot(path=str(out))
        return out

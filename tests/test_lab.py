"""The lab (issue #8): lesson 5.2's four experiments on the simulation, then in a browser.

The first part drives :class:`redundancy.lab_sim.LabSim` directly (fast, no browser). The
last test starts the lab's server and drives its page in headless Chromium (Debian's
``chromium`` package through Playwright, no browser download): it moves the controls for
each experiment, reads the readouts from the DOM and saves a screenshot. Without a browser
it is skipped with a message, unless ``REDUNDANCY_REQUIRE_BROWSER=1`` (set by CI), which
turns the skip into a failure.
"""

from __future__ import annotations

import os
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest

import redundancy as rd
from redundancy import collision
from redundancy.lab.sim import SIGMA_WINDOW, SPEED_WINDOW, LabSim, RealTimeRunner

#: The seven pairs in contact with the elbow folded to its 2.9 rad limit.
SEVEN_PAIRS = {
    "flange / link1",
    "flange / link2",
    "link1 / link5",
    "link1 / link6",
    "link2 / link4",
    "link2 / link5",
    "link2 / link6",
}


@pytest.fixture()
def sim(arm7: rd.Arm) -> LabSim:
    return LabSim(arm7)


def straight_up(sim: LabSim) -> np.ndarray:
    q = sim.home.copy()
    q[[1, 3, 5]] = 0.0  # j2 = j4 = j6 = 0; j1, j3, j5, j7 are 0 at home
    return q


# -- the simulation, without a browser -------------------------------------------------------


def test_starts_at_home_at_rest(sim: LabSim, arm7: rd.Arm) -> None:
    r = sim.readouts()
    np.testing.assert_array_equal(r.q, arm7.keyframe("home"))
    np.testing.assert_array_equal(r.targets, arm7.keyframe("home"))
    assert (r.kp, r.kd, sim.timestep) == (100.0, 5.0, 0.002)
    np.testing.assert_array_equal(r.armature, np.full(7, 0.05))
    assert r.sigma_min == pytest.approx(arm7.svd(arm7.keyframe("home")).sigma[-1], rel=1e-12)
    assert r.manipulability == pytest.approx(arm7.svd(arm7.keyframe("home")).manipulability)
    assert (r.contact_pairs, r.contacts_text) == ((), "none")
    assert (r.watch_joint, r.watch_speed, r.watch_limit) == ("j7", 0.0, 10.0)
    r = sim.run_for(1.0)  # gravity compensation holds the keyframe exactly
    assert np.max(np.abs(r.q - arm7.keyframe("home"))) < 1e-9


def test_experiment_1_straight_up_is_singular(sim: LabSim) -> None:
    sim.set_targets(straight_up(sim))
    r = sim.run_for(8.0)
    assert np.max(np.abs(r.q - straight_up(sim))) < 1e-3
    assert r.sigma_min < 2e-4
    assert r.manipulability < 1e-9
    t, s = sim.sigma_history()
    assert s[0] > 0.2  # near home (0.2332) at the start of the window
    assert s[-1] < 2e-4
    assert t[-1] - t[0] == pytest.approx(SIGMA_WINDOW, abs=0.05)


def test_experiment_2_folding_the_elbow(sim: LabSim, arm7: rd.Arm) -> None:
    sim.set_target("j4", 2.5)
    assert sim.run_for(3.0).contact_pairs == ()
    sim.set_target("j4", 2.58)
    r = sim.run_for(3.0)
    assert r.q[3] == pytest.approx(2.58, abs=2e-3)
    assert r.contact_pairs == ("link2 / link4",)
    assert len(r.contact_points) >= 1
    sim.set_target("j4", 2.9)
    r = sim.run_for(3.0)
    assert r.q[3] == pytest.approx(2.9, abs=2e-3)
    assert set(r.contact_pairs) == SEVEN_PAIRS
    # The same pairs as the library's checker at the simulated pose.
    pairs = collision.checker(arm7).contact_pairs(r.q)
    assert set(r.contact_pairs) == {p.label for p in pairs}


def test_with_contact_forces_the_links_stop_each_other(arm7: rd.Arm) -> None:
    sim = LabSim(arm7, contact_forces=True)
    sim.set_target("j4", 2.9)
    r = sim.run_for(3.0)
    assert 2.5 < r.q[3] < 2.6  # the forearm rests on the upper arm
    assert r.contact_pairs == ("link2 / link4",)
    sim.set_contact_forces(False)
    assert set(sim.run_for(3.0).contact_pairs) == SEVEN_PAIRS


def test_experiment_3_bare_wrist_buzzes_after_a_nudge(sim: LabSim) -> None:
    sim.set_armature(0.0)
    assert sim.run_for(1.0).watch_peak == 0.0  # at perfect rest nothing happens
    sim.nudge()
    r = sim.run_for(2.0)
    assert 13.0 < r.watch_peak < 16.0  # the lesson's "about 15 rad/s"
    assert abs(r.watch_speed) == pytest.approx(r.watch_peak, rel=0.02)
    assert abs(r.watch_torque) == pytest.approx(10.0)  # held only by the 10 N m limit
    _, v = sim.speed_history()
    assert len(v) == round(3.0 / sim.timestep)  # all 3 s so far (the window is 4 s)
    sim.run_for(2.0)
    _, v = sim.speed_history()
    assert len(v) == round(SPEED_WINDOW / sim.timestep)
    assert np.max(np.abs(v)) > 13.0
    # With the armature as modelled the same nudge dies away.
    sim.set_armature(None)
    sim.reset()
    sim.nudge()
    assert sim.run_for(2.0).watch_peak < 0.01


def test_experiment_4_kd_threshold(sim: LabSim) -> None:
    sim.set_armature(0.0)
    sim.nudge()
    assert sim.run_for(1.0).watch_peak > 10.0
    sim.set_kd(0.64)  # just above the threshold: still buzzing
    assert sim.run_for(2.0).watch_peak > 10.0
    sim.set_kd(0.6)  # below about 0.62: the buzz stops
    assert sim.run_for(3.0).watch_peak < 1e-3


def test_commands_validate_and_clip(sim: LabSim) -> None:
    sim.set_target("j4", 10.0)
    assert sim.targets[3] == 2.9
    sim.set_targets(np.full(7, -10.0))
    np.testing.assert_array_equal(sim.targets, sim.lower)
    with pytest.raises(rd.UnknownNameError):
        sim.set_target("j8", 0.0)
    with pytest.raises(rd.PoseError):
        sim.set_targets(np.zeros(6))
    with pytest.raises(rd.PoseError):
        sim.set_target("j1", float("nan"))
    with pytest.raises(ValueError, match="kd"):
        sim.set_kd(-1.0)
    with pytest.raises(ValueError, match="armature"):
        sim.set_armature(float("inf"))
    sim.run_for(0.5)
    sim.reset()
    assert sim.time == 0.0
    np.testing.assert_array_equal(sim.targets, sim.home)


def test_the_arm_is_not_modified(arm7: rd.Arm) -> None:
    sim = LabSim(arm7)
    sim.set_armature(0.0)
    sim.set_contact_forces(True)
    np.testing.assert_array_equal(arm7.mj_model.dof_armature, np.full(7, 0.05))
    assert arm7.mj_model.opt.disableflags == 0


def test_panda_runs(arm7: rd.Arm) -> None:
    panda = rd.load(rd.model_path("panda"), site="ee")
    sim = LabSim(panda)
    r = sim.run_for(0.5)
    assert r.watch_joint == panda.joint_names[-1]
    assert np.max(np.abs(r.q - panda.keyframe("home"))) < 1e-6


def test_real_time_runner_follows_the_wall_clock(sim: LabSim) -> None:
    frames: list[float] = []
    runner = RealTimeRunner(sim, fps=30.0)
    runner.callbacks.append(lambda s: frames.append(s.time))
    t0 = time.perf_counter()
    runner.start()
    time.sleep(1.0)
    runner.stop()
    wall = time.perf_counter() - t0
    assert not runner.running
    assert runner.errors == []
    # Real time, or slower when the machine is busy; never faster.
    assert 0.3 < sim.time <= wall + 0.01
    assert 5 <= len(frames) <= 40


def test_runner_survives_a_failing_callback(sim: LabSim) -> None:
    runner = RealTimeRunner(sim, fps=50.0)

    def boom(_: LabSim) -> None:
        raise RuntimeError("page gone")

    runner.callbacks.append(boom)
    runner.start()
    time.sleep(0.3)
    runner.stop()
    assert sim.time > 0.05
    assert runner.errors and isinstance(runner.errors[0], RuntimeError)


# -- the server ------------------------------------------------------------------------------


def test_server_serves_the_page(arm7: rd.Arm) -> None:
    lab_mod = pytest.importorskip("redundancy.lab.page", exc_type=ImportError)
    with lab_mod.LabServer(arm7, port=0) as lab:
        assert lab.url.startswith("http://127.0.0.1:")
        with urllib.request.urlopen(lab.url, timeout=10) as resp:
            assert resp.status == 200
            assert b"<html" in resp.read().lower()
        time.sleep(0.3)
        assert lab.runner.running
        assert lab.sim.time > 0.0
    assert not lab.runner.running


# -- in the browser --------------------------------------------------------------------------


def _browser_or_skip() -> str:
    require = os.environ.get("REDUNDANCY_REQUIRE_BROWSER") == "1"

    def missing(why: str) -> None:
        msg = f"browser test not run: {why}"
        if require:
            pytest.fail(msg + " (REDUNDANCY_REQUIRE_BROWSER=1)")
        pytest.skip(msg)

    for module, extra in (("viser", "lab"), ("playwright", "browser")):
        try:
            __import__(module)
        except ImportError:
            missing(f"{module} is not installed (pip install 'redundancy[{extra}]')")
    from redundancy.lab.browser import find_chromium

    exe = find_chromium()
    if exe is None:
        missing(
            "no Chromium: install Debian's package (apt-get install -y chromium) "
            "or set REDUNDANCY_CHROMIUM"
        )
    assert exe is not None
    return exe


def test_lab_in_the_browser(arm7: rd.Arm, tmp_path: Path) -> None:
    exe = _browser_or_skip()
    from redundancy.lab import page as L
    from redundancy.lab.browser import LabBrowser

    def num(s: str) -> float:
        return float(s.split()[0])

    t0 = time.monotonic()
    with L.LabServer(arm7, port=0) as lab, LabBrowser(lab.url, executable=exe) as b:
        page_loaded = time.monotonic() - t0
        assert num(b.readout("sigma_min")) == pytest.approx(0.2332, abs=1e-4)
        assert b.readout("contacts") == "none"
        assert b.slider_value("j4 (rad)") == 1.6

        # 1. The straight-up pose: sigma_min drops to 0.
        for joint in ("j2", "j4", "j6"):
            b.set_slider(f"{joint} (rad)", 0.0)
        b.wait_readout("sigma_min", lambda s: num(s) < 1e-3, what="sigma_min < 1e-3")
        assert num(b.readout("manipulability")) < 1e-3
        np.testing.assert_allclose(lab.sim.targets, straight_up(lab.sim))

        # A disconnect and a reconnect: the page comes back with the current state.
        b.reload()
        assert b.slider_value("j4 (rad)") == 0.0
        assert num(b.readout("sigma_min")) < 1e-3

        # 2. Folding the elbow from home: link2 / link4, then seven pairs at the limit.
        b.click(L.RESET_LABEL)
        b.wait_readout("sigma_min", lambda s: abs(num(s) - 0.2332) < 2e-3, what="home")
        assert b.slider_value("j4 (rad)") == 1.6
        b.set_slider("j4 (rad)", 2.58)
        b.wait_readout("contacts", lambda s: s == "link2 / link4", what="link2 / link4")
        b.set_slider("j4 (rad)", 2.9)
        text = b.wait_readout(
            "contacts", lambda s: len(s.split(", ")) == 7, what="seven pairs at j4 = 2.9"
        )
        assert set(text.split(", ")) == SEVEN_PAIRS

        # 3. Armature 0 and a nudge: j7 buzzes near 15 rad/s, held by its 10 N m limit.
        b.click(L.RESET_LABEL)
        b.wait_readout("contacts", lambda s: s == "none", what="no contacts at home")
        b.select(L.ARMATURE_LABEL, L.ARMATURE_ZERO)
        b.wait_readout("time", lambda s: lab.sim.model.dof_armature[6] == 0.0)
        b.click(L.NUDGE_LABEL)
        b.wait_readout("peak", lambda s: num(s) > 13.0, what="j7 buzzing")
        assert num(b.readout("peak")) < 16.0
        assert abs(num(b.readout("speed"))) > 13.0
        assert abs(num(b.readout("torque"))) == pytest.approx(10.0)

        # 4. kd below about 0.62: the buzz stops.
        b.set_slider(L.KD_LABEL, 0.6)
        b.wait_readout("peak", lambda s: num(s) < 0.01, what="the buzz to stop")
        assert lab.sim.kd == pytest.approx(0.6)

        shot = b.screenshot(tmp_path / "lab.png")
        extra = os.environ.get("REDUNDANCY_LAB_SCREENSHOT")
        if extra:
            b.screenshot(extra)
        assert lab.runner.errors == []
    assert shot.stat().st_size > 10_000
    total = time.monotonic() - t0
    print(f"lab browser test: page {page_loaded:.1f} s, total {total:.1f} s")
    assert total < 120

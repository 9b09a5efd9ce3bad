"""The momentum observer against MuJoCo simulating an arm pushed at its tool.

The arm follows a moving target under PD control with gravity compensation; from a known
time a known force F pushes at the tool. The observer sees only q, v and the actuators'
torque (``qfrc_actuator``) and must report J^T F.
"""

from __future__ import annotations

import re
from concurrent.futures import ThreadPoolExecutor

import mujoco
import numpy as np
import pytest

import redundancy as rd
from redundancy import batch

#: Three hinges with motors, joint damping, springs (stiffness and springref, when asked)
#: and a link compensated for half its weight by MuJoCo (gravcomp): every passive force the
#: observer must account for.
SPRUNG = """
<mujoco>
  <compiler angle="radian"/>
  <option timestep="0.002" integrator="Euler"/>
  <default><joint damping="0.3" armature="0.02" {springs}/><motor gear="1"/></default>
  <worldbody>
    <body name="l1" pos="0 0 0.1">
      <joint name="j1" axis="0 0 1" range="-3 3"/>
      <inertial pos="0 0 0.1" mass="2" diaginertia="0.02 0.02 0.01"/>
      <body name="l2" pos="0 0 0.2">
        <joint name="j2" axis="0 1 0" range="-2 2"/>
        <inertial pos="0.15 0 0" mass="1.5" diaginertia="0.005 0.02 0.02"/>
        <body name="l3" pos="0.3 0 0" gravcomp="0.5">
          <joint name="j3" axis="0 1 0" range="-2 2"/>
          <inertial pos="0.12 0 0" mass="0.8" diaginertia="0.002 0.01 0.01"/>
          <site name="tool" pos="0.25 0 0"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor joint="j1"/><motor joint="j2"/><motor joint="j3"/>
  </actuator>
</mujoco>
"""

F = np.array([5.0, -3.0, 4.0])  # the push at the tool [N], world axes
T_PUSH = 1.0  # when it starts [s]


def simulate(arm: rd.Arm, gain: float, seconds: float) -> dict[str, np.ndarray]:
    """PD with gravity compensation toward a moving target; F at the tool from T_PUSH.

    Returns the recorded q, v, tau (``qfrc_actuator``), the true external torque J^T F and
    the observer's estimate r, per step.
    """
    m = arm.mj_model
    d = mujoco.MjData(m)
    dt = m.opt.timestep
    q0 = 0.5 * (np.clip(arm.lower, -1, 1) + np.clip(arm.upper, -1, 1)) + 0.3
    d.qpos[:] = q0
    observer = rd.MomentumObserver(arm, gain)
    rec: dict[str, list[np.ndarray]] = {k: [] for k in ("t", "q", "v", "tau", "ext", "r")}
    for k in range(round(seconds / dt) + 1):
        t = k * dt
        q, v = d.qpos.copy(), d.qvel.copy()
        target = q0 + 0.2 * np.sin(np.pi * t + np.arange(arm.nq))
        d.ctrl[:] = 200.0 * (target - q) - 20.0 * v + arm.gravity(q)
        ext = arm.jacobian(q)[:3].T @ F if t >= T_PUSH - 1e-12 else np.zeros(arm.nq)
        d.qfrc_applied[:] = ext  # the force at the tool, as joint torques
        mujoco.mj_step(m, d)  # qfrc_actuator: the actuators' torque over this step
        r = observer.update(q, v, d.qfrc_actuator.copy(), dt)
        for key, value in zip(rec, (t, q, v, d.qfrc_actuator.copy(), ext, r), strict=True):
            rec[key].append(np.asarray(value))
    return {k: np.array(v) for k, v in rec.items()}


def ideal_filter(ext: np.ndarray, gain: float, dt: float) -> np.ndarray:
    """What the observer would answer with a perfect model: its first-order filter of the
    true torque, r' = K (ext - r), stepped as the observer integrates it (forward Euler, one
    step behind: the torque of a step shows in the momentum at the next)."""
    r = np.zeros_like(ext)
    for k in range(1, len(ext)):
        r[k] = r[k - 1] + gain * dt * (ext[k - 1] - r[k - 1])
    return r


@pytest.fixture(scope="module")
def arms(arm7: rd.Arm) -> dict[str, rd.Arm]:
    return {
        "arm7": arm7,
        "springs": rd.load_string(
            SPRUNG.format(springs='stiffness="8" springref="0.2"'), frame="tool"
        ),
        "no springs": rd.load_string(SPRUNG.format(springs=""), frame="tool"),
    }


@pytest.mark.parametrize("name", ["arm7", "springs", "no springs"])
def test_estimate_is_zero_before_the_push_and_J_transpose_F_after(arms: dict, name: str) -> None:
    arm, gain = arms[name], 50.0
    run = simulate(arm, gain, T_PUSH + 5.0 / gain)
    t, r, ext = run["t"], run["r"], run["ext"]
    size = np.max(np.abs(ext[-1]))
    # Before the push, once the start's transient (a jump to the target) has passed: the
    # estimate is the discretization of the integral, O(dt) (0.3 % of |J^T F| on arm7;
    # 4 times less at dt / 4).
    calm = (t >= 0.5) & (t < T_PUSH)
    assert np.max(np.abs(r[calm])) < 0.01 * size
    # 5 / gain after the push: e^-5 = 0.7 % of the step is still to come, plus the filter's
    # lag behind J^T F, which changes as the arm moves, plus the discretization: 2.1 % on
    # arm7.
    assert np.max(np.abs(r[-1] - ext[-1])) < 0.03 * size
    # Against the observer's own filter of the true torque: the model's discretization alone
    # (MuJoCo's Euler step, implicit in the damping, against the integral's rectangles).
    ideal = ideal_filter(ext, gain, arm.mj_model.opt.timestep)
    assert np.max(np.abs(r - ideal)[t >= 0.5]) < 0.01 * size


def test_springs_and_gravity_compensation_are_accounted_for(arms: dict) -> None:
    """The same run seen by an observer of the model without springs (or gravcomp) reports
    the springs' (gravcomp's) torque as external: the observer reads the model's."""
    run = simulate(arms["springs"], 50.0, T_PUSH - 0.2)
    blind = batch.external_torques(arms["no springs"], run["q"], run["v"], run["tau"], 0.002, 50.0)
    seen = batch.external_torques(arms["springs"], run["q"], run["v"], run["tau"], 0.002, 50.0)
    spring = 8.0 * (0.2 - run["q"][-1])  # what the springs add, stiffness (springref - q)
    assert np.max(np.abs(blind[-1] - spring)) < 0.05 * np.max(np.abs(spring))
    assert np.max(np.abs(seen[-1])) < 0.01 * np.max(np.abs(spring))
    no_gravcomp = rd.load_string(
        SPRUNG.format(springs='stiffness="8" springref="0.2"').replace(' gravcomp="0.5"', ""),
        frame="tool",
    )
    wrong = batch.external_torques(no_gravcomp, run["q"], run["v"], run["tau"], 0.002, 50.0)
    assert np.max(np.abs(wrong[-1])) > 10 * np.max(np.abs(seen[-1]))


def test_batch_external_torques_equal_stepping_the_observer(arms: dict) -> None:
    arm = arms["arm7"]
    run = simulate(arm, 30.0, 0.3)
    steps = np.full(len(run["t"]), 0.002)
    out = batch.external_torques(arm, run["q"], run["v"], run["tau"], steps, 30.0)
    assert np.array_equal(out, run["r"])
    assert np.array_equal(
        batch.external_torques(arm, run["q"], run["v"], run["tau"], 0.002, 30.0), out
    )
    with ThreadPoolExecutor(2) as pool:
        chunks = batch.external_torques(
            arm, run["q"], run["v"], run["tau"], 0.002, 30.0, executor=pool
        )
    assert np.array_equal(chunks, out)
    observer = rd.MomentumObserver(arm, 30.0)
    for q, v, tau in zip(run["q"][:5], run["v"][:5], run["tau"][:5], strict=True):
        observer.update(q, v, tau, 0.002)
    observer.reset()  # starts again: the same answers as a new observer
    again = [
        observer.update(q, v, tau, 0.002)
        for q, v, tau in zip(run["q"], run["v"], run["tau"], strict=True)
    ]
    assert np.array_equal(np.array(again), out)
    assert np.array_equal(observer.residual, out[-1])


def test_first_update_starts_at_zero_and_a_per_joint_gain(arm7: rd.Arm) -> None:
    q, v = np.full(7, 0.3), np.full(7, 0.5)
    observer = rd.MomentumObserver(arm7, np.linspace(10, 70, 7))
    assert not observer.update(q, v, np.ones(7), 0.01).any()
    assert np.array_equal(observer.gain, np.linspace(10, 70, 7))


def test_observer_input_is_checked(arm7: rd.Arm) -> None:
    q = np.zeros(7)
    with pytest.raises(
        rd.ParameterError,
        match=r"^gain must be a finite number \(or array of them\) > 0 \[1/s\], got 0.0$",
    ):
        rd.MomentumObserver(arm7, 0.0)
    with pytest.raises(
        rd.ParameterError,
        match=re.escape("gain must be a number or one per joint, shape (7,) [1/s]"),
    ):
        rd.MomentumObserver(arm7, [1.0, 2.0])
    with pytest.raises(rd.ParameterError, match="arm must be an Arm"):
        rd.MomentumObserver("arm7.xml", 1.0)  # type: ignore[arg-type]
    observer = rd.MomentumObserver(arm7, 10.0)
    bound = "a finite number (or array of them) in (0, 0.2) [s, below 2 / gain, where the observer diverges]"
    with pytest.raises(rd.ParameterError, match=f"^dt must be {re.escape(bound)}, got 0.0$"):
        observer.update(q, q, q, 0.0)
    with pytest.raises(rd.ParameterError, match=f"^dt must be {re.escape(bound)}, got 0.2$"):
        observer.update(q, q, q, 0.2)
    with pytest.raises(
        rd.ParameterError, match=r"^dt must be one number \[s\], got \[0.01, 0.01\]$"
    ):
        observer.update(q, q, q, [0.01, 0.01])
    with pytest.raises(rd.ParameterError, match="dt must be a finite number"):
        observer.update(q, q, q, float("nan"))
    with pytest.raises(rd.PoseError, match=re.escape("tau must have shape (7,) for joints")):
        observer.update(q, q, np.zeros(3), 0.01)
    with pytest.raises(rd.PoseError, match=r"^velocity has non-finite values: j1=nan$"):
        observer.update(q, np.array([np.nan, 0, 0, 0, 0, 0, 0]), q, 0.01)
    with pytest.raises(rd.PoseError, match=r"^pose has non-finite values: j7=inf$"):
        observer.update(np.array([0, 0, 0, 0, 0, 0, np.inf]), q, q, 0.01)
    Q = np.zeros((4, 7))
    with pytest.raises(
        rd.PoseError, match=re.escape("torques must have shape (4, 7), one row per pose")
    ):
        batch.external_torques(arm7, Q, Q, Q[:3], 0.01, 10.0)
    with pytest.raises(
        rd.ParameterError, match=re.escape("dt must be a number or one per step, shape (4,) [s]")
    ):
        batch.external_torques(arm7, Q, Q, Q, [0.01, 0.01], 10.0)
    with pytest.raises(rd.ParameterError, match="dt must be a finite number"):
        batch.external_torques(arm7, Q, Q, Q, -1.0, 10.0)

"""The lesson's joint PD controller: the torque reaches each joint whatever the actuator layout."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from redundancy.lab.control import JointPD

# Actuators declared in reverse joint order, with gears of both signs and not 1; joint "b"
# has none (the controller's torque goes through qfrc_applied there).
LAYOUT = """
<mujoco>
  <option gravity="0 0 -9.81" timestep="0.001"/>
  <worldbody>
    <body name="l1" pos="0 0 0.1">
      <joint name="a" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.04"/>
      <body name="l2" pos="0.3 0 0">
        <joint name="b" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.04"/>
        <body name="l3" pos="0.3 0 0">
          <joint name="c" axis="0 0 1"/>
          <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.03"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor joint="c" gear="-20" ctrlrange="-1e4 1e4"/>
    <motor joint="a" gear="50" ctrlrange="-1e4 1e4"/>
  </actuator>
</mujoco>
"""


def expected_torque(m, qpos, qvel, target, kp, kd):
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = qpos, qvel
    mujoco.mj_forward(m, d)
    return d.qfrc_bias + kp * (target - qpos) - kd * qvel


@pytest.mark.parametrize(("kp", "kd"), [(100.0, 5.0), (0.0, 0.0), (30.0, 0.7)])
def test_each_joint_gets_the_commanded_torque(kp, kd):
    m = mujoco.MjModel.from_xml_string(LAYOUT)
    d = mujoco.MjData(m)
    d.qpos[:] = [0.3, -0.4, 0.2]
    d.qvel[:] = [0.1, -0.2, 0.3]
    target = np.array([0.0, 0.1, -0.1])
    pd = JointPD(m)
    assert [(a, k, g) for a, k, g in pd.actuators] == [(0, 2, -20.0), (1, 0, 50.0)]
    assert pd.unactuated.tolist() == [1]
    for _ in range(5):
        tau = expected_torque(m, d.qpos.copy(), d.qvel.copy(), target, kp, kd)
        pd.step(m, d, target, kp, kd)
        got = [pd.applied(d, k) for k in range(m.nv)]
        np.testing.assert_allclose(got, tau, rtol=1e-12, atol=1e-12)
    # ctrl carries tau / gear, with the gear's sign.
    assert d.ctrl[0] == pytest.approx(pd.applied(d, 2) / -20.0, rel=1e-12)
    assert d.ctrl[1] == pytest.approx(pd.applied(d, 0) / 50.0, rel=1e-12)


def test_ctrlrange_clamps_the_torque_as_on_the_arm():
    m = mujoco.MjModel.from_xml_string(
        LAYOUT.replace('ctrlrange="-1e4 1e4"', 'ctrlrange="-0.1 0.1"')
    )
    d = mujoco.MjData(m)
    pd = JointPD(m)
    pd.step(m, d, np.array([2.0, 0.0, 2.0]), kp=1000.0, kd=0.0)
    assert pd.applied(d, 0) == pytest.approx(0.1 * 50.0)  # clamped: 5 N m, not 2000
    assert pd.applied(d, 2) == pytest.approx(-0.1 * -20.0)  # ctrl -0.1 times gear -20

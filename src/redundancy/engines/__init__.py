"""The engine layer: the only code that asks MuJoCo or Pinocchio for kinematics and dynamics.

Each engine module holds one class implementing :class:`~redundancy.engines.contract.Engine`
for one arm and tool site, returning arrays in the library's joint order (MuJoCo's):

* :mod:`redundancy.engines.mujoco`: :class:`~redundancy.engines.mujoco.MujocoEngine`;
* :mod:`redundancy.engines.pinocchio`: :class:`~redundancy.engines.pinocchio.PinocchioEngine`.
"""

from __future__ import annotations

from typing import Literal

EngineName = Literal["mujoco", "pinocchio"]
ENGINES: tuple[EngineName, ...] = ("mujoco", "pinocchio")

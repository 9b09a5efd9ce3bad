"""The engine layer: the only code that asks MuJoCo, Pinocchio or Drake for kinematics and dynamics.

Each engine module holds one class implementing `Engine` for one arm and tool site, returning arrays
in the library's joint order (MuJoCo's):

* `redundancy.engines.mujoco`: `MujocoEngine`;
* `redundancy.engines.pinocchio`: `PinocchioEngine`;
* `redundancy.engines.drake`: `DrakeEngine`, with the ``drake`` extra (pydrake), imported only
  when an arm is loaded with pydrake installed.

`redundancy.engines.mujoco_warnings` collects MuJoCo's warnings per thread (the loader's and
the simulation's, as well as the engine's).
"""

from __future__ import annotations

from typing import Literal

EngineName = Literal["mujoco", "pinocchio", "drake"]
#: Every engine the library knows; an arm has the first two always, Drake when it can take part
#: (``arm.absent_engines`` says why not).
ENGINES: tuple[EngineName, ...] = ("mujoco", "pinocchio", "drake")
#: The engine every other one is checked against (the cross-check's first column).
REFERENCE: EngineName = ENGINES[0]

"""MuJoCo time-stepping for the lab: the one place a simulation calls MuJoCo.

A simulation owns one ``MjData``, its state, advanced in time under its owner's lock; the engines'
per-thread data (`redundancy.engines.mujoco`) serve single poses and stacks instead, at rest.
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco


def new_state(model: mujoco.MjModel) -> mujoco.MjData:
    """A simulation state of ``model`` at ``qpos0``, at rest."""
    return mujoco.MjData(model)


def step(model: mujoco.MjModel, data: mujoco.MjData, actuate: Callable[[], None]) -> None:
    """One timestep: ``mj_step1``, then ``actuate()``, then ``mj_step2``.

    ``mj_step1`` runs the position and velocity stages, so ``qfrc_bias`` is current for the
    state about to be integrated when ``actuate`` sets ``ctrl`` or ``qfrc_applied``; ``mj_step2``
    then applies them and integrates. Together they are one ``mj_step``, without the extra
    ``mj_forward`` a read-then-step loop needs.
    """
    mujoco.mj_step1(model, data)
    actuate()
    mujoco.mj_step2(model, data)


def settle(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """Every quantity of the state derived again from its qpos and qvel (``mj_forward``)."""
    mujoco.mj_forward(model, data)


def place(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """Body, geom and site frames at the state's qpos (``mj_kinematics``, what drawing needs)."""
    mujoco.mj_kinematics(model, data)

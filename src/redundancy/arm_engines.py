"""An [`Arm`][redundancy.Arm]'s engines by name: the reference, the others, an absent one's reason.

`_Engines` is a part of `Arm`, which documents its methods.
"""

from __future__ import annotations

import mujoco

from .engines import REFERENCE, EngineName
from .engines.contract import Engine
from .engines.mujoco import MujocoEngine
from .engines.pinocchio import PinocchioEngine
from .errors import AbsentEngineError, UnknownNameError


class _Engines:
    """`Arm`'s engine lookups; they read the Arm's attributes declared here."""

    engines: dict[str, Engine]
    absent_engines: dict[str, str]

    @property
    def mujoco(self) -> MujocoEngine:
        """The MuJoCo engine (``engines["mujoco"]``)."""
        return self.engines["mujoco"]  # type: ignore[return-value]

    @property
    def pinocchio(self) -> PinocchioEngine:
        """The Pinocchio engine, with the bridged values (``engines["pinocchio"]``)."""
        return self.engines["pinocchio"]  # type: ignore[return-value]

    @property
    def reference(self) -> Engine:
        """The engine the others are checked against (`redundancy.engines.REFERENCE`)."""
        return self.engines[REFERENCE]

    def _others(self, name: str) -> tuple[Engine, ...]:
        """Every engine but ``name``, in order (those that confirm ``name``'s answers)."""
        return tuple(e for n, e in self.engines.items() if n != name)

    @property
    def mj_model(self) -> mujoco.MjModel:
        """MuJoCo's compiled model (shared, do not modify)."""
        return self.mujoco.model

    def engine(self, name: EngineName) -> Engine:
        """One engine, by name (``"mujoco"``, ``"pinocchio"`` or ``"drake"``).

        Raises:
            AbsentEngineError: An engine of `absent_engines` (the message says why).
            UnknownNameError: Any other name (lists the engines).
        """
        try:
            return self.engines[name]
        except (KeyError, TypeError):
            if isinstance(name, str) and name in self.absent_engines:
                reason = self.absent_engines[name]
                raise AbsentEngineError(name, reason, tuple(self.engines)) from None
            raise UnknownNameError("engine", str(name), tuple(self.engines)) from None

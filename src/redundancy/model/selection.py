"""What `select_arm` returns: the arm's joints, the held ones and what was set aside.

Below the modules that hold the rest of the robot (`redundancy.model.couplings`,
`redundancy.model.contact_rules`, `redundancy.model.reduced_pinocchio`) and the loaders that
report what they set aside; `redundancy.model.robot` re-exports its names.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from ..engines.mujoco import JOINT_TYPES

Array = NDArray[np.float64]

#: Coordinates of each MuJoCo joint type in qpos.
JOINT_NQ = {"hinge": 1, "slide": 1, "ball": 4, "free": 7}


RestSpec = str | Mapping[str, float | Sequence[float]] | None


@dataclass(frozen=True)
class SetAside:
    """Something in the robot's file that does not reach the arm, and why it does not matter.

    With ``reaches_arm``: something the loader read or mended on the way to both engines.

    Attributes:
        what: The element, e.g. ``"equality constraint"``.
        name: Its name (or display name).
        reason: Why the arm's numbers do not depend on it (or what was done with it).
        reaches_arm: The arm does depend on it (a link the arm moves, a file read in place):
            the audit lists it as read or mended, never as set aside.
    """

    what: str
    name: str
    reason: str
    reaches_arm: bool = False

    def __str__(self) -> str:
        return f"{self.what} {self.name!r}: {self.reason}"


@dataclass(frozen=True)
class MissingMesh:
    """A mesh the file names that is found nowhere: its link's geom is left out.

    Attributes:
        link: The link (body) whose collision geom names it.
        file: The file name as written (``package://...``, a relative path...).
        looked: The places looked in, in order.
    """

    link: str
    file: str
    looked: tuple[str, ...]

    def __str__(self) -> str:
        return f"link {self.link!r}: mesh {self.file!r} found nowhere"


@dataclass(frozen=True)
class ArmSelection:
    """The arm inside a robot: its joints, and the joints held at rest.

    Attributes:
        tool: Name of the tool frame (site, body or link) as the user gave it.
        tool_body: MuJoCo body id that carries the tool.
        base: Body the chain starts below, or None (the world).
        joints: Arm joint names, in chain order (world to tool).
        held: Held joint name -> its rest value (a float for hinge and slide joints, a tuple
            for ball and free joints, MuJoCo's convention: quaternions w x y z) [rad or m].
        rest: Where the held values come from: ``"qpos0"``, ``"keyframe 'name'"`` or
            ``"given"``.
        qpos: The whole robot's configuration at rest (MuJoCo's qpos; the arm joints at their
            ``qpos0``).
        set_aside: Elements of the file the arm does not depend on.
        coupled: The chain's coupled joints (`redundancy.model.coupled_chain`), None when
            none: ``joints`` are then the arm's coordinates, else every joint it moves.
    """

    tool: str
    tool_body: int
    base: str | None
    joints: tuple[str, ...]
    held: dict[str, float | tuple[float, ...]]
    rest: str
    qpos: Array
    set_aside: tuple[SetAside, ...] = field(default=())
    coupled: Any = None


def joint_kind(model: mujoco.MjModel, j: int) -> str:
    """MuJoCo joint ``j``'s type: ``"hinge"``, ``"slide"``, ``"ball"`` or ``"free"``."""
    return JOINT_TYPES[mujoco.mjtJoint(model.jnt_type[j])]

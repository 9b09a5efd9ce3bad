"""The last step of every load: Pinocchio's model bridged and reduced, checked, and the Arm built.

`LoadState` carries what a load asks for and what it has set aside on the way, from
`redundancy.model.loading` through the MJCF or URDF path (`redundancy.model.mjcf_loading`,
`redundancy.model.urdf_loading`) to `build_arm`.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import mujoco

from ..arm import Arm
from ..engines.mujoco import joint_limits, object_names
from .actuators import actuator_armature, actuator_damping, joint_force_limits
from .bridges import Bridge, bridge, bridge_robot, check_pinocchio
from .coupled_chain import coupling_map
from .drake_loading import DrakeSource, add_drake
from .robot import ArmSelection, RestSpec, SetAside, keyframe_moves, reduce_pinocchio
from .selection import MissingMesh
from .support import inertia_causes


class LoadState:
    """What a load asks for (tool, base, rest) and what it has set aside so far."""

    def __init__(self, tool: str, base: str | None, rest: RestSpec, source: str) -> None:
        self.tool, self.base, self.rest = tool, base, rest
        self.source = source
        self.set_aside: list[SetAside] = []
        self.defects: list[str] = []  # defects of the file on bodies the arm moves
        self.missing_inertia: list[str] = []  # links the arm moves without inertial data
        self.missing_meshes: list[MissingMesh] = []  # meshes found nowhere (geoms left out)
        self.inertia_causes: dict[int, tuple[str, ...]] = {}  # bodies whose masses MuJoCo sets
        self.changed = False  # Pinocchio must read an edited copy of the MJCF
        #: What Drake's parser reads: the user's file, or text (None: nothing to read).
        self.drake_source: DrakeSource | None = None
        self.xml_root: ET.Element | None = None  # the MJCF as written (Drake's inertia bridge)
        self.drake_bridges: list[Bridge] = []  # what the loader bridged for Drake already


def build_arm(
    mj: mujoco.MjModel,
    full: mujoco.MjModel,
    pm_full: object,
    sel: ArmSelection,
    robot: LoadState,
    bridged: tuple[Bridge, ...],
    xml_root: ET.Element | None,
    model_format: str,
    frame_type: str,
) -> Arm:
    """Bridge and reduce Pinocchio's model, check both engines see the same arm, build it.

    ``bridged`` lists what the loader has already changed in Pinocchio's model. What is
    bridged on the whole robot (a posed root, inertias Pinocchio reads differently, the tool
    frame's placement) is bridged before the held joints are locked; per-joint values after.
    """
    site = robot.tool
    robot_bridges = bridge_robot(
        pm_full,  # type: ignore[arg-type]
        full,
        site,
        frame_type,
        xml_root,
        robot.inertia_causes,
    )
    pm = reduce_pinocchio(pm_full, full, sel)
    joint_names = object_names(mj, mujoco.mjtObj.mjOBJ_JOINT)
    check_pinocchio(pm, joint_names, site, frame_type)  # type: ignore[arg-type]
    lower, upper = joint_limits(mj)
    # Armature and damping as the dynamics see them: the joint's own plus gear^2 times what
    # its actuators add (rotor-side values reflected through the transmission).
    armature = mj.dof_armature + actuator_armature(mj)
    damping = mj.dof_damping + actuator_damping(mj)
    effort = joint_force_limits(mj)
    bridges = (
        bridged
        + robot_bridges
        + bridge(
            pm,  # type: ignore[arg-type]
            mj,
            joint_names,
            effort,
            armature,
            damping,
            lower,
            upper,
        )
    )
    coupling = coupling_map(full, sel.coupled) if sel.coupled is not None else None
    arm = Arm(
        mj,
        pm,
        site,
        robot.source,
        armature=armature,
        damping=damping,
        effort_limit=effort,
        bridges=bridges,
        model_format=model_format,
        held=sel.held,
        set_aside=tuple(robot.set_aside),
        defects=tuple(robot.defects),
        missing_inertia=tuple(robot.missing_inertia),
        missing_meshes=tuple(robot.missing_meshes),
        robot_model=full,
        frame_type=frame_type,
        base=sel.base,
        rest=sel.rest,
        key_moves=tuple(keyframe_moves(full, k, sel.joints, sel.held) for k in range(full.nkey)),
        coupling=coupling,
    )
    # Drake reads the file itself: the bodies whose inertia MuJoCo sets, for its inertia bridge.
    causes = dict(robot.inertia_causes)
    if robot.xml_root is not None:
        causes = {**inertia_causes(robot.xml_root, full), **causes}
    add_drake(arm, robot.drake_source, full, sel.qpos, causes, tuple(robot.drake_bridges))
    return arm

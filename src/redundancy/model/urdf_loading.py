"""A URDF into both engines: its tree checked, its masses mended, each engine's importer.

See `redundancy.model.urdf` for how the library reads URDF.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco

from ..arm import Arm
from .assembly import LoadState, build_arm
from .bridges import Bridge
from .drake_loading import DrakeSource
from .robot import reduce_mujoco, select_arm
from .selection import SetAside
from .support import check_supported
from .urdf import (
    DisabledPairs,
    UrdfTree,
    build_mujoco,
    build_pinocchio,
    chain_joints,
    check_urdf,
    prepare_urdf,
    read_disabled_pairs,
    resolve_frame,
)
from .urdf_tree import below_planar_base, check_chain, mass_settings


def _arm_ends(tree: UrdfTree, robot: LoadState) -> tuple[str, str | None]:
    """The tool link and the base link the arm starts from, each said where it was inferred.

    A tool name that is a link and a fixed joint to another link is the link; a planar base
    is held by default (`urdf_tree.below_planar_base`). ``robot.base`` stays what was asked.
    """
    tool_link = resolve_frame(tree, robot.tool)
    joint = tree.joints.get(robot.tool)
    if joint is not None and joint[0] == "fixed" and tool_link == robot.tool != joint[2]:
        robot.set_aside.append(  # the name is ambiguous: say which frame it was read as
            SetAside(
                "tool frame",
                robot.tool,
                f"names a link and a fixed joint (to link {joint[2]!r}): the link is the tool; "
                f"the joint's frame is frame={joint[2]!r}",
                reaches_arm=True,
            )
        )
    base_link = robot.base  # select_arm checks it is a link on the chain to the tool
    if base_link is None and (below := below_planar_base(tree, tool_link)) is not None:
        base_link = below
        robot.set_aside.append(
            SetAside(
                "planar base",
                below,
                "a mobile base: held where the file puts it, the arm starts at its link "
                f"(base={below!r}, as a floating base is held)",
            )
        )
    return tool_link, base_link


def load_urdf(
    text: str,
    root: ET.Element,
    base: Path,
    pairs: DisabledPairs | None,
    robot: LoadState,
) -> Arm:
    """Both engines' URDF importers on the whole robot, checked (see `urdf`)."""
    source = robot.source
    tree = check_urdf(root, source)
    tool_link, base_link = _arm_ends(tree, robot)
    if base_link is None or base_link in tree.links:
        check_chain(tree, chain_joints(tree, tool_link, base_link), source)
    disabled, skipped = read_disabled_pairs(pairs, tree)
    if skipped is not None:
        robot.set_aside.append(skipped)
    mended, notes, defects, missing, follows = prepare_urdf(
        root, tree, tool_link, base_link, source
    )
    robot.missing_inertia += missing
    if notes:
        text = ET.tostring(mended, encoding="unicode")
        robot.set_aside += notes
        # Drake reads the mended text too: the defects are mended the same way in every engine.
        robot.drake_source = DrakeSource(None, text, True)
    robot.defects += defects
    pm, continuous = build_pinocchio(text, source)
    spec, full, meshes = build_mujoco(
        text, base, source, tree, tool_link, tool_link, disabled, robot.missing_meshes
    )
    robot.set_aside += meshes
    settings = tuple(mass_settings(root))
    if settings:  # MuJoCo's compiled masses are the robot's: bridged wherever they differ
        robot.inertia_causes = {b: settings for b in range(1, full.nbody)}
    sid = mujoco.mj_name2id(full, mujoco.mjtObj.mjOBJ_SITE, tool_link)
    made_fixed = {a.name: a.reason for a in notes if a.what == "joint"}
    sel = select_arm(
        full, robot.tool, int(full.site_bodyid[sid]), base_link, robot.rest, made_fixed, follows
    )
    mj, aside = reduce_mujoco(spec, full, sel)
    robot.set_aside += aside
    # URDF inertials are explicit and the joints are checked above: only the generic
    # refusals apply (non-finite values, negative damping, inverted ranges).
    check_supported(mj, None, strict=False)
    rebuilt = tuple(
        Bridge(
            "continuous joint as one angle",
            name,
            (-math.inf, math.inf),
            "URDF continuous joint (Pinocchio's parser makes it a cos/sin pair)",
        )
        for name in continuous
        if name in sel.joints
    )
    robot.tool = tool_link
    return build_arm(mj, full, pm, sel, robot, rebuilt, None, "URDF", "body")

"""An MJCF into both engines: MuJoCo's spec, the tool a site; Pinocchio's parser or its bridge.

Where Pinocchio's parser reads the file differently from MuJoCo (strict loading) or cannot read
it, Pinocchio gets MuJoCo's compiled model written out as plain MJCF
(`redundancy.model.resolved`); of several trees, it gets the arm's alone.
"""

from __future__ import annotations

import copy
import os
import tempfile
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np

from ..arm import Arm
from ..engines.mujoco import captured_warnings
from ..errors import ModelError, UnknownNameError
from .assembly import LoadState, build_arm
from .bridges import Bridge, whole_model
from .content import feed_assets, mujoco_assets, record
from .drake_loading import DrakeSource, resolved_robot
from .names import display_names
from .resolved import forced_causes, resolve_causes, resolved_mjcf, unit_causes
from .robot import SetAside, reduce_mujoco, select_arm
from .support import check_robot_values, check_supported
from .xmlfile import decode_xml, expand_includes, parse_xml


def read_mujoco(
    xml: str | None, path: Path | None, base: Path | None = None, tool: object = None
) -> tuple[mujoco.MjSpec, mujoco.MjModel, str]:
    """MuJoCo's model of the whole robot, with the tool as a site.

    Returns:
        An uncompiled copy of the spec (the held joints are deleted from it: editing a
        compiled spec costs 50 ms a joint, a fresh copy 2 ms), the compiled model, and
        ``"site"`` or ``"body"``: what the tool is in the MJCF.
    """
    try:
        # MuJoCo's compile-time warnings (a NaN in the XML, a singular inertia, a deprecated
        # attribute) would be printed and written to MUJOCO_LOG.TXT; check_supported refuses
        # their causes with the library's own message instead.
        with captured_warnings():
            if path is not None:
                spec = mujoco.MjSpec.from_file(str(path))
            else:
                spec = mujoco.MjSpec.from_string(xml or "")
                if base is not None:
                    # Transcoded text of a file: relative asset paths count from its directory.
                    spec.modelfiledir = str(base)
            if spec.compiler.fusestatic:
                # Fused bodies would leave the compiled model with fewer bodies than the spec
                # the held joints are edited in; unfused, masses and placements are the same.
                spec.compiler.fusestatic = False
            feed_assets(spec, mujoco_assets(spec, base or Path.cwd()))
            pristine = spec.copy()
            model = spec.compile()  # MuJoCo's own errors first, then the tool's
    except (ValueError, TypeError) as err:
        raise ModelError(f"MuJoCo could not compile the model: {err}") from err
    kind = _mjcf_tool(pristine, tool)
    if kind == "body":  # the site added to the copy: compile a copy of the copy
        edited = pristine.copy()
        with captured_warnings():
            model = pristine.compile()
        pristine = edited
    return pristine, model, kind


def record_models(root: ET.Element, folder: Path, depth: int = 0) -> None:
    """Record the files of every ``<model>`` asset (what ``<attach>`` attaches) and theirs.

    MuJoCo reads an attached model's file from the model's folder, and that file's includes
    and meshes from its own folder; the recipe carries them all, so a copy of the arm is
    the robot that was loaded even after one of them changes on disk.
    """
    for el in root.iter("model"):
        name = el.get("file")
        path = Path(os.path.normpath(folder / name.replace("\\", "/"))) if name else None
        if path is None or not path.is_file() or depth > 20:
            continue  # MuJoCo has refused a missing one already
        data = path.read_bytes()
        record(path, data)
        inner = expand_includes(parse_xml(decode_xml(data, str(path))[0]), path.parent, [])
        try:
            with captured_warnings():
                spec = mujoco.MjSpec.from_file(str(path))
        except ValueError:
            continue
        for asset in mujoco_assets(spec, path.parent):
            record(asset)
        record_models(inner, path.parent, depth + 1)


def _read_pinocchio(path: Path) -> object:
    import pinocchio as pin

    try:
        return pin.buildModelFromMJCF(str(path))
    except Exception as err:  # Pinocchio raises bare RuntimeError/ValueError from C++.
        raise ModelError(f"Pinocchio could not read the model: {err}") from err


def _pinocchio_from_text(xml: str) -> object:
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "model.xml"
        p.write_text(xml, encoding="utf-8")
        return _read_pinocchio(p)


def _mjcf_tool(spec: mujoco.MjSpec, tool: str) -> str:
    """``"site"`` or ``"body"``: what the MJCF tool frame is; a body gets a site of its name.

    Raises:
        UnknownNameError: Neither a site nor a body (the message lists both).
    """
    names = [s.name for s in spec.sites if s.name] + [
        b.name for b in spec.bodies if b.name and b.name != "world"
    ]
    if not isinstance(tool, str):
        raise UnknownNameError("site or body", repr(tool), names)
    if tool and spec.site(tool) is not None:
        return "site"
    body = spec.body(tool) if tool and tool != "world" else None
    if body is None:
        raise UnknownNameError("site or body", tool, names)
    # MuJoCo's tool is a site: one at the body's origin, named after it (Pinocchio reads
    # the body's own frame).
    body.add_site(name=tool)
    return "body"


def load_mjcf(
    spec: mujoco.MjSpec,
    full: mujoco.MjModel,
    kind: str,
    root: ET.Element,
    strict: bool,
    robot: LoadState,
    path: Path | None,
) -> Arm:
    """Both engines' MJCF parsers on the whole robot, then the arm selected and the rest held."""
    if any(c.get("fusestatic") == "true" for c in root.iter("compiler")):
        robot.set_aside.append(
            SetAside(
                "compiler option",
                'fusestatic="true"',
                "bodies without joints kept as bodies (the same masses and placements; "
                "fused, a held joint's body could not be placed)",
            )
        )
    robot.xml_root = root
    sid = mujoco.mj_name2id(full, mujoco.mjtObj.mjOBJ_SITE, robot.tool)
    sel = select_arm(full, robot.tool, int(full.site_bodyid[sid]), robot.base, robot.rest)
    mj, aside = reduce_mujoco(spec, full, sel)
    robot.set_aside += aside
    tree_root = int(full.body_rootid[sel.tool_body])
    roots = [b for b in range(1, full.nbody) if full.body_parentid[b] == 0]
    pin_root = root
    if len(roots) > 1:
        bodies = display_names(full, mujoco.mjtObj.mjOBJ_BODY)
        for r in roots:
            if r != tree_root:
                robot.set_aside.append(
                    SetAside(
                        "root body",
                        bodies[r],
                        "another tree: not given to Pinocchio (it does not move with the "
                        "arm); MuJoCo keeps it for collisions",
                    )
                )
        pin_root = _only_tree(root, roots.index(tree_root))
        robot.changed = True
    check_supported(mj, pin_root, strict, tool_site=robot.tool if kind == "body" else None)
    check_robot_values(full)
    causes = forced_causes(full, tree_root, sel.joints) + unit_causes(pin_root)
    causes += resolve_causes(pin_root) if strict else []
    pm = None
    if not causes:
        try:
            if path is not None and not robot.changed:
                pm = _read_pinocchio(path)
            else:
                pm = _pinocchio_from_text(ET.tostring(pin_root, encoding="unicode"))
        except ModelError as err:
            # The parser's own failure ("unordered_map::at") explains nothing to the user:
            # Pinocchio gets the model as MuJoCo compiled it instead, and the report says why.
            causes = [f"Pinocchio's parser could not read the file ({err.__cause__ or err})"]
    bridged: tuple[Bridge, ...] = ()
    # The inertia bridges match the file's bodies to MuJoCo's whole model one to one: the
    # whole file, not the one tree Pinocchio reads.
    inertia_root: ET.Element | None = root
    if causes:
        pm, bridged = _read_resolved(full, tree_root, causes)
        inertia_root = None  # every inertial is explicit: nothing for the inertia bridges to do
        # Bridged for Drake the same way: MuJoCo's compiled tree, reported as Drake's bridge.
        robot.drake_source = DrakeSource(None, resolved_robot(full))
        robot.drake_bridges.append(replace(bridged[0], engine="drake"))
        robot.xml_root = None
    frame_type = "body" if kind == "body" else "site"
    return build_arm(mj, full, pm, sel, robot, bridged, inertia_root, "MJCF", frame_type)


def _read_resolved(
    full: mujoco.MjModel, tree_root: int, causes: list[str]
) -> tuple[object, tuple[Bridge, ...]]:
    """Pinocchio's model of MuJoCo's compiled tree (`.resolved`), and the note saying so."""
    text = resolved_mjcf(full, tree_root)
    try:
        pm = _pinocchio_from_text(text)
    except ModelError as err:
        raise ModelError(
            f"Pinocchio could not read the model: {'; '.join(causes)}; nor MuJoCo's compiled "
            f"model of it written out as plain MJCF ({err.__cause__ or err})"
        ) from err
    note = whole_model(
        display_names(full, mujoco.mjtObj.mjOBJ_BODY)[tree_root],
        int(np.sum(full.body_rootid == tree_root)),
        "of " + "; ".join(causes),
    )
    return pm, (note,)


def _only_tree(root: ET.Element, index: int) -> ET.Element:
    """The MJCF with one tree of ``<worldbody>`` (the ``index``-th root body) and no keyframes.

    Pinocchio's MJCF parser reads only the first body of ``<worldbody>``; the arm's tree is
    handed to it alone. Keyframes go (their qpos is the whole robot's), as do elements that
    refer to other trees and that Pinocchio does not read (contact, equality, tendon,
    actuator, sensor).
    """
    root = copy.deepcopy(root)
    for world in root.findall("worldbody"):
        bodies = [el for el in world if el.tag == "body"]
        for k, el in enumerate(bodies):
            if k != index:
                world.remove(el)
    for tag in ("keyframe", "contact", "equality", "tendon", "actuator", "sensor"):
        for el in root.findall(tag):
            root.remove(el)
    return root

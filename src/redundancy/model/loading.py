"""Loading an MJCF or URDF file into both engines, checked and bridged, as an Arm."""

from __future__ import annotations

import copy
import math
import os
import tempfile
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Callable, Mapping
from pathlib import Path

import mujoco
import numpy as np

from .. import models
from ..arm import Arm
from ..engines.mujoco import captured_warnings, joint_limits, object_names
from ..errors import ModelError, ParameterError, UnknownNameError
from .actuators import actuator_armature, actuator_damping, joint_force_limits
from .bridges import Bridge, bridge, bridge_robot, check_pinocchio
from .content import Recipe, feed_assets, mujoco_assets, rebuild, record, recording
from .ends import frame_for
from .names import display_names
from .resolved import resolve_causes, resolved_mjcf
from .robot import (
    ArmSelection,
    RestSpec,
    SetAside,
    keyframe_moves,
    reduce_mujoco,
    reduce_pinocchio,
    select_arm,
)
from .support import check_robot_values, check_supported
from .urdf import (
    DisabledPairs,
    build_mujoco,
    build_pinocchio,
    check_urdf,
    is_urdf,
    prepare_urdf,
    read_disabled_pairs,
    resolve_frame,
)
from .xmlfile import decode_xml, expanded, parse_xml, strip_declaration


def _read_mujoco(
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


def _read_pinocchio(path: Path) -> object:
    import pinocchio as pin

    try:
        return pin.buildModelFromMJCF(str(path))
    except Exception as err:  # Pinocchio raises bare RuntimeError/ValueError from C++.
        raise ModelError(f"Pinocchio could not read the model: {err}") from err


def _read_file(path: str | os.PathLike[str]) -> tuple[Path, bytes]:
    """A model file's bytes, or the library's error saying what was passed instead."""
    if isinstance(path, bytes | bytearray):
        raise ModelError("load() takes a file path; for XML text or bytes use load_string()")
    if not isinstance(path, str | os.PathLike):
        raise ModelError(f"load() takes a file path, got {type(path).__name__}")
    text = os.fspath(path)
    # An existing file may be named "<arm7>.xml": only a path to nothing can be XML text.
    if isinstance(text, str) and text.lstrip().startswith("<") and not os.path.exists(text):
        raise ModelError(
            f"load() takes a file path, and this looks like XML text ({text.strip()[:40]!r}...); "
            "use load_string() for model text"
        )
    p = models.bundled(text) or Path(text)  # a bare "panda": the bundled model
    if isinstance(text, str) and not text.isascii():
        try:
            text.encode("utf-8")
        except UnicodeEncodeError:  # bytes that are not UTF-8, as the OS gave them to Python
            shown = os.fsencode(text).decode("utf-8", "backslashreplace")
            raise ModelError(
                f"the model file name '{shown}' is not UTF-8, which MuJoCo and Pinocchio "
                "require of file names: rename the file"
            ) from None
    try:
        return p, p.read_bytes()
    except FileNotFoundError as err:
        hint = models.not_found_hint(text)
        raise ModelError(f"model file not found: {str(p)!r}{hint}") from err
    except IsADirectoryError as err:
        raise ModelError(f"model path is a directory, not a file: {str(p)!r}") from err
    except OSError as err:
        raise ModelError(f"cannot read the model file {str(p)!r}: {err.strerror}") from err


def _warn_site(site: str | None) -> None:
    """Warn the caller of `load` or `load_string` who named the tool frame ``site=``."""
    if site is not None:
        warnings.warn(
            "site= is deprecated: name the tool frame with frame=", DeprecationWarning, stacklevel=3
        )


def _tool(site: str | None, frame: str | None) -> str | None:
    """The tool frame asked for: ``frame``, else the deprecated ``site``; None: the default."""
    for name, value in (("frame", frame), ("site", site)):
        if value is None:
            continue
        if not isinstance(value, str):
            raise ModelError(f"{name} must be a name (str) or None, got {type(value).__name__}")
        return value
    return None


def load(
    path: str | os.PathLike[str],
    frame: str | None = None,
    strict: bool = True,
    site: str | None = None,
    disabled_collisions: DisabledPairs | None = None,
    base: str | None = None,
    rest: RestSpec = None,
) -> Arm:
    """Load a robot from an MJCF or URDF file; its arm is the chain to the tool.

    The file is read whole by both engines (MuJoCo's and Pinocchio's own parsers): a URDF (root
    element ``<robot>``) through each engine's URDF importer (see `redundancy.model.urdf`), an MJCF
    through each engine's MJCF parser. The **arm** is every hinge and slide joint on the path from
    the world (or from ``base``) to the tool frame, in chain order; every other joint (a gripper's,
    a second arm's, a torso's, a floating base's) is **held** at a rest configuration (see
    `redundancy.model.robot`). ``arm.held`` says which joints and at what values, ``arm.set_aside``
    what in the file does not reach the arm.

    Args:
        path: MJCF or URDF file.
        frame: The tool frame: an MJCF site or body, a URDF link or fixed joint. None: the
            model's one chain end (a leaf with a moving joint above it; see
            `redundancy.model.ends`), else its frame named ``"ee"``, else a ModelError listing
            the chain ends.
        strict: Where Pinocchio's MJCF parser reads the file differently from MuJoCo
            (``<frame>``, ``<replicate>``, a class inside another childclass...: see
            `redundancy.model.resolved.resolve_causes`), give Pinocchio MuJoCo's
            compiled model instead, reported in ``arm.bridges``. False: Pinocchio reads the
            file itself and `redundancy.compare_models` shows the differences. MJCF
            only.
        site: Deprecated name of ``frame`` (from when the tool had to be an MJCF site):
            warns with a DeprecationWarning; ``frame`` wins when both are given.
        disabled_collisions: URDF only: link pairs that never collide, as an SRDF file (its
            ``<disable_collisions>`` elements) or an iterable of (link, link) pairs. Links
            joined by a joint are always excluded. An SRDF of a whole robot serves a part of
            it: its pairs naming links the URDF lacks are skipped and listed in
            ``arm.set_aside`` (an error when none applies); listed pairs must all exist.
        base: A body (MJCF) or link (URDF) on the chain to the tool: the arm starts below it,
            its own joints and those above it are held. None: the world.
        rest: The held joints' values: None for the model's reference configuration
            (MuJoCo's ``qpos0``: each joint's ``ref``, a free body at its pose in the file),
            a keyframe name, or a dict joint name -> value [rad or m] (a ball joint's
            quaternion, a free joint's position and quaternion in MuJoCo's w x y z order).

    Raises:
        ModelError: The file is missing, not XML, not decodable, XML text instead of a path,
            or an engine cannot compile it.
        UnsupportedFeatureError: The arm uses something the engines may not agree on (the
            message names the joint or body of this arm that matters).
        UnknownNameError: The tool is not a frame of the model, ``base`` not a body on its
            chain, ``rest`` not a keyframe or held joint (the message lists the valid names).
    """
    _warn_site(site)
    p, data = _read_file(path)
    options = _options(site, strict, frame, disabled_collisions, base, rest)
    return _from_file(p, data, options, str(p))


def _options(
    site: str | None,
    strict: bool,
    frame: str | None,
    disabled_collisions: DisabledPairs | None,
    base: str | None,
    rest: RestSpec,
) -> tuple[object, ...]:
    """The load's options as they pickle with the recipe (an SRDF path made absolute)."""
    pairs = None if disabled_collisions is None else _frozen_pairs(disabled_collisions)
    if isinstance(pairs, str):
        pairs = os.path.abspath(pairs)
    return (site, strict, frame, pairs, base, _frozen_rest(rest))


def _from_file(p: Path, data: bytes, options: tuple[object, ...], shown: str) -> Arm:
    """`load` of the file ``p`` (bytes ``data``), named ``shown`` in messages."""
    site, strict, frame, pairs, base, rest = options
    with recording() as reading:
        record(p.resolve(), data)
        text, as_is = decode_xml(data, shown)
        root = parse_xml(text)
        folder = p.resolve().parent
        tool, whole = _tool(site, frame), None  # type: ignore[arg-type]
        if tool is None:  # the model's default, from its chain ends, includes read
            whole = expanded(root, folder)
            tool = frame_for(whole[0], shown)
        robot = _Robot(tool, base, rest, shown)  # type: ignore[arg-type]
        if is_urdf(root):
            arm = _load_urdf(text, root, folder, pairs, robot)  # type: ignore[arg-type]
        else:
            _check_mjcf(pairs)  # type: ignore[arg-type]
            if as_is:
                # By its absolute path: MuJoCo then looks its assets up by theirs.
                spec, mj, kind = _read_mujoco(None, p.resolve(), folder, tool)
            else:
                spec, mj, kind = _read_mujoco(text, None, folder, tool)
            # After MuJoCo, whose errors name a missing include first.
            mjcf = _edited(robot, whole or expanded(root, folder))
            path_for_pin = None if robot.changed or not as_is else p
            arm = _load_mjcf(spec, mj, kind, mjcf, strict, robot, path_for_pin)  # type: ignore[arg-type]
    recipe = Recipe.made("load", str(p.resolve()), str(folder), options, shown, reading.files)
    arm._recipe = (rebuild_arm, (recipe,))
    return arm


def _again(recipe: Recipe, at: Callable[[str], str]) -> Arm:
    """The load a recipe records, with its files where ``at`` says they now are."""
    site, strict, frame, pairs, base, rest = recipe.options
    options = (site, strict, frame, at(pairs) if isinstance(pairs, str) else pairs, base, rest)
    if recipe.loader == "load_string":
        return _from_text(recipe.model, Path(at(recipe.folder)), options)
    p = Path(at(recipe.model))
    try:
        data = p.read_bytes()
    except OSError as err:
        raise ModelError(f"cannot read the model file {str(p)!r}: {err.strerror}") from err
    return _from_file(p, data, options, recipe.shown)


def rebuild_arm(recipe: Recipe) -> Arm:
    """An Arm again from its recipe (what a copy, a pickle and a worker call)."""
    if not isinstance(recipe, Recipe):
        raise ModelError(f"not an arm's recipe: {type(recipe).__name__}")
    arm, full = rebuild(recipe, _again)
    arm._recipe = (rebuild_arm, (full,))
    return arm


def load_string(
    xml: str | bytes,
    frame: str | None = None,
    strict: bool = True,
    site: str | None = None,
    disabled_collisions: DisabledPairs | None = None,
    base: str | None = None,
    rest: RestSpec = None,
) -> Arm:
    """Load MJCF or URDF text into MuJoCo and Pinocchio (see [`load`][redundancy.load]).

    The arguments after ``xml`` are `load`'s (``site=`` its deprecated name of ``frame=``).

    Bytes are decoded as XML says. Pinocchio's MJCF parser reads files, so MJCF text is
    written to a temporary file for it and must not refer to other files (meshes, includes)
    by relative path; a URDF's relative mesh paths count from the current directory.
    """
    _warn_site(site)
    if isinstance(xml, bytes | bytearray):
        xml, _ = decode_xml(bytes(xml), "<string>")
    elif isinstance(xml, str):
        xml = strip_declaration(xml)
    else:
        raise ModelError(f"model text must be a str or bytes, got {type(xml).__name__}")
    options = _options(site, strict, frame, disabled_collisions, base, rest)
    return _from_text(xml, Path.cwd(), options)


def _from_text(xml: str, folder: Path, options: tuple[object, ...]) -> Arm:
    """`load_string` of decoded text; relative paths in it count from ``folder``."""
    site, strict, frame, pairs, base, rest = options
    with recording() as reading:
        root = parse_xml(xml)
        tool, whole = _tool(site, frame), None  # type: ignore[arg-type]
        if tool is None:
            whole = expanded(root, folder)
            tool = frame_for(whole[0], "<string>")
        robot = _Robot(tool, base, rest, "<string>")  # type: ignore[arg-type]
        if is_urdf(root):
            arm = _load_urdf(xml, root, folder, pairs, robot)  # type: ignore[arg-type]
        else:
            _check_mjcf(pairs)  # type: ignore[arg-type]
            spec, mj, kind = _read_mujoco(xml, None, folder, tool)
            mjcf = _edited(robot, whole or expanded(root, folder))
            arm = _load_mjcf(spec, mj, kind, mjcf, strict, robot, None)  # type: ignore[arg-type]
    recipe = Recipe.made("load_string", xml, str(folder), options, "<string>", reading.files)
    arm._recipe = (rebuild_arm, (recipe,))
    return arm


def model_format(arm: Arm) -> str:
    """``"URDF"`` or ``"MJCF"``: the format the arm was loaded from (recorded at load)."""
    return arm.model_format


class _Robot:
    """What a load asks for (tool, base, rest) and what it has set aside so far."""

    def __init__(self, tool: str, base: str | None, rest: RestSpec, source: str) -> None:
        self.tool, self.base, self.rest = tool, base, rest
        self.source = source
        self.set_aside: list[SetAside] = []
        self.defects: list[str] = []  # defects of the file on bodies the arm moves
        self.missing_inertia: list[str] = []  # links the arm moves without inertial data
        self.changed = False  # Pinocchio must read an edited copy of the MJCF


def _frozen_rest(rest: RestSpec) -> RestSpec:
    """A rest dict as a plain dict of floats or tuples (it pickles with the recipe)."""
    if rest is None or isinstance(rest, str):
        return rest
    if not isinstance(rest, Mapping):
        raise ParameterError(
            "rest", rest, "None, a keyframe name, or a dict joint name -> value [rad or m]"
        )
    return {
        str(k): (tuple(v) if isinstance(v, list | tuple | np.ndarray) else v)
        for k, v in rest.items()
    }


def _check_mjcf(pairs: DisabledPairs | None) -> None:
    """Refuse what an MJCF cannot be loaded with: disabled pairs."""
    if pairs is not None:
        raise ModelError(
            "disabled_collisions is for URDF; an MJCF model excludes pairs itself, with "
            "<contact><exclude body1=... body2=...>"
        )


def _edited(robot: _Robot, whole: tuple[ET.Element, list[SetAside]]) -> ET.Element:
    """The expanded MJCF, its edits recorded on ``robot`` (set aside; Pinocchio reads it)."""
    mjcf, edits = whole
    robot.set_aside += edits
    robot.changed = robot.changed or bool(edits)
    return mjcf


def _frozen_pairs(pairs: DisabledPairs) -> DisabledPairs:
    """Pairs as a tuple (an iterator is read once), a path as a str (both pickle)."""
    if isinstance(pairs, str | os.PathLike):
        return os.fspath(pairs)
    try:
        return tuple(tuple(p) if not isinstance(p, str) else p for p in pairs)  # type: ignore[misc]
    except TypeError as err:
        raise ModelError(
            f"disabled_collisions must be an SRDF path or (link, link) pairs: {err}"
        ) from err


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


def _load_mjcf(
    spec: mujoco.MjSpec,
    full: mujoco.MjModel,
    kind: str,
    root: ET.Element,
    strict: bool,
    robot: _Robot,
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
    causes = resolve_causes(pin_root) if strict else []
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
    if causes:
        pm, bridged = _read_resolved(full, tree_root, causes)
        pin_root = None  # every inertial is explicit: nothing for the inertia bridges to do
    frame_type = "body" if kind == "body" else "site"
    return _build(mj, full, pm, sel, robot, bridged, pin_root, "MJCF", frame_type)


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
    note = Bridge(
        "whole model",
        display_names(full, mujoco.mjtObj.mjOBJ_BODY)[tree_root],
        f"{int(np.sum(full.body_rootid == tree_root))} bodies",
        "compiled model written out as plain MJCF (placements, joints, explicit inertials, "
        "sites), because of " + "; ".join(causes),
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


def _load_urdf(
    text: str,
    root: ET.Element,
    base: Path,
    pairs: DisabledPairs | None,
    robot: _Robot,
) -> Arm:
    """Both engines' URDF importers on the whole robot, checked (see `urdf`)."""
    source = robot.source
    tree = check_urdf(root, source)
    tool_link = resolve_frame(tree, robot.tool)
    base_link = robot.base  # select_arm checks it is a link on the chain to the tool
    disabled, skipped = read_disabled_pairs(pairs, tree)
    if skipped is not None:
        robot.set_aside.append(skipped)
    mended, notes, defects, missing = prepare_urdf(root, tree, tool_link, base_link, source)
    robot.missing_inertia += missing
    if notes:
        text = ET.tostring(mended, encoding="unicode")
        robot.set_aside += notes
    robot.defects += defects
    pm, continuous = build_pinocchio(text, source)
    spec, full, meshes = build_mujoco(text, base, source, tree, tool_link, tool_link, disabled)
    robot.set_aside += meshes
    sid = mujoco.mj_name2id(full, mujoco.mjtObj.mjOBJ_SITE, tool_link)
    made_fixed = {a.name: a.reason for a in notes if a.what == "joint"}
    sel = select_arm(
        full, robot.tool, int(full.site_bodyid[sid]), base_link, robot.rest, made_fixed
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
    return _build(mj, full, pm, sel, robot, rebuilt, None, "URDF", "body")


def _build(
    mj: mujoco.MjModel,
    full: mujoco.MjModel,
    pm_full: object,
    sel: ArmSelection,
    robot: _Robot,
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
    robot_bridges = bridge_robot(pm_full, full, site, frame_type, xml_root)  # type: ignore[arg-type]
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
    return Arm(
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
        robot_model=full,
        frame_type=frame_type,
        base=sel.base,
        rest=sel.rest,
        key_moves=tuple(keyframe_moves(full, k, sel.joints, sel.held) for k in range(full.nkey)),
    )

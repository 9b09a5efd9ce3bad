"""Loading an MJCF or URDF file into both engines, checked and bridged, as an Arm.

The entry points (`load`, `load_string`) and the recipe an Arm is rebuilt from; each format's
path is a module of its own (`redundancy.model.mjcf_loading`, `redundancy.model.urdf_loading`),
and both end in `redundancy.model.assembly.build_arm`.
"""

from __future__ import annotations

import os
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TypedDict, Unpack

import numpy as np

from .. import models
from ..arm import Arm
from ..checks import check_options
from ..errors import ModelError, ParameterError
from .assembly import LoadState
from .content import Recipe, rebuild, record, recording
from .drake_loading import DrakeSource
from .ends import frame_for
from .mjcf_loading import load_mjcf, read_mujoco, record_models
from .robot import RestSpec, SetAside
from .urdf import DisabledPairs, is_urdf
from .urdf_loading import load_urdf
from .xmlfile import decode_xml, expand_includes, expanded, parse_xml, strip_declaration


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


def _check_load_options(options: LoadOptions) -> None:
    """Refuse an unknown keyword; warn the caller who named the tool frame ``site=``.

    Called by `load` and `load_string` first (the warning points at their caller).
    """
    check_options(options, LoadOptions)
    if options.get("site") is not None:
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


class LoadOptions(TypedDict, total=False):
    """The keywords `load` and `load_string` take after the tool ``frame``.

    Attributes:
        strict: Where Pinocchio's MJCF parser reads the file differently from MuJoCo
            (``<frame>``, ``<replicate>``, a class inside another childclass...: see
            `redundancy.model.resolved.resolve_causes`), give Pinocchio MuJoCo's
            compiled model instead, reported in ``arm.bridges`` (default True). False:
            Pinocchio reads the file itself and `redundancy.compare_models` shows the
            differences. MJCF only.
        site: Deprecated name of ``frame`` (from when the tool had to be an MJCF site):
            warns with a DeprecationWarning; ``frame`` wins when both are given.
        disabled_collisions: URDF only: link pairs that never collide, as an SRDF file (its
            ``<disable_collisions>`` elements) or an iterable of (link, link) pairs. Links
            joined by a joint are always excluded. An SRDF of a whole robot serves a part of
            it: its pairs naming links the URDF lacks are skipped and listed in
            ``arm.set_aside`` (an error when none applies); listed pairs must all exist.
        base: A body (MJCF) or link (URDF) on the chain to the tool: the arm starts below it,
            its own joints and those above it are held. None (default): the world.
        rest: The held joints' values: None (default) for the model's reference configuration
            (MuJoCo's ``qpos0``: each joint's ``ref``, a free body at its pose in the file),
            a keyframe name, or a dict joint name -> value [rad or m] (a ball joint's
            quaternion, a free joint's position and quaternion in MuJoCo's w x y z order).
    """

    strict: bool
    site: str | None
    disabled_collisions: DisabledPairs | None
    base: str | None
    rest: RestSpec


def load(
    path: str | os.PathLike[str], frame: str | None = None, **options: Unpack[LoadOptions]
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
        **options: ``strict``, ``disabled_collisions`` (URDF), ``base`` and ``rest`` (where
            the arm starts, and the held joints' values), as
            [`LoadOptions`][redundancy.model.loading.LoadOptions] states.

    Raises:
        ModelError: The file is missing, not XML, not decodable, XML text instead of a path,
            or an engine cannot compile it.
        UnsupportedFeatureError: The arm uses something the engines may not agree on (the
            message names the joint or body of this arm that matters).
        UnknownNameError: The tool is not a frame of the model, ``base`` not a body on its
            chain, ``rest`` not a keyframe or held joint, a keyword not one of the options
            (the message lists the valid names).
    """
    _check_load_options(options)
    p, data = _read_file(path)
    return _from_file(p, data, _options(frame, options), str(p))


def _options(frame: str | None, options: LoadOptions) -> tuple[object, ...]:
    """The load's options as they pickle with the recipe (an SRDF path made absolute).

    The defaults are set here, once: ``strict`` True, the others None.
    """
    pairs = options.get("disabled_collisions")
    pairs = None if pairs is None else _frozen_pairs(pairs)
    if isinstance(pairs, str):
        pairs = os.path.abspath(pairs)
    site, strict = options.get("site"), options.get("strict", True)
    return (site, strict, frame, pairs, options.get("base"), _frozen_rest(options.get("rest")))


def _from_file(p: Path, data: bytes, options: tuple[object, ...], shown: str) -> Arm:
    """`load` of the file ``p`` (bytes ``data``), named ``shown`` in messages."""
    site, strict, frame, pairs, base, rest = options
    # The path as the user gave it, made absolute but not resolved: MuJoCo reads includes and
    # assets beside it (through a symbolic link: beside the link, not its target).
    p = Path(os.path.abspath(p))
    with recording() as reading:
        record(p, data)
        text, as_is = decode_xml(data, shown)
        root = parse_xml(text)
        folder = p.parent
        tool, whole = _tool(site, frame), None  # type: ignore[arg-type]
        if tool is None:  # the model's default, from its chain ends, includes read
            whole = expanded(root, folder)
            tool = frame_for(whole[0], shown)
        robot = LoadState(tool, base, rest, shown)  # type: ignore[arg-type]
        if is_urdf(root):
            # Drake reads the user's file itself (load_urdf gives it the text it mends instead).
            readable = as_is and p.is_file()
            robot.drake_source = (
                DrakeSource(p, None, True) if readable else DrakeSource(None, text, True)
            )
            arm = load_urdf(text, root, folder, pairs, robot)  # type: ignore[arg-type]
        else:
            _check_mjcf(pairs)  # type: ignore[arg-type]
            # A pipe's bytes are gone once read; MuJoCo reads a file by its suffix, and knows
            # MJCF as .xml only (an .mjcf goes as text, as a pipe's does).
            as_is = as_is and p.is_file() and p.suffix.lower() == ".xml"
            robot.drake_source = DrakeSource(p) if as_is else None
            if as_is:
                # By its absolute path: MuJoCo then looks its assets up by theirs.
                spec, mj, kind = read_mujoco(None, p, folder, tool)
            else:
                # Handed text, MuJoCo would look for the includes in the current directory.
                inlined = ET.tostring(expand_includes(root, folder, []), encoding="unicode")
                robot.drake_source = DrakeSource(None, inlined)
                spec, mj, kind = read_mujoco(inlined, None, folder, tool)
            # After MuJoCo, whose errors name a missing include first.
            mjcf = _edited(robot, whole or expanded(root, folder))
            record_models(mjcf, folder)
            path_for_pin = None if robot.changed or not as_is else p
            arm = load_mjcf(spec, mj, kind, mjcf, strict, robot, path_for_pin)  # type: ignore[arg-type]
    recipe = Recipe.made("load", str(p), str(folder), options, shown, reading.files)
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


def load_string(xml: str | bytes, frame: str | None = None, **options: Unpack[LoadOptions]) -> Arm:
    """Load MJCF or URDF text into MuJoCo and Pinocchio (see [`load`][redundancy.load]).

    The arguments after ``xml`` are `load`'s.

    Bytes are decoded as XML says. Pinocchio's MJCF parser reads files, so MJCF text is
    written to a temporary file for it and must not refer to other files (meshes, includes)
    by relative path; a URDF's relative mesh paths count from the current directory.
    """
    _check_load_options(options)
    if isinstance(xml, bytes | bytearray):
        xml, _ = decode_xml(bytes(xml), "<string>")
    elif isinstance(xml, str):
        xml = strip_declaration(xml)
    else:
        raise ModelError(f"model text must be a str or bytes, got {type(xml).__name__}")
    return _from_text(xml, Path.cwd(), _options(frame, options))


def _from_text(xml: str, folder: Path, options: tuple[object, ...]) -> Arm:
    """`load_string` of decoded text; relative paths in it count from ``folder``."""
    site, strict, frame, pairs, base, rest = options
    with recording() as reading:
        root = parse_xml(xml)
        tool, whole = _tool(site, frame), None  # type: ignore[arg-type]
        if tool is None:
            whole = expanded(root, folder)
            tool = frame_for(whole[0], "<string>")
        robot = LoadState(tool, base, rest, "<string>")  # type: ignore[arg-type]
        robot.drake_source = DrakeSource(None, xml, is_urdf(root))
        if is_urdf(root):
            arm = load_urdf(xml, root, folder, pairs, robot)  # type: ignore[arg-type]
        else:
            _check_mjcf(pairs)  # type: ignore[arg-type]
            spec, mj, kind = read_mujoco(xml, None, folder, tool)
            mjcf = _edited(robot, whole or expanded(root, folder))
            record_models(mjcf, folder)
            arm = load_mjcf(spec, mj, kind, mjcf, strict, robot, None)  # type: ignore[arg-type]
    recipe = Recipe.made("load_string", xml, str(folder), options, "<string>", reading.files)
    arm._recipe = (rebuild_arm, (recipe,))
    return arm


def model_format(arm: Arm) -> str:
    """``"URDF"`` or ``"MJCF"``: the format the arm was loaded from (recorded at load)."""
    return arm.model_format


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


def _edited(robot: LoadState, whole: tuple[ET.Element, list[SetAside]]) -> ET.Element:
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

"""Loading an MJCF or URDF file into both engines, checked and bridged, as an Arm."""

from __future__ import annotations

import codecs
import math
import os
import re
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco

from ..arm import Arm
from ..engines.mujoco import captured_warnings, joint_limits, object_names
from ..errors import ModelError, UnknownNameError, UnsupportedFeatureError
from .actuators import actuator_armature, actuator_damping, joint_force_limits
from .bridges import Bridge, bridge, check_pinocchio
from .support import check_supported
from .urdf import (
    DisabledPairs,
    build_mujoco,
    build_pinocchio,
    check_urdf,
    frame_clash,
    is_urdf,
    read_disabled_pairs,
    resolve_frame,
)


def _read_mujoco(xml: str | None, path: Path | None, base: Path | None = None) -> mujoco.MjModel:
    try:
        # MuJoCo's compile-time warnings (a NaN in the XML, a singular inertia, a deprecated
        # attribute) would be printed and written to MUJOCO_LOG.TXT; check_supported refuses
        # their causes with the library's own message instead.
        with captured_warnings():
            if path is not None:
                return mujoco.MjModel.from_xml_path(str(path))
            if base is None:
                return mujoco.MjModel.from_xml_string(xml or "")
            # Transcoded text of a file: relative asset paths still count from its directory.
            spec = mujoco.MjSpec.from_string(xml or "")
            spec.modelfiledir = str(base)
            return spec.compile()
    except (ValueError, TypeError) as err:
        raise ModelError(f"MuJoCo could not compile the model: {err}") from err


def _read_pinocchio(path: Path) -> object:
    import pinocchio as pin

    try:
        return pin.buildModelFromMJCF(str(path))
    except Exception as err:  # Pinocchio raises bare RuntimeError/ValueError from C++.
        raise ModelError(f"Pinocchio could not read the model: {err}") from err


def _xml_root(text: str) -> ET.Element:
    try:
        return ET.fromstring(text)
    except ET.ParseError as err:
        raise ModelError(f"not well-formed XML: {err}") from err


_BOMS = (
    (codecs.BOM_UTF32_LE, "utf-32"),
    (codecs.BOM_UTF32_BE, "utf-32"),
    (codecs.BOM_UTF8, "utf-8-sig"),
    (codecs.BOM_UTF16_LE, "utf-16"),
    (codecs.BOM_UTF16_BE, "utf-16"),
)
_DECLARED = re.compile(rb"""^\s*<\?xml[^>]*?encoding\s*=\s*["']([A-Za-z0-9._-]+)["']""")


def strip_declaration(text: str) -> str:
    """The text without its XML declaration (an encoding it names no longer applies)."""
    return re.sub(r"^\s*<\?xml[^>]*\?>", "", text, count=1)


def decode_xml(data: bytes, source: str) -> tuple[str, bool]:
    """Decode a model file's bytes as XML does: byte-order mark, else the declared encoding.

    MuJoCo reads UTF-8 only (a UTF-16 file fails to parse, a Latin-1 file's names reach it
    as invalid UTF-8) and Pinocchio's parsers likewise, so a file in another encoding is
    handed to both as the decoded text.

    Args:
        data: The file's bytes.
        source: File name, for messages.

    Returns:
        The text without its XML declaration, and whether the bytes were UTF-8 without a
        byte-order mark (the engines may then read the file itself).

    Raises:
        ModelError: An unknown encoding, or bytes that are not in the declared one.
    """
    encoding = next((enc for bom, enc in _BOMS if data.startswith(bom)), None)
    if encoding is None and data[:2] in (b"<\x00", b"\x00<"):
        encoding = "utf-16-le" if data[:1] == b"<" else "utf-16-be"  # UTF-16 without a BOM
    if encoding is None:
        declared = _DECLARED.match(data)
        encoding = declared.group(1).decode("ascii") if declared else "utf-8"
    try:
        text = data.decode(encoding)
    except LookupError as err:
        raise ModelError(f"{source}: unknown encoding {encoding!r} in the XML declaration") from err
    except UnicodeDecodeError as err:
        raise ModelError(f"{source}: not valid {encoding} text: {err}") from err
    as_is = codecs.lookup(encoding).name == "utf-8"
    return strip_declaration(text), as_is


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
    p = Path(text)
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
        raise ModelError(f"model file not found: {str(p)!r}") from err
    except IsADirectoryError as err:
        raise ModelError(f"model path is a directory, not a file: {str(p)!r}") from err
    except OSError as err:
        raise ModelError(f"cannot read the model file {str(p)!r}: {err.strerror}") from err


def _tool(site: str, frame: str | None) -> str:
    if not isinstance(site, str):
        raise ModelError(f"site must be a name (str), got {type(site).__name__}")
    if frame is None:
        return site
    if not isinstance(frame, str):
        raise ModelError(f"frame must be a name (str), got {type(frame).__name__}")
    return frame


def load(
    path: str | os.PathLike[str],
    site: str = "ee",
    strict: bool = True,
    frame: str | None = None,
    disabled_collisions: DisabledPairs | None = None,
) -> Arm:
    """Load an MJCF or URDF file into MuJoCo and Pinocchio.

    The file is read as bytes and decoded as XML says (byte-order mark or declared encoding);
    a URDF (root element ``<robot>``) goes through each engine's URDF importer (see
    :mod:`redundancy.model.urdf`), an MJCF through each engine's MJCF parser.

    Args:
        path: MJCF or URDF file.
        site: Name of the tool site (MJCF), or of the tool link (URDF).
        strict: Refuse features Pinocchio's MJCF parser reads differently (see
            :func:`check_supported`); MJCF only.
        frame: The tool frame by the name its format gives it: a site (MJCF), a link or a
            fixed joint (URDF). Overrides ``site``.
        disabled_collisions: URDF only: link pairs that never collide, as an SRDF file (its
            ``<disable_collisions>`` elements) or an iterable of (link, link) pairs. Links
            joined by a joint are always excluded.

    Raises:
        ModelError: The file is missing, not XML, not decodable, XML text instead of a path,
            or an engine cannot compile it.
        UnsupportedFeatureError: The model uses something the engines may not agree on.
        UnknownNameError: The tool is not a site (MJCF) or link (URDF) of the model (the
            message lists them).
    """
    p, data = _read_file(path)
    tool = _tool(site, frame)
    text, as_is = decode_xml(data, str(p))
    root = _xml_root(text)
    pairs = None if disabled_collisions is None else _frozen_pairs(disabled_collisions)
    recipe = (load, (str(p), site, strict, frame, pairs))
    if is_urdf(root):
        return _load_urdf(text, root, p.resolve().parent, str(p), tool, pairs, recipe)
    _check_mjcf(root, pairs, str(p))
    if as_is:
        mj = _read_mujoco(None, p)
        check_supported(mj, root, strict)
        return _build(mj, _read_pinocchio(p), tool, str(p), recipe, xml_root=root)
    mj = _read_mujoco(text, None, p.resolve().parent)
    check_supported(mj, root, strict)
    return _build(mj, _pinocchio_from_text(text), tool, str(p), recipe, xml_root=root)


def load_string(
    xml: str | bytes,
    site: str = "ee",
    strict: bool = True,
    frame: str | None = None,
    disabled_collisions: DisabledPairs | None = None,
) -> Arm:
    """Load MJCF or URDF text into MuJoCo and Pinocchio (see :func:`load`).

    Bytes are decoded as XML says. Pinocchio's MJCF parser reads files, so MJCF text is
    written to a temporary file for it and must not refer to other files (meshes, includes)
    by relative path; a URDF's relative mesh paths count from the current directory.
    """
    if isinstance(xml, bytes | bytearray):
        xml, _ = decode_xml(bytes(xml), "<string>")
    elif isinstance(xml, str):
        xml = strip_declaration(xml)
    else:
        raise ModelError(f"model text must be a str or bytes, got {type(xml).__name__}")
    tool = _tool(site, frame)
    root = _xml_root(xml)
    pairs = None if disabled_collisions is None else _frozen_pairs(disabled_collisions)
    recipe = (load_string, (xml, site, strict, frame, pairs))
    if is_urdf(root):
        return _load_urdf(xml, root, Path.cwd(), "<string>", tool, pairs, recipe)
    _check_mjcf(root, pairs, "<string>")
    mj = _read_mujoco(xml, None)
    check_supported(mj, root, strict)
    return _build(mj, _pinocchio_from_text(xml), tool, "<string>", recipe, xml_root=root)


def model_format(arm: Arm) -> str:
    """``"URDF"`` or ``"MJCF"``: the format the arm was loaded from (recorded at load)."""
    return arm.model_format


def _check_mjcf(root: ET.Element, pairs: DisabledPairs | None, source: str) -> None:
    """Refuse what an MJCF cannot be loaded with: disabled pairs, an ``<include>``."""
    if pairs is not None:
        raise ModelError(
            "disabled_collisions is for URDF; an MJCF model excludes pairs itself, with "
            "<contact><exclude body1=... body2=...>"
        )
    if root.find(".//include") is not None:
        raise UnsupportedFeatureError(
            "<include> element",
            source,
            "Pinocchio's MJCF parser does not follow includes; inline the file",
        )


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


def _load_urdf(
    text: str,
    root: ET.Element,
    base: Path,
    source: str,
    tool: str,
    pairs: DisabledPairs | None,
    recipe: tuple[object, tuple[object, ...]],
) -> Arm:
    """Both engines' URDF importers, checked (see :mod:`redundancy.model.urdf`)."""
    tree = check_urdf(root, source)
    tool_link = resolve_frame(tree, tool)
    disabled = read_disabled_pairs(pairs, tree)
    pm, continuous = build_pinocchio(text, source)
    clash = frame_clash(pm, tool_link)
    if clash:
        raise UnsupportedFeatureError(
            "tool frame name used twice",
            f"link {tool_link!r} in {source}",
            f"Pinocchio has {len(clash)} frames of that name ({', '.join(clash)}); "
            "rename the link or the joint",
        )
    mj = build_mujoco(text, base, source, tree, tool_link, tool_link, disabled)
    # URDF inertials are explicit and the joints are checked above: only the generic
    # refusals apply (non-finite values, negative damping, inverted ranges, several trees).
    check_supported(mj, None, strict=False)
    rebuilt = tuple(
        Bridge(
            "continuous joint as one angle",
            name,
            (-math.inf, math.inf),
            "URDF continuous joint (Pinocchio's parser makes it a cos/sin pair)",
        )
        for name in continuous
    )
    return _build(mj, pm, tool_link, source, recipe, rebuilt, model_format="URDF")


def _build(
    mj: mujoco.MjModel,
    pm: object,
    site: str,
    source: str,
    recipe: tuple[object, tuple[object, ...]],
    bridged: tuple[Bridge, ...] = (),
    xml_root: ET.Element | None = None,
    model_format: str = "MJCF",
) -> Arm:
    """Check that both engines see the same joints and tool, bridge, and build the Arm.

    ``bridged`` lists what the loader has already changed in Pinocchio's model.
    """
    sites = object_names(mj, mujoco.mjtObj.mjOBJ_SITE)
    if site not in sites:
        raise UnknownNameError("site", site, [s for s in sites if s])
    joint_names = object_names(mj, mujoco.mjtObj.mjOBJ_JOINT)
    check_pinocchio(pm, joint_names, site)  # type: ignore[arg-type]
    lower, upper = joint_limits(mj)
    # Armature and damping as the dynamics see them: the joint's own plus gear^2 times what
    # its actuators add (rotor-side values reflected through the transmission).
    armature = mj.dof_armature + actuator_armature(mj)
    damping = mj.dof_damping + actuator_damping(mj)
    effort = joint_force_limits(mj)
    bridges = bridged + bridge(
        pm,
        mj,
        joint_names,
        site,
        effort,
        armature,
        damping,
        lower,
        upper,  # type: ignore[arg-type]
        xml_root=xml_root,
    )
    return Arm(
        mj,
        pm,
        site,
        source,
        armature=armature,
        damping=damping,
        effort_limit=effort,
        bridges=bridges,
        recipe=recipe,  # type: ignore[arg-type]
        model_format=model_format,
    )

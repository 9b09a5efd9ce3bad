"""Loading one MJCF file into both engines, checked and bridged, as an :class:`~redundancy.Arm`."""

from __future__ import annotations

import os
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np

from ..arm import Arm
from ..engines.mujoco import captured_warnings, object_names
from ..errors import ModelError, UnknownNameError, UnsupportedFeatureError
from .actuators import actuator_armature, actuator_damping, joint_force_limits
from .bridges import bridge, check_pinocchio
from .support import check_supported


def _read_mujoco(xml: str | None, path: Path | None) -> mujoco.MjModel:
    try:
        # MuJoCo's compile-time warnings (a NaN in the XML, a singular inertia, a deprecated
        # attribute) would be printed and written to MUJOCO_LOG.TXT; check_supported refuses
        # their causes with the library's own message instead.
        with captured_warnings():
            if path is not None:
                return mujoco.MjModel.from_xml_path(str(path))
            return mujoco.MjModel.from_xml_string(xml or "")
    except (ValueError, TypeError) as err:
        raise ModelError(f"MuJoCo could not compile the model: {err}") from err


def _read_pinocchio(path: Path) -> object:
    import pinocchio as pin

    try:
        return pin.buildModelFromMJCF(str(path))
    except Exception as err:  # Pinocchio raises bare RuntimeError/ValueError from C++.
        raise ModelError(f"Pinocchio could not read the model: {err}") from err


def _xml_root(text: str | bytes) -> ET.Element:
    try:
        return ET.fromstring(text)
    except ET.ParseError as err:
        raise ModelError(f"not well-formed XML: {err}") from err


def load(path: str | os.PathLike[str], site: str = "ee", strict: bool = True) -> Arm:
    """Load an MJCF file into MuJoCo and Pinocchio.

    Args:
        path: MJCF file.
        site: Name of the tool site.
        strict: Refuse features Pinocchio reads differently (see :func:`check_supported`).

    Raises:
        ModelError: The file is missing, not XML, or an engine cannot compile it.
        UnsupportedFeatureError: The model uses something the engines may not agree on.
        UnknownNameError: ``site`` is not a site of the model (the message lists them).
    """
    p = Path(path)
    if not p.is_file():
        raise ModelError(f"MJCF file not found: {str(p)!r}")
    root = _xml_root(p.read_bytes())  # bytes: the XML declaration names the encoding
    if root.find(".//include") is not None:
        raise UnsupportedFeatureError(
            "<include> element",
            str(p),
            "Pinocchio's MJCF parser does not follow includes; inline the file",
        )
    mj = _read_mujoco(None, p)
    check_supported(mj, root, strict)
    return _build(mj, _read_pinocchio(p), site, str(p), (load, (str(p), site, strict)), root)


def load_string(xml: str, site: str = "ee", strict: bool = True) -> Arm:
    """Load MJCF text into MuJoCo and Pinocchio (see :func:`load`).

    The text is written to a temporary file for Pinocchio, whose parser reads files, so it
    must not refer to other files (meshes, includes) by relative path.
    """
    if not isinstance(xml, str):
        raise ModelError(f"MJCF text must be a str, got {type(xml).__name__}")
    root = _xml_root(xml)
    if root.find(".//include") is not None:
        raise UnsupportedFeatureError(
            "<include> element",
            "<string>",
            "Pinocchio's MJCF parser does not follow includes; inline the file",
        )
    mj = _read_mujoco(xml, None)
    check_supported(mj, root, strict)
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "model.xml"
        p.write_text(xml)
        pm = _read_pinocchio(p)
    return _build(mj, pm, site, "<string>", (load_string, (xml, site, strict)), root)


def _build(
    mj: mujoco.MjModel,
    pm: object,
    site: str,
    source: str,
    recipe: tuple[object, tuple[object, ...]],
    xml_root: ET.Element | None = None,
) -> Arm:
    """Check that both engines see the same joints and tool, bridge, and build the Arm."""
    sites = object_names(mj, mujoco.mjtObj.mjOBJ_SITE)
    if site not in sites:
        raise UnknownNameError("site", site, [s for s in sites if s])
    joint_names = object_names(mj, mujoco.mjtObj.mjOBJ_JOINT)
    check_pinocchio(pm, joint_names, site)  # type: ignore[arg-type]
    limited = mj.jnt_limited.astype(bool)
    lower = np.where(limited, mj.jnt_range[:, 0], -np.inf)
    upper = np.where(limited, mj.jnt_range[:, 1], np.inf)
    # Armature and damping as the dynamics see them: the joint's own plus gear^2 times what
    # its actuators add (rotor-side values reflected through the transmission).
    armature = mj.dof_armature + actuator_armature(mj)
    damping = mj.dof_damping + actuator_damping(mj)
    effort = joint_force_limits(mj)
    bridges = bridge(
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
    )

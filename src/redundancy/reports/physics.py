"""Plausible physics: what a published file's numbers say that no engine objects to.

The rules a careful engineer checks by hand before trusting a model: the reference pose and
every keyframe inside the joints' ranges, no effort or velocity limit of 0 on a joint the
arm moves, no link of mass 0 (or below) with an ``<inertial>``. Each returns
``(rule id, message, element kind, element name)`` tuples that `judging` turns into
findings; the link inertias against their geometry are in `physics_inertia`.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ..arm import Arm

#: A value this far outside a range [rad or m] is outside it, not rounding of the file's digits.
RANGE_SLACK = 1e-9

#: What a physics rule reports: rule id, message, element kind (``link``, ``joint``, ``key``),
#: element name.
Raised = tuple[str, str, str, str]


def joint_ranges(arm: Arm, keyframes: dict[str, np.ndarray]) -> Iterator[Raised]:
    """The reference pose (qpos0) and each keyframe against the joints' ranges.

    Args:
        arm: The arm.
        keyframes: Keyframe name -> its pose of the arm's joints [rad or m], in file order.
    """
    qpos0 = np.asarray(arm.mj_model.qpos0, dtype=float)
    for i, name in enumerate(arm.joint_names):
        out = _outside(float(qpos0[i]), arm, i)
        if out:
            yield (
                "reference-out-of-range",
                f"the reference pose (qpos0) puts joint {name!r} at {qpos0[i]:.6g}, {out}: "
                "a simulation reset to it starts beyond the limit (start from a keyframe inside "
                "the ranges)",
                "joint",
                name,
            )
    for key, q in keyframes.items():
        for i, name in enumerate(arm.joint_names):
            out = _outside(float(q[i]), arm, i)
            if out:
                yield (
                    "keyframe-out-of-range",
                    f"keyframe {key!r} puts joint {name!r} at {q[i]:.6g}, {out}",
                    "key",
                    key,
                )


def _outside(value: float, arm: Arm, i: int) -> str:
    """How ``value`` lies outside joint ``i``'s range, or ``""`` when inside (or unlimited)."""
    lo, hi = float(arm.lower[i]), float(arm.upper[i])
    unit = "rad" if arm.joint_types[i] == "hinge" else "m"
    if value < lo - RANGE_SLACK:
        return f"below its range [{lo:.6g}, {hi:.6g}] {unit} by {lo - value:.3g} {unit}"
    if value > hi + RANGE_SLACK:
        return f"above its range [{lo:.6g}, {hi:.6g}] {unit} by {value - hi:.3g} {unit}"
    return ""


def _urdf_root(arm: Arm) -> ET.Element | None:
    path = Path(arm.source)
    if arm.model_format != "URDF" or not path.is_file():
        return None
    try:
        return ET.fromstring(path.read_bytes())
    except ET.ParseError:
        return None


def urdf_limits(arm: Arm) -> Iterator[Raised]:
    """A URDF ``<limit effort="0">`` or ``velocity="0"`` on a joint the arm moves.

    URDF's effort and velocity limits are magnitudes: 0 says the motor gives no torque (or
    may not move), which no moving joint of an arm means; MuJoCo reads effort 0 as no limit,
    so the model silently has none.
    """
    root = _urdf_root(arm)
    if root is None:
        return
    moving = set(arm.joint_names)
    for joint in root.iter("joint"):
        name, lim = joint.get("name", ""), joint.find("limit")
        if name not in moving or lim is None:
            continue
        for attr, rule, unit in (
            ("effort", "effort-limit-zero", "N m or N"),
            ("velocity", "velocity-limit-zero", "rad/s or m/s"),
        ):
            value = lim.get(attr)
            if value is not None and _number(value) == 0.0:
                yield (
                    rule,
                    f'joint {name!r} moves with <limit {attr}="{value}"> [{unit}]: a motor '
                    f"that gives no {'torque' if attr == 'effort' else 'speed'} (the file most "
                    "likely left the value out)",
                    "joint",
                    name,
                )


def _number(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


def masses(arm: Arm) -> Iterator[Raised]:
    """A link the arm moves whose ``<inertial>`` has mass 0 or below (URDF)."""
    root = _urdf_root(arm)
    if root is None:
        return
    moved = set(arm.missing_inertia)
    for link in root.iter("link"):
        name, mass = link.get("name", ""), link.find("inertial/mass")
        value = _number(mass.get("value", "0")) if mass is not None else None
        if name in moved and value is not None and value <= 0:
            yield (
                "mass-not-positive",
                f"link {name!r} moves with an <inertial> of mass {value:g} kg: no body "
                "moves without mass (read as no inertia; the sections that need M or "
                "gravity are skipped)",
                "link",
                name,
            )

"""Plausible physics: what a published file's numbers say that no engine objects to.

The rules a careful engineer checks by hand before trusting a model: the reference pose and
every keyframe inside the joints' ranges, no effort or velocity limit of 0 on a joint the
arm moves, no link of mass 0 (or below) with an ``<inertial>``, and each link's inertia and
centre of mass against its geometry (`inertias`). Each yields `Raised` rule hits that
`judging` turns into findings and notes.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Iterator
from typing import NamedTuple

import numpy as np

from ..arm import Arm
from ..arm_coupled import ChainView
from ..errors import ModelError
from ..model.contact_rules import moved_bodies
from ..model.xmlfile import decode_xml, parse_xml

#: A value this far outside a range [rad or m] is outside it, not rounding of the file's digits.
RANGE_SLACK = 1e-9


class Raised(NamedTuple):
    """What a physics rule reports: its rule id, the message, and the element it concerns."""

    rule: str
    message: str
    kind: str  # the element's kind: ``link``, ``joint`` or ``key``
    element: str


def joint_ranges(arm: Arm, keyframes: dict[str, np.ndarray]) -> Iterator[Raised]:
    """The reference pose (qpos0) and each keyframe against the joints' ranges.

    Args:
        arm: The arm.
        keyframes: Keyframe name -> its pose of the arm's joints [rad or m], in file order.
    """
    # A coupled arm's ranges are every joint it moves: its chain's (followers too).
    joints: Arm | ChainView = arm if arm.coupling is None else ChainView(arm)
    qpos0 = np.asarray(arm.mj_model.qpos0, dtype=float)
    qpos0 = qpos0 if arm.coupling is not None else arm._of_chain(qpos0)
    for i, name in enumerate(joints.joint_names):
        out = _outside(float(qpos0[i]), joints, i)
        if out:
            yield Raised(
                "reference-out-of-range",
                f"the reference pose (qpos0) puts joint {name!r} at {qpos0[i]:.6g}, {out}: "
                "a simulation reset to it starts beyond the limit (start from a keyframe inside "
                "the ranges)",
                "joint",
                name,
            )
    for key, q in keyframes.items():
        if not arm._closes(q):
            yield Raised(
                "keyframe-loop-open",
                f"keyframe {key!r} puts the arm's joints where its loop cannot close "
                f"({_values(arm, q)}): a pose the mechanism cannot reach (left out of the "
                "keyframe sections)",
                "key",
                key,
            )
            continue
        x = q if arm.coupling is None else arm.chain_pose(q)
        for i, name in enumerate(joints.joint_names):
            out = _outside(float(x[i]), joints, i)
            if out:
                how = " (a follower: its coupling)" if name in arm.followers else ""
                yield Raised(
                    "keyframe-out-of-range",
                    f"keyframe {key!r} puts joint {name!r} at {x[i]:.6g}{how}, {out}",
                    "key",
                    key,
                )


def _values(arm: Arm, q: np.ndarray) -> str:
    return ", ".join(f"{n} {v:.6g}" for n, v in zip(arm.joint_names, q, strict=True))


def _outside(value: float, joints: Arm | ChainView, i: int) -> str:
    """How ``value`` lies outside joint ``i``'s range, or ``""`` when inside (or unlimited)."""
    lo, hi = float(joints.lower[i]), float(joints.upper[i])
    unit = "rad" if joints.joint_types[i] == "hinge" else "m"
    if value < lo - RANGE_SLACK:
        return f"below its range [{lo:.6g}, {hi:.6g}] {unit} by {lo - value:.3g} {unit}"
    if value > hi + RANGE_SLACK:
        return f"above its range [{lo:.6g}, {hi:.6g}] {unit} by {value - hi:.3g} {unit}"
    return ""


def urdf_root(arm: Arm, data: bytes | None) -> ET.Element | None:
    """The root of a URDF arm's file, read as the loader reads it (None for an MJCF arm).

    Args:
        arm: The arm.
        data: Its source file's bytes (None: no file to read, as for a model given as text).
    """
    if arm.model_format != "URDF" or data is None:
        return None
    try:  # the loader's reader: the declared encoding, undeclared prefixes tolerated
        return parse_xml(decode_xml(data, arm.source)[0])
    except ModelError:
        return None


def urdf_limits(arm: Arm, root: ET.Element | None) -> Iterator[Raised]:
    """A URDF ``<limit effort="0">`` or ``velocity="0"`` on a joint the arm moves.

    URDF's effort and velocity limits are magnitudes: 0 says the motor gives no torque (or
    may not move), which no moving joint of an arm means; MuJoCo reads effort 0 as no limit,
    so the model silently has none.

    Args:
        arm: The arm.
        root: Its URDF's root (`urdf_root`; None: nothing to judge).
    """
    if root is None:
        return
    moving = set(arm.chain_joint_names)  # a coupled arm's followers move too
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
                yield Raised(
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


def masses(arm: Arm, root: ET.Element | None) -> Iterator[Raised]:
    """A link the arm moves whose ``<inertial>`` has mass 0 or below (URDF).

    Args:
        arm: The arm.
        root: Its URDF's root (`urdf_root`; None: nothing to judge).
    """
    if root is None:
        return
    moved = set(arm.missing_inertia)
    for link in root.iter("link"):
        name, mass = link.get("name", ""), link.find("inertial/mass")
        value = _number(mass.get("value", "0")) if mass is not None else None
        if name in moved and value is not None and value <= 0:
            yield Raised(
                "mass-not-positive",
                f"link {name!r} moves with an <inertial> of mass {value:g} kg: no body "
                "moves without mass (read as no inertia; the sections that need M or "
                "gravity are skipped)",
                "link",
                name,
            )


#: A link's inertia this many times its geometry's is a unit mistake, not a hollow or dense
#: link: the published arms' links stay within 162x of a uniform solid of their shape (UR5).
#: Too small is not judged: published files write point masses (a zero tensor) on purpose.
INERTIA_RATIO = 300.0
#: A radius of gyration this many times the link's size: mass far outside its geometry.
GYRATION_FACTOR = 10.0
#: A centre of mass farther outside the geometry's box than the link's size plus this [m]
#: (Baxter's upper elbow puts its own 0.18 m beyond its collision cylinder of size 0.10 m).
COM_MARGIN = 0.1
#: Links lighter than this share of the arm's moving mass are not judged (a sensor, a flange).
MASS_SHARE = 0.005

#: Unit mistakes: what the written number is, in times the true kg m^2 value.
_UNITS = (
    (1e3, "g m^2 (x1e3)"),
    (1e4, "kg cm^2 (x1e4)"),
    (1e6, "kg mm^2 (x1e6)"),
    (1e7, "g cm^2 (x1e7)"),
    (1e9, "g mm^2 (x1e9)"),
)


def _unit(ratio: float) -> str:
    return min(_UNITS, key=lambda u: abs(np.log10(ratio / u[0])))[1]


def inertias(arm: Arm) -> Iterator[Raised]:
    """Each moving link's inertia and centre of mass against its collision geometry.

    ``inertia-unit``: the trace of the published inertia against a uniform solid of the
    link's collision geometry at its mass, `INERTIA_RATIO` times or more; ``gyration-radius``:
    sqrt(I_max / m) above `GYRATION_FACTOR` times the link's size; ``com-outside-link``: the
    centre of mass outside the geometry's box by more than its size plus `COM_MARGIN`.
    """
    from .link_geometry import link_geometry

    m = arm.mj_model
    moved = sorted(moved_bodies(m, set(range(m.njnt))))  # the arm's joints are the model's
    total = float(sum(m.body_mass[b] for b in moved))
    skip = set(arm.missing_inertia)
    for b in moved:
        name, mass = m.body(b).name, float(m.body_mass[b])
        if name in skip or mass <= 0 or mass < MASS_SHARE * total:
            continue
        geo = link_geometry(m, b)
        if geo is None or geo.size <= 0:
            continue
        moments = np.asarray(m.body_inertia[b], dtype=float)
        implied = mass * float(np.trace(geo.inertia_per_mass()))
        ratio = float(moments.sum()) / implied if implied > 0 else np.inf
        if ratio >= INERTIA_RATIO:
            yield Raised(
                "inertia-unit",
                f"link {name!r}: its inertia (trace {moments.sum():.3g} kg m^2) is {ratio:.3g}x "
                f"what its collision geometry gives at its mass {mass:.4g} kg "
                f"({implied:.3g} kg m^2): likely {_unit(ratio)} written as kg m^2",
                "link",
                name,
            )
        radius = float(np.sqrt(moments.max() / mass))
        if radius > GYRATION_FACTOR * geo.size:
            yield Raised(
                "gyration-radius",
                f"link {name!r}: radius of gyration sqrt(I/m) {radius:.3g} m on a link of size "
                f"{geo.size:.3g} m (half its box's diagonal): {radius / geo.size:.3g}x",
                "link",
                name,
            )
        com = np.asarray(m.body_ipos[b], dtype=float)
        out = geo.distance_outside(com)
        if out > geo.size + COM_MARGIN:
            yield Raised(
                "com-outside-link",
                f"link {name!r}: centre of mass {out:.3g} m outside its collision geometry's "
                f"box (the link's size {geo.size:.3g} m)",
                "link",
                name,
            )

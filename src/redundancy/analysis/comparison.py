"""What `redundancy.compare` returns, and the joint map it may read from a file and pairs joints by.

A [`Comparison`][redundancy.analysis.comparison.Comparison] holds the verdict, each
[`Finding`][redundancy.analysis.comparison.Finding] (a difference, or what one format cannot
express) and the [`RigidOffset`][redundancy.analysis.comparison.RigidOffset]s found; it shows
itself as text, JSON-ready data and HTML tables.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..arm import Arm
from ..display import Report, Table, json_ready, plural, table
from ..errors import ModelError, UnknownNameError
from ..model.equivalence import format_value

Array = NDArray[np.float64]

__all__ = ["Comparison", "Finding", "RigidOffset", "match_joints", "read_joint_map"]


@dataclass(frozen=True)
class RigidOffset:
    """A constant placement by which B differs from A.

    Attributes:
        kind: ``"base placement"`` (B's world = ``rotation`` A's world + ``translation``) or
            ``"tool mount"`` (B's tool frame = A's tool frame moved by ``translation`` and
            turned by ``rotation``, in A's tool frame).
        translation: [m], shape (3,).
        rotation: Rotation matrix, shape (3, 3).
    """

    kind: str
    translation: Array
    rotation: Array

    @property
    def angle(self) -> float:
        """Angle of the rotation [rad]."""
        R = self.rotation
        w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
        # atan2 keeps small angles exact where acos of the trace would lose them.
        return math.atan2(float(np.linalg.norm(w)) / 2.0, (float(np.trace(R)) - 1.0) / 2.0)

    @property
    def axis(self) -> Array:
        """Unit axis of the rotation (z when there is none)."""
        R = self.rotation
        w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
        norm = float(np.linalg.norm(w))
        if norm > 1e-12:
            return w / norm
        if self.angle < 1e-12:
            return np.array([0.0, 0.0, 1.0])
        # Half a turn: the axis is the column of R + I of largest norm.
        B = R + np.eye(3)
        v = B[:, int(np.argmax(np.linalg.norm(B, axis=0)))]
        return v / np.linalg.norm(v)

    def __str__(self) -> str:
        where = "in the world frame" if self.kind == "base placement" else "in A's tool frame"
        text = f"{self.kind}: B is A moved by {_vector(self.translation)} m {where}"
        if self.angle > 0:
            text += f", turned {math.degrees(self.angle):.6g} deg about {_vector(self.axis)}"
        return text

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {
            "kind": self.kind,
            "translation": json_ready(self.translation),
            "rotation": json_ready(self.rotation),
            "angle_deg": math.degrees(self.angle),
            "axis": json_ready(self.axis),
        }


def _vector(v: Array) -> str:
    return "[" + " ".join(f"{0.0 if abs(x) < 1e-12 else x:.6g}" for x in v) + "]"


@dataclass(frozen=True)
class Finding:
    """One quantity on which the two descriptions differ, or that one cannot express.

    Attributes:
        quantity: e.g. ``"joint axis (world)"``, ``"centre of mass (world)"``, ``"jacobian"``.
        where: The joint, body or frame it concerns, in A's names (B's in brackets when
            they differ).
        a: A's value (None where A cannot express it).
        b: B's value (None where B cannot express it).
        error: Largest absolute difference [SI units of the quantity] (0 for a listing).
        note: Extra context (the pose, the format that cannot express it).
    """

    quantity: str
    where: str
    a: Any
    b: Any
    error: float = 0.0
    note: str = ""

    def __str__(self) -> str:
        text = f"{self.quantity} of {self.where}: A {_fmt(self.a)}, B {_fmt(self.b)}"
        if self.error:
            text += f" (|diff| {self.error:.3g})"
        return text + (f"; {self.note}" if self.note else "")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (arrays as lists, infinities as null, as every document)."""
        return {
            "quantity": self.quantity,
            "where": self.where,
            "a": json_ready(self.a),
            "b": json_ready(self.b),
            "error": json_ready(self.error),
            "note": self.note,
        }


@dataclass(frozen=True, repr=False)
class Comparison(Report):
    """Result of [`compare`][redundancy.compare].

    ``print(comparison)`` prints
    [`lines`][redundancy.analysis.comparison.Comparison.lines]; a notebook shows the HTML
    tables.

    Attributes:
        a: Description of A (file and format); b likewise.
        frame_a: A's tool frame; frame_b likewise.
        joint_map: Pairs (A's joint, B's joint), in A's order.
        differences: Every difference, structural first, then pose by pose (after the
            rigid offsets).
        not_expressible: What one format cannot express, with the other's values.
        chains_part: Where the kinematic chains first part (a joint, ``"tool frame"``), or
            None when they do not.
        largest: Largest difference per quantity compared (0 where identical), relative to the
            quantity's scale on A ([`redundancy.model.scales`][redundancy.model.scales]) [-].
        n_poses: Poses compared (random ones and keyframes).
        tol: Relative tolerance [-].
        offsets: The rigid offsets found (base placement, tool mount), relative to which the
            rest was compared.
    """

    a: str
    b: str
    frame_a: str
    frame_b: str
    joint_map: tuple[tuple[str, str], ...]
    differences: tuple[Finding, ...]
    not_expressible: tuple[Finding, ...]
    chains_part: str | None
    largest: dict[str, float] = field(default_factory=dict)
    n_poses: int = 0
    tol: float = 1e-9
    offsets: tuple[RigidOffset, ...] = ()

    @property
    def equivalent(self) -> bool:
        """True when nothing differs, placement included.

        What a format cannot express is not a difference.
        """
        return not self.differences and not self.offsets

    @property
    def verdict(self) -> str:
        """``"same robot"``, ``"different"``, or ``"same robot, placed differently"``.

        The last when only rigid offsets differ.
        """
        if self.differences:
            return "different"
        return "same robot, placed differently" if self.offsets else "same robot"

    def lines(self) -> list[str]:
        """Human-readable report lines."""
        out = [
            f"A: {self.a}, tool frame {self.frame_a!r}",
            f"B: {self.b}, tool frame {self.frame_b!r}",
            f"joints matched: {len(self.joint_map)} ("
            + ", ".join(a if a == b else f"{a}={b}" for a, b in self.joint_map)
            + ")",
            f"compared: structure at the reference pose, and {self.n_poses} poses "
            f"(tolerance {self.tol:g})",
        ]
        out += [f"OFFSET  {o}" for o in self.offsets]
        if self.offsets:
            out.append("compared relative to the offset" + ("s" if len(self.offsets) > 1 else ""))
        if self.chains_part:
            out.append(f"the chains part at: {self.chains_part}")
        out += [f"DIFFERS  {d}" for d in self.differences]
        out += [f"NOT EXPRESSIBLE  {n}" for n in self.not_expressible]
        out.append("largest difference per quantity:")
        width = max((len(k) for k in self.largest), default=0)
        out += [f"  {k:<{width}}  {v:.2e}" for k, v in self.largest.items()]
        out.append(f"verdict: {self.verdict}")
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form of the whole comparison."""
        return {
            "a": self.a,
            "b": self.b,
            "frame_a": self.frame_a,
            "frame_b": self.frame_b,
            "joint_map": [list(p) for p in self.joint_map],
            "verdict": self.verdict,
            "equivalent": self.equivalent,
            "chains_part": self.chains_part,
            "offsets": [o.to_dict() for o in self.offsets],
            "differences": [d.to_dict() for d in self.differences],
            "not_expressible": [n.to_dict() for n in self.not_expressible],
            "largest": {k: json_ready(v) for k, v in self.largest.items()},
            "n_poses": self.n_poses,
            "tol": self.tol,
        }

    def summary(self) -> str:
        """The verdict and the counts, e.g. ``"different: 3 differences, 7 joints matched"``."""
        n = plural(len(self.differences), "difference")
        return f"{self.verdict}: {n}, {plural(len(self.joint_map), 'joint')} matched"

    def html_tables(self) -> list[Table]:
        """The differences, what a format cannot express, the largest difference per quantity."""
        rows = [
            (f.quantity, f.where, _fmt(f.a), _fmt(f.b), f"{f.error:.3g}", f.note)
            for f in self.differences
        ]
        header = ("quantity", "where", "A", "B", "|diff|", "note")
        align = (False, False, False, False, True, False)
        return [
            table(
                "the two descriptions",
                ("", "description", "tool frame"),
                [("A", self.a, self.frame_a), ("B", self.b, self.frame_b)],
            ),
            table(plural(len(rows), "difference"), header, rows, align),
            table(
                "not expressible in one of the formats",
                ("quantity", "where", "A", "B", "note"),
                [(f.quantity, f.where, _fmt(f.a), _fmt(f.b), f.note) for f in self.not_expressible],
            ),
            table(
                f"largest difference per quantity over {plural(self.n_poses, 'pose')}"
                f" (tolerance {self.tol:g})",
                ("quantity", "largest"),
                [(k, f"{v:.2e}") for k, v in self.largest.items()],
                (False, True),
            ),
        ]


def _fmt(x: Any) -> str:
    return "(cannot express)" if x is None else format_value(x)


def read_joint_map(path: str | os.PathLike[str]) -> dict[str, str]:
    """A joint map file: a JSON object ``{"A joint": "B joint"}``, or lines ``A_joint B_joint``.

    In the line form, ``#`` starts a comment and ``=`` or ``:`` may separate the two names.

    Raises:
        ModelError: Unreadable file, or a line that is not two names.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise ModelError(f"cannot read the joint map {str(p)!r}: {err}") from err
    if text.lstrip().startswith("{"):
        try:
            data = json.loads(text)
        except json.JSONDecodeError as err:
            raise ModelError(f"joint map {str(p)!r} is not valid JSON: {err}") from err
        if not all(isinstance(k, str) and isinstance(v, str) for k, v in data.items()):
            raise ModelError(f"joint map {str(p)!r}: every key and value must be a joint name")
        return dict(data)
    out: dict[str, str] = {}
    for n, line in enumerate(text.splitlines(), 1):
        words = line.split("#", 1)[0].replace("=", " ").replace(":", " ").split()
        if not words:
            continue
        if len(words) != 2:
            raise ModelError(
                f"joint map {str(p)!r} line {n}: expected two joint names, got {line.strip()!r}"
            )
        out[words[0]] = words[1]
    return out


def match_joints(a: Arm, b: Arm, joint_map: Mapping[str, str] | None) -> list[tuple[str, str]]:
    """Pair each joint of A with B's joint of the same name, or the one ``joint_map`` names.

    Raises:
        UnknownNameError: The map names a joint that A or B does not have.
        ModelError: The map sends two joints of A to one joint of B.
    """
    mapping = dict(joint_map or {})
    for name_a, name_b in mapping.items():
        if name_a not in a.joint_names:
            raise UnknownNameError("joint", name_a, a.joint_names)
        if name_b not in b.joint_names:
            raise UnknownNameError("joint", name_b, b.joint_names)
    pairs = [(n, mapping.get(n, n)) for n in a.joint_names]
    targets = [nb for _, nb in pairs]
    twice = sorted({nb for nb in targets if targets.count(nb) > 1})
    if twice:
        raise ModelError(
            f"the joint map sends two joints of A to one joint of B ({', '.join(twice)}): "
            f"{dict(pairs)}"
        )
    return pairs

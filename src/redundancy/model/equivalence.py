"""Structural comparison of the two compiled models: do both engines see the same arm?

Quantities are compared in the world frame at a reference pose, so that Pinocchio's and
MuJoCo's different internal frames (joint frame vs body frame, lumped fixed bodies) do not
matter; only what the physics depends on is compared.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..arm import Arm
from .bridges import Bridge


@dataclass(frozen=True)
class Difference:
    """One quantity on which the engines' models differ.

    Attributes:
        quantity: e.g. ``"body mass"``.
        item: Joint, body or site it concerns.
        mujoco: MuJoCo's value.
        pinocchio: Pinocchio's value.
        error: Largest absolute difference.
    """

    quantity: str
    item: str
    mujoco: object
    pinocchio: object
    error: float

    def __str__(self) -> str:
        return (
            f"{self.quantity} of {self.item}: MuJoCo {_fmt(self.mujoco)}, Pinocchio "
            f"{_fmt(self.pinocchio)} (|diff| {self.error:.3g})"
        )


def _fmt(x: object) -> str:
    if isinstance(x, np.ndarray):
        return np.array2string(x, precision=6, suppress_small=True, max_line_width=200)
    if isinstance(x, float):
        return f"{x:.9g}"
    return str(x)


@dataclass(frozen=True)
class EquivalenceReport:
    """Result of :func:`compare_models`.

    Attributes:
        differences: Every mismatch, with both values.
        bridges: Values copied from MuJoCo into Pinocchio because its parser does not read them.
        tol: Absolute tolerance used [SI units of each quantity].
        checked: Names of the quantities compared.
    """

    differences: tuple[Difference, ...]
    bridges: tuple[Bridge, ...]
    tol: float
    checked: tuple[str, ...]

    @property
    def equivalent(self) -> bool:
        """True when no quantity differs (bridged values are not differences)."""
        return not self.differences

    def lines(self) -> list[str]:
        """Human-readable report lines."""
        out = [
            f"compared ({len(self.checked)} quantities, tol {self.tol:g}): "
            f"{', '.join(self.checked)}"
        ]
        if self.differences:
            out += [f"DIFFERS  {d}" for d in self.differences]
        else:
            out.append("no differences")
        by_kind: dict[str, list[Bridge]] = {}
        for b in self.bridges:
            by_kind.setdefault(b.quantity, []).append(b)
        for kind, items in by_kind.items():
            vals = ", ".join(f"{b.joint}={b.value_text}" for b in items)
            out.append(
                f"BRIDGED  {kind} (from MuJoCo's {items[0].source}; Pinocchio's parser does "
                f"not read it as MuJoCo does): {vals}"
            )
        return out


def compare_models(arm: Arm, q: np.ndarray | None = None, tol: float = 1e-9) -> EquivalenceReport:
    """Compare the two engines' compiled models, quantity by quantity.

    Args:
        arm: The loaded arm.
        q: Reference pose [rad or m]; defaults to zeros clipped into the joint ranges.
        tol: Absolute tolerance [SI units].
    """
    mj, pn = arm.mujoco, arm.pinocchio
    q = np.clip(np.zeros(arm.nq), arm.lower, arm.upper) if q is None else arm.pose(q)
    names = arm.joint_names
    diffs: list[Difference] = []

    def cmp(quantity: str, item: str, a: object, b: object) -> None:
        a_arr, b_arr = np.asarray(a, float), np.asarray(b, float)
        same_inf = np.isinf(a_arr) & np.isinf(b_arr) & (np.sign(a_arr) == np.sign(b_arr))
        with np.errstate(invalid="ignore"):
            diff = a_arr - b_arr
        err = np.where(
            same_inf, 0.0, np.abs(np.nan_to_num(diff, nan=np.inf, posinf=np.inf, neginf=np.inf))
        )
        e = float(np.max(err)) if err.size else 0.0
        if e > tol:
            diffs.append(Difference(quantity, item, a, b, e))

    pm = pn.model
    # Tree structure: each joint's parent joint, by name.
    for i, n in enumerate(names):
        mj_parent_body = arm.mj_model.body_parentid[arm.mj_model.jnt_bodyid[i]]
        mj_parent = _mj_joint_of_body(arm, mj_parent_body)
        pin_parent = pm.names[pm.parents[pm.getJointId(n)]]
        pin_parent = "" if pin_parent == "universe" else pin_parent
        if mj_parent != pin_parent:
            diffs.append(
                Difference(
                    "parent joint", n, mj_parent or "(base)", pin_parent or "(base)", float("inf")
                )
            )
    from ..engines.pinocchio import joint_kind

    for i, n in enumerate(names):
        kind = joint_kind(pm.joints[pm.getJointId(n)])
        if kind != arm.joint_types[i]:
            diffs.append(Difference("joint type", n, arm.joint_types[i], kind, float("inf")))
    ax_m, an_m = mj.joint_axes(q)
    ax_p, an_p = pn.joint_axes(q)
    for i, n in enumerate(names):
        cmp("joint axis (world)", n, ax_m[i], ax_p[i])
        if arm.joint_types[i] == "hinge":
            # The anchor may sit anywhere on the axis line: compare its offset across the line.
            r = an_p[i] - an_m[i]
            cmp("joint axis line offset", n, np.zeros(3), r - (r @ ax_m[i]) * ax_m[i])
    lo_p = np.asarray(pm.lowerPositionLimit)[pn.perm]
    hi_p = np.asarray(pm.upperPositionLimit)[pn.perm]
    for i, n in enumerate(names):
        cmp("joint range", n, np.array([arm.lower[i], arm.upper[i]]), np.array([lo_p[i], hi_p[i]]))
    cmp_vec = [
        ("armature", arm.armature("mujoco"), arm.armature("pinocchio")),
        ("damping", arm.damping(), np.asarray(pm.damping)[pn.perm]),
        ("effort limit", arm.effort_limit, np.asarray(pm.effortLimit)[pn.perm]),
    ]
    for quantity, a, b in cmp_vec:
        for i, n in enumerate(names):
            cmp(quantity, n, float(a[i]), float(b[i]))
    m_m, c_m, I_m = mj.link_inertias(q)
    m_p, c_p, I_p = pn.link_inertias(q)
    for i, n in enumerate(names):
        item = f"body moved by {n}"
        cmp("body mass", item, float(m_m[i]), float(m_p[i]))
        cmp("centre of mass (world)", item, c_m[i], c_p[i])
        cmp("inertia about com (world)", item, I_m[i], I_p[i])
    p_m, R_m = mj.site_pose(q)
    p_p, R_p = pn.site_pose(q)
    cmp("site position", arm.site, p_m, p_p)
    cmp("site orientation", arm.site, R_m, R_p)
    cmp("gravity vector", "model", arm.mj_model.opt.gravity, np.asarray(pm.gravity.linear))
    checked = (
        "parent joint",
        "joint type",
        "joint axis",
        "joint range",
        "armature",
        "damping",
        "effort limit",
        "body mass",
        "centre of mass",
        "inertia",
        "site frame",
        "gravity",
    )
    return EquivalenceReport(tuple(diffs), arm.bridges, tol, checked)


def _mj_joint_of_body(arm: Arm, body: int) -> str:
    """Name of the joint that moves ``body`` (walking up welded bodies), '' for the base."""
    m = arm.mj_model
    while body > 0 and m.body_jntnum[body] == 0:
        body = m.body_parentid[body]
    if body == 0:
        return ""
    return arm.joint_names[m.body_jntadr[body]]

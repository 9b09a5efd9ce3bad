"""Two descriptions that claim to be one robot, compared structurally and pose by pose.

A URDF and its MJCF conversion, or two versions of one MJCF: each is loaded into its own two engines
(and cross-checked there, see [`redundancy.crosscheck`][redundancy.crosscheck]); this module
compares the two arms with each other. Joints are matched by name or by a joint map.

* **Structure**, at a reference pose (zeros clipped into the ranges), in the world frame so
  that each file's choice of body frames does not matter: each joint's parent, type, axis
  (with its sign) and axis line, range, effort limit, damping, friction; armature, spring
  stiffness and reference, MuJoCo's damping and stiffness polynomials (``damping="b0 b1 b2"``:
  b1 and b2, the v|v| and v^3 terms; ``stiffness="k0 k1 k2"``: k1 and k2), gravity
  compensation (per body, and whether it goes through the actuators) and velocity limits
  where both formats carry them; mass, centre of mass and inertia of the body each joint
  moves (links welded to it lumped in); the tool frame's placement; gravity.
* **Poses**: tool pose, Jacobian, mass matrix and gravity torques over random poses drawn
  in the ranges both share, and every keyframe of either file; between two files of one
  format also MuJoCo's passive force less the joint damping (all its terms, the actuators'
  included) and the gravity compensation (springs, tendons, fluid forces), and the gravity
  compensation, at random joint velocities: anything else the simulation adds.

First, a **rigid offset**: when B is A placed elsewhere (its base moved or turned) or with
its tool mounted elsewhere on the last link, the transform is found from the joint axes (and
the tool frame at the reference pose), said once, and everything else is compared relative
to it; what still differs comes after.

Each difference names the quantity, the joint or body, both values, and the first joint
where the two kinematic chains part. What a format cannot express (armature, springs,
gravity compensation, a damping polynomial, keyframes and gravity in URDF; velocity limits in
MJCF) is listed as such, not as a difference.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from ..arm import Arm
from ..arm_coupled import ChainView
from ..errors import ModelError
from ..model.bridges import effective_gravity
from ..model.equivalence import fit_rigid, parent_joint
from ..model.names import display_names
from ..model.scales import arm_scales, scaled_error, scaled_errors
from .compare_couplings import coupling_findings
from .compare_poses import (
    POLY_NOTE,
    STIFFNESS_NOTE,
    damping_polynomial,
    mujoco_stacks,
    passive_forces,
    passive_listing,
    shared_poses,
)
from .comparison import Comparison, Finding, RigidOffset, match_joints, read_joint_map

Array = NDArray[np.float64]

__all__ = ["Comparison", "Finding", "RigidOffset", "compare", "read_joint_map"]

#: A rigid offset is taken as found when, after it, every joint axis of A lies on B's within
#: this (or the comparison's tolerance, if larger), relative to the arm's length for
#: positions [-]; what remains is compared.
FIT_TOL = 1e-6


def _skew(v: Array) -> Array:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def compare(
    a: Arm | str | os.PathLike[str],
    b: Arm | str | os.PathLike[str],
    *,
    frame_a: str | None = None,
    frame_b: str | None = None,
    joint_map: Mapping[str, str] | str | os.PathLike[str] | None = None,
    n_poses: int = 200,
    seed: int = 0,
    tol: float = 1e-9,
) -> Comparison:
    """Compare two descriptions of one robot, structurally and pose by pose.

    Args:
        a: An Arm, or a model file (MJCF or URDF) loaded with ``frame_a``.
        b: Likewise, with ``frame_b``.
        frame_a: A's tool frame (an MJCF site or body, a URDF link or fixed joint); default: the
            file's one chain end, else its frame named ``"ee"``
            ([`redundancy.model.ends.frame_for`][redundancy.model.ends.frame_for]).
        frame_b: B's tool frame, likewise.
        joint_map: A's joint name -> B's, for joints whose names differ (others match by name), or
            the path of a joint map file (see
            [`read_joint_map`][redundancy.analysis.compare.read_joint_map]).
        n_poses: Random poses compared, besides the keyframes (>= 0).
        seed: Seed of the random poses.
        tol: Relative tolerance, finite and > 0: each difference is divided by its quantity's scale
            (max |A's value|, never below the quantity's size on A: its length for positions, m L^2
            for inertias, m g L for torques; see
            [`redundancy.model.scales`][redundancy.model.scales]), as in the cross-check [-].

    Raises:
        ModelError: A file that does not load, a bad joint map, bad arguments.
        UnknownNameError: A tool frame or mapped joint the model does not have.
    """
    from ..model.loading import load, model_format

    if not (isinstance(tol, int | float) and math.isfinite(tol) and tol > 0):
        raise ModelError(f"tol must be a finite number > 0, got {tol!r}")
    if isinstance(n_poses, bool) or not isinstance(n_poses, int) or n_poses < 0:
        raise ModelError(f"n_poses must be an integer >= 0, got {n_poses!r}")
    for name, model in (("a", a), ("b", b)):
        if not isinstance(model, Arm | str | os.PathLike):
            raise ModelError(
                f"{name} must be an Arm or a model file path, got {type(model).__name__}"
            )
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ModelError(f"seed must be an integer >= 0, got {seed!r}")
    for name, frame in (("frame_a", frame_a), ("frame_b", frame_b)):
        if frame is not None and not isinstance(frame, str):
            raise ModelError(f"{name} must be a name (str) or None, got {type(frame).__name__}")
    if joint_map is not None and not isinstance(joint_map, Mapping | str | os.PathLike):
        raise ModelError(
            "joint_map must be a mapping (A's joint -> B's), a file path or None, "
            f"got {type(joint_map).__name__}"
        )
    if isinstance(joint_map, str | os.PathLike):
        joint_map = read_joint_map(joint_map)
    # No frame: load's default (the file's one chain end, else a frame named "ee").
    arm_a = a if isinstance(a, Arm) else load(a, frame=frame_a)
    arm_b = b if isinstance(b, Arm) else load(b, frame=frame_b)
    fmt_a, fmt_b = model_format(arm_a), model_format(arm_b)
    # Two files of one mechanism: with couplings, every joint it moves, the couplings
    # themselves compared as functions (`coupling_findings`).
    if arm_a.coupling is not None or arm_b.coupling is not None:
        arm_a, arm_b = (ChainView(x) if x.coupling is not None else x for x in (arm_a, arm_b))
    pairs = match_joints(arm_a, arm_b, joint_map)
    return _Comparer(arm_a, arm_b, fmt_a, fmt_b, pairs, tol).run(n_poses, seed)


class _Comparer:
    """State of one comparison: the two arms, the joint pairing and the findings so far."""

    def __init__(
        self, a: Arm, b: Arm, fmt_a: str, fmt_b: str, pairs: list[tuple[str, str]], tol: float
    ) -> None:
        self.a, self.b, self.fmt_a, self.fmt_b, self.tol = a, b, fmt_a, fmt_b, tol
        self.pairs = pairs
        sc = self.scales = arm_scales(a)
        L = sc.length
        rate = math.sqrt(sc.gravity / L)  # the arm's natural rate [rad/s]
        #: Each quantity's size on A (model.scales): what its differences are divided by; a
        #: polynomial's, one per coefficient (each term's force at the natural rate or an
        #: angle of 1 rad: the torque scale).
        self.sizes: dict[str, float | tuple[float, ...]] = {
            "joint axis (world)": 1.0,
            "joint axis line (world)": L,
            "joint anchor (world)": L,
            "effort limit": sc.torque,
            "damping": sc.inertia * rate,
            "damping polynomial": (sc.inertia, sc.inertia / rate),
            "stiffness polynomial": (sc.torque, sc.torque),
            "friction": sc.torque,
            "body mass": sc.mass,
            "centre of mass (world)": L,
            "inertia about the centre of mass (world)": sc.inertia,
            "armature": sc.inertia,
            "joint stiffness": sc.torque,
            "gravity compensation": 1.0,
            "gravity compensation through the actuators": 1.0,
            "tool frame position (world)": L,
            "tool frame rotation (world)": 1.0,
            "gravity vector": sc.gravity,
        }
        self.diffs: list[Finding] = []
        self.inexpressible: list[Finding] = []
        self.largest: dict[str, float] = {}
        self.kinematic: list[int] = []  # indices (A's order) of joints whose kinematics differ
        # Joints of A present in B, as indices into each arm's order.
        self.ia = [i for i, (_, nb) in enumerate(pairs) if nb in b.joint_names]
        self.ib = [b.joint_index(pairs[i][1]) for i in self.ia]
        # Poses are compared over the joints both have (a joint only one has sits at zero,
        # clipped into its range, and is itself a difference).
        self.matched = bool(self.ia)
        # Per joint, the display name of the body it moves.
        self.bodies_a, self.bodies_b = (_joint_bodies(arm) for arm in (a, b))
        # Rigid offsets: B's world = R A's world + t; B's tool = A's tool moved by s, turned S.
        self.R, self.t = np.eye(3), np.zeros(3)
        self.S, self.s = np.eye(3), np.zeros(3)
        self.offsets: list[RigidOffset] = []

    # -- rigid offsets -----------------------------------------------------------------------
    def find_base(self) -> None:
        """B's base placement relative to A's, from the joint axes at the reference pose."""
        if not self.ia:
            return
        qa, qb = self.reference_poses()
        ax_a, an_a = self.a.mujoco.joint_axes(qa)
        ax_b, an_b = self.b.mujoco.joint_axes(qb)
        ia, ib = np.asarray(self.ia), np.asarray(self.ib)
        hinge = np.array([self.a.joint_types[i] == "hinge" for i in self.ia])
        fit = fit_rigid(ax_a[ia], an_a[ia], ax_b[ib], an_b[ib], hinge)
        if fit is None:
            return
        R, t = fit
        # Directions are compared as they are, positions relative to the arm's length.
        tol, L = max(self.tol, FIT_TOL), self.scales.length
        for k in range(len(ia)):  # every joint on B's after the offset, or no offset
            axis = R @ ax_a[ia[k]]
            r = an_b[ib[k]] - (R @ an_a[ia[k]] + t)
            across = r - (r @ axis) * axis if hinge[k] else r
            if np.max(np.abs(axis - ax_b[ib[k]])) > tol or np.max(np.abs(across)) > tol * L:
                return
        # Parts within the tolerance are none: a pure shift is said without a turn.
        R = np.eye(3) if np.max(np.abs(R - np.eye(3))) <= self.tol else R
        t = np.where(np.abs(t) <= self.tol * L, 0.0, t)
        if not np.any(t) and np.array_equal(R, np.eye(3)):
            return
        self.R, self.t = R, t
        self.offsets.append(RigidOffset("base placement", t, R))

    def find_tool(self) -> None:
        """B's tool mount relative to A's, when the joints agree and the tool frames do not."""
        if self.kinematic:  # a joint differs: the tool frame's difference is not a mount
            return
        qa, qb = self.reference_poses()
        pos_a, rot_a = self.a.mujoco.site_pose(qa)
        pos_b, rot_b = self.b.mujoco.site_pose(qb)
        rot_a, pos_a = self.R @ rot_a, self.R @ pos_a + self.t
        S = rot_a.T @ rot_b
        s = rot_a.T @ (pos_b - pos_a)
        S = np.eye(3) if np.max(np.abs(S - np.eye(3))) <= self.tol else S
        s = np.where(np.abs(s) <= self.tol * self.scales.length, 0.0, s)
        if not np.any(s) and np.array_equal(S, np.eye(3)):
            return
        self.S, self.s = S, s
        self.offsets.append(RigidOffset("tool mount", s, S))

    def placed(self, x: Array) -> Array:
        """A's world points, shape (..., 3), where B's world has them."""
        return x @ self.R.T + self.t

    def tool_a(self, pos: Array, rot: Array) -> tuple[Array, Array]:
        """A's tool frame(s) with B's mount, in B's world: positions (..., 3), rotations."""
        mounted = pos + rot @ self.s
        return self.placed(mounted), self.R @ rot @ self.S

    def jacobian_a(self, J: Array, rot: Array) -> Array:
        """A's tool Jacobians (n, 6, nv) at B's mount, in B's world axes."""
        r = rot @ self.s  # (n, 3): from A's tool point to the mounted one, world axes
        lin = J[:, :3] - np.einsum("nij,njk->nik", np.array([_skew(v) for v in r]), J[:, 3:])
        return np.concatenate([self.R @ lin, self.R @ J[:, 3:]], axis=1)

    def where(self, i: int) -> str:
        name_a, name_b = self.pairs[i]
        return f"joint {name_a!r}" + (f" [{name_b!r}]" if name_b != name_a else "")

    def body_where(self, i: int) -> str:
        ba = self.bodies_a[i]
        bb = self.bodies_b[self.b.joint_index(self.pairs[i][1])]
        shown = f"{ba!r}" + (f" [{bb!r}]" if bb != ba else "")
        return f"body {shown} (moved by {self.pairs[i][0]!r})"

    def check(
        self, quantity: str, where: str, va: Any, vb: Any, note: str = "", size: float = 0.0
    ) -> bool:
        """Record a difference when it exceeds tol relative to the quantity's scale.

        A quantity with one size per entry (a polynomial's coefficients) takes the largest
        of its entries' errors. Returns True when they differ.
        """
        sizes = size or self.sizes[quantity]
        if isinstance(sizes, tuple):
            errs = (scaled_error(x, y, s) for x, y, s in zip(va, vb, sizes, strict=True))
            err = max(errs)
        else:
            err = scaled_error(va, vb, sizes)
        self.largest[quantity] = max(self.largest.get(quantity, 0.0), err)
        if err > self.tol:
            self.diffs.append(Finding(quantity, where, va, vb, err, note))
            return True
        return False

    def cannot(self, quantity: str, where: str, va: Any, vb: Any, fmt: str) -> None:
        self.inexpressible.append(Finding(quantity, where, va, vb, 0.0, f"{fmt} cannot express it"))

    # -- structure -----------------------------------------------------------------------
    def structure(self) -> None:
        a, b = self.a, self.b
        self._presence()
        qa, qb = self.reference_poses()
        ax_a, an_a = a.mujoco.joint_axes(qa)
        ax_b, an_b = b.mujoco.joint_axes(qb)
        m_a, c_a, I_a = a.mujoco.link_inertias(qa)
        m_b, c_b, I_b = b.mujoco.link_inertias(qb)
        # A's world quantities where B's world has them (the base offset, if found).
        ax_a, an_a, c_a = ax_a @ self.R.T, self.placed(an_a), self.placed(c_a)
        I_a = self.R @ I_a @ self.R.T
        inverse = {nb: na for na, nb in self.pairs}
        for i, j in zip(self.ia, self.ib, strict=True):
            w = self.where(i)
            kin = False
            pa = parent_joint(a, i)
            pb = parent_joint(b, j)
            pb_in_a = inverse.get(pb, pb) if pb else ""
            if pa != pb_in_a:
                self.diffs.append(
                    Finding("parent joint", w, pa or "(base)", pb or "(base)", math.inf)
                )
                kin = True
            if a.joint_types[i] != b.joint_types[j]:
                self.diffs.append(
                    Finding("joint type", w, a.joint_types[i], b.joint_types[j], math.inf)
                )
                kin = True
            kin |= self.check("joint axis (world)", w, ax_a[i], ax_b[j])
            if a.joint_types[i] == "hinge":
                # The anchor may sit anywhere on the axis line: compare the offset across it.
                r = an_b[j] - an_a[i]
                kin |= self.check(
                    "joint axis line (world)", w, np.zeros(3), r - (r @ ax_a[i]) * ax_a[i]
                )
            else:
                kin |= self.check("joint anchor (world)", w, an_a[i], an_b[j])
            if kin:
                self.kinematic.append(i)
            unit = 1.0 if a.joint_types[i] == "hinge" else self.scales.length  # rad or m
            lo_hi_a, lo_hi_b = [a.lower[i], a.upper[i]], [b.lower[j], b.upper[j]]
            self.check("joint range", w, lo_hi_a, lo_hi_b, size=unit)
            self.check("effort limit", w, a.effort_limit[i], b.effort_limit[j])
            self.check("damping", w, a.damping()[i], b.damping()[j])
            self.check(
                "friction",
                w,
                a.mj_model.dof_frictionloss[i],
                b.mj_model.dof_frictionloss[j],
            )
            bw = self.body_where(i)
            self.check("body mass", bw, m_a[i], m_b[j])
            self.check("centre of mass (world)", bw, c_a[i], c_b[j])
            self.check("inertia about the centre of mass (world)", bw, I_a[i], I_b[j])
        self.armature()
        self.passive()
        self.couplings()
        self.format_only()
        self._tool_and_gravity(qa, qb)

    def _presence(self) -> None:
        """Joints (arm and held) that one description has and the other lacks."""
        a, b = self.a, self.b
        only_a = [na for na, nb in self.pairs if nb not in b.joint_names]
        mapped = {nb for _, nb in self.pairs}
        only_b = [n for n in b.joint_names if n not in mapped]
        for n in only_a:
            self.diffs.append(Finding("presence", f"joint {n!r}", "present", "absent", math.inf))
        for n in only_b:
            self.diffs.append(Finding("presence", f"joint {n!r}", "absent", "present", math.inf))
        # Joints off the arm (a gripper's, a torso's) are held still: one file may have them
        # and the other not; their bodies' masses show in the mass matrix and gravity below.
        for n in a.held:
            if n not in b.held and n not in b.joint_names:
                where = f"held joint {n!r}"
                self.diffs.append(Finding("presence", where, "present", "absent", math.inf))
        for n in b.held:
            if n not in a.held and n not in a.joint_names:
                where = f"held joint {n!r}"
                self.diffs.append(Finding("presence", where, "absent", "present", math.inf))
        if only_a:
            self.kinematic.append(a.joint_index(only_a[0]))

    def _tool_and_gravity(self, qa: Array, qb: Array) -> None:
        """The tool frame's placement at the reference poses, and the gravity vector."""
        a, b = self.a, self.b
        self.find_tool()
        pos_a, rot_a = self.tool_a(*a.mujoco.site_pose(qa))
        pos_b, rot_b = b.mujoco.site_pose(qb)
        tool = f"tool frame {a.frame!r}" + (f" [{b.frame!r}]" if b.frame != a.frame else "")
        moved = self.check("tool frame position (world)", tool, pos_a, pos_b)
        moved |= self.check("tool frame rotation (world)", tool, rot_a, rot_b)
        if moved:
            self.kinematic.append(a.nq)  # after the last joint
        # What MuJoCo simulates: opt.gravity, or zero under <flag gravity="disable"/>.
        g_a, g_b = effective_gravity(a.mj_model), effective_gravity(b.mj_model)
        if "URDF" in (self.fmt_a, self.fmt_b) and self.fmt_a != self.fmt_b:
            standard = np.array([0.0, 0.0, -9.81])
            mjcf_g = g_b if self.fmt_a == "URDF" else g_a
            if scaled_error(standard, mjcf_g, 1.0) > self.tol:
                self.cannot("gravity vector", "model", g_a, g_b, "URDF")
                return
        self.check("gravity vector", "model", g_a, g_b)

    def armature(self) -> None:
        a, b = self.a, self.b
        arm_a, arm_b = a.armature(), b.armature()
        if self.armature_comparable:
            for i, j in zip(self.ia, self.ib, strict=True):
                self.check("armature", self.where(i), arm_a[i], arm_b[j])
            return
        # One side is URDF: list the other side's armature (if any) as not expressible.
        arm = b if self.fmt_a == "URDF" else a
        values = arm.armature()
        if np.any(values != 0):
            listed = {n: float(v) for n, v in zip(arm.joint_names, values, strict=True)}
            va, vb = (None, listed) if self.fmt_a == "URDF" else (listed, None)
            self.cannot("armature", "joints", va, vb, "URDF")

    def passive(self) -> None:
        """Joint springs, damping polynomials and gravity compensation.

        Compared in one format, listed across two (URDF has none of them).
        """
        a, b = self.a, self.b
        ma, mb = a.mj_model, b.mj_model
        if self.fmt_a != self.fmt_b:  # URDF has none: list the MJCF side's
            side = "b" if self.fmt_a == "URDF" else "a"
            for quantity, (where, values) in passive_listing(b if side == "b" else a).items():
                if values:
                    va, vb = (values, None) if side == "a" else (None, values)
                    self.cannot(quantity, where, va, vb, "URDF")
            return
        poly_a, poly_b = damping_polynomial(a), damping_polynomial(b)
        with_gravcomp = bool(np.any(ma.body_gravcomp) or np.any(mb.body_gravcomp))
        for i, j in zip(self.ia, self.ib, strict=True):
            w = self.where(i)
            self.check("damping polynomial", w, poly_a[i], poly_b[j], POLY_NOTE)
            k_a, k_b = float(ma.jnt_stiffness[i]), float(mb.jnt_stiffness[j])
            self.check("joint stiffness", w, k_a, k_b)
            ks_a, ks_b = ma.jnt_stiffnesspoly[i], mb.jnt_stiffnesspoly[j]
            self.check("stiffness polynomial", w, ks_a, ks_b, STIFFNESS_NOTE)
            if (k_a or any(ks_a)) and (k_b or any(ks_b)):  # a reference matters to a spring
                unit = 1.0 if a.joint_types[i] == "hinge" else self.scales.length
                ref_a = float(ma.qpos_spring[ma.jnt_qposadr[i]])
                ref_b = float(mb.qpos_spring[mb.jnt_qposadr[j]])
                self.check("spring reference", w, ref_a, ref_b, size=unit)
            ga, gb = ma.body_gravcomp[ma.jnt_bodyid[i]], mb.body_gravcomp[mb.jnt_bodyid[j]]
            self.check("gravity compensation", self.body_where(i), float(ga), float(gb))
            if with_gravcomp:
                self.check(
                    "gravity compensation through the actuators",
                    w,
                    float(ma.jnt_actgravcomp[i]),
                    float(mb.jnt_actgravcomp[j]),
                )

    def couplings(self) -> None:
        """Mimics and joint equalities of the whole robots, compared as functions."""
        a, b = self.a.robot_model, self.b.robot_model
        found, self.largest["coupling"] = coupling_findings(
            a, b, dict(self.pairs), self.scales.length, self.tol
        )
        self.diffs.extend(found)

    @property
    def armature_comparable(self) -> bool:
        return "URDF" not in (self.fmt_a, self.fmt_b) or self.fmt_a == self.fmt_b

    def format_only(self) -> None:
        """Velocity limits (URDF only) and keyframes (MJCF only), listed where one side has them.

        Between two URDFs the velocity limits are compared.
        """
        if self.fmt_a == self.fmt_b == "URDF":
            vel_a, vel_b = (
                np.asarray(x.pinocchio.model.velocityLimit)[x.pinocchio.perm]
                for x in (self.a, self.b)
            )
            for i, j in zip(self.ia, self.ib, strict=True):
                unit = 1.0 if self.a.joint_types[i] == "hinge" else self.scales.length
                self.check(
                    "velocity limit", self.where(i), float(vel_a[i]), float(vel_b[j]), size=unit
                )
        if self.fmt_a == self.fmt_b:
            return
        for arm, fmt, side in ((self.a, self.fmt_a, "a"), (self.b, self.fmt_b, "b")):
            if fmt == "URDF":
                vel = np.asarray(arm.pinocchio.model.velocityLimit)[arm.pinocchio.perm]
                if np.isfinite(vel).any():
                    values = {n: float(v) for n, v in zip(arm.joint_names, vel, strict=True)}
                    va, vb = (values, None) if side == "a" else (None, values)
                    self.cannot("velocity limit", "joints", va, vb, "MJCF")
            elif arm.keyframes:
                names = sorted(arm.keyframes)
                va, vb = (names, None) if side == "a" else (None, names)
                self.cannot("keyframes", "model", va, vb, "URDF")

    def reference_poses(self) -> tuple[Array, Array]:
        qa = np.clip(np.zeros(self.a.nq), self.a.lower, self.a.upper)
        return qa, self.to_b(qa)

    def to_b(self, qa: Array) -> Array:
        """B's pose (or stack of poses) for A's: shared joints copied, B's others at rest."""
        rest = np.clip(np.zeros(self.b.nq), self.b.lower, self.b.upper)
        qb = np.broadcast_to(rest, (*qa.shape[:-1], self.b.nq)).copy()
        qb[..., self.ib] = qa[..., self.ia]
        return qb

    # -- poses -----------------------------------------------------------------------------
    def pose_by_pose(self, n: int, seed: int) -> int:
        qs = shared_poses(self.a, self.b, self.ia, self.ib, n, seed)
        if not len(qs):
            return 0
        perm = np.asarray(self.ib)
        cols = np.asarray(self.ia)
        full_m = self.armature_comparable
        gravity_ok = not any(f.quantity == "gravity vector" for f in self.inexpressible)
        # One stacked pass per arm (the engine's evaluate, equal to its single-pose methods).
        Xa, Ra, Ja, Ma, Ga = mujoco_stacks(self.a, qs, full_m, gravity_ok)
        Xb, Rb, Jb, Mb, Gb = mujoco_stacks(self.b, self.to_b(qs), full_m, gravity_ok)
        # A's tool where B's base and mount put it (gravity stays: a turned base changes it).
        Ja = self.jacobian_a(Ja, Ra)
        Xa, Ra = self.tool_a(Xa, Ra)
        # Per quantity: A's stack, B's stack, and the axis of one pose's value that runs over
        # joints (None for the tool pose), to name the joint with the largest difference.
        values: dict[str, tuple[Array, Array, int | None]] = {
            "tool position": (Xa, Xb, None),
            "tool rotation": (Ra, Rb, None),
            "jacobian": (Ja[:, :, cols], Jb[:, :, perm], 1),
            "mass matrix": (Ma[:, cols[:, None], cols], Mb[:, perm[:, None], perm], 0),
        }
        if Ga is not None and Gb is not None:
            values["gravity torque"] = (Ga[:, cols], Gb[:, perm], 0)
        if self.fmt_a == self.fmt_b:
            (Pa, Ca), (Pb, Cb) = passive_forces(
                self.a, self.b, qs, self.to_b(qs), self.ia, self.ib, self.scales.length, seed
            )
            values["spring and fluid force"] = (Pa[:, cols], Pb[:, perm], 0)
            values["gravity compensation torque"] = (Ca[:, cols], Cb[:, perm], 0)
        sc = self.scales
        sizes = {
            "tool position": sc.length,
            "tool rotation": 1.0,
            "mass matrix": sc.inertia,
            "gravity torque": sc.torque,
            "spring and fluid force": sc.torque,
            "gravity compensation torque": sc.torque,
        }
        for quantity, (stack_a, stack_b, axis) in values.items():
            if quantity == "jacobian":  # linear rows [m/rad] and angular rows, each its scale
                lin = scaled_errors(stack_a[:, :3], stack_b[:, :3], sc.length)
                ang = scaled_errors(stack_a[:, 3:], stack_b[:, 3:], 1.0)
                errs = np.maximum(lin, ang).tolist()
            else:
                errs = scaled_errors(stack_a, stack_b, sizes[quantity]).tolist()
            p = 0  # the first pose with the largest difference
            for k, e in enumerate(errs):
                if e > errs[p]:
                    p = k
            err, va, vb = errs[p], stack_a[p], stack_b[p]
            bare = quantity == "mass matrix" and not full_m
            name = quantity + (" (without armature)" if bare else "")
            self.largest[name] = err
            if err <= self.tol:
                continue
            note = f"worst at pose {p}, q_A = {np.array2string(qs[p], precision=4)}"
            if quantity == "tool position":
                self.diffs.append(Finding(name, "the tool frame", va, vb, err, note))
                continue
            # The entry that differs most, and the joint its row or column belongs to.
            entry = np.unravel_index(np.argmax(np.abs(va - vb)), va.shape)
            where = "the tool frame" if axis is None else self.where(self.ia[int(entry[axis])])
            note = f"entry {tuple(int(i) for i in entry)}; " + note
            self.diffs.append(Finding(name, where, float(va[entry]), float(vb[entry]), err, note))
        return len(qs)

    def run(self, n: int, seed: int) -> Comparison:
        self.find_base()
        self.structure()
        n_checked = self.pose_by_pose(n, seed) if self.matched else 0
        part = None
        if self.kinematic:
            first = min(self.kinematic)
            part = "tool frame (after the last joint)" if first >= self.a.nq else self.where(first)
        return Comparison(
            a=f"{self.a.source} ({self.fmt_a})",
            b=f"{self.b.source} ({self.fmt_b})",
            frame_a=self.a.frame,
            frame_b=self.b.frame,
            joint_map=tuple(self.pairs),
            differences=tuple(self.diffs),
            not_expressible=tuple(self.inexpressible),
            chains_part=part,
            largest=dict(self.largest),
            n_poses=n_checked,
            tol=self.tol,
            offsets=tuple(self.offsets),
        )


def _joint_bodies(arm: Arm) -> list[str]:
    """Per joint, the display name of the body it moves (see `redundancy.model.names`)."""
    m = arm.mj_model
    names = display_names(m, mujoco.mjtObj.mjOBJ_BODY)
    return [names[int(b)] for b in m.jnt_bodyid]

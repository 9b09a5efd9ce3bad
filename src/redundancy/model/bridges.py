"""Bridges: values Pinocchio's MJCF parser does not read, copied from MuJoCo's compiled model.

Each value is compared first and copied only when Pinocchio's differs, and each copy is
recorded as a :class:`Bridge`, so reports say exactly where the engines would otherwise have
seen different arms.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from ..engines.pinocchio import joint_kind
from ..errors import UnsupportedFeatureError

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Bridge:
    """A value Pinocchio's MJCF parser does not read, copied from MuJoCo's compiled model.

    Attributes:
        quantity: What was bridged, e.g. ``"effort limit"``.
        joint: Joint it applies to.
        value: The value given to Pinocchio [N m, kg m^2...].
        source: Where in MuJoCo's model it came from.
    """

    quantity: str
    joint: str
    value: float | tuple[float, ...]
    source: str

    @property
    def value_text(self) -> str:
        """The value, formatted compactly."""
        if isinstance(self.value, tuple):
            return "(" + ", ".join(f"{v:g}" for v in self.value) + ")"
        return f"{self.value:g}"


def check_pinocchio(pm: pin.Model, joint_names: Sequence[str], site: str) -> None:
    """Refuse a Pinocchio model whose joints or tool frame differ from MuJoCo's.

    Raises:
        UnsupportedFeatureError: Joints missing, of another type, or no frame named ``site``.
    """
    pin_joints = [pm.names[j] for j in range(1, pm.njoints)]
    missing = [n for n in joint_names if n not in pin_joints]
    if missing or pm.nq != len(joint_names) or pm.nv != len(joint_names):
        raise UnsupportedFeatureError(
            "joint structure Pinocchio reads differently",
            f"MuJoCo joints {list(joint_names)}, Pinocchio joints {pin_joints} "
            f"(nq {pm.nq}, nv {pm.nv})",
            "the engines must see the same joints",
        )
    if site not in [f.name for f in pm.frames]:
        raise UnsupportedFeatureError(
            "site Pinocchio does not read",
            f"site {site!r}",
            "Pinocchio has no frame of that name",
        )
    for n in joint_names:
        kind = joint_kind(pm.joints[pm.getJointId(n)])
        if kind not in ("hinge", "slide"):
            raise UnsupportedFeatureError(
                f"Pinocchio joint type {kind}",
                f"joint {n!r}",
                "expected a 1-dof revolute or prismatic joint",
            )


def bridge(
    pm: pin.Model,
    mm: mujoco.MjModel,
    joint_names: Sequence[str],
    site: str,
    effort_limit: Array,
    armature: Array,
    damping: Array,
    lower: Array,
    upper: Array,
) -> tuple[Bridge, ...]:
    """Copy into Pinocchio what its MJCF parser leaves out or reads differently.

    Each value is compared first and copied only when Pinocchio's differs, so the list
    says exactly where the engines would otherwise have seen different arms.
    """
    bridges: list[Bridge] = []
    # Per-dof values Pinocchio keeps in a vector of its own: (name, its vector, ours, source).
    per_dof = (
        (
            "effort limit",
            pm.effortLimit,
            effort_limit,
            "actuator ctrlrange/forcerange x gear",
        ),
        (
            "armature",
            pm.armature,
            armature,
            "dof armature + gear^2 x actuator armature",
        ),
        ("damping", pm.damping, damping, "dof damping + gear^2 x actuator damping"),
    )
    for i, name in enumerate(joint_names):
        k = pm.joints[pm.getJointId(name)].idx_v
        for quantity, theirs, ours, source in per_dof:
            if theirs[k] != ours[i]:
                theirs[k] = ours[i]  # Pinocchio's vectors are writable views of its model
                bridges.append(Bridge(quantity, name, float(ours[i]), source))
        rng = (float(lower[i]), float(upper[i]))
        if (pm.lowerPositionLimit[k], pm.upperPositionLimit[k]) != rng:
            bridges.append(Bridge("joint range", name, rng, "jnt_range and jnt_limited"))
            pm.lowerPositionLimit[k], pm.upperPositionLimit[k] = rng
    g = mm.opt.gravity.copy()
    if not np.array_equal(pm.gravity.linear, g):
        bridges.append(Bridge("gravity", "model", tuple(float(x) for x in g), "<option gravity>"))
        pm.gravity = pin.Motion(g, np.zeros(3))
    bridges += _bridge_site(pm, mm, joint_names, site)
    return tuple(bridges)


def _bridge_site(
    pm: pin.Model, mm: mujoco.MjModel, joint_names: Sequence[str], site: str
) -> list[Bridge]:
    """Fix the site frame's placement when only the site itself is misplaced.

    Pinocchio's parser ignores site defaults (``<default><site pos=.../>``). When the
    site's body sits where MuJoCo puts it but the site does not, the site's placement in
    its body is copied from MuJoCo; a misplaced body is left alone, for the equivalence
    report to show.
    """
    data = mujoco.MjData(mm)
    mujoco.mj_kinematics(mm, data)
    pd = pm.createData()
    q = np.zeros(pm.nq)
    for i, name in enumerate(joint_names):
        q[pm.joints[pm.getJointId(name)].idx_q] = mm.qpos0[i]
    pin.framesForwardKinematics(pm, pd, q)
    sid = mujoco.mj_name2id(mm, mujoco.mjtObj.mjOBJ_SITE, site)
    fid = pm.getFrameId(site)
    site_mj = pin.SE3(data.site_xmat[sid].reshape(3, 3).copy(), data.site_xpos[sid].copy())
    if np.max(np.abs((site_mj.inverse() * pd.oMf[fid]).homogeneous - np.eye(4))) < 1e-12:
        return []
    body = mm.site_bodyid[sid]
    bname = mujoco.mj_id2name(mm, mujoco.mjtObj.mjOBJ_BODY, body) or ""
    body_mj = pin.SE3(data.xmat[body].reshape(3, 3).copy(), data.xpos[body].copy())
    if not pm.existFrame(bname):
        return []
    bf = pm.getFrameId(bname)
    if np.max(np.abs((body_mj.inverse() * pd.oMf[bf]).homogeneous - np.eye(4))) > 1e-12:
        return []
    frame = pm.frames[fid]
    joint_pose = pd.oMi[frame.parentJoint]
    frame.placement = joint_pose.inverse() * site_mj
    pm.frames[fid] = frame
    return [
        Bridge(
            "site placement",
            site,
            tuple(float(x) for x in mm.site_pos[sid]),
            "site_pos and site_quat (site defaults)",
        )
    ]

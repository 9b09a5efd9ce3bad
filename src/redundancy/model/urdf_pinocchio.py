"""Pinocchio's model of a URDF, its continuous joints rebuilt as one-coordinate revolutes.

Pinocchio reads a continuous joint as an unbounded revolute of two coordinates (cos, sin);
MuJoCo's is a hinge of one. `build_pinocchio` rebuilds the model with one angle each, without
limits (see `redundancy.model.urdf` for how the library reads URDF).
"""

from __future__ import annotations

import numpy as np

from ..errors import ModelError


def build_pinocchio(text: str, source: str) -> tuple[object, list[str]]:
    """Pinocchio's model of a URDF, continuous joints as one-coordinate unbounded revolutes.

    Returns:
        The model, and the names of the continuous joints that were rebuilt.

    Raises:
        ModelError: Pinocchio cannot read it (the message carries Pinocchio's).
    """
    import pinocchio as pin

    try:
        model = pin.buildModelFromXML(text)
    except Exception as err:  # Pinocchio raises bare RuntimeError/ValueError from C++.
        raise ModelError(f"Pinocchio could not read the URDF {source}: {err}") from err
    return _bounded_revolutes(model)


def continuous_joints(model: object) -> list[str]:
    """Names of the joints Pinocchio read as (cos, sin) pairs."""
    kinds = ("JointModelRUBX", "JointModelRUBY", "JointModelRUBZ")
    kinds += ("JointModelRevoluteUnboundedUnaligned",)
    return [
        model.names[j]  # type: ignore[attr-defined]
        for j in range(1, model.njoints)  # type: ignore[attr-defined]
        if model.joints[j].shortname() in kinds  # type: ignore[attr-defined]
    ]


_NV_FIELDS = (
    "effortLimit",
    "lowerEffortLimit",
    "upperEffortLimit",
    "velocityLimit",
    "lowerVelocityLimit",
    "damping",
    "friction",
    "lowerDryFrictionLimit",
    "upperDryFrictionLimit",
    "armature",
    "rotorInertia",
    "rotorGearRatio",
)
_NQ_FIELDS = ("lowerPositionLimit", "upperPositionLimit", "positionLimitMargin")


def _bounded_revolutes(model: object) -> tuple[object, list[str]]:
    """Rebuild a Pinocchio model with each (cos, sin) revolute as a one-angle revolute.

    Same joint placements, inertias, frames and per-dof values; the configuration of a
    continuous joint becomes its angle, without limits, as MuJoCo's unlimited hinge.
    """
    import pinocchio as pin

    assert isinstance(model, pin.Model)
    axes = {"JointModelRUBX": pin.JointModelRX, "JointModelRUBY": pin.JointModelRY}
    axes["JointModelRUBZ"] = pin.JointModelRZ
    unaligned = "JointModelRevoluteUnboundedUnaligned"
    kinds = [model.joints[j].shortname() for j in range(model.njoints)]
    rebuilt = continuous_joints(model)
    if not rebuilt:
        return model, []
    new = pin.Model()
    new.name = model.name
    jmap = {0: 0}
    for j in range(1, model.njoints):
        joint = model.joints[j]
        if kinds[j] in axes:
            joint = axes[kinds[j]]()
        elif kinds[j] == unaligned:
            # The axis is not exposed; the motion subspace S = (0, axis) at angle 0 carries it.
            data = joint.createData()
            joint.calc(data, np.array([1.0, 0.0]))
            joint = pin.JointModelRevoluteUnaligned(np.asarray(data.S).reshape(6)[3:].copy())
        parent = jmap[model.parents[j]]
        jmap[j] = new.addJoint(parent, joint, model.jointPlacements[j], model.names[j])
        new.appendBodyToJoint(jmap[j], model.inertias[j], pin.SE3.Identity())
    new.inertias[0] = model.inertias[0].copy()
    fmap = {0: 0}
    for i in range(1, model.nframes):
        f = model.frames[i]
        copy = pin.Frame(
            f.name, jmap[f.parentJoint], fmap[f.parentFrame], f.placement, f.type, f.inertia
        )
        fmap[i] = new.addFrame(copy, False)  # the inertia is already in the joint's body
    for name in _NV_FIELDS + _NQ_FIELDS:
        old, out = np.asarray(getattr(model, name)), np.asarray(getattr(new, name)).copy()
        for j in range(1, model.njoints):
            a, b = model.joints[j], new.joints[jmap[j]]
            if name not in _NQ_FIELDS:
                out[b.idx_v : b.idx_v + b.nv] = old[a.idx_v : a.idx_v + a.nv]
            elif kinds[j] in axes or kinds[j] == unaligned:
                out[b.idx_q] = {"lowerPositionLimit": -np.inf, "upperPositionLimit": np.inf}.get(
                    name, 0.0
                )
            else:
                out[b.idx_q : b.idx_q + b.nq] = old[a.idx_q : a.idx_q + a.nq]
        setattr(new, name, out)
    new.gravity = model.gravity
    return new, rebuilt

import numpy as np, pinocchio as pin

_AXIS = {"JointModelRUBX": pin.JointModelRX, "JointModelRUBY": pin.JointModelRY, "JointModelRUBZ": pin.JointModelRZ}
_NV_FIELDS = ("effortLimit", "lowerEffortLimit", "upperEffortLimit", "velocityLimit", "lowerVelocityLimit",
              "damping", "friction", "lowerDryFrictionLimit", "upperDryFrictionLimit", "armature",
              "rotorInertia", "rotorGearRatio")
_NQ_FIELDS = ("lowerPositionLimit", "upperPositionLimit", "positionLimitMargin")

def bounded_revolutes(model):
    kinds = [model.joints[j].shortname() for j in range(model.njoints)]
    unbounded = {"JointModelRUBX", "JointModelRUBY", "JointModelRUBZ", "JointModelRevoluteUnboundedUnaligned"}
    if not unbounded & set(kinds):
        return model
    new = pin.Model()
    new.name = model.name
    jmap = {0: 0}
    for j in range(1, model.njoints):
        jm = model.joints[j]
        if kinds[j] in _AXIS:
            jm = _AXIS[kinds[j]]()
        elif kinds[j] == "JointModelRevoluteUnboundedUnaligned":
            jm = pin.JointModelRevoluteUnaligned(np.asarray(jm.getMotionAxis()))
        jmap[j] = new.addJoint(jmap[model.parents[j]], jm, model.jointPlacements[j], model.names[j])
        new.appendBodyToJoint(jmap[j], model.inertias[j], pin.SE3.Identity())
    new.inertias[0] = model.inertias[0].copy()
    fmap = {0: 0}
    for i in range(1, model.nframes):
        f = model.frames[i]
        g = pin.Frame(f.name, jmap[f.parentJoint], fmap[f.parentFrame], f.placement, f.type, f.inertia)
        fmap[i] = new.addFrame(g, False)
    for field in _NV_FIELDS:
        old, out = np.asarray(getattr(model, field)), np.asarray(getattr(new, field)).copy()
        for j in range(1, model.njoints):
            a, b = model.joints[j], new.joints[jmap[j]]
            out[b.idx_v:b.idx_v + b.nv] = old[a.idx_v:a.idx_v + a.nv]
        setattr(new, field, out)
    for field in _NQ_FIELDS:
        old, out = np.asarray(getattr(model, field)), np.asarray(getattr(new, field)).copy()
        for j in range(1, model.njoints):
            a, b = model.joints[j], new.joints[jmap[j]]
            if kinds[j] in unbounded:
                out[b.idx_q] = {"lowerPositionLimit": -np.inf, "upperPositionLimit": np.inf}.get(field, 0.0)
            else:
                out[b.idx_q:b.idx_q + b.nq] = old[a.idx_q:a.idx_q + a.nq]
        setattr(new, field, out)
    new.gravity = model.gravity
    return new

"""The arm's numbers against MuJoCo's model of the whole robot, the held joints at rest.

An independent check of holding: MuJoCo's full model (every joint free) at the rest
configuration with the arm's values put in, its Jacobian, mass matrix and gravity read at the
arm's dofs (rows and columns selected), against the arm's reduced models in both engines.
"""

from __future__ import annotations

import mujoco
import numpy as np

import redundancy as rd


def full_model_quantities(arm: rd.Arm, q: np.ndarray) -> dict[str, np.ndarray]:
    """Site Jacobian (6 x n), mass matrix (n x n) and gravity (n) of the whole robot's model."""
    m = arm.robot_model
    d = mujoco.MjData(m)
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(m.njnt)]
    d.qpos[:] = m.qpos0
    for name, value in arm.held.items():
        j = names.index(name)
        adr = m.jnt_qposadr[j]
        d.qpos[adr : adr + np.size(value)] = value
    ids = [names.index(n) for n in arm.joint_names]
    for j, value in zip(ids, q, strict=True):
        d.qpos[m.jnt_qposadr[j]] = value
    dofs = [int(m.jnt_dofadr[j]) for j in ids]
    mujoco.mj_forward(m, d)
    jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, arm.site)
    mujoco.mj_jacSite(m, d, jp, jr, sid)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    d.qvel[:] = 0
    mujoco.mj_forward(m, d)
    return {
        "jacobian": np.vstack([jp, jr])[:, dofs],
        "mass matrix": M[np.ix_(dofs, dofs)],
        "gravity": d.qfrc_bias[dofs].copy(),
        "site position": d.site_xpos[sid].copy(),
    }


def largest_difference_to_full_model(arm: rd.Arm, q: np.ndarray) -> float:
    """Largest |arm - full| / max(1, scale) over J, M, gravity and the site, both engines."""
    full = full_model_quantities(arm, q)
    worst = 0.0
    for engine in rd.arm.ENGINES:
        ours = {
            "jacobian": arm.jacobian(q, engine),
            "mass matrix": arm.mass_matrix(q, engine=engine),
            "gravity": arm.gravity(q, engine),
            "site position": arm.site_pose(q, engine)[0],
        }
        for key, value in ours.items():
            scale = max(1.0, float(np.max(np.abs(full[key]))))
            worst = max(worst, float(np.max(np.abs(value - full[key]))) / scale)
    return worst

"""Scratch: write models/*.urdf from the bundled MJCF (source strings for inertials)."""
import sys, xml.etree.ElementTree as ET
import mujoco, numpy as np

def rpy_of_quat(q):
    w, x, y, z = q
    R = np.array(mujoco.mju_quat2Mat  if False else [0]*9, float)
    mat = np.zeros(9); mujoco.mju_quat2Mat(mat, np.asarray(q, float)); R = mat.reshape(3, 3)
    # URDF rpy: R = Rz(y) Ry(p) Rx(r)
    p = np.arcsin(-R[2, 0]); r = np.arctan2(R[2, 1], R[2, 2]); yw = np.arctan2(R[1, 0], R[0, 0])
    return r, p, yw

def f(x):
    x = float(x)
    s = "0" if x == 0 else repr(x)
    return s[:-2] if s.endswith(".0") else s

def vec(v):
    return " ".join(f(x) for x in v)

def main(src, dst, tool, base_name, velocity, comment):
    root = ET.parse(src).getroot()
    inertials = {b.get("name"): b.find("inertial") for b in root.iter("body")}
    m = mujoco.MjModel.from_xml_path(src)
    from redundancy.mujoco_engine import joint_force_limits
    eff = joint_force_limits(m)
    name = lambda o, i: mujoco.mj_id2name(m, o, i)
    out = [f'<?xml version="1.0"?>', comment, f'<robot name="{root.get("model")}">']
    def link(b):
        bn = name(mujoco.mjtObj.mjOBJ_BODY, b)
        out.append(f'  <link name="{bn}">')
        el = inertials.get(bn)
        if el is not None:
            out.append(f'    <inertial>')
            out.append(f'      <origin xyz="{el.get("pos")}" rpy="0 0 0"/>')
            out.append(f'      <mass value="{el.get("mass")}"/>')
            if el.get("fullinertia"):
                xx, yy, zz, xy, xz, yz = el.get("fullinertia").split()
            else:
                xx, yy, zz = el.get("diaginertia").split(); xy = xz = yz = "0"
            out.append(f'      <inertia ixx="{xx}" iyy="{yy}" izz="{zz}" ixy="{xy}" ixz="{xz}" iyz="{yz}"/>')
            out.append(f'    </inertial>')
        for g in range(m.ngeom):
            if m.geom_bodyid[g] != b or m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0:
                continue
            gt = m.geom_type[g]; size = m.geom_size[g]; pos = m.geom_pos[g]; quat = m.geom_quat[g]
            mat = np.zeros(9); mujoco.mju_quat2Mat(mat, quat); R = mat.reshape(3, 3)
            def col(xyz, q, geom):
                r = rpy_of_quat(q)
                out.append(f'    <collision>')
                out.append(f'      <origin xyz="{vec(np.round(xyz, 12))}" rpy="{vec(r)}"/>')
                out.append(f'      <geometry>{geom}</geometry>')
                out.append(f'    </collision>')
            if gt == mujoco.mjtGeom.mjGEOM_CYLINDER:
                col(pos, quat, f'<cylinder radius="{f(size[0])}" length="{f(round(2*size[1], 12))}"/>')
            elif gt == mujoco.mjtGeom.mjGEOM_CAPSULE:
                col(pos, quat, f'<cylinder radius="{f(size[0])}" length="{f(round(2*size[1], 12))}"/>')
                for s in (-1, 1):
                    col(pos + s * size[1] * R[:, 2], [1, 0, 0, 0], f'<sphere radius="{f(size[0])}"/>')
            elif gt == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
                out.append(f'    <!-- ellipsoid {vec(size)} (URDF has none): a cylinder of its mean radius and its length -->')
                col(pos, quat, f'<cylinder radius="{f(round((size[0]+size[1])/2, 4))}" length="{f(round(2*size[2], 12))}"/>')
            else:
                raise SystemExit(f"geom type {gt}")
        out.append(f'  </link>')
    def walk(b):
        for c in range(1, m.nbody):
            if m.body_parentid[c] != b: continue
            cn = name(mujoco.mjtObj.mjOBJ_BODY, c)
            if b == 0 and not base_name:
                link(c); walk(c); continue
            pn = name(mujoco.mjtObj.mjOBJ_BODY, b) if b else base_name
            j = m.body_jntadr[c]
            rpy = rpy_of_quat(m.body_quat[c])
            if j < 0:
                jt = "fixed"; jn = f"{pn}_{cn}"
            else:
                jn = name(mujoco.mjtObj.mjOBJ_JOINT, j)
                jt = "revolute" if m.jnt_limited[j] else "continuous"
            out.append(f'  <joint name="{jn}" type="{jt}">')
            out.append(f'    <parent link="{pn}"/>')
            out.append(f'    <child link="{cn}"/>')
            out.append(f'    <origin xyz="{vec(m.body_pos[c])}" rpy="{vec(rpy)}"/>')
            if j >= 0:
                out.append(f'    <axis xyz="{vec(m.jnt_axis[j])}"/>')
                lo, hi = m.jnt_range[j]
                out.append(f'    <limit lower="{f(lo)}" upper="{f(hi)}" effort="{f(eff[j])}" velocity="{velocity[j]}"/>')
                out.append(f'    <dynamics damping="{f(m.dof_damping[j])}" friction="0"/>')
            out.append(f'  </joint>')
            link(c)
            walk(c)
    if base_name:
        out.append(f'  <link name="{base_name}"/>')
    walk(0)
    # the tool site as a fixed link
    s = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, tool)
    pb = name(mujoco.mjtObj.mjOBJ_BODY, m.site_bodyid[s])
    out.append(f'  <joint name="{pb}_{tool}" type="fixed">')
    out.append(f'    <parent link="{pb}"/>')
    out.append(f'    <child link="{tool}"/>')
    out.append(f'    <origin xyz="{vec(m.site_pos[s])}" rpy="{vec(rpy_of_quat(m.site_quat[s]))}"/>')
    out.append(f'  </joint>')
    out.append(f'  <link name="{tool}"/>')
    out.append('</robot>')
    open(dst, "w").write("\n".join(out) + "\n")

A7 = """<!--
  arm7 as URDF: the same robot as arm7.xml (lesson 5.2's 7-DOF arm), written for the library's
  URDF tests and for `redundancy compare models/arm7.urdf models/arm7.xml`.
  * Links, joint origins, axes, ranges, masses, centres of mass and inertias: arm7.xml's numbers
    (every body frame of arm7.xml is parallel to the world at the zero pose).
  * effort: the motor limits of arm7.xml's actuators (ctrlrange x gear) [N m]; damping [N m s/rad].
  * velocity: URDF requires it; arm7.xml has none, so 2.0 rad/s is a placeholder (not read by
    the library).
  * Not expressible in URDF, so absent here: armature (0.05 kg m^2 per joint in arm7.xml),
    keyframes, the visual geoms' colours. Collision geoms: each capsule is a cylinder plus two
    end spheres (the same volume); link2's ellipsoid has no URDF primitive, so it is a cylinder
    (mean radius of its cross-section, same length): self-contact counts differ from arm7.xml.
  * "ee": the tool frame as a fixed link (arm7.xml's site).
-->"""
PA = """<!--
  panda as URDF: the same robot as panda.xml (Franka Emika Panda, no gripper), written for the
  library's URDF tests and for `redundancy compare models/panda.urdf models/panda.xml`.
  * Every number is panda.xml's (see its header for the sources): joint origins (Franka's
    modified-DH table, body rotations as rpy), ranges, effort (tau_max) [N m], damping
    [N m s/rad], masses, centres of mass and inertia tensors (about the centre of mass, link
    axes).
  * velocity: Franka's published joint velocity limits (2.175 rad/s joints 1-4, 2.61 rad/s
    joints 5-7); panda.xml has none; the library does not read them.
  * Not expressible in URDF, so absent here: armature (panda.xml's reflected rotor inertias),
    the home keyframe, the <contact><exclude> of link0/link1 (adjacent links; the library
    excludes adjacent links of a URDF itself). Collision capsules are cylinders plus two end
    spheres (the same volume).
  * "ee": the flange frame as a fixed link (panda.xml's site).
-->"""
if __name__ == "__main__":
    main("../models/arm7.xml", "../models/arm7.urdf", "ee", "base", ["2.0"]*7, A7)
    main("../models/panda.xml", "../models/panda.urdf", "ee", "", ["2.175"]*4 + ["2.61"]*3, PA)

"""A corpus of real-arm-style MJCF models, written for this project, with their mesh files.

Each model is written the way MuJoCo Menagerie writes arms (default classes applied with
``childclass``, visual and collision geoms in their own classes, servos, a ``home`` keyframe),
from the manufacturers' published figures; the files are new. Mesh files are generated here
(convex prisms around each link, as Wavefront OBJ for visual geoms and binary STL for
collision geoms, plus inline-vertex meshes) and written with the model into a directory the
caller gives (a pytest ``tmp_path``): nothing is downloaded.

Why in ``tests/`` and not in the package: the models exist to exercise the loader, the
equivalence report, the cross-check, collision and the audit on published-style input; they
need generated mesh files on disk, which a wheel should not carry. ``python -m tests.corpus
DIR`` writes them out for the benchmark or a manual ``redundancy audit``.

Sources, per model (the figures each model uses, and where they come from):

* ``fr3``, Franka Research 3 (7 DOF). Kinematics: Franka's modified-DH table ("Robot and
  interface specifications", frankaemika.github.io/docs/control_parameters.html: d1 0.333,
  d3 0.316, a4 0.0825, a5 -0.0825, d5 0.384, a7 0.088, flange 0.107 m). Joint ranges and
  torque limits (87 N m on joints 1-4, 12 N m on 5-7): the same page, "Limits for Franka
  Research 3". Masses, centres of mass and principal inertias: Franka's franka_description
  FR3 URDF (the figures Menagerie's franka_fr3/fr3.xml carries). Servo gains (kp 4500 / 3500
  / 2000, kv = kp / 10), armature, damping and friction loss: Menagerie's fr3.xml.
* ``ur5e``, Universal Robots UR5e (6 DOF). Kinematics: UR's published DH parameters (d1 0.1625,
  a2 -0.425, a3 -0.3922, d4 0.1333, d5 0.0997, d6 0.0996 m) in the body layout of UR's
  ur_description URDF (0.163, 0.138, -0.131, 0.425, 0.392, 0.127, 0.1 m, which the DH table
  folds together). Masses 3.761 / 8.058 / 2.846 / 1.37 / 1.3 / 0.365 kg: UR's "DH parameters
  for calculations of kinematics and dynamics" page; centres of mass on the link centre lines
  as ur_description places them; inertias: uniform solid cylinders of the link's length and
  a radius chosen here (ur_description approximates them the same way, with its own radii).
  Torque limits 150 / 150 / 150 / 28 / 28 / 28 N m: UR's "max joint torques" article.
  Armature 0.1, damping 200 / 15, kp 3500 / 3000: Menagerie's ur5e.xml. The base is rotated
  180 degrees about z as Menagerie's ur5e.xml poses it, and raised 0.02 m here so that the
  posed root has a translation too.
* ``iiwa14``, KUKA LBR iiwa 14 R820 (7 DOF). Kinematics: KUKA's data sheet (0.36 / 0.42 /
  0.40 / 0.126 m between the axes, body split as in KUKA's URDF: 0.1575 + 0.2025, 0.2045 +
  0.2155, 0.1845 + 0.2155, 0.081 + 0.045). Ranges +-170 / 120 / 170 / 120 / 170 / 120 /
  175 deg and torque limits 320 / 320 / 176 / 176 / 110 / 40 / 40 N m: KUKA's specification.
  Masses and inertias: KUKA's iiwa14 URDF (drake's iiwa_description, as Menagerie's
  iiwa14.xml carries them); servo gains (kp 2000, kv 200): Menagerie's iiwa14.xml. Chosen
  here, not published: armature 0.1 kg m^2, damping 0.5 N m s/rad and friction loss 0.2 N m on
  every joint. Collision: 40 spheres laid along each link by this module.

Features, per model: explicit ``<inertial>`` on every moving body; visual meshes (OBJ,
inline vertices) and collision meshes (binary STL) with mass 0 set in default classes
(fr3); nested default classes where a class without a ``<joint>`` element inherits joint
defaults (axis, armature) from its parent (fr3, iiwa14); a posed fixed root (ur5e); position
servos with ``inheritrange`` (fr3) or ``ctrlrange`` and ``forcerange`` (ur5e); affine
``general`` servos (iiwa14); joint ``actuatorfrcrange`` (fr3, iiwa14); ``frictionloss``
(fr3, iiwa14); ``implicitfast`` (fr3, iiwa14); a 6-DOF arm (ur5e); ~40 collision spheres
(iiwa14).
"""

from __future__ import annotations

import math
import struct
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

Vec = tuple[float, float, float]


# ------------------------------------------------------------------------------------------
# Mesh files
# ------------------------------------------------------------------------------------------


def prism(
    start: Sequence[float], end: Sequence[float], radius: float, sides: int = 8
) -> tuple[np.ndarray, np.ndarray]:
    """A closed convex prism around the segment start-end: vertices (n, 3), triangles (m, 3).

    The triangles are wound counter-clockwise seen from outside (outward normals).
    """
    a, b = np.asarray(start, float), np.asarray(end, float)
    axis = b - a
    length = float(np.linalg.norm(axis))
    if length < 1e-9:
        axis, length = np.array([0.0, 0.0, 1.0]), 2 * radius
        a, b = a - axis * radius, a + axis * radius
    axis = axis / np.linalg.norm(axis)
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(axis, helper)
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    ring = [
        radius * (math.cos(2 * math.pi * k / sides) * u + math.sin(2 * math.pi * k / sides) * v)
        for k in range(sides)
    ]
    verts = np.array([a + r for r in ring] + [b + r for r in ring] + [a, b])
    tris: list[tuple[int, int, int]] = []
    ca, cb = 2 * sides, 2 * sides + 1
    for k in range(sides):
        k1 = (k + 1) % sides
        tris += [(k, k1, sides + k1), (k, sides + k1, sides + k)]  # side quad
        tris += [(ca, k1, k), (cb, sides + k, sides + k1)]  # caps
    return verts, np.array(tris, dtype=int)


def write_obj(path: Path, verts: np.ndarray, tris: np.ndarray) -> None:
    """Write a Wavefront OBJ file (1-based face indices)."""
    lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in verts]
    lines += [f"f {i + 1} {j + 1} {k + 1}" for i, j, k in tris]
    path.write_text("\n".join(lines) + "\n")


def write_binary_stl(path: Path, verts: np.ndarray, tris: np.ndarray) -> None:
    """Write a binary STL file: 80-byte header, triangle count, 50 bytes per triangle."""
    out = bytearray(b"redundancy corpus".ljust(80, b" "))
    out += struct.pack("<I", len(tris))
    for i, j, k in tris:
        p, q, r = verts[i], verts[j], verts[k]
        n = np.cross(q - p, r - p)
        n = n / (np.linalg.norm(n) or 1.0)
        out += struct.pack("<12fH", *n, *p, *q, *r, 0)
    path.write_bytes(bytes(out))


def inline_vertices(verts: np.ndarray) -> str:
    """The ``vertex`` attribute of an inline mesh (MuJoCo takes the convex hull)."""
    return " ".join(f"{x:.6f}" for x in verts.ravel())


# ------------------------------------------------------------------------------------------
# Models
# ------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CorpusModel:
    """One corpus model: its name, tool site, joint count and a writer for its files.

    Attributes:
        name: Model name, also the XML file's stem.
        site: Tool site.
        nq: Number of joints.
        home: Keyframe holding the arm's home pose.
        description: One line: which arm and which features.
    """

    name: str
    site: str
    nq: int
    home: str
    description: str
    _write: Callable[[Path], str]

    def write(self, directory: Path) -> Path:
        """Write the XML and its mesh files into ``directory``; return the XML's path."""
        directory.mkdir(parents=True, exist_ok=True)
        text = self._write(directory)
        path = directory / f"{self.name}.xml"
        path.write_text(text)
        return path


def _v(x: Sequence[float]) -> str:
    return " ".join(f"{float(c):g}" for c in x)


# -- Franka Research 3 ------------------------------------------------------------------------

#: (body, parent-frame pos, quat, inertial pos, inertial quat, mass, diaginertia, child offset)
#: Inertials: Franka's franka_description FR3 URDF. Kinematics: Franka's DH table.
_FR3_LINKS = (
    (
        "fr3_link1",
        (0, 0, 0.333),
        (1, 0, 0, 0),
        (4.128e-07, -0.0181251, -0.0386036),
        (0.998098, -0.0605364, 0.00380499, 0.0110109),
        2.92747,
        (0.0239286, 0.0227246, 0.00610634),
        (0, 0, 0),
    ),
    (
        "fr3_link2",
        (0, 0, 0),
        (1, -1, 0, 0),
        (0.00318289, -0.0743222, 0.00881461),
        (0.502599, 0.584437, -0.465998, 0.434366),
        2.93554,
        (0.0629567, 0.0411924, 0.0246371),
        (0, -0.316, 0),
    ),
    (
        "fr3_link3",
        (0, -0.316, 0),
        (1, 1, 0, 0),
        (0.0407016, -0.00482006, -0.0289731),
        (0.921025, -0.244161, 0.155272, 0.260745),
        2.2449,
        (0.0267409, 0.0189869, 0.0171587),
        (0.0825, 0, 0),
    ),
    (
        "fr3_link4",
        (0.0825, 0, 0),
        (1, 1, 0, 0),
        (-0.0459101, 0.0630493, -0.00851879),
        (0.438018, 0.803311, 0.00937812, 0.403414),
        2.6156,
        (0.05139, 0.0372717, 0.0160047),
        (-0.0825, 0.384, 0),
    ),
    (
        "fr3_link5",
        (-0.0825, 0.384, 0),
        (1, -1, 0, 0),
        (-0.00160396, 0.0292536, -0.0972966),
        (0.919031, 0.125604, 0.0751531, -0.366003),
        2.32712,
        (0.0579335, 0.0449144, 0.0130634),
        (0, 0, -0.2),
    ),
    (
        "fr3_link6",
        (0, 0, 0),
        (1, 1, 0, 0),
        (0.0597131, -0.0410295, -0.0101693),
        (0.621301, 0.552665, 0.510011, 0.220081),
        1.81704,
        (0.0175039, 0.0161123, 0.00193529),
        (0.088, 0, 0),
    ),
    (
        "fr3_link7",
        (0.088, 0, 0),
        (1, 1, 0, 0),
        (0.00452258, 0.00862619, -0.0161633),
        (0.727579, 0.0978688, -0.24906, 0.63168),
        0.627143,
        (0.000223836, 0.000223642, 5.64132e-07),
        (0, 0, 0.107),
    ),
)
#: Franka's "Limits for Franka Research 3" [rad] and tau_max [N m].
_FR3_RANGES = (
    (-2.9007, 2.9007),
    (-1.8361, 1.8361),
    (-2.9007, 2.9007),
    (-3.0770, -0.1169),
    (-2.8763, 2.8763),
    (0.4398, 4.6216),
    (-3.0508, 3.0508),
)
_FR3_TORQUE = (87, 87, 87, 87, 12, 12, 12)
#: Joint class per joint (shoulder / elbow carry no <joint>: axis and armature come from fr3).
_FR3_CLASS = ("shoulder", "shoulder", "elbow", "elbow", "wrist", "wrist", "wrist")
_FR3_FRICTION = (1.137, 1.137, 1.137, 1.137, 0.763, 0.44, 0.248)
#: Collision prism per link (start and end of its axis in the link frame [m], radius [m]),
#: chosen here along Franka's DH geometry: link1 the shoulder column, link2 and link3 the
#: two halves of the upper arm (link3's frame sits at the elbow's height), link4 the elbow
#: housing, link5 the forearm (the elbow is at (0.0825, 0, -0.384) in its frame), link6 the
#: wrist, link7 the flange. Non-neighbouring prisms stay apart at the home keyframe.
_FR3_COLLISION = {
    "link1": ((0, 0, -0.18), (0, 0, 0), 0.065),
    "link2": ((0, -0.02, 0), (0, -0.15, 0), 0.06),
    "link3": ((0, 0, -0.16), (0, 0, -0.02), 0.06),
    "link4": ((0, 0, 0), (-0.025, 0.115, 0), 0.055),
    "link5": ((0.0536, 0, -0.2496), (0.0124, 0, -0.0576), 0.05),
    "link6": ((0, 0, 0), (0.088, 0, 0), 0.05),
    "link7": ((0, 0, 0), (0, 0, 0.107), 0.045),
}


def _write_fr3(directory: Path) -> str:
    assets = directory / "fr3_assets"
    assets.mkdir(exist_ok=True)
    mesh_lines = []
    # link0 (the fixed base): an inline-vertex visual mesh and an STL collision mesh.
    base_v, base_t = prism((0, 0, 0), (0, 0, 0.25), 0.09, sides=10)
    write_binary_stl(assets / "link0.stl", base_v, base_t)
    mesh_lines.append(f'<mesh name="link0_visual" vertex="{inline_vertices(base_v)}"/>')
    mesh_lines.append('<mesh name="link0_coll" file="link0.stl"/>')
    for name, *_rest, child in _FR3_LINKS:
        stem = name.removeprefix("fr3_")
        verts, tris = prism((0, 0, 0), child, 0.06, sides=12)
        write_obj(assets / f"{stem}.obj", verts, tris)
        start, end, radius = _FR3_COLLISION[stem]
        cverts, ctris = prism(start, end, radius, sides=6)
        write_binary_stl(assets / f"{stem}.stl", cverts, ctris)
        mesh_lines.append(f'<mesh file="{stem}.obj"/>')
        mesh_lines.append(f'<mesh name="{stem}_coll" file="{stem}.stl"/>')

    body = ""
    close = ""
    for i, (name, pos, quat, ipos, iquat, mass, diag, _child) in enumerate(_FR3_LINKS):
        stem = name.removeprefix("fr3_")
        lo, hi = _FR3_RANGES[i]
        joint_extra = f' frictionloss="{_FR3_FRICTION[i]}"' if _FR3_FRICTION[i] != 1.137 else ""
        body += f"""
        <body name="{name}" pos="{_v(pos)}" quat="{_v(quat)}">
          <inertial pos="{_v(ipos)}" quat="{_v(iquat)}" mass="{mass}" diaginertia="{_v(diag)}"/>
          <joint name="fr3_joint{i + 1}" class="{_FR3_CLASS[i]}" range="{lo} {hi}"
            actuatorfrcrange="{-_FR3_TORQUE[i]} {_FR3_TORQUE[i]}"{joint_extra}/>
          <geom mesh="{stem}" class="visual"/>
          <geom name="{name}_collision" mesh="{stem}_coll" class="collision"/>"""
        close = "\n        </body>" + close
    actuators = "\n".join(
        f'    <position class="{_FR3_CLASS[i]}" name="fr3_joint{i + 1}" joint="fr3_joint{i + 1}"/>'
        for i in range(7)
    )
    return f"""<mujoco model="fr3">
  <!-- Franka Research 3, written for the redundancy corpus (sources: tests/corpus.py). -->
  <compiler angle="radian" meshdir="fr3_assets" autolimits="true"/>
  <option integrator="implicitfast"/>
  <default>
    <default class="fr3">
      <joint axis="0 0 1" damping="0.21" armature="0.195" frictionloss="1.137"/>
      <position inheritrange="1"/>
      <site size="0.001" group="4"/>
      <!-- No <joint> here: axis, armature, damping and friction loss come from fr3. -->
      <default class="shoulder">
        <position kp="4500" kv="450"/>
      </default>
      <default class="elbow">
        <position kp="3500" kv="350"/>
      </default>
      <default class="wrist">
        <joint armature="0.074"/>
        <position kp="2000" kv="200"/>
      </default>
      <default class="visual">
        <geom type="mesh" group="2" contype="0" conaffinity="0" mass="0"/>
      </default>
      <default class="collision">
        <geom type="mesh" group="3" mass="0" density="0"/>
      </default>
    </default>
  </default>
  <asset>
    {chr(10).join("    " + m for m in mesh_lines).strip()}
  </asset>
  <worldbody>
    <body name="base" childclass="fr3">
      <body name="fr3_link0">
        <geom mesh="link0_visual" class="visual"/>
        <geom name="fr3_link0_collision" mesh="link0_coll" class="collision"/>{body}
          <site name="attachment_site" pos="0 0 0.107"/>{close}
      </body>
    </body>
  </worldbody>
  <contact>
    <!-- Neighbours overlap at their shared joint by construction. -->
    <exclude body1="fr3_link0" body2="fr3_link1"/>
  </contact>
  <actuator>
{actuators}
  </actuator>
  <keyframe>
    <key name="home" qpos="0 0 0 -1.57079 0 1.57079 -0.7853"
      ctrl="0 0 0 -1.57079 0 1.57079 -0.7853"/>
  </keyframe>
</mujoco>
"""


# -- Universal Robots UR5e --------------------------------------------------------------------

#: (body, pos, quat, mass, com, cylinder radius, cylinder length, joint axis, class, child,
#: joint name).
#: Masses and centres of mass: UR's published dynamics table; kinematics: UR's DH
#: parameters in ur_description's body layout.
_UR5E_LINKS = (
    ("shoulder_link", (0, 0, 0.163), (1, 0, 0, 0), 3.761, (0, 0, 0), 0.06, 0.15, "0 0 1",
     "size3", (0, 0.138, 0), "shoulder_pan_joint"),
    ("upper_arm_link", (0, 0.138, 0), (1, 0, 1, 0), 8.058, (0, 0, 0.2125), 0.054, 0.425, None,
     "size3", (0, -0.131, 0.425), "shoulder_lift_joint"),
    ("forearm_link", (0, -0.131, 0.425), (1, 0, 0, 0), 2.846, (0, 0, 0.196), 0.06, 0.392, None,
     "size3_limited", (0, 0, 0.392), "elbow_joint"),
    ("wrist_1_link", (0, 0, 0.392), (1, 0, 1, 0), 1.37, (0, 0.127, 0), 0.06, 0.12, None,
     "size1", (0, 0.127, 0), "wrist_1_joint"),
    ("wrist_2_link", (0, 0.127, 0), (1, 0, 0, 0), 1.3, (0, 0, 0.1), 0.06, 0.12, "0 0 1",
     "size1", (0, 0, 0.1), "wrist_2_joint"),
    ("wrist_3_link", (0, 0, 0.1), (1, 0, 0, 0), 0.365, (0, 0.0771683, 0), 0.0375, 0.0345, None,
     "size1", (0, 0.1, 0), "wrist_3_joint"),
)  # fmt: skip


def _cylinder_inertia(mass: float, radius: float, length: float) -> Vec:
    """Principal inertia of a uniform solid cylinder along z [kg m^2]."""
    ixx = mass * (3 * radius**2 + length**2) / 12
    return (ixx, ixx, mass * radius**2 / 2)


def _write_ur5e(directory: Path) -> str:
    assets = directory / "ur5e_assets"
    assets.mkdir(exist_ok=True)
    meshes = []
    base_v, base_t = prism((0, 0, 0), (0, 0, 0.09), 0.075, sides=16)
    write_obj(assets / "base.obj", base_v, base_t)
    meshes.append('<mesh file="base.obj"/>')
    body, close = "", ""
    for name, pos, quat, mass, com, radius, length, axis, klass, child, joint in _UR5E_LINKS:
        verts, _tris = prism((0, 0, 0), child, radius, sides=12)
        meshes.append(f'<mesh name="{name}_visual" vertex="{inline_vertices(verts)}"/>')
        diag = _cylinder_inertia(mass, radius, length)
        axis_attr = f' axis="{axis}"' if axis else ""
        seg = np.asarray(child, float)
        half = float(np.linalg.norm(seg)) / 2
        collision = (
            f'<geom class="collision" fromto="0 0 0 {_v(seg)}" size="{radius * 0.8:g}"/>'
            if half > 0.03
            else f'<geom class="collision" type="sphere" size="{radius:g}"/>'
        )
        body += f"""
      <body name="{name}" pos="{_v(pos)}" quat="{_v(quat)}">
        <inertial mass="{mass}" pos="{_v(com)}" diaginertia="{_v(diag)}"/>
        <joint name="{joint}" class="{klass}"{axis_attr}/>
        <geom mesh="{name}_visual" class="visual"/>
        {collision}"""
        close = "\n      </body>" + close
    names = [link[10] for link in _UR5E_LINKS]
    classes = [link[8] for link in _UR5E_LINKS]
    actuators = "\n".join(
        f'    <position class="{c}" name="{n.removesuffix("_joint")}" joint="{n}"/>'
        for n, c in zip(names, classes, strict=True)
    )
    return f"""<mujoco model="ur5e">
  <!-- Universal Robots UR5e, written for the redundancy corpus (sources: tests/corpus.py). -->
  <compiler angle="radian" meshdir="ur5e_assets" autolimits="true"/>
  <default>
    <joint axis="0 1 0" range="-6.28319 6.28319"/>
    <position ctrlrange="-6.2831 6.2831"/>
    <default class="visual">
      <geom type="mesh" contype="0" conaffinity="0" group="2"/>
    </default>
    <default class="collision">
      <geom type="capsule" group="3"/>
    </default>
    <!-- UR's max joint torques: 150 N m (size 3), 28 N m (size 1). -->
    <default class="size3">
      <joint armature="0.1" damping="200"/>
      <position kp="3500" forcerange="-150 150"/>
      <default class="size3_limited">
        <joint range="-3.1415 3.1415"/>
        <position ctrlrange="-3.1415 3.1415"/>
      </default>
    </default>
    <default class="size1">
      <joint armature="0.1" damping="15"/>
      <position kp="3000" forcerange="-28 28"/>
    </default>
  </default>
  <asset>
    {chr(10).join("    " + m for m in meshes).strip()}
  </asset>
  <worldbody>
    <!-- The posed fixed root: Menagerie's ur5e rotates the base 180 degrees about z. -->
    <body name="base" pos="0 0 0.02" quat="0 0 0 -1">
      <inertial mass="4.0" pos="0 0 0" diaginertia="0.00443333156 0.00443333156 0.0072"/>
      <geom mesh="base" class="visual"/>{body}
        <site name="attachment_site" pos="0 0.1 0" quat="-1 1 0 0"/>{close}
    </body>
  </worldbody>
  <actuator>
{actuators}
  </actuator>
  <keyframe>
    <key name="home" qpos="-1.5708 -1.5708 1.5708 -1.5708 -1.5708 0"
      ctrl="-1.5708 -1.5708 1.5708 -1.5708 -1.5708 0"/>
  </keyframe>
</mujoco>
"""


# -- KUKA LBR iiwa 14 -------------------------------------------------------------------------

#: (body, pos, quat, mass, com, diaginertia, class, segment to the next axis in this frame).
_IIWA_LINKS = (
    ("link1", (0, 0, 0.1575), (1, 0, 0, 0), 5.76, (0, -0.03, 0.12), (0.0333, 0.033, 0.0123),
     "joint1", (0, 0, 0.2025)),
    ("link2", (0, 0, 0.2025), (0, 0, 1, 1), 6.35, (0.0003, 0.059, 0.042),
     (0.0305, 0.0304, 0.011), "joint2", (0, 0.2045, 0)),
    ("link3", (0, 0.2045, 0), (0, 0, 1, 1), 3.5, (0, 0.03, 0.13), (0.025, 0.0238, 0.0076),
     "joint3", (0, 0, 0.2155)),
    ("link4", (0, 0, 0.2155), (1, 1, 0, 0), 3.5, (0, 0.067, 0.034), (0.017, 0.0164, 0.006),
     "joint4", (0, 0.1845, 0)),
    ("link5", (0, 0.1845, 0), (0, 0, 1, 1), 3.5, (0.0001, 0.021, 0.076),
     (0.01, 0.0087, 0.00449), "joint5", (0, 0, 0.2155)),
    ("link6", (0, 0, 0.2155), (1, 1, 0, 0), 1.8, (0, 0.0006, 0.0004),
     (0.0049, 0.0047, 0.0036), "joint6", (0, 0.081, 0)),
    ("link7", (0, 0.081, 0), (0, 0, 1, 1), 1.2, (0, 0, 0.02), (0.001, 0.001, 0.001),
     "joint7", (0, 0, 0.045)),
)  # fmt: skip
#: KUKA LBR iiwa 14 R820: ranges [deg] and maximum torques [N m].
_IIWA_RANGE_DEG = (170, 120, 170, 120, 170, 120, 175)
_IIWA_TORQUE = (320, 320, 176, 176, 110, 40, 40)
#: Collision spheres per body (base and seven links): 40 in all.
_IIWA_SPHERES = (4, 6, 6, 6, 6, 6, 4, 2)
_IIWA_RADII = (0.11, 0.08, 0.075, 0.07, 0.07, 0.06, 0.06, 0.05)


def iiwa14_sphere_count() -> int:
    """Collision spheres of the iiwa14 corpus model."""
    return sum(_IIWA_SPHERES)


def _spheres(segment: Sequence[float], count: int, radius: float, offset: Vec) -> str:
    """``count`` spheres spaced along a segment from the body origin, alternating sides."""
    seg = np.asarray(segment, float)
    out = []
    for k in range(count):
        t = (k + 0.5) / count
        side = (-1) ** k * 0.01
        p = seg * t + np.asarray(offset) * side
        out.append(f'<geom class="collision" size="{radius:g}" pos="{_v(np.round(p, 5))}"/>')
    return "\n          ".join(out)


def _write_iiwa14(directory: Path) -> str:
    del directory  # primitives only
    base = _spheres((0, 0, 0.15), _IIWA_SPHERES[0], _IIWA_RADII[0], (1, 0, 0))
    body, close = "", ""
    for i, (name, pos, quat, mass, com, diag, klass, seg) in enumerate(_IIWA_LINKS):
        spheres = _spheres(seg, _IIWA_SPHERES[i + 1], _IIWA_RADII[i + 1], (1, 0, 0))
        body += f"""
        <body name="{name}" pos="{_v(pos)}" quat="{_v(quat)}">
          <inertial mass="{mass}" pos="{_v(com)}" diaginertia="{_v(diag)}"/>
          <joint name="joint{i + 1}" class="{klass}"/>
          {spheres}"""
        close = "\n        </body>" + close
    classes = "\n".join(
        f"""      <default class="joint{i + 1}">
        <joint range="{-math.radians(d):.6f} {math.radians(d):.6f}"
          actuatorfrcrange="{-t} {t}"/>
        <general ctrlrange="{-math.radians(d):.6f} {math.radians(d):.6f}"/>
      </default>"""
        for i, (d, t) in enumerate(zip(_IIWA_RANGE_DEG, _IIWA_TORQUE, strict=True))
    )
    actuators = "\n".join(
        f'    <general name="actuator{i + 1}" joint="joint{i + 1}" class="joint{i + 1}"/>'
        for i in range(7)
    )
    return f"""<mujoco model="iiwa14">
  <!-- KUKA LBR iiwa 14 R820, written for the redundancy corpus (sources: tests/corpus.py). -->
  <compiler angle="radian" autolimits="true"/>
  <option integrator="implicitfast"/>
  <default>
    <default class="iiwa">
      <joint axis="0 0 1" armature="0.1" damping="0.5" frictionloss="0.2"/>
      <general gaintype="fixed" biastype="affine" gainprm="2000" biasprm="0 -2000 -200"/>
      <site size="0.001" group="4"/>
      <default class="collision">
        <geom type="sphere" group="3"/>
      </default>
{classes}
    </default>
  </default>
  <worldbody>
    <body name="base" childclass="iiwa">
      <inertial mass="5" pos="-0.1 0 0.07" diaginertia="0.05 0.06 0.03"/>
      {base}{body}
          <site name="attachment_site" pos="0 0 0.045"/>{close}
    </body>
  </worldbody>
  <contact>
    <!-- Neighbours overlap at their shared joint by construction. -->
    <exclude body1="base" body2="link1"/>
  </contact>
  <actuator>
{actuators}
  </actuator>
  <keyframe>
    <key name="home" qpos="0 0.785398 0 -1.5708 0 0 0" ctrl="0 0.785398 0 -1.5708 0 0 0"/>
  </keyframe>
</mujoco>
"""


MODELS: dict[str, CorpusModel] = {
    m.name: m
    for m in (
        CorpusModel(
            "fr3",
            "attachment_site",
            7,
            "home",
            "Franka Research 3: OBJ/STL/inline meshes with mass 0 in default classes, "
            "inherited joint defaults, position servos with inheritrange, actuatorfrcrange, "
            "frictionloss, implicitfast",
            _write_fr3,
        ),
        CorpusModel(
            "ur5e",
            "attachment_site",
            6,
            "home",
            "Universal Robots UR5e: 6 DOF, posed fixed root, inline-vertex visual meshes, "
            "position servos with forcerange",
            _write_ur5e,
        ),
        CorpusModel(
            "iiwa14",
            "attachment_site",
            7,
            "home",
            "KUKA LBR iiwa 14: 40 collision spheres, affine general servos, "
            "actuatorfrcrange, frictionloss, implicitfast",
            _write_iiwa14,
        ),
    )
}


def write_all(directory: Path) -> dict[str, Path]:
    """Write every corpus model into ``directory``; model name -> XML path."""
    return {name: m.write(directory) for name, m in MODELS.items()}


if __name__ == "__main__":
    target = Path(sys.argv[1] if len(sys.argv) > 1 else "corpus")
    for name, path in write_all(target).items():
        print(f"{name}: {path}")

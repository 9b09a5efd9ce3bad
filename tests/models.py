"""Tiny inline MJCF models for edge cases (MuJoCo-test style)."""

from __future__ import annotations

from pathlib import Path

#: A 7-joint arm with offsets, rotated bodies, mixed axes, a slide joint and an actuator
#: with its own armature: everything arm7 does not exercise.
SKEW7 = """
<mujoco model="skew7">
  <compiler angle="degree"/>
  <option gravity="0.3 -0.2 -9.7"/>
  <default>
    <joint armature="0.02" damping="0.3"/>
    <geom type="capsule" size="0.03" density="800"/>
  </default>
  <worldbody>
    <body name="b1" pos="0.1 0 0.2" quat="0.9 0.1 0.3 0.2">
      <joint name="q1" axis="0 0.6 0.8" range="-170 170"/>
      <geom fromto="0 0 0 0 0 0.2"/>
      <body name="b2" pos="0 0.05 0.2" euler="30 0 10">
        <joint name="q2" axis="1 0 0" range="-90 90"/>
        <geom fromto="0 0 0 0.25 0 0"/>
        <body name="b3" pos="0.25 0 0" axisangle="0 0 1 40">
          <joint name="q3" type="slide" axis="1 0 0" range="-0.1 0.1"/>
          <geom type="box" size="0.05 0.03 0.02"/>
          <body name="b4" pos="0.1 0 0" xyaxes="0 1 0 -1 0 0">
            <joint name="q4" axis="0 0 1" range="-120 120"/>
            <inertial pos="0.05 0.01 0" mass="0.7" diaginertia="0.004 0.003 0.002"/>
            <geom type="sphere" size="0.04"/>
            <body name="b5" pos="0.1 0 0" zaxis="1 1 0">
              <joint name="q5" axis="0 1 0" range="-100 100"/>
              <geom type="cylinder" fromto="0 0 0 0 0 0.15" size="0.025"/>
              <body name="b6" pos="0 0 0.15">
                <joint name="q6" axis="1 1 1" range="-100 100"/>
                <geom type="ellipsoid" size="0.03 0.04 0.05"/>
                <body name="b7" pos="0 0 0.08">
                  <joint name="q7" axis="0 0 1" range="-170 170"/>
                  <geom type="box" size="0.02 0.02 0.01"/>
                  <site name="tool" pos="0.01 0.02 0.05" euler="10 20 30"/>
                </body>
              </body>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor joint="q1" gear="100" ctrlrange="-1 1" armature="1e-6"/>
    <motor joint="q2" forcerange="-40 40" forcelimited="true"/>
  </actuator>
  <keyframe><key name="bent" qpos="0.3 -0.4 0.05 1.0 -0.6 0.7 0.2"/></keyframe>
</mujoco>
"""


def chain(
    body_extra: str = "", joints: str = '<joint name="a" axis="0 1 0"/>', extra: str = ""
) -> str:
    """A two-link model with hooks for the feature under test."""
    return f"""
<mujoco>
  <worldbody>
    <body name="l1" pos="0 0 0.1">
      {joints}
      <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.04"/>
      <body name="l2" pos="0 0 0.3">
        <joint name="b" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.04"/>
        <site name="tip" pos="0 0 0.3"/>
        {body_extra}
      </body>
    </body>
  </worldbody>
  {extra}
</mujoco>
"""


#: A two-link arm written as files (:func:`write_two_links`): a model that includes a file of
#: defaults and names an OBJ mesh in its mesh folder; ``mass`` is the first link's.
TWO_LINKS = """<mujoco model="two">
  <compiler angle="radian" meshdir="{meshdir}"/>
  <include file="defaults.xml"/>
  <asset><mesh name="block" file="block.obj"/></asset>
  <worldbody>
    <body name="l1">
      <joint name="j1" axis="0 1 0"/>
      <inertial pos="0.25 0 0" mass="{mass}" diaginertia="0.01 0.05 0.05"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.05"/>
      <body name="l2" pos="0.5 0 0">
        <joint name="j2" axis="0 1 0"/>
        <inertial pos="0.2 0 0" mass="1" diaginertia="0.005 0.02 0.02"/>
        <geom type="mesh" mesh="block" mass="0"/>
        <site name="ee" pos="0.4 0 0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
DEFAULTS = '<mujoco><default><joint armature="{armature}"/></default></mujoco>'
#: A box 0.4 m long along x, as OBJ vertices and triangles.
BLOCK = (
    "".join(
        f"v {x} {y} {z}\n"
        for z in (-0.05, 0.05)
        for x, y in ((0, -0.05), (0.4, -0.05), (0.4, 0.05), (0, 0.05))
    )
    + "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n"
)


def write_two_links(folder: Path, meshdir: str = "meshes", mass: float = 2.0) -> Path:
    """The two-link arm as files: the model, an included file, a mesh (in ``meshdir``)."""
    folder.mkdir(parents=True, exist_ok=True)
    mesh_folder = folder / meshdir
    mesh_folder.mkdir(parents=True, exist_ok=True)
    (mesh_folder / "block.obj").write_text(BLOCK)
    (folder / "defaults.xml").write_text(DEFAULTS.format(armature=0.1))
    path = folder / "two.xml"
    path.write_text(TWO_LINKS.format(meshdir=meshdir, mass=mass))
    return path

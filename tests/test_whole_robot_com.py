"""The whole robot's centre of mass, its Jacobian and the centroidal momentum: cross-checked, and
every body that does not move with the arm counted in both engines (mocap bodies included).

Ground truth outside the library: the centre of mass summed by hand from the file's masses, its
Jacobian by central differences of that sum, and raw MuJoCo on the whole file (``subtree_com``,
``mj_jacSubtreeCom`` and ``mj_subtreeVel``'s momentum of the world body's subtree).
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import redundancy as rd

from .models import chain
from .test_quantities import Skewed

# The chain's joints a and b (both about y) to the tip, its capsules of 1000 kg/m^3. Held: the
# finger's slide, at 0. Not moving with the arm: a pedestal welded to the world (a tree
# Pinocchio's parser does not read), a mocap target and a marker welded to it (MuJoCo's weld
# group of the mocap body, not the world's).
INERTIA = 'diaginertia="0.01 0.01 0.01"'
ROBOT = chain(
    body_extra='<body name="finger" pos="0 0.05 0"><joint name="f" type="slide" axis="0 1 0" '
    f'range="0 0.04"/><inertial pos="0 0 0" mass="0.25" {INERTIA}/></body>',
    extra=f"""<worldbody>
    <body name="pedestal" pos="0 0 -0.2"><inertial pos="0 0 0" mass="3" {INERTIA}/></body>
    <body name="target" mocap="true" pos="0.5 0.4 0.3">
      <inertial pos="0 0 0" mass="2" {INERTIA}/>
      <body name="marker" pos="0 0 0.1"><inertial pos="0 0 0" mass="0.1" {INERTIA}/></body>
    </body>
  </worldbody>""",
)
#: Each capsule of the chain: radius 0.04 m, 0.3 m between its ends.
CAPSULE = 1000 * (np.pi * 0.04**2 * 0.3 + 4 / 3 * np.pi * 0.04**3)

ENGINES = ("mujoco", "pinocchio")


def hand_com(q: np.ndarray) -> np.ndarray:
    """The masses of the file placed by hand (the chain swings in the xz plane)."""
    s1, c1, s12, c12 = np.sin(q[0]), np.cos(q[0]), np.sin(q[0] + q[1]), np.cos(q[0] + q[1])
    l2 = np.array([0.3 * s1, 0.0, 0.1 + 0.3 * c1])  # the second body's origin
    parts = (
        (CAPSULE, (0.15 * s1, 0.0, 0.1 + 0.15 * c1)),
        (CAPSULE, l2 + np.array([0.15 * s12, 0.0, 0.15 * c12])),
        (0.25, l2 + np.array([0.0, 0.05, 0.0])),
        (3.0, (0.0, 0.0, -0.2)),
        (2.0, (0.5, 0.4, 0.3)),
        (0.1, (0.5, 0.4, 0.4)),
    )
    return sum(m * np.array(c) for m, c in parts) / sum(m for m, _ in parts)


def raw_mujoco(q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """MuJoCo's whole file at q, v (the finger at 0): centre of mass, its Jacobian, momentum."""
    m = mujoco.MjModel.from_xml_string(ROBOT)
    d = mujoco.MjData(m)
    d.qpos[:2], d.qvel[:2] = q, v
    mujoco.mj_forward(m, d)
    J = np.empty((3, m.nv))
    mujoco.mj_jacSubtreeCom(m, d, J, 0)
    mujoco.mj_subtreeVel(m, d)
    momentum = np.concatenate([m.body_subtreemass[0] * d.subtree_linvel[0], d.subtree_angmom[0]])
    return d.subtree_com[0].copy(), J[:, :2], momentum


POSES = np.array([[0.0, 0.0], [0.3, -0.4], [1.2, 0.9], [-2.5, 2.0]])


@pytest.mark.parametrize("engine", ENGINES)
def test_a_mocap_body_counts_in_the_centre_of_mass_of_both_engines(engine: str) -> None:
    arm = rd.load_string(ROBOT, frame="tip")
    assert arm.joint_names == ("a", "b") and arm.held == {"f": 0.0}
    v = np.array([0.7, -1.3])
    for q in POSES:
        com, J, momentum = raw_mujoco(q, v)
        np.testing.assert_allclose(com, hand_com(q), rtol=0, atol=1e-15)
        h = 1e-6
        fd = np.column_stack(
            [(hand_com(q + h * e) - hand_com(q - h * e)) / (2 * h) for e in np.eye(2)]
        )
        np.testing.assert_allclose(J, fd, rtol=0, atol=1e-10)
        np.testing.assert_allclose(arm.com(q, engine=engine), com, rtol=0, atol=1e-15)
        np.testing.assert_allclose(arm.com_jacobian(q, engine=engine), J, rtol=0, atol=1e-15)
        A = arm.centroidal_momentum_matrix(q, engine=engine)
        np.testing.assert_allclose(A @ v, momentum, rtol=0, atol=1e-14)


def test_the_crosscheck_compares_the_centre_of_mass_and_the_momentum() -> None:
    arm = rd.load_string(ROBOT, frame="tip")
    names = ("centre of mass", "centre of mass jacobian", "centroidal momentum")
    report = rd.crosscheck(arm, POSES)
    assert report.ok
    assert [a.quantity for a in report.agreements][-3:] == list(names)
    for name in names:
        assert report[name].max_error < 1e-14, name
    # Pinocchio's world: the pedestal, the target and its marker (3 + 2 + 0.1 kg).
    (bridge,) = arm.bridges
    assert bridge.quantity == "world mass"
    centre = 3.0 * np.array([0, 0, -0.2]) + 2.0 * np.array([0.5, 0.4, 0.3]) + [0.05, 0.04, 0.04]
    np.testing.assert_allclose(bridge.value, (5.1, *(centre / 5.1)), rtol=0, atol=1e-15)


class _Shifted(Skewed):
    """Pinocchio's numbers with the centre of mass moved 1 mm along x: a disagreement to find."""

    name = "shifted"

    def com(self, q: np.ndarray) -> np.ndarray:
        return self._inner.com(q) + np.array([1e-3, 0.0, 0.0])  # type: ignore[no-any-return]


def test_a_centre_of_mass_that_differs_is_reported() -> None:
    arm = rd.load_string(ROBOT, frame="tip")
    arm.engines["shifted"] = _Shifted(arm.pinocchio)
    report = rd.crosscheck(arm, POSES, ["centre of mass", "centre of mass jacobian"])
    assert not report["centre of mass"].ok
    assert report["centre of mass jacobian"].ok
    # 1 mm against the largest coordinate of the centre of mass, at the pose where that is least.
    least = min(np.max(np.abs(hand_com(q))) for q in POSES)
    assert report["centre of mass"].max_error == pytest.approx(1e-3 / least, rel=1e-9)

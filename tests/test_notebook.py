"""examples/first_day.ipynb runs top to bottom in a fresh kernel and shows what it says:
the cross-check table, the figures, a self-motion and a Dask sweep equal to the serial one."""

from __future__ import annotations

import socket
import tomllib
from collections.abc import Iterator
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")
pytest.importorskip("ipykernel")
pytest.importorskip("distributed")
pytest.importorskip("matplotlib")

NOTEBOOK = Path(__file__).resolve().parents[1] / "examples" / "first_day.ipynb"


@pytest.fixture(scope="module")
def executed() -> Iterator[list]:
    with socket.socket() as s:  # Dask's default status port held, as by a running cluster
        try:
            s.bind(("127.0.0.1", 8787))
            s.listen()
        except OSError:
            pass  # already taken
        yield _execute()


def _execute() -> list:
    nb = nbformat.read(NOTEBOOK, as_version=4)
    client = nbclient.NotebookClient(
        nb,
        timeout=600,
        kernel_name="python3",
        resources={"metadata": {"path": str(NOTEBOOK.parent)}},
    )
    client.execute()  # raises CellExecutionError naming the cell on any error
    return [c for c in nb.cells if c.cell_type == "code"]


def _outputs(cell, mime: str) -> list[str]:
    return [o["data"][mime] for o in cell.outputs if "data" in o and mime in o["data"]]


def _stdout(cell) -> str:
    return "".join(o.get("text", "") for o in cell.outputs if o.get("name") == "stdout")


def test_the_notebook_runs_and_shows_its_results(executed: list) -> None:
    sources = [c.source for c in executed]
    by = {
        key: next(c for c, s in zip(executed, sources, strict=True) if key in s)
        for key in (
            "crosscheck_batch",
            "arm.svd(q0)",
            "manipulability_figure(arm, path",
            "velocity_ellipsoid_figure(arm",
            "selfmotion.self_motion",
            "LocalCluster",
        )
    }
    table = _outputs(by["crosscheck_batch"], "text/html")
    assert len(table) == 1 and "<table>" in table[0]
    assert "CrossCheckReport: ok, 14 quantities over 500 poses" in table[0]
    assert "rank 5 of 6" in _outputs(by["arm.svd(q0)"], "text/html")[0]
    for key in (
        "manipulability_figure(arm, path",
        "velocity_ellipsoid_figure(arm",
        "selfmotion.self_motion",
    ):
        assert len(_outputs(by[key], "image/png")) == 1, key
    assert "tool drift" in _stdout(by["selfmotion.self_motion"])
    assert "bit for bit: True" in _stdout(by["LocalCluster"])
    stderr = [o.get("text", "") for c in executed for o in c.outputs if o.get("name") == "stderr"]
    assert not any("already in use" in s for s in stderr), stderr


def test_the_notebook_extra_installs_what_running_the_notebooks_needs() -> None:
    extras = tomllib.loads((NOTEBOOK.parents[1] / "pyproject.toml").read_text())["project"][
        "optional-dependencies"
    ]

    def names(extra: str) -> set[str]:  # distribution names, through redundancy[...] extras
        out = set()
        for req in extras[extra]:
            name = req.split(">")[0].split("[")[0].split("=")[0].strip()
            if name == "redundancy":
                for inner in req.split("[")[1].split("]")[0].split(","):
                    out |= names(inner.strip())
            else:
                out.add(name)
        return out

    needed = {"nbconvert", "nbclient", "nbformat", "ipykernel"}  # to run one
    needed |= {"example-robot-data", "matplotlib", "dask", "distributed"}  # what it imports
    assert needed <= names("notebook")


def test_the_committed_notebook_has_no_outputs() -> None:
    nb = nbformat.read(NOTEBOOK, as_version=4)
    nbformat.validate(nb)
    assert all(not c.get("outputs") for c in nb.cells if c.cell_type == "code")

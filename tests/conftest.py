"""Shared fixtures. Hypothesis profile: $HYPOTHESIS_PROFILE = redundancy-ci (the default) or
redundancy-thorough (`make test-thorough`); a profile of one's own is left in force."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

import redundancy as rd
from redundancy.testing import register_profiles

from .models import SKEW7

PROFILE = register_profiles(default="redundancy-ci")

#: The arms the core properties run on: the lesson's, the Panda, and the oddities of SKEW7.
ARM_NAMES = ("arm7", "panda", "skew7")

_LOG = pytest.StashKey[dict]()


def pytest_configure(config: pytest.Config) -> None:
    config.stash[_LOG] = {"worst": {}, "examples": {}}


def pytest_report_header(config: pytest.Config) -> str:
    seed = config.getoption("hypothesis_seed", None)
    if PROFILE == "redundancy-ci":
        return f"hypothesis profile: {PROFILE} (derandomized)"
    return f"hypothesis profile: {PROFILE}, seed {seed} (rerun with --hypothesis-seed={seed})"


@pytest.fixture(scope="session")
def arm7() -> rd.Arm:
    return rd.load(rd.model_path("arm7"), frame="ee")


@pytest.fixture(scope="session")
def panda() -> rd.Arm:
    return rd.load(rd.model_path("panda"), frame="ee")


@pytest.fixture(scope="session")
def skew7() -> rd.Arm:
    return rd.load_string(SKEW7, frame="tool")


@pytest.fixture(scope="session")
def arms(arm7: rd.Arm, panda: rd.Arm, skew7: rd.Arm) -> dict[str, rd.Arm]:
    return {"arm7": arm7, "panda": panda, "skew7": skew7}


class EngineLog:
    """Largest engine difference seen per (arm, quantity), printed at the end of the run."""

    def __init__(self, store: dict) -> None:
        self.worst: dict[tuple[str, str], float] = store["worst"]
        self.examples: dict[str, int] = store["examples"]

    def record(self, name: str, report: rd.CrossCheckReport) -> None:
        self.examples[name] = self.examples.get(name, 0) + 1
        for a in report.agreements:
            key = (name, a.quantity)
            self.worst[key] = max(self.worst.get(key, 0.0), a.max_error)


@pytest.fixture(scope="session")
def engine_log(pytestconfig: pytest.Config) -> Iterator[EngineLog]:
    yield EngineLog(pytestconfig.stash[_LOG])


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter) -> None:
    log = EngineLog(terminalreporter.config.stash[_LOG])
    if log.worst:
        tr = terminalreporter
        tr.section("largest engine differences (|MuJoCo - Pinocchio| / the quantity's scale)")
        for name, n in sorted(log.examples.items()):
            row = ", ".join(f"{q} {e:.1e}" for (a, q), e in log.worst.items() if a == name)
            tr.write_line(f"{name} ({n} examples): {row}")


def pytest_sessionfinish(session: pytest.Session) -> None:
    """On an xdist worker, hand its engine log to the controller, which prints the summary."""
    output = getattr(session.config, "workeroutput", None)
    if output is not None:
        log = session.config.stash[_LOG]
        output["engine_log"] = {
            "worst": [[a, q, e] for (a, q), e in log["worst"].items()],
            "examples": dict(log["examples"]),
        }


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node: object, error: object) -> None:
    """Merge a finished xdist worker's engine log into the controller's (largest wins)."""
    sent = getattr(node, "workeroutput", {}).get("engine_log")
    if sent is None:
        return
    log = node.config.stash[_LOG]  # type: ignore[attr-defined]
    for a, q, e in sent["worst"]:
        log["worst"][(a, q)] = max(log["worst"].get((a, q), 0.0), e)
    for name, n in sent["examples"].items():
        log["examples"][name] = log["examples"].get(name, 0) + n

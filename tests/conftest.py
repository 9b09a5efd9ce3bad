"""Shared fixtures. Hypothesis profile: $HYPOTHESIS_PROFILE = default (CI) or thorough."""

from __future__ import annotations

import pytest

import redundancy as rd
from redundancy.testing import register_profiles

PROFILE = register_profiles()


def pytest_report_header(config: pytest.Config) -> str:
    return f"hypothesis profile: {PROFILE}"


@pytest.fixture(scope="session")
def arm7() -> rd.Arm:
    return rd.load(rd.model_path("arm7"), site="ee")


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter) -> None:
    from . import test_core

    if test_core.WORST:
        tr = terminalreporter
        tr.section("largest engine differences (|MuJoCo - Pinocchio| / max(1, |value|))")
        for name, n in sorted(test_core.EXAMPLES.items()):
            row = ", ".join(f"{q} {e:.1e}" for (a, q), e in test_core.WORST.items() if a == name)
            tr.write_line(f"{name} ({n} examples): {row}")

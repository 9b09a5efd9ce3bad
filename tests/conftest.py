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

"""Hypothesis strategies and profiles for property tests of an arm, yours or ours.

Example:
    >>> from hypothesis import given
    >>> import redundancy as rd
    >>> from redundancy.testing import poses
    >>> arm = rd.load(rd.model_path("panda"), frame="ee")
    >>> @given(poses(arm))
    ... def test_engines_agree(q):
    ...     assert rd.crosscheck(arm, q).ok
"""

from __future__ import annotations

import os

import numpy as np

try:
    from hypothesis import HealthCheck, settings
    from hypothesis import strategies as st
except ImportError as _err:  # pragma: no cover - exercised only without the extra
    from .errors import MissingDependencyError

    raise MissingDependencyError("hypothesis", "test") from _err

from .arm import Arm, check_arm, sampling_ranges
from .checks import check_choice, check_number

#: The library's profiles, by name: examples per property. "redundancy-ci" is fast enough
#: for CI and derandomized; "redundancy-thorough" runs >= 1000 examples per property.
PROFILES = {"redundancy-ci": 60, "redundancy-thorough": 1000}


def register_profiles(default: str | None = None) -> str:
    """Register the library's profiles; load one when $HYPOTHESIS_PROFILE (or ``default``) names it.

    The profiles are registered under the library's own names (`PROFILES`), never Hypothesis's
    ``"default"``. A profile name of the user's own (``HYPOTHESIS_PROFILE=ci``, registered by their
    conftest) is left alone: nothing is loaded over it and nothing is refused, so the user's
    settings stay in force.

    Args:
        default: The library profile to load when $HYPOTHESIS_PROFILE is unset (None:
            load none, keep Hypothesis's current profile).

    Returns:
        The name of the profile in force afterwards (Hypothesis's current profile).

    Raises:
        UnknownNameError: ``default`` is not one of `PROFILES`.
    """
    if default is not None:
        check_choice("hypothesis profile", default, tuple(PROFILES))
    common = {
        "deadline": None,  # engines warm up their caches on the first call
        "suppress_health_check": [HealthCheck.too_slow, HealthCheck.differing_executors],
    }
    # The CI profile is derandomized, so a failure there reproduces on any machine; the
    # thorough profile explores with a fresh seed each run (pytest prints it in the header;
    # rerun with --hypothesis-seed=N).
    settings.register_profile(
        "redundancy-ci", max_examples=PROFILES["redundancy-ci"], derandomize=True, **common
    )
    settings.register_profile(
        "redundancy-thorough",
        max_examples=PROFILES["redundancy-thorough"],
        derandomize=False,
        print_blob=True,
        **common,
    )
    name = os.environ.get("HYPOTHESIS_PROFILE") or default
    if name in PROFILES:
        settings.load_profile(name)
    return settings.get_current_profile_name()


def poses(arm: Arm, margin: float = 0.0, unlimited: float = np.pi) -> st.SearchStrategy[np.ndarray]:
    """Joint configurations inside the joint ranges, shape (nq,), float64.

    Each joint is drawn independently, so shrinking moves one joint at a time toward the
    lower limit (or 0 for unlimited joints).

    Args:
        arm: The arm whose ranges to use.
        margin: Keep this far inside each limit [rad or m]: at least 0, at most what leaves
            every joint a range to draw from.
        unlimited: Half-width of the interval used for unlimited joints [rad or m] (hinges as
            [`sampling_ranges`][redundancy.arm.sampling_ranges] draws them; slides too).

    Raises:
        ParameterError: Not an Arm, or ``margin`` or ``unlimited`` not a finite number in
            its range (the message states it).
    """
    arm = check_arm(arm)
    margin = check_number("margin", margin, 0.0, unit="rad or m")
    lo, hi = sampling_ranges(arm, unlimited, unlimited_slide=unlimited)
    ends = np.isfinite(arm.lower).astype(int) + np.isfinite(arm.upper)
    widest = min((float((b - a) / k) for a, b, k in zip(lo, hi, ends, strict=True) if k), default=0)
    if ends.any():
        check_number("margin", margin, 0.0, widest, unit="rad or m")
    lo = np.where(np.isfinite(arm.lower), lo + margin, lo)
    hi = np.where(np.isfinite(arm.upper), np.maximum(hi - margin, lo), hi)
    elements = [
        st.floats(float(a), float(b), allow_nan=False, allow_infinity=False, width=64)
        for a, b in zip(lo, hi, strict=True)
    ]
    return st.tuples(*elements).map(lambda t: np.array(t, dtype=np.float64))


def velocities(arm: Arm, speed: float = 2.0) -> st.SearchStrategy[np.ndarray]:
    """Joint velocities in [-speed, speed] per joint, shape (nq,), float64 [rad/s or m/s].

    Each joint is drawn independently (shrinking toward rest, one joint at a time).

    Raises:
        ParameterError: Not an Arm, or ``speed`` not a finite number >= 0.
    """
    arm = check_arm(arm)
    speed = check_number("speed", speed, 0.0, unit="rad/s or m/s")
    elements = [
        st.floats(-speed, speed, allow_nan=False, allow_infinity=False, width=64)
        for _ in arm.joint_names
    ]
    return st.tuples(*elements).map(lambda t: np.array(t, dtype=np.float64))


def states(
    arm: Arm, margin: float = 0.0, unlimited: float = np.pi, speed: float = 2.0
) -> st.SearchStrategy[tuple[np.ndarray, np.ndarray]]:
    """(pose, velocity) pairs: `poses` and `velocities` drawn together (arguments as theirs)."""
    return st.tuples(poses(arm, margin, unlimited), velocities(arm, speed))


__all__ = ["PROFILES", "poses", "register_profiles", "states", "velocities"]

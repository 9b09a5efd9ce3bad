"""How results show in a notebook and with print, the figure helpers, the hypothesis profiles,
and the small things of a user's first day (top-level names, version, a bundled model by name)."""

from __future__ import annotations

import importlib.metadata
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import redundancy as rd
from redundancy.display import table

ROOT = Path(__file__).resolve().parents[1]


def _run(code: str, **env: str) -> str:
    """Python code in a fresh interpreter (global state: matplotlib's backend, hypothesis's
    profiles); returns its stdout."""
    return _run_env(code, dict(env))


def _run_env(code: str, env: dict[str, str | None]) -> str:
    """:func:`_run` with variables removed (value None) as well as set."""
    full = {k: v for k, v in {**os.environ, **env}.items() if v is not None}
    out = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        env=full,
        cwd=ROOT,
        timeout=120,
    )
    assert out.returncode == 0, out.stderr
    return out.stdout


# -- reports: repr, str, HTML --------------------------------------------------------------------
@pytest.fixture(scope="module")
def reports(arm7: rd.Arm) -> dict[str, object]:
    zero, home = arm7.keyframe("zero"), arm7.keyframe("home")
    return {
        "crosscheck": rd.crosscheck(arm7, np.stack([zero, home])),
        "equivalence": rd.compare_models(arm7),
        "svd": arm7.svd(zero),
        "manipulability": arm7.manipulability(home),
        "comparison": rd.compare(rd.model_path("arm7"), rd.model_path("arm7"), n_poses=5),
    }


def test_reprs_are_one_short_line(reports: dict[str, object]) -> None:
    reprs = {k: repr(v) for k, v in reports.items()}
    assert reprs["crosscheck"] == "<CrossCheckReport: ok, 14 quantities over 2 poses>"
    assert reprs["svd"] == "<JacobianSVD: rank 3 of 6, manipulability 0, condition inf>"
    assert reprs["comparison"] == "<Comparison: same robot: 0 differences, 7 joints matched>"
    assert reprs["equivalence"].startswith("<EquivalenceReport: equivalent, ")
    assert reprs["manipulability"].startswith("<Manipulability: full ")
    for r in reprs.values():
        assert "\n" not in r and len(r) <= 120, r


def test_str_is_the_readable_table(reports: dict[str, object]) -> None:
    for name, report in reports.items():
        assert str(report) == "\n".join(report.lines()), name  # type: ignore[attr-defined]
    text = str(reports["crosscheck"])
    assert text.splitlines()[0].split() == [
        "quantity",
        "max",
        "rel.",
        "diff",
        "tol",
        "over",
        "2",
        "poses",
    ]
    assert "Agreement(" not in text and "np.float64" not in text
    svd = str(reports["svd"]).splitlines()
    assert svd[-1] == "lost tool directions: translation y, translation z, rotation x"


def test_html_tables(reports: dict[str, object]) -> None:
    html = reports["crosscheck"]._repr_html_()  # type: ignore[attr-defined]
    assert html.startswith(
        "<div><p><b>CrossCheckReport: ok, 14 quantities over 2 poses</b></p><table>"
    )
    assert html.count("<tr>") == 1 + 14  # header and one row per quantity
    assert '<td style="text-align:left">mass matrix (bare)</td>' in html
    for name, report in reports.items():
        doc = report._repr_html_()  # type: ignore[attr-defined]
        assert "<table>" in doc and doc.endswith("</div>"), name


def test_html_escapes_every_cell() -> None:
    t = table("a <b> & c", ("x<y",), [["<script>alert(1)</script>"]])
    assert t.html() == (
        "<table><caption>a &lt;b&gt; &amp; c</caption><thead><tr>"
        '<th style="text-align:left">x&lt;y</th></tr></thead><tbody><tr>'
        '<td style="text-align:left">&lt;script&gt;alert(1)&lt;/script&gt;</td></tr></tbody></table>'
    )


def test_manipulability_is_typed_float(arm7: rd.Arm) -> None:
    m = arm7.manipulability(arm7.keyframe("home"), length=0.5)
    assert all(type(getattr(m, k)) is float for k in ("full", "position", "orientation", "scaled"))
    assert (
        rd.Manipulability.full.__doc__
        == "Product of the singular values of the 6 x n J [mixed units]."
    )
    assert m == arm7.manipulability(arm7.keyframe("home"), length=0.5)


# -- figures --------------------------------------------------------------------------------------
def test_figure_helpers_leave_the_backend_and_pyplot_alone() -> None:
    out = _run(
        """
        import json, matplotlib, redundancy as rd
        from redundancy import plotting
        arm = rd.load("arm7")
        fig = plotting.manipulability_figure(arm, rd.random_poses(arm, 20), s=[0.1 * i for i in range(20)])
        ell = plotting.velocity_ellipsoid_figure(arm, arm.keyframe("home"))
        plt = plotting.pyplot()
        print(json.dumps({
            "backend": matplotlib.get_backend(),
            "figures": plt.get_fignums(),
            "types": [type(f).__module__ + "." + type(f).__name__ for f in (fig, ell)],
            "axes": [len(fig.axes), len(ell.axes)],
            "title": fig.axes[0].get_title(),
            "points": len(fig.axes[0].lines[0].get_xdata()),
        }))
        """,
        MPLBACKEND="svg",
    )
    got = json.loads(out)
    assert got == {
        "backend": "svg",
        "figures": [],
        "types": ["matplotlib.figure.Figure"] * 2,
        "axes": [2, 1],
        "title": "ee: manipulability along the path (20 poses)",
        "points": 20,
    }


def test_figure_helpers_check_their_input(arm7: rd.Arm) -> None:
    from redundancy import plotting

    with pytest.raises(
        rd.ParameterError, match=r"^s must be of shape \(3,\), one value per pose, got \(2,\)$"
    ):
        plotting.manipulability_figure(arm7, np.zeros((3, 7)), s=[0.0, 1.0])
    with pytest.raises(rd.UnknownNameError, match="velocity ellipsoid kind"):
        plotting.velocity_ellipsoid_figure(arm7, np.zeros(7), kind="force")
    with pytest.raises(rd.PoseError):
        plotting.velocity_ellipsoid_figure(arm7, np.zeros(3))


# -- hypothesis profiles --------------------------------------------------------------------------
# Hypothesis loads its own "ci" profile (derandomized) at import when it sees a CI service's
# variable ($CI, $GITHUB_ACTIONS, ...), so each case runs twice: with $CI set, and with every
# variable Hypothesis looks for removed. The expectations are the same in both but for what
# Hypothesis itself had in force before the library was imported.
def _ci_env(in_ci: bool) -> dict[str, str | None]:
    from hypothesis._settings import _CI_VARS  # the variables Hypothesis reads, by its own list

    return {"CI": "true"} if in_ci else dict.fromkeys(_CI_VARS)


PROFILE_PROBE = """
    import json, os
    from hypothesis import settings
    before = settings.get_current_profile_name()       # Hypothesis's own choice: default or ci
    settings.register_profile("ci", max_examples=7)   # the user's own, as in their conftest
    user_ci = settings.get_profile("ci")
    if os.environ["HYPOTHESIS_PROFILE"] == "ci":
        settings.load_profile("ci")
    default_before = settings.get_profile("default").max_examples
    from redundancy.testing import register_profiles
    name = register_profiles(default="redundancy-ci")
    print(json.dumps({
        "before": before,
        "name": name,
        "max_examples": settings.default.max_examples,
        "derandomize": settings.default.derandomize,
        "user_ci_derandomize": user_ci.derandomize,
        "default_untouched": settings.get_profile("default").max_examples == default_before,
        "ci_untouched": settings.get_profile("ci").max_examples == 7,
    }))
"""


@pytest.mark.parametrize("in_ci", [False, True], ids=["no CI variables", "CI=true"])
@pytest.mark.parametrize(
    ("env", "expected"),
    [
        ("", ("redundancy-ci", 60, True)),
        ("redundancy-thorough", ("redundancy-thorough", 1000, False)),
        # the user's own profile: neither refused nor replaced; it keeps what it inherited
        # from the profile Hypothesis had in force when the user registered it
        ("ci", ("ci", 7, "user's")),
    ],
)
def test_profiles_under_the_librarys_own_names(env: str, expected: tuple, in_ci: bool) -> None:
    got = json.loads(_run_env(PROFILE_PROBE, {**_ci_env(in_ci), "HYPOTHESIS_PROFILE": env}))
    assert got["before"] == ("ci" if in_ci else "default")
    name, max_examples, derandomize = expected
    if derandomize == "user's":
        derandomize = got["user_ci_derandomize"]
        assert derandomize is in_ci  # Hypothesis's ci profile is derandomized, its default not
    assert (got["name"], got["max_examples"], got["derandomize"]) == (
        name,
        max_examples,
        derandomize,
    )
    assert got["default_untouched"] and got["ci_untouched"]


@pytest.mark.parametrize("in_ci", [False, True], ids=["no CI variables", "CI=true"])
def test_profiles_without_a_default_load_nothing(in_ci: bool) -> None:
    out = _run_env(
        """
        from hypothesis import settings
        before = settings.get_current_profile_name(), settings.default.max_examples
        from redundancy.testing import register_profiles
        print(*before, register_profiles(), settings.default.max_examples)
        """,
        {**_ci_env(in_ci), "HYPOTHESIS_PROFILE": None},
    )
    hypothesis_own = "ci" if in_ci else "default"
    assert out.split() == [hypothesis_own, "100", hypothesis_own, "100"]
    with pytest.raises(rd.UnknownNameError, match="hypothesis profile 'default'"):
        from redundancy.testing import register_profiles

        register_profiles(default="default")


# -- a user's first day: names, version, bundled models ------------------------------------------
def test_top_level_names_and_version() -> None:
    assert rd.__version__ == importlib.metadata.version("redundancy")
    assert rd.random_poses is rd.arm.random_poses
    assert "random_poses" in rd.__all__


def test_a_bundled_model_by_name(panda: rd.Arm) -> None:
    arm = rd.load("panda")
    assert arm.source == str(rd.model_path("panda"))
    assert arm.joint_names == panda.joint_names
    with pytest.raises(rd.ModelError) as err:
        rd.load("pand")
    assert str(err.value) == (
        "model file not found: 'pand'; bundled models (load by name or rd.model_path(name)): "
        "arm7, panda"
    )


def test_a_file_wins_over_a_bundled_name(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from .models import SKEW7

    (tmp_path / "panda.xml").write_text(SKEW7)
    monkeypatch.chdir(tmp_path)
    assert rd.load("panda.xml", frame="tool").source == "panda.xml"


def test_license_is_the_apache_text() -> None:
    text = (ROOT / "LICENSE").read_text()
    assert text.lstrip().startswith(
        "Apache License\n                           Version 2.0, January 2004"
    )
    assert "END OF TERMS AND CONDITIONS" in text
    meta = importlib.metadata.metadata("redundancy")
    assert meta["License"] == "Apache-2.0" or meta["License-Expression"] == "Apache-2.0"

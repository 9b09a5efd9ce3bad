"""The audit's report formats, each a module that turns an `Outcome` into text.

``redundancy audit --format F`` picks one: ``text`` (`text`), ``json`` (`jsondoc`, what a
baseline reads), ``sarif`` (`sarif`, GitHub code scanning), ``junit`` (`junit`, CI test
reports), ``github`` (`github`, workflow annotations), ``markdown`` (`markdown`, a job
summary) and ``html`` (`html_page`, one page). Each takes the results of a whole run
(`results.collect`: a list of model reports, one for one model), so an audit of several
models writes one document. `render` is the one dispatch; importing this package imports no
writer (the command line's parser lists `FORMATS` and `FAIL_ON` from `choices`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from .choices import DEFAULT_FAIL_ON, FAIL_ON, FORMATS, FailOn

if TYPE_CHECKING:
    from .results import Outcome

__all__ = ["DEFAULT_FAIL_ON", "FAIL_ON", "FORMATS", "FailOn", "render"]


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("redundancy")
    except PackageNotFoundError:  # a source tree on sys.path, not installed
        return "unknown"


def render(name: str, outcome: Outcome, quiet: bool = False) -> str:
    """An audit run's results in format ``name``.

    Args:
        name: One of `FORMATS`.
        outcome: The run's results (`collect`).
        quiet: ``text`` only: each model's findings, without the tables.

    Raises:
        ParameterError: ``name`` is none of `FORMATS` (the message lists them).
    """
    from . import github, html_page, jsondoc, junit, markdown, sarif, text

    writers: dict[str, Callable[[Outcome], str]] = {
        "text": lambda o: text.render(o, quiet),
        "json": jsondoc.render,
        "sarif": lambda o: sarif.render(o, _version()),
        "junit": junit.render,
        "github": github.render,
        "markdown": markdown.render,
        "html": html_page.render,
    }
    if name not in writers:
        from ...errors import ParameterError

        raise ParameterError("format", name, f"one of {', '.join(FORMATS)}")
    return writers[name](outcome)

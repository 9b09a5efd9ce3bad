"""``--format html``: the audit as one self-contained web page (no script, no external file).

The page carries what the Markdown report does (`redundancy.reports.formats.markdown`): a
summary table with a row per model, the exit status and why, each model's findings, notes and
known results with their rule, element and line, and its whole text report folded below. It is
rendered by Jinja2 with autoescaping on: every name and message from the model is text, never
markup (a joint named ``<script>`` shows as written).
"""

from __future__ import annotations

from typing import Any

from .markdown import status_line
from .results import ModelResults, Outcome, Result, sections, where
from .text import render as render_text

_TEMPLATE = """\
<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>redundancy audit{% if models|length == 1 %}: {{ models[0].model }}{% endif %}</title>
<style>
body { font-family: system-ui, sans-serif; margin: 2em; color: #222; }
table { border-collapse: collapse; margin: 0.5em 0 1em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }
td.n { text-align: right; }
.error { color: #b00020; font-weight: bold; }
.warning { color: #9a6700; font-weight: bold; }
.note { color: #0550ae; }
pre { background: #f6f8fa; padding: 1em; overflow-x: auto; }
</style>
</head>
<body>
<h1>redundancy audit</h1>
<table>
<tr><th>model</th><th>format</th><th>tool frame</th><th>errors</th><th>warnings</th>\
<th>notes</th><th>known</th></tr>
{% for m in models %}
<tr><td><a href="#model-{{ loop.index }}">{{ m.model }}</a></td><td>{{ m.format }}</td>\
<td>{{ m.frame }}</td><td class="n">{{ m.tally.error }}</td>\
<td class="n">{{ m.tally.warning }}</td>\
<td class="n">{{ m.tally.note }}</td><td class="n">{{ m.tally.known }}</td></tr>
{% endfor %}
</table>
<p>{{ status }}</p>
{% if baseline is not none %}
<p>Baseline <code>{{ baseline }}</code>: its results are known and do not fail.</p>
{% endif %}
{% for m in models %}
<h2 id="model-{{ loop.index }}">{{ m.model }}</h2>
<p>{{ m.format }}, tool frame <code>{{ m.frame }}</code>, {{ m.mode }} mode.</p>
{% for title, rows in m.sections %}
<h3>{{ title }}: {{ rows|length }}</h3>
{% if rows %}
<table>
<tr><th>severity</th><th>rule</th><th>element</th><th>where</th><th>message</th></tr>
{% for r in rows %}
<tr><td class="{{ r.severity }}">{{ r.severity }}</td><td><code>{{ r.rule }}</code></td>\
<td>{{ r.element if r.element is not none else "" }}</td><td>{{ r.where }}</td>\
<td>{{ r.message }}</td></tr>
{% endfor %}
</table>
{% else %}
<p>None.</p>
{% endif %}
{% endfor %}
<details><summary>The whole text report</summary>
<pre>{{ m.text }}</pre>
</details>
{% endfor %}
</body>
</html>
"""


def render(outcome: Outcome) -> str:
    """The HTML page of an audit run.

    Raises:
        MissingDependencyError: Jinja2 is not installed (it is a dependency of the package).
    """
    try:
        import jinja2
    except ImportError as err:  # pragma: no cover - a dependency of the package
        from ...errors import MissingDependencyError

        raise MissingDependencyError(
            "--format html needs Jinja2: pip install 'jinja2>=3.1'"
        ) from err
    env = jinja2.Environment(
        autoescape=True, undefined=jinja2.StrictUndefined, trim_blocks=True, lstrip_blocks=True
    )
    page = env.from_string(_TEMPLATE).render(
        models=[_model(outcome, m) for m in outcome.models],
        status=_plain(status_line(outcome)),
        baseline=outcome.baseline,
    )
    return page


def _plain(markdown: str) -> str:
    """The status line without its Markdown marks (the page escapes it as text)."""
    return markdown.replace("**", "").replace("`", "")


def _model(outcome: Outcome, m: ModelResults) -> dict[str, Any]:
    r = m.report
    return {
        "model": r.model,
        "format": r.model_format,
        "frame": r.frame,
        "mode": r.mode,
        "tally": outcome.tally(m),
        "sections": [(title, [_row(x) for x in rows]) for title, rows in sections(m)],
        "text": render_text(Outcome((m,), outcome.fail_on, None)).rstrip("\n"),
    }


def _row(x: Result) -> dict[str, Any]:
    return {
        "severity": x.severity,
        "rule": x.rule,
        "element": x.element,
        "where": where(x),
        "message": x.message,
    }

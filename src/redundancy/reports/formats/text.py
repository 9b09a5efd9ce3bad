"""``--format text``: the audit's text report, model after model, and what the baseline accepts.

Each model's report is `redundancy.reports.audit_report.format_report`'s (``quiet``: from its
findings on); with a baseline, a last block says which results it accepts as known.
"""

from __future__ import annotations

from ..audit_report import format_report
from ..tables import fit
from .results import ModelResults, Outcome


def render(outcome: Outcome, quiet: bool = False) -> str:
    """The text report of every model, a blank line between two.

    Args:
        outcome: The audit run's results.
        quiet: Only the findings of each model (and the baseline's block).
    """
    parts = ["\n".join(_model_lines(outcome, m, quiet)) for m in outcome.models]
    return "\n\n".join(parts) + "\n"


def _model_lines(outcome: Outcome, m: ModelResults, quiet: bool) -> list[str]:
    lines = format_report(m.report)
    if quiet:  # the findings alone
        lines = lines[next(i for i, x in enumerate(lines) if x.startswith("findings: ")) :]
    if outcome.baseline is None:
        return lines
    known = [r for r in m.results if r.known]
    new = [r for r in m.results if not r.known and r.finding]
    block = [
        "",
        f"baseline {outcome.baseline}: {len(known)} known (accepted: they do not fail), "
        f"{len(new)} new {'finding' if len(new) == 1 else 'findings'}",
        *(f"  known [{r.kind}] {r.message}" for r in known),
    ]
    return lines + fit(block)

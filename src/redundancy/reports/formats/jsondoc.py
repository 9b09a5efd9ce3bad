"""``--format json``: the audit's JSON document, the one ``--json`` writes and a baseline reads.

One model: its report's document (`AuditReport.to_dict`), unchanged. Several:
``{"reports": [...]}``, one document each. With a baseline, each finding and note carries
``accepted`` (true: the baseline knows it) and the document ``baseline``, the file's name.
"""

from __future__ import annotations

from typing import Any

from ...display import to_json
from .results import ModelResults, Outcome


def document(outcome: Outcome) -> Any:
    """The JSON-ready document of an audit run (see the module's description)."""
    docs = [_model_document(outcome, m) for m in outcome.models]
    return docs[0] if len(docs) == 1 else {"reports": docs}


def render(outcome: Outcome) -> str:
    """The document as JSON text (ASCII, infinities and NaN as null), ending with a newline."""
    return to_json(document(outcome)) + "\n"


def _model_document(outcome: Outcome, m: ModelResults) -> dict[str, Any]:
    doc = m.report.to_dict()
    if outcome.baseline is None:
        return doc
    known = iter(r.known for r in m.results)  # findings, then notes: the document's order
    doc["findings"] = [{**f, "accepted": next(known)} for f in doc["findings"]]
    doc["notes"] = [{**n, "accepted": next(known)} for n in doc["notes"]]
    doc["baseline"] = outcome.baseline
    return doc

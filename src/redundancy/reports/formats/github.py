"""``--format github``: GitHub Actions workflow commands, one annotation per result.

Each finding or note the baseline does not accept is one line,
``::error file=F,line=N,title=RULE::MESSAGE`` (``::warning``, and ``::notice`` for a note):
GitHub shows it on the file's line in the pull request and the run's summary. The file and
line are the element's (the model's root element when the result names none). Values are
escaped as GitHub's toolkit escapes them: in the message ``%``, CR and LF; in a property also
``:`` and ``,``. A result the baseline accepts is not annotated.
"""

from __future__ import annotations

from .results import Outcome, Result

#: The workflow command of each severity.
COMMANDS = {"error": "error", "warning": "warning", "note": "notice"}


def escape_data(text: str) -> str:
    """A command's message as GitHub reads it back: ``%``, CR and LF percent-encoded."""
    return text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")


def escape_property(text: str) -> str:
    """A command's property value: as `escape_data`, and ``:`` and ``,`` too."""
    return escape_data(text).replace(":", "%3A").replace(",", "%2C")


def annotation(r: Result) -> str:
    """The workflow command of one result."""
    props = []
    if r.file is not None:
        props.append(f"file={escape_property(r.file)}")
        if r.line is not None:
            props.append(f"line={r.line}")
    props.append(f"title={escape_property(r.rule)}")
    return f"::{COMMANDS[r.severity]} {','.join(props)}::{escape_data(r.message)}"


def render(outcome: Outcome) -> str:
    """One annotation per result the baseline does not accept, model after model."""
    lines = [annotation(r) for m in outcome.models for r in m.results if not r.known]
    return "".join(line + "\n" for line in lines)

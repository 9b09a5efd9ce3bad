"""What the audit reports: findings to act on and notes of what it could not judge, as data.

Each carries the stable id of its rule, a severity and, where it concerns one element of the
file, that element's file, line and name, so that a report can be turned into the formats a CI
reads (SARIF, JUnit, annotations) without parsing its text.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

#: How much a finding matters: ``error`` (the numbers are wrong or unsafe), ``warning`` (likely
#: wrong, worth a look), ``note`` (what the audit could not judge, or assumed).
Severity = Literal["error", "warning", "note"]


@dataclass(frozen=True)
class Finding:
    """Something in the model a user should act on.

    Attributes:
        kind: Category: ``armature``, ``timestep``, ``simulation``, ``gravity``,
            ``keyframe``, ``engines``.
        message: What is wrong and where, with the numbers.
        rule: The stable id of the rule that raised it (empty where none is assigned yet).
        severity: ``error``, ``warning`` or ``note``.
        file: The file holding the element it concerns, if known.
        line: That element's line in ``file`` (1-based), if known.
        element: The element's name (a link, joint, keyframe...), if it concerns one.
    """

    kind: str
    message: str
    rule: str = ""
    severity: Severity = "error"
    file: str | None = None
    line: int | None = None
    element: str | None = None


@dataclass(frozen=True)
class Note:
    """What the audit cannot judge from the file, and what it assumed instead.

    Attributes:
        kind: Category: ``format`` (the file's format cannot express it), ``armature``,
            ``timestep``.
        message: What is missing and what the numbers use in its place.
        rule: The stable id of the rule that raised it (empty where none is assigned yet).
        severity: Always ``note``.
        file: The file holding the element it concerns, if known.
        line: That element's line in ``file`` (1-based), if known.
        element: The element's name, if it concerns one.
    """

    kind: str
    message: str
    rule: str = ""
    severity: Severity = "note"
    file: str | None = None
    line: int | None = None
    element: str | None = None

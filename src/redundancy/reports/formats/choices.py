"""What ``--format`` and ``--fail-on`` offer.

Names only, so that the command line's parser imports nothing heavy to list them.
"""

from __future__ import annotations

from typing import Literal, get_args

#: The formats ``--format`` offers, the default first.
FORMATS = ("text", "json", "sarif", "junit", "github", "markdown", "html")

#: The lowest severity that makes the exit status 1; ``never``: the status is 0 whatever the
#: results (bad input still exits 2).
FailOn = Literal["error", "warning", "note", "never"]
FAIL_ON: tuple[str, ...] = get_args(FailOn)
#: ``--fail-on``'s default, as before the option existed: any finding (an error or a
#: warning) fails, a note never does.
DEFAULT_FAIL_ON: FailOn = "warning"

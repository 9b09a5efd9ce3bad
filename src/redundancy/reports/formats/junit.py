"""``--format junit``: JUnit XML, the test report CI servers draw (GitLab, Jenkins, Actions).

A ``<testsuite>`` per model, named by its file; in it a ``<testcase>`` per rule of the
catalogue (`redundancy.reports.rules.RULES`, the passing ones included), named by the rule's
id; a ``<failure>`` per result that fails the run (`Outcome.counts`: at or above
``--fail-on``, not known to the baseline), typed by its severity, so that the report is red
exactly when the exit status is 1. The results that do not fail (a note under the default
``--fail-on warning``, a finding the baseline accepts) are listed in the test case's
``<system-out>``. The counts (``tests``, ``failures``) are those of the elements.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

from ..rules import RULES
from .results import ModelResults, Outcome, Result

#: Characters XML 1.0 cannot carry (C0 controls but tab and newlines, surrogates, FFFE/FFFF).
_NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")


def _xml_text(text: str) -> str:
    """Text XML can hold: each character it cannot hold written as its Python escape."""
    return _NOT_XML.sub(lambda m: m.group().encode("unicode_escape").decode(), text)


def render(outcome: Outcome) -> str:
    """The JUnit XML document of an audit run, UTF-8, ending with a newline."""
    suites = ET.Element("testsuites", name="redundancy audit")
    total = failed = 0
    for m in outcome.models:
        suite = _suite(outcome, m)
        suites.append(suite)
        total += int(suite.get("tests", "0"))
        failed += int(suite.get("failures", "0"))
    suites.set("tests", str(total))
    suites.set("failures", str(failed))
    suites.set("errors", "0")
    ET.indent(suites)
    body = ET.tostring(suites, encoding="unicode")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + body + "\n"


def _suite(outcome: Outcome, m: ModelResults) -> ET.Element:
    r = m.report
    failures = [x for x in m.results if outcome.counts(x)]
    suite = ET.Element(
        "testsuite",
        name=_xml_text(r.model),
        tests=str(len(RULES)),
        failures=str(len(failures)),
        errors="0",
        skipped="0",
    )
    props = ET.SubElement(suite, "properties")
    for name, value in (
        ("format", r.model_format),
        ("frame", r.frame),
        ("mode", r.mode),
        ("fail-on", outcome.fail_on),
        *((("baseline", outcome.baseline),) if outcome.baseline is not None else ()),
    ):
        ET.SubElement(props, "property", name=name, value=_xml_text(value))
    for rule in RULES.values():
        case = ET.SubElement(
            suite, "testcase", name=rule.id, classname=_xml_text(r.model), file=_xml_text(r.model)
        )
        hits = [x for x in m.results if x.rule == rule.id]
        for x in hits:
            if outcome.counts(x):
                failure = ET.SubElement(
                    case, "failure", message=_xml_text(x.message), type=x.severity
                )
                failure.text = _xml_text(f"{x.severity} {x.rule}: {x.message}\n{_where(x)}")
        passing = [_passing(outcome, x) for x in hits if not outcome.counts(x)]
        if passing:
            ET.SubElement(case, "system-out").text = _xml_text("\n".join(passing))
    return suite


def _where(x: Result) -> str:
    place = f"{x.file}:{x.line}" if x.line is not None else (x.file or "(no file)")
    return place + (f" ({x.element})" if x.element is not None else "")


def _passing(outcome: Outcome, x: Result) -> str:
    if x.known:
        why = "known: in the baseline"
    elif outcome.fail_on == "never":
        why = "--fail-on never"
    else:
        why = f"below --fail-on {outcome.fail_on}"
    return f"{x.severity} ({why}): {x.message} [{_where(x)}]"

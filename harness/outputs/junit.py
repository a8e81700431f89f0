"""JUnit XML for CI systems: one testcase per check, a failure carrying the figure, its budget and its limit.

The layout is the common denominator that GitHub (test-reporter actions),
GitLab (``artifacts:reports:junit``) and Jenkins read: ``<testsuites>`` holding
one ``<testsuite>`` per case, ``classname`` = ``mjharness.CASE``, ``name`` =
the check. No timestamps or durations, so identical runs give identical files.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence

from harness.core.checks import Check
from harness.core.escape import xml_text

__all__ = ["junit_xml"]


def _fmt(value: float) -> str:
    return f"{value:.6e}"


def _describe(c: Check) -> str:
    if c.budget is not None:
        b = c.budget
        parts = ", ".join(f"{k} {_fmt(v)}" for k, v in b.explained.items())
        return (f"measured {_fmt(b.measured)} {c.unit} (explained: {parts or 'nothing'}), unexplained "
                f"{_fmt(b.unexplained)} {c.unit}, limit {_fmt(b.limit)} {c.unit}")
    return f"figure {_fmt(c.value)} {c.unit}, threshold {_fmt(c.threshold)} {c.unit}"


def junit_xml(checks: Mapping[str, Sequence[Check]], *, accept_known_defects: bool = False) -> str:
    """The XML document (UTF-8 text with declaration) for ``checks`` by case. A known defect is a failure
    (type ``KnownDefect``) unless the run accepts known defects, when it is skipped with its reason."""
    skipped = [c for cs in checks.values() for c in cs if c.note or (c.known and accept_known_defects)]
    total = sum(len(cs) for cs in checks.values())
    failures = sum(not c.passed for cs in checks.values() for c in cs) - sum(bool(c.known) for c in skipped)
    root = ET.Element("testsuites", name="mjharness", tests=str(total), failures=str(failures),
                      errors="0")
    for case, cs in checks.items():
        accepted = [c for c in cs if c.known and accept_known_defects]
        suite = ET.SubElement(root, "testsuite", name=case, tests=str(len(cs)),
                              failures=str(sum(not c.passed for c in cs) - len(accepted)), errors="0",
                              skipped=str(sum(bool(c.note) for c in cs) + len(accepted)))
        for c in cs:
            tc = ET.SubElement(suite, "testcase", classname=f"mjharness.{case}", name=c.name)
            if c.note:  # not measurable here
                ET.SubElement(tc, "skipped", message=c.note)
            elif c.known and accept_known_defects:
                ET.SubElement(tc, "skipped", message=f"known defect (accepted): {c.known}")
            elif c.passed:
                ET.SubElement(tc, "system-out").text = _describe(c)
            elif c.diverged:  # no figure: the run it comes from could not be measured
                fail = ET.SubElement(tc, "failure", type="Diverged", message=f"{c.name}: {c.diverged}")
                fail.text = f"{case} {c.name}: {c.diverged}"
            elif c.known:
                fail = ET.SubElement(tc, "failure", type="KnownDefect", message=f"{c.name}: {c.known}")
                fail.text = f"{case} {c.name}: {_describe(c)}; a known defect of this MuJoCo: {c.known}"
            else:
                fail = ET.SubElement(tc, "failure", type="Unexplained" if c.budget is not None
                                     else "ThresholdExceeded", message=f"{c.name}: {_describe(c)}")
                fail.text = f"{case} {c.name}: {_describe(c)}"
    for element in root.iter():  # names from files and models: no character XML cannot hold
        element.attrib.update({k: xml_text(v) for k, v in element.attrib.items()})
        if element.text:
            element.text = xml_text(element.text)
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"

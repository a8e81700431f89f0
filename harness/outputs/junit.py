"""JUnit XML for CI systems: one testcase per check, a failure carrying the figure and threshold.

The layout is the common denominator that GitHub (test-reporter actions),
GitLab (``artifacts:reports:junit``) and Jenkins read: ``<testsuites>`` holding
one ``<testsuite>`` per case, ``classname`` = ``mjharness.CASE``, ``name`` =
the check. No timestamps or durations, so identical runs give identical files.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence

from harness.core.checks import Check


def _fmt(value: float) -> str:
    return f"{value:.6e}"


def junit_xml(checks: Mapping[str, Sequence[Check]]) -> str:
    """The XML document (UTF-8 text with declaration) for ``checks`` by case."""
    total = sum(len(cs) for cs in checks.values())
    failures = sum(not c.passed for cs in checks.values() for c in cs)
    root = ET.Element("testsuites", name="mjharness", tests=str(total), failures=str(failures),
                      errors="0")
    for case, cs in checks.items():
        suite = ET.SubElement(root, "testsuite", name=case, tests=str(len(cs)),
                              failures=str(sum(not c.passed for c in cs)), errors="0",
                              skipped=str(sum(bool(c.note or c.known) for c in cs)))
        for c in cs:
            tc = ET.SubElement(suite, "testcase", classname=f"mjharness.{case}", name=c.name)
            figure = f"figure {_fmt(c.value)} {c.unit}, threshold {_fmt(c.threshold)} {c.unit}"
            if c.note or c.known:  # not measurable here, or a documented defect of this MuJoCo
                ET.SubElement(tc, "skipped", message=c.note or c.known)
            elif c.passed:
                ET.SubElement(tc, "system-out").text = figure
            elif c.diverged:  # no figure: the run it comes from diverged
                fail = ET.SubElement(tc, "failure", type="Diverged", message=f"{c.name}: {c.diverged}")
                fail.text = f"{case} {c.name}: {c.diverged} (threshold {_fmt(c.threshold)} {c.unit})"
            else:
                fail = ET.SubElement(tc, "failure", type="ThresholdExceeded",
                                     message=f"{c.name}: {figure}")
                fail.text = (f"{case} {c.name}: measured {_fmt(c.value)} {c.unit} exceeds the threshold "
                             f"{_fmt(c.threshold)} {c.unit} (pyproject.toml "
                             f"[tool.mjharness.thresholds.{case}])")
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"

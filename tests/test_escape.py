"""The escaping helpers (harness/core/escape.py) on any text: what each lands in cannot be changed by it.

Properties over arbitrary Unicode (hypothesis; cheap): HTML text and attributes hold no markup character and
read back as the visible name; a Markdown cell is one line whose ``|`` never splits the row; XML built from
it parses and reads back; a terminal line holds no control or format character. The whole path through
``run`` and Chromium is tests/test_hostile_names.py.
"""

from __future__ import annotations

import html
import re
import unicodedata
import xml.etree.ElementTree as ET

from hypothesis import given
from hypothesis import strategies as st

from harness.core.escape import html_attr, html_text, markdown_cell, terminal, visible, xml_text

TEXT = st.text(alphabet=st.characters(exclude_categories=("Cs",)), max_size=40) | st.sampled_from(
    ["q'><svg onload=alert(1)>", "a|b", "a\nb", "\x1b[31m", "\x01", "\u202e", "\\|", "&amp;", "`x`", "[a](b)"])


@given(TEXT)
def test_html_holds_no_markup_and_reads_back(text):
    for escaped in (html_text(text), html_attr(text)):
        assert not set(escaped) & set("<>'\"")
        assert html.unescape(escaped) == visible(text)


def _columns(line: str) -> int:
    return sum(1 for m in re.finditer(r"(\\*)\|", line) if len(m.group(1)) % 2 == 0)


@given(TEXT, TEXT)
def test_a_markdown_row_keeps_its_columns(a, b):
    row = f"| {markdown_cell(a)} | {markdown_cell(b)} |"
    assert "\n" not in row and "\r" not in row
    assert _columns(row) == 3
    assert "<" not in row  # no HTML tag opens (GitHub renders HTML in Markdown)


@given(TEXT)
def test_xml_built_from_it_parses_and_reads_back(text):
    root = ET.Element("testsuite", name=xml_text(text))
    root.text = xml_text(text)
    back = ET.fromstring(ET.tostring(root, encoding="unicode"))
    assert back.get("name") == visible(text)


@given(TEXT)
def test_a_terminal_line_holds_no_control_character(text):
    shown = terminal(text)
    assert not any(unicodedata.category(c) in ("Cc", "Cf", "Zl", "Zp") for c in shown)
    assert terminal("ok name") == "ok name" and terminal("\x1b[2J") == "\\x1b[2J"


def test_a_junit_file_of_a_hostile_case_name_parses():
    from harness.core.checks import Check
    from harness.outputs.junit import junit_xml

    name = "a\x01b<c>&\x1b"
    check = Check(case=name, name="RK4.position", value=1.0, threshold=0.5, unit="m")
    root = ET.fromstring(junit_xml({name: [check]}).split("\n", 1)[1])
    assert root.find("testsuite").get("name") == "a\\x01b<c>&\\x1b"


def test_the_sweeps_markdown_keeps_its_columns_with_a_hostile_model_name():
    from harness.versions import sweep
    from harness.versions import sweep_report as report

    name = "m|x\n<img src=x onerror=alert(1)>"
    cells = (sweep.Cell(name, "3.3.0", "c", "pass"), sweep.Cell(name, "4.0.0", "c", "error", reason="a|b\nc"))
    page = report.markdown(sweep.Sweep((name,), ("3.3.0", "4.0.0"), ("c",), cells))
    rows = [line for line in page.splitlines() if line.startswith("|")]
    assert len({_columns(r) for r in rows}) == 1, rows
    assert "<img" not in page

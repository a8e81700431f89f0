"""Names from files, models and the command line cannot change the outputs they land in (issue 45, point 1).

A property test (hypothesis) gives ``mjharness run --mjcf FILE --junit`` model files with adversarial names
(markup that would add an element or run a script, quotes that close an attribute, ``|`` and newlines that
split a Markdown row, control characters XML cannot hold, terminal escapes) and asserts, for each:

- in Chromium's DOM of every page written, no element or script was added (the page's script, SVG, image,
  frame and form elements are those of a plain-named run), no element carries an event handler and the
  page title was not rewritten;
- junit.xml parses, and names the case as written (control characters made visible);
- every Markdown table row of summary.md keeps its header's number of columns;
- the command's output holds no control character.

The escaping helpers' own properties, cheaper, run on many more names in tests/test_escape.py.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from hypothesis import HealthCheck, Phase, example, given, settings
from hypothesis import strategies as st

from harness.cli.commands import main
from harness.core.escape import visible
from harness.engine.models import mjcf_path
from tests.chromium import Browser, find_chromium

FRAGMENTS = ("q'><svg id=pwn onload=document.title=4242>", '"><img src=x onerror=document.title=4243>',
             "<script>document.title=4244<\\script>", "|", "\n", "\r", "\x01", "\x07", "\x1b[31m", "\x1b]0;t\x07",
             "&amp;", "&lt;b&gt;", "]]>", "`", "<!--", "\\", "*", "_", "\u202e", "<b>", "'", '"', "$(id)", "%s",
             "[x](javascript:alert(1))", " ", "é", "1e-05")
DANGEROUS = ("SCRIPT", "SVG", "IMG", "IFRAME", "OBJECT", "EMBED", "FORM", "INPUT", "BASE", "LINK", "META", "STYLE",
             "A", "B", "VIDEO", "AUDIO")
DOM = """(() => {
  const all = Array.from(document.querySelectorAll('*'));
  const tags = {};
  for (const e of all) tags[e.tagName] = (tags[e.tagName] || 0) + 1;
  const handlers = all.flatMap(e => Array.from(e.attributes).filter(a => a.name.toLowerCase().startsWith('on'))
                                 .map(a => e.tagName + '.' + a.name));
  const urls = all.flatMap(e => ['href', 'src'].map(k => e.getAttribute(k) || ''))
                  .filter(u => u.trim().toLowerCase().startsWith('javascript:'));
  return {title: document.title, tags, handlers, urls, pwn: !!document.getElementById('pwn')};
})()"""
names = st.lists(st.sampled_from(FRAGMENTS) | st.text(min_size=1, max_size=3), min_size=1, max_size=4).map(
    "".join).filter(lambda n: "/" not in n and "\0" not in n and n not in (".", "..")
                    and len(f"{n}.xml".encode()) < 200)


@pytest.fixture(scope="module")
def browser():
    binary = find_chromium()
    if binary is None:
        pytest.skip("chromium not installed (apt-get install chromium, or set CHROMIUM)")
    with Browser(binary, width=1000) as b:
        yield b


def _unnamed_copy(model: Path) -> None:
    """The pendulum's MJCF without its ``model`` attribute, so that the case is named after the file (an own
    model's name is its ``model`` attribute first): the hostile name is the case's name everywhere it lands."""
    text = mjcf_path("pendulum").read_text()
    assert '<mujoco model="pendulum">' in text
    model.write_text(text.replace('<mujoco model="pendulum">', "<mujoco>", 1))


def _run(folder: Path, name: str, capsys) -> tuple[Path | None, str]:
    """The report folder of a short run of the pendulum from a file called ``name``, and what the command said;
    no folder where MuJoCo cannot open such a file (a backslash in its name), which must be one line, exit 2."""
    model = folder / f"{name}.xml"
    _unnamed_copy(model)
    out = folder / "R"
    code = main(["run", "--mjcf", str(model), "--out", str(out), "--junit", str(out / "junit.xml"),
                 "--horizon", "0.05", "--integrators", "RK4", "--no-studies", "--quiet"])
    said = capsys.readouterr()
    if code == 2:
        assert "\\" in name and "Error opening file" in said.err and len(said.err.strip().splitlines()) == 1, said.err
        return None, said.out + said.err
    assert code in (0, 1), said.err
    return out, said.out + said.err


def _dom(browser: Browser, page: Path) -> dict:
    browser.open(page.resolve().as_uri())
    return browser.evaluate(DOM)


def _columns(line: str) -> int:
    """The cells of a Markdown table row: its ``|`` not escaped by a backslash (an odd run of them)."""
    return sum(1 for m in re.finditer(r"(\\*)\|", line) if len(m.group(1)) % 2 == 0)


def _tables_keep_their_columns(markdown: str) -> None:
    header = None
    for line in markdown.splitlines():
        if not line.startswith("|"):
            header = None
            continue
        if header is None:
            header = _columns(line)
        assert _columns(line) == header, line


@pytest.fixture(scope="module")
def plain(tmp_path_factory, browser) -> dict[str, dict]:
    """The DOM of each page of a plain-named run: what a hostile name's pages must not add to."""
    folder = tmp_path_factory.mktemp("plain")
    model = folder / "plain.xml"
    _unnamed_copy(model)
    out = folder / "R"
    assert main(["run", "--mjcf", str(model), "--out", str(out), "--horizon", "0.05", "--integrators", "RK4",
                 "--no-studies", "--quiet"]) in (0, 1)
    return {"report": _dom(browser, out / "report.html"), "case": _dom(browser, out / "cases" / "plain.html")}


@pytest.mark.slow
@settings(max_examples=4, deadline=None, phases=[Phase.explicit, Phase.generate],  # no shrinking: bounded
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@example(name="q'><svg id=pwn onload=document.title=4242>")
@example(name="a|b\nc\x01d\x1b[31me\x07")
@given(name=names)
def test_hostile_names_add_nothing_to_any_output(tmp_path_factory, browser, plain, capsys, name):
    """A short run, its report and JUnit, two pages in Chromium, for each of 6 names."""
    folder = tmp_path_factory.mktemp("hostile")
    out, said = _run(folder, name, capsys)
    assert not re.search(r"[\x00-\x08\x0b-\x1f\x7f\x9b\u202e]", said), repr(said)
    if out is None:
        return
    pages = {"report": out / "report.html", "case": next((out / "cases").glob("*.html"))}
    for kind, page in pages.items():
        dom = _dom(browser, page)
        assert not dom["pwn"] and dom["handlers"] == [] and dom["urls"] == [], (kind, dom)
        assert not re.search(r"424[234]", dom["title"]) or re.search(r"424[234]", name), dom["title"]
        base = plain[kind]["tags"]
        added = {t: n for t, n in dom["tags"].items() if t not in base or (t in DANGEROUS and n != base[t])}
        assert added == {}, (kind, added)
    suites = ET.parse(out / "junit.xml").getroot().findall("testsuite")
    assert [s.get("name") for s in suites] == [visible(name)]
    _tables_keep_their_columns((out / "summary.md").read_text(encoding="utf-8"))

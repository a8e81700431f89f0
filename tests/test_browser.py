"""The report's pages in a real browser: headless Chromium (Debian's, installed by .ci/run) loads each page
(the overview report.html, each case's, the studies', the audit's) at 1000 px and a script in the page
reports what a reader would meet:

- an image that does not decode, or is shown below 3/4 of its drawn size (its text illegible), above 4/3
  (blurred) or stretched out of its proportions;
- a table-of-contents link that resolves to nothing, a section the contents do not reach, no way back;
- anything wider than the window, 1000 px or a laptop's 1366 (the page, an element, a scrolling box);
- raw LaTeX in the visible text (``\\frac``, ``$...$``, ``^{``);
- a number broken across two lines (``4.99e-`` / ``04``).

The full report goes to ``$MJHARNESS_ARTIFACTS/report`` and screenshots of the overview, the pendulum's
page and the studies' (each page's top and each section) to ``$MJHARNESS_ARTIFACTS/screenshots`` (CI keeps
both), or to pytest's temporary directory. Without Chromium the tests skip with the reason, unless
``MJHARNESS_REQUIRE_CHROMIUM=1`` (set by .ci/run), where a missing browser fails.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.chromium import Browser, find_chromium, section_screenshots
from tests.pages import broken_links, python_reprs, visible_text

WIDTH = 1000
LAPTOP = 1366  # a common laptop screen's width: the page must read there too
MIN_SCALE = 0.75  # an image shown below 3/4 of its drawn size: 9 px text becomes < 7 px

CHECK_PAGE = r"""
(async () => {
  const found = {images: [], scaled: [], toc: [], unreached: [], overflow: [], latex: [], wrapped: []};
  const name = el => el.tagName.toLowerCase() + (el.id ? '#' + el.id : '')
      + (el.className && typeof el.className === 'string' ? '.' + el.className.split(' ').join('.') : '')
      + ' in ' + ((el.closest('section[id]') || {}).id || 'page');
  for (const img of Array.from(document.images)) {
    try { await img.decode(); } catch (e) { /* reported below */ }
    if (!img.complete || img.naturalWidth === 0) {
      found.images.push(name(img) + ' ' + (img.alt || '').slice(0, 80));
      continue;
    }
    const box = img.getBoundingClientRect();
    const sx = box.width / img.naturalWidth, sy = box.height / img.naturalHeight;
    const bad = Math.min(sx, sy) < MIN_SCALE || Math.max(sx, sy) > 1 / MIN_SCALE + 0.01 || Math.abs(sx / sy - 1) > 0.05;
    if (bad && !img.classList.contains('still'))
      found.scaled.push(`${name(img)}: shown ${Math.round(box.width)}×${Math.round(box.height)} px, drawn `
                        + `${img.naturalWidth}×${img.naturalHeight}`);
  }
  const toc = document.querySelector('nav.toc');
  const linked = new Set();
  if (!toc) found.toc.push('no nav.toc');
  else for (const a of toc.querySelectorAll('a')) {
    const href = a.getAttribute('href') || '';
    const target = href.startsWith('#') ? document.getElementById(decodeURIComponent(href.slice(1))) : null;
    if (!target) found.toc.push(`${href} (${a.textContent.trim()})`); else linked.add(target.id);
  }
  for (const s of document.querySelectorAll('section[id]'))
    if (!linked.has(s.id)) found.unreached.push(s.id);
  if (toc && !toc.id) found.toc.push('the contents have no id to come back to');
  else if (toc && !document.querySelector(`a[href="#${toc.id}"]`)) found.toc.push('no link back to the contents');
  const W = document.documentElement.clientWidth;
  const pageWidth = document.documentElement.scrollWidth;
  if (pageWidth > W) found.overflow.push(`page: ${pageWidth} px wide`);
  for (const el of document.body.querySelectorAll('*')) {
    const r = el.getBoundingClientRect();
    if (r.width > 0 && r.right > W + 0.5) found.overflow.push(`${name(el)}: right edge at ${Math.round(r.right)} px`);
    const style = getComputedStyle(el);
    if (['auto', 'scroll'].includes(style.overflowX) && el.scrollWidth > el.clientWidth + 1)
      found.overflow.push(`${name(el)}: scrolls ${el.scrollWidth - el.clientWidth} px sideways`);
  }
  const text = document.body.innerText;
  for (const m of text.matchAll(/\\[A-Za-z]+|\$[^$\n]{1,80}\$|[_^]\{/g))
    found.latex.push(text.slice(Math.max(0, m.index - 30), m.index + 40).replace(/\s+/g, ' '));
  const walker = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT);
  const number = /[-−]?\d+(?:\.\d+)?e[-+−]\d+/g;
  for (let node = walker.nextNode(); node; node = walker.nextNode()) {
    for (const m of node.data.matchAll(number)) {
      const range = document.createRange();
      range.setStart(node, m.index);
      range.setEnd(node, m.index + m[0].length);
      const tops = new Set(Array.from(range.getClientRects()).filter(r => r.width > 0).map(r => Math.round(r.top)));
      if (tops.size > 1) found.wrapped.push(`${m[0]} in ${name(node.parentElement)}`);
    }
  }
  return found;
})()
""".replace("MIN_SCALE", repr(MIN_SCALE))


def _browser_or_skip() -> str:
    binary = find_chromium()
    if binary is None:
        if os.environ.get("MJHARNESS_REQUIRE_CHROMIUM") == "1":
            pytest.fail("MJHARNESS_REQUIRE_CHROMIUM=1 but no chromium on PATH (apt-get install chromium)")
        pytest.skip("chromium not installed (apt-get install chromium, or set CHROMIUM): the report's "
                    "browser checks did not run")
    return binary


def problems(browser: Browser, page: Path) -> dict[str, list[str]]:
    """What CHECK_PAGE finds on ``page`` at WIDTH px, by kind (only the kinds with findings)."""
    browser.open(page.resolve().as_uri())
    return {kind: items for kind, items in browser.evaluate(CHECK_PAGE).items() if items}


def _artifacts(tmp_path: Path) -> Path:
    root = os.environ.get("MJHARNESS_ARTIFACTS")
    return Path(root) if root else tmp_path


@pytest.mark.slow
def test_the_full_report_reads_in_a_browser(tmp_path):
    """Every case with its studies and the seed audit, as `mjharness run` writes them (about two minutes): each
    page (the overview, every case's, the studies', the audit's) reads at both widths, every link reaches a
    written page and anchor, and no page shows a raw Python repr."""
    binary = _browser_or_skip()
    out = _artifacts(tmp_path) / "report"
    proc = subprocess.run([sys.executable, "-m", "harness.cli", "run", "--out", str(out), "--quiet"],
                          capture_output=True, text=True, timeout=900, check=False)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    pages = sorted(out.rglob("*.html"))
    names = {p.relative_to(out).as_posix() for p in pages}
    assert {"report.html", "studies.html", "audit.html", "cases/pendulum.html"} <= names
    assert broken_links(out) == {}
    reprs = {p.relative_to(out).as_posix(): python_reprs(visible_text(p.read_text(encoding="utf-8"))) for p in pages}
    assert {name: found for name, found in reprs.items() if found} == {}
    found: dict[str, list[str]] = {}
    shots = []
    for width in (WIDTH, LAPTOP):
        with Browser(binary, width=width) as browser:
            for page in pages:
                name = page.relative_to(out).as_posix()
                found |= {f"{kind} in {name} at {width} px": items for kind, items in problems(browser, page).items()}
                if width == WIDTH and name in ("report.html", "studies.html", "cases/pendulum.html"):
                    shots += section_screenshots(browser, _artifacts(tmp_path) / "screenshots" / page.stem)
    assert len(shots) >= 3
    assert found == {}, "\n".join(f"{kind}: {len(items)}: {items[:8]}" for kind, items in found.items())


BROKEN = """<!DOCTYPE html><html><head><meta charset='utf-8'><style>body{margin:0}</style></head><body>
<nav class='toc' id='contents'><a href='#one'>one</a> <a href='#nowhere'>dangling</a></nav>
<section id='one'><h2>one</h2><p>$\\frac{a}{b}$ and \\theta</p>
<img src='data:image/png;base64,iVBORw0KGgo=' alt='not a png'>
<img src='ONE_PIXEL' style='width:50px;height:20px' alt='a 1×1 PNG stretched'>
<div style='width:1400px'>too wide</div>
<p style='width:9ch;font-family:monospace'>xx 4.99e-04</p></section>
<section id='two'><h2>two</h2></section>
</body></html>""".replace("ONE_PIXEL", "data:image/png;base64,iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQ"
                           "VR42mNk+M9QDwADhgGAWjR9awAAAABJRU5ErkJggg==")


def test_the_page_checks_find_each_kind_of_fault(tmp_path):
    """The checker itself, on a page with one fault of each kind: none may go unseen."""
    binary = _browser_or_skip()
    page = tmp_path / "broken.html"
    page.write_text(BROKEN)
    with Browser(binary, width=WIDTH) as browser:
        found = problems(browser, page)
    assert set(found) == {"images", "scaled", "toc", "unreached", "overflow", "latex", "wrapped"}, found
    assert found["scaled"] == ["img in one: shown 50×20 px, drawn 1×1"]
    assert any("#nowhere" in t for t in found["toc"]) and any("back" in t for t in found["toc"])
    assert found["unreached"] == ["two"]
    assert "$\\frac{a}{b}$" in found["latex"][0] and any("\\theta" in t for t in found["latex"])
    assert any("4.99e-04" in w for w in found["wrapped"])
    assert any("div" in o for o in found["overflow"]) and found["overflow"][0].startswith("page")

"""What the report's tests read from written pages: the visible text (for raw Python reprs) and the links
(each must reach a written file and an anchor in it). Plain HTML parsing, no browser."""

from __future__ import annotations

import re
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

REPRS = re.compile("|".join((
    r"\{\s*['\"][^'\"\n]*['\"]\s*:",  # a dict with string keys: {'cone': 'elliptic'
    r"\[\s*\(",  # a list of tuples: [('a', 1)
    r"\[\s*['\"]",  # a list of strings: ['a', 'b']
    r"\(\s*['\"][^'\"\n]*['\"]\s*,",  # a tuple of strings: ('a', 'b')
    r"<[\w.]+ object at 0x[0-9a-fA-F]+>",  # an object's default repr
    r"\bnp\.\w+\(",  # numpy scalars: np.float64(1.0)
    r"\barray\(\[",  # a numpy array
    r"\b[A-Z]\w*\(\w+=",  # a dataclass or named tuple: Check(case=
    r"<\w+\.\w+: -?\d+>",  # an enum member: <mjtCone.mjCONE_ELLIPTIC: 1>
    r"\b(?:mappingproxy|dict|frozenset)\(",  # other containers' reprs
)))


class _Text(HTMLParser):
    """The text a reader sees: every text node outside ``<style>`` and ``<script>``."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.parts: list[str] = []
        self._hidden = 0

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self._hidden += tag in ("style", "script")

    def handle_endtag(self, tag: str) -> None:
        self._hidden -= tag in ("style", "script")

    def handle_data(self, data: str) -> None:
        if not self._hidden:
            self.parts.append(data)


def visible_text(html: str) -> str:
    """The page's text with its markup stripped, text nodes joined by spaces."""
    parser = _Text()
    parser.feed(html)
    parser.close()
    return " ".join(parser.parts)


def python_reprs(text: str) -> list[str]:
    """Each place in ``text`` that reads as a raw Python repr, with some text around it."""
    return [text[max(0, m.start() - 30):m.end() + 30] for m in REPRS.finditer(text)]


class _Links(HTMLParser):
    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.hrefs: list[str] = []
        self.ids: set[str] = set()

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        found = dict(attrs)
        if found.get("id"):
            self.ids.add(str(found["id"]))
        if tag == "a" and found.get("href") is not None:
            self.hrefs.append(str(found["href"]))


def links(html: str) -> tuple[list[str], set[str]]:
    """The page's link targets (``<a href>``) and its element ids."""
    parser = _Links()
    parser.feed(html)
    parser.close()
    return parser.hrefs, parser.ids


def broken_links(out: Path) -> dict[str, list[str]]:
    """Per page under ``out``, each link that does not reach a page written there (and, with ``#anchor``, an
    element of that page with that id); links off the report (a scheme such as ``https:``) count as broken too:
    the report opens offline."""
    pages = {p.relative_to(out).as_posix(): links(p.read_text(encoding="utf-8")) for p in sorted(out.rglob("*.html"))}
    found: dict[str, list[str]] = {}
    for name, (hrefs, _ids) in pages.items():
        for href in hrefs:
            parts = urlsplit(href)
            resolved = _normal((Path(name).parent / unquote(parts.path)).as_posix()) if parts.path else name
            ok = (not parts.scheme and not parts.netloc and resolved in pages
                  and (not parts.fragment or unquote(parts.fragment) in pages[resolved][1]))
            if not ok:
                found.setdefault(name, []).append(href)
    return found


def _normal(path: str) -> str:
    """``path`` with ``.`` and ``..`` folded (``cases/../report.html`` → ``report.html``)."""
    parts: list[str] = []
    for part in path.split("/"):
        if part == "..":
            if not parts:
                return "../" + path  # above the report: reaches nothing written
            parts.pop()
        elif part not in ("", "."):
            parts.append(part)
    return "/".join(parts)

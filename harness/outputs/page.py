"""The report's pages: what a page besides the overview and the case pages is (:class:`Page`), and passes
over a page's assembled HTML: its table of contents, read from the page's own sections, and numbers kept on
one line.

The contents are read from the page rather than listed beside it, so that a section added anywhere (a
case, a study, the audit) is reached from the top without anyone remembering to list it: every
``<section id>`` becomes an entry titled by its first heading, nested as the sections are. Numbers such
as ``4.99e-04`` would otherwise break after the hyphen in a narrow cell; each is wrapped in a span that
does not break (in text only: tags, attributes and the style sheet are left as they are).
"""

from __future__ import annotations

import html
import re
from dataclasses import dataclass, field
from html.parser import HTMLParser

__all__ = ["Page", "table_of_contents", "unbroken_numbers"]

CONTENTS_ID = "contents"


@dataclass(frozen=True)
class Page:
    """A page of the report beside the overview and the case pages (the studies, the seed audit, the backends
    side by side): its file in the output directory (one of :data:`harness.outputs.files.PAGES`), its title,
    the line the overview gives it, and its sections."""

    name: str
    title: str
    about: str
    sections: tuple[str, ...]


@dataclass
class Entry:
    """A section of the page: its anchor, its heading's text and the sections inside it."""

    anchor: str
    title: str = ""
    children: list[Entry] = field(default_factory=list)


class _Outline(HTMLParser):
    """The tree of ``<section id>`` elements with the text of each one's first h2-h4."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.root = Entry("")
        self._open: list[Entry | None] = []  # the sections open at this point (None: one without an id)
        self._titling: Entry | None = None
        self._text: list[str] = []

    def _parent(self) -> Entry:
        return next((e for e in reversed(self._open) if e is not None), self.root)

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag == "section":
            anchor = dict(attrs).get("id")
            entry = Entry(anchor) if anchor else None
            if entry is not None:
                self._parent().children.append(entry)
            self._open.append(entry)
        elif tag in ("h2", "h3", "h4") and self._open and self._open[-1] is not None \
                and not self._open[-1].title and self._titling is None:
            self._titling, self._text = self._open[-1], []

    def handle_endtag(self, tag: str) -> None:
        if tag == "section" and self._open:
            self._open.pop()
        elif tag in ("h2", "h3", "h4") and self._titling is not None:
            self._titling.title = " ".join("".join(self._text).split())
            self._titling = None

    def handle_data(self, data: str) -> None:
        if self._titling is not None:
            self._text.append(data)


def outline(body: str) -> list[Entry]:
    """The page's sections, top level first, each with its nested ones."""
    parser = _Outline()
    parser.feed(body)
    parser.close()
    return parser.root.children


def _link(entry: Entry) -> str:
    return f"<a href='#{html.escape(entry.anchor, quote=True)}'>{html.escape(entry.title or entry.anchor)}</a>"


def _items(entries: list[Entry]) -> str:
    return "".join(f"<li>{_link(e)}" + (f"<ul>{_items(e.children)}</ul>" if e.children else "") + "</li>"
                   for e in entries)


def table_of_contents(body: str) -> str:
    """A ``<nav>`` linking every section of ``body`` (id :data:`CONTENTS_ID`, so any page part can link
    back to it)."""
    return (f"<nav class='toc' id='{CONTENTS_ID}'><h2>Contents</h2><ol>{_items(outline(body))}</ol></nav>"
            f"<a class='to-contents' href='#{CONTENTS_ID}' title='back to the contents'>↑ contents</a>")


_NUMBER = re.compile(r"[-−]?\d+(?:\.\d+)?e[-+−]\d+")
_TAG_OR_STYLE = re.compile(r"(<style.*?</style>|<[^>]*>)", re.DOTALL)


def unbroken_numbers(page: str) -> str:
    """``page`` with each number in scientific notation in its text wrapped in ``<span class='nb'>`` (the
    style sheet keeps such a span on one line)."""
    parts = _TAG_OR_STYLE.split(page)
    return "".join(part if k % 2 else _NUMBER.sub(r"<span class='nb'>\g<0></span>", part)
                   for k, part in enumerate(parts))

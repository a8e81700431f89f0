"""Numbers and tables for people: aligned text tables for the terminal, HTML tables for pages."""

from __future__ import annotations

import html
import math
import os
import shutil
import sys
import textwrap
from collections.abc import Sequence

__all__ = ["fmt", "html_table", "terminal_width", "text_table", "wrap"]


def fmt(value: float | None, spec: str = ".3e") -> str:
    """A number for a table; ``-`` for None, ``nan``/``inf`` spelled out."""
    if value is None:
        return "-"
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return format(value, spec)


def text_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """Columns padded to their widest cell, two spaces apart."""
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    return "\n".join("  ".join(v.ljust(w) for v, w in zip(r, widths, strict=True)).rstrip()
                     for r in [header, *rows])


def html_table(header: Sequence[str], rows: Sequence[Sequence[str]],
               classes: Sequence[str] | None = None) -> str:
    """An HTML table; ``classes`` gives each row's class (``pass``/``fail``/``""``)."""
    classes = classes or [""] * len(rows)
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join(
        f"<tr class='{c}'>" + "".join(f"<td>{html.escape(v)}</td>" for v in r) + "</tr>"
        for r, c in zip(rows, classes, strict=True))
    return f"<table><tr>{head}</tr>{body}</table>"


NOT_A_TERMINAL_WIDTH = 100
"""Columns the output fits where stdout is not a terminal (a CI log, a pipe) and COLUMNS is not set."""


def terminal_width() -> int:
    """Columns a line may take: COLUMNS where set, else the terminal's, else (not a terminal)
    :data:`NOT_A_TERMINAL_WIDTH`; never fewer than 20."""
    if "COLUMNS" not in os.environ and not _isatty(sys.stdout):
        return NOT_A_TERMINAL_WIDTH
    return max(20, shutil.get_terminal_size((NOT_A_TERMINAL_WIDTH, 24)).columns)


def _isatty(stream: object) -> bool:
    try:
        return bool(stream.isatty())  # type: ignore[attr-defined]
    except (AttributeError, ValueError):  # no isatty, or closed
        return False


def wrap(text: str, width: int, indent: str = "", more: str = "    ") -> list[str]:
    """``text`` as lines of at most ``width`` columns: the first indented by ``indent``, the rest by
    ``more``; a word longer than a line (a path) is broken."""
    return textwrap.wrap(text, width=width, initial_indent=indent, subsequent_indent=indent + more,
                         break_on_hyphens=False) or [indent.rstrip()]

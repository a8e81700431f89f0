"""Numbers and tables for people: aligned text tables for the terminal, HTML tables for pages."""

from __future__ import annotations

import html
import math
from collections.abc import Sequence


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

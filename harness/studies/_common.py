"""Shared helpers of the studies: PNG plots, aligned text tables, HTML tables.

Plots are rendered with matplotlib's Agg backend (``harness.plotting``,
imported on first use) to PNG bytes with no timestamp, so the same study
gives byte-identical images.
"""

from __future__ import annotations

import base64
import html
import io
import math
from collections.abc import Sequence

from harness.plotting import pyplot


def png_bytes(fig) -> bytes:
    """Render and close ``fig``; PNG bytes without the Software/time metadata."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90, metadata={"Software": None}, bbox_inches="tight")
    pyplot().close(fig)
    return buf.getvalue()


def png_data_uri(png: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


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


def case_dynamics(case):
    """The numeric dynamics of ``case`` at the parameters of its shipped model (cached derivation)."""
    from analytic.systems import load
    from harness import reference as refmod
    from harness.models import compile_model, mjcf_path

    params = load(case.system).params_from_model(compile_model(mjcf_path(case.mjcf)))
    return refmod.dynamics(case.system, params)

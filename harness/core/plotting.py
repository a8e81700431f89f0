"""matplotlib, imported on first use: the plots of reports and studies, as PNG bytes.

``pyplot()`` selects the Agg backend (PNG bytes, no display) and the report's
style the first time it is called. Commands that draw nothing (``check``,
``baseline``, ``diff``) never import matplotlib, whose import would be a
sizeable part of every such run's start. PNGs carry no Software or time metadata, so the same
plot gives byte-identical images.
"""

from __future__ import annotations

import base64
import functools
import io
from collections.abc import Mapping, Sequence
from types import ModuleType
from typing import cast

import numpy as np

__all__ = ["FULL_WIDTH", "HALF_WIDTH", "coinciding", "formula_png", "png_bytes", "png_data_uri", "pyplot", "style"]

DPI = 90
STYLE = {"figure.dpi": DPI, "font.size": 9, "legend.fontsize": 8, "axes.titlesize": 9.5,
         "svg.hashsalt": "mjharness"}
"""At 90 dpi a 9 pt label is 11 px and an 8 pt legend 10 px on a page that shows the plot at its drawn size."""

HALF_WIDTH = 5.1
"""Inches (459 px): two plots side by side on a page 1000 px wide, each shown at its drawn size."""
FULL_WIDTH = 10.4
"""Inches (936 px): one plot across the page."""

_STYLES = (("tab:blue", "-", "o"), ("tab:orange", "--", "s"), ("tab:green", "-.", "^"), ("tab:red", ":", "D"),
           ("tab:purple", (0, (5, 1.5)), "v"), ("tab:brown", (0, (3, 1, 1, 1)), "P"), ("tab:pink", "-", "X"))
INTEGRATORS = ("Euler", "implicit", "implicitfast", "RK4", "discrete")


def style(name: str, k: int = 0) -> dict[str, object]:
    """Colour, line style and marker of a curve: fixed per MuJoCo integrator (the same in every plot), else
    the ``k``-th of the cycle; curves that differ in colour differ in dash and marker too."""
    colour, dash, marker = _STYLES[INTEGRATORS.index(name) if name in INTEGRATORS else k % len(_STYLES)]
    return {"color": colour, "linestyle": dash, "marker": marker}


def coinciding(curves: Mapping[str, np.ndarray], *, rtol: float = 0.01) -> list[tuple[list[str], str]]:
    """Curves grouped where they would lie on top of each other: each group's names (first seen first) and
    its label — ``"Euler = implicitfast (identical)"`` when equal, ``"Euler ≈ implicit (within 1 %)"`` when
    every point agrees within ``rtol``, the name alone otherwise."""
    groups: list[list[str]] = []
    for name, values in curves.items():
        home = next((g for g in groups if np.shape(curves[g[0]]) == np.shape(values)
                     and np.allclose(values, curves[g[0]], rtol=rtol, atol=0, equal_nan=True)), None)
        if home is None:
            groups.append([name])
        else:
            home.append(name)
    out = []
    for g in groups:
        if len(g) == 1:
            out.append((g, g[0]))
        elif all(np.array_equal(curves[n], curves[g[0]], equal_nan=True) for n in g):
            out.append((g, " = ".join(g) + " (identical)"))
        else:
            out.append((g, " ≈ ".join(g) + f" (within {100 * rtol:g} %)"))
    return out


@functools.cache
def pyplot() -> ModuleType:
    """``matplotlib.pyplot`` on the Agg backend, with :data:`STYLE`."""
    import matplotlib  # lazy: matplotlib, only for commands that draw

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # lazy: as above

    plt.rcParams.update(cast(dict, STYLE))  # (matplotlib's hints name its keys one literal each)
    return plt


def png_bytes(fig, **savefig) -> bytes:
    """Render and close ``fig``; PNG bytes without the Software/time metadata. ``savefig`` options
    override the defaults (dpi 90, tight bounding box)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", **({"dpi": DPI, "metadata": {"Software": None}, "bbox_inches": "tight"}
                                      | savefig))
    pyplot().close(fig)
    return buf.getvalue()


def png_data_uri(png: bytes) -> str:
    """PNG bytes as a data URI, for a self-contained HTML page."""
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def formula_png(latex: str | Sequence[str], *, fontsize: float = 13.0, dpi: int = 110) -> bytes | None:
    """A formula typeset by matplotlib's mathtext (no TeX, no network): one line of LaTeX without dollar
    signs, or several drawn one under the other, as PNG bytes; None where mathtext cannot typeset it."""
    plt = pyplot()
    fig = plt.figure(figsize=(0.01, 0.01))
    lines = [latex] if isinstance(latex, str) else list(latex)
    fig.text(0, 0, "\n".join(f"${line}$" for line in lines), fontsize=fontsize, multialignment="left")
    buf = io.BytesIO()
    try:
        fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight", pad_inches=0.04,
                    metadata={"Software": None}, transparent=True)  # on a card, a tinted row or white
    except ValueError:  # mathtext's parse error
        return None
    finally:
        plt.close(fig)
    return buf.getvalue()

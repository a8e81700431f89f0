"""A contact-settings study (:mod:`harness.studies.contact`) as a table and a plot per case."""

from __future__ import annotations

import base64
import html
from collections.abc import Mapping, Sequence

import numpy as np

from harness.core.plotting import FULL_WIDTH, png_bytes, pyplot
from harness.studies.contact import StudyResult

__all__ = ["html_section", "plot"]


def plot(result: StudyResult) -> bytes:
    """Steady slip, worst force error and position error per setting, as PNG bytes: one horizontal bar
    a setting in three panels side by side, labelled in the table's order (the shipped row in bold)."""
    plt = pyplot()
    from matplotlib.patches import Patch  # lazy: matplotlib loads only to draw

    shipped = result.shipped_row()
    labels = [f"{r['cone']}, impratio {r['impratio']:g}, noslip {r['noslip_iterations']}, {r['softness']}"
              for r in result.rows]
    colours = ["tab:blue" if r["cone"] == "elliptic" else "tab:orange" for r in result.rows]
    panels = [("slip_late", "steady slip [m/s]\n(max over the 2nd half)"),
              ("force_error", "worst contact force\nerror / m g"),
              ("position", "position error [m]")]
    fig, axes = plt.subplots(1, len(panels), figsize=(FULL_WIDTH, 1.4 + 0.19 * len(result.rows)), sharey=True,
                             layout="constrained")
    y = np.arange(len(result.rows))
    for ax, (key, title) in zip(axes, panels, strict=True):
        values = np.array([float(r[key]) for r in result.rows])
        finite = np.isfinite(values)  # a setting whose run diverged has no number: named, not drawn
        values = np.maximum(values[finite], 1e-16)
        ax.barh(y[finite], values, color=[c for c, f in zip(colours, finite, strict=True) if f], height=0.7)
        ax.set_xscale("log")  # whole decades, labelled at the decades only (minor labels would collide)
        if values.size:
            ax.set_xlim(10 ** np.floor(np.log10(values.min())), 10 ** np.ceil(np.log10(values.max())))
        for row in y[~finite]:
            ax.annotate("diverged", (0.02, row), xycoords=("axes fraction", "data"), va="center", fontsize=8)
        ax.tick_params(axis="x", which="minor", labelbottom=False)
        ax.set_title(title)
        ax.grid(True, axis="x", alpha=0.3)
    axes[0].set_yticks(y, labels)
    axes[0].invert_yaxis()  # the table's order, top to bottom
    for tick, row in zip(axes[0].get_yticklabels(), result.rows, strict=True):
        tick.set_fontweight("bold" if row is shipped else "normal")
    fig.legend(handles=[Patch(color="tab:orange", label="pyramidal cone"),
                        Patch(color="tab:blue", label="elliptic cone")], loc="outside lower center", ncol=2,
               frameon=False)
    fig.suptitle(f"{result.case}: contact settings ({result.integrator}, h = {result.timestep:g} s; "
                 "the shipped settings in bold)")
    return png_bytes(fig)


def _settings_text(settings: Mapping[str, object]) -> str:
    """``cone = elliptic, impratio = 10, noslip_iterations = 0``: the settings as a reader writes them."""
    return ", ".join(f"{k} = {v:g}" if isinstance(v, float) else f"{k} = {v}" for k, v in settings.items())


def html_section(results: Sequence[StudyResult], plots: Mapping[tuple[str, str], bytes]) -> str:
    """The contact-settings studies as a report section: a table per case (shipped row marked) and its plot
    (``plots[("contact", case)]``, drawn by :func:`plot`)."""
    parts = []
    for r in results:
        keys = ("cone", "impratio", "noslip_iterations", "softness", "slip_late", "force_error", "position",
                *(("diverged",) if any("diverged" in row for row in r.rows) else ()))
        shipped = r.shipped_row()
        head = "".join(f"<th>{k}</th>" for k in keys)
        rows = "".join(
            "<tr" + (" class='shipped'" if row is shipped else "") + ">"
            + "".join(f"<td>{row[k]:.3g}</td>" if isinstance(row.get(k), float)
                      else f"<td>{html.escape(str(row.get(k, '')))}</td>" for k in keys) + "</tr>" for row in r.rows)
        img = base64.b64encode(plots[("contact", r.case)]).decode("ascii")
        parts.append(f"<section id='contact-{html.escape(r.case)}'>"
                     f"<h3>{html.escape(r.case)}: cone, impratio, noslip ({html.escape(r.integrator)}, "
                     f"h = {r.timestep:g} s)</h3><p>Shipped settings: {html.escape(_settings_text(r.shipped))} "
                     f"(bold row). slip_late: steady slip velocity (m/s), max over the second half; "
                     f"force_error: worst contact force error / m g; position: max position error (m).</p>"
                     f"<table><tr>{head}</tr>{rows}</table><img src='data:image/png;base64,{img}' "
                     f"alt='contact settings of {html.escape(r.case)}'></section>")
    return (f"<section id='contact-study'><h2>Contact settings study</h2>{''.join(parts)}</section>"
            if parts else "")

"""``mjharness advise`` for people: the text, the JSON document, the plot and the page.

The plot has one panel per quantity a requirement can name (position, energy, constraint force): each integrator's
error against the timestep with its error bars, its stability limit as a vertical line of its colour, the
requirement as a horizontal line, and the verified recommendation as a star at its measured error.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from harness.core.escape import html_text
from harness.core.plotting import FULL_WIDTH, png_bytes, png_data_uri, pyplot, style
from harness.core.tables import text_table
from harness.studies.advice import Advice, Curve, Point, Verification, covered

__all__: list[str] = []

PANELS = (("position", "position error (m)"), ("drift.energy", "energy drift error (relative)"),
          ("force", "constraint force error (relative)"))
"""The quantities drawn: a measure, or ``force`` for the largest of the ``force.*`` figures."""


def _value(point: Point, measure: str) -> tuple[float, float]:
    """``measure``'s value and bar at ``point`` (``force``: the largest force figure's); nan where it has none."""
    if measure == "force":
        forces = [(v, point.bars[m]) for m, v in point.values.items() if m.startswith("force.")]
        return max(forces, default=(math.nan, math.nan))
    return point.values.get(measure, math.nan), point.bars.get(measure, math.nan)


def _ms(h: float) -> str:
    return f"{h * 1e3:.3g} ms" if math.isfinite(h) else "—"


def _limit_text(curve: Curve) -> str:
    lim = curve.limit
    if math.isnan(lim.timestep):
        return "not assessed"
    if math.isinf(lim.timestep):
        return "none found"
    return _ms(lim.timestep) + (" (confirmed)" if lim.confirmed else " (not confirmed)")


def _requirements(advice: Advice) -> str:
    return ", ".join(f"{r.measure} ≤ {r.value:g}" for r in advice.requirements)


def _verified(v: Verification, advice: Advice) -> str:
    figures = ", ".join(f"{m} {x:.3g}" for m, x in sorted(v.measured.items()))
    predicted = ", ".join(f"{m} {x:.3g}" for m, x in sorted(v.predicted.items()) if math.isfinite(x))
    return (f"{v.integrator} at h = {_ms(v.timestep)}: measured {figures} (predicted {predicted}), margin "
            f"{v.margin:.3g}× within {_requirements(advice)}; every check of its runs passes its budget; cost "
            f"{v.cost:.3g} CPU s per simulated s (measured here)")


def text(advice: Advice) -> str:
    """Everything as aligned text: the requirement, each integrator's ladder, the limits and the answer."""
    own, h0 = advice.own
    lines = [f"{advice.model}: its own setting {own} at h = {_ms(h0)}; required: {_requirements(advice)}; "
             f"horizon {advice.horizon:g} s"]
    rows = []
    for curve in advice.curves:
        for p in curve.points:
            if p.diverged:
                rows.append([curve.integrator, _ms(p.timestep), "diverged", "", "", ""])
                continue
            cells = []
            for measure, _ in PANELS:
                v, bar = _value(p, measure)
                cells.append(f"{v:.3g} ± {bar:.1g}" if math.isfinite(v) else "")
            rows.append([curve.integrator, _ms(p.timestep), *cells, f"{p.cost:.3g}"])
    lines += ["", "Error against the reference by timestep (± the error bar: the reference's own error, round-off, "
                  "the solver's stop); cost = CPU seconds per simulated second on this machine:",
              text_table(["integrator", "h", "position (m)", "energy (rel.)", "force (rel.)", "cost"], rows)]
    lines += ["", "Stability and order:"]
    for curve in advice.curves:
        held = [f"{m} from {_ms(r[0])} to {_ms(r[1])}" for m, r in curve.ordered.items()
                if m in ("position", "drift.energy") or m.startswith("force.")]
        order = (f"order {curve.order:g} holds for " + ", ".join(held) if held else
                 f"order {curve.order:g} not observed on the ladder (fewer than two runs in its asymptotic range)")
        lines.append(f"  {curve.integrator}: largest stable step {_limit_text(curve)}: {curve.limit.basis}"
                     + (f"; below: {curve.limit.below}; above: {curve.limit.above}" if curve.limit.below else "")
                     + f"; {order}")
    lines.append("")
    if advice.recommended is not None:
        lines.append("Recommended: " + _verified(advice.recommended, advice))
        if advice.recommended.findings:
            lines.append(f"  the check at that setting also fails {', '.join(advice.recommended.findings)}: "
                         "figures no integrator or timestep changes (at the sampled states, of the reference), a "
                         "finding about the model that `mjharness check --mjcf` explains")
        lines += [f"  not {name}: {why}" for name, why in advice.rejected.items()]
    else:
        lines.append("No recommendation: " + advice.why_none)
    for other in (t for t in advice.tried if t is not advice.recommended):
        as_is = ", ".join(f"{m} {x:.3g}" for m, (x, _) in sorted(other.as_is.items()))
        state = "met" if other.met else ("failed its checks: " + ", ".join(other.failures[:3]) if other.failures
                                         else "missed the requirement" + (f" (as it is: {as_is})" if as_is else ""))
        lines.append(f"  also verified: {other.integrator} at h = {_ms(other.timestep)}: "
                     + ", ".join(f"{m} {x:.3g}" for m, x in sorted(other.measured.items()))
                     + f", cost {other.cost:.3g}: {state}")
    if advice.uncovered:
        lines.append("")
        lines.append(coverage(advice))
    lines.append("")
    lines.append(f"({', '.join(f'{k} {v:.1f} s' for k, v in advice.seconds.items())})")
    return "\n".join(lines)


def coverage(advice: Advice) -> str:
    """Which requirement is verified against the reference and which only by self-convergence and the balance."""
    kinds = ", ".join(advice.uncovered)
    said = [f"Not in the reference: {kinds}. The errors above and the verification are the model's tree dynamics "
            "with them switched off."]
    v = advice.recommended
    if v is not None and v.as_is:
        for measure, (value, how) in v.as_is.items():
            named = [r for r in advice.requirements if covered(r, measure)]
            verdict = ("within the requirement" if all(value <= r.value for r in named) else "beyond the requirement") \
                if named else "no requirement names it"
            said.append(f"With them on, {measure} is checked only by {how}: {value:.3g} ({verdict}).")
        said.append("Constraint forces with them on: not checked.")
    return " ".join(said)


def as_dict(advice: Advice) -> dict[str, object]:
    """The advice as JSON."""
    def point(p: Point) -> dict[str, object]:
        return {"timestep": p.timestep, "diverged": p.diverged or None, "cost": p.cost,
                "figures": {m: {"value": v, "bar": p.bars[m], "unit": p.units[m]} for m, v in sorted(p.values.items())}}

    def verification(v: Verification | None) -> dict[str, object] | None:
        if v is None:
            return None
        return {"integrator": v.integrator, "timestep": v.timestep, "measured": dict(v.measured),
                "predicted": dict(v.predicted), "failures": list(v.failures), "findings": list(v.findings),
                "cost": v.cost, "met": v.met,
                "margin": v.margin, "as_is": {m: {"value": x, "how": how} for m, (x, how) in v.as_is.items()}}

    return {"model": advice.model, "own": {"integrator": advice.own[0], "timestep": advice.own[1]},
            "requirements": {r.measure: r.value for r in advice.requirements}, "horizon": advice.horizon,
            "integrators": {c.integrator: {"order": c.order, "limit": c.limit.as_dict(),
                                           "ordered": {m: list(r) for m, r in c.ordered.items()},
                                           "points": [point(p) for p in c.points]} for c in advice.curves},
            "recommended": verification(advice.recommended), "tried": [verification(v) for v in advice.tried],
            "why_none": advice.why_none or None, "rejected": dict(advice.rejected),
            "not_in_reference": dict(advice.uncovered),
            "seconds": dict(advice.seconds)}


def plot(advice: Advice) -> bytes:
    """Error against timestep per integrator, one panel per quantity measured (PNG)."""
    plt = pyplot()
    panels = [(m, label) for m, label in PANELS
              if any(math.isfinite(_value(p, m)[0]) for c in advice.curves for p in c.points if not p.diverged)]
    fig, axes = plt.subplots(1, len(panels), figsize=(FULL_WIDTH, 3.6), squeeze=False)
    for ax, (measure, label) in zip(axes[0], panels, strict=True):
        for k, curve in enumerate(advice.curves):
            look = style(curve.integrator, k)
            pts = [p for p in curve.points if not p.diverged and math.isfinite(_value(p, measure)[0])]
            if pts:
                values = [_value(p, measure) for p in pts]
                ax.errorbar([p.timestep for p in pts], [v for v, _ in values], yerr=[b for _, b in values],
                            label=curve.integrator, capsize=2, **look)
            if math.isfinite(curve.limit.timestep) and curve.limit.timestep > 0:
                ax.axvline(curve.limit.timestep, color=look.get("color"), linestyle=":", linewidth=1)
        for r in advice.requirements:
            if covered(r, measure if measure != "force" else "force.x"):
                ax.axhline(r.value, color="black", linewidth=1, label=f"required: {r.measure} ≤ {r.value:g}")
        v = advice.recommended
        if v is not None:
            shown = [x for m, x in v.measured.items() if (m == measure or (measure == "force"
                                                                           and m.startswith("force.")))]
            if shown:
                ax.plot([v.timestep], [max(shown)], marker="*", markersize=14, color="gold",
                        markeredgecolor="black", linestyle="none", label=f"recommended: {v.integrator}")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("timestep h (s); dotted: stability limits")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(loc="best")
    fig.suptitle(f"{advice.model}: error against the reference by timestep")
    return png_bytes(fig)


def _lines(said: str) -> str:
    """Text for a <pre>, line by line (html_text makes a line break in a name visible, as it must)."""
    return "\n".join(html_text(line) for line in said.split("\n"))


def html_page(advice: Sequence[Advice], plots: Sequence[bytes]) -> str:
    """A standalone page: per model, its plot and its text (every name escaped)."""
    style_css = ("body{font-family:sans-serif;max-width:72em;margin:1em auto;color:#222}"
                 "pre{white-space:pre-wrap;font-size:.8em}img{max-width:100%;display:block;margin:.5em 0}")
    body = "".join(f"<section><h2>{html_text(a.model)}</h2><img alt='error against timestep' "
                   f"src='{png_data_uri(png)}'><pre>{_lines(text(a))}</pre></section>"
                   for a, png in zip(advice, plots, strict=True))
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>mjharness advise</title>"
            f"<style>{style_css}</style></head><body><h1>Which integrator and timestep</h1>{body}</body></html>\n")

"""A convergence study as tables and a plot (the study itself: :mod:`harness.families.convergence`)."""

from __future__ import annotations

import math

import numpy as np

from harness.core.plotting import FULL_WIDTH, coinciding, png_bytes, png_data_uri, pyplot, style
from harness.core.tables import fmt, html_table, text_table
from harness.families.convergence import (
    EXPECTED_ORDER,
    ORDER_TOLERANCE,
    VERDICT_QUANTITY,
    ConvergenceStudy,
    Series,
)

__all__ = ["HEADER", "LEGEND", "html_section", "plot", "rows"]

HEADER = ("case", "integrator", "quantity", "h [ms]", "error", "order", "expected", "floor", "verdict")


def rows(study: ConvergenceStudy, *, gated: bool = True) -> list[tuple[str, ...]]:
    """Table rows (case × integrator): the gated series and unavailable integrators, or
    (``gated=False``) the series shown for information only."""
    out: list[tuple[str, ...]] = []
    for s in study.series:
        if (s.expected is not None or bool(s.note)) != gated:
            continue
        out.append((study.case, s.integrator, s.quantity, " ".join(f"{h * 1e3:g}" for h in s.dts),
                    " ".join(_point(e, st) for e, st in zip(s.errors, s.fit.status, strict=True)),
                    _order(s),
                    "exact" if s.note else fmt(s.expected, "g"), _floor(s),
                    s.verdict + (f" (known defect: {why})" if (why := study.known_defect(s)) else "")))
    if gated:
        for name, why in study.unavailable.items():
            out.append((study.case, name, "-", "-", "-", "-", fmt(float(EXPECTED_ORDER[name]), "g"), "-",
                        f"n/a: {why}"))
    return out


def _order(s: Series) -> str:
    return fmt(s.fit.order, ".2f") if math.isfinite(s.fit.order) else "-"


def _floor(s: Series) -> str:
    seen = fmt(s.fit.floor, ".1e") if s.fit.floor is not None else "none seen"
    return seen if s.predicted_floor is None else f"{seen} (doc {s.predicted_floor:.1e})"


def _point(error: float, status: str) -> str:
    """An error with its status mark: ``*`` floor, ``^`` saturated, ``!`` diverged, none when fitted."""
    mark = {"used": "", "floor": "*", "saturated": "^", "diverged": "!", "zero": "0"}[status]
    return "diverged!" if status == "diverged" else f"{error:.2e}{mark}"


LEGEND = "marks: * at the floor, ^ saturated (> 5 % of the length scale), ! diverged; unmarked points are fitted"


def text(study: ConvergenceStudy) -> str:
    """Aligned text tables for the CLI: the verdicts, then the series shown for information."""
    out = text_table(HEADER, rows(study))
    info = rows(study, gated=False)
    return out + ("\n\n" + text_table(HEADER, info) if info else "")


def plot(study: ConvergenceStudy) -> bytes:
    """Log-log error vs h across the page: the gated series per integrator (filled: fitted), the
    as-authored series for constrained cases (thin dashes), fitted lines and detected floors; integrators
    whose errors coincide drawn once and named together; the legend below the data."""
    plt = pyplot()

    fig, ax = plt.subplots(figsize=(FULL_WIDTH, 4.6), layout="constrained")
    gated = VERDICT_QUANTITY[study.constrained]
    series = {s.integrator: s for s in study.series if s.quantity == gated}
    authored = {s.integrator: s for s in study.series if s.quantity == "position" and study.constrained}
    groups = coinciding({name: np.array(s.errors) for name, s in series.items()})
    for k, (names, together) in enumerate(groups):
        s, look = series[names[0]], style(names[0], k)
        h, e = np.array(s.dts), np.array(s.errors)
        ok = np.isfinite(e) & (e > 0)
        used = np.array([st == "used" for st in s.fit.status])
        orders = "; ".join(f"order {_order(series[n])}" for n in names) if len(set(map(_order, (
            series[n] for n in names)))) > 1 else f"order {_order(s)}"
        ax.loglog(h[ok], e[ok], color=look["color"], linestyle=look["linestyle"], lw=1.3,
                  label=f"{together}: {orders} (expected {'exact' if s.note else format(s.expected, 'g')})")
        ax.loglog(h[used], e[used], look["marker"], color=look["color"], ms=6)
        ax.loglog(h[ok & ~used], e[ok & ~used], look["marker"], mfc="none", color=look["color"], ms=6)
        if used.sum() >= 2:
            p = np.polyfit(np.log(h[used]), np.log(e[used]), 1)
            hh = np.array([h[used].min(), h[used].max()])
            ax.loglog(hh, np.exp(np.polyval(p, np.log(hh))), ":", color="k", lw=0.8)
        if s.fit.floor is not None:
            ax.axhline(s.fit.floor, color=look["color"], ls="--", lw=0.6)
        for name in names:
            if name in authored:
                a = np.array(authored[name].errors)
                fine = np.isfinite(a) & (a > 0)
                ax.loglog(np.array(authored[name].dts)[fine], a[fine], "--", color=look["color"], lw=0.8, alpha=0.6)
    for name, why in study.unavailable.items():
        ax.plot([], [], " ", label=f"{name}: {why}")
    ax.plot([], [], "o", color="0.4", label="filled: fitted; open: not fitted (floor, saturated)")
    ax.plot([], [], ":", color="k", lw=0.8, label="fitted slope")
    what = "rigid-limit position error (thin dashes: as authored)" if study.constrained else "position error"
    ax.set(xlabel="timestep h [s]", ylabel="max |x_mj − x_ref| over [0, T] [m]",
           title=f"{study.case}: {what}, T = {study.horizon:g} s")
    ax.grid(True, which="both", lw=0.3)
    fig.legend(loc="outside lower center", ncol=2, frameon=False)
    return png_bytes(fig)


def html_section(study: ConvergenceStudy, png: bytes | None) -> str:
    """An HTML section (table + ``png``, the study's :func:`plot`) for the report; self-contained (PNG as data
    URI)."""
    body = rows(study) + rows(study, gated=False)
    classes = ["fail" if r[-1].startswith(("FAIL", "diverged")) else "pass" if r[-1] == "pass" else "" for r in body]
    img = f"<img src='{png_data_uri(png)}' alt='convergence plot'>" if png else ""
    gated = VERDICT_QUANTITY[study.constrained]
    return (f"<section id='converge-{study.case}'><h3>Convergence: {study.case}</h3>"
            f"<p>Error over T = {study.horizon:g} s vs timestep; the order is the log-log slope over the "
            f"asymptotic range, judged against the documented order (RK4 4, the others 1) with tolerance "
            f"{ORDER_TOLERANCE}. The gated quantity is <b>{gated}</b>"
            + (" (softness removed by extrapolating 1 − d → 0 from runs at 1 − d and 2(1 − d); "
               "'softness' is the part it removed, 'force' the multiplier error / force scale)"
               if study.constrained else "") + f". {LEGEND}.</p>"
            f"{html_table(HEADER, body, classes)}{img}</section>")

"""Layer 4, convergence study as tables and a plot (the study itself: :mod:`harness.layers.orders`)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from harness.core.plotting import png_bytes, png_data_uri, pyplot
from harness.core.tables import fmt, html_table, text_table
from harness.layers.orders import (
    EXPECTED_ORDER,
    ORDER_TOLERANCE,
    VERDICT_QUANTITY,
    ConvergenceStudy,
    Series,
)
from harness.layers.orders import convergence_study as _computed


def convergence_study(case, **options) -> ConvergenceStudy:
    """:func:`harness.layers.orders.convergence_study` with its plot (``plot_png``)."""
    study = _computed(case, **options)
    return dataclasses.replace(study, plot_png=plot_study(study))


HEADER = ("case", "integrator", "quantity", "h [ms]", "error", "order", "expected", "floor", "verdict")


def rows(study: ConvergenceStudy, *, gated: bool = True) -> list[tuple[str, ...]]:
    """Table rows (case × integrator): the gated series and unavailable integrators, or
    (``gated=False``) the series shown for information only."""
    out = []
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


def plot_study(study: ConvergenceStudy) -> bytes:
    """Log-log error vs h: the gated series per integrator (filled: fitted), the as-authored
    series for constrained cases (dashed), fitted lines and detected floors."""
    plt = pyplot()

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    gated = VERDICT_QUANTITY[study.constrained]
    for k, name in enumerate(dict.fromkeys(s.integrator for s in study.series)):
        c = colours[k % len(colours)]
        for s in study.series:
            if s.integrator != name or s.quantity not in (gated, "position"):
                continue
            h, e = np.array(s.dts), np.array(s.errors)
            ok = np.isfinite(e) & (e > 0)
            if s.quantity == gated:
                ax.loglog(h[ok], e[ok], "-", color=c, lw=1,
                          label=f"{name}: order {_order(s)} (expected "
                                f"{'exact' if s.note else format(s.expected, 'g')})")
                used = np.array([st == "used" for st in s.fit.status])
                ax.loglog(h[used], e[used], "o", color=c, ms=5)
                ax.loglog(h[ok & ~used], e[ok & ~used], "o", mfc="none", color=c, ms=5)
                if used.sum() >= 2:
                    p = np.polyfit(np.log(h[used]), np.log(e[used]), 1)
                    hh = np.array([h[used].min(), h[used].max()])
                    ax.loglog(hh, np.exp(np.polyval(p, np.log(hh))), ":", color="k", lw=0.8)
                if s.fit.floor is not None:
                    ax.axhline(s.fit.floor, color=c, ls="--", lw=0.6)
            elif study.constrained:
                ax.loglog(h[ok], e[ok], "--", color=c, lw=0.8, alpha=0.6)
    for name, why in study.unavailable.items():
        ax.plot([], [], " ", label=f"{name}: {why}")
    what = "rigid-limit position error (dashed: as authored)" if study.constrained else "position error"
    ax.set(xlabel="timestep h [s]", ylabel="max |x_mj − x_ref| over [0, T] [m]",
           title=f"{study.case}: {what}, T = {study.horizon:g} s")
    ax.legend(fontsize=7)
    ax.grid(True, which="both", lw=0.3)
    return png_bytes(fig)


def html_section(study: ConvergenceStudy) -> str:
    """An HTML section (table + plot) for the report; self-contained (PNG as data URI)."""
    body = rows(study) + rows(study, gated=False)
    classes = ["fail" if r[-1].startswith(("FAIL", "diverged")) else "pass" if r[-1] == "pass" else "" for r in body]
    img = f"<img src='{png_data_uri(study.plot_png)}' alt='convergence plot'>" if study.plot_png else ""
    gated = VERDICT_QUANTITY[study.constrained]
    return (f"<section id='converge-{study.case}'><h3>Convergence: {study.case}</h3>"
            f"<p>Error over T = {study.horizon:g} s vs timestep; the order is the log-log slope over the "
            f"asymptotic range, judged against the documented order (RK4 4, the others 1) with tolerance "
            f"{ORDER_TOLERANCE}. The gated quantity is <b>{gated}</b>"
            + (" (softness removed by extrapolating 1 − d → 0 from runs at 1 − d and 2(1 − d); "
               "'softness' is the part it removed, 'force' the multiplier error / force scale)"
               if study.constrained else "") + f". {LEGEND}.</p>"
            f"{html_table(HEADER, body, classes)}{img}</section>")

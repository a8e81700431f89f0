"""A softness study (:mod:`harness.studies.softness`) as a summary, a table and a plot."""

from __future__ import annotations

import math

import numpy as np

from harness.core.plotting import FULL_WIDTH, png_bytes, png_data_uri, pyplot, style
from harness.core.tables import fmt, html_table, text_table
from harness.studies.softness import SETTLE, SoftnessStudy

__all__ = ["html_section", "plot", "text"]

HEADER = ("case", "timeconst [s]", "eff. [s]", "d", "violation [m]", "doc", "ratio",
          "force t=0", "doc", "force settled", "position [m]")


def table_rows(study: SoftnessStudy) -> list[tuple[str, ...]]:
    """One row per setting; a setting whose run diverged says so where its violation would be."""
    return [(study.case, f"{r.timeconst:g}", f"{r.effective_timeconst:g}", f"{r.impedance:g}",
             *((r.diverged, *["-"] * 6) if r.diverged else (
                 fmt(r.violation, ".2e"), fmt(r.violation_doc, ".2e"),
                 fmt(r.violation / r.violation_doc if r.violation_doc else math.nan, ".2f"),
                 fmt(r.force_t0, ".2e"), fmt(r.force_t0_doc, ".2e"), fmt(r.force_settled, ".2e"),
                 fmt(r.position, ".2e")))) for r in study.rows]


def summary(study: SoftnessStudy) -> str:
    """One paragraph: the fitted exponents against the documented ones, the best setting, the settings whose
    runs diverged."""
    diverged = [r for r in study.rows if r.diverged]
    tail = "".join(f" timeconst {r.timeconst:g} s, d {r.impedance:g}: {r.diverged}." for r in diverged)
    ran = [r for r in study.rows if not r.diverged]
    if not ran:
        return f"{study.case}: every setting diverged:{tail}"
    best = min(ran, key=lambda r: r.violation)
    text = (f"{study.case}: {study.integrator} at h = {study.timestep:g} s over {study.horizon:g} s, "
            f"equalities {', '.join(study.constraints)}. Forces are |λ_mj − λ_ref| / force scale "
            f"(worst constraint); 'force settled' from t = {SETTLE:g} × effective timeconst. ")
    if study.fit is not None:
        text += (f"Violation ∝ (1 − d)^{study.fit.impedance_exponent:.2f} · timeconst^"
                 f"{study.fit.timeconst_exponent:.2f} (documented: 1 and 2). ")
    return text + (f"Stiffest: timeconst {best.timeconst:g} s, d {best.impedance:g}: violation "
                   f"{best.violation:.1e} m, force error {best.force_t0:.1e} at t = 0, "
                   f"{fmt(best.force_settled, '.1e')} settled.") + tail


def text(study: SoftnessStudy) -> str:
    return summary(study) + "\n" + text_table(HEADER, table_rows(study))


def plot(study: SoftnessStudy) -> bytes:
    """Violation and force error at t = 0 vs 1 − d, one colour per timeconst; markers measured,
    lines documented."""
    plt = pyplot()

    fig, axes = plt.subplots(1, 2, figsize=(FULL_WIDTH, 3.9), layout="constrained")
    for k, tc in enumerate(dict.fromkeys(r.timeconst for r in study.rows)):
        rs = [r for r in study.rows if r.timeconst == tc]
        eps = [1 - r.impedance for r in rs]
        look = style("", k)
        c, marker = look["color"], look["marker"]
        axes[0].loglog(eps, [r.violation for r in rs], marker, color=c, label=f"timeconst {tc:g} s: measured")
        axes[0].loglog(eps, [r.violation_doc for r in rs], "-", color=c, lw=0.8)
        axes[1].loglog(eps, [r.force_t0 for r in rs], marker, color=c)
        axes[1].loglog(eps, [r.force_t0_doc for r in rs], "-", color=c, lw=0.8)
        settled = [(e, r.force_settled) for e, r in zip(eps, rs, strict=True) if np.isfinite(r.force_settled)]
        if settled:
            axes[1].loglog(*zip(*settled, strict=True), "x", color=c, ms=7)
    axes[0].plot([], [], "-", color="0.3", lw=0.8, label="documented (line)")
    axes[0].plot([], [], "x", color="0.3", label="force error once settled (right)")
    axes[0].set(xlabel="1 − d", ylabel="max |violation| [m]", title="violation vs documented sag")
    axes[1].set(xlabel="1 − d", ylabel="|λ_mj − λ_ref| / force scale",
                title="force error at t = 0 vs documented; settled (x)")
    for ax in axes:
        ax.grid(True, which="both", lw=0.3)
    fig.legend(loc="outside lower center", ncol=3, frameon=False)
    fig.suptitle(f"{study.case}: softness of the equalities ({study.integrator}, h = {study.timestep:g} s)")
    return png_bytes(fig)


def html_section(study: SoftnessStudy, png: bytes | None) -> str:
    """An HTML section (summary, table, ``png``: the study's :func:`plot`) for the report."""
    img = f"<img src='{png_data_uri(png)}' alt='softness plot'>" if png else ""
    return (f"<section id='softness-{study.case}'><h3>Constraint softness: {study.case}</h3>"
            f"<p>{summary(study)} 'doc' columns: the violation r = a_u (1 − d) timeconst² dampratio² "
            f"(modeling.rst, Solver parameters), i.e. −(1 − d) timeconst² dampratio² A_ii λ_i along the "
            f"reference (timeconst clamped to ≥ 2h by refsafe), and the force error (A + R)⁻¹Rλ(0), "
            f"R_ii = (1 − d)/d A_ii.</p>"
            f"{html_table(HEADER, table_rows(study))}{img}</section>")

"""A solver study (:mod:`harness.studies.solvers`) as a summary, a table and a plot."""

from __future__ import annotations

import numpy as np

from harness.core.plotting import FULL_WIDTH, png_bytes, png_data_uri, pyplot, style
from harness.core.tables import fmt, html_table, text_table
from harness.studies.solvers import SolverStudy

__all__ = ["html_section", "plot", "text"]

HEADER = ("case", "solver", "force error", "vs first", "position [m]", "iterations mean", "max", "limit", "note")


def table_rows(study: SolverStudy) -> list[tuple[str, ...]]:
    """One row per solver; a solver whose run diverged says so in its note."""
    return [(study.case, r.solver, *(["-"] * 6 if r.diverged else [
                fmt(r.force, ".2e"), fmt(r.force_vs_first, ".1e"), fmt(r.position, ".2e"),
                f"{r.iterations_mean:.2f}", str(r.iterations_max), str(r.iteration_limit)]),
             r.diverged or ("hit the iteration limit" if r.iterations_max >= r.iteration_limit else ""))
            for r in study.rows]


def summary(study: SolverStudy) -> str:
    return (f"{study.case}: {study.integrator} at h = {study.timestep:g} s over {study.horizon:g} s, "
            f"tolerance {study.tolerance:g}; force error = max |λ_mj − λ_ref| / force scale (worst constraint, "
            f"t ≥ the case's settle time); 'vs first' = max |λ − λ_{study.rows[0].solver}| / force scale, the "
            f"solvers' own disagreement; iterations of the solve at each recorded state.")


def text(study: SolverStudy) -> str:
    return summary(study) + "\n" + text_table(HEADER, table_rows(study))


def plot(study: SolverStudy) -> bytes:
    """Force error and iterations over time, one curve per solver whose run did not diverge."""
    plt = pyplot()

    fig, axes = plt.subplots(2, 1, figsize=(FULL_WIDTH, 4.8), sharex=True, layout="constrained")
    every = max(1, min(len(s.t) for s in study.series) // 12) if study.series else 1
    for k, s in enumerate(study.series):
        look = style("", k)
        axes[0].semilogy(s.t, np.maximum(s.force, 1e-16), lw=1, ms=4, markevery=(k * every // 4, every),
                         label=s.solver, **look)
        axes[1].plot(s.t, s.iterations, lw=1, ms=4, markevery=(k * every // 4, every), **look)
    axes[0].set(ylabel="|λ_mj − λ_ref| / force scale", title=f"{study.case}: solvers ({study.integrator}, "
                f"h = {study.timestep:g} s)")
    axes[1].set(xlabel="t [s]", ylabel="solver iterations")
    for ax in axes:
        ax.grid(True, which="major", lw=0.3)
    fig.legend(loc="outside right upper", frameon=False)
    return png_bytes(fig)


def html_section(study: SolverStudy, png: bytes | None) -> str:
    """An HTML section (summary, table, ``png``: the study's :func:`plot`) for the report."""
    img = f"<img src='{png_data_uri(png)}' alt='solver plot'>" if png else ""
    return (f"<section id='solvers-{study.case}'><h3>Solvers: {study.case}</h3><p>{summary(study)}</p>"
            f"{html_table(HEADER, table_rows(study))}{img}</section>")

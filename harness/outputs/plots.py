"""A case's report plots: trajectory overlay, error per integrator, constraint forces, invariant drift.

Each plot is drawn at the width the page shows it (:data:`~harness.core.plotting.HALF_WIDTH`, two side by
side), so its 9 pt labels stay 11 px; legends sit below the axes, never on the data. Integrators keep one
colour, dash and marker in every plot, errors are on log scales, and integrators whose curves coincide
are drawn once and named together ("Euler = implicitfast = discrete (identical)").
"""

from __future__ import annotations

import html

import numpy as np

from harness.core.escape import html_attr
from harness.core.plotting import HALF_WIDTH, coinciding, png_bytes, png_data_uri, pyplot, style
from harness.core.trajectory import Trajectory
from harness.families.runs import point_differences
from harness.pipeline.run import CaseResult

__all__ = ["section_plots", "shipped_integrator"]

FLOOR = 1e-16  # errors below this are drawn at it (a log axis has no zero)
MARKERS = 12  # markers per curve: enough to tell dashes apart, few enough not to hide the line


def position_error(ref: Trajectory, sim: Trajectory) -> np.ndarray:
    """The worst named point's distance from the reference's, sample by sample (the two on one grid)."""
    return np.max(np.linalg.norm(point_differences(sim.positions, ref.positions), axis=-1), axis=1)


def _png(fig) -> str:
    return png_data_uri(png_bytes(fig, dpi="figure"))


def _figure(rows: int = 1, height: float = 3.3):
    return pyplot().subplots(rows, 1, figsize=(HALF_WIDTH, height), sharex=True, squeeze=False,
                             layout="constrained")


def _legend(fig, *axes, columns: int = 2) -> None:
    """One legend for ``axes`` (each label once), below the plot, outside the data."""
    entries: dict[str, object] = {}
    for ax in axes:
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            entries.setdefault(label, handle)
    if entries:
        fig.legend(list(entries.values()), list(entries), loc="outside lower center",
                   ncol=min(columns, len(entries)), frameon=False)


def shipped_integrator(result: CaseResult) -> str:
    """The integrator the model ships with, or the first one run if that one was not."""
    name = result.settings.integrator
    return name if name in result.simulations else next(iter(result.simulations))


def _log_curves(ax, t: np.ndarray, curves: dict[str, np.ndarray]) -> None:
    """One log-scale curve per group of coinciding ``curves``, styled by its first member."""
    every = max(1, len(t) // MARKERS)
    for k, (names, label) in enumerate(coinciding(curves)):
        ax.semilogy(t, np.maximum(curves[names[0]], FLOOR), lw=1.2, ms=4, markevery=(k * every // 5, every),
                    label=label, **style(names[0], k))


def plot_overlay(result: CaseResult) -> str:
    """World coordinates of each point: reference (line) vs MuJoCo's shipped integrator (dashed)."""
    ref, sim = result.reference, result.simulations[shipped_integrator(result)]
    assert ref is not None  # plotted only of a run that kept its reference (not a figures-only one)
    fig, axes = _figure()
    ax = axes[0, 0]
    k = 0
    for p in ref.positions:
        for j, axis in enumerate("xyz"):
            if np.ptp(ref.positions[p][:, j]) < 1e-9:
                continue
            colour = style("", k)["color"]
            ax.plot(ref.t, ref.positions[p][:, j], lw=2.2, alpha=0.45, color=colour, label=f"{p}.{axis} reference")
            ax.plot(sim.t, sim.positions[p][:, j], "--", lw=1, color=colour, label=f"{p}.{axis} {sim.source}")
            k += 1
    ax.set(xlabel="t [s]", ylabel="position [m]", title="Trajectory: reference (wide) and MuJoCo (dashed)")
    _legend(fig, ax)
    return _png(fig)


def plot_errors(result: CaseResult) -> str:
    """Position error vs time for every integrator (log scale; coinciding integrators drawn once)."""
    ref = result.reference
    assert ref is not None  # plotted only of a run that kept its reference (not a figures-only one)
    fig, axes = _figure()
    ax = axes[0, 0]
    t = ref.t[1:]
    _log_curves(ax, t, {name: position_error(ref, sim)[1:]
                        for name, sim in result.simulations.items()})
    ax.set(xlabel="t [s]", ylabel="|x_mj − x_ref| [m]", title="Position error vs time, per integrator")
    ax.grid(True, which="major", lw=0.3)
    _legend(fig, ax)
    return _png(fig)


def plot_forces(result: CaseResult) -> str | None:
    """Each multiplier: reference λ vs MuJoCo's constraint force (shipped integrator) above, and their
    difference below on a log scale, so the first instants do not flatten the rest; the settle time after
    which force figures are taken is marked."""
    ref, sim = result.reference, result.simulations[shipped_integrator(result)]
    assert ref is not None  # plotted only of a run that kept its reference (not a figures-only one)
    names = [c for c in ref.multipliers if c in sim.multipliers]
    if not names:
        return None
    fig, axes = _figure(2, 4.6)
    top, bottom = axes[0, 0], axes[1, 0]
    diffs = {}
    for k, c in enumerate(names):
        colour = style("", k)["color"]
        top.plot(ref.t, ref.multipliers[c], lw=2.2, alpha=0.45, color=colour, label=f"λ_{c} reference")
        top.plot(sim.t, sim.multipliers[c], "--", lw=1, color=colour, label=f"{c}: MuJoCo ({sim.source})")
        diffs[f"{c}: |MuJoCo − reference|"] = np.abs(sim.multipliers[c] - ref.multipliers[c])
    _log_curves(bottom, sim.t, diffs)
    settle = float(result.case.settle) if result.case is not None else 0.0
    if settle > 0:
        bottom.axvline(settle, color="k", ls=":", lw=1, label=f"settle time {settle:g} s (gated after it)")
    top.set(ylabel="force [N]", title="Constraint force: multiplier vs efc_force")
    bottom.set(xlabel="t [s]", ylabel="|MuJoCo − reference| [N]")
    bottom.grid(True, which="major", lw=0.3)
    _legend(fig, top, bottom)
    return _png(fig)


def plot_invariants(result: CaseResult) -> str | None:
    """Drift of each invariant of MuJoCo's own state, per integrator (|I(t) − I(0)|, log)."""
    ref = result.reference
    assert ref is not None  # plotted only of a run that kept its reference (not a figures-only one)
    names = list(ref.invariants)
    if not names:
        return None
    fig, axes = _figure(len(names), 1.2 + 2.1 * len(names))
    for ax, inv in zip(axes[:, 0], names, strict=True):
        drifts = {name: np.abs(sim.invariants[inv] - sim.invariants[inv][0])[1:]
                  for name, sim in result.simulations.items() if inv in sim.invariants}
        _log_curves(ax, ref.t[1:], drifts)
        ax.set(ylabel=f"|{inv}(t) − {inv}(0)|", title=f"{inv} drift of MuJoCo's own state")
        ax.grid(True, which="major", lw=0.3)
    axes[-1, 0].set(xlabel="t [s]")
    _legend(fig, *axes[:, 0])
    return _png(fig)


PLOTS = (("overlay", plot_overlay), ("errors", plot_errors), ("forces", plot_forces),
         ("invariants", plot_invariants))


def section_plots(result: CaseResult) -> str:
    """The case's plots, of every run that did not diverge, and a note naming those that did."""
    diverged = {run: why for run, why in result.diverged.items()
                if run not in result.simulations and not run.startswith("instant.")}  # (not runs: figures)
    note = ("<p class='note'>Not plotted: " + "; ".join(f"{html.escape(run)} {html.escape(why)}"
                                                        for run, why in diverged.items()) + "</p>") if diverged else ""
    if not result.simulations:
        return note
    drawn = [(name, fn(result)) for name, fn in PLOTS]
    return note + "".join(f"<img class='plot' src='{uri}' alt='{name} plot of {html_attr(result.case.name)}'>"
                          for name, uri in drawn if uri)

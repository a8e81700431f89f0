"""A case's report plots: trajectory overlay, error per integrator, constraint forces, invariant drift."""

from __future__ import annotations

import html

import numpy as np

from harness.core.plotting import png_bytes, png_data_uri, pyplot
from harness.layers.trajectory import error_series
from harness.pipeline.run import CaseResult


def _png(fig) -> str:
    return png_data_uri(png_bytes(fig, dpi="figure"))


def shipped_integrator(result: CaseResult) -> str:
    """The integrator the model ships with, or the first one run if that one was not."""
    name = str(result.settings["integrator"])
    return name if name in result.simulations else next(iter(result.simulations))


def plot_overlay(result: CaseResult) -> str:
    """World coordinates of each point: reference (line) vs MuJoCo's shipped integrator (dashed)."""
    ref, sim = result.reference, result.simulations[shipped_integrator(result)]
    fig, ax = pyplot().subplots(figsize=(6.4, 3.0))
    for p in ref.positions:
        for k, axis in enumerate("xyz"):
            if np.ptp(ref.positions[p][:, k]) < 1e-9:
                continue
            ax.plot(ref.t, ref.positions[p][:, k], lw=1.5, label=f"{p}.{axis} reference")
            ax.plot(sim.t, sim.positions[p][:, k], "--", lw=1, label=f"{p}.{axis} {sim.source}")
    ax.set(xlabel="t [s]", ylabel="position [m]", title="Trajectory overlay")
    ax.legend(fontsize=7, ncol=2)
    return _png(fig)


def plot_errors(result: CaseResult) -> str:
    """Position error vs time for every integrator (log scale)."""
    fig, ax = pyplot().subplots(figsize=(6.4, 3.0))
    for name, sim in result.simulations.items():
        err = error_series(result.reference, sim)["position"]
        ax.semilogy(sim.t[1:], np.maximum(err[1:], 1e-16), lw=1, label=name)
    ax.set(xlabel="t [s]", ylabel="|x_mj − x_ref| [m]", title="Position error vs time")
    ax.legend(fontsize=7)
    return _png(fig)


def plot_forces(result: CaseResult) -> str | None:
    """Each multiplier: reference λ vs MuJoCo's constraint force (shipped integrator)."""
    ref, sim = result.reference, result.simulations[shipped_integrator(result)]
    names = [c for c in ref.multipliers if c in sim.multipliers]
    if not names:
        return None
    fig, axes = pyplot().subplots(2, 1, figsize=(6.4, 4.2), sharex=True, layout="constrained")
    for c in names:
        axes[0].plot(ref.t, ref.multipliers[c], lw=1.5, label=f"λ_{c} reference")
        axes[0].plot(sim.t, sim.multipliers[c], "--", lw=1, label=f"{c} MuJoCo ({sim.source})")
        axes[1].plot(sim.t, sim.multipliers[c] - ref.multipliers[c], lw=1, label=c)
    axes[0].set(ylabel="force [N]", title="Constraint force: multiplier vs efc_force")
    axes[1].set(xlabel="t [s]", ylabel="MuJoCo − reference [N]")
    axes[0].legend(fontsize=7)
    axes[1].legend(fontsize=7)
    return _png(fig)


def plot_invariants(result: CaseResult) -> str:
    """Drift of each invariant of MuJoCo's own state, per integrator (|I(t) − I(0)|, log)."""
    names = list(result.reference.invariants)
    fig, axes = pyplot().subplots(len(names), 1, figsize=(6.4, 2.6 * len(names)), squeeze=False,
                             layout="constrained")
    for ax, inv in zip(axes[:, 0], names, strict=True):
        for name, sim in result.simulations.items():
            if inv in sim.invariants:
                drift = np.abs(sim.invariants[inv] - sim.invariants[inv][0])
                ax.semilogy(sim.t[1:], np.maximum(drift[1:], 1e-16), lw=1, label=name)
        ax.set(xlabel="t [s]", ylabel=f"|{inv}(t) − {inv}(0)|", title=f"{inv} drift")
        ax.legend(fontsize=7)
    return _png(fig)


def section_plots(result: CaseResult) -> str:
    """The case's plots, of every run that did not diverge, and a note naming those that did."""
    diverged = {run: why for run, why in result.diverged.items() if run not in result.simulations}
    note = ("<p class='note'>Not plotted: " + "; ".join(f"{html.escape(run)} {html.escape(why)}"
                                                        for run, why in diverged.items()) + "</p>") if diverged else ""
    if not result.simulations:
        return note
    plots = [plot_overlay(result), plot_errors(result), plot_forces(result), plot_invariants(result)]
    return note + "".join(f"<img src='{p}' alt='plot'>" for p in plots if p)

"""The backends side by side: every gated figure of every case on each backend, the error-vs-time plot of
each backend's run against the reference, and the findings — figures a backend gets wrong beyond its own
budget (float32 round-off included) where the C engine gets them right.

A finding is for that backend's users: the same model, the same physics and the same budget rule, and a
residual the backend's own settings and arithmetic do not explain.
"""

from __future__ import annotations

import html
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from harness.core.checks import Check
from harness.core.plotting import FULL_WIDTH, png_bytes, png_data_uri, pyplot, style
from harness.pipeline.run import CaseResult

__all__ = ["BackendRun", "findings", "side_by_side_html", "side_by_side_json"]


@dataclass(frozen=True)
class BackendRun:
    """One backend's results and checks over the selected cases."""

    name: str
    precision: str
    results: Sequence[CaseResult]
    checks: Mapping[str, Sequence[Check]]


@dataclass(frozen=True)
class BackendFinding:
    """A figure a backend fails on a case where the reference backend (C) passes it."""

    backend: str
    case: str
    figure: str
    measured: float
    unexplained: float | None
    limit: float
    unit: str
    reference_verdict: str

    def line(self) -> str:
        unexplained = "" if self.unexplained is None else f", unexplained {self.unexplained:.3e}"
        return (f"{self.backend}: {self.case} {self.figure} measured {self.measured:.3e} {self.unit}{unexplained} > "
                f"limit {self.limit:.3e} (C engine: {self.reference_verdict})")


def _verdict(check: Check | None) -> str:
    if check is None:
        return "not run"
    if check.note:
        return "n/a"
    return "pass" if check.passed else "FAIL"


def findings(runs: Sequence[BackendRun]) -> list[BackendFinding]:
    """Every check a backend after the first fails where the first (the C engine) passes or did not run it."""
    first, rest = runs[0], runs[1:]
    out = []
    for run in rest:
        for case, checks in run.checks.items():
            ref = {c.name: c for c in first.checks.get(case, ())}
            for c in checks:
                if c.passed or c.note:
                    continue
                if ref.get(c.name) is not None and not ref[c.name].passed:
                    continue  # the C engine fails it too: a fault of the model, not of this backend
                out.append(BackendFinding(
                    backend=run.name, case=case, figure=str(c.name), measured=float(c.value),
                    unexplained=None if c.budget is None else float(c.budget.unexplained),
                    limit=float(c.budget.limit if c.budget is not None else c.threshold), unit=c.unit,
                    reference_verdict=_verdict(ref.get(c.name))))
    return out


def _cell(check: Check | None) -> str:
    if check is None:
        return "<td>—</td>"
    verdict = _verdict(check)
    if check.diverged:
        return f"<td class='fail'>{html.escape(check.diverged)}</td>"
    used = ""
    if check.budget is not None and check.budget.limit > 0:
        used = f" ({100 * check.budget.unexplained / check.budget.limit:.0f} %)"
    css = "pass" if verdict in ("pass", "n/a") else "fail"
    return f"<td class='{css}'>{check.value:.3e}{used} {verdict}</td>"


def _position_error(result: CaseResult, integrator: str) -> tuple[np.ndarray, np.ndarray] | None:
    sim, ref = result.simulations.get(integrator), result.reference
    if sim is None or ref is None:
        return None
    err = np.zeros(len(sim.t))
    for point, positions in sim.positions.items():
        if point in ref.positions:
            err = np.maximum(err, np.linalg.norm(positions - ref.positions[point], axis=1))
    return sim.t, err


def _plot(case: str, runs: Sequence[BackendRun]) -> str:
    """Position error against the reference over time, the model's own integrator, one line per backend."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(FULL_WIDTH / 2, 3.0))
    drawn = False
    for k, run in enumerate(runs):
        result = next((r for r in run.results if r.case.name == case), None)
        if result is None:
            continue
        integrator = result.settings.integrator
        series = _position_error(result, integrator)
        if series is None:
            continue
        t, err = series
        label = f"{run.name} ({run.precision}, {integrator})"
        ax.semilogy(t, np.maximum(err, 1e-17), label=label, **style(run.name, k))
        drawn = True
    if not drawn:
        plt.close(fig)
        return ""
    ax.set_xlabel("t (s)")
    ax.set_ylabel("position error (m)")
    ax.set_title(f"{case}: each backend against the reference")
    ax.legend(fontsize=7)
    return f"<img alt='{html.escape(case)} error vs time per backend' src='{png_data_uri(png_bytes(fig))}'>"


def side_by_side_html(runs: Sequence[BackendRun]) -> str:
    """The section: per case, a table of every gated figure on every backend and the error-vs-time plot;
    then every finding."""
    parts = ["<section id='backends'><h2>Backends side by side</h2>",
             "<p>Every backend runs the same layers and budgets (its round-off part from its own arithmetic: "
             + ", ".join(f"{html.escape(r.name)} {r.precision}" for r in runs)
             + "). A cell: measured, the share of the limit the unexplained residual uses, the verdict.</p>"]
    cases = list(dict.fromkeys(c for run in runs for c in run.checks))
    for case in cases:
        names = list(dict.fromkeys(str(c.name) for run in runs for c in run.checks.get(case, ())))
        by_run = [{str(c.name): c for c in run.checks.get(case, ())} for run in runs]
        head = "".join(f"<th>{html.escape(r.name)}</th>" for r in runs)
        rows = "".join(f"<tr><td>{html.escape(n)}</td>{''.join(_cell(b.get(n)) for b in by_run)}</tr>" for n in names)
        parts.append(f"<h3>{html.escape(case)}</h3>{_plot(case, runs)}"
                     f"<table class='checks'><tr><th>figure</th>{head}</tr>{rows}</table>")
    found = findings(runs)
    parts.append("<h3>Findings for the backends' users</h3>")
    if found:
        parts.append("<ul>" + "".join(f"<li>{html.escape(f.line())}</li>" for f in found) + "</ul>")
    else:
        parts.append("<p>None: every backend's figures lie within their budgets wherever the C engine's do.</p>")
    parts.append("</section>")
    return "".join(parts)


def _check_json(c: Check) -> dict[str, object]:
    return {"value": c.value, "verdict": _verdict(c), "unexplained": None if c.budget is None else c.budget.unexplained,
            "limit": c.budget.limit if c.budget else c.threshold}


def side_by_side_json(runs: Sequence[BackendRun]) -> dict[str, object]:
    """The same as JSON: each backend's checks by case, and the findings."""
    return {
        "backends": [{"name": r.name, "precision": r.precision,
                      "checks": {case: {str(c.name): _check_json(c) for c in checks}
                                 for case, checks in r.checks.items()}} for r in runs],
        "findings": [dict(f.__dict__) for f in findings(runs)],
    }

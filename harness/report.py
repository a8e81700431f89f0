"""Reports: one self-contained HTML page, a Markdown summary and a JSON of every figure.

A builder collects independent sections; each section is a function of one
CaseResult (plus its checks) returning HTML. Plots are PNGs embedded as data
URIs, so the page opens offline. Nothing time- or machine-dependent beyond
the versions is written, so identical inputs give byte-identical files.
Files are written to a temporary directory and moved into place, so a failed
run never leaves a half-written report.
"""

from __future__ import annotations

import base64
import html
import io
import json
import os
import platform
import shutil
import tempfile
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import mujoco
import numpy as np

from harness import __version__
from harness.compare import error_series
from harness.pipeline import CaseResult
from harness.verdict import Check

plt.rcParams.update({"figure.dpi": 90, "font.size": 9, "svg.hashsalt": "mjharness"})


def versions() -> dict[str, str]:
    import scipy
    import sympy

    return {"mjharness": __version__, "mujoco": mujoco.__version__, "numpy": np.__version__,
            "scipy": scipy.__version__, "sympy": sympy.__version__,
            "python": platform.python_version()}


# ----------------------------------------------------------------- plots
def _png(fig: plt.Figure) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None}, bbox_inches="tight")
    plt.close(fig)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _shipped(result: CaseResult) -> str:
    name = str(result.settings["integrator"])
    return name if name in result.simulations else next(iter(result.simulations))


def plot_overlay(result: CaseResult) -> str:
    """World coordinates of each point: reference (line) vs MuJoCo's shipped integrator (dashed)."""
    ref, sim = result.reference, result.simulations[_shipped(result)]
    fig, ax = plt.subplots(figsize=(6.4, 3.0))
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
    fig, ax = plt.subplots(figsize=(6.4, 3.0))
    for name, sim in result.simulations.items():
        err = error_series(result.reference, sim)["position"]
        ax.semilogy(sim.t[1:], np.maximum(err[1:], 1e-16), lw=1, label=name)
    ax.set(xlabel="t [s]", ylabel="|x_mj − x_ref| [m]", title="Position error vs time")
    ax.legend(fontsize=7)
    return _png(fig)


def plot_forces(result: CaseResult) -> str | None:
    """Each multiplier: reference λ vs MuJoCo's constraint force (shipped integrator)."""
    ref, sim = result.reference, result.simulations[_shipped(result)]
    names = [c for c in ref.multipliers if c in sim.multipliers]
    if not names:
        return None
    fig, axes = plt.subplots(2, 1, figsize=(6.4, 4.2), sharex=True)
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
    fig, axes = plt.subplots(len(names), 1, figsize=(6.4, 2.6 * len(names)), squeeze=False)
    for ax, inv in zip(axes[:, 0], names, strict=True):
        for name, sim in result.simulations.items():
            if inv in sim.invariants:
                drift = np.abs(sim.invariants[inv] - sim.invariants[inv][0])
                ax.semilogy(sim.t[1:], np.maximum(drift[1:], 1e-16), lw=1, label=name)
        ax.set(xlabel="t [s]", ylabel=f"|{inv}(t) − {inv}(0)|", title=f"{inv} drift")
        ax.legend(fontsize=7)
    return _png(fig)


# -------------------------------------------------------------- sections
def _fmt(value: float) -> str:
    return f"{value:.3e}" if np.isfinite(value) else str(value)


def _checks_table(checks: Sequence[Check]) -> str:
    rows = "".join(
        f"<tr class='{'pass' if c.passed else 'fail'}'><td>{html.escape(c.name)}</td>"
        f"<td>{_fmt(c.value)}</td><td>{_fmt(c.threshold)}</td><td>{html.escape(c.unit)}</td>"
        f"<td>{'PASS' if c.passed else 'FAIL'}</td></tr>" for c in checks)
    return ("<table><tr><th>check</th><th>figure</th><th>threshold</th><th>unit</th>"
            f"<th>verdict</th></tr>{rows}</table>")


def section_summary(results: Sequence[CaseResult], checks: dict[str, list[Check]]) -> str:
    rows = []
    for r in results:
        cs = checks[r.case.name]
        failed = [c.name for c in cs if not c.passed]
        verdict = "PASS" if not failed else "FAIL"
        rows.append(f"<tr class='{verdict.lower()}'><td><a href='#{r.case.name}'>{r.case.name}</a></td>"
                    f"<td>{len(cs) - len(failed)}/{len(cs)}</td><td>{verdict}</td>"
                    f"<td>{html.escape(', '.join(failed))}</td></tr>")
    return ("<h2>Summary</h2><table><tr><th>case</th><th>checks passed</th><th>verdict</th>"
            f"<th>failed checks</th></tr>{''.join(rows)}</table>")


def section_case(result: CaseResult, checks: list[Check]) -> str:
    c = result.case
    gated = {ch.name for ch in checks}
    info = "".join(f"<tr><td>{html.escape(f.name)}</td><td>{_fmt(f.value)}</td>"
                   f"<td>{html.escape(f.unit)}</td><td>{html.escape(f.description)}</td></tr>"
                   for f in result.figures if f.name not in gated)
    settings = "".join(f"<tr><td>{html.escape(k)}</td><td>{html.escape(str(v))}</td></tr>"
                       for k, v in result.settings.items())
    plots = [plot_overlay(result), plot_errors(result), plot_forces(result), plot_invariants(result)]
    imgs = "".join(f"<img src='{p}' alt='plot'>" for p in plots if p)
    return (f"<section id='{c.name}'><h2>{c.name}</h2><p>{html.escape(c.description)}</p>"
            f"<h3>Gated checks</h3>{_checks_table(checks)}<h3>Plots</h3>{imgs}"
            f"<h3>Other figures (not gated)</h3><table><tr><th>figure</th><th>value</th><th>unit</th>"
            f"<th>meaning</th></tr>{info}</table>"
            f"<h3>Settings</h3><table>{settings}</table></section>")


_STYLE = """
body{font-family:sans-serif;max-width:60em;margin:1em auto;color:#222}
table{border-collapse:collapse;margin:.5em 0;font-size:.85em}
td,th{border:1px solid #ccc;padding:2px 6px;text-align:left}
tr.pass td:last-child{color:#070} tr.fail td{background:#fdd}
tr.fail td:last-child{color:#b00;font-weight:bold} img{max-width:100%;display:block;margin:.5em 0}
"""


def render_html(results: Sequence[CaseResult], checks: dict[str, list[Check]]) -> str:
    ver = ", ".join(f"{k} {v}" for k, v in versions().items())
    body = section_summary(results, checks) + "".join(
        section_case(r, checks[r.case.name]) for r in results)
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>mjharness report</title>"
            f"<style>{_STYLE}</style></head><body><h1>mjharness report</h1>"
            f"<p>How to read: each check is a measured figure beside its threshold (a measured value "
            f"times a stated margin, see pyproject.toml). Figures named INTEGRATOR.* come from a run "
            f"of that MuJoCo integrator against our reference; instant.* from sampled states without "
            f"time integration; reference.* judge the reference itself.</p>"
            f"<p>Versions: {html.escape(ver)}</p>{body}</body></html>\n")


def render_markdown(results: Sequence[CaseResult], checks: dict[str, list[Check]]) -> str:
    lines = ["# mjharness summary", "", "| case | check | figure | threshold | verdict |",
             "|---|---|---|---|---|"]
    for r in results:
        for c in checks[r.case.name]:
            lines.append(f"| {r.case.name} | {c.name} | {_fmt(c.value)} | {_fmt(c.threshold)} | "
                         f"{'pass' if c.passed else '**FAIL**'} |")
    return "\n".join(lines) + "\n"


def render_json(results: Sequence[CaseResult], checks: dict[str, list[Check]]) -> str:
    doc = {"versions": versions(), "cases": {}}
    for r in results:
        doc["cases"][r.case.name] = {
            "figures": {f.name: f.as_dict() for f in r.figures},
            "checks": {c.name: {"value": c.value, "threshold": c.threshold, "passed": c.passed}
                       for c in checks[r.case.name]},
            "settings": r.settings,
        }
    return json.dumps(doc, indent=1, sort_keys=True, default=float) + "\n"


def prepare_output(out: Path) -> Path:
    """Create ``out`` if needed; ValueError if it cannot be created or written."""
    out = Path(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"cannot create output directory {str(out)!r}: {exc.strerror}") from None
    if not os.access(out, os.W_OK):
        raise ValueError(f"output directory {str(out)!r} is not writable")
    return out


def write_report(out: Path, results: Sequence[CaseResult], checks: dict[str, list[Check]]) -> list[Path]:
    """Write report.html, report.json and summary.md into ``out`` atomically (all or nothing)."""
    out = prepare_output(out)
    files = {"report.html": render_html(results, checks), "report.json": render_json(results, checks),
             "summary.md": render_markdown(results, checks)}
    tmp = Path(tempfile.mkdtemp(prefix=".mjharness-", dir=out))
    try:
        for name, text in files.items():
            (tmp / name).write_text(text, encoding="utf-8")
        for name in files:
            os.replace(tmp / name, out / name)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return [out / name for name in files]

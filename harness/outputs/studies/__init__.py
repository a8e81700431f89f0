"""Layer 4 for people: each study's text, HTML section and plot (one module per study), and the studies page.

A plot is drawn apart from its section (:data:`PLOTS`), so that the report's workers draw them in parallel
(harness/outputs/drawings.py); the sections take the PNG bytes drawn, keyed like the report's calls:
``(kind, case)``, e.g. ``("convergence", "pendulum")``.
"""

from __future__ import annotations

import html
from collections.abc import Callable, Mapping

from harness.core.tables import text_table
from harness.families import convergence as orders
from harness.outputs.studies import contact, convergence, softness, solvers
from harness.studies import Studies

__all__ = ["PLOTS", "draw", "html_page", "html_section", "text"]

PLOTS: Mapping[str, Callable[..., bytes]] = {
    "convergence": convergence.plot, "softness": softness.plot, "solvers": solvers.plot, "contact": contact.plot}
"""Each kind of study's plot, as PNG bytes."""


def draw(studies: Studies) -> dict[tuple[str, str], bytes]:
    """Every study's plot, drawn here one after another, by ``(kind, case)``."""
    return {(kind, study.case): PLOTS[kind](study)
            for kind, group in (("convergence", studies.convergence), ("softness", studies.softness),
                                ("solvers", studies.solvers)) for study in group}


def text(studies: Studies) -> str:
    """Everything as aligned text: one convergence table, then the softness and solver tables."""
    gated = [r for st in studies.convergence for r in convergence.rows(st)]
    info = [r for st in studies.convergence for r in convergence.rows(st, gated=False)]
    parts = ["Convergence: error over [0, T] vs timestep h; order = log-log slope over the fitted points, "
             "expected = the documented order (pass: order ≥ expected − "
             f"{orders.ORDER_TOLERANCE:g}); constrained cases are judged on the rigid limit.",
             text_table(convergence.HEADER, gated) if gated else "(no cases)"]
    if info:
        parts += ["", "Not gated: constrained cases' position as authored, the softness part the rigid limit "
                      "removes, and the force error / force scale (doc: the documented softness floor).",
                  text_table(convergence.HEADER, info)]
    parts.append(convergence.LEGEND + ".")
    for st in studies.softness:
        parts += ["", "Softness " + softness.text(st)]
    for solver_study in studies.solvers:
        parts += ["", "Solvers " + solvers.text(solver_study)]
    failed = studies.failures
    parts += ["", f"{sum(len(s.verdicts) for s in studies.convergence) - len(failed)} order verdicts passed, "
                  f"{len(failed)} failed" + (": " + ", ".join(
                      f"{st.case}/{s.integrator}" for st in studies.convergence for s in st.verdicts
                      if not s.passed) if failed else "")
              + f" (MuJoCo {studies.mujoco_version}, {studies.elapsed:.1f} s)"]
    return "\n".join(parts)


def html_section(studies: Studies, plots: Mapping[tuple[str, str], bytes]) -> str:
    """One report section with every study's table and plot (``plots``, by ``(kind, case)``; PNG data URIs:
    self-contained)."""
    body = "".join(convergence.html_section(s, plots.get(("convergence", s.case))) for s in studies.convergence)
    body += "".join(softness.html_section(s, plots.get(("softness", s.case))) for s in studies.softness)
    body += "".join(solvers.html_section(s, plots.get(("solvers", s.case))) for s in studies.solvers)
    return (f"<section id='studies'><h2>Studies</h2><p>Layer 4: convergence order per integrator against "
            f"the documented one, constraint softness against MuJoCo's documented relations, and the "
            f"constraint solvers (MuJoCo {html.escape(studies.mujoco_version)}).</p>{body}</section>")


def html_page(studies: Studies, plots: Mapping[tuple[str, str], bytes]) -> str:
    """A standalone HTML page of the studies (for ``mjharness converge --html``)."""
    style = ("body{font-family:sans-serif;max-width:70em;margin:1em auto;color:#222}"
             "table{border-collapse:collapse;font-size:.8em}td,th{border:1px solid #ccc;padding:2px 5px}"
             "tr.fail td{background:#fdd}img{max-width:100%;display:block;margin:.5em 0}")
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>mjharness studies</title>"
            f"<style>{style}</style></head><body>{html_section(studies, plots)}</body></html>\n")

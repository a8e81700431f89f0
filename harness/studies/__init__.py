"""Layer 4, studies: convergence orders, constraint softness and solver comparison.

Each study is a pure function of a registered case returning a frozen
dataclass (rows, verdicts and plot PNG bytes); ``text``/``html_section``
render it for the CLI and the report. ``run_studies`` runs the chosen studies
over a selection of cases (generic over the registry: softness and solvers
run on the cases they apply to), ``html_section`` renders them all as one
report section.
"""

from __future__ import annotations

import html
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco

from harness.cases import Case
from harness.core.tables import text_table
from harness.engine.backends import Backend
from harness.families import convergence as orders
from harness.studies import convergence, softness, solvers


@dataclass(frozen=True)
class Studies:
    """The studies run on a selection of cases, and how long they took (s)."""

    convergence: tuple[orders.ConvergenceStudy, ...]
    softness: tuple[softness.SoftnessStudy, ...] = ()
    solvers: tuple[solvers.SolverStudy, ...] = ()
    elapsed: float = 0.0
    mujoco_version: str = mujoco.__version__

    @property
    def passed(self) -> bool:
        """All order verdicts pass (softness and solver studies carry no verdict)."""
        return all(s.passed for s in self.convergence)

    @property
    def failures(self) -> tuple[orders.Series, ...]:
        """Failed verdicts, those explained by a documented defect of this MuJoCo included."""
        return tuple(s for st in self.convergence for s in st.verdicts if not s.passed)


def run_studies(selected: Sequence[Case], *, fast: bool = False, with_softness: bool = True,
                with_solvers: bool = True, progress: bool = False, engine: Backend | None = None) -> Studies:
    """Convergence for every case; softness for the equality-constrained ones and the solver
    comparison for the constrained ones, when asked; every run on ``engine`` (default: MuJoCo's C engine)."""
    start = time.perf_counter()

    def note(text: str) -> None:
        if progress:
            print(text, file=sys.stderr, flush=True)

    conv, soft, solv = [], [], []
    for case in selected:
        note(f"converge {case.name} ...")
        conv.append(convergence.convergence_study(case, fast=fast, engine=engine))
    if with_softness:
        for case in softness.equality_cases(selected):
            note(f"softness {case.name} ...")
            soft.append(softness.softness_study(case, fast=fast, engine=engine))
    if with_solvers:
        for case in solvers.constrained_cases(selected):
            note(f"solvers {case.name} ...")
            solv.append(solvers.solver_study(case, fast=fast, engine=engine))
    return Studies(convergence=tuple(conv), softness=tuple(soft), solvers=tuple(solv),
                   elapsed=time.perf_counter() - start)


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
    for st in studies.solvers:
        parts += ["", "Solvers " + solvers.text(st)]
    failed = studies.failures
    parts += ["", f"{sum(len(s.verdicts) for s in studies.convergence) - len(failed)} order verdicts passed, "
                  f"{len(failed)} failed" + (": " + ", ".join(
                      f"{st.case}/{s.integrator}" for st in studies.convergence for s in st.verdicts
                      if not s.passed) if failed else "")
              + f" (MuJoCo {studies.mujoco_version}, {studies.elapsed:.1f} s)"]
    return "\n".join(parts)


def html_section(studies: Studies) -> str:
    """One report section with every study's table and plot (PNG data URIs: self-contained)."""
    body = "".join(convergence.html_section(s) for s in studies.convergence)
    body += "".join(softness.html_section(s) for s in studies.softness)
    body += "".join(solvers.html_section(s) for s in studies.solvers)
    return (f"<section id='studies'><h2>Studies</h2><p>Layer 4: convergence order per integrator against "
            f"the documented one, constraint softness against MuJoCo's documented relations, and the "
            f"constraint solvers (MuJoCo {html.escape(studies.mujoco_version)}).</p>{body}</section>")


def html_page(studies: Studies) -> str:
    """A standalone HTML page of the studies (for ``mjharness converge --html``)."""
    style = ("body{font-family:sans-serif;max-width:70em;margin:1em auto;color:#222}"
             "table{border-collapse:collapse;font-size:.8em}td,th{border:1px solid #ccc;padding:2px 5px}"
             "tr.fail td{background:#fdd}img{max-width:100%;display:block;margin:.5em 0}")
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>mjharness studies</title>"
            f"<style>{style}</style></head><body>{html_section(studies)}</body></html>\n")

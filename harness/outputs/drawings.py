"""What the report draws besides its tables — layer 4 studies and the seed audit (each a page of the
report) and each case's plots — run serially, or on a process pool forked after the cases, so that the
workers hold every reference the cases solved. The results are those of a serial run, in the same order
(pinned in tests/test_speed_paths.py)."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence

from harness import cases
from harness.audit.registry import all_claims
from harness.audit.verdicts import audit
from harness.families import convergence as orders
from harness.outputs.audit import html_section as audit_section
from harness.outputs.audit import json_rows as audit_json
from harness.outputs.files import AUDIT_PAGE, STUDIES_PAGE
from harness.outputs.page import Page
from harness.outputs.plots import section_plots
from harness.outputs.studies import PLOTS, html_section
from harness.outputs.studies import contact as contact_section
from harness.pipeline.executor import LOCAL, Executor
from harness.pipeline.matrix import progress
from harness.pipeline.pool import cpus, run_tasks
from harness.pipeline.run import CaseResult
from harness.studies import Studies, contact, softness, solvers

__all__ = ["draw_report"]


def study_calls(selected: Sequence[cases.Case]) -> list[tuple[str, str]]:
    """Layer 4 and the seed audit as (kind, name) calls, the costliest kinds first (the seed audit of a
    system and the convergence study, then the rest: their costs in docs/findings/speed.md)."""
    systems = list(dict.fromkeys(c.system for c in selected))
    claimed = {c.frame.system for c in all_claims()}
    return ([("audit", s) for s in systems if s in claimed]
            + [("convergence", c.name) for c in selected]
            + [("softness", c.name) for c in softness.equality_cases(selected)]
            + [("solvers", c.name) for c in solvers.constrained_cases(selected)]
            + [("contact", c.name) for c in selected if "slip" in c.mujoco_series])


def study(kind: str, name: str):
    """One call of :func:`study_calls` (module-level: a worker runs it): an audit's rows, or a study and its
    plot (drawn here, in the worker). An audit's rows come back without their claims, which hold closures;
    the parent puts them back."""
    if kind == "audit":
        return [dataclasses.replace(row, claim=None)
                for row in audit([c for c in all_claims() if c.frame.system == name])]
    case = cases.get(name)
    run = {"convergence": lambda: orders.convergence_study(case, fast=False),
           "softness": lambda: softness.softness_study(case, fast=False),
           "solvers": lambda: solvers.solver_study(case, fast=False),
           "contact": lambda: contact.contact_study(name)}[kind]
    found = run()
    return found, PLOTS[kind](found)


def case_plots(case: str | cases.Case, result: CaseResult) -> str:
    """A case's report plots (module-level: a worker runs it), from its result sent without the Case: a shipped
    case by name (its wiring holds closures), a model's own tree case whole (it is plain data, and no registry
    holds it)."""
    return section_plots(dataclasses.replace(result, case=cases.get(case) if isinstance(case, str) else case))


def draw_report(selected: Sequence[cases.Case], results: Sequence[CaseResult], *, jobs: int | None,
                studies: bool, executor: Executor = LOCAL
                ) -> tuple[list[Page], dict[str, object] | None, dict[str, str]]:
    """What the report draws besides its tables: layer 4 and the seed audit (their pages and JSON
    entries, when ``studies``) and each case's plots. With more than one worker the calls share a
    process pool forked now, so the workers hold the references the cases solved; the results are
    those of a serial run, in the same order. On a Ray cluster (``executor``) each call is a task."""
    start = time.perf_counter()
    layer4 = study_calls(selected) if studies else []
    calls = ([(study, call) for call in layer4]
             + [(case_plots, (r.case.name if r.case.tree is None else r.case, r.without_case()))
                for r in results])
    labels = [" ".join(c) for c in layer4] + [f"plots {r.case.name}" for r in results]
    workers = min(jobs or cpus(), len(calls))
    bar = progress(calls, "report", unit="part")

    def note(i: int, _result: object) -> None:
        bar.set_postfix_str(labels[i], refresh=False)
        bar.update()

    done = run_tasks(calls, workers, on_done=note, executor=executor, labels=labels)
    bar.close()
    drawn = {r.case.name: html for r, html in zip(results, done[len(layer4):], strict=True)}
    if not studies:
        return [], None, drawn
    pages, appendix = _studies_pages(selected, dict(zip(layer4, done, strict=False)),
                                     elapsed=time.perf_counter() - start)
    return pages, appendix, drawn


def _studies_pages(selected: Sequence[cases.Case], done: dict, *, elapsed: float
                   ) -> tuple[list[Page], dict[str, object]]:
    """The studies' page and the audit's (where it has claims) and their JSON entries, from their calls'
    results."""
    claims = all_claims()
    rows = []
    for system in dict.fromkeys(c.system for c in selected):  # each in all_claims() order
        system_claims = [c for c in claims if c.frame.system == system]
        rows += [dataclasses.replace(row, claim=claim)
                 for row, claim in zip(done.get(("audit", system), []), system_claims, strict=True)]
    order = {c.id: k for k, c in enumerate(claims)}
    rows.sort(key=lambda row: order[row.claim.id])  # the order of one audit of every claim
    drawn = {call: found for call, found in done.items() if call[0] != "audit"}  # (study, plot) each
    plots = {call: png for call, (_, png) in drawn.items()}
    by_kind = {kind: tuple(study for (k, _), (study, _) in drawn.items() if k == kind)
               for kind in ("convergence", "softness", "solvers", "contact")}
    found = Studies(convergence=by_kind["convergence"], softness=by_kind["softness"],
                    solvers=by_kind["solvers"], elapsed=elapsed)
    contact_results = list(by_kind["contact"])
    studied = tuple(h for h in (html_section(found, plots), contact_section.html_section(contact_results, plots))
                    if h)
    pages = [Page(STUDIES_PAGE, "Studies", "layer 4: convergence orders per integrator, constraint softness, the "
                  "constraint solvers and the contact settings", studied)]
    if rows:
        pages.append(Page(AUDIT_PAGE, "Seed audit", "every display and statement of the seed documents, checked "
                          "symbolically and against MuJoCo", (audit_section(rows),)))
    appendix = {"audit": audit_json(rows),
                "contact_study": {r.case: [dict(row) for row in r.rows] for r in contact_results}}
    return pages, appendix

"""Running the case matrix and the report's parts: serially, or on a process pool (``--jobs``).

``run_all`` runs the cases (a system's cases in one worker, so that its
derivation, dynamics and reference are made once) and judges them;
``report_parts`` runs what the report draws besides its tables — layer 4
studies, the seed audit and each case's plots — on a pool forked after the
cases, so the workers hold every reference the cases solved. Either way the
results are those of a serial run, in registry order (pinned in
tests/test_speed_paths.py).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from harness import cases
from harness.config import load_config
from harness.pool import cpus, run_tasks
from harness.verdict import verdict


def progress(items: Sequence, desc: str, unit: str = "case"):
    """A tqdm bar on stderr, silent when stderr is not a terminal (CI logs, pipes)."""
    from tqdm import tqdm

    return tqdm(items, desc=desc, unit=unit, file=sys.stderr, leave=False,
                disable=not sys.stderr.isatty())


def run_all(selected: Sequence[cases.Case], config_path: Path | None, mjcf: Path | None = None, *,
            jobs: int | None = None, figures_only: bool = False):
    """run_case for each case, then its verdict; (results, checks by case, config).

    ``jobs`` worker processes (default: one per CPU) share the cases; every
    case is computed by the same code from the same inputs wherever it runs, so
    the results are those of a serial run, in registry order, for any ``jobs``.
    ``figures_only``: the caller reads figures and settings alone (``check``,
    ``baseline``), so workers send back no trajectories (several MB a case,
    which the parent would unpickle while the workers wait on the pipe) and no
    reference solutions (for studies).
    """
    from harness import pipeline

    config = load_config(config_path)
    workers = min(jobs or cpus(), len(selected))
    bar = progress(selected, "mjharness")
    if workers <= 1 or mjcf is not None:
        results = []
        for case in bar:
            bar.set_postfix_str(case.name)
            results.append(pipeline.run_case(case, mjcf=mjcf))
    else:
        results = _run_parallel(selected, workers, bar, figures_only=figures_only)
    bar.close()
    checks = {r.case.name: verdict(r.case.name, r.figures, config.for_case(r.case.name)) for r in results}
    return results, checks, config


def groups(selected: Sequence[cases.Case], *, derived: Callable[[str], bool] | None = None) -> list[list[int]]:
    """Indices of the selected cases by system, each group in registry order, costliest group first.

    A system's cases run in one worker, so that its derivation, dynamics and reference are made once.
    A group costs its cases' ``cost`` plus, where ``derived(system)`` is False (default: its
    derivation is not in the on-disk cache), the system's :data:`cases.DERIVATION_COST`.
    """
    if derived is None:
        from harness.reference import derivation_stored as derived
    by_system: dict[str, list[int]] = {}
    for i, case in enumerate(selected):
        by_system.setdefault(case.system, []).append(i)

    def cost(system: str, group: list[int]) -> float:
        deriving = 0.0 if derived(system) else cases.DERIVATION_COST.get(system, 0.5)
        return deriving + sum(selected[i].cost for i in group)

    return sorted(by_system.values(), key=lambda group: -cost(selected[group[0]].system, group))


def _run_group(names: Sequence[str], figures_only: bool):
    """A group's cases in a worker, in order, until one fails: per case (its result without the
    unpicklable Case, or its error), then the references this worker solved (none if
    ``figures_only``, when the results carry no trajectories either)."""
    import dataclasses

    from harness import pipeline
    from harness import reference as refmod

    outcomes = []
    for name in names:
        try:
            result = pipeline.run_case(cases.get(name))
        except Exception as exc:  # returned, raised by the parent in registry order
            outcomes.append((None, exc))
            break
        if figures_only:
            result = dataclasses.replace(result, reference=None, simulations={})
        outcomes.append((dataclasses.replace(result, case=None), None))
    return outcomes, ({} if figures_only else refmod.export_solutions())


def _run_parallel(selected: Sequence[cases.Case], workers: int, bar, *, figures_only: bool) -> list:
    """run_case on a process pool, a system's cases in one worker; results in registry order. A
    case's error is raised once every case before it in the registry has finished, as a serial run
    would raise it."""
    import dataclasses
    from concurrent.futures import as_completed

    from harness import pipeline  # noqa: F401  imported once here, not once per worker
    from harness import reference as refmod
    from harness.pool import fork_pool
    from harness.studies import convergence  # noqa: F401  (run_case imports it)

    stored = {system: refmod.derivation_stored(system) for system in dict.fromkeys(c.system for c in selected)}
    if not all(stored.values()):  # the workers derive: sympy and its lazily loaded parts, once, before the fork
        from analytic import lagrangian

        lagrangian.preload()
    outcomes: dict[int, tuple] = {}
    with fork_pool(workers) as pool:
        futures = {pool.submit(_run_group, [selected[i].name for i in group], figures_only): group
                   for group in groups(selected, derived=stored.__getitem__)}
        next_in_order = 0
        for future in as_completed(futures):
            group = futures[future]
            done, seeds = future.result()
            refmod.import_solutions(seeds)  # the run's studies reuse these solves
            outcomes.update(zip(group, done, strict=False))  # cases after a failure never ran
            bar.set_postfix_str(", ".join(selected[i].name for i in group[:len(done)]), refresh=False)
            bar.update(len(done))
            while next_in_order in outcomes:
                error = outcomes[next_in_order][1]
                if error is not None:
                    raise error
                next_in_order += 1
    return [dataclasses.replace(outcomes[i][0], case=case) for i, case in enumerate(selected)]


def study_calls(selected: Sequence[cases.Case]) -> list[tuple[str, str]]:
    """Layer 4 and the seed audit as (kind, name) calls, the costliest kinds first (measured: a seed
    audit of a system 0.3-1.5 s, a convergence study 0.3-1.5 s, the rest 0.2-1 s)."""
    from harness import audit
    from harness.studies import softness, solvers

    systems = list(dict.fromkeys(c.system for c in selected))
    claimed = {c.frame.system for c in audit.all_claims()}
    return ([("audit", s) for s in systems if s in claimed]
            + [("convergence", c.name) for c in selected]
            + [("softness", c.name) for c in softness.equality_cases(selected)]
            + [("solvers", c.name) for c in solvers.constrained_cases(selected)]
            + [("contact", c.name) for c in selected if "slip" in c.mujoco_series])


def study(kind: str, name: str):
    """One call of :func:`study_calls` (module-level: a worker runs it). An audit's rows come back
    without their claims, which hold closures; the parent puts them back."""
    import dataclasses

    from harness import audit
    from harness.studies import contact, convergence, softness, solvers

    if kind == "audit":
        return [dataclasses.replace(row, claim=None)
                for row in audit.audit([c for c in audit.all_claims() if c.frame.system == name])]
    case = cases.get(name)
    study = {"convergence": lambda: convergence.convergence_study(case, fast=False),
             "softness": lambda: softness.softness_study(case, fast=False),
             "solvers": lambda: solvers.solver_study(case, fast=False),
             "contact": lambda: contact.contact_study(name)}[kind]
    return study()


def case_plots(name: str, result):
    """A case's report plots (module-level: a worker runs it), from its result sent without the Case,
    which holds closures."""
    import dataclasses

    from harness.report import section_plots

    return section_plots(dataclasses.replace(result, case=cases.get(name)))


def report_parts(selected: Sequence[cases.Case], results: Sequence, *, jobs: int | None,
                 studies: bool) -> tuple[list[str], dict[str, object] | None, dict[str, str]]:
    """What the report draws besides its tables: layer 4 and the seed audit (HTML sections and JSON
    entries, when ``studies``) and each case's plots. With more than one worker the calls share a
    process pool forked now, so the workers hold the references the cases solved; the results are
    those of a serial run, in the same order."""
    import dataclasses

    start = time.perf_counter()
    layer4 = study_calls(selected) if studies else []
    calls = ([(study, call) for call in layer4]
             + [(case_plots, (r.case.name, dataclasses.replace(r, case=None))) for r in results])
    labels = [" ".join(c) for c in layer4] + [f"plots {r.case.name}" for r in results]
    workers = min(jobs or cpus(), len(calls))
    bar = progress(calls, "report", unit="part")

    def note(i: int, _result: object) -> None:
        bar.set_postfix_str(labels[i], refresh=False)
        bar.update()

    done = run_tasks(calls, workers, on_done=note)
    bar.close()
    drawn = {r.case.name: html for r, html in zip(results, done[len(layer4):], strict=True)}
    if not studies:
        return [], None, drawn
    extras, appendix = _studies_html(selected, dict(zip(layer4, done, strict=False)),
                                     elapsed=time.perf_counter() - start)
    return extras, appendix, drawn


def _studies_html(selected: Sequence[cases.Case], done: dict, *, elapsed: float
                  ) -> tuple[list[str], dict[str, object]]:
    """The studies' and the audit's HTML sections and JSON entries, from their calls' results."""
    import dataclasses

    from harness import audit
    from harness.studies import Studies, html_section
    from harness.studies import contact as contact_study

    claims = audit.all_claims()
    rows = []
    for system in dict.fromkeys(c.system for c in selected):  # each in all_claims() order
        system_claims = [c for c in claims if c.frame.system == system]
        rows += [dataclasses.replace(row, claim=claim)
                 for row, claim in zip(done.get(("audit", system), []), system_claims, strict=True)]
    order = {c.id: k for k, c in enumerate(claims)}
    rows.sort(key=lambda row: order[row.claim.id])  # the order of one audit of every claim
    by_kind = {kind: tuple(r for (k, _), r in done.items() if k == kind)
               for kind in ("convergence", "softness", "solvers", "contact")}
    studies = Studies(convergence=by_kind["convergence"], softness=by_kind["softness"],
                      solvers=by_kind["solvers"], elapsed=elapsed)
    contact = list(by_kind["contact"])
    html = [html_section(studies), contact_study.html_section(contact), audit.html_section(rows)]
    appendix = {"audit": audit.json_rows(rows),
                "contact_study": {r.case: [dict(row) for row in r.rows] for r in contact}}
    return [h for h in html if h], appendix

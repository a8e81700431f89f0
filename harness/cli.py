"""``mjharness``: a thin argparse layer over pure functions.

Exit codes: 0 all checks pass, 1 a check fails (or, for ``baseline
--compare``, a figure regressed), 2 bad usage or input (unknown case, invalid
MJCF or config, a model that does not fit its case, unwritable output,
diverging simulation). User mistakes give one line on stderr, never a
traceback, and never a half-written file. ``diff`` is informational: 0 unless
its input is bad (2).

Each subcommand is one entry in ``COMMANDS``: a function adding its arguments
and a ``cmd_NAME(args) -> int`` doing the work.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from harness import cases
from harness.config import load_config
from harness.simulate import SimulationDiverged
from harness.verdict import Check, verdict

EXIT_OK, EXIT_FAIL, EXIT_USAGE = 0, 1, 2


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2 (argparse's own code)
        self.exit(EXIT_USAGE, f"mjharness: error: {message}\n")


# --------------------------------------------------------------- helpers
def _progress(items: Sequence, desc: str, unit: str = "case"):
    """A tqdm bar on stderr, silent when stderr is not a terminal (CI logs, pipes)."""
    from tqdm import tqdm

    return tqdm(items, desc=desc, unit=unit, file=sys.stderr, leave=False,
                disable=not sys.stderr.isatty())


def _selected(args: argparse.Namespace) -> tuple[cases.Case, ...]:
    """Cases named positionally or with --case (all when none); --mjcf needs exactly one."""
    names = [*args.cases, *(args.case or [])]
    selected = cases.select(names)
    if getattr(args, "mjcf", None) is not None and len(selected) != 1:
        raise ValueError(f"--mjcf validates one model against one case; name it with --case NAME "
                         f"(known cases: {', '.join(cases.names())})")
    return selected


def _run_all(selected: Sequence[cases.Case], config_path: Path | None, mjcf: Path | None = None, *,
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
    workers = min(jobs or _cpus(), len(selected))
    bar = _progress(selected, "mjharness")
    if workers <= 1 or mjcf is not None:
        results = []
        for case in bar:
            bar.set_postfix_str(case.name)
            results.append(pipeline.run_case(case, mjcf=mjcf) if mjcf is not None else pipeline.run_case(case))
    else:
        results = _run_parallel(selected, workers, bar, figures_only=figures_only)
    bar.close()
    checks = {r.case.name: verdict(r.case.name, r.figures, config.for_case(r.case.name)) for r in results}
    return results, checks, config


def _cpus() -> int:
    from harness.pool import cpus

    return cpus()


def _groups(selected: Sequence[cases.Case]) -> list[list[int]]:
    """Indices of the selected cases by system, each group in registry order, costliest group first.
    A system's cases run in one worker, so that its derivation, dynamics and reference are made once."""
    by_system: dict[str, list[int]] = {}
    for i, case in enumerate(selected):
        by_system.setdefault(case.system, []).append(i)
    return sorted(by_system.values(), key=lambda group: -sum(selected[i].cost for i in group))


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

    from analytic import solvers
    from harness import pipeline  # noqa: F401  imported once here, not once per worker
    from harness import reference as refmod
    from harness.pool import fork_pool
    from harness.studies import convergence  # noqa: F401  (run_case imports it)

    solvers.integrator()  # every worker solves references: load scipy.integrate once, before the fork
    outcomes: dict[int, tuple] = {}
    with fork_pool(workers) as pool:
        futures = {pool.submit(_run_group, [selected[i].name for i in group], figures_only): group
                   for group in _groups(selected)}
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


def _table(checks: dict[str, list[Check]]) -> str:
    from harness.report import ratio, ratio_text

    rows = [(c.case, c.name, f"{c.value:.3e}", f"{c.threshold:.3e}", c.unit, ratio_text(ratio(c)),
             f"{c.status}: {c.note or c.known}" if c.note or c.known else c.status)
            for cs in checks.values() for c in cs]
    header = ("case", "check", "figure", "threshold", "unit", "used", "verdict")
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    lines = ["  ".join(v.ljust(w) for v, w in zip(r, widths, strict=True)).rstrip() for r in [header, *rows]]
    failed = sum(not c.passed for cs in checks.values() for c in cs)
    total = sum(len(cs) for cs in checks.values())
    na = sum(bool(c.note) for cs in checks.values() for c in cs)
    known = sum(bool(c.known) for cs in checks.values() for c in cs)
    lines.append(f"{total - failed - na - known} passed, {failed} failed"
                 + (f", {na} n/a (not in this MuJoCo)" if na else "")
                 + (f", {known} known defect(s) of this MuJoCo" if known else ""))
    return "\n".join(lines)


def _exit(checks: dict[str, list[Check]]) -> int:
    return EXIT_OK if all(c.passed for cs in checks.values() for c in cs) else EXIT_FAIL


def _add_selection(p: argparse.ArgumentParser, *, mjcf: bool = True) -> None:
    p.add_argument("cases", nargs="*", metavar="CASE", help="case names (default: all)")
    p.add_argument("--case", action="append", metavar="NAME", help="a case name (same as CASE; repeatable)")
    p.add_argument("--config", type=Path, metavar="FILE", help="TOML overriding [tool.mjharness] thresholds")
    p.add_argument("--jobs", "-j", type=_positive, metavar="N",
                   help=f"worker processes for the cases (default: one per CPU, here {_cpus()}); "
                        "the results do not depend on N")
    if mjcf:
        p.add_argument("--mjcf", type=Path, metavar="PATH",
                       help="validate this MJCF (your variant of the case's model) against the case's "
                            "reference and thresholds; needs exactly one case")


def _positive(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text!r}")
    return value


# ----------------------------------------------------------- subcommands
def _args_list(p: argparse.ArgumentParser) -> None:
    pass


def cmd_list(args: argparse.Namespace) -> int:
    tags = {c.name: f"[{','.join(sorted(c.tags))}]" for c in cases.CASES}
    width, tag_width = max(map(len, tags)), max(map(len, tags.values()))
    for c in cases.CASES:
        print(f"{c.name.ljust(width)}  {tags[c.name].ljust(tag_width)}  {c.description}")
    return EXIT_OK


def _add_junit(p: argparse.ArgumentParser) -> None:
    p.add_argument("--junit", type=Path, metavar="FILE", help="also write JUnit XML (one testcase per check)")


def _check_junit(path: Path | None) -> None:
    """Refuse an unusable --junit path before any work is done."""
    from harness.report import check_output

    if path is not None:
        if path.is_dir():
            raise ValueError(f"--junit {str(path)!r} is a directory; give a file name")
        check_output(path.parent)


def _write_junit(path: Path | None, checks: dict[str, list[Check]]) -> list[Path]:
    if path is None:
        return []
    from harness.junit import junit_xml
    from harness.report import prepare_output, write_atomic

    prepare_output(path.parent)
    return write_atomic({path: junit_xml(checks)})


def _args_run(p: argparse.ArgumentParser) -> None:
    _add_selection(p)
    p.add_argument("--out", type=Path, default=Path("mjharness-report"), metavar="DIR",
                   help="output directory (default: ./mjharness-report)")
    p.add_argument("--no-studies", dest="studies", action="store_false",
                   help="skip layer 4 (convergence, softness, solver and contact studies) and the seed audit")
    _add_junit(p)


def _study_calls(selected: Sequence[cases.Case]) -> list[tuple[str, str]]:
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


def _study(kind: str, name: str):
    """One call of :func:`_study_calls` (module-level: a worker runs it). An audit's rows come back
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


def _plots(name: str, result):
    """A case's report plots (module-level: a worker runs it), from its result sent without the Case,
    which holds closures."""
    import dataclasses

    from harness.report import section_plots

    return section_plots(dataclasses.replace(result, case=cases.get(name)))


def _report_parts(selected: Sequence[cases.Case], results: Sequence, *, jobs: int | None,
                  studies: bool) -> tuple[list[str], dict[str, object] | None, dict[str, str]]:
    """What the report draws besides its tables: layer 4 and the seed audit (HTML sections and JSON
    entries, when ``studies``) and each case's plots. With more than one worker the calls share a
    process pool forked now, so the workers hold the references the cases solved; the results are
    those of a serial run, in the same order."""
    import dataclasses

    start = time.perf_counter()
    study_calls = _study_calls(selected) if studies else []
    calls = ([(_study, call) for call in study_calls]
             + [(_plots, (r.case.name, dataclasses.replace(r, case=None))) for r in results])
    labels = [" ".join(c) for c in study_calls] + [f"plots {r.case.name}" for r in results]
    workers = min(jobs or _cpus(), len(calls))
    bar = _progress(calls, "report", unit="part")

    def note(i: int, _result: object) -> None:
        bar.set_postfix_str(labels[i], refresh=False)
        bar.update()

    if workers > 1:
        from harness.pool import run_tasks

        done = run_tasks(calls, workers, on_done=note)
    else:
        done = []
        for i, (fn, call_args) in enumerate(calls):
            done.append(fn(*call_args))
            note(i, done[-1])
    bar.close()
    plots = {r.case.name: html for r, html in zip(results, done[len(study_calls):], strict=True)}
    if not studies:
        return [], None, plots
    extras, appendix = _studies_html(selected, dict(zip(study_calls, done, strict=False)),
                                     elapsed=time.perf_counter() - start)
    return extras, appendix, plots


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


def cmd_run(args: argparse.Namespace) -> int:
    from harness.report import check_output, write_report

    start = time.perf_counter()
    check_output(args.out)  # fail before minutes of work, not after
    _check_junit(args.junit)
    selected = _selected(args)
    results, checks, config = _run_all(selected, args.config, args.mjcf, jobs=args.jobs)
    extras, appendix, plots = _report_parts(selected, results, jobs=args.jobs,
                                            studies=args.studies and args.mjcf is None)
    paths = write_report(args.out, results, checks, config_source=config.source, extras=extras,
                         appendix=appendix, plots=plots)
    paths += _write_junit(args.junit, checks)
    print(_table(checks))
    print(f"wrote {', '.join(str(p) for p in paths)} in {time.perf_counter() - start:.1f} s")
    return _exit(checks)


def _args_check(p: argparse.ArgumentParser) -> None:
    _add_selection(p)
    _add_junit(p)
    p.add_argument("--json", action="store_true", help="print the run as JSON (report.json schema) "
                                                       "instead of the table")


def cmd_check(args: argparse.Namespace) -> int:
    from harness.report import dumps, json_doc

    _check_junit(args.junit)
    results, checks, _ = _run_all(_selected(args), args.config, args.mjcf, jobs=args.jobs, figures_only=True)
    _write_junit(args.junit, checks)
    if args.json:
        sys.stdout.write(dumps(json_doc(results, checks)))
    else:
        print(_table(checks))
    return _exit(checks)


def _args_diff(p: argparse.ArgumentParser) -> None:
    p.add_argument("old", type=Path, metavar="OLD.json", help="report.json (or baseline, or check --json) before")
    p.add_argument("new", type=Path, metavar="NEW.json", help="the same after")
    p.add_argument("--all", action="store_true", help="list unchanged figures too")


def cmd_diff(args: argparse.Namespace) -> int:
    from harness.diff import diff_runs, format_diff, load_run

    old, new = load_run(args.old), load_run(args.new)
    print(format_diff(diff_runs(old, new), show_all=args.all), end="")
    return EXIT_OK


def _args_baseline(p: argparse.ArgumentParser) -> None:
    _add_selection(p, mjcf=False)
    mode = p.add_mutually_exclusive_group(required=True)
    mode.add_argument("--write", type=Path, metavar="FILE",
                      help="run the cases and write their gated figures (naming cases updates only those)")
    mode.add_argument("--compare", type=Path, metavar="FILE",
                      help="run the cases and fail (exit 1) where a figure regressed against FILE")


def cmd_baseline(args: argparse.Namespace) -> int:
    from harness import baseline
    from harness.diff import load_run
    from harness.report import check_output, dumps, prepare_output, write_atomic

    selected = _selected(args)
    if args.write is not None:
        check_output(args.write.parent)
        old = load_run(args.write) if args.write.exists() and (args.cases or args.case) else None
        results, checks, _ = _run_all(selected, args.config, jobs=args.jobs, figures_only=True)
        failing = [c for cs in checks.values() for c in cs if not c.passed]
        if failing:
            print(_table(checks))
            print(f"mjharness: refusing to write a baseline while {len(failing)} check(s) fail", file=sys.stderr)
            return EXIT_FAIL
        doc = baseline.merge(old, baseline.baseline_doc(results, checks))
        prepare_output(args.write.parent)
        write_atomic({args.write: dumps(doc)})
        count = sum(len(c["figures"]) for c in doc["cases"].values())
        print(f"wrote {args.write}: {len(doc['cases'])} case(s), {count} gated figures")
        return EXIT_OK
    reference = load_run(args.compare)
    mismatch = baseline.version_mismatch(reference, source=str(args.compare))
    if mismatch:  # a baseline is per MuJoCo version: refuse before any work
        raise ValueError(mismatch)
    results, checks, config = _run_all(selected, args.config, jobs=args.jobs, figures_only=True)
    findings = [f for r in results for f in baseline.compare(
        reference, r.case.name, r.figures, config.for_case(r.case.name), source=str(args.compare))]
    for f in findings:
        print(f.message)
    print(f"{len(findings)} regression(s) or missing entries against {args.compare} "
          f"(rule: new > {baseline.FACTOR:g} × max(old, {baseline.FLOOR:g} × threshold))")
    return EXIT_FAIL if findings else EXIT_OK


def _args_converge(p: argparse.ArgumentParser) -> None:
    p.add_argument("cases", nargs="*", metavar="CASE", help="case names (default: all)")
    p.add_argument("--fast", action="store_true", help="the 3-timestep subset `check` gates (T ≤ 0.5 s)")
    p.add_argument("--softness", action="store_true", help="also sweep solref/solimp of the equality cases")
    p.add_argument("--solvers", action="store_true", help="also compare Newton, CG and PGS on the constrained cases")
    p.add_argument("--html", type=Path, metavar="FILE", help="also write the tables and plots as one HTML page")


def cmd_converge(args: argparse.Namespace) -> int:
    from harness.report import check_output, prepare_output, write_atomic
    from harness.studies import html_page, run_studies, text

    if args.html is not None:
        check_output(args.html.parent)
    studies = run_studies(cases.select(args.cases), fast=args.fast, with_softness=args.softness,
                          with_solvers=args.solvers, progress=True)
    print(text(studies))
    if args.html is not None:
        prepare_output(args.html.parent)
        write_atomic({args.html: html_page(studies)})
    return EXIT_OK if studies.passed else EXIT_FAIL


def _args_audit(p: argparse.ArgumentParser) -> None:
    p.add_argument("--json", action="store_true", help="print the verdicts as JSON instead of the table")


def cmd_audit(args: argparse.Namespace) -> int:
    from harness import audit
    from harness.report import dumps

    rows = audit.audit()
    if args.json:
        sys.stdout.write(dumps(audit.json_rows(rows)))
    else:
        print(audit.format_table(rows))
    return EXIT_OK


@dataclass(frozen=True)
class Command:
    help: str
    add_arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], int]


COMMANDS: dict[str, Command] = {
    "list": Command("list the cases", _args_list, cmd_list),
    "run": Command("run cases and write the report (report.html, report.json, summary.md)", _args_run, cmd_run),
    "check": Command("CI gate: figures vs thresholds (exit 0 pass, 1 fail, 2 bad input)", _args_check, cmd_check),
    "diff": Command("what changed between two runs' JSON, figure by figure", _args_diff, cmd_diff),
    "baseline": Command("write or compare the regression baseline (reports/baseline.json)",
                        _args_baseline, cmd_baseline),
    "converge": Command("convergence order per integrator vs the documented one (exit 1 if one falls "
                        "short); --softness, --solvers: constraint studies", _args_converge, cmd_converge),
    "audit": Command("the seed documents' claims: confirmed, refuted (with the correction) or ambiguous",
                     _args_audit, cmd_audit),
}


def _parser() -> argparse.ArgumentParser:
    p = _Parser(prog="mjharness", description="Validate MuJoCo against analytical mechanics.")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name, command in COMMANDS.items():
        command.add_arguments(sub.add_parser(name, help=command.help, description=command.help))
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        return COMMANDS[args.command].run(args)
    except SimulationDiverged as exc:
        print(f"mjharness: error: simulation diverged: {exc}", file=sys.stderr)
    except ValueError as exc:  # ConfigError, ModelError, ModelMismatch and every input check
        print(f"mjharness: error: {' '.join(str(exc).split())}", file=sys.stderr)
    except OSError as exc:
        print(f"mjharness: error: {exc.strerror or exc}: {exc.filename or ''}".rstrip(": "), file=sys.stderr)
    except KeyboardInterrupt:
        print("mjharness: interrupted", file=sys.stderr)
        return 130
    return EXIT_USAGE


if __name__ == "__main__":
    sys.exit(main())

"""``mjharness run``: run cases, write the report's pages, report.json and summary.md."""

from __future__ import annotations

import argparse
import time
from collections.abc import Sequence
from pathlib import Path

from harness.cli.common import (
    Command,
    case_lines,
    check_junit,
    command_exit_code,
    executor_of,
    inertials_of,
    judging_of,
    junit_files,
    limits_of,
    opinions_of,
    peers_of,
    print_checks,
    run_options,
    selected_cases,
    trees_of,
)
from harness.cli.options import add_executor, add_junit, add_out, add_quiet, add_run_options, add_selection
from harness.core.progress import heartbeat
from harness.engine import backends
from harness.outputs.files import (
    BACKENDS_PAGE,
    CASE_PAGES,
    check_report_folder,
    prepare_output,
    superseded,
    with_manifest,
    write_atomic,
)
from harness.pipeline.entry import evaluate, evaluate_backends

__all__ = ["COMMAND"]


def _args_run(p: argparse.ArgumentParser) -> None:
    add_selection(p)
    add_out(p, Path("mjharness-report"), "the report")
    p.add_argument("--no-studies", dest="studies", action="store_false",
                   help="skip layer 4 (convergence, softness, solver and contact studies) and the seed audit")
    add_junit(p)
    add_quiet(p)
    add_run_options(p)
    add_executor(p)


def cmd_run(args: argparse.Namespace) -> int:
    from harness.outputs.drawings import draw_report  # lazy: studies and plots load sympy and matplotlib
    from harness.outputs.inertia import inertia_banners, inertia_page  # lazy: matplotlib, as above
    from harness.outputs.report import report_files  # lazy: as above

    start = time.perf_counter()
    check_report_folder(args.out, force=args.force_out)  # fail before minutes of work, not after
    check_junit(args.junit, args.out)
    selected = selected_cases(args)  # first: a model too large for its reference is refused before anything runs
    opinions = opinions_of(args)
    options = run_options(args, selected, several=True)
    executor = executor_of(args)
    done = evaluate(selected, options=options, judging=judging_of(args), jobs=args.jobs, executor=executor,
                    **case_lines(args))
    results, checks, limits, outcome = done.results, done.checks, done.limits, done.outcome
    inertials = inertials_of(args, selected, limits)
    with heartbeat("the report: plots, pictures and pages"):  # seconds to minutes, after the cases' lines
        pages, appendix, plots = draw_report(selected, results, jobs=args.jobs, executor=executor,
                                             studies=args.studies and options.shipped)
    appendix = (appendix or {}) | ({"opinions": opinions.as_dict()} if opinions.as_dict() else {})
    appendix |= {"inertials": inertials.as_dict()}
    pages = [*pages, *inertia_page(inertials)]
    others = backends.expand(args.backend)[1:]
    if others:  # the first backend's report, and every backend side by side (its verdict is the first's)
        from harness.outputs.backends import BackendRun, side_by_side_html, side_by_side_json  # lazy: matplotlib
        from harness.outputs.page import Page  # lazy: with the backends' page it belongs to

        runs = [BackendRun(options.backend, backends.PRECISION[options.backend], results, checks)]
        runs += [BackendRun(name, backends.PRECISION[name], r, c)
                 for name, r, c in evaluate_backends(selected, args.config, options, others)]
        pages = [*pages, Page(BACKENDS_PAGE, "Backends side by side", "every gated figure of each case on each "
                              "backend, and the findings", (side_by_side_html(runs),))]
        appendix = (appendix or {}) | {"backends": side_by_side_json(runs)}
    with heartbeat("the report: pages"):
        files = report_files(args.out, results, outcome, config_source=limits.source, pages=pages,
                             appendix=appendix, plots=plots, banners=inertia_banners(inertials))
    prepare_output(args.out)
    # the report and its JUnit, all or none, and an earlier report's pages this one has not removed with them
    paths = write_atomic(with_manifest(args.out, files | junit_files(args.junit, outcome)),
                         remove=superseded(args.out, files))
    print_checks(outcome, quiet=args.quiet, verbose=args.verbose, trees=trees_of(results), limits=limits_of(results),
                  peers=peers_of(results), opinions=[*opinions.lines(quiet=args.quiet),
                                                   *inertials.lines(quiet=args.quiet)],
                  written=f"wrote in {time.perf_counter() - start:.1f} s: {_written(args.out, paths)}")
    return command_exit_code(outcome, opinions, inertials)


def _written(out: Path, paths: Sequence[Path]) -> str:
    """The files written, the case pages counted rather than listed."""
    cases = out / CASE_PAGES
    pages = [p for p in paths if p.parent == cases]
    listed = [str(p) for p in paths if p.parent != cases]
    return ", ".join(listed + ([f"{len(pages)} case page(s) in {cases}"] if pages else []))


COMMAND = Command("run cases, write the report's pages, report.json and summary.md", _args_run, cmd_run)

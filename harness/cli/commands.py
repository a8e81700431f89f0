"""``mjharness``: a thin argparse layer over pure functions.

Exit codes (:data:`EXIT_CODES`, printed by ``--help`` and a bare ``mjharness``): 0 all checks pass,
1 a check fails (a run that diverged fails its checks with the reason; for ``baseline --compare``, a
figure regressed), 2 bad usage or input (unknown case, invalid MJCF or config, a model that does not
fit its case, unwritable output). User mistakes give one line on stderr, never a traceback, and never a
half-written file; so does a bug of ours (an unexpected exception: "internal error", exit 2, with the hint
to report it); a numerical failure of our own solvers (a singular linear solve, a reference solve that cannot
go on) is neither: one line, exit 4. ``diff`` is informational: 0 unless its input is bad (2). A command whose stdout is
closed (``| head -1``) stops quietly with 141 (128 + SIGPIPE); one interrupted exits 130 (Ctrl-C) or
143 (SIGTERM), and marks stale the report files it would have written.

``run`` and ``check`` print what fits the terminal: a line per case as it finishes (its checks, how
many fail, the worst share of a limit, seconds; on stdout, flushed, so a CI log shows them as they
come), then each failed check with its budget, and the verdict line last, where a person sees it
without scrolling; ``--verbose`` adds the table of every check; ``--quiet`` prints the failures and the
verdict only (the cases' lines go to stderr where it is not a terminal, a progress bar where it is).

Each subcommand is one entry in ``COMMANDS``: a function adding its arguments
and a ``cmd_NAME(args) -> int`` doing the work. The commands that draw
(``run``, ``converge``, ``audit``) import the report and studies, which load
matplotlib and sympy, when they run; the gate (``check``) never loads them.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import math
import os
import signal
import sys
import textwrap
import time
import traceback
import warnings
from collections.abc import Callable, Sequence
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path
from typing import NoReturn

import mujoco
from numpy.linalg import LinAlgError

from analytic.dop853 import IntegrationError
from analytic.solvers import TooManySteps
from harness import cases
from harness.cases import sources
from harness.cases.own import from_mjcf
from harness.core import VERSION
from harness.core.bounds import max_steps
from harness.core.checks import Check
from harness.core.errors import SimulationDiverged
from harness.core.escape import terminal
from harness.core.lifetime import Terminated, exit_code, sigterm_as_interrupt
from harness.core.options import RunOptions
from harness.core.progress import heartbeat
from harness.core.tables import terminal_width, wrap
from harness.engine import backends, messages
from harness.engine.integrators import available_integrators
from harness.families import figure_names
from harness.opinions import threeway
from harness.outputs import baseline
from harness.outputs.diff import diff_runs, format_diff, load_run, select
from harness.outputs.files import (
    BACKENDS_PAGE,
    CASE_PAGES,
    FORCE,
    PAGES,
    REPORT_FILES,
    STALE,
    check_output,
    check_report_folder,
    mark_stale,
    ours,
    prepare_output,
    superseded,
    with_manifest,
    write_atomic,
)
from harness.outputs.jsondoc import dumps, json_doc
from harness.outputs.junit import junit_xml
from harness.outputs.table import (
    checks_table,
    coverage_block,
    failures_block,
    fitness_line,
    fitness_table,
    stability_block,
    verdict_line,
)
from harness.pipeline import limits as limits_data
from harness.pipeline import require
from harness.pipeline.executor import EXECUTORS, Executor, TaskLost
from harness.pipeline.matrix import LogProgress, run_all, run_backends
from harness.pipeline.outcome import EXIT_UNFIT, Outcome, outcome_of
from harness.pipeline.pool import cpus, run_tasks

EXIT_OK, EXIT_FAIL, EXIT_USAGE = 0, 1, 2
EXIT_NUMERIC = 4
EXIT_CODES = {EXIT_OK: "every check passes (and every --require is met)",
              EXIT_FAIL: "a check fails: an error its budget does not explain, a run that could not be measured, "
                         "or a known defect of this MuJoCo not accepted (baseline --compare: a figure regressed or "
                         "a case is missing; converge: an order falls short)",
              EXIT_USAGE: "bad usage or input: unknown case, unreadable or invalid MJCF or config, a model "
                          "that does not fit its case, an unwritable output; or an internal error (a bug: one "
                          "line asking you to report it, the report files marked stale)",
              EXIT_UNFIT: "every check passes, but these settings do not meet a --require",
              EXIT_NUMERIC: "a numerical failure inside the harness's own solvers (a linear solve of the reference "
                            "that is singular, a reference solve that cannot go on): not your input; "
                            "MJHARNESS_TRACEBACK=1 prints the traceback",
              141: "stdout closed (| head): stopped quietly",
              130: "interrupted (Ctrl-C); 143: terminated (SIGTERM); the report files it would have written "
                   "are marked stale"}
INTERRUPTED = (128 + signal.SIGINT, 128 + signal.SIGTERM)  # Ctrl-C, SIGTERM
EXIT_PIPE = 128 + signal.SIGPIPE  # stdout's reader went away: what a shell reports for a tool SIGPIPE stopped
TRACEBACK_VARIABLE = "MJHARNESS_TRACEBACK"  # set to 1: an internal error prints its traceback after its line


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # one line, exit 2 (argparse's own code)
        self.exit(EXIT_USAGE, f"mjharness: error: {message}\n")


# --------------------------------------------------------------- helpers
def _selected(args: argparse.Namespace) -> tuple[cases.Case, ...]:
    """Cases named positionally or with --case (all when none); --mjcf with no case is any model, judged
    against its own kinematic tree, and with one case a variant of that case's model."""
    names = [*args.cases, *(args.case or [])]
    mjcf = getattr(args, "mjcf", None)
    if mjcf is not None and not names:
        return (from_mjcf(mjcf, keyframe=args.keyframe, ctrl=args.ctrl, horizon=args.horizon),)
    if (getattr(args, "keyframe", None) or getattr(args, "ctrl", None)) and mjcf is None:
        raise ValueError("--keyframe and --ctrl apply to a model judged against its own tree: --mjcf FILE, no case")
    selected = cases.select(names)
    if mjcf is not None and len(selected) != 1:
        raise ValueError(f"--mjcf with cases judges one model against one case; name one case, or none to judge "
                         f"the model against its own tree (known cases: {', '.join(cases.names())})")
    return selected


def _add_quiet(p: argparse.ArgumentParser) -> None:
    g = p.add_mutually_exclusive_group()
    g.add_argument("--quiet", "-q", action="store_true", help="print the failures and the verdict line only")
    g.add_argument("--verbose", "-v", action="store_true",
                   help="also print every check as a table: its figure, budget parts, limit and verdict")


def _case_lines(args: argparse.Namespace) -> dict:
    """Where run_all prints each case's line as it finishes: stdout (flushed, terminal or not) unless
    --quiet or --json, which keep stdout for the verdict or the document (then stderr where it is not a
    terminal, a progress bar where it is)."""
    return {"lines": True} if args.quiet or getattr(args, "json", False) else {"out": sys.stdout}


def _trees(results: Sequence) -> dict[str, dict[str, str] | None]:
    """Each case's forces its own tree's reference leaves out (None: a hand-derived case)."""
    return {r.case.name: (dict(r.settings.tree["not examined"]) if r.settings.tree is not None else None)
            for r in results}


def _limits(results: Sequence) -> dict[str, list[str]]:
    """Each case's statements of the integrators run beyond their stability limit, the model's own first."""
    return {r.case.name: [s.statement() for s in r.stability.values() if s.beyond] for r in results}


def _peers(results: Sequence) -> dict[str, dict | None]:
    """Each case's three-way comparison (None where it did not run: a backend other than C)."""
    return {r.case.name: r.settings.peers for r in results}


def _print_checks(outcome: Outcome, *, quiet: bool, verbose: bool = False, written: str = "",
                  trees: dict[str, dict[str, str] | None] | None = None,
                  peers: dict[str, dict | None] | None = None, opinions: Sequence[str] = (),
                  limits: dict[str, list[str]] | None = None) -> None:
    """After the cases' lines: what each model's own tree covered (``trees``), the second opinions' summary
    (``peers``: each case's three-way comparison, :func:`harness.opinions.threeway.summary`; a hand-derived case's
    with ``verbose`` only: the model one brings is the one that needs it) with the other second opinions'
    ``opinions`` (a URDF's comparison, Pinocchio's MJCF parser's: :mod:`harness.opinions.urdf`), the integrators run
    beyond their stability limit (``limits``, by case), every check as a table
    (``verbose``), each failed check with its budget, the requirements judged, ``written`` (what was
    written), and the verdict line last (and the requirements' line, where stated); ``quiet``: the
    failures and the verdict only. All but the table and the verdict's lines fit the terminal
    (:func:`~harness.outputs.table.terminal_width`)."""
    width = terminal_width()
    failures = failures_block(outcome.checks, width)
    fitness = fitness_table(outcome)
    coverage = coverage_block(trees or {}, width)
    parts = [coverage] if coverage and not quiet else []
    beyond = stability_block(limits or {}, width)  # the method's limit, said even when quiet: its figures are n/a
    parts += [beyond] if beyond else []
    shown = {case: doc for case, doc in (peers or {}).items() if verbose or (trees or {}).get(case) is not None}
    said = [*(threeway.summary(shown) if not quiet else ()), *opinions]
    parts += ["\n".join(line for text in said for line in wrap(text, width))] if said else []
    parts += [checks_table(outcome.checks)] if verbose and not quiet else []
    parts += [failures] if failures else []
    parts += [fitness] if fitness and not quiet else []
    parts += ["\n".join(wrap(written, width))] if written and not quiet else []
    last = "\n".join(line for line in (verdict_line(outcome), fitness_line(outcome)) if line)
    text = "\n\n".join([*parts, last]) if quiet else "\n" + "\n\n".join([*parts, last])
    print("\n".join(terminal(line) for line in text.split("\n")))  # names from files and models: no escapes act


def _add_run_options(p: argparse.ArgumentParser) -> None:
    """How the cases run and what decides the exit code (run, check)."""
    g = p.add_argument_group("how the cases run (default: as shipped)")
    g.add_argument("--timestep", type=_seconds, metavar="SECONDS", help="run every model at this timestep")
    g.add_argument("--horizon", type=_seconds, metavar="SECONDS", help="simulate this long (default: the case's)")
    g.add_argument("--integrators", type=_names, metavar="NAMES",
                   help=f"run only these, comma-separated (default: every one: {', '.join(available_integrators())})")
    g.add_argument("--q0", type=_state, metavar="NAME=VALUE,...",
                   help="initial coordinates (the case's names; needs one case); the rest as the case has them, "
                        "then brought onto the constraints")
    g.add_argument("--qd0", type=_state, metavar="NAME=VALUE,...", help="initial velocities, as --q0")
    _add_backend(g)
    g = p.add_argument_group("a second opinion on the model (needs pip install 'mjharness[pin]')")
    g.add_argument("--urdf", type=Path, metavar="FILE",
                   help="the robot's URDF, compared with the MJCF (--mjcf, or the one case's) body by body and joint "
                        "by joint: mass, centre of mass, inertia, axes, limits, M(q) and gravity torques; a "
                        "difference over tolerance fails (exit 1)")
    g.add_argument("--urdf-map", type=Path, metavar="FILE",
                   help='TOML renaming the URDF\'s names to the MJCF\'s: [bodies] link = "body", [joints] a = "b"')
    g = p.add_argument_group("verdict")
    g.add_argument("--require", action="append", default=[], metavar="MEASURE=VALUE",
                   help="the accuracy you need, judged on each model's own integrator (e.g. position=1e-3, "
                        "drift.energy=1e-4, force=1e-3; repeatable): exit 3 where the checks pass and it is not met")
    g.add_argument("--accept-known-defects", action="store_true",
                   help="let a failure that shows the signature of a documented defect of this MuJoCo (shown as "
                        "FAIL, known defect) not fail the exit code")


def _add_backend(g) -> None:
    g.add_argument("--backend", type=_backend, default="c", metavar="|".join([*backends.BACKENDS, "all"]),
                   help="the engine every run goes to (default c: MuJoCo's C engine; mjx float32 and mjx-f64 need "
                        "pip install 'mjharness[mjx]')")


def _backend(text: str) -> str:
    try:
        backends.expand(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def _number(text: str) -> float:
    """``text`` as a float; nan where it is none (the caller's range check then refuses it)."""
    try:
        return float(text)
    except ValueError:
        return math.nan


def _seconds(text: str) -> float:
    value = _number(text)
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a positive number of seconds, got {text!r}")
    return value


def _requirement(text: str) -> str:
    """A package requirement for ``uv pip install``: never an option (``-e``, ``--index-url``: it would be taken as
    one, and could install from anywhere)."""
    if not text.strip() or text.lstrip().startswith("-"):
        raise argparse.ArgumentTypeError(f"{text!r} is not a package requirement (it would reach the installer as an "
                                         "option); accepted: a requirement such as 'mujoco-mjx=={version}'")
    return text


def _folder(text: str) -> Path:
    """A folder argument: an empty one names no folder (it would mean the current one, silently)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("names no folder (an empty path would mean the current folder); give a "
                                         "folder, e.g. mjharness-report")
    return Path(text)


def _tiny(text: str) -> float:
    value = _number(text)
    if not (math.isfinite(value) and 0 < abs(value) <= 1e-6):  # float32's round-off (MJX) is 1.2e-7
        raise argparse.ArgumentTypeError(f"must be a nonzero number within ±1e-6 (round-off sized), got {text!r}")
    return value


def _names(text: str) -> tuple[str, ...]:
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    unknown = [n for n in names if n not in available_integrators()]
    if not names or unknown:
        raise argparse.ArgumentTypeError(f"unknown integrator(s) {', '.join(unknown) or repr(text)}; this MuJoCo "
                                         f"offers {', '.join(available_integrators())}")
    return names


def _state(text: str) -> dict[str, float]:
    out = {}
    for item in text.split(","):
        name, sep, value = item.partition("=")
        number = _number(value)
        if not sep or not name.strip() or not math.isfinite(number):
            raise argparse.ArgumentTypeError(f"expected NAME=VALUE,... with finite numbers, got {item!r}")
        out[name.strip()] = number
    return out


def _options(args: argparse.Namespace, selected: Sequence[cases.Case], *, several: bool = False) -> RunOptions:
    """The run options the flags ask for; --q0/--qd0 name one case's coordinates, so need one case."""
    if (args.q0 or args.qd0) and len(selected) != 1:
        raise ValueError("--q0 and --qd0 name one case's coordinates; name exactly one case "
                         f"(known cases: {', '.join(cases.names())})")
    for case in selected:
        case.with_motion(q0=args.q0, qd0=args.qd0, horizon=args.horizon)  # ValueError naming what is wrong
    # a malformed --require, or one no figure of these cases answers: refused before the run, not after it
    require.check_possible(require.parse(getattr(args, "require", ())),
                           (n for case in selected for n in figure_names(case)))
    max_steps()  # and a malformed MJHARNESS_MAX_STEPS
    chosen = backends.expand(args.backend)
    if len(chosen) > 1 and not several:
        raise ValueError(f"--backend {args.backend}: {args.command} runs one backend ({', '.join(chosen)} asked); "
                         "`mjharness run --backend all` shows them side by side")
    for name in chosen:
        backends.check_installed(name)  # not installed: one line naming the fix, before any work
    return RunOptions(mjcf=args.mjcf, timestep=args.timestep, integrators=args.integrators, horizon=args.horizon,
                      q0=args.q0, qd0=args.qd0, perturb=getattr(args, "perturb", None), backend=chosen[0])


def _outcome(args: argparse.Namespace, results: Sequence, checks: dict[str, list[Check]], limits) -> Outcome:
    requirements = (*limits.requirements, *require.parse(args.require))
    require.check_known(requirements, results)
    return outcome_of(results, checks, requirements=requirements,
                      accept_known_defects=args.accept_known_defects or limits.accept_known_defects)


def _add_systems(p: argparse.ArgumentParser) -> None:
    p.add_argument("--systems", action="append", type=_systems_directory, metavar="DIR",
                   help="also discover the cases of your own systems in DIR: NAME.py (the analytic system), "
                        "NAME.xml (its MJCF), NAME.limits.toml (repeatable; installed packages' come through the "
                        f"entry point group {sources.GROUP})")


def _systems_directory(text: str) -> Path:
    try:
        sources.directory_source(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return Path(text)


def _add_selection(p: argparse.ArgumentParser, *, mjcf: bool = True) -> None:
    p.add_argument("cases", nargs="*", metavar="CASE", help="case names (default: all)")
    p.add_argument("--case", action="append", metavar="NAME", help="a case name (same as CASE; repeatable)")
    _add_systems(p)
    p.add_argument("--config", type=Path, metavar="FILE",
                   help="TOML: limits of your own ([thresholds.CASE] \"FIGURE\" = LIMIT), requirements "
                        "([require] QUANTITY = SIZE) and accept_known_defects = true")
    p.add_argument("--jobs", "-j", type=_positive, metavar="N",
                   help=f"worker processes for the cases (default: one per CPU, here {cpus()}); "
                        "the results do not depend on N")
    if mjcf:
        p.add_argument("--mjcf", type=Path, metavar="PATH",
                       help="validate this MJCF: with no case, any model against its own kinematic tree; with "
                            "one case, your variant of that case's model against the case's reference and limits")
        p.add_argument("--keyframe", metavar="NAME", help="with --mjcf and no case: start at this keyframe "
                                                          "(default: qpos0, every joint set moving)")
        p.add_argument("--ctrl", type=_state, metavar="NAME=VALUE,...",
                       help="with --mjcf and no case: actuator controls by name (default: the keyframe's, else 0)")


def _add_executor(p: argparse.ArgumentParser) -> None:
    p.add_argument("--executor", choices=EXECUTORS, default="local",
                   help="where the runs go: local (worker processes on this machine, the default) or ray (a Ray "
                        "task each, pip install 'mjharness[ray]'); the results do not depend on it")
    p.add_argument("--ray-address", metavar="HOST:PORT",
                   help="with --executor ray: the cluster to use (default: $RAY_ADDRESS, else a local cluster "
                        "started and stopped by this command)")


def _executor(args: argparse.Namespace) -> Executor:
    """The executor ``--executor``/``--ray-address`` ask for; Ray not installed: one line naming the fix."""
    if args.ray_address is not None and args.executor != "ray":
        raise ValueError("--ray-address needs --executor ray")
    if args.executor == "ray" and importlib.util.find_spec("ray") is None:
        raise ValueError("--executor ray: Ray is not installed; fix: pip install 'mjharness[ray]'")
    return Executor(args.executor, args.ray_address)


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
    _add_systems(p)


def cmd_list(args: argparse.Namespace) -> int:
    """A case a line or a few: its name, then its description and tags wrapped beside it to the terminal's
    width (:func:`~harness.outputs.table.terminal_width`)."""
    unavailable = cases.unavailable()
    rows = [(c.name, f"{c.description} [{','.join(sorted(c.tags))}]") for c in cases.all_cases()]
    rows += [(name, f"not run here: {why} [n/a]") for name, why in unavailable.items()]
    names = max(len(name) for name, _ in rows) + 2
    width = terminal_width()
    for name, text in rows:
        if width - names >= 30:  # the text beside the name, in a column of its own
            lines = textwrap.wrap(text, width - names, break_on_hyphens=False)
            print("\n".join(f"{name if i == 0 else '':<{names}}{line}" for i, line in enumerate(lines)))
        else:  # too narrow for a column: the text below the name
            print("\n".join([name, *wrap(text, width, "    ", "")]))
    return EXIT_OK


def _add_junit(p: argparse.ArgumentParser) -> None:
    p.add_argument("--junit", type=Path, metavar="FILE", help="also write JUnit XML (one testcase per check)")


def _check_junit(path: Path | None, report: Path | None = None) -> None:
    """Refuse an unusable --junit path before any work is done: a directory, an unwritable place, or (with
    ``report``, the --out of ``run``) one of the report's own files, which the JUnit would replace."""
    if path is not None:
        if path.is_dir():
            raise ValueError(f"--junit {str(path)!r} is a directory; give a file name")
        names: tuple[str, ...] = (*REPORT_FILES, *PAGES)
        names = (*names, *(n + STALE for n in names))
        if report is not None and any(_same_file(path, report / name) for name in names):
            raise ValueError(f"--junit {str(path)!r} is a file of the report in {str(report)!r} "
                             f"({', '.join(REPORT_FILES)}); give another name, e.g. {str(report / 'junit.xml')!r}")
        check_output(path.parent)


def _same_file(a: Path, b: Path) -> bool:
    """Whether ``a`` and ``b`` name the same file (neither need exist): their absolute paths with links resolved."""
    return a.resolve() == b.resolve()


def _junit(path: Path | None, outcome: Outcome) -> dict[Path, str]:
    """The JUnit file to write with the command's other outputs (none without --junit)."""
    if path is None:
        return {}
    prepare_output(path.parent)
    return {path: junit_xml(outcome.checks, accept_known_defects=outcome.accept_known_defects)}


def _add_out(p: argparse.ArgumentParser, default: Path, what: str) -> None:
    """--out and --force-out, as every command that writes a folder of files takes them: a new or empty folder, or
    one an earlier run wrote (its manifest: :func:`harness.outputs.files.check_report_folder`)."""
    p.add_argument("--out", type=_folder, default=default, metavar="DIR",
                   help=f"where to write {what} (default: ./{default}); a new or empty folder, or one an earlier "
                   "mjharness run wrote: only the files it wrote there (its manifest) are replaced or removed")
    p.add_argument(FORCE, dest="force_out", action="store_true",
                   help="write into --out even if it is not yours or holds other files (those are never removed; "
                   "a file of the output's own name is replaced)")


def _args_run(p: argparse.ArgumentParser) -> None:
    _add_selection(p)
    _add_out(p, Path("mjharness-report"), "the report")
    p.add_argument("--no-studies", dest="studies", action="store_false",
                   help="skip layer 4 (convergence, softness, solver and contact studies) and the seed audit")
    _add_junit(p)
    _add_quiet(p)
    _add_run_options(p)
    _add_executor(p)


def cmd_run(args: argparse.Namespace) -> int:
    from harness.outputs.drawings import draw_report  # lazy: studies and plots load sympy and matplotlib
    from harness.outputs.inertia import inertia_banners, inertia_page  # lazy: matplotlib, as above
    from harness.outputs.report import report_files  # lazy: as above

    start = time.perf_counter()
    check_report_folder(args.out, force=args.force_out)  # fail before minutes of work, not after
    _check_junit(args.junit, args.out)
    selected = _selected(args)  # first: a model too large for its reference is refused before anything runs
    opinions = _opinions(args)
    options = _options(args, selected, several=True)
    executor = _executor(args)
    results, checks, limits = run_all(selected, args.config, options, jobs=args.jobs, executor=executor,
                                      **_case_lines(args))
    outcome = _outcome(args, results, checks, limits)
    inertials = _inertials(args, selected, limits)
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
                 for name, r, c in run_backends(selected, args.config, options, others)]
        pages = [*pages, Page(BACKENDS_PAGE, "Backends side by side", "every gated figure of each case on each "
                              "backend, and the findings", (side_by_side_html(runs),))]
        appendix = (appendix or {}) | {"backends": side_by_side_json(runs)}
    with heartbeat("the report: pages"):
        files = report_files(args.out, results, outcome, config_source=limits.source, pages=pages,
                             appendix=appendix, plots=plots, banners=inertia_banners(inertials))
    prepare_output(args.out)
    # the report and its JUnit, all or none, and an earlier report's pages this one has not removed with them
    paths = write_atomic(with_manifest(args.out, files | _junit(args.junit, outcome)),
                         remove=superseded(args.out, files))
    _print_checks(outcome, quiet=args.quiet, verbose=args.verbose, trees=_trees(results), limits=_limits(results),
                  peers=_peers(results), opinions=[*opinions.lines(quiet=args.quiet),
                                                   *inertials.lines(quiet=args.quiet)],
                  written=f"wrote in {time.perf_counter() - start:.1f} s: {_written(args.out, paths)}")
    return _exit_code(outcome, opinions, inertials)


def _written(out: Path, paths: Sequence[Path]) -> str:
    """The files written, the case pages counted rather than listed."""
    cases = out / CASE_PAGES
    pages = [p for p in paths if p.parent == cases]
    listed = [str(p) for p in paths if p.parent != cases]
    return ", ".join(listed + ([f"{len(pages)} case page(s) in {cases}"] if pages else []))


def _args_check(p: argparse.ArgumentParser) -> None:
    _add_selection(p)
    _add_junit(p)
    p.add_argument("--json", action="store_true", help="print the run as JSON (report.json schema) "
                                                       "instead of the table")
    p.add_argument("--perturb", type=_tiny, metavar="SIZE",
                   help="move every initial coordinate and velocity x by SIZE × max(|x|, 1) (round-off: SIZE within "
                        "±1e-6, e.g. 1e-15 or =-1e-15 in float64, 5e-7 on a float32 backend): how far each figure "
                        "moves at round-off, its run-to-run noise (mjharness versions measures it so)")
    _add_quiet(p)
    _add_run_options(p)
    _add_executor(p)


def cmd_check(args: argparse.Namespace) -> int:
    _check_junit(args.junit)
    selected = _selected(args)  # first: a model too large for its reference is refused before anything runs
    opinions = _opinions(args)
    # with --json, stdout is the document alone: what a library prints meanwhile goes to stderr (mujoco-mjx
    # prints "Failed to import warp" to stdout when it is imported without Warp)
    with contextlib.redirect_stdout(sys.stderr) if args.json else contextlib.nullcontext():
        results, checks, limits = run_all(selected, args.config, _options(args, selected), jobs=args.jobs,
                                          figures_only=True, executor=_executor(args), **_case_lines(args))
    outcome = _outcome(args, results, checks, limits)
    inertials = _inertials(args, selected, limits)
    write_atomic(_junit(args.junit, outcome))
    if args.json:
        appendix = ({"opinions": opinions.as_dict()} if opinions.as_dict() else {}) | {
            "inertials": inertials.as_dict()}
        sys.stdout.write(dumps(json_doc(results, outcome, appendix=appendix)))
    else:
        _print_checks(outcome, quiet=args.quiet, verbose=args.verbose, trees=_trees(results), limits=_limits(results),
                      peers=_peers(results), opinions=[*opinions.lines(quiet=args.quiet),
                                                       *inertials.lines(quiet=args.quiet)])
    return _exit_code(outcome, opinions, inertials, json=args.json)


def _inertials(args: argparse.Namespace, selected: Sequence[cases.Case], limits):
    """The inertia audit (harness.inertia) of the models judged: --mjcf's, else each case's, and --urdf's own
    inertials against its own meshes, the bodies the config's [accept_inertia] names accepted."""
    from harness.inertia.models import audit_files  # lazy: scipy's start-up, paid by the audit alone

    models = [(args.mjcf.name, args.mjcf)] if args.mjcf is not None else [(c.name, c.mjcf) for c in selected]
    return audit_files(models, urdf=args.urdf, accept=limits.accept_inertia, own=args.mjcf is not None)


def _opinions(args: argparse.Namespace):
    """The second opinions on the model (harness.opinions.urdf), bad input named before any case is built: the
    URDF's comparison where --urdf is given (with --mjcf, or one case's model), Pinocchio's MJCF parser's on a
    model of your own (--mjcf)."""
    from harness.opinions.urdf import model_opinions  # lazy: Pinocchio is optional

    mjcf = args.mjcf
    if mjcf is None and args.urdf is not None:
        named = cases.select([*args.cases, *(args.case or [])])
        mjcf = named[0].mjcf if len(named) == 1 else None
    own = args.mjcf is not None and not [*args.cases, *(args.case or [])]  # a model of your own, no case
    with heartbeat(f"{Path(mjcf).name if mjcf is not None else 'model'}: second opinions"):  # Pinocchio's: slow
        return model_opinions(mjcf, urdf=args.urdf, mapping=args.urdf_map, parser=own and not args.quiet)


def _exit_code(outcome: Outcome, opinions, inertials, *, json: bool = False) -> int:
    """The checks' exit code, made a fail where the URDF disagrees with the MJCF or a body's inertial cannot lie
    in its geometry (each printed under the verdict; on stderr where stdout holds the JSON document alone)."""
    failed = [part for part in (opinions, inertials) if part.failed]
    for part in failed:
        print(part.verdict(), file=sys.stderr if json else sys.stdout)
    if failed:
        return EXIT_FAIL if outcome.exit_code in (EXIT_OK, EXIT_UNFIT) else outcome.exit_code
    return outcome.exit_code


def _args_diff(p: argparse.ArgumentParser) -> None:
    p.add_argument("old", type=Path, metavar="OLD", help="report.json, check --json output or a baseline "
                                                         "(file or directory) before")
    p.add_argument("new", type=Path, metavar="NEW", help="the same after")
    p.add_argument("--all", action="store_true", help="list every figure, unchanged ones and those whose "
                                                      "new/old prints as 1 too")
    p.add_argument("--case", action="append", default=[], metavar="NAME", help="only this case (repeatable)")
    p.add_argument("--figure", action="append", default=[], metavar="PATTERN",
                   help="only the figures matching this name or glob pattern, e.g. RK4.position or 'RK4.*' "
                        "(repeatable)")
    p.add_argument("--exact", action="store_true",
                   help="exit 1 unless every figure and verdict of both runs is identical")


def cmd_diff(args: argparse.Namespace) -> int:
    diff = select(diff_runs(load_run(args.old), load_run(args.new)), cases=args.case, figures=args.figure)
    print(format_diff(diff, show_all=args.all), end="")
    return EXIT_FAIL if args.exact and not diff.identical else EXIT_OK


def _args_versions(p: argparse.ArgumentParser) -> None:
    p.add_argument("releases", nargs="+", metavar="RELEASE",
                   help="MuJoCo releases to compare (3.17.0 4.0.0), or a range LO..HI: every release the package "
                        "index offers from LO to HI (3.3.0..4.0.0); 3.3.0 and later")
    p.add_argument("--bisect", metavar="CASE:FIGURE|verdicts",
                   help="find the first release of the range at which this figure moved beyond its noise (or any "
                        "verdict flipped), installing only the releases the bisection needs")
    _add_out(p, Path("mjharness-versions"), "versions.html, versions.json and versions.txt")
    p.add_argument("--backend", metavar="NAME",
                   help="install the backend's packages in every environment and run the check with --backend NAME")
    p.add_argument("--with", dest="extras", action="append", default=[], metavar="REQUIREMENT", type=_requirement,
                   help="an extra package for every environment ('{version}' is the MuJoCo release, e.g. "
                        "'mujoco-mjx=={version}'; repeatable)")
    p.add_argument("--parallel", type=_positive, metavar="N",
                   help="releases run at once (default: as many as CPUs, here "
                        f"{cpus()}; one with --bisect)")
    p.add_argument("--jobs", "-j", type=_positive, metavar="N",
                   help="worker processes of each release's check (default: the CPUs left per release, at least 1)")
    p.add_argument("--no-plots", dest="plots", action="store_false", help="versions.html without the plots")
    _add_executor(p)


def cmd_versions(args: argparse.Namespace) -> int:
    from harness.versions import bisect as bisection  # lazy: only this command builds environments
    from harness.versions import changes_report as report  # lazy: as above
    from harness.versions import envs, releases, session  # lazy: as above
    from harness.versions.runs import CheckCommand, check_environ, noise_runs  # lazy: as above

    check_report_folder(args.out, force=args.force_out)  # before any environment is built
    check_args = list(getattr(args, "check_args", []))
    extras = list(args.extras)
    if args.backend is not None:
        if args.backend not in envs.BACKENDS:
            raise ValueError(f"unknown backend {args.backend!r} for versions; accepted: "
                             f"{', '.join(envs.BACKENDS)} (one backend per run)")
        check_args += ["--backend", args.backend]
    checked = _check_options(check_args)
    target = bisection.parse_target(args.bisect) if args.bisect else None
    if target is not None and target.case is not None:
        cases.select([target.case])  # an unknown case: one line naming the known ones
        if not (checked.cases or checked.case):
            check_args += ["--case", target.case]  # only the case the figure belongs to
    executor = _executor(args)
    if executor.kind == "ray" and target is not None:
        raise ValueError("--bisect runs one release after another (each depends on the last): use it without "
                         "--executor ray")
    chosen = releases.parse_selection(args.releases)
    refused = _backend_refusals(args.backend, chosen)
    added = {r: envs.backend_packages(args.backend, r) for r in chosen if r not in refused} if args.backend else {}
    check_output(args.out)
    parallel = 1 if target is not None else (args.parallel or min(len(chosen), cpus()))
    jobs = args.jobs or max(1, cpus() // parallel)
    root = envs.source_root()
    builder = envs.Builder(uv=envs.find_uv(), root=envs.envs_root(), source=root)
    command = CheckCommand(args=tuple(check_args), jobs=jobs, cwd=Path.cwd(), environ=check_environ())
    digest = envs.source_hash(root)
    noise = noise_runs(backends.PRECISION[args.backend or "c"])  # moves that survive the backend's arithmetic

    def done(run) -> None:
        if sys.stderr.isatty():
            state = "ran" if run.ok else f"failed: {run.error}"
            print(f"MuJoCo {run.release}: {state} ({run.env_seconds + run.check_seconds:.0f} s)", file=sys.stderr)

    if target is not None:
        comparison = session.bisect_releases(builder, chosen, digest, command, target, extras=extras,
                                             pinned=envs.pins(), refused=refused, added=added,
                                             noise=noise, on_done=done)
    else:
        comparison = session.compare_releases(builder, chosen, digest, command, extras=extras, pinned=envs.pins(),
                                              parallel=parallel, refused=refused, added=added,
                                              noise=noise, on_done=done, executor=executor)
    summary = report.text(comparison)
    prepare_output(args.out)
    write_atomic(with_manifest(args.out, {args.out / "versions.txt": summary,
                                          args.out / "versions.json": dumps(report.json_doc(comparison)),
                                          args.out / "versions.html": report.html_page(comparison,
                                                                                       plots=args.plots)}))
    print(summary, end="")
    print(f"wrote {args.out / 'versions.html'}, {args.out / 'versions.json'}, {args.out / 'versions.txt'}")
    stopped = comparison.bisection is not None and comparison.bisection.errors
    return EXIT_FAIL if comparison.errors or stopped else EXIT_OK


def _args_sweep(p: argparse.ArgumentParser) -> None:
    p.add_argument("models", nargs="+", metavar="MODEL",
                   help="zoo models (dm_control/acrobot, or a stem: acrobot), MJCF files (robot.xml), or shipped "
                        "cases (case:pendulum)")
    p.add_argument("--releases", nargs="+", required=True, metavar="RELEASE",
                   help="MuJoCo releases (3.17.0 4.0.0) or a range LO..HI: every release the package index offers "
                        "from LO to HI (3.3.0..4.0.0); 3.3.0 and later")
    p.add_argument("--backends", type=_backend_list, default=("c",), metavar="NAMES",
                   help="comma-separated backends, each cell run with check --backend NAME (default: c; "
                        "mjx where the index has mujoco-mjx of the release, else the cell is n/a)")
    p.add_argument("--integrators", type=_names, metavar="NAMES",
                   help="judge on these integrators only (default: every one, as check)")
    p.add_argument("--timeout", type=_seconds, metavar="SECONDS",
                   help="stop each cell's check after so long (the cell: error)")
    _add_out(p, Path("mjharness-sweep"), "sweep.md and sweep.json")
    p.add_argument("--jobs", "-j", type=_positive, metavar="N",
                   help="cells at once on this machine (default: one per CPU); on Ray, one task per CPU of the cluster")
    _add_executor(p)


def _backend_list(text: str) -> tuple[str, ...]:
    """``c,mjx``: the sweep's backends, each once."""
    from harness.versions import envs  # lazy: only the sweep needs it

    names = tuple(dict.fromkeys(n.strip() for n in text.split(",") if n.strip()))
    unknown = [n for n in names if n not in envs.BACKENDS]
    if unknown or not names:
        raise argparse.ArgumentTypeError(f"unknown backend(s) {', '.join(unknown) or 'none'}; accepted: "
                                         f"{', '.join(envs.BACKENDS)} (comma-separated)")
    return names


def cmd_sweep(args: argparse.Namespace) -> int:
    from harness import zoo  # lazy: only the zoo's commands read the zoo
    from harness.versions import envs, releases, sweep  # lazy: only this command builds environments
    from harness.versions import sweep_report as report  # lazy: as above

    check_report_folder(args.out, force=args.force_out)  # before any environment is built
    executor = _executor(args)
    models = zoo.sweep_models(args.models)
    chosen = releases.parse_selection(args.releases)
    refused = {(r, b): why for b in args.backends for r, why in _backend_refusals(b, chosen, every=True).items()}
    check_output(args.out)
    root = envs.source_root()
    builder = envs.Builder(uv=envs.find_uv(), root=envs.envs_root(), source=root)
    shipped = envs.Shipped.of(builder, envs.source_hash(root))  # built once here, carried by every task
    tasks = sweep.plan(models, chosen, args.backends, shipped=shipped, root=envs.envs_root(), pinned=envs.pins(),
                       packages=lambda b, r: envs.backend_packages(b, r), refused=refused,
                       integrators=args.integrators or (), timeout=args.timeout)
    command = " ".join(["mjharness", *sys.argv[1:]]) if sys.argv[1:2] == ["sweep"] else "mjharness sweep"
    result = sweep.run(tasks, workers=args.jobs or cpus(), executor=executor, command=command,
                       on_done=lambda cell: print(cell.line(), flush=True))
    prepare_output(args.out)
    paths = write_atomic(with_manifest(args.out, {args.out / "sweep.md": report.markdown(result),
                                                  args.out / "sweep.json": dumps(report.json_doc(result))}))
    print(report.text(result) + f"wrote {', '.join(str(p) for p in paths)}", flush=True)
    return EXIT_FAIL if result.errors else EXIT_OK


def _check_options(check_args: Sequence[str]) -> argparse.Namespace:
    """The check options ``versions`` passes through (after ``--``), parsed as ``check`` parses them here,
    so a mistake is one line before anything is installed."""
    if "--json" in check_args:
        raise ValueError("the check options after -- need no --json: versions always reads the check's JSON")
    if any(a == "--perturb" or a.startswith("--perturb=") for a in check_args):
        raise ValueError("the check options after -- may not set --perturb: versions sets it for the noise runs")
    parser = _CheckOptions(prog="mjharness versions ... --", add_help=False)
    _args_check(parser)
    return parser.parse_args(list(check_args))


def _backend_refusals(backend: str | None, chosen: Sequence, *, every: bool = False) -> dict:
    """The releases ``backend`` cannot run because the package index has no release of its package under
    the same number (mujoco-mjx for MuJoCo 4.0.0), each with its one-line reason; ValueError where that
    is every chosen release, unless ``every`` (a sweep: each such cell says why)."""
    from harness.versions import envs, releases  # lazy: only the versions command needs them

    package = envs.SAME_RELEASE.get(backend or "")
    if package is None:
        return {}
    offered = []
    for text in releases.pip_index_versions(package):
        with contextlib.suppress(ValueError):  # a pre-release (3.3.0rc1) is no release of MuJoCo's number
            offered.append(releases.Release(text))
    span = "none" if not offered else str(min(offered)) if min(offered) == max(offered) else \
        f"{min(offered)} … {max(offered)}"
    refused = {r: f"the package index has no {package} {r} (it offers {span}), which backend {backend!r} needs "
                  "at the same release" for r in chosen if r not in offered}
    if refused and len(refused) == len(chosen) and not every:
        raise ValueError(f"--backend {backend}: the package index has no {package} of "
                         f"{', '.join(str(r) for r in chosen)} (it offers {span}); choose releases in that span")
    return refused


class _CheckOptions(_Parser):
    def error(self, message: str) -> NoReturn:  # raised, not printed: the command's one line names it
        raise ValueError(f"the check options after -- are not ones `mjharness check` takes here: {message}")


def _args_baseline(p: argparse.ArgumentParser) -> None:
    _add_selection(p, mjcf=False)
    mode = p.add_mutually_exclusive_group(required=True)
    mode.add_argument("--write", type=Path, metavar="PATH",
                      help="run the cases and write their gated figures: a directory gets one file per case "
                           "(naming cases updates only those), a .json file all cases in one")
    mode.add_argument("--compare", type=Path, metavar="PATH",
                      help="run the cases and fail (exit 1) where a figure regressed against PATH")


def cmd_baseline(args: argparse.Namespace) -> int:
    selected = _selected(args)
    if args.write is not None:
        check_output(baseline.output_dir(args.write))
        partial = bool(args.cases or args.case)
        old = load_run(args.write) if partial and baseline.exists(args.write) else None
        results, checks, _ = run_all(selected, args.config, jobs=args.jobs, figures_only=True)
        failing = [c for cs in checks.values() for c in cs if not c.passed and not c.known]  # a known defect is
        # what this MuJoCo does, documented: a baseline of this version records it
        if failing:
            print(checks_table(checks))
            print(f"mjharness: refusing to write a baseline while {len(failing)} check(s) fail", file=sys.stderr)
            return EXIT_FAIL
        new = baseline.baseline_doc(results, checks)
        baseline.write(args.write, new, old)
        count = sum(len(c["figures"]) for c in new["cases"].values())
        print(f"wrote {args.write}: {', '.join(new['cases'])} ({count} gated figures)")
        return EXIT_OK
    reference = load_run(args.compare)
    mismatch = baseline.version_mismatch(reference, source=str(args.compare))
    if mismatch:  # a baseline is per MuJoCo version: refuse before any work
        raise ValueError(mismatch)
    results, checks, _ = run_all(selected, args.config, jobs=args.jobs, figures_only=True)
    findings = [f for r in results for f in baseline.compare(
        reference, r.case.name, r.figures, checks[r.case.name], source=str(args.compare))]
    for f in findings:
        print(f.message)
    print(f"{len(findings)} regression(s) or missing entries against {args.compare} "
          f"(rule: new > {baseline.FACTOR:g} × max(old, {baseline.FLOOR:g} × limit))")
    return EXIT_FAIL if findings else EXIT_OK


def _args_limits(p: argparse.ArgumentParser) -> None:
    p.add_argument("cases", nargs="*", metavar="CASE", help="case names (default: all)")
    _add_systems(p)
    p.add_argument("--write", action="store_true",
                   help="run the cases that have no limits file and write one by the default rule (the "
                        "figures it gates, each judged by its budget or its theory limit); files that exist "
                        "are left as they are")
    p.add_argument("--jobs", "-j", type=_positive, metavar="N", help="worker processes (default: one per CPU)")


def cmd_limits(args: argparse.Namespace) -> int:
    selected = cases.select(args.cases)
    if not args.write:
        shipped = limits_data.load_limits()
        for case in selected:
            entry = shipped.cases.get(case.name)
            print(f"{case.name} ({limits_data.limits_path(case.mjcf)}): "
                  + (f"{len(entry.limits)} gated figures" if entry else "no limits file"))
            for name, lim in (entry.limits.items() if entry else ()):
                value = "" if lim.value is None else f"{lim.value:.3e}"
                print(f"  {name:42s} {value:>10s}  {lim.describe()}")
        return EXIT_OK
    missing = [case for case in selected if not limits_data.limits_path(case.mjcf).is_file()]
    for case in missing:  # every file must be writable before the work
        check_output(limits_data.limits_path(case.mjcf).parent)
    if not missing:
        print("every case named has its limits file; budgets are computed for each run, so there is nothing "
              "to rewrite (edit a file to gate another figure)")
        return EXIT_OK
    results, _, _ = run_all(missing, None, jobs=args.jobs, figures_only=True)
    files = {}
    for r in results:
        constrained = bool(r.case.dynamics().constraint_names)
        new = limits_data.default_limits(r.case.name, [f.name for f in r.figures], constrained=constrained)
        files[limits_data.limits_path(r.case.mjcf)] = limits_data.format_case_limits(new)
    for path in write_atomic(files):
        print(f"wrote {path}")
    return EXIT_OK


def _args_figures(p: argparse.ArgumentParser) -> None:
    p.add_argument("cases", nargs="*", metavar="CASE", help="case names (default: all)")
    _add_systems(p)
    p.add_argument("--config", type=Path, metavar="FILE", help="TOML overriding the shipped limits (shown as "
                                                               "basis 'user')")
    p.add_argument("--jobs", "-j", type=_positive, metavar="N", help="worker processes (default: one per CPU)")


def cmd_figures(args: argparse.Namespace) -> int:
    """Every figure a case measures, with its unit, what it measures and its limit with the basis. The
    descriptions are those the code that measures the figures gives them, so the cases run (as ``check``
    does: seconds, no report)."""
    results, _, limits = run_all(cases.select(args.cases), args.config, jobs=args.jobs, figures_only=True)
    width = terminal_width()
    print("\n".join(wrap("unit 1 = relative to the case's scale (m·g for forces, m·g·l for energy); a "
                         "budget-gated figure passes when what its budget does not explain is within the limit "
                         "the budget computes, a figure with a fixed limit when it is finite and ≤ it", width,
                         more="")))
    for r in results:  # per figure: its name, unit and what it measures; below, its limit and basis
        print("\n" + "\n".join(wrap(f"{r.case.name} — {r.case.description}", width, more="  ")))
        for f in r.figures:
            lim = limits.limit(r.case.name, f.name)
            gate = ("not gated" if lim is None else lim.describe() if lim.value is None
                    else f"limit {lim.value:.3g}: {lim.describe()}")
            print("\n".join([*wrap(f"{f.name} [{f.unit}]: {f.description}", width, "  ", "  "),
                             *wrap(gate, width, "      ", "  ")]))
    return EXIT_OK


def _args_converge(p: argparse.ArgumentParser) -> None:
    p.add_argument("cases", nargs="*", metavar="CASE", help="case names (default: all)")
    _add_systems(p)
    p.add_argument("--fast", action="store_true", help="the 3-timestep subset `check` gates (T ≤ 0.5 s)")
    p.add_argument("--softness", action="store_true", help="also sweep solref/solimp of the equality cases")
    p.add_argument("--solvers", action="store_true", help="also compare Newton, CG and PGS on the constrained cases")
    p.add_argument("--html", type=Path, metavar="FILE", help="also write the tables and plots as one HTML page")
    _add_backend(p)


def cmd_converge(args: argparse.Namespace) -> int:
    from harness.outputs.studies import draw, html_page, text  # lazy: the studies' plots load matplotlib
    from harness.studies import run_studies  # lazy: only this command runs them

    if args.html is not None:
        check_output(args.html.parent)
    chosen = backends.expand(args.backend)
    if len(chosen) > 1:
        raise ValueError(f"--backend {args.backend}: one backend per run for now ({', '.join(chosen)} asked); "
                         "run once per backend")
    backends.check_installed(chosen[0])  # not installed: one line naming the fix, before any work
    studies = run_studies(cases.select(args.cases), fast=args.fast, with_softness=args.softness,
                          with_solvers=args.solvers, progress=True, engine=backends.get(chosen[0]))
    print(text(studies))
    if args.html is not None:
        prepare_output(args.html.parent)
        write_atomic({args.html: html_page(studies, draw(studies))})
    return EXIT_OK if studies.passed else EXIT_FAIL


def _args_audit(p: argparse.ArgumentParser) -> None:
    p.add_argument("--json", action="store_true", help="print the verdicts as JSON instead of the table")


def cmd_audit(args: argparse.Namespace) -> int:
    from harness.audit.verdicts import audit  # lazy: sympy, only for this command
    from harness.outputs.audit import format_table, json_rows  # lazy: as above

    rows = audit()
    if args.json:
        sys.stdout.write(dumps(json_rows(rows)))
    else:
        print(format_table(rows))
    return EXIT_OK


def _args_faults(p: argparse.ArgumentParser) -> None:
    p.add_argument("cases", nargs="*", metavar="CASE", help="case names (default: all)")
    _add_systems(p)
    p.add_argument("--coarse", action="store_true",
                   help="also judge each fault at 2 × the timestep with MuJoCo's default softness, at its coarse size")
    p.add_argument("--jobs", "-j", type=_positive, metavar="N", help="worker processes (default: one per CPU)")
    _add_executor(p)


def cmd_faults(args: argparse.Namespace) -> int:
    from harness.outputs.studies.sensitivity import trials_table  # lazy: only the fault commands load the catalog
    from harness.studies import faults  # lazy: as above
    from harness.studies import sensitivity as study  # lazy: as above

    selected = cases.select(args.cases)
    calls = [(study.trial_named, (case.name, change.name, False)) for case in selected for change in faults.SETTINGS]
    calls += [(study.trial_named, (case.name, fault.name, coarse)) for case in selected for fault in faults.FAULTS
              for coarse in ((False, True) if args.coarse else (False,))]
    rows = run_tasks(calls, args.jobs or cpus(), on_done=_progress(len(calls)), executor=_executor(args),
                     labels=[f"faults {case} {change} (MuJoCo {mujoco.__version__}, backend c)"
                             for _, (case, change, _) in calls])
    print(trials_table(rows))
    judged = [r for r in rows if r.verdict != "n/a"]
    unexpected = [r for r in judged if not r.as_expected]
    print(f"{len(judged) - len(unexpected)} of {len(judged)} as expected (settings pass, faults fail)"
          + (f"; unexpected: {', '.join(f'{r.case} {r.change} ({r.setting})' for r in unexpected)}"
             if unexpected else ""))
    return EXIT_FAIL if unexpected else EXIT_OK


def _args_sensitivity(p: argparse.ArgumentParser) -> None:
    p.add_argument("cases", nargs="*", metavar="CASE", help="case names (default: all)")
    _add_systems(p)
    p.add_argument("--faults", type=lambda text: text.split(","), metavar="NAME,...",
                   help="the faults to size (default: every fault of the catalog)")
    p.add_argument("--jobs", "-j", type=_positive, metavar="N", help="worker processes (default: one per CPU)")
    _add_executor(p)


def cmd_sensitivity(args: argparse.Namespace) -> int:
    from harness.outputs.studies.sensitivity import table  # lazy: only the fault commands load the catalog
    from harness.studies import faults  # lazy: as above
    from harness.studies import sensitivity as study  # lazy: as above

    selected = cases.select(args.cases)
    chosen = [faults.by_name(name) for name in args.faults] if args.faults else list(faults.FAULTS)
    unknown = [f.name for f in chosen if f.kind != "fault"]
    if unknown:
        raise ValueError(f"--faults names settings, not faults: {', '.join(unknown)}; faults: "
                         f"{', '.join(f.name for f in faults.FAULTS)}")
    calls = [(study.sensitivity_named, (case.name, fault.name, coarse)) for case in selected for fault in chosen
             for coarse in (False, True)]
    rows = run_tasks(calls, args.jobs or cpus(), on_done=_progress(len(calls)), executor=_executor(args),
                     labels=[f"sensitivity {case} {fault} (MuJoCo {mujoco.__version__}, backend c)"
                             for _, (case, fault, _) in calls])
    print(table(rows))
    return EXIT_OK


def _args_zoo(p: argparse.ArgumentParser) -> None:
    p.add_argument("models", nargs="*", metavar="MODEL",
                   help="zoo models (dm_control/acrobot, or a stem: acrobot; default: every model installed); "
                        "with --folder, that folder's entries (robot/scene, or a stem)")
    p.add_argument("--folder", type=Path, metavar="DIR",
                   help="judge every MJCF entry of DIR instead, a folder of robots laid out like MuJoCo Menagerie's: "
                        "every .xml file under it whose root is <mujoco> and that no other <include>s (scene.xml, "
                        "not the robot.xml it includes)")
    _add_out(p, Path("reports/zoo"), "zoo.md and zoo.json")
    p.add_argument("--faults", action="store_true",
                   help="also find the smallest size of each engine-side fault (inertia, damping, axis tilt) caught")
    p.add_argument("--injection", action="store_true",
                   help="also find the smallest energy injection (energy from no force) each model's balance catches")
    p.add_argument("--fault-max-nv", type=_positive, metavar="N",
                   help="size the faults and injections on models of ≤ N dofs only")
    p.add_argument("--integrators", type=_names, metavar="NAMES",
                   help="judge the verdicts on these integrators only (default: every one, as check)")
    p.add_argument("--timeout", type=_seconds, metavar="SECONDS",
                   help="stop each model's verdict, and each model's fault study, after so long (unfinished)")
    p.add_argument("--jobs", "-j", type=_positive, metavar="N", help="worker processes (default: one per CPU)")
    _add_executor(p)


def cmd_zoo(args: argparse.Namespace) -> int:
    from harness import zoo  # lazy: only this command reads the zoo
    from harness.outputs.studies.engine_faults import cell as fault_cell  # lazy: as above
    from harness.outputs.studies.injection import cell as injection_cell  # lazy: as above

    check_report_folder(args.out, force=args.force_out)
    if args.folder is not None:
        models, passed = zoo.folder_models(args.folder)
        skipped: tuple = ()
        for line in passed:
            print(f"passed over: {line}", flush=True)
    else:
        models, skipped = zoo.discover()
    chosen = zoo.select(args.models, models, skipped)
    for s in skipped:
        print(f"skipped: {s.line()}", flush=True)
    if not chosen:
        raise ValueError("no zoo model is installed; " + "; ".join(s.pip for s in skipped))

    def done(result) -> None:  # one line per model (and per model's faults) as it ends, terminal or not
        if isinstance(result, zoo.ZooResult):
            lines = [result.line()]
        elif isinstance(result, zoo.Injection):
            lines = [f"{result.model}: injection on {result.joint or '-'}: {injection_cell(result)}"]
        elif all(c.size is None and not c.crashed and not c.unfinished for c in result):  # refused: no fault to size
            lines = [f"{result[0].model}: faults n/a ({result[0].note})"]
        else:
            lines = [f"{c.model}: fault {c.fault} on {c.target}: {fault_cell(c)}" for c in result]
        print("\n".join(lines), flush=True)

    run = zoo.run(chosen, jobs=args.jobs or cpus(), integrators=args.integrators, faults=args.faults,
                  fault_max_nv=args.fault_max_nv, injection=args.injection, skipped=skipped, on_done=done,
                  timeout=args.timeout, executor=_executor(args), found=args.folder is None,
                  command=" ".join(["mjharness", *sys.argv[1:]]) if sys.argv[1:2] == ["zoo"] else "mjharness zoo")
    prepare_output(args.out)
    paths = write_atomic(with_manifest(args.out, {args.out / "zoo.md": zoo.zoo_markdown(run),
                                                  args.out / "zoo.json": dumps(zoo.zoo_json(run))}))
    short = run.faults_short()
    print(f"{len(run.results)} models in {run.seconds:.0f} s: "
          + ", ".join(f"{sum(r.verdict == v for r in run.results)} {v}"
                      for v in ("pass", "fail", "refused", "crashed", "unfinished"))
          + "".join(f"; fault {f} {why}" for f, why in short.items())
          + f"; wrote {', '.join(str(p) for p in paths)}")
    return run.exit_code


def _progress(total: int) -> Callable[[int, object], None]:
    """A progress line on stderr as each of ``total`` runs finishes: rewritten in place on a terminal;
    elsewhere (a log) a line of its own at most every :data:`~harness.pipeline.matrix.PROGRESS_INTERVAL`."""
    log = None if sys.stderr.isatty() else LogProgress(range(total), "mjharness", "run")
    done = [0]

    def report(_i: int, _result: object) -> None:
        done[0] += 1
        if log is not None:
            log.update()
        else:
            print(f"\r{done[0]}/{total}", end="" if done[0] < total else "\n", file=sys.stderr, flush=True)
    return report


def _args_advise(p: argparse.ArgumentParser) -> None:
    p.add_argument("cases", nargs="?", default=None, metavar="CASE",
                   help="a shipped case (or one of --systems); none with --mjcf: your model against its own tree")
    _add_systems(p)
    p.add_argument("--mjcf", type=Path, metavar="PATH", help="the model: any MJCF, against its own kinematic tree")
    p.add_argument("--keyframe", metavar="NAME", help="with --mjcf: start at this keyframe (default: qpos0, every "
                                                      "joint set moving)")
    p.add_argument("--ctrl", type=_state, metavar="NAME=VALUE,...",
                   help="with --mjcf: actuator controls by name (default: the keyframe's, else 0)")
    p.add_argument("--require", action="append", default=[], metavar="MEASURE=VALUE", required=True,
                   help="the accuracy you need (e.g. position=1e-3, drift.energy=1e-4, force=1e-2; repeatable, at "
                        "least one): the recommendation is the cheapest setting that meets every one, verified")
    p.add_argument("--integrators", type=_names, metavar="NAMES",
                   help=f"consider only these, comma-separated (default: every one: "
                        f"{', '.join(available_integrators())})")
    p.add_argument("--horizon", type=_seconds, metavar="SECONDS", help="simulate this long (default: the case's)")
    p.add_argument("--json", action="store_true", help="print the advice as JSON instead of the text")
    p.add_argument("--html", type=Path, metavar="FILE", help="also write a page with the plot and the text")
    p.add_argument("--png", type=Path, metavar="FILE", help="also write the plot: error against timestep per "
                                                            "integrator, stability limits, the requirement and "
                                                            "the recommendation")


def cmd_advise(args: argparse.Namespace) -> int:
    from harness.outputs import advice as shown  # lazy: its plot loads matplotlib
    from harness.studies.advice import advise  # lazy: only this command runs it

    for path in (args.html, args.png):
        if path is not None:
            check_output(path.parent)
    requirements = require.parse(args.require)
    if (args.cases is None) == (args.mjcf is None):
        raise ValueError("advise needs one model: a case name, or --mjcf FILE (not both); known cases: "
                         + ", ".join(cases.names()))
    if args.mjcf is None and (args.keyframe or args.ctrl):
        raise ValueError("--keyframe and --ctrl apply to a model judged against its own tree: --mjcf FILE, no case")
    case = from_mjcf(args.mjcf, keyframe=args.keyframe, ctrl=args.ctrl, horizon=args.horizon) \
        if args.mjcf is not None else cases.get(args.cases)
    require.check_possible(requirements, figure_names(case))
    options = RunOptions(horizon=args.horizon if args.mjcf is None else None)
    with heartbeat(f"advise {case.name}"):
        found = advise(case, requirements, options=options, integrators=args.integrators)
    files: dict[Path, str | bytes] = {}
    png = shown.plot(found) if args.png is not None or args.html is not None else b""
    if args.png is not None:
        files[args.png] = png
    if args.html is not None:
        files[args.html] = shown.html_page([found], [png])
    if files:
        for path in files:
            prepare_output(path.parent)
        write_atomic(files)
    if args.json:
        sys.stdout.write(dumps(shown.as_dict(found)))
    else:
        print("\n".join(terminal(line) for line in shown.text(found).split("\n")))
        if files:
            print("wrote " + ", ".join(terminal(str(p)) for p in files))
    return EXIT_OK if found.recommended is not None else EXIT_UNFIT


@dataclass(frozen=True)
class Command:
    """A subcommand: ``help``, one line for the command list (``mjharness --help``); ``description``, more
    for ``mjharness NAME --help`` (``help`` when empty)."""

    help: str
    add_arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], int]
    description: str = ""


COMMANDS: dict[str, Command] = {
    "list": Command("list the cases", _args_list, cmd_list),
    "run": Command("run cases, write the report's pages, report.json and summary.md", _args_run, cmd_run),
    "check": Command("the CI gate: every gated figure judged by its budget, no report", _args_check, cmd_check,
                     "the CI gate: run the cases and judge every gated figure by its error budget or its "
                     "limit (exit 0 pass, 1 fail, 2 bad input, 3 a --require not met); draws nothing"),
    "figures": Command("every figure: what it measures, its unit, its limit's basis", _args_figures,
                       cmd_figures, "every figure each case measures: what it measures, its unit, and its "
                                    "limit with the basis (budget, theory, or your config); runs the "
                                    "cases as check does"),
    "diff": Command("what changed between two runs, figure by figure", _args_diff, cmd_diff,
                    "what changed between two runs' JSON (report.json, check --json, a baseline), figure "
                    "by figure; flipped verdicts first, then by the size of the change; --case and --figure "
                    "select rows"),
    "versions": Command("what changed between MuJoCo releases (an environment each)",
                        _args_versions, cmd_versions,
                        "run the check in one isolated environment per MuJoCo release (built with uv, cached) and "
                        "report what changed from release to release: verdict flips (known defects included), "
                        "figures that moved beyond their noise, figures that appeared or vanished. Options for "
                        "the check go after --, e.g. mjharness versions 3.17.0 4.0.0 -- --case pendulum --mjcf "
                        "my.xml, or -- --mjcf robot.xml for a model of your own. Exit 1 where a release could "
                        "not be run."),
    "sweep": Command("models × MuJoCo releases × backends: a verdict table", _args_sweep, cmd_sweep,
                     "run check on every model (zoo names, MJCF files, case:NAME) in every MuJoCo release's own "
                     "environment on every backend, one task per cell (--executor ray: a Ray task each), and write "
                     "sweep.md and sweep.json: per model a row per backend of verdicts by release, with the first "
                     "release at which the verdict, and at which a figure (bit for bit), changed. Exit 1 where a "
                     "cell could not be run (its line names the model, release and backend)"),
    "baseline": Command("write or compare the regression baseline", _args_baseline, cmd_baseline,
                        "write or compare the regression baseline (reports/baseline/)"),
    "limits": Command("each case's limits with their basis", _args_limits, cmd_limits,
                      "list each case's limits with their basis; --write writes the file of a case that has none, "
                      "by the default rule (nothing measured)"),
    "converge": Command("convergence orders and constraint studies (layer 4)", _args_converge, cmd_converge,
                        "convergence order per integrator vs the documented one (exit 1 if one falls "
                        "short); --softness, --solvers: constraint studies"),
    "faults": Command("the fault catalog judged: settings must pass, faults fail", _args_faults, cmd_faults,
                      "every legitimate setting and every fault of the catalog (harness/studies/faults.py) on "
                      "each case, judged as check --mjcf judges a variant: the verdict, the check that decided "
                      "and its budget (exit 1 if a setting fails or a fault passes)"),
    "sensitivity": Command("the smallest size of each fault each case detects", _args_sensitivity,
                           cmd_sensitivity, "the smallest size of each fault each case detects, at the shipped "
                                            "settings and at 2 × the timestep with MuJoCo's default softness "
                                            "(dozens of runs per case: minutes)"),
    "zoo": Command("models nobody here wrote, each against its own tree", _args_zoo, cmd_zoo,
                   "judge every MuJoCo model that the installed dm_control and Gymnasium ship (pip install "
                   "'mjharness[zoo]') as check --mjcf FILE does, one line per model as it ends, and write zoo.md and "
                   "zoo.json; --faults also sizes engine-side faults. A failing model is a finding about the model "
                   "or MuJoCo, in the report: exit 0 when every model ran to a verdict (pass, finding or refusal) "
                   "and each fault is caught on at least 3 models, 1 when a fault is caught on fewer or a model "
                   "stopped at --timeout, 2 when a model crashed (a bug of the harness) or on bad input"),
    "advise": Command("which integrator and timestep meet your accuracy, verified", _args_advise, cmd_advise,
                      "every integrator's error against the reference over a ladder of timesteps (with error bars), "
                      "its largest stable timestep (the linearization's, confirmed by runs just below and above) and "
                      "its cost on this machine; then the cheapest (integrator, timestep) that meets every --require, "
                      "verified by checking the model at that setting (exit 0), or why none does (exit 3)"),
    "audit": Command("the seed documents' claims, checked", _args_audit, cmd_audit,
                     "the seed documents' claims: confirmed, refuted (with the correction) or ambiguous"),
}


def _exit_codes_text() -> str:
    return "exit codes:\n" + "\n".join(textwrap.fill(text, width=96, initial_indent=f"  {code}  ",
                                                      subsequent_indent=" " * 5) for code, text in EXIT_CODES.items())


class _Help(argparse.RawDescriptionHelpFormatter):
    """argparse's help with the commands listed one a line, without the ``{list,run,...}`` line above them."""

    def _format_action(self, action: argparse.Action) -> str:
        if isinstance(action, argparse._SubParsersAction):
            return "".join(self._format_action(a) for a in action._get_subactions())
        return super()._format_action(action)


def _parser() -> argparse.ArgumentParser:
    p = _Parser(prog="mjharness", description="Validate MuJoCo against analytical mechanics.",
                epilog=_exit_codes_text() + "\n\n'mjharness COMMAND --help' gives each command's options.",
                formatter_class=_Help)
    p.add_argument("--version", action="version", version=_version())
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser, title="commands",
                           metavar="COMMAND")
    for name, command in COMMANDS.items():
        command.add_arguments(sub.add_parser(name, help=command.help, description=command.description
                                             or command.help))
    return p


def _version() -> str:
    import mujoco  # lazy: already imported by harness.cases; named here for its version

    return f"mjharness {VERSION} (MuJoCo {mujoco.__version__}, Python {sys.version.split()[0]})"


def _discard_stdout() -> None:
    """Send what is left of stdout (Python's buffer, written at exit) to /dev/null: its reader is gone."""
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):  # not a file (captured, replaced)
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, fd)
    os.close(devnull)


def _outputs(args: argparse.Namespace) -> list[Path]:
    """The report files the command writes: those a failed or interrupted run marks stale."""
    # run: only the files an earlier run wrote into --out, unchanged since (nothing of the user's is renamed)
    paths = [p for p in ours(args.out) if not p.name.endswith(STALE)] if args.command == "run" else []
    return paths + [p for p in (getattr(args, "junit", None), getattr(args, "html", None)) if p is not None]


def main(argv: Sequence[str] | None = None) -> int:
    parser = _parser()
    if not (sys.argv[1:] if argv is None else list(argv)):  # a bare `mjharness`: what it can do
        parser.print_help()
        return EXIT_USAGE
    argv = list(sys.argv[1:] if argv is None else argv)
    check_args: list[str] = []
    if argv[0] == "versions" and "--" in argv:  # the check's own options, passed through as given
        cut = argv.index("--")
        argv, check_args = argv[:cut], argv[cut + 1:]
    args = parser.parse_args(argv)
    args.check_args = check_args
    messages.keep()  # MuJoCo's own warnings: read from its counters, never printed before our one line
    with warnings.catch_warnings():  # nor Python's: a MuJoCo fallback is in the run's settings ("compat")
        warnings.simplefilter("ignore")
        code = _main(args)
    if code == EXIT_USAGE or code in INTERRUPTED:  # no earlier report may pass for this run's
        mark_stale(_outputs(args))
    return code


def _main(args: argparse.Namespace) -> int:
    """The command, its errors as one line on stderr and their exit code."""
    try:
        with sigterm_as_interrupt():
            sources.use(getattr(args, "systems", None) or ())  # the cases of --systems DIR, discovered as the others
            code = COMMANDS[args.command].run(args)
            sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's exit
            return code
    except BrokenPipeError:  # the reader went away (`| head -1`): stop quietly, as Unix tools do
        _discard_stdout()
        return EXIT_PIPE
    except BrokenProcessPool:  # a worker killed under it (the system's out-of-memory killer, a crash)
        _error("mjharness: error: a worker process died while running the cases (killed by the system: out of "
              "memory?); fix: fewer workers (-j 1) or fewer cases at once")
    except TaskLost as exc:  # a Ray task the cluster could not run (harness.pipeline.cluster)
        _error(f"mjharness: error: {exc}; fix: check the cluster's nodes, or run with --executor local")
    except SimulationDiverged as exc:
        _error(f"mjharness: error: simulation diverged: {exc}")
    except TooManySteps as exc:  # a bound passed: refused up front, with the estimate
        _error(f"mjharness: error: the reference cannot be computed for this model: {exc}")
    except (IntegrationError, LinAlgError) as exc:  # our own solvers failed (LinAlgError is a ValueError: first)
        _error(f"mjharness: internal failure: a numerical solve of the harness failed: {type(exc).__name__}: "
               f"{' '.join(str(exc).split())} (not your input; {TRACEBACK_VARIABLE}=1 prints the traceback)")
        if os.environ.get(TRACEBACK_VARIABLE, "").strip() not in ("", "0"):
            traceback.print_exc()
        return EXIT_NUMERIC
    except ValueError as exc:  # ConfigError, ModelError, ModelMismatch and every input check
        _error(f"mjharness: error: {' '.join(str(exc).split())}")
    except OSError as exc:
        _error(f"mjharness: error: {exc.strerror or exc}: {exc.filename or ''}".rstrip(": "))
    except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM (harness.core.lifetime.Terminated)
        _error("mjharness: terminated (SIGTERM)" if isinstance(exc, Terminated) else "mjharness: interrupted")
        return exit_code(exc)
    except MemoryError:
        _error("mjharness: error: out of memory; fix: a longer --timestep, a shorter --horizon, fewer cases or "
              "workers (-j 1)")
    except Exception as exc:  # a bug of ours: still one line, and no report passes for the run
        _error(f"mjharness: internal error: {type(exc).__name__}: {' '.join(str(exc).split())} (a bug in mjharness, "
              f"not in your input: please report it with the command line; {TRACEBACK_VARIABLE}=1 prints the "
              "traceback)")
        if os.environ.get(TRACEBACK_VARIABLE, "").strip() not in ("", "0"):
            traceback.print_exc()
    finally:
        _disconnect()
    return EXIT_USAGE


def _error(line: str) -> None:
    """An error line on stderr, its names from files, models and the command line made visible
    (:func:`harness.core.escape.terminal`: an ESC or BEL in a name never reaches the terminal as such)."""
    print(terminal(line), file=sys.stderr)


def _disconnect() -> None:
    """Leave the Ray cluster a command used (a local one it started stops): the command exits without the
    interpreter's teardown (:func:`harness.cli.entry.exit_now`), which would otherwise do it."""
    cluster = sys.modules.get("harness.pipeline.cluster")
    if cluster is not None:
        with contextlib.suppress(Exception):  # the run's own outcome stands whatever the disconnection says
            cluster.shutdown()


if __name__ == "__main__":  # the command itself is harness.cli.entry:entry (python -m harness.cli.entry)
    sys.exit(main())

"""What several commands share: the exit codes, the :class:`Command` record, the cases a command line selects,
the run options its flags ask for, the outcome and its exit code, and how ``run`` and ``check`` print it.

``run`` and ``check`` print what fits the terminal: a line per case as it finishes (its checks, how
many fail, the worst share of a limit, seconds; on stdout, flushed, so a CI log shows them as they
come), then each failed check with its budget, and the verdict line last, where a person sees it
without scrolling; ``--verbose`` adds the table of every check; ``--quiet`` prints the failures and the
verdict only (the cases' lines go to stderr where it is not a terminal, a progress bar where it is).

The names keep their underscore: they are the command line's own, shared by its modules, not an API.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from harness import cases
from harness.core.bounds import max_steps
from harness.core.escape import terminal
from harness.core.options import RunOptions
from harness.core.progress import heartbeat
from harness.core.tables import terminal_width, wrap
from harness.engine import backends
from harness.families import figure_names
from harness.opinions import threeway
from harness.outputs.files import PAGES, REPORT_FILES, STALE, check_output, prepare_output
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
from harness.pipeline import require
from harness.pipeline.entry import Judging, own_case
from harness.pipeline.executor import Executor
from harness.pipeline.matrix import LogProgress
from harness.pipeline.outcome import EXIT_UNFIT, Outcome

__all__ = ["EXIT_CODES", "EXIT_FAIL", "EXIT_NUMERIC", "EXIT_OK", "EXIT_USAGE", "Command", "backend_refusals",
           "case_lines", "check_junit", "command_exit_code", "executor_of", "inertials_of", "judging_of",
           "junit_files", "limits_of", "opinions_of", "peers_of", "print_checks", "progress_printer", "run_options",
           "selected_cases", "trees_of"]

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


@dataclass(frozen=True)
class Command:
    """A subcommand: ``help``, one line for the command list (``mjharness --help``); ``description``, more
    for ``mjharness NAME --help`` (``help`` when empty)."""

    help: str
    add_arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], int]
    description: str = ""


def selected_cases(args: argparse.Namespace) -> tuple[cases.Case, ...]:
    """Cases named positionally or with --case (all when none); --mjcf with no case is any model, judged
    against its own kinematic tree, and with one case a variant of that case's model."""
    names = [*args.cases, *(args.case or [])]
    mjcf = getattr(args, "mjcf", None)
    if mjcf is not None and not names:
        return (own_case(mjcf, keyframe=args.keyframe, ctrl=args.ctrl, horizon=args.horizon),)
    if (getattr(args, "keyframe", None) or getattr(args, "ctrl", None)) and mjcf is None:
        raise ValueError("--keyframe and --ctrl apply to a model judged against its own tree: --mjcf FILE, no case")
    selected = cases.select(names)
    if mjcf is not None and len(selected) != 1:
        raise ValueError(f"--mjcf with cases judges one model against one case; name one case, or none to judge "
                         f"the model against its own tree (known cases: {', '.join(cases.names())})")
    return selected


def case_lines(args: argparse.Namespace) -> dict:
    """Where run_all prints each case's line as it finishes: stdout (flushed, terminal or not) unless
    --quiet or --json, which keep stdout for the verdict or the document (then stderr where it is not a
    terminal, a progress bar where it is)."""
    return {"lines": True} if args.quiet or getattr(args, "json", False) else {"out": sys.stdout}


def trees_of(results: Sequence) -> dict[str, dict[str, str] | None]:
    """Each case's forces its own tree's reference leaves out (None: a hand-derived case)."""
    return {r.case.name: (dict(r.settings.tree["not examined"]) if r.settings.tree is not None else None)
            for r in results}


def limits_of(results: Sequence) -> dict[str, list[str]]:
    """Each case's statements of the integrators run beyond their stability limit, the model's own first."""
    return {r.case.name: [s.statement() for s in r.stability.values() if s.beyond] for r in results}


def peers_of(results: Sequence) -> dict[str, dict | None]:
    """Each case's three-way comparison (None where it did not run: a backend other than C)."""
    return {r.case.name: r.settings.peers for r in results}


def print_checks(outcome: Outcome, *, quiet: bool, verbose: bool = False, written: str = "",
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


def run_options(args: argparse.Namespace, selected: Sequence[cases.Case], *, several: bool = False) -> RunOptions:
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


def judging_of(args: argparse.Namespace) -> Judging:
    """How the flags ask the runs to be judged: ``--config``, ``--require``, ``--accept-known-defects``."""
    return Judging(config=args.config, require=require.parse(args.require),
                   accept_known_defects=args.accept_known_defects)


def executor_of(args: argparse.Namespace) -> Executor:
    """The executor ``--executor``/``--ray-address`` ask for; Ray not installed: one line naming the fix."""
    if args.ray_address is not None and args.executor != "ray":
        raise ValueError("--ray-address needs --executor ray")
    if args.executor == "ray" and importlib.util.find_spec("ray") is None:
        raise ValueError("--executor ray: Ray is not installed; fix: pip install 'mjharness[ray]'")
    return Executor(args.executor, args.ray_address)


def check_junit(path: Path | None, report: Path | None = None) -> None:
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


def junit_files(path: Path | None, outcome: Outcome) -> dict[Path, str]:
    """The JUnit file to write with the command's other outputs (none without --junit)."""
    if path is None:
        return {}
    prepare_output(path.parent)
    return {path: junit_xml(outcome.checks, accept_known_defects=outcome.accept_known_defects)}


def inertials_of(args: argparse.Namespace, selected: Sequence[cases.Case], limits):
    """The inertia audit (harness.inertia) of the models judged: --mjcf's, else each case's, and --urdf's own
    inertials against its own meshes, the bodies the config's [accept_inertia] names accepted."""
    from harness.inertia.models import audit_files  # lazy: scipy's start-up, paid by the audit alone

    models = [(args.mjcf.name, args.mjcf)] if args.mjcf is not None else [(c.name, c.mjcf) for c in selected]
    return audit_files(models, urdf=args.urdf, accept=limits.accept_inertia, own=args.mjcf is not None)


def opinions_of(args: argparse.Namespace):
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


def command_exit_code(outcome: Outcome, opinions, inertials, *, json: bool = False) -> int:
    """The checks' exit code, made a fail where the URDF disagrees with the MJCF or a body's inertial cannot lie
    in its geometry (each printed under the verdict; on stderr where stdout holds the JSON document alone)."""
    failed = [part for part in (opinions, inertials) if part.failed]
    for part in failed:
        print(part.verdict(), file=sys.stderr if json else sys.stdout)
    if failed:
        return EXIT_FAIL if outcome.exit_code in (EXIT_OK, EXIT_UNFIT) else outcome.exit_code
    return outcome.exit_code


def progress_printer(total: int) -> Callable[[int, object], None]:
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


def backend_refusals(backend: str | None, chosen: Sequence, *, every: bool = False) -> dict:
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

"""Running the case matrix, serially or on a process pool (``--jobs``), and judging it.

``run_all`` runs the cases (a system's cases in one worker, so that its
derivation, dynamics and reference are made once) and judges them. Either way
the results are those of a serial run, in registry order (pinned in
tests/test_speed_paths.py). Each case's measured cost is kept for the next
run's scheduling (:mod:`harness.core.costs`).
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import as_completed
from pathlib import Path
from typing import TextIO

from harness import cases
from harness.core import costs
from harness.core.checks import Check, Limit, closest, ratio
from harness.core.escape import terminal
from harness.core.options import RunOptions
from harness.core.tables import terminal_width, wrap
from harness.pipeline.carry import Carried, pack
from harness.pipeline.executor import LOCAL, Executor
from harness.pipeline.limits import Limits, case_limits, check_config, load_limits
from harness.pipeline.pool import cpus, fork_pool, run_tasks
from harness.pipeline.run import CaseResult, run_case
from harness.pipeline.verdict import judge
from harness.reference import derivations
from harness.reference import solutions as refmod

__all__ = ["LogProgress", "progress", "run_all"]

COLD = ("derivation",)  # the timings of run_case that a warm run (derivations cached) does not pay


PROGRESS_INTERVAL = 30.0
"""Seconds between two progress lines where stderr is not a terminal (a CI log, a pipe): a run shorter
than this prints none."""


class LogProgress:
    """Progress for a log: tqdm's interface (iterate, ``update``, ``set_postfix_str``, ``close``), one plain
    line on stderr when something finishes and :data:`PROGRESS_INTERVAL` has passed since the start or the
    last line ("mjharness: 3 of 15 cases done after 1.5 min (pendulum)"). Written by the thread that
    counts, never a thread of its own: a process pool forks from this process."""

    def __init__(self, items: Sequence, desc: str, unit: str, *, quiet: bool = False) -> None:
        self.items, self.desc, self.unit, self.quiet = items, desc, unit, quiet
        self.n, self.postfix = 0, ""
        self.start = self.last = time.monotonic()

    def __iter__(self):
        for item in self.items:
            yield item
            self.update()

    def set_postfix_str(self, text: str, refresh: bool = True) -> None:
        self.postfix = text

    def update(self, n: int = 1) -> None:
        self.n += n
        now = time.monotonic()
        if not self.quiet and now - self.last >= PROGRESS_INTERVAL and self.n < len(self.items):
            self.last = now
            elapsed = now - self.start
            when = f"{elapsed / 60:.1f} min" if elapsed >= 60 else f"{elapsed:.0f} s"
            print(f"{self.desc}: {self.n} of {len(self.items)} {self.unit}s done after {when}"
                  + (f" ({self.postfix})" if self.postfix else ""), file=sys.stderr, flush=True)

    def close(self) -> None:
        pass


def progress(items: Sequence, desc: str, unit: str = "case", *, quiet: bool = False):
    """A tqdm bar on stderr where stderr is a terminal; elsewhere (CI logs, pipes) a plain line now and then
    (:class:`LogProgress`), so a long run is seen to go on — none where ``quiet``: the caller prints a line per
    item itself."""
    if not sys.stderr.isatty():
        return LogProgress(items, desc, unit, quiet=quiet)
    from tqdm import tqdm  # lazy: tqdm, only where a bar is drawn

    return tqdm(items, desc=desc, unit=unit, file=sys.stderr, leave=False)


def worst_text(checks: Sequence[Check], *, short: bool = False) -> str:
    """The largest share of its limit a case's checks use: "worst 63% of its limit", "worst 31.2× its
    limit" ("worst 63%", "worst 31.2×" where ``short``), "worst not measured" (a run that could not be
    measured, a non-finite figure), "all n/a"."""
    worst = closest(checks)
    if worst is None:
        return "all n/a" if checks else "no checks"
    r = ratio(worst)
    if not math.isfinite(r):
        return "worst not measured"
    share = f"{100 * r:.0f}%" if r <= 1 else f"{r:.3g}×"
    return f"worst {share}" if short else f"worst {share} {'of its' if r <= 1 else 'its'} limit"


def case_line(case: str, checks: Sequence[Check], seconds: float, width: int = 0, columns: int | None = None) -> str:
    """One finished case: its checks, how many fail, the worst share of a limit, the seconds it took;
    the name padded to ``width`` (the longest name of the run) so that a run's lines align. Longer than
    ``columns``: shorter words, and wrapped where that is not enough."""
    failing = sum(not c.passed for c in checks)
    case = terminal(case)  # a name from a file or model: no escape sequence reaches the terminal
    line = (f"case {case + ':':<{width + 1}} {len(checks):>3} checks, {failing:>2} fail, {worst_text(checks)} "
            f"({seconds:.1f} s)")
    if columns is None or len(line) <= columns:
        return line
    line = f"case {case}: {len(checks)} checks, {failing} fail, {worst_text(checks, short=True)} ({seconds:.1f} s)"
    return "\n".join(wrap(line, columns))


def run_all(selected: Sequence[cases.Case], config_path: Path | str | None, options: RunOptions | None = None, *,
            jobs: int | None = None, figures_only: bool = False, lines: bool = False, out: TextIO | None = None,
            executor: Executor = LOCAL, given: Mapping[str, Limit] | None = None, bar: bool = True,
            record_costs: bool = True) -> tuple[list[CaseResult], dict[str, list[Check]], Limits]:
    """run_case for each case (as ``options`` ask), then its verdict; (results, checks by case, limits).

    ``jobs`` worker processes (default: one per CPU) share the cases; every
    case is computed by the same code from the same inputs wherever it runs, so
    the results are those of a serial run, in registry order, for any ``jobs``.
    ``figures_only``: the caller reads figures and settings alone (``check``,
    ``baseline``), so workers send back no trajectories (several MB a case,
    which the parent would unpickle while the workers wait on the pipe) and no
    reference solutions (for studies).
    ``lines``: where stderr is not a terminal (a CI log, a pipe), which shows no progress bar, each case
    prints its :func:`case_line` there as it finishes. ``out``: each case prints
    its line to this stream as it finishes, terminal or not, flushed, and no progress bar is drawn (the
    lines are the progress).

    ``given``: fixed limits by figure name, over every case's own; ``bar``: False draws no progress (a library
    call's); ``record_costs``: keep each shipped case's measured cost for the next run's scheduling.
    """
    options = options or RunOptions()
    limits = load_limits(config_path)
    checks: dict[str, list[Check]] = {}

    def finished(result: CaseResult) -> None:  # judged as it comes in, so its line can say how it went
        checks[result.case.name] = judge(result, case_limits(limits, result.case, result.judged_names)
                                         | dict(given or {}))
        stream = out if out is not None else sys.stderr if lines and not sys.stderr.isatty() else None
        if stream is not None:
            print(case_line(result.case.name, checks[result.case.name], sum(result.timings.values()), width,
                            terminal_width()), file=stream, flush=True)

    check_config(limits.overrides, cases.all_cases(), source=repr(str(config_path)))  # the cases not run too
    workers = min(jobs or cpus(), len(selected))
    width = max((len(c.name) for c in selected), default=0)
    if out is not None or not bar:  # the cases' lines are the progress (or none is asked for): no bar
        shown = LogProgress(selected, "mjharness", "case", quiet=True)
    else:  # with lines, each case's own line says the progress
        shown = progress(selected, "mjharness", quiet=lines)
    if executor.kind != "local" and options.mjcf is not None:
        results = _run_own_on_cluster(selected, executor, figures_only=figures_only, options=options,
                                      finished=finished)
    elif executor.kind != "local":
        results = _run_on_cluster(selected, executor, shown, figures_only=figures_only, options=options,
                                  finished=finished)
    elif options.backend != "c" and len(selected) > 1 and options.mjcf is None:
        results = _run_isolated(selected, shown, figures_only=figures_only, options=options, finished=finished)
    elif workers <= 1 or options.mjcf is not None:
        results = []
        for case in shown:
            shown.set_postfix_str(case.name)
            results.append(run_case(case, options))
            finished(results[-1])
    else:
        results = _run_parallel(selected, workers, shown, figures_only=figures_only, options=options,
                                finished=finished)
    shown.close()
    if options.shipped and record_costs:
        costs.record({r.case.name: sum(v for k, v in r.timings.items() if k not in COLD) for r in results})
    return results, {r.case.name: checks[r.case.name] for r in results}, limits


def groups(selected: Sequence[cases.Case], *, derived: Callable[[str], bool] | None = None) -> list[list[int]]:
    """Indices of the selected cases by system, each group in registry order, costliest group first.

    A system's cases run in one worker, so that its derivation, dynamics and reference are made once.
    A group costs its cases' measured warm costs plus, where ``derived(system)`` is False (default: its
    derivation is not in the on-disk cache), the system's measured cold derivation; what was never
    measured counts :data:`harness.core.costs.UNKNOWN`.
    """
    derived = derived or derivations.derivation_stored
    measured = costs.case_costs()
    by_system: dict[str, list[int]] = {}
    for i, case in enumerate(selected):
        by_system.setdefault(case.system, []).append(i)

    def cost(system: str, group: list[int]) -> float:
        deriving = 0.0 if derived(system) else (derivations.derivation_cost(system) or costs.UNKNOWN)
        return deriving + sum(measured.get(selected[i].name, costs.UNKNOWN) for i in group)

    return sorted(by_system.values(), key=lambda group: -cost(selected[group[0]].system, group))


def _run_group(names: Sequence[str], figures_only: bool, options: RunOptions):
    """A group's cases in a worker, in order, until one fails: per case (its result without the
    unpicklable Case, or its error), then the references this worker solved (none if
    ``figures_only``, when the results carry no trajectories either)."""
    outcomes: list[tuple[CaseResult | None, Exception | None]] = []
    for name in names:
        try:
            result = run_case(cases.get(name), options)
        except Exception as exc:  # returned, raised by the parent in registry order
            outcomes.append((None, exc))
            break
        if figures_only:
            result = dataclasses.replace(result, reference=None, simulations={})
        outcomes.append((result.without_case(), None))
    return outcomes, ({} if figures_only else refmod.export_solutions())


def _run_parallel(selected: Sequence[cases.Case], workers: int, bar, *, figures_only: bool,
                  options: RunOptions, finished: Callable[[CaseResult], None]) -> list[CaseResult]:
    """run_case on a process pool, a system's cases in one worker; results in registry order. A
    case's error is raised once every case before it in the registry has finished, as a serial run
    would raise it."""
    stored = {system: derivations.derivation_stored(system) for system in dict.fromkeys(c.system for c in selected)}
    if not all(stored.values()):  # the workers derive: sympy and its lazily loaded parts, once, before the fork
        from analytic.lagrangian import preload  # lazy: sympy, only when the workers will derive

        preload()
    outcomes: dict[int, tuple] = {}
    with fork_pool(workers) as pool:
        futures = {pool.submit(_run_group, [selected[i].name for i in group], figures_only, options): group
                   for group in groups(selected, derived=stored.__getitem__)}
        next_in_order = 0
        for future in as_completed(futures):
            group = futures[future]
            done, seeds = future.result()
            refmod.import_solutions(seeds)  # the run's studies reuse these solves
            outcomes.update(zip(group, done, strict=False))  # cases after a failure never ran
            for i, (result, _) in zip(group, done, strict=False):
                if result is not None:
                    finished(dataclasses.replace(result, case=selected[i]))
            bar.set_postfix_str(", ".join(selected[i].name for i in group[:len(done)]), refresh=False)
            bar.update(len(done))
            while next_in_order in outcomes:
                error = outcomes[next_in_order][1]
                if error is not None:
                    raise error
                next_in_order += 1
    return [dataclasses.replace(outcomes[i][0], case=case) for i, case in enumerate(selected)]


def _run_on_cluster(selected: Sequence[cases.Case], executor: Executor, bar, *, figures_only: bool,
                    options: RunOptions, finished: Callable[[CaseResult], None]) -> list[CaseResult]:
    """run_case on a Ray cluster, a system's cases as one task (named by its cases, MuJoCo's release and the
    backend), as the local pool groups them: a case's reference may be cut from a longer solve of its
    system that an earlier case made in the same process, so the grouping is part of the figures' bits;
    results in registry order, a case's error raised as :func:`_run_parallel` raises it, a task
    lost for good as :class:`~harness.pipeline.pool.TaskLost`."""
    import mujoco  # lazy: already imported by harness.cases; named here for its release in the tasks' names

    order = groups(selected)
    calls = [(_run_group, ([selected[i].name for i in group], figures_only, options)) for group in order]
    labels = [f"{', '.join(selected[i].name for i in group)} (MuJoCo {mujoco.__version__}, backend "
              f"{options.backend})" for group in order]

    def done(k: int, outcome: tuple) -> None:
        ran, seeds = outcome
        refmod.import_solutions(seeds)  # the run's studies reuse these solves
        for i, (result, _) in zip(order[k], ran, strict=False):
            if result is not None:
                finished(dataclasses.replace(_named_here(result, str(selected[i].mjcf)), case=selected[i]))
        bar.update(len(ran))

    outcomes: dict[int, tuple] = {}
    for group, (ran, _) in zip(order, run_tasks(calls, len(calls), on_done=done, executor=executor, labels=labels),
                               strict=True):
        outcomes.update(zip(group, ran, strict=False))
    for i in range(len(selected)):  # a case's error, as a serial run raises its first
        if i not in outcomes:
            continue
        if outcomes[i][1] is not None:
            raise outcomes[i][1]
    return [dataclasses.replace(_named_here(outcomes[i][0], str(case.mjcf)), case=case)
            for i, case in enumerate(selected)]


def _run_own(case: cases.Case, carried: Carried, figures_only: bool, options: RunOptions) -> CaseResult:
    """run_case of a user's model on a cluster's node, from the model's files carried there; the result without
    its case (the driver's, reattached there)."""
    here = carried.here()
    if case.tree is not None:  # judged against its own tree: the case is the model's, read from its copy here
        case = dataclasses.replace(case, mjcf=here)
    result = run_case(case, dataclasses.replace(options, mjcf=here))
    if figures_only:
        result = dataclasses.replace(result, reference=None, simulations={})
    return result.without_case()


def _named_here(result: CaseResult, mjcf: str) -> CaseResult:
    """``result`` of a cluster's node with its model named ``mjcf``, as a run here names it: a node names its own
    copy (a carried model's, or the harness's own models in Ray's session folder where its packages travelled)."""
    settings = result.settings
    node = settings.mjcf
    if node == mjcf:
        return result

    def here(value):
        return value.replace(node, mjcf) if isinstance(value, str) else value

    changed = {k: ({kk: here(vv) for kk, vv in v.items()} if isinstance(v, dict) else v)
               for k, v in settings.changed.items()}
    return dataclasses.replace(result, settings=dataclasses.replace(
        settings, mjcf=mjcf, changed=changed, compat=tuple(here(c) for c in settings.compat)))


def _run_own_on_cluster(selected: Sequence[cases.Case], executor: Executor, *, figures_only: bool,
                        options: RunOptions, finished: Callable[[CaseResult], None]) -> list[CaseResult]:
    """A user's model (``options.mjcf``: judged against its own tree, or a variant of one case's model) as one
    task on a Ray cluster (named by the model, MuJoCo's release and the backend), its files carried to the
    node (:mod:`harness.pipeline.carry`); the local run's result, the model named by the user's path."""
    import mujoco  # lazy: already imported by harness.cases; named here for its release in the task's name

    assert options.mjcf is not None  # a user's model: the one task is its file
    carried = pack(options.mjcf)
    (case,) = selected
    label = f"{case.name} ({options.mjcf}, MuJoCo {mujoco.__version__}, backend {options.backend})"
    (result,) = run_tasks([(_run_own, (case, carried, figures_only, options))], 1, executor=executor,
                          labels=[label])
    result = dataclasses.replace(_named_here(result, str(options.mjcf)), case=case)
    finished(result)
    return [result]


def _run_isolated(selected: Sequence[cases.Case], bar, *, figures_only: bool, options: RunOptions,
                  finished: Callable[[CaseResult], None]) -> list[CaseResult]:
    """An accelerated backend's cases, each in a fresh worker process of its own, one at a time, from this
    process (which imports neither JAX nor Warp: neither survives a fork). XLA's CPU compiles of every case
    in one process ran it out of memory (LLVM's "Cannot allocate memory", then a segfault:
    docs/findings/backends.md), so a process compiles one case's functions and ends."""
    results = []
    for case in selected:
        bar.set_postfix_str(case.name)
        with fork_pool(1) as pool:
            done, seeds = pool.submit(_run_group, [case.name], figures_only, options).result()
        refmod.import_solutions(seeds)
        result, error = done[0]
        if error is not None:
            raise error
        results.append(dataclasses.replace(result, case=case))
        finished(results[-1])
        bar.update(1)
    return results

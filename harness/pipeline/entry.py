"""The one way a case, or a model of one's own, is run and judged: ``check``, ``run``, :func:`harness.validate`
(and through it the pytest fixture and the zoo) all come through :func:`evaluate`.

A model of one's own becomes a case by :func:`own_case` (its start from a keyframe and controls, its horizon
chosen unless given); :func:`evaluate` runs the cases (:func:`harness.pipeline.matrix.run_all`: serially, on a
process pool or a cluster), judges each by its limits (its limits file's, the config's overrides, and any given
here), checks that every stated requirement names a figure the run measured, and returns the outcome the
commands print and exit by. The sweep across MuJoCo releases runs ``mjharness check`` in each release's
environment, so it comes through here too, in another process.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

from harness import cases
from harness.cases import Case
from harness.cases.own import from_mjcf
from harness.core.checks import Check, Limit
from harness.core.options import RunOptions
from harness.pipeline.executor import LOCAL, Executor
from harness.pipeline.limits import Limits
from harness.pipeline.matrix import run_all
from harness.pipeline.outcome import Outcome, outcome_of
from harness.pipeline.pool import fork_pool
from harness.pipeline.require import Requirement, check_known
from harness.pipeline.run import CaseResult

__all__ = ["Judging", "evaluate", "evaluate_backends", "own_case"]


@dataclass(frozen=True)
class Judging:
    """How the runs are judged: ``config`` (a TOML file as ``--config``: limits, requirements,
    ``accept_known_defects``), ``limits`` (fixed limits by figure name, over the config's and the shipped ones),
    ``require`` (requirements besides the config's) and ``accept_known_defects``."""

    config: Path | str | None = None
    limits: Mapping[str, Limit] = field(default_factory=dict)
    require: tuple[Requirement, ...] = ()
    accept_known_defects: bool = False


@dataclass(frozen=True)
class Evaluated:
    """What :func:`evaluate` ran and how it judged it: each case's result (in the order given), its checks, the
    limits read (their source, the config's own requirements) and the outcome (checks, fitness, findings)."""

    results: list[CaseResult]
    checks: dict[str, list[Check]]
    limits: Limits
    outcome: Outcome


def own_case(path: Path | str, *, keyframe: str | None = None, ctrl: Mapping[str, float] | None = None,
             horizon: float | None = None) -> Case:
    """The case of the model at ``path`` judged against its own kinematic tree
    (:func:`harness.cases.own.from_mjcf`): what ``--mjcf`` with no case, ``validate(mjcf=...)`` and the zoo run."""
    return from_mjcf(path, keyframe=keyframe, ctrl=ctrl, horizon=horizon)


def evaluate(target: Case | Sequence[Case] | Path | str, *, options: RunOptions | None = None,
             judging: Judging = Judging(), keyframe: str | None = None, ctrl: Mapping[str, float] | None = None,
             jobs: int | None = None, figures_only: bool = False, lines: bool = False, out: TextIO | None = None,
             executor: Executor = LOCAL, bar: bool = True, record_costs: bool = True,
             requirements: bool = True) -> Evaluated:
    """Run ``target`` (a case, several, or the path of a model of one's own, a ``str`` included: :func:`own_case`
    with ``keyframe``, ``ctrl`` and the options' horizon) as ``options`` ask and judge it as ``judging`` says.

    ``jobs``, ``figures_only``, ``lines``, ``out``, ``executor``: how and where the cases run and say they
    finished (:func:`~harness.pipeline.matrix.run_all`); ``bar``: a progress bar (or a log's progress lines)
    while they run; ``record_costs``: keep each shipped case's measured cost for the next run's scheduling;
    ``requirements``: False where the caller reads the figures and checks alone (``baseline``, ``figures``,
    ``limits``, the other backends of ``run --backend all``): the requirements are then neither checked against
    the figures measured nor judged. ValueError where a requirement names no figure the runs measured."""
    options = options or RunOptions()
    if isinstance(target, (Path, str)):
        target = own_case(target, keyframe=keyframe, ctrl=ctrl, horizon=options.horizon)
    selected = (target,) if isinstance(target, Case) else tuple(target)
    results, checks, limits = run_all(selected, judging.config, options,
                                      jobs=jobs, figures_only=figures_only, lines=lines, out=out,
                                      executor=executor, given=judging.limits, bar=bar, record_costs=record_costs)
    required = (*limits.requirements, *judging.require) if requirements else ()
    check_known(required, results)
    outcome = outcome_of(results, checks, requirements=required,
                         accept_known_defects=judging.accept_known_defects or limits.accept_known_defects)
    return Evaluated(results=results, checks=checks, limits=limits, outcome=outcome)


def _evaluate_backend(names: Sequence[str], config: Path | str | None, options: RunOptions
                      ) -> tuple[list[CaseResult], dict[str, list[Check]]]:
    """:func:`evaluate` in a backend's own process; its results go back to the parent without their case (a case's
    system may hold closures, which do not pickle: symmetric_top's axial momentum), reattached there."""
    done = evaluate([cases.get(n) for n in names], options=options, judging=Judging(config=config), jobs=1,
                    requirements=False)
    return [r.without_case() for r in done.results], done.checks


def evaluate_backends(selected: Sequence[Case], config: Path | str | None, options: RunOptions,
                      names: Sequence[str]) -> list[tuple[str, list[CaseResult], dict[str, list[Check]]]]:
    """:func:`evaluate` on each backend of ``names`` (each case's results and checks by backend), each in a process
    of its own, forked from this one, which imports no accelerated backend: JAX and Warp do not survive a fork,
    and MJX fixes its precision at its first import, so float32 and float64 cannot share a process."""
    out = []
    for name in names:
        with fork_pool(1) as pool:
            results, checks = pool.submit(_evaluate_backend, [c.name for c in selected], config,
                                          dataclasses.replace(options, backend=name)).result()
        out.append((name, [dataclasses.replace(r, case=c) for r, c in zip(results, selected, strict=True)], checks))
    return out

"""The check, run in each release's environment: once as asked, and again with the initial state moved at
round-off level to measure each figure's noise.

MuJoCo is deterministic on one machine: the same run gives the same bits, so "run-to-run noise" has to
be made. Each release's check is repeated with every initial coordinate and velocity moved by
±:data:`PERTURBATION` relative (``check --perturb``, :func:`harness.families.bench.perturbed`): a few
units of float round-off, nothing physical, but enough that every rounding of the run — MuJoCo's, the
reference solver's adaptive steps, the sampled states of the instant layer — falls differently. How far
a figure moves then is how far round-off moves it, which is all that a release that only reorders
arithmetic can do to it (:mod:`harness.versions.changes` compares changes with it).

Releases run on a pool of ``parallel`` threads, each building its environment and then running its
checks one after another with ``jobs`` worker processes each; ``parallel × jobs`` should not exceed
the machine's cores. On a Ray cluster (``versions --executor ray``) each release's runs are one task
instead, which carries the harness's wheel and builds the release's environment on its node.
"""

from __future__ import annotations

import json
import os
import subprocess
import time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from pathlib import Path

from harness.outputs.schema import SchemaError, check_run
from harness.pipeline.executor import LOCAL, Executor
from harness.pipeline.pool import run_tasks
from harness.versions.envs import Builder, EnvError, Environment, EnvSpec, Shipped
from harness.versions.releases import Release

__all__ = ["NOISE_RUNS", "CheckCommand", "ReleaseRun", "check_environ", "noise_runs", "run_release", "run_releases"]

PERTURBATION = 1e-15
"""The relative move of the initial state for the noise runs: about 4.5 units of round-off (2⁻⁵² ≈ 2.2e-16)."""
NOISE_RUNS = (PERTURBATION, -PERTURBATION)
"""The perturbed runs of each release: one each way."""
PERTURBATIONS = {"float64": PERTURBATION, "float32": 5e-7}
"""The move per arithmetic the runs step in: about 4.5 units of its round-off, 1e-15 in float64 and 5e-7 in
float32 (2⁻²³ ≈ 1.2e-7). A float32 backend (MJX) casts the initial state to float32, where a 1e-15 move
rounds away: every perturbed run would be the same bits and each figure's noise its ULP floor, so any
float32-sized difference between releases would read as a change."""


def noise_runs(precision: str = "float64") -> tuple[float, float]:
    """The noise runs' moves for a check that steps in ``precision`` (``float64`` or ``float32``:
    :data:`harness.engine.backends.PRECISION` of its backend)."""
    if precision not in PERTURBATIONS:
        raise ValueError(f"unknown precision {precision!r}; accepted: {', '.join(PERTURBATIONS)}")
    move = PERTURBATIONS[precision]
    return move, -move

OK_EXITS = (0, 1, 3)  # check: all pass, a check fails, a requirement unmet — every one a complete run


@dataclass(frozen=True)
class ReleaseRun:
    """One release's runs: ``doc`` the check as asked, ``noise`` the perturbed ones (by their move), the
    seconds each took, and ``error`` (one line) where the environment or the check could not be had."""

    release: Release
    doc: Mapping | None = None
    noise: Mapping[float, Mapping] = field(default_factory=dict)
    env_seconds: float = 0.0
    env_built: bool = False
    check_seconds: float = 0.0
    error: str = ""

    @property
    def ok(self) -> bool:
        return self.doc is not None and not self.error


@dataclass(frozen=True)
class CheckCommand:
    """How to run the check in an environment: ``args`` are the check's options (cases, ``--mjcf``, ...),
    run in ``cwd`` with ``jobs`` workers; ``environ`` the variables it runs with."""

    args: tuple[str, ...] = ()
    jobs: int = 1
    cwd: Path | None = None
    environ: Mapping[str, str] | None = None

    def argv(self, python: Path, perturb: float | None) -> list[str]:
        extra = [f"--perturb={perturb!r}"] if perturb is not None else []  # "=": argparse reads -1e-15 as an option
        return [str(python), "-P", "-m", "harness", "check", "--json", "--jobs", str(self.jobs), *self.args, *extra]


def check_environ() -> dict[str, str]:
    """This process's variables without those that would let the environment import anything else
    (PYTHONPATH, PYTHONHOME, a user site)."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    env["PYTHONNOUSERSITE"] = "1"
    return env


def run_check(env: Environment, command: CheckCommand, perturb: float | None) -> Mapping:
    """The check's JSON document from ``env``; ValueError (one line: the check's own error) where it did
    not run to the end or printed something else than a run document."""
    done = subprocess.run(command.argv(env.python, perturb), capture_output=True, text=True, check=False,
                          cwd=command.cwd, env=dict(command.environ) if command.environ is not None else None)
    what = f"MuJoCo {env.spec.release}" + (f" (perturbed {perturb:+g})" if perturb is not None else "")
    if done.returncode not in OK_EXITS:
        last = (done.stderr.strip().splitlines() or ["no message"])[-1]
        raise ValueError(f"check on {what} exited {done.returncode}: {last.strip()}")
    try:
        return check_run(json.loads(done.stdout), f"check --json on {what}")
    except (json.JSONDecodeError, SchemaError) as exc:
        last = (done.stderr.strip().splitlines() or [str(exc)])[-1]  # a crash: its traceback's last line
        raise ValueError(f"check --json on {what} exited {done.returncode} with no run document: "
                         f"{last.strip()}") from None


def run_release(builder: Builder, spec: EnvSpec, digest: str, command: CheckCommand, *,
                noise: Sequence[float] = NOISE_RUNS) -> ReleaseRun:
    """Build (or reuse) ``spec``'s environment and run the check in it, then the noise runs (an error
    naming why where ``spec`` is refused, nothing built)."""
    if spec.refused:
        return ReleaseRun(spec.release, error=spec.refused)
    try:
        env = builder.ensure(spec, digest)
    except (EnvError, OSError) as exc:
        return ReleaseRun(spec.release, error=str(exc))
    start = time.perf_counter()
    try:
        doc = run_check(env, command, None)
        perturbed = {p: run_check(env, command, p) for p in noise}
    except (ValueError, OSError) as exc:
        return ReleaseRun(spec.release, env_seconds=env.seconds, env_built=env.built, error=str(exc),
                          check_seconds=time.perf_counter() - start)
    return ReleaseRun(spec.release, doc=doc, noise=perturbed, env_seconds=env.seconds, env_built=env.built,
                      check_seconds=time.perf_counter() - start)


def release_task(shipped: Shipped, root: Path, spec: EnvSpec, command: CheckCommand,
                 noise: Sequence[float]) -> ReleaseRun:
    """:func:`run_release` as a task on any node: the environment built under ``root`` there with the
    ``shipped`` harness, the check run with that node's variables (:func:`check_environ`) and in
    ``command.cwd`` where the node has it."""
    cwd = command.cwd if command.cwd is not None and command.cwd.is_dir() else None
    here = replace(command, cwd=cwd, environ=check_environ())
    return run_release(shipped.builder(root), spec, shipped.digest, here, noise=noise)


def run_releases(builder: Builder, specs: Sequence[EnvSpec], digest: str, command: CheckCommand, *,
                 parallel: int, noise: Sequence[float] = NOISE_RUNS,
                 on_done: Callable[[ReleaseRun], None] | None = None,
                 executor: Executor = LOCAL) -> list[ReleaseRun]:
    """:func:`run_release` for each spec, ``parallel`` at a time; results in the order of ``specs``.
    The harness's wheel is built first, once, so the releases do not wait on one another for it. On a Ray
    ``executor`` each release is a task (:func:`release_task`); one lost for good is a run with its error."""
    builder.wheel(digest)
    if executor.kind != "local":
        shipped = Shipped.of(builder, digest)
        return run_tasks([(release_task, (shipped, builder.root, s, command, tuple(noise))) for s in specs],
                         parallel, executor=executor, labels=[f"MuJoCo {s.release}" for s in specs],
                         on_done=None if on_done is None else lambda _i, run: on_done(run),
                         failed=lambda i, why: ReleaseRun(specs[i].release, error=f"the task was lost: {why}"))
    with ThreadPoolExecutor(max_workers=max(1, parallel)) as pool:
        futures = [pool.submit(run_release, builder, s, digest, command, noise=noise) for s in specs]
        results = []
        for f in futures:
            results.append(f.result())
            if on_done is not None:
                on_done(results[-1])
    return results

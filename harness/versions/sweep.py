"""``mjharness sweep``: models × MuJoCo releases × backends, one task per cell, on this machine or a Ray cluster.

Each cell runs ``check --json --mjcf FILE --backend B`` (``--case NAME`` for a shipped case) in the release's
own environment (:mod:`harness.versions.envs`), as ``zoo`` judges a model: against its own kinematic tree,
every integrator unless told otherwise. The task builds the environment itself (``Builder.ensure``): on each
node the first task of a release builds it under the cache's lock and every later one reuses it, so a
release's environment is built once per node whatever the tasks' order. The task carries the harness's
wheel (:class:`~harness.versions.envs.Shipped`), so a node needs no source tree.

A cell's verdict is ``pass`` or ``fail`` (check exits 0 or 1), ``refused`` (check's one-line refusal of the
model, exit 2), ``n/a`` (the backend has no package for the release: nothing built), or ``error``: the cell
could not be had (the environment did not build, the check crashed or ran past the time limit, the task
was lost with its node), with one line naming the model, the release and the backend.
"""

from __future__ import annotations

import contextlib
import importlib.util
import itertools
import json
import math
import socket
import subprocess
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from harness.outputs.schema import SchemaError, check_run
from harness.pipeline.carry import Carried, pack
from harness.pipeline.executor import LOCAL, Executor
from harness.pipeline.pool import run_tasks
from harness.versions.changes import figures, statuses
from harness.versions.envs import EnvError, EnvSpec, Shipped
from harness.versions.releases import Release
from harness.versions.runs import CheckCommand, check_environ

__all__ = ["ERROR", "NA", "REFUSED", "FirstChange", "Model", "Sweep", "first_changes", "plan", "run"]

PASS, FAIL, REFUSED, NA, ERROR = "pass", "fail", "refused", "n/a", "error"
VERDICTS = (PASS, FAIL, REFUSED, NA, ERROR)
JUDGED = (PASS, FAIL, REFUSED)
"""The verdicts that are the harness's answer on a release: a verdict change is between two of these."""
RAN = (PASS, FAIL)
"""The verdicts that come with figures."""


@dataclass(frozen=True)
class Model:
    """A model of the sweep: a zoo model (``dm_control/acrobot``), a shipped case (``case:pendulum``) or an
    MJCF file; ``path`` is its file as this machine sees it (none for a case), and a zoo model's ``within``
    its file's place inside its ``package``, where another node finds its own copy."""

    name: str
    kind: str
    path: str = ""
    package: str = ""
    within: str = ""
    carried: Carried | None = None

    def check_args(self) -> tuple[str, ...]:
        """How ``check`` is told the model, on the node running it."""
        if self.kind == "case":
            return ("--case", self.name.removeprefix("case:"))
        return ("--mjcf", self._here())

    def _here(self) -> str:
        """The file here: the model's files carried to this node (a sweep on a cluster), else a zoo model's in
        this node's copy of its package where it has one."""
        if self.carried is not None:
            return str(self.carried.here())
        if self.package:
            with contextlib.suppress(ImportError, ValueError):
                spec = importlib.util.find_spec(self.package)
                for folder in (spec.submodule_search_locations or []) if spec is not None else []:
                    if (Path(folder) / self.within).is_file():
                        return str(Path(folder) / self.within)
        return self.path


@dataclass(frozen=True)
class Task:
    """One cell to run: ``model`` on ``backend`` in the environment ``spec`` (a refused spec: an n/a cell),
    built under ``root`` with the ``shipped`` harness; the check with ``jobs`` workers, stopped after
    ``timeout`` seconds (None: never)."""

    model: Model
    backend: str
    spec: EnvSpec
    shipped: Shipped
    root: Path
    jobs: int = 1
    integrators: tuple[str, ...] = ()
    timeout: float | None = None

    @property
    def label(self) -> str:
        return f"{self.model.name} on MuJoCo {self.spec.release} ({self.backend})"


@dataclass(frozen=True)
class Cell:
    """One (model, release, backend): its verdict, why where it is not pass or fail, and what the check
    measured: each figure's value and each check's status, by ``case:figure``. ``mujoco`` is the release
    the check reported running on; ``seconds``, ``env_seconds`` and ``host`` say what it cost where."""

    model: str
    release: str
    backend: str
    verdict: str
    reason: str = ""
    mujoco: str = ""
    figures: Mapping[str, float] = field(default_factory=dict)
    statuses: Mapping[str, str] = field(default_factory=dict)
    seconds: float = 0.0
    env_seconds: float = 0.0
    host: str = ""

    def line(self) -> str:
        """One line: ``model on MuJoCo R (backend): verdict[: reason]``."""
        head = f"{self.model} on MuJoCo {self.release} ({self.backend}): {self.verdict}"
        return f"{head}: {self.reason}" if self.reason else head


def _cell(task: Task, verdict: str, reason: str = "", **kw: object) -> Cell:
    # kw: Cell's other fields, by name (their types are Cell's)
    return Cell(task.model.name, str(task.spec.release), task.backend, verdict, " ".join(reason.split()),
                host=socket.gethostname(), **kw)  # type: ignore[arg-type]


def lost(task: Task, why: str) -> Cell:
    """The cell of a task that failed for good outside the check (its retries spent, its node lost)."""
    return _cell(task, ERROR, f"the task was lost: {why}")


def run_task(task: Task, carried: Carried | None = None) -> Cell:
    """``task``'s cell, its model's files ``carried`` to this node where they are given; never raises (whatever
    goes wrong is an error cell saying what)."""
    start = time.perf_counter()
    if carried is not None:
        task = replace(task, model=replace(task.model, carried=carried))
    if task.spec.refused:
        return _cell(task, NA, task.spec.refused)
    try:
        env = task.shipped.builder(task.root).ensure(task.spec, task.shipped.digest)
        args = (*task.model.check_args(), "--backend", task.backend,
                *(("--integrators", ",".join(task.integrators)) if task.integrators else ()))
        command = CheckCommand(args=args, jobs=task.jobs, environ=check_environ())
        done = subprocess.run(command.argv(env.python, None), capture_output=True, text=True, check=False,
                              env=dict(command.environ or {}), timeout=task.timeout)
    except subprocess.TimeoutExpired:
        return _cell(task, ERROR, f"stopped at the time limit of {task.timeout:g} s",
                     seconds=time.perf_counter() - start)
    except (EnvError, OSError, ValueError) as exc:
        return _cell(task, ERROR, str(exc), seconds=time.perf_counter() - start)
    spent: dict[str, Any] = {"seconds": time.perf_counter() - start - env.seconds, "env_seconds": env.seconds}
    last = (done.stderr.strip().splitlines() or ["no message"])[-1].strip()
    if done.returncode == 2 and last.startswith("mjharness: error:"):
        return _cell(task, REFUSED, last.removeprefix("mjharness: error:"), **spent)
    if done.returncode not in (0, 1):
        return _cell(task, ERROR, f"check exited {done.returncode}: {last}", **spent)
    try:
        doc = check_run(json.loads(done.stdout), f"check --json on MuJoCo {task.spec.release}")
    except (ValueError, SchemaError) as exc:
        return _cell(task, ERROR, f"check exited {done.returncode} with no run document: {exc}", **spent)
    return _cell(task, PASS if done.returncode == 0 else FAIL, mujoco=str(doc.get("versions", {}).get("mujoco", "")),
                 figures={f"{c}:{f}": v for (c, f), v in sorted(figures(doc).items())},
                 statuses={f"{c}:{f}": s for (c, f), s in sorted(statuses(doc).items())}, **spent)


@dataclass(frozen=True)
class Sweep:
    """Every cell of one sweep, in the order models × backends × releases, with what it ran on."""

    models: tuple[str, ...]
    releases: tuple[str, ...]
    backends: tuple[str, ...]
    cells: tuple[Cell, ...]
    command: str = ""
    executor: str = "local"
    seconds: float = 0.0

    @property
    def errors(self) -> tuple[Cell, ...]:
        return tuple(c for c in self.cells if c.verdict == ERROR)

    def row(self, model: str, backend: str) -> tuple[Cell, ...]:
        """One model's cells on one backend, oldest release first."""
        return tuple(c for c in self.cells if c.model == model and c.backend == backend)


def plan(models: Sequence[Model], releases: Sequence[Release], backends: Sequence[str], *, shipped: Shipped,
         root: Path, pinned: Sequence[str] = (), packages: Callable[[str, Release], Sequence[str]] = lambda b, r: (),
         refused: Mapping[tuple[Release, str], str] | None = None, jobs: int = 1,
         integrators: Sequence[str] = (), timeout: float | None = None) -> list[Task]:
    """One task per (model, backend, release), in that order: two workers start on two releases' builds
    rather than wait on one. ``packages(backend, release)`` are the backend's packages in the release's
    environment; ``refused[(release, backend)]`` why it has none (an n/a cell)."""
    out = []
    for model in models:
        for backend in backends:
            for release in releases:
                why = (refused or {}).get((release, backend), "")
                spec = EnvSpec(release, tuple(packages(backend, release)) if not why else (), tuple(pinned), why)
                out.append(Task(model, backend, spec, shipped, root, jobs, tuple(integrators), timeout))
    return out


def run(tasks: Sequence[Task], *, workers: int, executor: Executor = LOCAL, command: str = "",
        on_done: Callable[[Cell], None] | None = None) -> Sweep:
    """Every task's cell, ``workers`` at a time on ``executor`` (each task one Ray task there, a file's or zoo
    model's files carried to its node, :mod:`harness.pipeline.carry`); a task lost for good is an error cell
    naming it, never a missing one."""
    start = time.perf_counter()
    carried: dict[str, Carried] = {}
    if executor.kind == "ray":
        carried = {m.path: pack(m.path) for m in dict.fromkeys(t.model for t in tasks) if m.path}

    def done(_i: int, cell: Cell) -> None:
        if on_done is not None:
            on_done(cell)

    calls = [(run_task, (t, carried[t.model.path]) if t.model.path in carried else (t,)) for t in tasks]
    cells = run_tasks(calls, workers, on_done=done, executor=executor,
                      failed=lambda i, why: lost(tasks[i], why), labels=[t.label for t in tasks])
    return Sweep(tuple(dict.fromkeys(t.model.name for t in tasks)),
                 tuple(str(r) for r in sorted({t.spec.release for t in tasks})),
                 tuple(dict.fromkeys(t.backend for t in tasks)), tuple(cells), command=command,
                 executor=executor.kind, seconds=time.perf_counter() - start)


@dataclass(frozen=True)
class FirstChange:
    """Where one model's row on one backend first changed: ``verdict``, the first release whose verdict
    differs from the one of the release before it that had a verdict (``was`` → ``now``); ``figure``, the
    first release at which a figure's value differs bit for bit from the release before it that ran, or a
    figure appeared or vanished: how many of the figures of both changed value (of ``compared``), how many
    appeared or vanished, and the largest relative change among those of both (``|new − old| / |old|``,
    infinite from zero or to a number that is not finite)."""

    model: str
    backend: str
    verdict: str = ""
    was: str = ""
    now: str = ""
    figure: str = ""
    changed: int = 0
    appeared: int = 0
    compared: int = 0
    largest: float = 0.0
    largest_figure: str = ""


def _same(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


def _relative(old: float, new: float) -> float:
    if not (math.isfinite(old) and math.isfinite(new)):
        return math.inf
    return abs(new - old) / abs(old) if old else math.inf


def first_change(row: Sequence[Cell]) -> FirstChange:
    """The first verdict change and the first figure change along ``row`` (one model, one backend, oldest
    release first); cells without a verdict (n/a, error) are stepped over."""
    out = FirstChange(row[0].model, row[0].backend) if row else FirstChange("", "")
    judged = [c for c in row if c.verdict in JUDGED]
    for before, after in itertools.pairwise(judged):
        if before.verdict != after.verdict:
            out = replace(out, verdict=after.release, was=before.verdict, now=after.verdict)
            break
    ran = [c for c in row if c.verdict in RAN]
    for before, after in itertools.pairwise(ran):
        both = sorted(set(before.figures) & set(after.figures))
        moved = {k: _relative(before.figures[k], after.figures[k]) for k in both
                 if not _same(before.figures[k], after.figures[k])}
        appeared = len(set(before.figures) ^ set(after.figures))
        if moved or appeared:
            worst = max(moved, key=lambda k: moved[k], default="")
            return replace(out, figure=after.release, changed=len(moved), appeared=appeared, compared=len(both),
                           largest=moved.get(worst, 0.0), largest_figure=worst)
    return out


def first_changes(sweep: Sweep) -> tuple[FirstChange, ...]:
    """:func:`first_change` of every row, models × backends."""
    return tuple(first_change(sweep.row(m, b)) for m in sweep.models for b in sweep.backends)

"""Bounds on how long a run may be, checked before it starts: a run past one is refused in one line with
its estimate, instead of running for hours or out of memory (the way to raise each is in the line).

- :func:`max_steps`: the steps of one MuJoCo run at the model's timestep (horizon / timestep). The
  default is a run the smallest model finishes in minutes, its budget's runs at h/2 and h/4 included, in
  the memory of an ordinary machine; a mistyped ``--timestep`` or ``--horizon`` would otherwise run out of
  memory or for hours.
- :func:`max_reference_steps`: the steps of the reference's solver (DOP853) over the horizon. The default
  is far above what any shipped case takes, and minutes of solving; a start spun far faster than the
  model's own motion would otherwise solve for many minutes before the solver's own cap stops it, so the
  steps a solve needs are estimated from its first :data:`analytic.solvers.TRIAL_STEPS` steps.
- :func:`max_reference_seconds`: the seconds a model's own tree reference may take (``check --mjcf``). Its
  first steps are no guide where one evaluation of a large tree takes seconds (a 300-link chain: 500 steps
  would take hours), so the solve is estimated before it starts, from a cost model: one evaluation of the
  tree's accelerations timed on the model itself, times the fewest evaluations a simulated second of a
  reference has taken (:data:`EVALUATIONS_PER_SECOND`): a lower bound, so no model that would solve within
  the bound is refused.

The measurements these defaults and the estimates' rates rest on: docs/findings/bases.md, "Run bounds".

Each is overridden by its environment variable (a positive integer), which the worker processes see too.
"""

from __future__ import annotations

import math
import os

from harness.core.errors import RunTooLong

__all__ = ["EVALUATIONS_PER_SECOND", "check_reference_cost", "check_steps", "max_reference_seconds",
           "max_reference_steps", "max_solve_seconds", "max_steps", "reference_too_long", "solve_too_slow"]

MAX_STEPS = 1_000_000
MAX_STEPS_VARIABLE = "MJHARNESS_MAX_STEPS"
MAX_REFERENCE_STEPS = 100_000
MAX_REFERENCE_STEPS_VARIABLE = "MJHARNESS_MAX_REFERENCE_STEPS"
MAX_REFERENCE_SECONDS = 30
"""The longest a model's own tree reference may be estimated to take (CPU s): half the minute a robot's whole check
is meant to take on a 2-core machine (issue 43), the rest its runs, budget and ladder (80 % of Panda's check, the
chaos horizon's two solves 20 %: docs/findings/bases.md). The estimate is a lower bound, so a model refused by it
could not have met that minute."""
MAX_REFERENCE_SECONDS_VARIABLE = "MJHARNESS_MAX_REFERENCE_SECONDS"
EVALUATIONS_PER_SECOND = 90
"""Evaluations of the tree's accelerations a reference over one simulated second takes at the fewest: the fewest
measured on the kicked start of ``check --mjcf`` was Gymnasium's reacher's 92 (chains of 2 to 16 links: 863 and
more; benchmarks/tree_scale.py, benchmarks/results_tree_scale.txt), rounded down."""
BYTES_PER_STEP = 1.3e9 / 250_000
"""Peak memory per step of the run at the model's timestep, measured on the pendulum (the smallest model:
larger ones record more per step; docs/findings/bases.md)."""
SECONDS_PER_STEP = 63.0 / 250_000
"""Wall time per step of the run at the model's timestep, every integrator and budget run included,
measured on the pendulum (2 shared cores; docs/findings/bases.md)."""


def _bound(variable: str, default: int, *, unit: str = "steps") -> int:
    text = os.environ.get(variable, "").strip()
    if not text:
        return default
    try:
        number = float(text)
    except ValueError:
        number = math.nan
    # 1e400 is inf (int() of it raised OverflowError: an internal error) and 1.5 is no whole number (it was
    # silently 1)
    if not (math.isfinite(number) and number >= 1 and number == int(number)):
        raise ValueError(f"{variable}={text!r}; accepted: a positive whole number of {unit} (default {default})")
    return int(number)


def max_steps() -> int:
    """The most steps one MuJoCo run may take (:data:`MAX_STEPS`, or ``MJHARNESS_MAX_STEPS``)."""
    return _bound(MAX_STEPS_VARIABLE, MAX_STEPS)


def max_reference_steps() -> int:
    """The most steps the reference's solver may take (:data:`MAX_REFERENCE_STEPS`, or
    ``MJHARNESS_MAX_REFERENCE_STEPS``)."""
    return _bound(MAX_REFERENCE_STEPS_VARIABLE, MAX_REFERENCE_STEPS)


def max_reference_seconds() -> int:
    """The most seconds a model's tree reference may be estimated to take (:data:`MAX_REFERENCE_SECONDS`, or
    ``MJHARNESS_MAX_REFERENCE_SECONDS``)."""
    return _bound(MAX_REFERENCE_SECONDS_VARIABLE, MAX_REFERENCE_SECONDS, unit="seconds")


def _duration(seconds: float) -> str:
    for unit, size in (("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if seconds >= size:
            return f"{seconds / size:.2g} {unit}"
    return f"{seconds:.2g} s"


def check_steps(steps: int, *, horizon: float, timestep: float) -> None:
    """RunTooLong where a run of ``steps`` (``horizon`` / ``timestep``) is past :func:`max_steps`, with its
    estimated time and memory (at least the pendulum's per step)."""
    bound = max_steps()
    if steps <= bound:
        return
    raise RunTooLong(f"a run of {horizon:g} s at a timestep of {timestep:g} s is {steps:.3g} steps, more than the "
                     f"bound of {bound:g} (at least {_duration(steps * SECONDS_PER_STEP)} and "
                     f"{steps * BYTES_PER_STEP / 1e9:.3g} GB of memory a case); fix: a longer --timestep or a "
                     f"shorter --horizon, or {MAX_STEPS_VARIABLE}={steps} to run it anyway")


def reference_too_long(why: str) -> RunTooLong:
    """The refusal of a reference whose solve would pass :func:`max_reference_steps` (``why``: the estimate)."""
    return RunTooLong(f"the reference of this motion is too long to solve: {why}; fix: a shorter --horizon or a "
                      f"slower initial state, or {MAX_REFERENCE_STEPS_VARIABLE}=N to solve it anyway")


SOLVE_FACTOR = 4
"""How many times :func:`max_reference_seconds` one solve of a model's tree reference may use of CPU before it is
stopped and the model refused (:func:`max_solve_seconds`): the up-front estimate is a floor that a large stiff
tree's Jacobians pass by far (dm_control's dog: 11 min for its horizon's two solves). 120 s by default, above the
costliest solve measured on the zoo and the Menagerie robots (docs/findings/bases.md, SOLVE_FACTOR)."""


def max_solve_seconds() -> float:
    """The CPU seconds one solve of a model's tree reference may use (:data:`SOLVE_FACTOR` ×
    :func:`max_reference_seconds`)."""
    return float(SOLVE_FACTOR * max_reference_seconds())


def solve_too_slow(why: str, *, nv: int) -> RunTooLong:
    """The refusal of a model whose tree reference's solve passed :func:`max_solve_seconds` (``why``: how far it got
    and the whole at that rate)."""
    return RunTooLong(f"the model's tree reference ({nv} dof) was stopped: {why}, more than the bound of "
                      f"{max_solve_seconds():g} s a solve ({SOLVE_FACTOR} × {MAX_REFERENCE_SECONDS_VARIABLE}); fix: "
                      f"a shorter --horizon, or {MAX_REFERENCE_SECONDS_VARIABLE}=N to allow {SOLVE_FACTOR} × N s")


def check_reference_cost(*, evaluation: float, span: float, nv: int, stopped: bool = False,
                         jacobian: float = 0.0, jacobian_stopped: bool = False) -> None:
    """RunTooLong where a tree reference over ``span`` seconds, one evaluation of its accelerations timed at
    ``evaluation`` CPU seconds (or more: ``stopped`` there), is estimated to take longer than
    :func:`max_reference_seconds` (the estimate and its basis in the line). ``jacobian``: the CPU seconds of the
    exact Jacobian every tree solve takes at its start (its stiffness test), measured from one chunk of its columns
    (or more: ``jacobian_stopped``), added to the evaluations' floor."""
    bound = max_reference_seconds()
    estimate = EVALUATIONS_PER_SECOND * span * evaluation + jacobian
    if estimate <= bound:
        return
    more = stopped or jacobian_stopped
    took = f"{'more than ' if stopped else ''}{evaluation:.3g} s"
    fits = (bound - jacobian) / (EVALUATIONS_PER_SECOND * evaluation)
    shorter = "" if more or fits <= 0 else f"--horizon {fits:.2g} or shorter fits, or "
    at_least = f"more than the bound of {_duration(bound)}" if more else (
        f"at least {_duration(estimate)}, more than the bound of {_duration(bound)}")
    start = "" if not jacobian else (
        f"; and each solve starts with its exact Jacobian (its stiffness test: {2 * nv} columns), "
        f"{'more than ' if jacobian_stopped else ''}{_duration(jacobian)} by one chunk of them timed here")
    raise RunTooLong(f"the model's tree reference ({nv} dof) would take {at_least} to solve over {span:g} s "
                     f"(one evaluation of its accelerations "
                     f"took {took} of CPU here, and a simulated second of a reference takes at least "
                     f"{EVALUATIONS_PER_SECOND} of them: benchmarks/results_tree_scale.txt{start}); fix: {shorter}"
                     f"{MAX_REFERENCE_SECONDS_VARIABLE}={math.ceil(estimate)} or more to solve it anyway")

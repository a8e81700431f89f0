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

The measurements these defaults and the estimates' rates rest on: docs/findings/bases.md, "Run bounds".

Each is overridden by its environment variable (a positive integer), which the worker processes see too.
"""

from __future__ import annotations

import math
import os

from harness.core.errors import RunTooLong

MAX_STEPS = 1_000_000
MAX_STEPS_VARIABLE = "MJHARNESS_MAX_STEPS"
MAX_REFERENCE_STEPS = 100_000
MAX_REFERENCE_STEPS_VARIABLE = "MJHARNESS_MAX_REFERENCE_STEPS"
BYTES_PER_STEP = 1.3e9 / 250_000
"""Peak memory per step of the run at the model's timestep, measured on the pendulum (the smallest model:
larger ones record more per step; docs/findings/bases.md)."""
SECONDS_PER_STEP = 63.0 / 250_000
"""Wall time per step of the run at the model's timestep, every integrator and budget run included,
measured on the pendulum (2 shared cores; docs/findings/bases.md)."""


def _bound(variable: str, default: int) -> int:
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
        raise ValueError(f"{variable}={text!r}; accepted: a positive whole number of steps (default {default})")
    return int(number)


def max_steps() -> int:
    """The most steps one MuJoCo run may take (:data:`MAX_STEPS`, or ``MJHARNESS_MAX_STEPS``)."""
    return _bound(MAX_STEPS_VARIABLE, MAX_STEPS)


def max_reference_steps() -> int:
    """The most steps the reference's solver may take (:data:`MAX_REFERENCE_STEPS`, or
    ``MJHARNESS_MAX_REFERENCE_STEPS``)."""
    return _bound(MAX_REFERENCE_STEPS_VARIABLE, MAX_REFERENCE_STEPS)


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

"""Bounds on how long a run may be, checked before it starts: a run past one is refused in one line with
its estimate, instead of running for hours or out of memory (the way to raise each is in the line).

- :func:`max_steps`: the steps of one MuJoCo run at the model's timestep (horizon / timestep).
  Measured here: the pendulum at h = 2e-5 s over 5 s (250 000 steps) takes about 1 min and a peak of
  1.3 GB, its budget's runs at h/2 and h/4 included; so 1 000 000 steps, the default, is about 4 min and
  5 GB on the smallest model, a run any 8 GB machine holds. ``--timestep 1e-9`` (5e9 steps) ran out of
  memory after minutes; ``--horizon 1e6`` ran for hours.
- :func:`max_reference_steps`: the steps of the reference's solver (DOP853) over the horizon. The shipped
  cases take 7 to 227; 100 000, the default, is 440 times the longest, about 4 to 16 min at the 2 to 10
  ms a step measured. ``--qd0 theta=1e6`` (the pendulum spun at 10⁶ rad/s) ran 15 min before the
  solver's own cap; it is now estimated from its first :data:`analytic.solvers.TRIAL_STEPS` steps.

Each is overridden by its environment variable (a positive integer), which the worker processes see too.
"""

from __future__ import annotations

import os

from harness.core.errors import RunTooLong

MAX_STEPS = 1_000_000
MAX_STEPS_VARIABLE = "MJHARNESS_MAX_STEPS"
MAX_REFERENCE_STEPS = 100_000
MAX_REFERENCE_STEPS_VARIABLE = "MJHARNESS_MAX_REFERENCE_STEPS"
BYTES_PER_STEP = 1.3e9 / 250_000
"""Peak memory per step of the run at the model's timestep, measured on the pendulum (the smallest model:
larger ones record more per step)."""
SECONDS_PER_STEP = 63.0 / 250_000
"""Wall time per step of the run at the model's timestep, every integrator and budget run included,
measured on the pendulum (2 shared cores)."""


def _bound(variable: str, default: int) -> int:
    text = os.environ.get(variable, "").strip()
    if not text:
        return default
    try:
        value = int(float(text))
    except ValueError:
        value = 0
    if value < 1:
        raise ValueError(f"{variable}={text!r}; accepted: a positive whole number of steps (default {default})")
    return value


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

"""Run a MuJoCo model and record a Trajectory whose every sample belongs to its state.

After ``mj_step`` the derived fields describe the state *before* the step, and
after an RK4 step ``efc_force``, ``qfrc_constraint`` and ``energy`` hold the
last Runge–Kutta stage (design.md, "Conventions"). Three recorders honour that
and give the same numbers, bit for bit (pinned in tests/test_recording.py):

- :mod:`~harness.engine.recording.native`: ``mj_step`` called from C (built on
  first use where a C compiler is found), recording as it steps;
- :mod:`~harness.engine.recording.batch`: ``mujoco.batch`` rollouts (MuJoCo ≥ 4),
  their fields shifted or recomputed;
- :mod:`~harness.engine.recording.loop`: ``mj_forward``, record, the integrator's
  own function, in Python (any MuJoCo).

The recorders in C record fields and :mod:`~harness.engine.recording.assemble`
makes them a run (the equalities: :mod:`~harness.engine.recording.equalities`);
every such run is checked against a fresh ``mj_forward``
(:mod:`~harness.engine.recording.verify`), and a mismatch hands the equalities,
or the whole run, to the loop (:func:`notes` says so). :func:`record` with
``method="auto"`` takes the native recorder, else the batch one where
``mujoco.batch`` exists, else the loop; :func:`recorder` says which and why.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence

import mujoco
import numpy as np

from harness.core.trajectory import Trajectory
from harness.engine.probe import Probe
from harness.engine.recording import batch, loop, native
from harness.engine.recording.assemble import Run, point_state, recorded_fields, trajectory
from harness.engine.recording.batch import set_threads
from harness.engine.recording.scratch import give_back_data, take_data
from harness.engine.recording.verify import FALLBACKS

__all__ = ["notes", "point_state", "record", "recorded_fields", "recorder", "set_threads", "steps_in"]


def recorder() -> str:
    """Which recorder :func:`record` uses on this MuJoCo, and why."""
    if native.library() is not None:
        return ("native: mj_step in C (harness/engine/recording/native_record.c, built on first use; RK4 as "
                "forward, record, mj_RungeKutta), recording state, fixed-size fields and the equalities' efc rows "
                "as it steps; readings evaluated over the whole run")
    if batch.mujoco_batch is None:
        return (f"loop: mj_forward, read, integrator function per step in Python (MuJoCo {mujoco.__version__} "
                f"has no mujoco.batch; no native recorder: {native.why_not()})")
    return ("batch: steps and fixed-size fields recorded in C (mujoco.batch; RK4's fields recomputed on a "
            f"second thread while it steps), readings evaluated over the whole run (no native recorder: "
            f"{native.why_not()})")


def notes() -> tuple[str, ...]:
    """Every time this process's native or batch recorder fell back to reading per sample or to the loop, and why,
    in order (empty when it never did); ``notes()[n:]`` are the notes since an earlier count n."""
    return tuple(FALLBACKS)


def steps_in(horizon: float, timestep: float) -> int:
    """The number of whole steps of ``timestep`` that fit in ``horizon`` (a run never steps past the horizon
    the reference covers; 1e-9 of a step forgives the rounding of horizon / timestep)."""
    steps = math.floor(horizon / timestep + 1e-9)
    if steps < 1:
        raise ValueError(f"the timestep {timestep:g} s is longer than the horizon {horizon:g} s; "
                         f"give a timestep of at most {horizon:g} s (or a longer --horizon)")
    return steps


def record(
    model: mujoco.MjModel,
    probe: Probe,
    *,
    q0: Sequence[float] | np.ndarray,
    qd0: Sequence[float] | np.ndarray,
    steps: int,
    method: str = "auto",
    timings: dict[str, float] | None = None,
) -> Trajectory:
    """Step ``model`` with its own integrator and timestep, recording every state.

    Returns ``steps + 1`` samples at t = k·h, k = 0 .. steps: the time the state after k steps stands for.
    MuJoCo's own clock adds h at every step and drifts from it by its accumulated round-off, a time that
    is no property of the state: a reference sampled there would be off by the velocity times the drift,
    and past its horizon. Raises SimulationDiverged
    on NaN or MuJoCo warnings, ModelMismatch if the model lacks what the probe
    reads. ``method``: ``auto`` (the native recorder where it could be built, else the
    batch recorder where ``mujoco.batch`` exists, else the loop), ``native``, ``batch``
    or ``loop``; all give the same numbers.
    ``timings``, if given, receives the seconds of the Python readings
    (``readings``, recorders in C) or of the whole loop recording (``loop``).
    """
    if steps < 1:
        raise ValueError(f"steps must be >= 1, got {steps}")
    if method not in ("auto", "native", "batch", "loop"):
        raise ValueError(f"method must be 'auto', 'native', 'batch' or 'loop', got {method!r}")
    if method == "batch" and batch.mujoco_batch is None:
        raise ValueError(f"method 'batch' needs mujoco.batch, which MuJoCo {mujoco.__version__} lacks; "
                         "accepted here: 'auto', 'loop'")
    probe.validate(model)
    timings = {} if timings is None else timings
    run = None
    lib = native.library() if method in ("auto", "native") else None
    if method == "native" and lib is None:
        accepted = ", ".join(repr(m) for m in ("auto", "batch", "loop")
                             if m != "batch" or batch.mujoco_batch is not None)
        raise ValueError(f"method 'native' is not available here: {native.why_not()}; accepted here: {accepted}")
    in_c: list[Callable[[mujoco.MjData], Run | None]] = []  # each None where its check sends the run on
    if lib is not None:
        in_c.append(lambda data: native.record(lib, model, probe, data, steps, timings))
    if batch.mujoco_batch is not None and method in ("auto", "batch"):
        in_c.append(lambda data: batch.record(model, probe, data, steps, timings))
    for recorded in in_c:
        data = take_data(model)
        try:
            probe.binding.set_state(model, data, q0, qd0)
            run = recorded(data)
        finally:
            give_back_data(model, data)
        if run is not None:
            break
    if run is None:
        start = time.perf_counter()
        data = mujoco.MjData(model)
        probe.binding.set_state(model, data, q0, qd0)
        run = loop.record(model, probe, data, steps)
        timings["loop"] = time.perf_counter() - start
    return trajectory(model, probe, run)

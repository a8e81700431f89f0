"""The batch recorder: the steps run in C by ``mujoco.batch`` (MuJoCo ≥ 4), recording as they go.

``Batch.rollout`` records after every substep the integration state and the fixed-size derived fields
the assembly needs (:func:`harness.engine.recording.assemble.recorded_fields`). For every integrator
but RK4 the fields recorded after step k + 1 are those ``mj_step``'s own ``mj_forward`` computed at
state k (what the loop reads at sample k), so they are shifted by one, and the last state gets one
checked ``forward``. After an RK4 step they hold the last stage, so RK4's fields are recomputed by a
batched ``forward`` of every recorded state (warm start included: it is part of the integration
state). Where a second thread may run, the rollout goes in chunks (bit-identical to one call: the
integration state carries everything a step reads) and each chunk's states are recomputed on that
thread while the next chunk steps, so only the last chunk's recomputation adds to the wall time.

Equalities no recorded field gives (:mod:`harness.engine.recording.equalities`) are read after
``mj_forward`` at every recorded state, as the loop reads them; with a second thread, on that thread,
chunk by chunk, while the rollout steps the next chunk.
"""

from __future__ import annotations

import contextlib
import itertools
import os
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor

import mujoco
import numpy as np

from harness.core.errors import SimulationDiverged
from harness.engine.integrators import integrator_name
from harness.engine.probe import Probe
from harness.engine.recording.assemble import Run, recorded_fields
from harness.engine.recording.equalities import joint_equalities, read_equalities, rows, signed
from harness.engine.recording.scratch import SPARE, STATE, Record, give_back_data, keep, take_data
from harness.engine.recording.verify import check_warnings, checked_forward, checked_run

__all__ = ["mujoco_batch", "record", "set_threads"]

try:  # MuJoCo ≥ 4
    from mujoco import batch as mujoco_batch
except ImportError:  # MuJoCo 3.3: the loop records everything (recording.recorder() says so)
    mujoco_batch = None

_PARALLEL_SIMS = 256  # fewer recomputed states than this run on the caller's thread alone
_MIN_CHUNK = 32  # RK4 rollouts with a second thread go in halving chunks down to about this many steps
_EVEN_CHUNKS = 16  # other rollouts that read equalities per state go in this many equal chunks

_threads: int | None = None
_spare_batches: dict[int, tuple[mujoco.MjModel, object]] = {}


def set_threads(count: int | None) -> None:
    """Threads the batch recorder may use for RK4's recomputation (None: one per CPU). A process pool
    of one worker per CPU sets 1, so that workers do not compete for the same cores."""
    if count is not None and count < 1:
        raise ValueError(f"thread count must be >= 1 or None, got {count}")
    global _threads
    _threads = count


def _threads_allowed() -> int:
    return _threads or os.cpu_count() or 1


def _new_batch(model: mujoco.MjModel, nsim: int, data: mujoco.MjData, *, threads: int | None = None
               ) -> mujoco_batch.Batch:
    # the batch's results are bit-identical at any thread count (mujoco.batch documentation)
    threads = threads or (1 if nsim < _PARALLEL_SIMS else _threads_allowed())
    b = mujoco_batch.Batch(model, nsim, nthread=min(threads, nsim))
    # The batch makes an MjData of its own, only to learn field shapes, on first use (about as costly
    # as a short rollout); ours serves as well. An optimisation: without it the batch makes its own.
    with contextlib.suppress(Exception):  # another mujoco.batch: it makes its own
        b._data = data
    return b


def _take_batch(model: mujoco.MjModel, data: mujoco.MjData) -> mujoco_batch.Batch:
    """A one-simulation batch of ``model`` (this very object: a batch keeps its model), reused from an
    earlier run where one was given back (making one costs a share of a short rollout: docs/findings/speed.md).
    Every run sets the whole integration state, and a step starts from it alone (mj_forward), so
    nothing leaks from one run to the next (pinned bit for bit against the loop)."""
    spare = _spare_batches.pop(id(model), None)
    return spare[1] if spare is not None else _new_batch(model, 1, data)


def _give_back_batch(model: mujoco.MjModel, b: mujoco_batch.Batch) -> None:
    # the model is held, so its id is not reused meanwhile
    keep(_spare_batches, id(model), (model, b), 2 * SPARE)


def _out(rec: Record, start: int, stop: int, *, with_fields: bool) -> dict:
    """``Batch.rollout``'s out= for steps start..stop−1: states start+1..stop and, ``with_fields``,
    the fields mj_step computed at states start..stop−1 (an RK4 rollout records none)."""
    out: dict = {STATE: rec.states[None, start + 1:stop + 1]}
    if with_fields:
        out |= {f: v[None, start:stop] for f, v in rec.fields.items()}
    return out


def _forward_all(model: mujoco.MjModel, data: mujoco.MjData, states: np.ndarray,
                 into: Mapping[str, np.ndarray], *, threads: int | None = None) -> None:
    """The fields ``into`` names, after mj_forward at every state row (one batched call in C),
    written into ``into`` (arrays of len(states) rows)."""
    fb = _new_batch(model, len(states), data, threads=threads)
    outputs = {f: fb.bind(f) for f in into}
    fb.state[:] = states
    fb.forward()
    raised = np.flatnonzero(fb.warning[:, :, 1].max(axis=1) > 0)
    if raised.size:
        k = int(raised[0])
        check_warnings(fb.warning[k, :, 1], float(states[k, 0]))
    for f, v in outputs.items():
        into[f][...] = np.asarray(v).reshape(into[f].shape)


def _step(b: mujoco_batch.Batch, nstep: int, record: Sequence, out: dict, states: np.ndarray) -> None:
    """``nstep`` steps of batch ``b``'s one simulation, recording into ``out`` (``states``: the recorded
    states, the first step's start included); SimulationDiverged on an error or a warning, at the time of
    the state it was raised at, as the loop recorder reads it (:func:`_warning_time`)."""
    try:
        b.rollout(nstep, record=record, out=out)
    except mujoco_batch.SimulationError as exc:
        raise SimulationDiverged(f"MuJoCo error {' '.join(str(exc).split())!r}", _warning_time(states)) from None
    counts = b.warning[0, :, 1]
    if counts.max() > 0:
        check_warnings(counts, _warning_time(states))


def _warning_time(states: np.ndarray) -> float:
    """The time of the state a rollout's warning was raised at. MuJoCo resets the data in that step (and
    steps on from time 0), then the rollout stops and its records repeat the step's result: the warning's
    state is the one before the first repeated record (the last but one where nothing repeats)."""
    repeated = np.flatnonzero((states[1:] == states[:-1]).all(axis=1))
    after = int(repeated[0]) if repeated.size else len(states) - 1
    return float(states[max(after - 1, 0), 0])


def _chunk_sizes(steps: int) -> list[int]:
    """Halving chunks (half the run, a quarter, ...) down to at most 2·_MIN_CHUNK steps. A forward is one of
    an RK4 step's four evaluations, so a chunk's recomputation ends while the next, half as long,
    steps; what is left after the last step is the last chunk's, a few dozen states."""
    sizes, left = [], steps
    while left > 2 * _MIN_CHUNK:
        sizes.append(left - left // 2)
        left //= 2
    return [*sizes, left]


def _even_chunk_sizes(steps: int) -> list[int]:
    """About _EVEN_CHUNKS equal chunks of at least _MIN_CHUNK steps. Reading a state's equalities is a forward,
    as a step of the integrators but RK4 is, so the other thread keeps pace with chunks of one size and
    what is left after the last step is the last chunk's reading."""
    size = max(_MIN_CHUNK, -(-steps // _EVEN_CHUNKS))
    return [size] * (steps // size) + ([steps % size] if steps % size else [])


# work(data, start, stop): what the other thread does with states start..stop−1 once they are recorded
_Work = Callable[[mujoco.MjData, int, int], None]


def _rollout(model: mujoco.MjModel, data: mujoco.MjData, rec: Record, steps: int, *, recomputed: bool,
             work: _Work | None) -> None:
    """States 1..steps into ``rec`` and, unless ``recomputed`` (RK4, whose recorded fields are its last
    stage's), the fields mj_step computed at states 0..steps−1; then ``work`` on every state 0..steps
    (RK4: after its fields' recomputation). With a second thread the rollout goes in chunks and each
    chunk's states are worked on the other thread while the next steps (both calls release the GIL)."""
    def each(helper: mujoco.MjData, start: int, stop: int) -> None:
        if recomputed:  # states start..stop−1
            _forward_all(model, helper, rec.states[start:stop],
                         {f: v[start:stop] for f, v in rec.fields.items()}, threads=1)
        if work is not None:
            work(helper, start, stop)

    record = [STATE] if recomputed else [STATE, *rec.fields]
    sizes = _chunk_sizes(steps) if recomputed else _even_chunk_sizes(steps)
    b = _take_batch(model, data)
    b.state[0] = rec.states[0]
    if _threads_allowed() < 2 or len(sizes) < 2 or (not recomputed and work is None):
        _step(b, steps, record, _out(rec, 0, steps, with_fields=not recomputed), rec.states)
        _give_back_batch(model, b)  # not after an error: its warning counters would stop the next run
        if recomputed:
            _forward_all(model, data, rec.states, rec.fields)
        if work is not None:
            work(data, 0, steps + 1)
        return
    bounds = np.cumsum([0, *sizes])
    helper = take_data(model, spare=True)  # the other thread's: not the rollout's own
    try:
        with ThreadPoolExecutor(max_workers=1) as pool:
            pending = []
            for start, stop in itertools.pairwise(bounds):
                _step(b, int(stop - start), record, _out(rec, int(start), int(stop), with_fields=not recomputed),
                      rec.states[int(start):int(stop) + 1])
                pending.append(pool.submit(each, helper, int(start), int(stop)))
            _give_back_batch(model, b)
            pending.append(pool.submit(each, helper, steps, steps + 1))
            for f in pending:
                f.result()
    finally:
        give_back_data(model, helper, spare=True)


def record(model: mujoco.MjModel, probe: Probe, data: mujoco.MjData, steps: int,
           timings: dict[str, float]) -> Run | None:
    """The batch recorder, from ``data``'s state; None where the check against a fresh mj_forward sends the
    run back to the loop."""
    shifted = integrator_name(model) != "RK4"
    rec = Record.take(model, data, steps, recorded_fields(model, probe))
    try:
        return _record_into(model, probe, data, steps, rec, shifted, timings)
    finally:
        rec.give_back(model)


def _record_into(model: mujoco.MjModel, probe: Probe, data: mujoco.MjData, steps: int, rec: Record,
                 shifted: bool, timings: dict[str, float]) -> Run | None:
    """:func:`record` with its scratch arrays."""
    mujoco.mj_getState(model, data, rec.states[0], STATE)
    # the equalities no recorded field gives: read after mj_forward at every state, beside the rollout
    recoverable = joint_equalities(model, probe.constraints)
    read = [c for c in probe.constraints if c not in recoverable]
    lam = {c: rows(model, c, steps + 1) for c in read}
    viol = {c: rows(model, c, steps + 1) for c in read}

    def work(helper: mujoco.MjData, start: int, stop: int) -> None:
        read_equalities(model, helper, rec.states[start:stop], {c: lam[c][start:stop] for c in read},
                        {c: viol[c][start:stop] for c in read})

    _rollout(model, data, rec, steps, recomputed=not shifted, work=work if read else None)
    states, fields = rec.states, rec.fields
    # the last state, which no step follows, gets the checks mj_step would make (as in the loop)
    mujoco.mj_setState(model, data, states[-1], STATE)
    checked_forward(model, data)
    check_warnings(data.warning.number, float(states[-1, 0]))
    if shifted:  # fields of states 0..steps−1 from the rollout, the last state's from that forward
        for f, v in fields.items():
            v[-1] = getattr(data, f)
    for c in read:
        lam[c], viol[c] = signed(probe.sign(c), lam[c], viol[c])
    return checked_run(model, probe, data, rec, lam, viol, timings)

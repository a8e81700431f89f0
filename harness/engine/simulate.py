"""Run a MuJoCo model and record a Trajectory whose every sample belongs to its state.

After ``mj_step`` the derived fields describe the state *before* the step, and
after an RK4 step ``efc_force``, ``qfrc_constraint`` and ``energy`` hold the
last Runge–Kutta stage (design.md, "Conventions"). Three recorders honour that
and give the same numbers, bit for bit (pinned in tests/test_simulate.py):

``loop`` (any MuJoCo): each step is ``mj_forward`` (derived fields of the
current state) between the checks ``mj_step`` makes around it
(``mj_checkPos/Vel/Acc``: a huge or non-finite value is a MuJoCo warning),
record, then the integrator's own function — the same work ``mj_step`` does,
in the same order, bit-identical to it. It costs a Python round trip per
sample, several times MuJoCo's own step.

``native`` (where a C compiler is found, :mod:`harness.engine.native`): the
batch recorder's steps made in C (``mj_step``, fields shifted by one; RK4 as
the loop), recording at every sample the integration state, the fixed-size
fields (:func:`recorded_fields`) and the equalities' ``efc_*`` rows (which no
fixed-size field holds) as it steps, so nothing is computed twice. Then the
same assembly, readings and check as the batch recorder's.

``batch`` (``mujoco.batch``, MuJoCo ≥ 4): the steps run in C
(``Batch.rollout``), recording after every substep the integration state and
the fixed-size derived fields it needs (:func:`recorded_fields`). For every
integrator but RK4,
the fields recorded after step k + 1 are those ``mj_step``'s own
``mj_forward`` computed at state k — what the loop reads at sample k — so they
are shifted by one, and the last state gets one checked ``forward``. After an
RK4 step they hold the last stage, so RK4's fields are recomputed by a batched
``forward`` of every recorded state (warm start included: it is part of the
integration state); where a second thread may run, the rollout goes in chunks
(bit-identical to one call: the integration state carries everything a step
reads) and each chunk's states are recomputed on that thread while the next
chunk steps, so only the last chunk's recomputation adds to the wall time.
The rest is numpy over the whole run, reproducing the loop's arithmetic: a
point's position is ``site_xpos`` for a site and ``xipos`` for a body
(:mod:`harness.engine.points`), its velocity J·qvel with J assembled from
``cdof`` and ``subtree_com`` at that position as ``mj_jac`` does, and a joint equality's
``efc_force``/``efc_pos`` come from ``qfrc_constraint`` and ``qpos`` where
that is exact (:class:`_JointEquality`). The case's readings
(``Probe.invariants/forces/series``, :class:`harness.readings.Reading`) name
the fixed-size fields they need; those are recorded with the rest and
the readings evaluated once over the whole run, by both recorders alike.
Equalities that cannot be recovered exactly are read after ``mj_forward`` at
every recorded state (``mj_setState`` of its row, sensors skipped), as the loop
reads them; with a second thread, on that thread, chunk by chunk, while the
rollout steps the next chunk (efc_* has no fixed size: ``mujoco.batch`` cannot
record it, and a forward per state costs about a step).

Every native or batch run is checked against a fresh ``mj_forward`` at one
sample, bit for bit; a mismatch (another MuJoCo's arithmetic) hands the
equalities, or the whole run, to the loop, and :func:`recorder_notes` says so.
``auto`` takes the native recorder, else the batch one where ``mujoco.batch``
exists (MuJoCo ≥ 4), else the loop; :func:`recorder` says which and why.
"""

from __future__ import annotations

import contextlib
import itertools
import math
import os
import time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import mujoco
import numpy as np

from harness.core.errors import SimulationDiverged
from harness.core.trajectory import Trajectory
from harness.engine import native
from harness.engine.bindings import ONE_DOF
from harness.engine.constraints import EQUALITY_ROWS, equality_block, equality_size
from harness.engine.integrators import STEP_FUNCTIONS, integrator_name
from harness.engine.points import point_jacobian, point_source
from harness.engine.probe import Probe
from harness.engine.readings import fields_of

try:  # MuJoCo ≥ 4
    from mujoco import batch as _batch
except ImportError:  # MuJoCo 3.3: the loop records everything (recorder() says so)
    _batch = None


# Derived fields the batch recorder records at every state (all fixed-size), besides the readings' own:
# always (energy, generalized constraint force), for points (position: site_xpos or xipos as the points
# are sites or bodies; and velocity as mj_jac assembles it) and for joint equalities recovered from
# qfrc_constraint (the row count, to know every row is theirs).
# Each costs about 1 % of a small model's step; a non-finite qacc is MuJoCo's own warning (mj_checkAcc).
ALWAYS_FIELDS: tuple[str, ...] = ("qfrc_constraint", "energy")
POINT_FIELDS: tuple[str, ...] = ("subtree_com", "cdof")  # with each point's own position field
EQUALITY_FIELDS: tuple[str, ...] = ("nefc",)
_STATE = mujoco.mjtState.mjSTATE_INTEGRATION

_PARALLEL_SIMS = 256  # fewer recomputed states than this run on the caller's thread alone
_MIN_CHUNK = 32  # RK4 rollouts with a second thread go in halving chunks down to about this many steps
_EVEN_CHUNKS = 16  # other rollouts that read equalities per state go in this many equal chunks

_SPARE_DATA = 4  # MjData kept for reuse, by model layout

_notes: list[str] = []
_threads: int | None = None
_spare_data: dict[tuple[int, int, int, bool], mujoco.MjData] = {}
_spare_batches: dict[int, tuple[mujoco.MjModel, object]] = {}


def recorder() -> str:
    """Which recorder :func:`simulate` uses on this MuJoCo, and why."""
    if native.library() is not None:
        return ("native: mj_step in C (harness/engine/native_record.c, built on first use; RK4 as forward, "
                "record, mj_RungeKutta), recording state, fixed-size fields and the equalities' efc rows as it "
                "steps; readings evaluated over the whole run")
    if _batch is None:
        return (f"loop: mj_forward, read, integrator function per step in Python (MuJoCo {mujoco.__version__} "
                f"has no mujoco.batch; no native recorder: {native.why_not()})")
    return ("batch: steps and fixed-size fields recorded in C (mujoco.batch; RK4's fields recomputed on a "
            f"second thread while it steps), readings evaluated over the whole run (no native recorder: "
            f"{native.why_not()})")


def recorder_notes() -> tuple[str, ...]:
    """Every time this process's native or batch recorder fell back to reading per sample or to the loop, and why,
    in order (empty when it never did); ``recorder_notes()[n:]`` are the notes since an earlier count n."""
    return tuple(_notes)


def recorded_fields(model: mujoco.MjModel, probe: Probe) -> tuple[str, ...]:
    """The derived fields the batch recorder records at every state for ``probe`` on ``model``."""
    positions = dict.fromkeys(point_source(model, p).field for p in probe.points)
    wanted = [*ALWAYS_FIELDS, *positions, *(POINT_FIELDS if probe.points else ())]
    if _joint_equalities(model, probe.constraints):
        wanted += EQUALITY_FIELDS
    return tuple(dict.fromkeys((*wanted, *fields_of(probe.readings()))))


def point_state(model: mujoco.MjModel, data: mujoco.MjData, point: str) -> tuple[np.ndarray, np.ndarray]:
    """World position and linear velocity of a named point: a site, or a body's centre of mass
    (:func:`harness.engine.points.point_source`).

    The velocity is J·qvel with J from ``mj_jac`` at the point on its body, summed column by column
    in dof order (Σᵢ Jᵢ q̇ᵢ, a multiply then an add per term, no fused multiply-add), so that the
    batch recorder's vectorized sum over a whole run gives the same numbers bit for bit."""
    source = point_source(model, point)
    jacp = point_jacobian(model, data, source)
    velocity = np.zeros(3)
    for i in range(model.nv):
        velocity = velocity + jacp[:, i] * data.qvel[i]
    return source.position(data).copy(), velocity


def _rows(model: mujoco.MjModel, name: str, n: int) -> np.ndarray:
    """Zeros for ``n`` samples of equality ``name``: (n,) for one row, (n, k) for a block of k rows."""
    size = equality_size(model, name)
    return np.zeros(n) if size == 1 else np.zeros((n, size))


def _block(model: mujoco.MjModel, data: mujoco.MjData, name: str, sign: float = 1.0
           ) -> tuple[np.ndarray | float, np.ndarray | float]:
    """(efc_force, efc_pos) × ``sign`` (the probe's, :attr:`Probe.signs`) of equality ``name`` at this state:
    floats for one row, (k,) for a block."""
    force, pos = equality_block(model, data, name)
    if sign != 1.0:
        force, pos = sign * force, sign * pos
    return (float(force[0]), float(pos[0])) if force.size == 1 else (force, pos)


def _signed(sign: float, lam: np.ndarray, viol: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(λ, violation) of an equality × the probe's ``sign`` elementwise, as :func:`_block` multiplies each
    sample (the arrays themselves where the sign is 1)."""
    return (lam, viol) if sign == 1.0 else (sign * lam, sign * viol)


def _check_warnings(counts: np.ndarray, time: float) -> None:
    raised = [mujoco.mjtWarning(i).name for i in range(len(counts)) if counts[i] > 0]
    if raised:
        raise SimulationDiverged(", ".join(raised), time)


# ---------------------------------------------------------------- recorded run
@dataclass
class _Run:
    """A run in arrays: integration states and derived fields at every sample, plus readings."""

    states: np.ndarray                      # (N, nstate), mjSTATE_INTEGRATION rows (batch recorder only)
    t: np.ndarray                           # (N,)
    positions: dict[str, np.ndarray]        # (N, 3) per point
    velocities: dict[str, np.ndarray]       # (N, 3) per point
    lam: dict[str, np.ndarray]              # efc_force per equality, (N,) or (N, k) for a k-row block
    viol: dict[str, np.ndarray]             # efc_pos per equality, likewise
    energy: np.ndarray                      # (N,)
    qfrc: np.ndarray                        # (N, nv) qfrc_constraint
    readings: dict[str, np.ndarray]         # Probe.readings() keys, (N,)
    fields: dict[str, np.ndarray] = field(default_factory=dict)  # recorded derived fields (batch recorder)


def _evaluate_readings(model: mujoco.MjModel, probe: Probe, states_t: np.ndarray, qpos: np.ndarray,
                       qvel: np.ndarray, fields: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Every reading of ``probe`` over the run, from the recorded state and fields."""
    recorded = {"time": states_t, "qpos": qpos, "qvel": qvel, **fields}
    out = {}
    for key, reading in probe.readings().items():
        values = np.array(reading.evaluate(model, recorded), dtype=float)  # a copy: recorded is scratch
        if values.shape != states_t.shape:
            raise ValueError(f"reading {key!r} returned shape {values.shape}; expected {states_t.shape}")
        out[key] = values
    return out


def steps_in(horizon: float, timestep: float) -> int:
    """The number of whole steps of ``timestep`` that fit in ``horizon`` (a run never steps past the horizon
    the reference covers; 1e-9 of a step forgives the rounding of horizon / timestep)."""
    steps = math.floor(horizon / timestep + 1e-9)
    if steps < 1:
        raise ValueError(f"the timestep {timestep:g} s is longer than the horizon {horizon:g} s; "
                         f"give a timestep of at most {horizon:g} s (or a longer --horizon)")
    return steps


def simulate(
    model: mujoco.MjModel,
    probe: Probe,
    *,
    q0: Sequence[float],
    qd0: Sequence[float],
    steps: int,
    method: str = "auto",
    timings: dict[str, float] | None = None,
) -> Trajectory:
    """Step ``model`` with its own integrator and timestep, recording every state.

    Returns ``steps + 1`` samples at t = k·h, k = 0 .. steps: the time the state after k steps stands for.
    MuJoCo's own clock adds h at every step and drifts from it by its round-off (5.000000000015821 s
    after 250 000 steps of 2e-5 s), a time that is no property of the state: a reference sampled there
    would be off by the velocity times the drift, and past its horizon. Raises SimulationDiverged
    on NaN or MuJoCo warnings, ModelMismatch if the model lacks what the probe
    reads. ``method``: ``auto`` (the native recorder where it could be built, else the
    batch recorder where ``mujoco.batch`` exists, else the loop), ``native``, ``batch``
    or ``loop``; all give the same numbers.
    ``timings``, if given, receives the seconds of the Python readings
    (``readings``, batch recorder) or of the whole loop recording (``loop``).
    """
    if steps < 1:
        raise ValueError(f"steps must be >= 1, got {steps}")
    if method not in ("auto", "native", "batch", "loop"):
        raise ValueError(f"method must be 'auto', 'native', 'batch' or 'loop', got {method!r}")
    if method == "batch" and _batch is None:
        raise ValueError(f"method 'batch' needs mujoco.batch, which MuJoCo {mujoco.__version__} lacks; "
                         "accepted here: 'auto', 'loop'")
    probe.validate(model)
    timings = {} if timings is None else timings
    run = None
    lib = native.library() if method in ("auto", "native") else None
    if method == "native" and lib is None:
        accepted = ", ".join(repr(m) for m in ("auto", "batch", "loop") if m != "batch" or _batch is not None)
        raise ValueError(f"method 'native' is not available here: {native.why_not()}; accepted here: {accepted}")
    in_c: list[Callable[[mujoco.MjData], _Run | None]] = []  # each None where its check sends the run on
    if lib is not None:
        in_c.append(lambda data: _record_native(lib, model, probe, data, steps, timings))
    if _batch is not None and method in ("auto", "batch"):
        in_c.append(lambda data: _record_batch(model, probe, data, steps, timings))
    for record in in_c:
        data = _take_data(model)
        try:
            probe.binding.set_state(model, data, q0, qd0)
            run = record(data)
        finally:
            _give_back_data(model, data)
        if run is not None:
            break
    if run is None:
        start = time.perf_counter()
        data = mujoco.MjData(model)
        probe.binding.set_state(model, data, q0, qd0)
        run = _record_loop(model, probe, data, steps)
        timings["loop"] = time.perf_counter() - start
    return _trajectory(model, probe, run)


def _trajectory(model: mujoco.MjModel, probe: Probe, run: _Run) -> Trajectory:
    dof = probe.binding.dof_matrix(model)
    extra = {name: run.readings[f"invariants.{name}"] for name in probe.invariants}
    forces = {name: run.readings[f"forces.{name}"] for name in probe.forces}
    series = {name: run.readings[f"series.{name}"] for name in probe.series}
    return Trajectory(
        t=np.arange(len(run.t)) * float(model.opt.timestep), positions=run.positions, velocities=run.velocities,
        multipliers=run.lam | forces,
        generalized_force=None if dof is None else run.qfrc @ dof,
        invariants={"energy": run.energy} | extra, violations=run.viol,
        source=f"mujoco:{integrator_name(model)}", series=series,
    )


# ----------------------------------------------------------------- loop recorder
def _record_loop(model: mujoco.MjModel, probe: Probe, data: mujoco.MjData, steps: int) -> _Run:
    """mj_forward, record, integrator function: one Python round trip per step."""
    step = STEP_FUNCTIONS[integrator_name(model)]
    n = steps + 1
    t = np.zeros(n)
    pos = {p: np.zeros((n, 3)) for p in probe.points}
    vel = {p: np.zeros((n, 3)) for p in probe.points}
    lam = {c: _rows(model, c, n) for c in probe.constraints}
    viol = {c: _rows(model, c, n) for c in probe.constraints}
    energy = np.zeros(n)
    extra = fields_of(probe.readings())
    recorded = {f: np.zeros((n, *np.shape(getattr(data, f)))) for f in extra}
    qpos, qvel = np.zeros((n, model.nq)), np.zeros((n, model.nv))
    qfrc = np.zeros((n, model.nv))
    for k in range(n):
        t[k] = data.time  # before the checks: a bad value makes MuJoCo warn and reset the data
        _checked_forward(model, data)
        _check_warnings(data.warning.number, t[k])
        for p in probe.points:
            pos[p][k], vel[p][k] = point_state(model, data, p)
        for c in probe.constraints:
            lam[c][k], viol[c][k] = _block(model, data, c, probe.sign(c))
        energy[k] = data.energy[0] + data.energy[1]
        qpos[k], qvel[k] = data.qpos, data.qvel
        for f in extra:
            recorded[f][k] = getattr(data, f)
        qfrc[k] = data.qfrc_constraint
        if k < steps:
            step(model, data)
    values = _evaluate_readings(model, probe, t, qpos, qvel, recorded)
    return _Run(states=np.zeros((0, 0)), t=t, positions=pos, velocities=vel, lam=lam, viol=viol, energy=energy,
                qfrc=qfrc, readings=values)


# ---------------------------------------------------------------- batch recorder
def _state_offset(model: mujoco.MjModel, component: mujoco.mjtState) -> int:
    """Where ``component`` starts in an mjSTATE_INTEGRATION row (components lie in bit order)."""
    return mujoco.mj_stateSize(model, int(_STATE) & (int(component) - 1))


def set_threads(count: int | None) -> None:
    """Threads the batch recorder may use for RK4's recomputation (None: one per CPU). A process pool
    of one worker per CPU sets 1, so that workers do not compete for the same cores."""
    if count is not None and count < 1:
        raise ValueError(f"thread count must be >= 1 or None, got {count}")
    global _threads
    _threads = count


def _layout(model: mujoco.MjModel) -> tuple[int, int, int] | None:
    """What MjData and scratch arrays of ``model`` share with another model's; None where MuJoCo gives
    no model signature (3.3, whose runs reuse nothing)."""
    signature = getattr(model, "signature", None)
    return None if signature is None else (int(signature), int(model.narena), int(model.nbuffer))


def _take_data(model: mujoco.MjModel, *, spare: bool = False) -> mujoco.MjData:
    """A reset MjData for ``model``, reused from an earlier run of a model of the same layout (same
    signature and arena, as models compiled from one MJCF with other options are) where one was
    given back: making one costs about 0.35 ms, as much as a short rollout. The batch recorder sets
    every state it reads, so nothing leaks from one run to the next."""
    layout = _layout(model)
    data = None if layout is None else _spare_data.pop((*layout, spare), None)
    if data is None:
        return mujoco.MjData(model)
    mujoco.mj_resetData(model, data)
    return data


def _keep(pool: dict, key: object, value: object, limit: int) -> None:
    """Put ``value`` in ``pool`` for the next run, dropping the oldest entries beyond ``limit``."""
    while len(pool) >= limit:
        pool.pop(next(iter(pool)))
    pool[key] = value


def _give_back_data(model: mujoco.MjModel, data: mujoco.MjData, *, spare: bool = False) -> None:
    layout = _layout(model)
    if layout is not None:
        _keep(_spare_data, (*layout, spare), data, _SPARE_DATA)


def _new_batch(model: mujoco.MjModel, nsim: int, data: mujoco.MjData, *, threads: int | None = None
               ) -> _batch.Batch:
    # the batch's results are bit-identical at any thread count (mujoco.batch documentation)
    threads = threads or (1 if nsim < _PARALLEL_SIMS else _threads_allowed())
    b = _batch.Batch(model, nsim, nthread=min(threads, nsim))
    # The batch makes an MjData of its own, only to learn field shapes, on first use (about as costly
    # as a short rollout); ours serves as well. An optimisation: without it the batch makes its own.
    with contextlib.suppress(Exception):  # another mujoco.batch: it makes its own
        b._data = data
    return b


def _checked_forward(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """mj_forward between the checks mj_step makes around it: a huge or non-finite qpos, qvel or
    qacc raises a MuJoCo warning (and resets the data), which the caller turns into SimulationDiverged."""
    mujoco.mj_checkPos(model, data)
    mujoco.mj_checkVel(model, data)
    mujoco.mj_forward(model, data)
    mujoco.mj_checkAcc(model, data)


def _forward_at(model: mujoco.MjModel, data: mujoco.MjData, state: np.ndarray) -> None:
    """mj_forward at a recorded state, as the loop recorder computes it there."""
    mujoco.mj_setState(model, data, state, _STATE)
    mujoco.mj_forward(model, data)


@dataclass
class _Record:
    """Where a batch run is recorded: the integration states and ``fields``, one row per sample.

    The arrays are scratch space, reused by the next run of the same layout and length (fresh
    arrays of a few MB cost a page fault per 4 KiB when first written: about a sixth of a short
    rollout). Everything a Trajectory keeps is copied out of them."""

    states: np.ndarray                # (steps + 1, nstate)
    fields: dict[str, np.ndarray]     # (steps + 1, ...) per field, MjData's dtype

    @classmethod
    def take(cls, model: mujoco.MjModel, data: mujoco.MjData, steps: int, fields: Sequence[str]) -> _Record:
        layout = _layout(model)
        spare = None if layout is None else _spare_records.pop((*layout, steps, tuple(fields)), None)
        if spare is not None:
            return spare
        nstate = mujoco.mj_stateSize(model, _STATE)
        # MjData's types: an int field (nefc, nisland) is a C int, as the batch records it
        shapes = {f: (np.shape(getattr(data, f)), np.int32 if isinstance(getattr(data, f), int)
                      else np.asarray(getattr(data, f)).dtype) for f in fields}
        return cls(states=np.empty((steps + 1, nstate)),
                   fields={f: np.empty((steps + 1, *shape), dtype) for f, (shape, dtype) in shapes.items()})

    def give_back(self, model: mujoco.MjModel) -> None:
        layout = _layout(model)
        if layout is not None:
            _keep(_spare_records, (*layout, len(self.states) - 1, tuple(self.fields)), self, _SPARE_DATA)

    def out(self, start: int, stop: int, *, with_fields: bool) -> dict:
        """``Batch.rollout``'s out= for steps start..stop−1: states start+1..stop and, ``with_fields``,
        the fields mj_step computed at states start..stop−1 (an RK4 rollout records none)."""
        out: dict = {_STATE: self.states[None, start + 1:stop + 1]}
        if with_fields:
            out |= {f: v[None, start:stop] for f, v in self.fields.items()}
        return out


_spare_records: dict[tuple, _Record] = {}


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
        _check_warnings(fb.warning[k, :, 1], float(states[k, 0]))
    for f, v in outputs.items():
        into[f][...] = np.asarray(v).reshape(into[f].shape)


def _step(b: _batch.Batch, nstep: int, record: Sequence, out: dict, states: np.ndarray) -> None:
    """``nstep`` steps of batch ``b``'s one simulation, recording into ``out`` (``states``: the recorded
    states, the first step's start included); SimulationDiverged on an error or a warning, at the time of
    the state it was raised at, as the loop recorder reads it (:func:`_warning_time`)."""
    try:
        b.rollout(nstep, record=record, out=out)
    except _batch.SimulationError as exc:
        raise SimulationDiverged(f"MuJoCo error {' '.join(str(exc).split())!r}", _warning_time(states)) from None
    counts = b.warning[0, :, 1]
    if counts.max() > 0:
        _check_warnings(counts, _warning_time(states))


def _warning_time(states: np.ndarray) -> float:
    """The time of the state a rollout's warning was raised at. MuJoCo resets the data in that step (and
    steps on from time 0), then the rollout stops and its records repeat the step's result: the warning's
    state is the one before the first repeated record (the last but one where nothing repeats)."""
    repeated = np.flatnonzero((states[1:] == states[:-1]).all(axis=1))
    after = int(repeated[0]) if repeated.size else len(states) - 1
    return float(states[max(after - 1, 0), 0])


def _take_batch(model: mujoco.MjModel, data: mujoco.MjData) -> _batch.Batch:
    """A one-simulation batch of ``model`` (this very object: a batch keeps its model), reused from an
    earlier run where one was given back (making one costs about 0.1 ms, 3 % of a short rollout).
    Every run sets the whole integration state, and a step starts from it alone (mj_forward), so
    nothing leaks from one run to the next (pinned bit for bit against the loop)."""
    spare = _spare_batches.pop(id(model), None)
    return spare[1] if spare is not None else _new_batch(model, 1, data)


def _give_back_batch(model: mujoco.MjModel, b: _batch.Batch) -> None:
    # the model is held, so its id is not reused meanwhile
    _keep(_spare_batches, id(model), (model, b), 2 * _SPARE_DATA)


def _threads_allowed() -> int:
    return _threads or os.cpu_count() or 1


def _chunk_sizes(steps: int) -> list[int]:
    """Halving chunks (half the run, a quarter, ...) down to at most 2·_MIN_CHUNK steps. A forward costs
    about a quarter of an RK4 step, so a chunk's recomputation ends while the next, half as long,
    steps; what is left after the last step is the last chunk's, a few dozen states."""
    sizes, left = [], steps
    while left > 2 * _MIN_CHUNK:
        sizes.append(left - left // 2)
        left //= 2
    return [*sizes, left]


def _even_chunk_sizes(steps: int) -> list[int]:
    """About _EVEN_CHUNKS equal chunks of at least _MIN_CHUNK steps. Reading a state's equalities costs
    about what stepping it does (a forward), so the other thread keeps pace with chunks of one size and
    what is left after the last step is the last chunk's reading."""
    size = max(_MIN_CHUNK, -(-steps // _EVEN_CHUNKS))
    return [size] * (steps // size) + ([steps % size] if steps % size else [])


# work(data, start, stop): what the other thread does with states start..stop−1 once they are recorded
_Work = Callable[[mujoco.MjData, int, int], None]


def _rollout(model: mujoco.MjModel, data: mujoco.MjData, rec: _Record, steps: int, *, recomputed: bool,
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

    record = [_STATE] if recomputed else [_STATE, *rec.fields]
    sizes = _chunk_sizes(steps) if recomputed else _even_chunk_sizes(steps)
    b = _take_batch(model, data)
    b.state[0] = rec.states[0]
    if _threads_allowed() < 2 or len(sizes) < 2 or (not recomputed and work is None):
        _step(b, steps, record, rec.out(0, steps, with_fields=not recomputed), rec.states)
        _give_back_batch(model, b)  # not after an error: its warning counters would stop the next run
        if recomputed:
            _forward_all(model, data, rec.states, rec.fields)
        if work is not None:
            work(data, 0, steps + 1)
        return
    bounds = np.cumsum([0, *sizes])
    helper = _take_data(model, spare=True)  # the other thread's: not the rollout's own
    try:
        with ThreadPoolExecutor(max_workers=1) as pool:
            pending = []
            for start, stop in itertools.pairwise(bounds):
                _step(b, int(stop - start), record, rec.out(int(start), int(stop), with_fields=not recomputed),
                      rec.states[int(start):int(stop) + 1])
                pending.append(pool.submit(each, helper, int(start), int(stop)))
            _give_back_batch(model, b)
            pending.append(pool.submit(each, helper, steps, steps + 1))
            for f in pending:
                f.result()
    finally:
        _give_back_data(model, helper, spare=True)


def _record_batch(model: mujoco.MjModel, probe: Probe, data: mujoco.MjData, steps: int,
                  timings: dict[str, float]) -> _Run | None:
    """The batch recorder; None where a check sends the run back to the loop."""
    shifted = integrator_name(model) != "RK4"
    rec = _Record.take(model, data, steps, recorded_fields(model, probe))
    try:
        return _record_into(model, probe, data, steps, rec, shifted, timings)
    finally:
        rec.give_back(model)


def _record_into(model: mujoco.MjModel, probe: Probe, data: mujoco.MjData, steps: int, rec: _Record,
                 shifted: bool, timings: dict[str, float]) -> _Run | None:
    """:func:`_record_batch` with its scratch arrays."""
    mujoco.mj_getState(model, data, rec.states[0], _STATE)
    # the equalities no recorded field gives: read after mj_forward at every state, beside the rollout
    recoverable = _joint_equalities(model, probe.constraints)
    read = [c for c in probe.constraints if c not in recoverable]
    lam = {c: _rows(model, c, steps + 1) for c in read}
    viol = {c: _rows(model, c, steps + 1) for c in read}

    def work(helper: mujoco.MjData, start: int, stop: int) -> None:
        _read_equalities(model, helper, rec.states[start:stop], {c: lam[c][start:stop] for c in read},
                         {c: viol[c][start:stop] for c in read})

    _rollout(model, data, rec, steps, recomputed=not shifted, work=work if read else None)
    states, fields = rec.states, rec.fields
    # the last state, which no step follows, gets the checks mj_step would make (as in the loop)
    mujoco.mj_setState(model, data, states[-1], _STATE)
    _checked_forward(model, data)
    _check_warnings(data.warning.number, float(states[-1, 0]))
    if shifted:  # fields of states 0..steps−1 from the rollout, the last state's from that forward
        for f, v in fields.items():
            v[-1] = getattr(data, f)
    for c in read:
        lam[c], viol[c] = _signed(probe.sign(c), lam[c], viol[c])
    return _finish(model, probe, data, rec, lam, viol, timings)


def _finish(model: mujoco.MjModel, probe: Probe, data: mujoco.MjData, rec: _Record, lam: dict[str, np.ndarray],
            viol: dict[str, np.ndarray], timings: dict[str, float],
            velocities: dict[str, np.ndarray] | None = None) -> _Run | None:
    """A recorded run's assembly, readings and check against a fresh mj_forward (both recorders in C);
    ``lam``/``viol``: the equalities already read per state, signed; ``velocities``: the points' (else
    assembled from the recorded fields). None where the check sends the run back to the loop."""
    states, fields = rec.states, rec.fields
    # a sum is finite only if every term is (MuJoCo's own checks would have warned long before an
    # overflow); the row-by-row look, only to say where
    if not np.isfinite(states.sum()):
        finite = np.isfinite(states).all(axis=1)
        if not finite.all():
            raise SimulationDiverged("non-finite state", float(states[np.argmin(finite), 0]))
    run = _assemble(model, probe, states, fields, velocities)
    run.lam |= lam
    run.viol |= viol
    clock = time.perf_counter()
    run.readings = _evaluate_readings(model, probe, run.t, states[:, 1:1 + model.nq],
                                      states[:, 1 + model.nq:1 + model.nq + model.nv], fields)
    timings["readings"] = time.perf_counter() - clock
    recovered = list(run.lam)
    _read_at_states(model, data, probe, run, [c for c in probe.constraints if c not in run.lam])
    bad = _verify(model, data, probe, run)
    wrong = [c for c in recovered if f"equality {c!r}" in bad]
    if wrong and len(wrong) == len(bad):  # only the recovered equalities: read them per sample instead
        _notes.append(f"{_label(model)}: efc_force/efc_pos recovered from qfrc_constraint and qpos differed "
                      f"from a fresh mj_forward for {wrong}; read per sample instead")
        _read_at_states(model, data, probe, run, wrong)
        bad = _verify(model, data, probe, run)
    if bad:
        _notes.append(f"{_label(model)}: the batch recorder's {', '.join(bad)} differed from a fresh "
                      "mj_forward; recorded with the loop instead")
        return None
    return run


# -------------------------------------------------------------- native recorder
def _record_native(lib: object, model: mujoco.MjModel, probe: Probe, data: mujoco.MjData, steps: int,
                   timings: dict[str, float]) -> _Run | None:
    """The native recorder (:mod:`harness.engine.native`): MuJoCo's steps made in C, recording the
    state, the fixed-size fields and the equalities' efc rows at every sample as it steps; None where
    the check against a fresh mj_forward sends the run back to the loop."""
    rec = _Record.take(model, data, steps, recorded_fields(model, probe))
    try:
        mujoco.mj_getState(model, data, rec.states[0], _STATE)
        recoverable = _joint_equalities(model, probe.constraints)
        read = [c for c in probe.constraints if c not in recoverable]
        layout = _equality_layout(model) if read else None
        nrows = layout[1] if layout is not None else 0
        force, pos = np.empty((steps + 1, nrows)), np.empty((steps + 1, nrows))
        sources = [point_source(model, p) for p in probe.points]
        velocity = np.empty((len(sources), steps + 1, 3))  # a fresh array: the trajectory keeps its rows
        k, rows_ok = native.record(lib, model, data, steps=steps, integrator=integrator_name(model),
                                   states=rec.states, fields=rec.fields, force=force, pos=pos,
                                   points=[native.Point(body=s.body, site=s.index if s.kind == "site" else -1,
                                                        root=int(model.body_rootid[s.body]),
                                                        chain=tuple(sorted(_velocity_chain(model, s.body))))
                                           for s in sources],
                                   velocity=velocity)
        if k >= 0:
            _check_warnings(data.warning.number, float(rec.states[k, 0]))
        fixed = _fixed_rows(model, rec.states) if nrows and rows_ok else None
        lam, viol = {}, {}
        for c in read if fixed is not None else ():
            lam[c], viol[c] = _signed(probe.sign(c), force[:, fixed[c]], pos[:, fixed[c]])
        velocities = dict(zip(probe.points, velocity, strict=True))
        return _finish(model, probe, data, rec, lam, viol, timings, velocities)
    finally:
        rec.give_back(model)


def _label(model: mujoco.MjModel) -> str:
    return f"{integrator_name(model)} at h = {model.opt.timestep:g} s"


def _velocity_chain(model: mujoco.MjModel, body: int) -> list[int]:
    """The dofs mj_jac visits for ``body``: its first moving ancestor's dof chain."""
    while body and model.body_dofnum[body] == 0:
        body = int(model.body_parentid[body])
    if not body:
        return []
    chain, i = [], int(model.body_dofadr[body] + model.body_dofnum[body] - 1)
    while i >= 0:
        chain.append(i)
        i = int(model.dof_parentid[i])
    return chain


def _point_velocity(model: mujoco.MjModel, fields: Mapping[str, np.ndarray], qvel: np.ndarray,
                    point: np.ndarray, body: int) -> np.ndarray:
    """J·qvel at ``point`` (N, 3: the point's world position at every sample) moving with ``body``,
    J's columns assembled as mj_jac does (cdof_lin + cdof_ang × (point − subtree_com[root])) and
    summed in dof order as point_state does (the dofs outside the chain add exact zeros there), so the
    result is point_state's, bit for bit."""
    rows = np.ascontiguousarray  # samples contiguous per component: fast elementwise operations
    o0, o1, o2 = rows((point - fields["subtree_com"][:, model.body_rootid[body]]).T)
    velocity = np.zeros((3, len(qvel)))
    for i in sorted(_velocity_chain(model, body)):
        a0, a1, a2, l0, l1, l2 = rows(fields["cdof"][:, i].T)
        q = rows(qvel[:, i])
        velocity[0] = velocity[0] + (l0 + (a1 * o2 - a2 * o1)) * q
        velocity[1] = velocity[1] + (l1 + (a2 * o0 - a0 * o2)) * q
        velocity[2] = velocity[2] + (l2 + (a0 * o1 - a1 * o0)) * q
    return rows(velocity.T)


@dataclass(frozen=True)
class _JointEquality:
    """A one-row joint equality whose efc_force and efc_pos follow exactly from recorded fields.

    MuJoCo's row of a joint equality (engine_core_constraint.c) has Jacobian 1
    at joint1's dof and −p'(q2 − q2₀) at joint2's, and position error
    q1 − q1₀ − c0 − (c1 d + c2 d² + c3 d³ + c4 d⁴), d = q2 − q2₀. When no
    other row touches joint1's dof, qfrc_constraint = Jᵀ efc_force holds
    efc_force there times 1, exactly; and the position error is recomputed
    with the same operations. Both are checked bit for bit at a few samples.
    """

    dof: int
    qpos1: int
    ref1: float
    qpos2: int | None
    ref2: float
    coef: tuple[float, ...]

    def violation(self, qpos: np.ndarray) -> np.ndarray:
        c0, c1, c2, c3, c4 = self.coef
        if self.qpos2 is None:
            return qpos[:, self.qpos1] - self.ref1 - c0
        dif = qpos[:, self.qpos2] - self.ref2
        return qpos[:, self.qpos1] - self.ref1 - c0 - (c1 * dif + c2 * dif * dif + c3 * dif * dif * dif
                                                       + c4 * dif * dif * dif * dif)




def _joint_equalities(model: mujoco.MjModel, names: Sequence[str]) -> dict[str, _JointEquality]:
    """The equalities of ``names`` recoverable from recorded fields (see :class:`_JointEquality`),
    provided every efc row at every sample is a joint-equality row (checked by the caller)."""
    if model.neq == 0 or any(int(t) != int(mujoco.mjtEq.mjEQ_JOINT) for t in model.eq_type):
        return {}
    joints = [(int(model.eq_obj1id[i]), int(model.eq_obj2id[i])) for i in range(model.neq)]
    if any(int(model.jnt_type[j]) not in ONE_DOF for pair in joints for j in pair if j >= 0):
        return {}
    touched = [model.jnt_dofadr[j] for pair in joints for j in pair if j >= 0]
    out = {}
    for name in names:
        eq = model.equality(name).id
        j1, j2 = joints[eq]
        dof = int(model.jnt_dofadr[j1])
        if touched.count(dof) != 1:
            continue
        adr1 = int(model.jnt_qposadr[j1])
        adr2 = int(model.jnt_qposadr[j2]) if j2 >= 0 else None
        out[name] = _JointEquality(
            dof=dof, qpos1=adr1, ref1=float(model.qpos0[adr1]), qpos2=adr2,
            ref2=float(model.qpos0[adr2]) if adr2 is not None else 0.0,
            coef=tuple(float(c) for c in model.eq_data[eq, :5]))
    return out


def _assemble(model: mujoco.MjModel, probe: Probe, states: np.ndarray, fields: dict[str, np.ndarray],
              velocities: dict[str, np.ndarray] | None = None) -> _Run:
    nq, nv = model.nq, model.nv
    qpos = states[:, 1:1 + nq]
    qvel = states[:, 1 + nq:1 + nq + nv]
    positions = {}
    given, velocities = velocities is not None, dict(velocities or {})
    for p in probe.points:
        source = point_source(model, p)
        positions[p] = fields[source.field][:, source.index].copy()
        if not given:
            velocities[p] = _point_velocity(model, fields, qvel, positions[p], source.body)
    energy = fields["energy"][:, 0] + fields["energy"][:, 1]
    qfrc = np.array(fields["qfrc_constraint"])  # fields are the recorder's scratch space
    lam, viol = {}, {}
    recoverable = _joint_equalities(model, probe.constraints)
    if recoverable:
        start = _state_offset(model, mujoco.mjtState.mjSTATE_EQ_ACTIVE)
        active = states[:, start:start + model.neq]
        if np.all(active == 1) and np.all(fields["nefc"] == model.neq):  # every row is an equality's
            for c, eq in recoverable.items():
                lam[c] = qfrc[:, eq.dof] * probe.sign(c)  # × 1.0 is exact: bit for bit the loop's
                viol[c] = eq.violation(qpos) * probe.sign(c)
    return _Run(states=states, t=states[:, 0].copy(), positions=positions, velocities=velocities, lam=lam,
                viol=viol, energy=energy, qfrc=qfrc, readings={}, fields=fields)


def _read_at_states(model: mujoco.MjModel, data: mujoco.MjData, probe: Probe, run: _Run,
                    equalities: Sequence[str]) -> None:
    """The equalities ``equalities`` after mj_forward at every recorded state, as the loop recorder
    reads them."""
    if not equalities:
        return
    n = len(run.states)
    lam = {c: _rows(model, c, n) for c in equalities}
    viol = {c: _rows(model, c, n) for c in equalities}
    _read_equalities(model, data, run.states, lam, viol)
    for c in equalities:
        run.lam[c], run.viol[c] = _signed(probe.sign(c), lam[c], viol[c])


def _read_equalities(model: mujoco.MjModel, data: mujoco.MjData, states: np.ndarray,
                     lam: Mapping[str, np.ndarray], viol: Mapping[str, np.ndarray]) -> None:
    """efc_force and efc_pos of the equalities ``lam`` names (unsigned) after mj_forward at every row of
    ``states``, into ``lam`` and ``viol`` (arrays of len(states) rows). Sensors are skipped: nothing
    of the constraint solver reads them (the efc rows are bit for bit mj_forward's, checked with the
    rest by :func:`_verify`)."""
    fixed = _fixed_rows(model, states)
    if fixed is None:
        for k, state in enumerate(states):
            _forward_at(model, data, state)
            for c in lam:
                lam[c][k], viol[c][k] = _block(model, data, c)
        return
    # the same numbers with no search per sample: each equality's rows are a fixed slice of efc_*
    slices = [(lam[c], viol[c], fixed[c]) for c in lam]
    none = mujoco.mjtStage.mjSTAGE_NONE
    for k, state in enumerate(states):
        mujoco.mj_setState(model, data, state, _STATE)
        mujoco.mj_forwardSkip(model, data, none, 1)
        force, pos = data.efc_force, data.efc_pos  # views sized by this forward's nefc
        for values, errors, rows in slices:
            values[k], errors[k] = force[rows], pos[rows]


def _fixed_rows(model: mujoco.MjModel, states: np.ndarray) -> dict[str, slice | int] | None:
    """Each equality's rows in efc_* where they are the same at every state of ``states``, else None.

    MuJoCo makes the equalities' rows first, in equality order, one block per active equality
    (engine_core_constraint.c); where every equality is of a type with a fixed number of rows
    (:data:`EQUALITY_ROWS`) and active at every state, equality k's rows follow those of 0..k−1. A
    one-row block is an index (a float per sample), a longer one a slice. Checked bit for bit against
    the rows found by search (:func:`equality_block`) at one sample, as every batch run is."""
    layout = _equality_layout(model)
    start = _state_offset(model, mujoco.mjtState.mjSTATE_EQ_ACTIVE)
    if layout is None or not np.all(states[:, start:start + model.neq] == 1):
        return None
    return layout[0]


def _equality_layout(model: mujoco.MjModel) -> tuple[dict[str, slice | int], int] | None:
    """Each named equality's rows where every equality is active, and the number of those rows, where every
    equality is of a type with a fixed number of rows and none is switched off; else None."""
    kinds = [int(t) for t in model.eq_type]
    off = int(mujoco.mjtDisableBit.mjDSBL_EQUALITY) | int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    if any(k not in EQUALITY_ROWS for k in kinds) or model.opt.disableflags & off:
        return None
    out, row = {}, 0
    for eq, kind in enumerate(kinds):
        size = EQUALITY_ROWS[kind]
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_EQUALITY, eq)
        if name:
            out[name] = row if size == 1 else slice(row, row + size)
        row += size
    return out, row


def _verify(model: mujoco.MjModel, data: mujoco.MjData, probe: Probe, run: _Run) -> list[str]:
    """What differs from a fresh mj_forward at one sample mid-run (a shifted or, for RK4, a recomputed
    record), bit for bit: every recorded field (positions, energy and qfrc_constraint are copies or
    sums of them), the point velocities and the recovered equalities; empty when nothing does."""
    k = len(run.states) // 2
    _forward_at(model, data, run.states[k])
    bad = [f"field {f!r}" for f, values in run.fields.items() if not np.array_equal(getattr(data, f), values[k])]
    bad += [f"velocity of {p!r}" for p in probe.points
            if not np.array_equal(point_state(model, data, p)[1], run.velocities[p][k])]
    bad += [f"equality {c!r}" for c in probe.constraints
            if not all(np.array_equal(a, b) for a, b in zip(_block(model, data, c, probe.sign(c)),
                                                             (run.lam[c][k], run.viol[c][k]),
                                                             strict=True))]
    return bad

"""The Warp backend: MuJoCo Warp (``mujoco-warp``) on CPU, float32, batched over Warp worlds.

MuJoCo Warp steps ``nworld`` copies of one model at once; on CPU (``wp.set_device("cpu")``,
deterministic, what this harness uses: nothing may depend on a GPU) a step costs about the same
for one world as for hundreds, because the cost is the kernels' launch, not the arithmetic of a
pendulum. So every run of a request list goes into as few Warp calls as the model allows
(:func:`groups`):

- runs whose models differ only in fields Warp keeps per world (the fields its types declare
  with a leading ``*`` batch axis: the timestep, ``solref``/``solimp``, a body's inertia, the
  solver's tolerance, …) share one Warp model whose differing fields get one row per world
  (Warp reads ``field[world % rows]``) and are stepped together, as many steps as the longest
  run asks; a shorter run's extra steps are computed and dropped;
- runs that differ in anything else (the integrator, the solver, a model's sizes: Warp builds
  its step from them) go in separate calls.

Recording. After every step the full integration state of every world is read back
(``get_state``, ``mjSTATE_INTEGRATION``: time, qpos, qvel, act, warm start, …). The
derived fields a Trajectory needs (point positions, ``cdof``, ``subtree_com``, energy,
``qfrc_constraint``, the equalities' ``efc`` rows, the readings' fields) are then computed
by *one* batched ``forward`` with one world per recorded state (``set_state`` of that row,
warm start included, so each is the forward the step itself made at that state — and for
RK4 the fields of the state, not of the last stage). From there the arrays go through the
same assembly as the C batch recorder's (:mod:`harness.engine.recording`): the same points,
velocities J·qvel from ``cdof``, readings, equalities; what Warp does not compute is computed
by the harness from Warp's own arrays, never from the C engine's.

The instantaneous layer's states (:meth:`WarpBackend.forward_many`) go to Warp the same way: one
world per state in one ``forward`` (from a zero warm start, as the C engine's reset ``MjData``).
Warp computes the force, torque and accelerometer sensors and ``cfrc_int``/``cfrc_ext`` itself
(its ``forward`` calls ``rne_postconstraint`` where those sensors are present, contacts, connects
and welds included): they are read as they are. Its mass matrix is kept in the C engine's CSR
layout (``M``, rows ``M_rowadr``/``M_rownnz``, columns ``M_colind``, the lower triangle), which the
harness expands to the dense matrix (:func:`dense_mass`).

The kernels are compiled on first use (once per model structure, a cost a first run pays)
and cached on disk under the user cache folder (``$XDG_CACHE_HOME/mjharness/warp``), so a
second process, or a CI run that keeps the cache, loads them instead (the times:
docs/findings/backends.md).
"""

from __future__ import annotations

import copy
import dataclasses
import time
from collections.abc import Sequence
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

import mujoco
import numpy as np
import warp as wp

from harness.core.cache import cache_dir
from harness.core.errors import BackendUnavailable, SimulationDiverged
from harness.core.trajectory import Trajectory
from harness.engine.backends import Forward, Request, computes_reactions
from harness.engine.backends.completion import completed_run
from harness.engine.constraints import equality_size
from harness.engine.integrators import integrator_name
from harness.engine.probe import Probe
from harness.engine.recording.assemble import Run, evaluate_readings, recorded_fields, trajectory

__all__ = ["backend"]

# Before mujoco_warp loads Warp: no banner, no line per compiled module (warnings still show), and the
# kernels cached beside the harness's own disk cache.
wp.config.quiet = True
wp.config.log_level = wp.LOG_WARNING
_root = cache_dir()
if _root is not None:
    wp.config.kernel_cache_dir = str(_root / "warp")

import mujoco_warp as mjw  # noqa: E402  (after Warp's configuration above)

_STATE = int(mujoco.mjtState.mjSTATE_INTEGRATION)
COMPLETION_FIELDS = ("qacc", "qfrc_bias", "qfrc_passive", "qfrc_constraint", "M")
"""Recorded beside a constrained run's fields: what :func:`harness.engine.backends.completion.completed_run` reads."""

ADAPTED_FLAGS: dict[str, str] = {
    "mjENBL_DIAGEXACT": ("diagexact: MuJoCo Warp lacks it; constraint regularisers use MuJoCo's diagonal "
                         "approximation, and the softness part of the budget is measured on Warp's own runs"),
}
"""Enable flags cleared on Warp's copy of a model, each with what stands in for it (shown in the report),
as the MJX backend does."""
FORWARD_WORLDS = 4096
"""At most this many recorded states go to one batched ``forward`` (memory, not speed)."""

_ready = False
timings: dict[str, float] = {}
"""Seconds of this process's Warp work: ``init`` (loading Warp), ``compile`` (the first step and the
first forward of each model structure: kernels compiled, or loaded from the disk cache), ``step``,
``forward`` (the batched recomputation), by key; for the benchmarks."""


def kernel_cache() -> str:
    """Where Warp's compiled kernels are kept: beside the harness's own disk cache (a CI that keeps
    ``$XDG_CACHE_HOME`` between runs reuses them), else Warp's default."""
    return str(wp.config.kernel_cache_dir)


def init() -> None:
    """Load Warp once per process on the CPU, quietly, with its kernel cache under the user cache."""
    global _ready
    if _ready:
        return
    clock = time.perf_counter()
    wp.init()
    wp.set_device("cpu")
    _ready = True
    timings["init"] = timings.get("init", 0.0) + time.perf_counter() - clock


# ----------------------------------------------------------------------------- one Warp model per group
def _batched_fields(obj: Any) -> dict[str, object]:
    """The array fields of a Warp Model (or its Option) that carry a leading per-world axis."""
    out: dict[str, object] = {}
    for f in dataclasses.fields(obj):
        shape = getattr(f.type, "shape", ())
        if shape and shape[0] == "*":
            out[f.name] = f
    return out


def _frozen(value: object) -> object:
    """A hashable value that is equal for equal contents (arrays by their bytes, not their identity)."""
    if isinstance(value, wp.array):
        return ("array", value.shape, str(value.dtype), value.numpy().tobytes())
    if isinstance(value, np.ndarray):
        return ("ndarray", value.shape, value.tobytes())
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return _static_key(value)
    if isinstance(value, (tuple, list)):
        return tuple(_frozen(v) for v in value)
    if isinstance(value, dict):
        return tuple(sorted((str(k), _frozen(v)) for k, v in value.items()))
    if value is None or isinstance(value, (bool, int, float, str, np.generic)):
        return value
    return repr(value)


def _static_key(obj: Any) -> tuple:
    """Everything of a Warp Model (or Option) that is not per world, as a hashable value: runs whose
    keys differ cannot share a call."""
    batched = _batched_fields(obj)
    return tuple((f.name, _frozen(getattr(obj, f.name, None))) for f in dataclasses.fields(obj)
                 if f.name not in batched)


def _batch_into(target: Any, others: Sequence[Any]) -> None:
    """Give ``target`` one row per world for every per-world field in which ``others`` (the same
    structure, in world order, ``target``'s own values first) differ."""
    for name in _batched_fields(target):
        base = getattr(target, name)
        if not isinstance(base, wp.array):
            continue
        values = [getattr(o, name).numpy() for o in others]
        if all(np.array_equal(values[0], v) for v in values[1:]):
            continue
        stacked = np.concatenate(values, axis=0)
        array = wp.array(stacked, dtype=base.dtype, device=base.device)
        array._is_batched = True  # as put_model marks its per-world arrays (warp_util.mark_batched)
        setattr(target, name, array)
    for f in dataclasses.fields(target):
        value = getattr(target, f.name, None)
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            _batch_into(value, [getattr(o, f.name) for o in others])


@dataclass
class _Group:
    """Requests that share one Warp model and go to Warp as one call."""

    indices: list[int]
    models: list[object]


def groups(requests: Sequence[Request]) -> list[list[int]]:
    """The request indices that can share a Warp call (see the module docstring), in order."""
    return [g.indices for g in _group([mjw.put_model(r.model) for r in requests])]


def _group(wmodels: Sequence[object]) -> list[_Group]:
    out: dict[tuple, _Group] = {}
    for i, wm in enumerate(wmodels):
        key = _static_key(wm)
        out.setdefault(key, _Group(indices=[], models=[])).indices.append(i)
        out[key].models.append(wm)
    return list(out.values())


# ------------------------------------------------------------------------------------------ recording
def _capacity(model: mujoco.MjModel, datas: Sequence[mujoco.MjData | SimpleNamespace]) -> dict[str, int]:
    """Contact and constraint buffers: twice the C engine's count at the start (MuJoCo's parity guide),
    at least Warp's own default; an overflow later is checked and refused, never dropped silently."""
    nefc = max(d.nefc for d in datas)
    ncon = max(d.ncon for d in datas)
    return {"njmax": max(2 * nefc, model.neq * 6 + 2 * model.njnt + 16, 16), "nconmax": max(2 * ncon, 16)}


def _check_overflow(d: Any, what: str) -> None:
    flags = int(np.bitwise_or.reduce(d.overflow.numpy())) if d.overflow.shape[0] else 0
    mask = ~(int(mjw.OverflowType.ITERATIONS) | int(mjw.OverflowType.LS_ITERATIONS))
    if flags & mask:
        raise SimulationDiverged(f"MuJoCo Warp buffer overflow in {what}: {mjw.OverflowType(flags & mask)!r}", 0.0)


def _initial_states(requests: Sequence[Request], probe: Probe) -> tuple[np.ndarray, list[mujoco.MjData]]:
    rows, datas = [], []
    for r in requests:
        data = mujoco.MjData(r.model)
        probe.binding.set_state(r.model, data, r.q0, r.qd0)
        mujoco.mj_forward(r.model, data)
        row = np.zeros(mujoco.mj_stateSize(r.model, _STATE))
        mujoco.mj_getState(r.model, data, row, _STATE)
        rows.append(row)
        datas.append(data)
    return np.array(rows), datas


def _rollout(wm: object, model: mujoco.MjModel, start: np.ndarray, steps: int, capacity: dict[str, int],
             data: mujoco.MjData) -> np.ndarray:
    """Every world's integration state after 0..steps steps: (steps + 1, nworld, nstate), float64 copies
    of Warp's float32."""
    nworld = len(start)
    d = mjw.put_data(model, data, nworld=nworld, **capacity)
    mjw.set_state(wm, d, wp.array(start, dtype=float), _STATE)
    out = np.empty((steps + 1, nworld, start.shape[1]))
    buffer = wp.zeros((nworld, start.shape[1]), dtype=float)
    mjw.get_state(wm, d, buffer, _STATE)
    out[0] = buffer.numpy()
    for k in range(1, steps + 1):
        mjw.step(wm, d)
        mjw.get_state(wm, d, buffer, _STATE)
        out[k] = buffer.numpy()
    wp.synchronize()
    _check_overflow(d, "the rollout")
    return out


def _efc_block(types_: np.ndarray, ids: np.ndarray, nefc: np.ndarray, values: np.ndarray, eq: int,
               size: int) -> np.ndarray:
    """The ``size`` efc rows of equality ``eq`` at every world, in row order: (W,) or (W, size); rows
    past a world's ``nefc`` are buffer, not constraints."""
    used = np.arange(types_.shape[1])[None, :] < nefc[:, None]
    mask = used & (types_ == int(mujoco.mjtConstraint.mjCNSTR_EQUALITY)) & (ids == eq)
    counts = mask.sum(axis=1)
    if not np.all(counts == size):
        raise SimulationDiverged(f"equality {eq} has {sorted(set(counts.tolist()))} efc rows in Warp's "
                                 f"constraint arrays; expected {size}", 0.0)
    rows = values[mask].reshape(len(values), size)
    return rows[:, 0] if size == 1 else rows


def _forward_fields(wm: Any, model: mujoco.MjModel, states: np.ndarray, fields: Sequence[str],
                    equalities: Sequence[str], capacity: dict[str, int], data: mujoco.MjData,
                    ) -> tuple[dict[str, np.ndarray], dict[str, tuple[np.ndarray, np.ndarray]]]:
    """Warp's forward at every state of ``states`` ((W, nstate), W a multiple of the model's per-world
    rows, world w of the row w % rows): the derived ``fields`` and the equalities' (efc_force, efc_pos)."""
    out: dict[str, list] = {f: [] for f in fields}
    eqs: dict[str, tuple[list, list]] = {c: ([], []) for c in equalities}
    rows = FORWARD_WORLDS - FORWARD_WORLDS % max(1, _rows(wm))
    for lo in range(0, len(states), rows):
        chunk = states[lo:lo + rows]
        d = mjw.put_data(model, data, nworld=len(chunk), **capacity)
        mjw.set_state(wm, d, wp.array(chunk, dtype=float), _STATE)
        mjw.forward(wm, d)
        wp.synchronize()
        _check_overflow(d, "the recomputed forward")
        for f in fields:
            out[f].append(np.asarray(getattr(d, f).numpy(), dtype=float))
        if equalities:
            efc_type, efc_id, nefc = d.efc.type.numpy(), d.efc.id.numpy(), d.nefc.numpy()
            force, pos = d.efc.force.numpy().astype(float), d.efc.pos.numpy().astype(float)
            for c in equalities:
                eq = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_EQUALITY, c)
                size = equality_size(model, c)
                eqs[c][0].append(_efc_block(efc_type, efc_id, nefc, force, eq, size))
                eqs[c][1].append(_efc_block(efc_type, efc_id, nefc, pos, eq, size))
    fields_out = {f: np.concatenate(v, axis=0) for f, v in out.items()}
    return fields_out, {c: (np.concatenate(a), np.concatenate(b)) for c, (a, b) in eqs.items()}


def dense_mass(model: mujoco.MjModel, csr: np.ndarray) -> np.ndarray:
    """The dense joint-space inertia matrices (N, nv, nv) from the CSR lower triangles ``csr`` (N, nC) that
    MuJoCo (``mjData.M``) and MuJoCo Warp (``Data.M``) keep: rows ``M_rowadr``/``M_rownnz``, columns
    ``M_colind``; mirrored to the upper triangle."""
    dense = np.zeros((len(csr), model.nv, model.nv))
    for i in range(model.nv):
        for k in range(int(model.M_rowadr[i]), int(model.M_rowadr[i] + model.M_rownnz[i])):
            j = int(model.M_colind[k])
            dense[:, i, j] = csr[:, k]
            dense[:, j, i] = csr[:, k]
    return dense


def _rows(wm: Any) -> int:
    """How many per-world rows the group's Warp model has (1 unless runs differ in a per-world field)."""
    rows = 1
    for obj in (wm, wm.opt):
        for name in _batched_fields(obj):
            value = getattr(obj, name, None)
            if isinstance(value, wp.array) and value.ndim and value.shape[0] > rows:
                rows = value.shape[0]
    return rows


def _run_group(requests: Sequence[Request], wmodels: Sequence[object], probe: Probe) -> list[Trajectory]:
    model = host_model(requests[0].model)
    wm = wmodels[0]
    _batch_into(wm, wmodels)
    if _rows(wm) not in (1, len(requests)):
        raise AssertionError(f"per-world rows {_rows(wm)} for {len(requests)} worlds")
    start, datas = _initial_states(requests, probe)
    capacity = _capacity(model, datas)
    steps = max(r.steps for r in requests)
    clock = time.perf_counter()
    states = _rollout(wm, model, start, steps, capacity, datas[0])
    timings["step"] = timings.get("step", 0.0) + time.perf_counter() - clock
    # Time is the step count times the run's timestep, in float64: Warp's float32 clock drifts by its
    # round-off (1e-7 s after 1 s), which is no error of the state it carries.
    ks = np.arange(steps + 1)
    for g, r in enumerate(requests):
        states[:, g, 0] = start[g, 0] + ks * float(r.model.opt.timestep)
    # A run shorter than the call's keeps its own samples; for the forward its extra rows repeat its
    # last state (the steps past its end are not its run, and may have left the physics).
    nworld = len(requests)
    for g, r in enumerate(requests):
        states[r.steps + 1:, g] = states[r.steps, g]
    for g, r in enumerate(requests):
        bad = ~np.isfinite(states[:r.steps + 1, g]).all(axis=1)
        if bad.any():
            k = int(np.argmax(bad))
            raise SimulationDiverged("non-finite state on MuJoCo Warp", float(states[max(k - 1, 0), g, 0]))
    # with constraints, also what completing each sample's stopped solve needs (harness/engine/backends/completion.py)
    wanted = tuple(dict.fromkeys((*recorded_fields(model, probe),
                                  *(COMPLETION_FIELDS if probe.constraints else ()))))
    for f in wanted:
        if not hasattr(mjw.Data, "__dataclass_fields__") or f not in {x.name for x in dataclasses.fields(mjw.Data)}:
            raise BackendUnavailable(f"backend 'warp' does not compute the field {f!r} this case reads; "
                                     "fix: use --backend c for this case")
    clock = time.perf_counter()
    flat = states.reshape(-1, states.shape[-1])  # sample-major: world w is run w % nworld
    fields, eqs = _forward_fields(wm, model, flat, wanted, probe.constraints, capacity, datas[0])
    timings["forward"] = timings.get("forward", 0.0) + time.perf_counter() - clock
    out = []
    for g, r in enumerate(requests):
        take = slice(g, (r.steps + 1) * nworld, nworld)
        run_states = np.ascontiguousarray(flat[take])
        run_fields = {f: np.ascontiguousarray(v[take]) for f, v in fields.items()}
        if "energy" in run_fields and run_fields["energy"].ndim == 1:
            run_fields["energy"] = run_fields["energy"].reshape(-1, 2)
        run = Run.from_record(r.model, probe, run_states, run_fields)
        for c, (force, pos) in eqs.items():
            if c not in run.lam:  # a joint equality recovered from Warp's qfrc_constraint is kept
                sign = probe.sign(c)  # a tendon whose rows are −1 × the analytic constraint's (Probe.signs)
                run.lam[c], run.viol[c] = sign * force[take], sign * pos[take]
        run.readings = evaluate_readings(r.model, probe, run.t, run_states[:, 1:1 + r.model.nq],
                                         run_states[:, 1 + r.model.nq:1 + r.model.nq + r.model.nv], run_fields)
        traj = dataclasses.replace(trajectory(r.model, probe, run), source=f"warp:{integrator_name(r.model)}")
        if probe.constraints:
            nq, nv = r.model.nq, r.model.nv
            traj = completed_run(r.model, probe, traj, qpos=run_states[:, 1:1 + nq],
                                 qvel=run_states[:, 1 + nq:1 + nq + nv],
                                 fields={**run_fields, "mass": dense_mass(model, run_fields["M"])},
                                 equality={c: force[take] for c, (force, _) in eqs.items()},
                                 epsilon=WarpBackend.epsilon)
        out.append(traj)
    return out


class WarpBackend:
    """MuJoCo Warp on CPU, float32, one call per group of runs that can share a Warp model."""

    precision = "float32"
    epsilon = float(np.finfo(np.float32).eps)

    def __init__(self, name: str = "warp") -> None:
        self.name = name
        init()

    def unsupported(self, model: mujoco.MjModel) -> str:
        """Why MuJoCo Warp cannot run ``model`` (one line: the backend, Warp's own words, the fix), or ""."""
        try:
            _put_model(model)
        except BackendUnavailable as exc:
            return str(exc)
        return ""

    def adaptations(self, model: mujoco.MjModel) -> tuple[str, ...]:
        return adaptations(model)

    def supports(self, model: mujoco.MjModel) -> None:
        _put_model(model)

    def forward_many(self, model: mujoco.MjModel, probe: Probe, qpos: np.ndarray, qvel: np.ndarray) -> Forward:
        """Warp's ``forward`` at every state, one world per state, in one call (chunks of
        :data:`FORWARD_WORLDS`), the arrays copied to float64; each equality's rows found by type and id
        in Warp's constraint arrays."""
        clock = time.perf_counter()
        wm = _put_model(model)
        host = host_model(model)
        data = mujoco.MjData(host)
        rows, datas = [], []
        for qp, qv in zip(qpos, qvel, strict=True):
            mujoco.mj_resetData(host, data)
            data.qpos[:], data.qvel[:] = qp, qv
            row = np.zeros(mujoco.mj_stateSize(host, _STATE))
            mujoco.mj_getState(host, data, row, _STATE)  # before the forward: a zero warm start
            rows.append(row)
            mujoco.mj_forward(host, data)  # the C engine's contact and row counts size Warp's buffers only
            datas.append(SimpleNamespace(nefc=data.nefc, ncon=data.ncon))
        reactions = computes_reactions(model)
        wanted = ("qacc", "qfrc_bias", "qfrc_passive", "qfrc_constraint", "M",
                  *(("sensordata",) if model.nsensordata else ()), *(("cfrc_int", "cfrc_ext") if reactions else ()),
                  *(("qfrc_actuator",) if model.nu else ()))
        mujoco.mj_resetData(host, data)
        fields, eqs = _forward_fields(wm, host, np.array(rows).reshape(len(rows), -1), wanted, probe.constraints,
                                      _capacity(host, datas), data)
        timings["forward_many"] = timings.get("forward_many", 0.0) + time.perf_counter() - clock
        return Forward(qacc=fields["qacc"], qfrc_bias=fields["qfrc_bias"], qfrc_passive=fields["qfrc_passive"],
                       qfrc_constraint=fields["qfrc_constraint"], mass=dense_mass(host, fields["M"]),
                       equality={c: force.reshape(len(rows), -1) for c, (force, _) in eqs.items()},
                       sensordata=fields.get("sensordata"), cfrc_int=fields.get("cfrc_int"),
                       cfrc_ext=fields.get("cfrc_ext"), qfrc_actuator=fields.get("qfrc_actuator"))

    def simulate_many(self, requests: Sequence[Request], probe: Probe) -> list[Trajectory]:
        if not requests:
            return []
        clock = time.perf_counter()
        put: dict[int, object] = {}  # one Warp model per distinct MjModel (put_model is costly even for a pendulum)
        for r in requests:
            if r.steps < 1:
                raise ValueError(f"steps must be >= 1, got {r.steps}")
            probe.validate(r.model)
            if id(r.model) not in put:
                put[id(r.model)] = _put_model(r.model)
        wmodels = [put[id(r.model)] for r in requests]
        out: list[Trajectory | None] = [None] * len(requests)
        for group in _group(wmodels):
            chosen = [requests[i] for i in group.indices]
            for i, traj in zip(group.indices, _run_group(chosen, group.models, probe), strict=True):
                out[i] = traj
        timings["simulate_many"] = timings.get("simulate_many", 0.0) + time.perf_counter() - clock
        # every entry is set: the groups cover every request
        return out  # type: ignore[return-value]


def adaptations(model: mujoco.MjModel) -> tuple[str, ...]:
    """What Warp's copy of ``model`` has changed, and what stands in (:data:`ADAPTED_FLAGS`)."""
    return tuple(why for flag, why in ADAPTED_FLAGS.items()
                 if model.opt.enableflags & int(getattr(mujoco.mjtEnableBit, flag, 0)))


def host_model(model: mujoco.MjModel) -> mujoco.MjModel:
    """A copy of ``model`` MuJoCo Warp accepts: the :data:`ADAPTED_FLAGS` cleared (``model`` itself where
    none is set)."""
    if not adaptations(model):
        return model
    host = copy.deepcopy(model)
    for flag in ADAPTED_FLAGS:
        host.opt.enableflags &= ~int(getattr(mujoco.mjtEnableBit, flag, 0))
    return host


def _put_model(model: mujoco.MjModel) -> object:
    """``mjw.put_model`` of :func:`host_model`, a feature Warp lacks refused as :class:`BackendUnavailable`
    (one line)."""
    init()
    try:
        return mjw.put_model(host_model(model))
    except (NotImplementedError, ValueError) as exc:
        text = str(exc).strip()
        why = text.splitlines()[0] if text else type(exc).__name__
        raise BackendUnavailable(f"backend 'warp' cannot run this model: MuJoCo Warp says {why!r}; "
                                 "fix: remove that feature from the model, or use --backend c") from None


def backend(name: str) -> WarpBackend:
    return WarpBackend(name)

"""The MJX backend: MuJoCo's JAX implementation (``mujoco-mjx``), float32 (``mjx``) or float64 (``mjx-f64``).

How a run is made, and why:

- The model is the compiled ``MjModel`` the harness made (variants and all),
  with the ``energy`` flag cleared — MJX's ``put_model`` refuses it — and
  ``diagexact`` (MJX lacks it: the regulariser then uses MuJoCo's diagonal
  approximation, a softness the budget's softness part measures on MJX's own
  runs; the report lists both, :data:`ADAPTED_FLAGS`), and put
  on the CPU device in the backend's precision (``jax_enable_x64`` on for
  float64, off for float32: every array of the model and the data is then
  float32, as a policy trained on MJX sees it). MJX makes constants when it is
  imported (RK4's tableau) in the precision of that moment, so one process runs
  one precision: the first MJX backend used fixes it, and asking for the other
  one later is refused with the fix (another process: another command, or
  ``-j`` workers).
- The initial state is written by the case's binding into a C ``MjData`` and
  copied over, so both engines start from the same numbers (rounded to float32
  on ``mjx``).
- Each step is MJX's own ``step`` taken apart: ``forward``, read the fields of
  the state just computed, then the integrator (``euler``, ``rungekutta4``,
  ``implicit``) — the same work ``step`` does, in the same order — so every
  recorded field belongs to its state, as in the C recorders (after an RK4 step
  the fields would hold the last stage).
- Batched: the runs of one call that share an integrator and a model structure
  are one ``jax.vmap`` over the fields that differ between their models
  (timestep, solref, masses, …) and over their initial states, stepped by a
  ``jax.lax.scan`` of :data:`CHUNK` steps compiled once per structure; the last
  chunk runs past the horizon by fewer than ``CHUNK`` steps, which are dropped.
  The compiled code is kept on disk (JAX's compilation cache under the user
  cache dir), so a second process skips most of the compile.
- What MJX does not provide is computed by the harness from MJX's state and
  arrays, in float64: the energy (MuJoCo's ``energy``: potential
  −Σ mᵢ g·xiposᵢ + ½ k (q − q_spring)² of every hinge and slide spring, kinetic
  ½ q̇ᵀ M q̇ with M from MJX's own mass matrix), point velocities J·q̇ (J from
  MJX's ``cdof`` and ``subtree_com``, as ``mj_jac``), each equality's
  ``efc_force``/``efc_pos`` from MJX's constraint rows (which MJX orders by
  equality type: connect, weld, joint, tendon).
- Times are k·h in float64, as the C engine's runs record them: MJX carries
  its ``time`` in its own precision (float32 drifts by up to N·ε·t), and no
  case's forces depend on time, so the nominal time of sample k is the one the
  reference is compared at.
- A run whose state stops being finite raises SimulationDiverged at the first
  non-finite sample; MJX raises no warnings (no ``mjWARN_BADQACC``).
- The instantaneous layer's states (:meth:`MjxBackend.forward_many`) are one
  ``jax.jit(jax.vmap(forward))`` over the states, the model shared, from
  ``make_data``'s zero warm start (as the C engine's reset ``MjData``). MJX
  computes the force, torque and accelerometer sensors and ``cfrc_int`` /
  ``cfrc_ext`` itself (``sensor_acc`` calls its ``rne_postconstraint`` for those
  sensors, contacts, connects and welds included) where the model has constraint
  rows: they are read as they are. Without constraint rows MJX's ``forward``
  returns before ``sensor_acc`` (mujoco/mjx/_src/forward.py, mujoco-mjx 3.17:
  ``if d._impl.efc_J.size == 0: return``), leaving those sensors and
  ``cfrc_int`` at zero: they are then handed back as None, and the instantaneous
  layer computes them in float64 from MJX's qacc (no constraint forces to carry).
"""

from __future__ import annotations

import copy
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import jax
import mujoco
import numpy as np

from harness.core.errors import BackendUnavailable, SimulationDiverged
from harness.core.trajectory import Trajectory
from harness.engine.backends import Forward, Request, computes_reactions
from harness.engine.backends.completion import completed_run
from harness.engine.integrators import integrator_name
from harness.engine.points import point_source
from harness.engine.probe import Probe
from harness.engine.readings import fields_of
from harness.engine.recording.assemble import evaluate_readings, point_velocity

__all__ = ["backend", "energy", "host_model"]

CHUNK = 250
"""Steps per compiled scan: a run of N steps is ⌈N / CHUNK⌉ calls of one compiled function."""

INTEGRATORS = {"Euler": "euler", "RK4": "rungekutta4", "implicitfast": "implicit"}
"""MJX's integrators (mujoco/mjx/_src/forward.py ``step``); MuJoCo's ``implicit`` and ``discrete`` it lacks."""

_EQ_ROWS = {int(mujoco.mjtEq.mjEQ_CONNECT): 3, int(mujoco.mjtEq.mjEQ_WELD): 6, int(mujoco.mjtEq.mjEQ_JOINT): 1,
            int(mujoco.mjtEq.mjEQ_TENDON): 1}


def _cache_dir() -> Path:
    root = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return root / "mjharness" / "jax"


_loaded_x64: list[bool] = []  # the precision MJX was imported in, once it is


def _mjx(name: str, x64: bool):
    """MJX's modules (mjx, its forward and support internals), imported in this process's precision."""
    if _loaded_x64 and _loaded_x64[0] != x64:
        other = "mjx-f64" if _loaded_x64[0] else "mjx"
        raise BackendUnavailable(f"backend {name!r} cannot run in a process that already ran {other!r}: JAX's "
                                 "precision is fixed when MJX is imported; fix: run each MJX precision as its own "
                                 "command (or with -j 2 or more, one per worker)")
    if not _loaded_x64:
        jax.config.update("jax_enable_x64", x64)
        _loaded_x64.append(x64)
    from mujoco import mjx  # lazy: after the precision is set (module docstring)
    from mujoco.mjx._src import forward, support  # lazy: as above

    return mjx, forward, support


jax.config.update("jax_platforms", "cpu")  # the CPU device, also where an accelerator exists: results comparable
jax.config.update("jax_compilation_cache_dir", str(_cache_dir()))
jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)


ADAPTED_FLAGS: dict[str, str] = {
    "mjENBL_ENERGY": "energy: MJX refuses the flag; the harness computes MuJoCo's energy from MJX's state",
    "mjENBL_DIAGEXACT": ("diagexact: MJX lacks it; constraint regularisers use MuJoCo's diagonal approximation, "
                         "and the softness part of the budget is measured on MJX's own runs"),
}
"""Enable flags cleared on MJX's copy of a model, each with what stands in for it (shown in the report)."""


def host_model(model: mujoco.MjModel) -> mujoco.MjModel:
    """A copy of ``model`` MJX accepts: the :data:`ADAPTED_FLAGS` cleared."""
    host = copy.deepcopy(model)
    for flag in ADAPTED_FLAGS:
        host.opt.enableflags &= ~int(getattr(mujoco.mjtEnableBit, flag, 0))
    return host


def adaptations(model: mujoco.MjModel) -> tuple[str, ...]:
    """What MJX's copy of ``model`` has changed, and what stands in (:data:`ADAPTED_FLAGS`)."""
    return tuple(why for flag, why in ADAPTED_FLAGS.items()
                 if model.opt.enableflags & int(getattr(mujoco.mjtEnableBit, flag, 0)))


def equality_rows(model: mujoco.MjModel) -> dict[str, slice]:
    """Each equality's rows in MJX's ``efc`` arrays: MJX makes the rows of every connect, then every weld,
    joint and tendon equality, each type in id order (mujoco/mjx/_src/constraint.py ``make_efc_type``)."""
    out, start = {}, 0
    for kind in _EQ_ROWS:
        for i in range(model.neq):
            if int(model.eq_type[i]) == kind:
                out[model.equality(i).name] = slice(start, start + _EQ_ROWS[kind])
                start += _EQ_ROWS[kind]
    return out


class MjxBackend:
    """MJX's JAX implementation on the CPU, float32 or float64."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.x64 = name == "mjx-f64"
        self.precision = "float64" if self.x64 else "float32"
        self.epsilon = float(np.finfo(np.float64 if self.x64 else np.float32).eps)
        self._compiled: dict[tuple, Any] = {}  # jitted functions: a forward, or a run's (chunk, final) pair
        self.mjx, self.forward, self.support = _mjx(name, self.x64)

    def unsupported(self, model: mujoco.MjModel) -> str:
        """Why MJX cannot run ``model`` (one line naming the feature and the fix), or "" where it can."""
        name = integrator_name(model)
        if name not in INTEGRATORS:
            return (f"backend {self.name!r} lacks the {name} integrator (MJX has {', '.join(INTEGRATORS)}); "
                    f"fix: --integrators {','.join(INTEGRATORS)}, or --backend c")
        one_dof = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
        springs = [model.joint(j).name for j in range(model.njnt)
                   if model.jnt_stiffness[j] != 0 and int(model.jnt_type[j]) not in one_dof]
        if springs or np.any(model.tendon_stiffness != 0):
            return (f"backend {self.name!r}: the harness computes MJX's energy for hinge and slide springs only, "
                    f"and this model has springs on {springs or 'a tendon'}; fix: --backend c")
        try:
            self.mjx.put_model(host_model(model))
        except NotImplementedError as exc:
            return (f"backend {self.name!r} cannot run this model: MJX does not implement {exc}; "
                    "fix: --backend c, or a model without it (mujoco doc/mjx.rst, feature parity)")
        return ""

    def adaptations(self, model: mujoco.MjModel) -> tuple[str, ...]:
        return adaptations(model)

    def supports(self, model: mujoco.MjModel) -> None:
        reason = self.unsupported(model)
        if reason:
            raise BackendUnavailable(reason)

    # ------------------------------------------------------------------ runs
    def simulate_many(self, requests: Sequence[Request], probe: Probe) -> list[Trajectory]:
        out: list[Trajectory | None] = [None] * len(requests)
        for indices, puts in self._groups(requests).values():
            records = self._run_group([requests[i] for i in indices], puts, probe)
            for i, rec in zip(indices, records, strict=True):
                out[i] = run = _trajectory(requests[i], probe, rec)
                if not self.x64 and probe.constraints:  # float32: the stopped solves, completed (completion.py)
                    rows = equality_rows(requests[i].model)
                    out[i] = completed_run(requests[i].model, probe, run, qpos=rec["qpos"], qvel=rec["qvel"],
                                           fields={**rec, "mass": rec["qM"]},
                                           equality={c: rec["efc_force"][:, rows[c]] for c in probe.constraints},
                                           epsilon=self.epsilon)
        # every entry is set: the groups cover every request
        return out  # type: ignore[return-value]

    def forward_many(self, model: mujoco.MjModel, probe: Probe, qpos: np.ndarray, qvel: np.ndarray) -> Forward:
        """MJX's ``forward`` at every state as one ``jit(vmap)`` call (compiled once per model structure),
        the arrays copied to float64; the equalities' rows found by :func:`equality_rows`."""
        self.supports(model)
        put = self.mjx.put_model(host_model(model))
        reactions = computes_reactions(model)
        wanted = ("qacc", "qfrc_bias", "qfrc_passive", "qfrc_constraint", "qM", "efc_force",
                  *(("sensordata",) if model.nsensordata else ()), *(("cfrc_int", "cfrc_ext") if reactions else ()),
                  *(("qfrc_actuator",) if model.nu else ()))
        leaves, treedef = jax.tree_util.tree_flatten(put)
        key = ("forward", treedef, tuple(leaf.tobytes() for leaf in leaves if isinstance(leaf, np.ndarray)), wanted)
        data = self.mjx.make_data(put)
        if getattr(data, "_impl", data).efc_J.size == 0:  # MJX's forward skips sensor_acc (module docstring)
            wanted = tuple(f for f in wanted if f not in ("sensordata", "cfrc_int", "cfrc_ext"))
            key = (*key[:3], wanted)
        if key not in self._compiled:
            forward, support = self.forward.forward, self.support

            def one(m, d, qp, qv):
                d = forward(m, d.replace(qpos=qp, qvel=qv))
                return {f: _field(support, m, d, f) for f in wanted}

            self._compiled[key] = jax.jit(jax.vmap(one, in_axes=(None, None, 0, 0)))
        got = jax.device_get(self._compiled[key](put, data, jax.numpy.asarray(qpos, dtype=data.qpos.dtype),
                                                 jax.numpy.asarray(qvel, dtype=data.qvel.dtype)))
        out = {f: np.asarray(v, dtype=np.float64) for f, v in got.items()}
        rows = equality_rows(model)
        return Forward(qacc=out["qacc"], qfrc_bias=out["qfrc_bias"], qfrc_passive=out["qfrc_passive"],
                       qfrc_constraint=out["qfrc_constraint"], mass=out["qM"],
                       equality={c: out["efc_force"][:, rows[c]] for c in probe.constraints},
                       sensordata=out.get("sensordata"), cfrc_int=out.get("cfrc_int"), cfrc_ext=out.get("cfrc_ext"),
                       qfrc_actuator=out.get("qfrc_actuator"))

    def _groups(self, requests: Sequence[Request]) -> dict[tuple, tuple[list[int], list]]:
        """Requests that can be one vmap: the same integrator, model structure and static fields."""
        groups: dict[tuple, tuple[list[int], list]] = {}
        for i, r in enumerate(requests):
            self.supports(r.model)
            put = self.mjx.put_model(host_model(r.model))
            leaves, treedef = jax.tree_util.tree_flatten(put)
            static = tuple(leaf.tobytes() for leaf in leaves if isinstance(leaf, np.ndarray))
            key = (integrator_name(r.model), treedef, static)
            groups.setdefault(key, ([], []))
            groups[key][0].append(i)
            groups[key][1].append(put)
        return groups

    def _run_group(self, requests: Sequence[Request], puts: Sequence, probe: Probe) -> list[dict[str, np.ndarray]]:
        """One batched run of requests sharing a structure: every recorded field, (N + 1, ...) per request."""
        model = requests[0].model
        wanted = _wanted_fields(model, probe)
        batched, axes = _stack_models(puts)
        datas = [self._initial_data(r, put, probe) for r, put in zip(requests, puts, strict=True)]
        data = jax.tree_util.tree_map(lambda *x: jax.numpy.stack(x), *datas)
        key = (integrator_name(model), jax.tree_util.tree_structure(batched), str(axes), wanted)
        chunk, final = self._functions(key, integrator_name(model), axes, wanted)
        steps = max(r.steps for r in requests)
        pieces = []
        for _ in range(-(-steps // CHUNK)):
            data, rec = chunk(batched, data)
            pieces.append(jax.device_get(rec))
        pieces.append(jax.tree_util.tree_map(lambda x: x[:, None], jax.device_get(final(batched, data))))
        out = []
        for b, r in enumerate(requests):
            out.append({f: np.concatenate([np.asarray(p[f][b], dtype=np.float64) for p in pieces])[:r.steps + 1]
                        for f in wanted})
        return out

    def _initial_data(self, request: Request, put, probe: Probe):
        return _initial(self.mjx, request, put, probe)

    def _functions(self, key: tuple, integrator: str, axes, wanted: tuple[str, ...]):
        """The compiled chunk (CHUNK steps, batched) and the final read, for one structure."""
        if key not in self._compiled:
            integrate = getattr(self.forward, INTEGRATORS[integrator])
            forward, support = self.forward.forward, self.support

            def read(m, d):
                return {f: _field(support, m, d, f) for f in wanted}

            def one_chunk(m, d):
                def body(d, _):
                    start = d
                    d = forward(m, d)
                    rec = read(m, d)
                    # the carry keeps its types: under x64, MJX's tendon wrapping returns int64 indices
                    # for fields make_data made int32 (atwood's, spring's drawing tendons)
                    return jax.tree_util.tree_map(lambda new, old: new.astype(old.dtype), integrate(m, d), start), rec
                return jax.lax.scan(body, d, None, length=CHUNK)

            def one_final(m, d):
                return read(m, forward(m, d))

            self._compiled[key] = (jax.jit(jax.vmap(one_chunk, in_axes=(axes, 0))),
                                   jax.jit(jax.vmap(one_final, in_axes=(axes, 0))))
        return self._compiled[key]


def _wanted_fields(model: mujoco.MjModel, probe: Probe) -> tuple[str, ...]:
    positions = [point_source(model, p).field for p in probe.points]
    return tuple(dict.fromkeys(["qpos", "qvel", "qfrc_constraint", "xipos", "qM", *positions,
                                *(("subtree_com", "cdof") if probe.points else ()),
                                *(("efc_force", "efc_pos", "qacc", "qfrc_bias", "qfrc_passive")
                                  if probe.constraints else ()),
                                *fields_of(probe.readings())]))


def _field(support, m, d, name: str):
    if name == "qM":  # the dense mass matrix, for the kinetic energy
        return support.full_m(m, d)
    # the constraint rows live in the implementation's data (``Data._impl``, since MJX split its JAX and Warp
    # implementations); older releases (mujoco-mjx 3.3.0) keep every field on ``Data`` itself
    impl = getattr(d, "_impl", None)
    if impl is not None and (name.startswith("efc_") or name in ("cacc", "cfrc_int", "cfrc_ext")) \
            and hasattr(impl, name):  # cfrc_* on Data itself is deprecated since the split
        return getattr(impl, name)
    if hasattr(d, name):
        return getattr(d, name)
    if impl is not None and hasattr(impl, name):
        return getattr(impl, name)
    raise BackendUnavailable(f"backend 'mjx' has no field {name!r} that a reading of this case needs; "
                             "fix: --backend c")


def _stack_models(puts: Sequence):
    """The models as one pytree: leaves that differ stacked on a leading axis (in_axes 0), the rest shared
    (in_axes None). Static (numpy) leaves are equal within a group (:meth:`MjxBackend._groups`)."""
    flat = [jax.tree_util.tree_flatten(p) for p in puts]
    treedef = flat[0][1]
    leaves, axes = [], []
    for column in zip(*(f[0] for f in flat), strict=True):
        first = column[0]
        same = isinstance(first, np.ndarray) or all(
            np.shape(c) == np.shape(first) and np.array_equal(np.asarray(c), np.asarray(first)) for c in column[1:])
        leaves.append(first if same else jax.numpy.stack(column))
        axes.append(None if same else 0)
    return jax.tree_util.tree_unflatten(treedef, leaves), jax.tree_util.tree_unflatten(treedef, axes)


def _initial(mjx, request: Request, put, probe: Probe):
    """MJX data at the request's initial state, written by the case's binding into a C MjData first."""
    host = mujoco.MjData(request.model)
    probe.binding.set_state(request.model, host, request.q0, request.qd0)
    data = mjx.make_data(put)
    return data.replace(qpos=jax.numpy.asarray(host.qpos, dtype=data.qpos.dtype),
                        qvel=jax.numpy.asarray(host.qvel, dtype=data.qvel.dtype))


def energy(model: mujoco.MjModel, rec: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(potential, kinetic) at every sample, as MuJoCo's ``energy`` defines them (engine_core_smooth.c
    ``mj_energyPos``/``mj_energyVel``): gravity on every body's centre of mass, hinge and slide springs,
    ½ q̇ᵀ M q̇. Computed in float64 from the backend's state and mass matrix."""
    g = np.asarray(model.opt.gravity, dtype=float)
    potential = -np.einsum("b,nbk,k->n", np.asarray(model.body_mass, dtype=float), rec["xipos"], g)
    if model.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_GRAVITY):
        potential = np.zeros(len(rec["qpos"]))
    for j in range(model.njnt):
        k = float(model.jnt_stiffness[j])
        if k:
            adr = int(model.jnt_qposadr[j])
            stretch = rec["qpos"][:, adr] - float(model.qpos_spring[adr])
            potential = potential + 0.5 * k * stretch * stretch
    qvel = rec["qvel"]
    kinetic = 0.5 * np.einsum("ni,nij,nj->n", qvel, rec["qM"], qvel)
    return potential, kinetic


def _trajectory(request: Request, probe: Probe, rec: dict[str, np.ndarray]) -> Trajectory:
    model = request.model
    finite = np.isfinite(rec["qpos"]).all(axis=1) & np.isfinite(rec["qvel"]).all(axis=1)
    t = np.arange(request.steps + 1) * float(model.opt.timestep)  # k h, as the C engine's runs
    if not finite.all():
        raise SimulationDiverged("non-finite state (MJX)", float(t[int(np.argmin(finite))]))
    positions, velocities = {}, {}
    for p in probe.points:
        source = point_source(model, p)
        positions[p] = rec[source.field][:, source.index].copy()
        velocities[p] = point_velocity(model, rec, rec["qvel"], positions[p], source.body)
    rows = equality_rows(model)
    lam, viol = {}, {}
    for c in probe.constraints:
        block = rows[c]
        sign = probe.sign(c)  # a tendon whose rows are −1 × the analytic constraint's (Probe.signs)
        force, pos = sign * rec["efc_force"][:, block], sign * rec["efc_pos"][:, block]
        lam[c], viol[c] = (force[:, 0], pos[:, 0]) if force.shape[1] == 1 else (force, pos)
    potential, kinetic = energy(model, rec)
    fields = {f: v for f, v in rec.items() if f not in ("qpos", "qvel")}
    readings = evaluate_readings(model, probe, t, rec["qpos"], rec["qvel"], fields)
    dof = probe.binding.dof_matrix(model)
    return Trajectory(
        t=t, positions=positions, velocities=velocities,
        multipliers=lam | {name: readings[f"forces.{name}"] for name in probe.forces},
        generalized_force=None if dof is None else rec["qfrc_constraint"] @ dof,
        invariants={"energy": potential + kinetic}
        | {name: readings[f"invariants.{name}"] for name in probe.invariants},
        violations=viol, source=f"mjx:{integrator_name(model)}",
        series={name: readings[f"series.{name}"] for name in probe.series},
    )


def backend(name: str) -> MjxBackend:
    return MjxBackend(name)

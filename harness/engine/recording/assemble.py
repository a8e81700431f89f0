"""From recorded fields to a Trajectory: the points, their velocities, energy, the equalities and the readings.

The batch recorder records, at every sample, the integration state and the fixed-size derived fields
:func:`recorded_fields` names; the rest is numpy over the whole run, reproducing the loop's arithmetic
so that every recorder gives the same numbers bit for bit. A point's position is ``site_xpos`` for a
site and ``xipos`` for a body (:mod:`harness.engine.points`); its velocity is J·qvel with J assembled
from ``cdof`` and ``subtree_com`` at that position as ``mj_jac`` does (:func:`point_velocity`); a
recoverable joint equality comes from ``qfrc_constraint`` and ``qpos``
(:mod:`harness.engine.recording.equalities`). The native recorder makes the positions, the velocities
and the readings' momenta itself as it steps, with the same operations, and records only the fields
the rest needs (:attr:`Plan.native_fields`). The case's readings
(``Probe.invariants/forces/series``, :class:`harness.engine.readings.Reading`) name the fixed-size
fields they need; those are recorded with the rest and the readings evaluated once over the whole run
(:func:`evaluate_readings`), by every recorder alike.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import mujoco
import numpy as np

from harness.core.trajectory import Trajectory
from harness.engine.integrators import integrator_name
from harness.engine.points import PointSource, point_jacobian, point_source
from harness.engine.probe import Probe
from harness.engine.readings import Reading, fields_of
from harness.engine.readings.momentum import MOMENTUM_FIELDS, about_key
from harness.engine.recording.equalities import joint_equalities, recovered
from harness.engine.recording.scratch import SPARE, keep

__all__ = ["Plan", "Run", "evaluate_readings", "plan", "point_state", "point_velocity", "recorded_fields",
           "source_velocity", "trajectory"]

# Derived fields the recorders in C record at every state (all fixed-size), besides the readings' own:
# always (energy, generalized constraint force), for points (position: site_xpos or xipos as the points
# are sites or bodies; and velocity as mj_jac assembles it) and for joint equalities recovered from
# qfrc_constraint (the row count, to know every row is theirs).
# Each is cheap beside a step (docs/findings/speed.md); a non-finite qacc is MuJoCo's own warning (mj_checkAcc).
ALWAYS_FIELDS: tuple[str, ...] = ("qfrc_constraint", "energy")
POINT_FIELDS: tuple[str, ...] = ("subtree_com", "cdof")  # with each point's own position field
EQUALITY_FIELDS: tuple[str, ...] = ("nefc",)


@dataclass(frozen=True)
class Plan:
    """What a run of a probe on a model records, worked out once per model and probe (the names it looks
    up and the model's tree do not change): each point's source and the dofs that move it (increasing),
    the derived fields recorded at every state (:func:`recorded_fields`) and the subtree angular momenta
    the readings project (:attr:`harness.engine.readings.Reading.about`). The native recorder makes the points'
    positions and velocities and those momenta itself as it steps, so it records only ``native_fields``: the
    others, less the fields only those are made from."""

    sources: tuple[PointSource, ...]
    chains: tuple[tuple[int, ...], ...]
    fields: tuple[str, ...]
    momenta: tuple[tuple[str, str], ...]  # the subtree momenta the readings project: (body, site), each once
    native_fields: tuple[str, ...]


_plans: dict[tuple[int, int], tuple[mujoco.MjModel, Probe, Plan]] = {}


def plan(model: mujoco.MjModel, probe: Probe) -> Plan:
    """The :class:`Plan` of ``probe`` on ``model``, kept for the next runs of the same two (a study or a
    convergence ladder records one model many times; a run asks for it at every stage)."""
    kept = _plans.get((id(model), id(probe)))
    if kept is not None and kept[0] is model and kept[1] is probe:
        return kept[2]
    sources = tuple(point_source(model, p) for p in probe.points)
    positions = dict.fromkeys(s.field for s in sources)
    wanted = [*ALWAYS_FIELDS, *positions, *(POINT_FIELDS if probe.points else ())]
    equalities = EQUALITY_FIELDS if joint_equalities(model, probe.constraints) else ()
    readings = probe.readings()
    # a reading of a momentum the recorder hands it reads the momentum's own fields only through it
    besides = {k: Reading(fields=tuple(f for f in r.fields if f not in MOMENTUM_FIELDS), evaluate=r.evaluate,
                          description=r.description) if r.about is not None else r for k, r in readings.items()}
    made = Plan(sources=sources, chains=tuple(tuple(sorted(velocity_chain(model, s.body))) for s in sources),
                fields=tuple(dict.fromkeys((*wanted, *equalities, *fields_of(readings)))),
                momenta=tuple(dict.fromkeys(r.about for r in readings.values() if r.about is not None)),
                native_fields=tuple(dict.fromkeys((*ALWAYS_FIELDS, *equalities, *fields_of(besides)))))
    # model and probe held: their ids are not reused while the entry is kept
    keep(_plans, (id(model), id(probe)), (model, probe, made), 2 * SPARE)
    return made


def recorded_fields(model: mujoco.MjModel, probe: Probe) -> tuple[str, ...]:
    """The derived fields the recorders in C record at every state for ``probe`` on ``model``."""
    return plan(model, probe).fields


def point_state(model: mujoco.MjModel, data: mujoco.MjData, point: str) -> tuple[np.ndarray, np.ndarray]:
    """World position and linear velocity of a named point: a site, or a body's centre of mass
    (:func:`harness.engine.points.point_source`); the velocity is :func:`source_velocity`'s."""
    source = point_source(model, point)
    return source.position(data).copy(), source_velocity(model, data, source)


def source_velocity(model: mujoco.MjModel, data: mujoco.MjData, source: PointSource) -> np.ndarray:
    """The linear velocity of the point ``source`` after ``mj_forward``.

    J·qvel with J from ``mj_jac`` at the point on its body, summed column by column
    in dof order (Σᵢ Jᵢ q̇ᵢ from 0, a multiply then an add per term, no fused multiply-add), so that the
    recorders' vectorized sum over a whole run gives the same numbers bit for bit. In Python floats (IEEE
    doubles, each operation rounded as numpy's): a few dozen of them cost less than numpy's calls on 3-vectors."""
    jx, jy, jz = point_jacobian(model, data, source).tolist()
    x = y = z = 0.0
    for i, q in enumerate(data.qvel.tolist()):
        x, y, z = x + jx[i] * q, y + jy[i] * q, z + jz[i] * q
    return np.array([x, y, z])


def velocity_chain(model: mujoco.MjModel, body: int) -> list[int]:
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


def point_velocity(model: mujoco.MjModel, fields: Mapping[str, np.ndarray], qvel: np.ndarray,
                   point: np.ndarray, body: int) -> np.ndarray:
    """J·qvel at ``point`` (N, 3: the point's world position at every sample) moving with ``body``,
    J's columns assembled as mj_jac does (cdof_lin + cdof_ang × (point − subtree_com[root])) and
    summed in dof order as point_state does (the dofs outside the chain add exact zeros there), so the
    result is point_state's, bit for bit."""
    rows = np.ascontiguousarray  # samples contiguous per component: fast elementwise operations
    o0, o1, o2 = rows((point - fields["subtree_com"][:, model.body_rootid[body]]).T)
    velocity = np.zeros((3, len(qvel)))
    for i in sorted(velocity_chain(model, body)):
        a0, a1, a2, l0, l1, l2 = rows(fields["cdof"][:, i].T)
        q = rows(qvel[:, i])
        velocity[0] = velocity[0] + (l0 + (a1 * o2 - a2 * o1)) * q
        velocity[1] = velocity[1] + (l1 + (a2 * o0 - a0 * o2)) * q
        velocity[2] = velocity[2] + (l2 + (a0 * o1 - a1 * o0)) * q
    return rows(velocity.T)


@dataclass
class Run:
    """A run in arrays: integration states and derived fields at every sample, plus readings."""

    states: np.ndarray                      # (N, nstate), mjSTATE_INTEGRATION rows (recorders in C only)
    t: np.ndarray                           # (N,)
    positions: dict[str, np.ndarray]        # (N, 3) per point
    velocities: dict[str, np.ndarray]       # (N, 3) per point
    lam: dict[str, np.ndarray]              # efc_force per equality, (N,) or (N, k) for a k-row block
    viol: dict[str, np.ndarray]             # efc_pos per equality, likewise
    energy: np.ndarray                      # (N,)
    qfrc: np.ndarray                        # (N, nv) qfrc_constraint
    readings: dict[str, np.ndarray]         # Probe.readings() keys, (N,)
    fields: dict[str, np.ndarray] = field(default_factory=dict)  # recorded derived fields (recorders in C)

    @classmethod
    def from_record(cls, model: mujoco.MjModel, probe: Probe, states: np.ndarray, fields: dict[str, np.ndarray],
                    velocities: dict[str, np.ndarray] | None = None,
                    positions: dict[str, np.ndarray] | None = None) -> Run:
        """The run of recorded ``states`` and ``fields`` (:func:`recorded_fields`), its points' velocities
        ``velocities`` and positions ``positions`` where given (else assembled from the fields) and the
        equalities recoverable from the fields; readings are left to :func:`evaluate_readings`."""
        nv = model.nv
        qvel = states[:, 1 + model.nq:1 + model.nq + nv]
        positions, velocities = dict(positions or {}), dict(velocities or {})
        for p, source in zip(probe.points, plan(model, probe).sources, strict=True):
            if p not in positions:
                positions[p] = fields[source.field][:, source.index].copy()
            if p not in velocities:
                velocities[p] = point_velocity(model, fields, qvel, positions[p], source.body)
        energy = fields["energy"][:, 0] + fields["energy"][:, 1]
        qfrc = fields["qfrc_constraint"]  # the recorder's scratch: what a Trajectory keeps is made from it, never it
        lam, viol = recovered(model, probe, states, qfrc, fields)
        return cls(states=states, t=states[:, 0].copy(), positions=positions, velocities=velocities, lam=lam,
                   viol=viol, energy=energy, qfrc=qfrc, readings={}, fields=fields)


def evaluate_readings(model: mujoco.MjModel, probe: Probe, states_t: np.ndarray, qpos: np.ndarray,
                      qvel: np.ndarray, fields: Mapping[str, np.ndarray],
                      momenta: Mapping[tuple[str, str], np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """Every reading of ``probe`` over the run, from the recorded state and fields; ``momenta``: subtree angular
    momenta (3, N) by (body, site) the recorder computed (:func:`harness.engine.readings.momentum.about_key`)."""
    recorded = {"time": states_t, "qpos": qpos, "qvel": qvel, **fields,
                **{about_key(*pair): total for pair, total in (momenta or {}).items()}}
    out = {}
    for key, reading in probe.readings().items():
        values = np.array(reading.evaluate(model, recorded), dtype=float)  # a copy: recorded is scratch
        if values.shape != states_t.shape:
            raise ValueError(f"reading {key!r} returned shape {values.shape}; expected {states_t.shape}")
        out[key] = values
    return out


def trajectory(model: mujoco.MjModel, probe: Probe, run: Run) -> Trajectory:
    """The Trajectory of ``run``: samples at t = k·h (the time the state after k steps stands for)."""
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

"""The stepping recorder: a Python loop that runs on any MuJoCo, and the others' reference.

Each step is ``mj_forward`` (the derived fields of the current state) between the checks ``mj_step``
makes around it (``mj_checkPos/Vel/Acc``: a huge or non-finite value is a MuJoCo warning), the record,
then the integrator's own function: the same work ``mj_step`` does, in the same order, bit-identical to
it. It costs a Python round trip per sample, more than MuJoCo's own step on a small model
(docs/findings/speed.md), so it records where
neither recorder in C can (MuJoCo 3.3 without a C compiler) and wherever their check against a fresh
``mj_forward`` fails.
"""

from __future__ import annotations

import mujoco
import numpy as np

from harness.engine.integrators import STEP_FUNCTIONS, integrator_name
from harness.engine.probe import Probe
from harness.engine.readings import fields_of
from harness.engine.recording.assemble import Run, evaluate_readings, point_state
from harness.engine.recording.equalities import block, rows
from harness.engine.recording.verify import check_warnings, checked_forward

__all__ = ["record"]


def record(model: mujoco.MjModel, probe: Probe, data: mujoco.MjData, steps: int) -> Run:
    """mj_forward, record, integrator function: one Python round trip per step."""
    step = STEP_FUNCTIONS[integrator_name(model)]
    n = steps + 1
    t = np.zeros(n)
    pos = {p: np.zeros((n, 3)) for p in probe.points}
    vel = {p: np.zeros((n, 3)) for p in probe.points}
    lam = {c: rows(model, c, n) for c in probe.constraints}
    viol = {c: rows(model, c, n) for c in probe.constraints}
    energy = np.zeros(n)
    extra = fields_of(probe.readings())
    recorded = {f: np.zeros((n, *np.shape(getattr(data, f)))) for f in extra}
    qpos, qvel = np.zeros((n, model.nq)), np.zeros((n, model.nv))
    qfrc = np.zeros((n, model.nv))
    for k in range(n):
        t[k] = data.time  # before the checks: a bad value makes MuJoCo warn and reset the data
        checked_forward(model, data)
        check_warnings(data.warning.number, t[k])
        for p in probe.points:
            pos[p][k], vel[p][k] = point_state(model, data, p)
        for c in probe.constraints:
            lam[c][k], viol[c][k] = block(model, data, c, probe.sign(c))
        energy[k] = data.energy[0] + data.energy[1]
        qpos[k], qvel[k] = data.qpos, data.qvel
        for f in extra:
            recorded[f][k] = getattr(data, f)
        qfrc[k] = data.qfrc_constraint
        if k < steps:
            step(model, data)
    values = evaluate_readings(model, probe, t, qpos, qvel, recorded)
    return Run(states=np.zeros((0, 0)), t=t, positions=pos, velocities=vel, lam=lam, viol=viol, energy=energy,
               qfrc=qfrc, readings=values)

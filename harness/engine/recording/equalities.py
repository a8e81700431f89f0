"""The equalities' efc_force and efc_pos at every sample, for the recorders in C.

Why a module of their own: they lie in MuJoCo's arena, whose size changes from step to step, so no
fixed-size field holds them and ``mujoco.batch`` can neither record nor bind them. They are had three
ways, each bit for bit the loop's reading after ``mj_forward``:

- recovered from recorded fields (:class:`JointEquality`): a one-row joint equality's force is
  ``qfrc_constraint`` at its first joint's dof, and its violation is recomputed from ``qpos``;
- copied from fixed rows (:func:`fixed_rows`): where every equality has a fixed number of rows and is
  active at every state, each one's rows are a fixed slice of ``efc_*`` (the native recorder copies them
  as it steps);
- read after ``mj_forward`` at every recorded state (:func:`read_equalities`: a forward per state, about a
  step; the batch recorder does it on a second thread beside the rollout).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from harness.engine.bindings import ONE_DOF
from harness.engine.constraints import EQUALITY_ROWS, equality_block, equality_size
from harness.engine.probe import Probe
from harness.engine.recording.scratch import STATE

__all__ = ["block", "equality_layout", "fixed_rows", "joint_equalities", "read_equalities", "recovered", "rows",
           "signed"]


def rows(model: mujoco.MjModel, name: str, n: int) -> np.ndarray:
    """Zeros for ``n`` samples of equality ``name``: (n,) for one row, (n, k) for a block of k rows."""
    size = equality_size(model, name)
    return np.zeros(n) if size == 1 else np.zeros((n, size))


def block(model: mujoco.MjModel, data: mujoco.MjData, name: str, sign: float = 1.0
          ) -> tuple[np.ndarray | float, np.ndarray | float]:
    """(efc_force, efc_pos) × ``sign`` (the probe's, :attr:`Probe.signs`) of equality ``name`` at this state:
    floats for one row, (k,) for a block."""
    force, pos = equality_block(model, data, name)
    if sign != 1.0:
        force, pos = sign * force, sign * pos
    return (float(force[0]), float(pos[0])) if force.size == 1 else (force, pos)


def signed(sign: float, lam: np.ndarray, viol: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(λ, violation) of an equality × the probe's ``sign`` elementwise, as :func:`block` multiplies each
    sample (the arrays themselves where the sign is 1)."""
    return (lam, viol) if sign == 1.0 else (sign * lam, sign * viol)


def state_offset(model: mujoco.MjModel, component: mujoco.mjtState) -> int:
    """Where ``component`` starts in an mjSTATE_INTEGRATION row (components lie in bit order)."""
    return mujoco.mj_stateSize(model, int(STATE) & (int(component) - 1))


@dataclass(frozen=True)
class JointEquality:
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


def joint_equalities(model: mujoco.MjModel, names: Sequence[str]) -> dict[str, JointEquality]:
    """The equalities of ``names`` recoverable from recorded fields (see :class:`JointEquality`),
    provided every efc row at every sample is a joint-equality row (checked by :func:`recovered`)."""
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
        out[name] = JointEquality(
            dof=dof, qpos1=adr1, ref1=float(model.qpos0[adr1]), qpos2=adr2,
            ref2=float(model.qpos0[adr2]) if adr2 is not None else 0.0,
            coef=tuple(float(c) for c in model.eq_data[eq, :5]))
    return out


def recovered(model: mujoco.MjModel, probe: Probe, states: np.ndarray, qfrc: np.ndarray,
              fields: Mapping[str, np.ndarray]) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """(λ, violation) of the probe's equalities recoverable from the recorded ``qfrc_constraint``, ``qpos`` and
    ``nefc`` (signed), where every efc row at every sample is an equality's; else two empty dicts."""
    lam, viol = {}, {}
    recoverable = joint_equalities(model, probe.constraints)
    if recoverable:
        qpos = states[:, 1:1 + model.nq]
        start = state_offset(model, mujoco.mjtState.mjSTATE_EQ_ACTIVE)
        active = states[:, start:start + model.neq]
        if np.all(active == 1) and np.all(fields["nefc"] == model.neq):  # every row is an equality's
            for c, eq in recoverable.items():
                lam[c] = qfrc[:, eq.dof] * probe.sign(c)  # × 1.0 is exact: bit for bit the loop's
                viol[c] = eq.violation(qpos) * probe.sign(c)
    return lam, viol


def read_equalities(model: mujoco.MjModel, data: mujoco.MjData, states: np.ndarray,
                    lam: Mapping[str, np.ndarray], viol: Mapping[str, np.ndarray]) -> None:
    """efc_force and efc_pos of the equalities ``lam`` names (unsigned) after mj_forward at every row of
    ``states``, into ``lam`` and ``viol`` (arrays of len(states) rows). Sensors are skipped: nothing
    of the constraint solver reads them (the efc rows are bit for bit mj_forward's, checked with the
    rest against a fresh mj_forward)."""
    fixed = fixed_rows(model, states)
    if fixed is None:
        for k, state in enumerate(states):
            mujoco.mj_setState(model, data, state, STATE)
            mujoco.mj_forward(model, data)
            for c in lam:
                lam[c][k], viol[c][k] = block(model, data, c)
        return
    # the same numbers with no search per sample: each equality's rows are a fixed slice of efc_*
    slices = [(lam[c], viol[c], fixed[c]) for c in lam]
    none = mujoco.mjtStage.mjSTAGE_NONE
    for k, state in enumerate(states):
        mujoco.mj_setState(model, data, state, STATE)
        mujoco.mj_forwardSkip(model, data, none, 1)
        force, pos = data.efc_force, data.efc_pos  # views sized by this forward's nefc
        for values, errors, where in slices:
            values[k], errors[k] = force[where], pos[where]


def fixed_rows(model: mujoco.MjModel, states: np.ndarray) -> dict[str, slice | int] | None:
    """Each equality's rows in efc_* where they are the same at every state of ``states``, else None.

    MuJoCo makes the equalities' rows first, in equality order, one block per active equality
    (engine_core_constraint.c); where every equality is of a type with a fixed number of rows
    (:data:`EQUALITY_ROWS`) and active at every state, equality k's rows follow those of 0..k−1. A
    one-row block is an index (a float per sample), a longer one a slice. Checked bit for bit against
    the rows found by search (:func:`equality_block`) at one sample, as every run in C is."""
    found = equality_layout(model)
    start = state_offset(model, mujoco.mjtState.mjSTATE_EQ_ACTIVE)
    if found is None or not np.all(states[:, start:start + model.neq] == 1):
        return None
    return found[0]


def equality_layout(model: mujoco.MjModel) -> tuple[dict[str, slice | int], int] | None:
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

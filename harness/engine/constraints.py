"""A constraint's rows in MuJoCo's constraint arrays (``efc_*``), read as one block.

An equality constraint contributes several rows to ``efc_force``/``efc_pos``
when it constrains several directions: a ``joint`` or ``tendon`` equality one,
a ``connect`` three (the world x, y, z components of anchor1 − anchor2, in
that order), a ``weld`` six (three of position, three of orientation). The
rows of equality k are those with ``efc_type == mjCNSTR_EQUALITY`` and
``efc_id == k``, consecutive and in that order; their forces satisfy
``qfrc_constraint = Jᵀ efc_force`` over all rows (engine_core_constraint.c).
"""

from __future__ import annotations

import mujoco
import numpy as np

from harness.core.errors import ModelMismatch

__all__ = ["EQUALITY_ROWS", "equality_block", "equality_force", "equality_jacobian", "equality_rows", "equality_size"]

# rows MuJoCo makes for one equality of each type (mjEQ_FLEX and others: as many as MuJoCo makes)
EQUALITY_ROWS: dict[int, int] = {
    int(mujoco.mjtEq.mjEQ_CONNECT): 3,
    int(mujoco.mjtEq.mjEQ_WELD): 6,
    int(mujoco.mjtEq.mjEQ_JOINT): 1,
    int(mujoco.mjtEq.mjEQ_TENDON): 1,
}


def equality_size(model: mujoco.MjModel, name: str) -> int:
    """How many efc rows equality ``name`` makes when it is active (ModelMismatch for a type whose
    count is not fixed)."""
    kind = int(model.eq_type[model.equality(name).id])
    if kind not in EQUALITY_ROWS:
        raise ModelMismatch(f"equality {name!r} is of type {mujoco.mjtEq(kind).name}; accepted: "
                            f"{', '.join(mujoco.mjtEq(k).name for k in EQUALITY_ROWS)}")
    return EQUALITY_ROWS[kind]


def equality_rows(model: mujoco.MjModel, data: mujoco.MjData, name: str) -> np.ndarray:
    """Indices of the efc rows of equality ``name`` (efc_type EQUALITY, efc_id its id), in order."""
    eq_id = model.equality(name).id
    return np.flatnonzero((data.efc_type[: data.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY)
                          & (data.efc_id[: data.nefc] == eq_id))


def equality_block(model: mujoco.MjModel, data: mujoco.MjData, name: str) -> tuple[np.ndarray, np.ndarray]:
    """(efc_force, efc_pos) of equality ``name``'s rows, each of shape (k,), after ``mj_forward``;
    ModelMismatch unless the equality is active with the rows its type makes."""
    rows = equality_rows(model, data, name)
    expected = equality_size(model, name)
    if rows.size != expected:
        raise ModelMismatch(f"equality {name!r} has {rows.size} efc rows; its type makes {expected} "
                            "(an inactive equality has none)")
    return data.efc_force[rows].copy(), data.efc_pos[rows].copy()


def equality_jacobian(model: mujoco.MjModel, data: mujoco.MjData, name: str) -> np.ndarray:
    """The rows of ``efc_J`` of equality ``name``, dense (k, nv), after ``mj_forward``."""
    rows = equality_rows(model, data, name)
    if not mujoco.mj_isSparse(model):
        return data.efc_J.reshape(-1, model.nv)[rows].copy()
    dense = np.zeros((data.nefc, model.nv))
    mujoco.mju_sparse2dense(dense, data.efc_J, data.efc_J_rownnz, data.efc_J_rowadr, data.efc_J_colind)
    return dense[rows]


def equality_force(model: mujoco.MjModel, data: mujoco.MjData, name: str) -> tuple[float, float]:
    """(efc_force, efc_pos) of a one-row equality (a joint or tendon equality)."""
    force, pos = equality_block(model, data, name)
    if force.size != 1:
        raise ModelMismatch(f"equality {name!r} has {force.size} efc rows; one is expected here "
                            "(read a block with equality_block)")
    return float(force[0]), float(pos[0])

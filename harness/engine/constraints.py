"""A constraint's rows in MuJoCo's constraint arrays (``efc_*``), read as one block."""

from __future__ import annotations

import mujoco
import numpy as np

from harness.core.errors import ModelMismatch


def equality_rows(model: mujoco.MjModel, data: mujoco.MjData, name: str) -> np.ndarray:
    """Indices of the efc rows of equality ``name`` (efc_type EQUALITY, efc_id its id)."""
    eq_id = model.equality(name).id
    return np.flatnonzero((data.efc_type[: data.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY)
                          & (data.efc_id[: data.nefc] == eq_id))


def equality_force(model: mujoco.MjModel, data: mujoco.MjData, name: str) -> tuple[float, float]:
    """(efc_force, efc_pos) of a one-row equality constraint."""
    rows = equality_rows(model, data, name)
    if rows.size != 1:
        raise ModelMismatch(f"equality {name!r} has {rows.size} efc rows; one is expected")
    return float(data.efc_force[rows[0]]), float(data.efc_pos[rows[0]])

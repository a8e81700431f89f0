"""Differences between MuJoCo versions (3.3 is the oldest supported), in one place."""

from __future__ import annotations

import mujoco
import numpy as np


def full_mass_matrix(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """Dense joint-space inertia matrix after ``mj_forward``.

    MuJoCo 3.10 changed ``mj_fullM(m, dst, qM)`` to ``mj_fullM(m, d, dst)`` and
    later removed ``mjData.qM``; the old signature is the fallback.
    """
    dense = np.zeros((model.nv, model.nv))
    if hasattr(data, "qM"):
        mujoco.mj_fullM(model, dense, data.qM)
    else:
        mujoco.mj_fullM(model, data, dense)
    return dense

"""The C backend: MuJoCo's own engine through the recorders of :mod:`harness.engine.recording`.

Nothing is changed for it: each request goes to the same ``recording.record`` the
harness always called (the batch recorder in C where ``mujoco.batch``
exists), so its numbers are bit for bit those of the default install.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor

import mujoco
import numpy as np

from harness.core.trajectory import Trajectory
from harness.engine import recording
from harness.engine.backends import Forward, Request, computes_reactions
from harness.engine.compat import full_mass_matrix
from harness.engine.constraints import equality_block
from harness.engine.probe import Probe

__all__ = ["backend"]


class CBackend:
    """MuJoCo's C engine, float64."""

    precision = "float64"
    epsilon = float(np.finfo(np.float64).eps)

    def __init__(self, name: str = "c") -> None:
        self.name = name

    def unsupported(self, model: mujoco.MjModel) -> str:
        """Nothing: every model MuJoCo compiles."""
        return ""

    def adaptations(self, model: mujoco.MjModel) -> tuple[str, ...]:
        return ()

    def supports(self, model: mujoco.MjModel) -> None:
        """Every model MuJoCo compiles."""

    def simulate_many(self, requests: Sequence[Request], probe: Probe) -> list[Trajectory]:
        """One C rollout per request, side by side on the machine's cores: each runs in C with Python's lock
        released (the native recorder's steps), on its own MjData; the results in the requests' order, the same
        as one after another."""
        def one(r: Request) -> Trajectory:
            return recording.record(r.model, probe, q0=r.q0, qd0=r.qd0, steps=r.steps)

        workers = min(len(requests), os.cpu_count() or 1)
        if workers <= 1:
            return [one(r) for r in requests]
        with ThreadPoolExecutor(max_workers=workers) as pool:
            return list(pool.map(one, requests))

    def forward_many(self, model: mujoco.MjModel, probe: Probe, qpos: np.ndarray, qvel: np.ndarray) -> Forward:
        """``mj_forward`` at each state (from a reset MjData: a zero warm start), the arrays copied."""
        data = mujoco.MjData(model)
        names = probe.constraints
        reactions = computes_reactions(model)
        rows: dict[str, list] = {k: [] for k in ("qacc", "qfrc_bias", "qfrc_passive", "qfrc_constraint", "mass",
                                                 "sensordata", "cfrc_int", "cfrc_ext", "qfrc_actuator")}
        eqs: dict[str, list] = {c: [] for c in names}
        for qp, qv in zip(qpos, qvel, strict=True):
            mujoco.mj_resetData(model, data)
            data.qpos[:], data.qvel[:] = qp, qv
            mujoco.mj_forward(model, data)
            for f in ("qacc", "qfrc_bias", "qfrc_passive", "qfrc_constraint", "sensordata", "cfrc_int", "cfrc_ext",
                      "qfrc_actuator"):
                rows[f].append(getattr(data, f).copy())
            rows["mass"].append(full_mass_matrix(model, data))
            for c in names:
                eqs[c].append(equality_block(model, data, c)[0])
        out = {f: np.array(v, dtype=float) for f, v in rows.items()}
        return Forward(qacc=out["qacc"], qfrc_bias=out["qfrc_bias"], qfrc_passive=out["qfrc_passive"],
                       qfrc_constraint=out["qfrc_constraint"], mass=out["mass"],
                       equality={c: np.array(v, dtype=float).reshape(len(qpos), -1) for c, v in eqs.items()},
                       sensordata=out["sensordata"] if reactions or model.nsensordata else None,
                       cfrc_int=out["cfrc_int"] if reactions else None,
                       cfrc_ext=out["cfrc_ext"] if reactions else None,
                       qfrc_actuator=out["qfrc_actuator"] if model.nu else None)


def backend(name: str) -> CBackend:
    return CBackend(name)

"""The C backend: MuJoCo's own engine through the recorders of :mod:`harness.engine.simulate`.

Nothing is changed for it: each request goes to the same ``simulate`` the
harness always called (the batch recorder in C where ``mujoco.batch``
exists), so its numbers are bit for bit those of the default install.
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from harness.core.trajectory import Trajectory
from harness.engine.backends import Request
from harness.engine.probe import Probe
from harness.engine.simulate import simulate


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
        """One C rollout per request (each already runs in C; there is nothing to batch across Python)."""
        return [simulate(r.model, probe, q0=r.q0, qd0=r.qd0, steps=r.steps) for r in requests]


def backend(name: str) -> CBackend:
    return CBackend(name)

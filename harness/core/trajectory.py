"""The one schema both producers (our reference and MuJoCo) fill in.

Because both sides produce the same thing, comparison is symmetric and knows
nothing about either producer.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Trajectory"]


@dataclass(frozen=True)
class Trajectory:
    """Time series on a common time grid.

    Attributes:
        t: times, shape (N,).
        positions, velocities: world position / linear velocity of named
            points (bodies), each (N, 3).
        multipliers: constraint forces by constraint name, each (N,), or (N, k)
            for a constraint that is a block of k rows (a connect equality: 3),
            in the analytic sign convention (M q̈ = F + Jᵀλ).
        generalized_force: Jᵀλ in the analytic coordinates, (N, n), or None
            where the coordinates of the two sides are not linearly related.
        invariants: conserved quantities by name (``energy``, ``p_phi``), (N,).
        violations: constraint violation by constraint name, (N,) or (N, k),
            in the constraint's own units (f(q) for holonomic rows).
        series: one producer's own series with no counterpart on the other
            side (a contact's slip velocity), by name, (N,).
        source: who produced it ("reference" or "mujoco:RK4", ...).
        completed: on a float32 backend, the same run with each sample's stopped constraint solve completed
            in float64 (:mod:`harness.engine.backends.completion`): the equalities' multipliers and the generalized
            force as the solve would have left them, everything else as run; None elsewhere.
    """

    t: np.ndarray
    positions: Mapping[str, np.ndarray]
    velocities: Mapping[str, np.ndarray]
    multipliers: Mapping[str, np.ndarray] = field(default_factory=dict)
    generalized_force: np.ndarray | None = None
    invariants: Mapping[str, np.ndarray] = field(default_factory=dict)
    violations: Mapping[str, np.ndarray] = field(default_factory=dict)
    source: str = ""
    series: Mapping[str, np.ndarray] = field(default_factory=dict)
    completed: Trajectory | None = None

    def __post_init__(self) -> None:
        n = len(self.t)
        for group in ("positions", "velocities", "multipliers", "invariants", "violations", "series"):
            for name, arr in getattr(self, group).items():
                if len(arr) != n:
                    raise ValueError(f"{group}[{name!r}] has {len(arr)} samples, t has {n}")

    def is_finite(self) -> bool:
        arrays = [self.t, *self.positions.values(), *self.velocities.values(),
                  *self.multipliers.values(), *self.invariants.values(), *self.violations.values(),
                  *self.series.values()]
        if self.generalized_force is not None:
            arrays.append(self.generalized_force)
        return all(np.all(np.isfinite(a)) for a in arrays)

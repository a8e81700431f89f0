"""Layer 3: compare two Trajectories on the same grid and name the figures.

Symmetric in its inputs and blind to who produced them. Every figure is a
maximum over the horizon unless its name says ``final``.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from analytic.systems import Scales
from harness.cases import Series
from harness.core.figures import Figure, FigureName, max_abs
from harness.core.trajectory import Trajectory


def _point_error(a: dict, b: dict) -> np.ndarray:
    """Euclidean distance per sample, maximised over points: shape (N,)."""
    return np.max(np.stack([np.linalg.norm(a[p] - b[p], axis=1) for p in a]), axis=0)


def error_series(ref: Trajectory, sim: Trajectory) -> dict[str, np.ndarray]:
    """Time series of the errors, for plots: position, velocity, per-multiplier force."""
    _check_grid(ref, sim)
    out = {"position": _point_error(sim.positions, ref.positions),
           "velocity": _point_error(sim.velocities, ref.velocities)}
    for c in ref.multipliers:
        if c in sim.multipliers:
            out[f"force.{c}"] = sim.multipliers[c] - ref.multipliers[c]
    return out


def _check_grid(ref: Trajectory, sim: Trajectory) -> None:
    if ref.t.shape != sim.t.shape or not np.allclose(ref.t, sim.t, rtol=0, atol=1e-9):
        raise ValueError("trajectories must share one time grid")
    if set(ref.positions) != set(sim.positions):
        raise ValueError(f"point names differ: {sorted(ref.positions)} vs {sorted(sim.positions)}")


def trajectory_figures(ref: Trajectory, sim: Trajectory, scales: Scales, *, prefix: str,
                       settle: float = 0.0) -> list[Figure]:
    """Position, velocity, invariant drift, multiplier and violation figures.

    Force figures (multipliers, generalized force) are maxima over t ≥ ``settle``
    only: a contact has no force of its own at the first sample, it builds one
    from slip or penetration over a few solref time constants (``Case.settle``).
    """
    err = error_series(ref, sim)
    settled = ref.t >= settle
    after = f" for t ≥ {settle:g} s" if settle > 0 else ""
    figs = [
        Figure(FigureName.trajectory(prefix, "position"), max_abs(err["position"]), "m",
               "max over horizon of |x_mj − x_ref| (worst point)"),
        Figure(FigureName.trajectory(prefix, "position_final"), float(err["position"][-1]), "m",
               "|x_mj − x_ref| at the horizon"),
        Figure(FigureName.trajectory(prefix, "velocity"), max_abs(err["velocity"]), "m/s",
               "max over horizon of |v_mj − v_ref|"),
    ]
    for name, series in sim.invariants.items():
        scale = scales.energy if name == "energy" else scales.momentum
        figs.append(Figure(FigureName.trajectory(prefix, "drift", name), max_abs(series - series[0]) / scale, "1",
                           f"max |{name}(t) − {name}(0)| of MuJoCo's own {name}, / {scale:.4g}"))
        if name in ref.invariants:
            figs.append(Figure(FigureName.trajectory(prefix, name), max_abs(series - ref.invariants[name]) / scale, "1",
                               f"max |{name}_mj − {name}_ref| / {scale:.4g}"))
    for c in ref.multipliers:
        if c in sim.multipliers:
            figs.append(Figure(FigureName.trajectory(prefix, "force", c),
                               max_abs(err[f"force.{c}"][settled]) / scales.force, "1",
                               f"max |λ_mj − λ_ref| for {c!r}{after} / force scale {scales.force:.4g} N"))
        if c in sim.violations:
            figs.append(Figure(FigureName.trajectory(prefix, "violation", c), max_abs(sim.violations[c]), "m",
                               f"max constraint violation of {c!r} in MuJoCo"))
    if ref.generalized_force is not None and sim.generalized_force is not None and ref.multipliers:
        diff = sim.generalized_force - ref.generalized_force
        figs.append(Figure(FigureName.trajectory(prefix, "generalized_force"), max_abs(diff[settled]) / scales.force,
                           "1", f"max |Dᵀqfrc_constraint − Jᵀλ|{after} / force scale (per coordinate, SI)"))
    return figs


def series_figures(sim: Trajectory, specs: Mapping[str, Series], *, prefix: str) -> list[Figure]:
    """One figure per MuJoCo-only series (``Case.mujoco_series``): its max |·| over the horizon."""
    return [Figure(FigureName.trajectory(prefix, "series", name), max_abs(sim.series[name]), spec.unit,
                   f"max over horizon of {spec.description}")
            for name, spec in specs.items()]

"""Layer 3: compare two Trajectories on the same grid and name the figures.

Symmetric in its inputs and blind to who produced them. Each figure is one
:class:`~harness.core.deviation.Deviation` — a time series of how far MuJoCo is from the reference
(vectors where the quantity is a vector), its scale and how it is reduced to a
number (the maximum over the horizon unless its name says ``final``). The
error budget (:mod:`harness.budget`) extrapolates the same series from other
runs of the model, so a figure and its budget are reduced the same way.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from analytic.systems import Scales
from harness.cases import Series
from harness.core.deviation import Deviation
from harness.core.figures import Figure, FigureName
from harness.core.trajectory import Trajectory


def _points(a: Mapping[str, np.ndarray], b: Mapping[str, np.ndarray]) -> np.ndarray:
    """a − b per point, stacked: shape (N, points, 3)."""
    return np.stack([a[p] - b[p] for p in a], axis=1)


def _check_grid(ref: Trajectory, sim: Trajectory) -> None:
    if ref.t.shape != sim.t.shape or not np.allclose(ref.t, sim.t, rtol=0, atol=1e-9):
        raise ValueError("trajectories must share one time grid")
    if set(ref.positions) != set(sim.positions):
        raise ValueError(f"point names differ: {sorted(ref.positions)} vs {sorted(sim.positions)}")


def error_series(ref: Trajectory, sim: Trajectory) -> dict[str, np.ndarray]:
    """Time series of the errors, for plots: position, velocity (worst point's distance), per-multiplier
    force difference."""
    _check_grid(ref, sim)
    out = {"position": np.max(np.linalg.norm(_points(sim.positions, ref.positions), axis=-1), axis=1),
           "velocity": np.max(np.linalg.norm(_points(sim.velocities, ref.velocities), axis=-1), axis=1)}
    for c in ref.multipliers:
        if c in sim.multipliers:
            out[f"force.{c}"] = sim.multipliers[c] - ref.multipliers[c]
    return out


NOT_CONSERVED = 1e-6
"""A reference invariant that changes by more than this (× its scale) over the horizon is not conserved by the
motion (damping, actuators): far above what the reference's tolerance lets a conserved one drift (≤ 1e-10)."""


def deviations(ref: Trajectory, sim: Trajectory, scales: Scales, *, prefix: str, settle: float = 0.0,
               series: Mapping[str, Series] | None = None) -> list[Deviation]:
    """Every trajectory figure of one run as a :class:`Deviation`: position (and at the horizon),
    velocity, invariant drifts and invariants against the reference, multipliers, violations, the
    generalized constraint force and the MuJoCo-only series.

    Force, velocity and MuJoCo-only figures count only t ≥ ``settle``: a contact has no force of its
    own at the first sample, it builds one from slip or penetration over a few solref time constants
    (:func:`harness.pipeline.run.settle_time`), and the slip its velocity carries meanwhile is a
    transient of the contact, f(t/τ), not the steady effect linear in τ its budget extrapolates.
    """
    _check_grid(ref, sim)
    settled = ref.t >= settle
    after = f" for t ≥ {settle:g} s" if settle > 0 else ""
    positions = _points(sim.positions, ref.positions)
    length = max(scales.length, _largest(np.stack(list(ref.positions.values()), axis=1), vector=True))
    speed = _largest(np.stack(list(ref.velocities.values()), axis=1), vector=True) or scales.length
    out = [
        Deviation(FigureName.trajectory(prefix, "position"), positions, "vector", "m",
                  "max over horizon of |x_mj − x_ref| (worst point)", size=length),
        Deviation(FigureName.trajectory(prefix, "position_final"), positions, "vector", "m",
                  "|x_mj − x_ref| at the horizon", final=True, size=length),
        Deviation(FigureName.trajectory(prefix, "velocity"), _points(sim.velocities, ref.velocities), "vector", "m/s",
                  f"max{after or ' over horizon'} of |v_mj − v_ref|", samples=settled, size=speed),
    ]
    for name, values in sim.invariants.items():
        scale = scales.energy if name == "energy" else scales.momentum
        size = max(_largest(ref.invariants.get(name, values)) / scale, 1.0)
        drift, what = values - values[0], f"max |{name}(t) − {name}(0)| of MuJoCo's own {name}, / {scale:.4g}"
        if name in ref.invariants and _largest(ref.invariants[name] - ref.invariants[name][0]) > NOT_CONSERVED * scale:
            # not an invariant of this motion (damping, actuators): MuJoCo's change against the reference's change
            drift = drift - (ref.invariants[name] - ref.invariants[name][0])
            what = f"max |Δ{name}_mj(t) − Δ{name}_ref(t)| ({name} is not conserved here), / {scale:.4g}"
        out.append(Deviation(FigureName.trajectory(prefix, "drift", name), drift, "scalar", "1", what, scale=scale,
                             size=size))
        if name in ref.invariants:
            out.append(Deviation(FigureName.trajectory(prefix, name), values - ref.invariants[name], "scalar", "1",
                                 f"max |{name}_mj − {name}_ref| / {scale:.4g}", scale=scale, size=size))
    for c in ref.multipliers:
        if c in sim.multipliers:
            out.append(Deviation(FigureName.trajectory(prefix, "force", c), sim.multipliers[c] - ref.multipliers[c],
                                 "scalar", "1",
                                 f"max |λ_mj − λ_ref| for {c!r}{after} / force scale {scales.force:.4g} N",
                                 samples=settled, scale=scales.force,
                                 size=max(_largest(ref.multipliers[c]) / scales.force, 1.0)))
        if c in sim.violations:
            out.append(Deviation(FigureName.trajectory(prefix, "violation", c), sim.violations[c], "scalar", "m",
                                 f"max constraint violation of {c!r} in MuJoCo", size=length))
    if ref.generalized_force is not None and sim.generalized_force is not None and ref.multipliers:
        out.append(Deviation(FigureName.trajectory(prefix, "generalized_force"),
                             sim.generalized_force - ref.generalized_force, "scalar", "1",
                             f"max |Dᵀqfrc_constraint − Jᵀλ|{after} / force scale (per coordinate, SI)",
                             samples=settled, scale=scales.force,
                             size=max(_largest(ref.generalized_force) / scales.force, 1.0)))
    for name, spec in (series or {}).items():
        out.append(Deviation(FigureName.trajectory(prefix, "series", name), sim.series[name], "scalar", spec.unit,
                             f"max{after or ' over horizon'} of {spec.description}", samples=settled,
                             size=speed if spec.unit == "m/s" else length))
    return out


def _largest(values: np.ndarray, *, vector: bool = False) -> float:
    """The largest entry's size (the largest vector norm with ``vector``); 0 for no entries."""
    if values.size == 0:
        return 0.0
    return float(np.max(np.linalg.norm(values, axis=-1) if vector else np.abs(values)))


def trajectory_figures(ref: Trajectory, sim: Trajectory, scales: Scales, *, prefix: str, settle: float = 0.0,
                       series: Mapping[str, Series] | None = None) -> list[Figure]:
    """The figures of :func:`deviations`."""
    return [d.figure() for d in deviations(ref, sim, scales, prefix=prefix, settle=settle, series=series)]

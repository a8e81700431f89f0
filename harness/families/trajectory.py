"""The trajectory family: each integrator's run over the horizon against the reference, sample by sample.

Figures ``INTEGRATOR.QUANTITY[.DETAIL]``: how far the named points are from the reference's (``position``, the
largest distance over the horizon; ``position_final``, at the horizon; ``velocity``), each constraint's force
against its multiplier (``force.NAME``) and its violation (``violation.NAME``), the generalized constraint force
(``generalized_force``), and the case's MuJoCo-only series (``series.NAME``: a slip that should be 0). Each is a
:class:`~harness.core.deviation.Deviation` — a time series of how far MuJoCo is from the reference (vectors where
the quantity is a vector), its scale and how it is reduced to a number (the maximum over the horizon unless its
name says ``final``) — so that the budget extrapolates the same series from the model's other runs and a figure
and its budget are reduced alike.

Force, velocity and MuJoCo-only figures count only t ≥ the settle time: a contact has no force of its own at the
first sample, it builds one from slip or penetration over a few solref time constants
(:func:`harness.families.bench.settle_time`), and the slip its velocity carries meanwhile is a transient of the
contact, f(t/τ), not the steady effect linear in τ its budget extrapolates.

Budget: the runs' (:mod:`harness.families.runs`): integration (Richardson from h/2), softness (extrapolated to the
rigid limit), the point masses' floors, the solver's stop. Gated by default: the position, forces, violations and
series.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from harness.cases import Case
from harness.core.checks import Limit
from harness.core.deviation import Deviation
from harness.core.figures import FigureName
from harness.core.trajectory import Trajectory
from harness.engine.integrators import EXPECTED_ORDER
from harness.families.bench import Bench, Measured
from harness.families.instant import not_unique
from harness.families.runs import Target, largest, point_differences

__all__ = ["NAME", "QUANTITIES", "compare", "gated", "measure", "names", "owns", "theory_limit"]

NAME = "trajectory"
QUANTITIES = ("position", "position_final", "velocity", "force", "violation", "generalized_force", "series")
GATED = ("position", "force", "violation", "series")


def owns(name: FigureName) -> bool:
    return name.layer == "trajectory" and name.quantity in QUANTITIES


def names(case: Case, model: mujoco.MjModel) -> set[FigureName]:
    constraints = [*(model.equality(i).name for i in range(model.neq)), *case.mujoco_forces]
    found: set[FigureName] = set()
    for integrator in EXPECTED_ORDER:
        found |= {FigureName.trajectory(integrator, q)
                  for q in ("position", "position_final", "velocity", "generalized_force")}
        found |= {FigureName.trajectory(integrator, q, c) for q in ("force", "violation") for c in constraints}
        found |= {FigureName.trajectory(integrator, "series", s) for s in case.mujoco_series}
    return found


def gated(name: FigureName, *, constrained: bool) -> bool:
    return name.quantity in GATED


def theory_limit(name: FigureName) -> Limit | None:
    return None


def compare(target: Target, sim: Trajectory, prefix: str) -> list[Deviation]:
    """This family's figures of one run (its integrator ``prefix``) against the reference on the same grid."""
    ref, scales, settle, series = target.reference, target.scales, target.settle, target.series
    settled = ref.t >= settle
    after = f" for t ≥ {settle:g} s" if settle > 0 else ""
    positions = point_differences(sim.positions, ref.positions)
    length = max(scales.length, largest(np.stack(list(ref.positions.values()), axis=1), vector=True))
    speed = largest(np.stack(list(ref.velocities.values()), axis=1), vector=True) or scales.length
    out = [
        Deviation(FigureName.trajectory(prefix, "position"), positions, "vector", "m",
                  "max over horizon of |x_mj − x_ref| (worst point)", size=length),
        Deviation(FigureName.trajectory(prefix, "position_final"), positions, "vector", "m",
                  "|x_mj − x_ref| at the horizon", final=True, size=length),
        Deviation(FigureName.trajectory(prefix, "velocity"), point_differences(sim.velocities, ref.velocities),
                  "vector", "m/s", f"max{after or ' over horizon'} of |v_mj − v_ref|", samples=settled, size=speed),
    ]
    for c in ref.multipliers:
        if c in sim.multipliers:
            out.append(Deviation(FigureName.trajectory(prefix, "force", c), sim.multipliers[c] - ref.multipliers[c],
                                 "scalar", "1",
                                 f"max |λ_mj − λ_ref| for {c!r}{after} / force scale {scales.force:.4g} N",
                                 samples=settled, scale=scales.force,
                                 size=max(largest(ref.multipliers[c]) / scales.force, 1.0)))
        if c in sim.violations:
            out.append(Deviation(FigureName.trajectory(prefix, "violation", c), sim.violations[c], "scalar", "m",
                                 f"max constraint violation of {c!r} in MuJoCo", size=length))
    if ref.generalized_force is not None and sim.generalized_force is not None and ref.multipliers:
        out.append(Deviation(FigureName.trajectory(prefix, "generalized_force"),
                             sim.generalized_force - ref.generalized_force, "scalar", "1",
                             f"max |Dᵀqfrc_constraint − Jᵀλ|{after} / force scale (per coordinate, SI)",
                             samples=settled, scale=scales.force,
                             size=max(largest(ref.generalized_force) / scales.force, 1.0)))
    for name, spec in (series or {}).items():
        out.append(Deviation(FigureName.trajectory(prefix, "series", name), sim.series[name], "scalar", spec.unit,
                             f"max{after or ' over horizon'} of {spec.description}", samples=settled,
                             size=speed if spec.unit == "m/s" else length))
    return out


def measure(bench: Bench) -> Measured:
    """The runs' figures; a constraint's ``force`` figures n/a where its multipliers are not unique along the
    reference (:func:`harness.families.instant.not_unique`: only the total Jᵀλ is compared then)."""
    found = bench.measured_over_runs(owns)
    dyn = bench.reference.dynamics
    if not dyn.rows:
        return found
    ref = bench.reference_run
    unique = dyn.constrained(*bench.reference.solution.state(ref.t)).unique
    why = {c: reason for c in dyn.constraint_names if (reason := not_unique(dyn, unique, c))}
    if not why:
        return found

    def kept(name: str | FigureName) -> bool:
        name = FigureName(str(name))
        return not (name.quantity == "force" and name.detail in why)

    return dataclasses.replace(
        found, figures=tuple(f for f in found.figures if kept(f.name)),
        budgets={k: v for k, v in found.budgets.items() if kept(k)},
        defect_budgets={k: v for k, v in found.defect_budgets.items() if kept(k)},
        unmeasured={**found.unmeasured, **{str(f.name): why[FigureName(str(f.name)).detail] for f in found.figures
                                           if not kept(f.name)}})

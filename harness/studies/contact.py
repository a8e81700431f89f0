"""Layer 4 for contacts: slip and force error vs friction cone, impratio, noslip and softness.

One reference per case, then one MuJoCo run per setting (the model's own
integrator and timestep), each compared with the same figures run_case uses.
The settings swept are the options that decide how MuJoCo's soft contact
approximates rolling without slipping:

- ``cone``: pyramidal or elliptic friction cone;
- ``impratio``: ratio of frictional to normal impedance (elliptic cones);
- ``noslip_iterations``: the NoSlip post-processing pass (hard friction rows);
- softness: the case's own contact ``solref``/``solimp`` ("shipped") or
  MuJoCo's defaults ("mujoco_default": solref 0.02 1, solimp 0.9 0.95 0.001
  0.5 2), to show which of the three matter where.

The figures per row: the largest slip speed (J q̇ + b of the rolling rows at
MuJoCo's state) over the horizon and over its second half (the steady, slow
slippage), the penetration, the error of every contact multiplier (after the
settle time run_case uses, / m g), the position error and MuJoCo's energy drift.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from harness import cases
from harness.core.errors import SimulationDiverged
from harness.engine import backends
from harness.engine.backends import Backend, simulate
from harness.engine.integrators import integrator_name
from harness.engine.models import compile_model
from harness.engine.recording import steps_in
from harness.families import COMPARISONS
from harness.families.bench import settle_time
from harness.families.runs import Target, compared
from harness.reference import solutions as refmod

__all__ = ["StudyResult", "contact_study"]

CONES = ("pyramidal", "elliptic")
IMPRATIOS = (1.0, 10.0, 100.0)
NOSLIP_ITERATIONS = (0, 3)
SOFTNESS: Mapping[str, tuple[tuple[float, ...], tuple[float, ...]] | None] = {
    "shipped": None,
    "mujoco_default": ((0.02, 1.0), (0.9, 0.95, 0.001, 0.5, 2.0)),
}


# a row's figures, nan where its run diverged (the row's "diverged" says why)
DIVERGED_NAN = ("slip_max", "slip_late", "penetration", "force_error", "position", "drift.energy")


@dataclass(frozen=True)
class StudyResult:
    """Rows of the study (one dict per setting) and the settings the MJCF ships."""

    case: str
    integrator: str
    timestep: float
    shipped: Mapping[str, object]
    rows: tuple[Mapping[str, Any], ...]

    def shipped_row(self) -> Mapping[str, object]:
        """The row with the MJCF's own cone, impratio, noslip and softness."""
        for row in self.rows:
            if row["softness"] == "shipped" and all(row[k] == v for k, v in self.shipped.items()):
                return row
        raise ValueError(f"the study did not include the shipped settings {dict(self.shipped)}")


def _options(model: mujoco.MjModel) -> dict[str, object]:
    return {"cone": mujoco.mjtCone(int(model.opt.cone)).name.removeprefix("mjCONE_").lower(),
            "impratio": float(model.opt.impratio),
            "noslip_iterations": int(model.opt.noslip_iterations)}


def _edit(cone: str, impratio: float, noslip: int, softness: tuple | None):
    def edit(spec: mujoco.MjSpec) -> None:
        spec.option.cone = getattr(mujoco.mjtCone, f"mjCONE_{cone.upper()}")
        spec.option.impratio = impratio
        spec.option.noslip_iterations = noslip
        if softness is not None:
            for pair in spec.pairs:
                pair.solref, pair.solimp = list(softness[0]), list(softness[1])

    return edit


def _validate(values: Sequence, allowed: Sequence | None, label: str) -> None:
    if not values:
        raise ValueError(f"{label} must not be empty")
    if allowed is not None and set(values) - set(allowed):
        raise ValueError(f"{label} must be among {list(allowed)}, got {list(values)}")


def contact_study(
    case_name: str,
    *,
    cones: Sequence[str] = CONES,
    impratios: Sequence[float] = IMPRATIOS,
    noslip_iterations: Sequence[int] = NOSLIP_ITERATIONS,
    softness: Sequence[str] = tuple(SOFTNESS),
    engine: Backend | None = None,
) -> StudyResult:
    """Run ``case_name`` (a case with a contact <pair> and a ``slip`` series) at every
    combination of the settings, on ``engine`` (default: MuJoCo's C engine); one row per combination."""
    engine = engine or backends.get("c")
    case = cases.get(case_name)
    _validate(cones, CONES, "cones")
    _validate(softness, tuple(SOFTNESS), "softness")
    _validate(impratios, None, "impratios")
    _validate(noslip_iterations, None, "noslip_iterations")
    if any(not r >= 1 for r in impratios) or any(n < 0 for n in noslip_iterations):
        raise ValueError(f"impratios must be >= 1 and noslip_iterations >= 0, got {impratios}, "
                         f"{noslip_iterations}")
    path = case.mjcf
    shipped_model = compile_model(path)
    if shipped_model.npair == 0 or "slip" not in case.mujoco_series:
        raise ValueError(f"case {case_name!r} has no contact pair and slip series; contact cases: "
                         f"{[c.name for c in cases.all_cases() if 'slip' in c.mujoco_series]}")
    ref = case.reference(shipped_model)
    probe = case.probe(ref.dynamics)
    steps = steps_in(case.horizon, shipped_model.opt.timestep)
    rows = []
    for soft, cone, imp, ns in itertools.product(softness, cones, impratios, noslip_iterations):
        model = compile_model(path, edit=_edit(cone, float(imp), int(ns), SOFTNESS[soft]))
        setting = {"softness": soft, "cone": cone, "impratio": float(imp), "noslip_iterations": int(ns),
                   "solref": [float(x) for x in model.pair_solref[0]]}
        try:
            sim = simulate(engine, model, probe, q0=ref.q0(), qd0=ref.qd0(), steps=steps)
        except SimulationDiverged as exc:  # a finding of the sweep, never a number
            rows.append({**setting, **dict.fromkeys(DIVERGED_NAN + tuple(f"force.{c}" for c in case.mujoco_forces),
                                                    float("nan")), "diverged": exc.reason})
            continue
        ref_traj = refmod.trajectory(ref, sim.t)
        target = Target(reference=ref_traj, scales=ref.scales, settle=settle_time(case, model, case.horizon)[0],
                        series=case.mujoco_series, q0=ref.q0(), qd0=ref.qd0(), rtol=ref.solution.rtol,
                        compare=COMPARISONS.over_runs)
        figs = {d.name.removeprefix("sim."): d.magnitude() for d in compared(target, sim, "sim")}
        forces = {f"force.{c}": figs[f"force.{c}"] for c in case.mujoco_forces}
        slip = sim.series["slip"]
        rows.append({
            **setting,
            "slip_max": float(np.max(np.abs(slip))),
            "slip_late": float(np.max(np.abs(slip[len(slip) // 2:]))),
            "penetration": figs.get("series.penetration", float("nan")),
            **forces,
            "force_error": max(forces.values()),
            "position": figs["position"],
            "drift.energy": figs["drift.energy"],
        })
    return StudyResult(case=case_name, integrator=integrator_name(shipped_model),
                       timestep=float(shipped_model.opt.timestep), shipped=_options(shipped_model),
                       rows=tuple(rows))

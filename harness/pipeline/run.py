"""Run one case through every layer: reference, instantaneous checks, trajectories, orders.

Pure function of its inputs: the CLI, the Python API, the tests and the CI
gate all call :func:`run_case` and differ only in what they do with the result.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from harness.cases import Case
from harness.core.errors import SimulationDiverged
from harness.core.figures import Figure
from harness.core.trajectory import Trajectory
from harness.engine.compat import fallbacks, joint_types, unavailable_reason
from harness.engine.integrators import available_integrators, integrator_name
from harness.engine.models import compile_model
from harness.engine.simulate import recorder, simulate
from harness.engine.simulate import recorder_notes as simulate_notes
from harness.layers.instant import instantaneous_figures
from harness.layers.orders import convergence_study, order_figures
from harness.layers.reference import reference_figures
from harness.layers.trajectory import series_figures, trajectory_figures
from harness.reference import derivations
from harness.reference import solutions as refmod


@dataclass(frozen=True)
class CaseResult:
    """Everything one case produced: figures, trajectories and the settings used (``reference`` None
    and ``simulations`` empty where a parallel run sent back figures only: ``check``, ``baseline``)."""

    case: Case
    figures: tuple[Figure, ...]
    reference: Trajectory | None
    simulations: dict[str, Trajectory]
    settings: dict[str, object]
    timings: dict[str, float] = field(default_factory=dict)
    joints: frozenset[int] = frozenset()  # the joint types of the model run (known defects match them)
    diverged: dict[str, str] = field(default_factory=dict)  # run (INTEGRATOR, converge.INTEGRATOR) -> reason

    def figure(self, name: str) -> Figure:
        for f in self.figures:
            if f.name == name:
                return f
        raise KeyError(name)


def model_settings(model: mujoco.MjModel) -> dict[str, object]:
    """The settings that matter for a comparison, as recorded in the report."""
    out: dict[str, object] = {
        "timestep": float(model.opt.timestep),
        "integrator": integrator_name(model),
        "solver": mujoco.mjtSolver(int(model.opt.solver)).name.removeprefix("mjSOL_"),
        "iterations": int(model.opt.iterations),
        "tolerance": float(model.opt.tolerance),
        "cone": mujoco.mjtCone(int(model.opt.cone)).name.removeprefix("mjCONE_"),
        "impratio": float(model.opt.impratio),
        "noslip_iterations": int(model.opt.noslip_iterations),
    }
    for i in range(model.neq):
        eq = model.equality(i)
        out[f"equality.{eq.name}.solref"] = [float(x) for x in eq.solref]
        out[f"equality.{eq.name}.solimp"] = [float(x) for x in eq.solimp]
    for i in range(model.npair):
        pair = model.pair(i)
        for key in ("solref", "solimp", "friction", "margin"):
            out[f"pair.{pair.name}.{key}"] = [float(x) for x in np.atleast_1d(getattr(pair, key))]
    return out


def run_case(
    case: Case,
    *,
    mjcf: Path | str | None = None,
    integrators: Sequence[str] | None = None,
    timestep: float | None = None,
    edit: Callable[[mujoco.MjSpec], None] | None = None,
) -> CaseResult:
    """All layers for ``case``. ``mjcf`` replaces the shipped model (the reference
    keeps the shipped parameters); ``edit`` modifies the model through MjSpec."""
    timings: dict[str, float] = {}
    recorder_notes = len(simulate_notes())
    clock = time.perf_counter()
    shipped = compile_model(case.mjcf)
    path = Path(mjcf) if mjcf is not None else case.mjcf
    model = compile_model(path, timestep=timestep, edit=edit)
    compiling = time.perf_counter() - clock  # counted with the reference, which reads the shipped model
    clock = time.perf_counter()
    # numeric dynamics at the model's parameters: loaded from the on-disk cache, or derived (and cached)
    dyn = derivations.dynamics_of(case.system, shipped)
    derivations.minimal_dynamics(case.system, dict(dyn.params))
    timings["derivation"] = time.perf_counter() - clock
    clock = time.perf_counter()
    ref = case.reference(shipped)
    timings["reference"] = compiling + (time.perf_counter() - clock)
    probe = case.probe(ref.dynamics)
    figures: list[Figure] = []

    clock = time.perf_counter()
    instant_model = model
    if integrator_name(model) == "discrete":  # qacc is the step map there; use continuous time
        instant_model = compile_model(path, timestep=timestep, edit=edit, integrator="Euler")
    figures += instantaneous_figures(instant_model, probe, ref)
    timings["instant"] = time.perf_counter() - clock

    clock = time.perf_counter()
    sims: dict[str, Trajectory] = {}
    diverged: dict[str, str] = {}  # a diverged run is a verdict of its own, never a number (pipeline.verdict)
    steps = round(case.horizon / model.opt.timestep)
    for name in integrators or available_integrators():
        m = compile_model(path, timestep=timestep, edit=edit, integrator=name)
        try:
            sims[name] = simulate(m, probe, q0=ref.q0(), qd0=ref.qd0(), steps=steps)
        except SimulationDiverged as exc:
            diverged[name] = exc.reason
    timings["mujoco"] = time.perf_counter() - clock

    clock = time.perf_counter()
    grid = next(iter(sims.values())).t if sims else np.arange(steps + 1) * model.opt.timestep
    ref_traj = refmod.trajectory(ref, grid)
    figures += reference_figures(ref, grid)
    for name, sim in sims.items():
        figures += trajectory_figures(ref_traj, sim, ref.scales, prefix=name, settle=case.settle)
        figures += series_figures(sim, case.mujoco_series, prefix=name)
    timings["compare"] = time.perf_counter() - clock

    clock = time.perf_counter()  # layer 4, fast subset: observed vs documented order per integrator
    if sims:  # an integrator whose run diverged has no ladder: its order's verdict is that run's
        study = convergence_study(case, fast=True, integrators=list(sims), mjcf=path, timestep=timestep,
                                  edit=edit, reference=ref)
        figures += order_figures(study)
        diverged |= {f"converge.{s.integrator}": s.diverged for s in study.verdicts if s.diverged}
    timings["converge"] = time.perf_counter() - clock
    settings = model_settings(model) | {"mjcf": str(path), "horizon": case.horizon,
                                        "params": dict(ref.params), "recorder": recorder()}
    fallbacks_here = tuple(dict.fromkeys(simulate_notes()[recorder_notes:]))
    if fallbacks_here:  # the batch recorder handed some runs to the loop: shown, never silent
        settings["recorder_fallbacks"] = list(fallbacks_here)
    missing = [n for n in ("discrete",) if unavailable_reason(f"{n}.position")]  # shown, never silently skipped
    notes = [*fallbacks(str(path)), *(unavailable_reason(f"{n}.position") for n in missing)]
    if notes:
        settings["compat"] = notes
    return CaseResult(case=case, figures=tuple(figures), reference=ref_traj, simulations=sims,
                      settings=settings, timings=timings, joints=joint_types(model), diverged=diverged)

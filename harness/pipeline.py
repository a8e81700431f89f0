"""Run one case through every layer: reference, instantaneous checks, trajectories.

Pure function of its inputs: the CLI, the tests and the CI gate all call
:func:`run_case` and differ only in what they do with the result.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from analytic.dynamics import Dynamics
from analytic.solvers import solve
from analytic.systems import load as load_system
from harness import reference as refmod
from harness.binding import JointBinding
from harness.cases import Case
from harness.compare import series_figures, trajectory_figures
from harness.figures import Figure, max_abs
from harness.instant import instantaneous_figures
from harness.models import compile_model, mjcf_path
from harness.simulate import Probe, available_integrators, integrator_name, recorder, simulate
from harness.simulate import recorder_notes as simulate_notes
from harness.trajectory import Trajectory


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

    def figure(self, name: str) -> Figure:
        for f in self.figures:
            if f.name == name:
                return f
        raise KeyError(name)


def probe_for(case: Case, dyn: Dynamics) -> Probe:
    """What to read from MuJoCo for ``case``: equalities for every constraint not
    read through the case's own ``mujoco_forces``."""
    binding = (case.binding or JointBinding)(dyn.coordinates)
    equalities = tuple(c for c in dyn.constraint_names if c not in case.mujoco_forces)
    return Probe(binding=binding, points=dyn.point_names, constraints=equalities,
                 invariants=case.mujoco_invariants, forces=case.mujoco_forces,
                 series={k: s.read for k, s in case.mujoco_series.items()})


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


def reference_figures(ref: refmod.Reference, t: np.ndarray) -> list[Figure]:
    """Quality of the reference itself: constraint residual and the ODE cross-check."""
    pos, vel = ref.solution.residuals(t)
    figs = [
        Figure("reference.residual", max(max_abs(pos), max_abs(vel)), "SI",
               f"max |f(q)|, |Jq̇+b| of our DAE solution (rtol {ref.solution.rtol:g})"),
    ]
    dyn_min = refmod.minimal_dynamics(ref.case.system, ref.params)
    if dyn_min is not None:
        full_q, full_qd = ref.solution.state([0.0])
        # the minimal coordinates are the full ones that survive the embedding
        keep = [ref.dynamics.coordinates.index(c) for c in dyn_min.coordinates]
        sol = solve(dyn_min, q0=full_q[0, keep], qd0=full_qd[0, keep], t_end=ref.solution.t_end,
                    rtol=ref.solution.rtol, atol=ref.solution.rtol)
        q_full, _ = ref.solution.state(t)
        q_min, _ = sol.state(t)
        diff = np.max(np.linalg.norm(ref.dynamics.points(q_full) - dyn_min.points(q_min), axis=-1))
        figs.append(Figure("reference.ode_vs_dae", float(diff), "m",
                           "max distance between the DAE and minimal-coordinate ODE solutions"))
    return figs


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
    shipped = compile_model(mjcf_path(case.mjcf))
    path = Path(mjcf) if mjcf is not None else mjcf_path(case.mjcf)
    model = compile_model(path, timestep=timestep, edit=edit)
    compiling = time.perf_counter() - clock  # counted with the reference, which reads the shipped model
    clock = time.perf_counter()
    # numeric dynamics at the model's parameters: loaded from the on-disk cache, or derived (and cached)
    params = load_system(case.system).params_from_model(shipped)
    refmod.dynamics(case.system, params)
    refmod.minimal_dynamics(case.system, params)
    timings["derivation"] = time.perf_counter() - clock
    clock = time.perf_counter()
    ref = refmod.build_reference(case, shipped)
    timings["reference"] = compiling + (time.perf_counter() - clock)
    probe = probe_for(case, ref.dynamics)
    figures: list[Figure] = []

    clock = time.perf_counter()
    instant_model = model
    if integrator_name(model) == "discrete":  # qacc is the step map there; use continuous time
        instant_model = compile_model(path, timestep=timestep, edit=edit, integrator="Euler")
    figures += instantaneous_figures(instant_model, probe, ref)
    timings["instant"] = time.perf_counter() - clock

    clock = time.perf_counter()
    sims: dict[str, Trajectory] = {}
    steps = round(case.horizon / model.opt.timestep)
    for name in integrators or available_integrators():
        m = compile_model(path, timestep=timestep, edit=edit, integrator=name)
        sims[name] = simulate(m, probe, q0=ref.q0(), qd0=ref.qd0(), steps=steps)
    timings["mujoco"] = time.perf_counter() - clock

    clock = time.perf_counter()
    grid = next(iter(sims.values())).t
    ref_traj = refmod.trajectory(ref, grid)
    figures += reference_figures(ref, grid)
    for name, sim in sims.items():
        figures += trajectory_figures(ref_traj, sim, ref.scales, prefix=name, settle=case.settle)
        figures += series_figures(sim, case.mujoco_series, prefix=name)
    timings["compare"] = time.perf_counter() - clock

    clock = time.perf_counter()  # layer 4, fast subset: observed vs documented order per integrator
    from harness.studies.convergence import convergence_study, order_figures  # imports this module

    figures += order_figures(convergence_study(case, fast=True, integrators=list(sims), mjcf=path,
                                               timestep=timestep, edit=edit, reference=ref, plot=False))
    timings["converge"] = time.perf_counter() - clock
    settings = model_settings(model) | {"mjcf": str(path), "horizon": case.horizon,
                                        "params": dict(ref.params), "recorder": recorder()}
    fallbacks_here = tuple(dict.fromkeys(simulate_notes()[recorder_notes:]))
    if fallbacks_here:  # the batch recorder handed some runs to the loop: shown, never silent
        settings["recorder_fallbacks"] = list(fallbacks_here)
    from harness.compat import fallbacks, unavailable_reason

    missing = [n for n in ("discrete",) if unavailable_reason(n)]  # shown, never silently skipped
    notes = [*fallbacks(str(path)), *(unavailable_reason(n) for n in missing)]
    if notes:
        settings["compat"] = notes
    return CaseResult(case=case, figures=tuple(figures), reference=ref_traj, simulations=sims,
                      settings=settings, timings=timings)

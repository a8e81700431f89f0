"""Layer 4: MuJoCo's constraint solvers (Newton, CG, PGS) on the constrained cases.

Each solver runs the case at its shipped integrator, timestep, iteration
limit and tolerance; the study reports the constraint-force error against the
reference (worst constraint, / force scale), the position error, and the
iterations each solve used (``mjData.solver_niter``, per island since MuJoCo
3.x: harness.compat.solver_iterations takes the most any island used).
A solver that reaches the iteration limit has not met the tolerance; the
table says so. The force error of every solver includes the softness floor
(1 − d)|λ(0)| (see softness.py), so the solvers' disagreement with the first
one (Newton) is reported too. Iterations are those of the solve at each
recorded state (mj_forward); RK4's intermediate stages solve too, uncounted.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from harness.cases import Case
from harness.core.errors import SimulationDiverged
from harness.engine import backends
from harness.engine.backends import Backend, simulate
from harness.engine.compat import SOLVER_ITERATIONS
from harness.engine.integrators import integrator_name
from harness.engine.models import compile_model
from harness.engine.recording import steps_in
from harness.reference import solutions as refmod

__all__ = ["SolverStudy", "constrained_cases", "solver_study"]

SOLVERS: tuple[str, ...] = ("Newton", "CG", "PGS")
FAST_HORIZON = 0.5


@dataclass(frozen=True)
class SolverRow:
    solver: str
    force: float
    force_vs_first: float
    position: float
    iterations_mean: float
    iterations_max: int
    iteration_limit: int
    diverged: str = ""  # the solver's run diverged: its reason, and nan (0 iterations) for the rest


@dataclass(frozen=True)
class SolverSeries:
    """One solver's run over time (a plot's curves): the force error (/ force scale, worst constraint) and the
    iterations of the solve at each recorded state."""

    solver: str
    t: np.ndarray
    force: np.ndarray
    iterations: np.ndarray


@dataclass(frozen=True)
class SolverStudy:
    case: str
    integrator: str
    timestep: float
    tolerance: float
    horizon: float
    rows: tuple[SolverRow, ...]
    series: tuple[SolverSeries, ...] = ()  # the solvers whose runs did not diverge
    mujoco_version: str = mujoco.__version__


def constrained_cases(selected: Sequence[Case]) -> tuple[Case, ...]:
    """Cases with constraint forces to compare: MJCF equalities or contacts read by the case."""
    return tuple(c for c in selected if c.dynamics().constraint_names or c.mujoco_forces)


def _solver(name: str):
    if name not in SOLVERS:
        raise ValueError(f"unknown solver {name!r}; accepted: {list(SOLVERS)}")

    def edit(spec: mujoco.MjSpec) -> None:
        spec.option.solver = getattr(mujoco.mjtSolver, f"mjSOL_{name.upper()}")
    return edit


def solver_study(case: Case, *, fast: bool = False, solvers: Sequence[str] = SOLVERS,
                 engine: Backend | None = None) -> SolverStudy:
    """Force and position error and iterations used, per solver, at the shipped settings, every run on ``engine``
    (default: MuJoCo's C engine)."""
    engine = engine or backends.get("c")
    path = case.mjcf
    shipped = compile_model(path)
    horizon = min(case.horizon, FAST_HORIZON) if fast else case.horizon
    reference = case.reference(shipped, t_end=horizon)
    base = case.probe(reference.dynamics)
    if not (base.constraints or base.forces):
        raise ValueError(f"case {case.name!r} has no constraint forces to compare; the solver study needs "
                         "equality or contact constraints")
    probe = dataclasses.replace(base, series={**base.series, "solver_niter": SOLVER_ITERATIONS})
    steps = steps_in(horizon, shipped.opt.timestep)
    names = [*base.constraints, *base.forces]
    rows, series, ref_traj, newton = [], [], None, None
    for k, name in enumerate(solvers):
        model = compile_model(path, edit=_solver(name))
        try:
            sim = simulate(engine, model, probe, q0=reference.q0(), qd0=reference.qd0(), steps=steps)
        except SimulationDiverged as exc:  # a finding of the comparison, never a number
            rows.append(SolverRow(solver=name, force=np.nan, force_vs_first=np.nan, position=np.nan,
                                  iterations_mean=np.nan, iterations_max=0,
                                  iteration_limit=int(model.opt.iterations), diverged=exc.reason))
            continue
        if ref_traj is None:
            ref_traj = refmod.trajectory(reference, sim.t)
        lam = np.stack([sim.multipliers[c] for c in names])
        newton = lam if k == 0 else newton  # the first solver's forces ('vs first'; nan if it diverged)
        force = np.max(np.abs(lam - np.stack([ref_traj.multipliers[c] for c in names])), axis=0)
        force = force / reference.scales.force
        iters = sim.series["solver_niter"]
        series.append(SolverSeries(name, sim.t, force, iters))
        settled = sim.t >= case.settle
        rows.append(SolverRow(
            solver=name, force=float(np.max(force[settled])),
            force_vs_first=np.nan if newton is None else float(np.max(np.abs(lam - newton)[:, settled]))
            / reference.scales.force,
            position=max(float(np.max(np.linalg.norm(sim.positions[p] - ref_traj.positions[p], axis=1)))
                         for p in ref_traj.positions),
            iterations_mean=float(np.mean(iters)), iterations_max=int(np.max(iters)),
            iteration_limit=int(model.opt.iterations)))
    return SolverStudy(case=case.name, integrator=integrator_name(shipped), timestep=float(shipped.opt.timestep),
                       tolerance=float(shipped.opt.tolerance), horizon=horizon, rows=tuple(rows), series=tuple(series))

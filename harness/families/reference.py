"""The reference's own quality: how well our DAE solution keeps its constraints, and how closely it agrees with the
independent minimal-coordinate ODE where the system has one.

Figures ``reference.residual`` (max |f(q)|, |Jq̇ + b| of the solution) and ``reference.ode_vs_dae``. Limits: from
theory, the solver's tolerance (:data:`RESIDUAL_LIMIT`, :data:`ODE_VS_DAE_LIMIT`, each with its reason); the residual
is gated only where the case has constraints.
"""

from __future__ import annotations

import mujoco
import numpy as np

from analytic.solvers import DEFAULT_RTOL, solve
from harness.budget.reference import REFERENCE
from harness.cases import Case
from harness.core.checks import Limit
from harness.core.figures import Figure, FigureName, max_abs
from harness.families.bench import Bench, Measured
from harness.reference.derivations import minimal_dynamics
from harness.reference.solutions import Reference

__all__ = ["NAME", "gated", "measure", "names", "owns", "reference_figures", "theory_limit"]

NAME = "reference"
QUANTITIES = ("residual", "ode_vs_dae")

RESIDUAL_LIMIT = 1000 * DEFAULT_RTOL
RESIDUAL_REASON = (f"each step of the DAE solve injects ≤ rtol·|y| (rtol {DEFAULT_RTOL:g}) into f(q) and Jq̇ + b; "
                   "Baumgarte stabilization (ω = 10/s) removes it over 1/ω ≈ 0.1 s, about 100 steps: ≲ 100 rtol at "
                   "the cases' O(1) scales; × 10")
ODE_VS_DAE_LIMIT = 2 * REFERENCE * DEFAULT_RTOL * 10.0
ODE_VS_DAE_REASON = (f"each solution within {REFERENCE:g} rtol × L of the truth (harness/core/budget.py, "
                     f"REFERENCE), rtol {DEFAULT_RTOL:g}, L ≤ 10 m: their distance ≤ {ODE_VS_DAE_LIMIT:g} m")


def owns(name: FigureName) -> bool:
    return name.layer == "reference"


def names(case: Case, model: mujoco.MjModel) -> set[FigureName]:
    return {FigureName.reference(q) for q in QUANTITIES}


def gated(name: FigureName, *, constrained: bool) -> bool:
    return name.quantity != "residual" or constrained


def theory_limit(name: FigureName) -> Limit | None:
    if name == "reference.residual":
        return Limit("theory", RESIDUAL_LIMIT, RESIDUAL_REASON)
    if name == "reference.ode_vs_dae":
        return Limit("theory", ODE_VS_DAE_LIMIT, ODE_VS_DAE_REASON)
    return None


def reference_figures(ref: Reference, t: np.ndarray) -> list[Figure]:
    """Constraint residual of the DAE solution, and its distance from the minimal-coordinate ODE."""
    pos, vel = ref.solution.residuals(t)
    figs = [
        Figure(FigureName.reference("residual"), max(max_abs(pos), max_abs(vel)), "SI",
               f"max |f(q)|, |Jq̇+b| of our DAE solution (rtol {ref.solution.rtol:g})"),
    ]
    dyn_min = minimal_dynamics(ref.system, ref.params)
    if dyn_min is not None:
        full_q, full_qd = ref.solution.state([0.0])
        # the minimal coordinates are the full ones that survive the embedding
        keep = [ref.dynamics.coordinates.index(c) for c in dyn_min.coordinates]
        sol = solve(dyn_min, q0=full_q[0, keep], qd0=full_qd[0, keep], t_end=ref.solution.t_end,
                    rtol=ref.solution.rtol, atol=ref.solution.rtol)
        q_full, _ = ref.solution.state(t)
        q_min, _ = sol.state(t)
        diff = np.max(np.linalg.norm(ref.dynamics.points(q_full) - dyn_min.points(q_min), axis=-1))
        figs.append(Figure(FigureName.reference("ode_vs_dae"), float(diff), "m",
                           "max distance between the DAE and minimal-coordinate ODE solutions"))
    return figs


def measure(bench: Bench) -> Measured:
    grid = bench.grid  # the runs' sample times (the runs are made first, timed as such)
    return Measured(figures=tuple(bench.timed("compare", lambda: reference_figures(bench.reference, grid))))

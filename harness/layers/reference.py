"""The reference's own quality: how well our DAE solution keeps its constraints, and how closely it
agrees with the independent minimal-coordinate ODE where the system has one."""

from __future__ import annotations

import numpy as np

from analytic.solvers import solve
from harness.core.figures import Figure, FigureName, max_abs
from harness.reference.derivations import minimal_dynamics
from harness.reference.solutions import Reference


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

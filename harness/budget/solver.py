"""The ``solver`` part: where the model's constraint solver stops short of the solution (CG or PGS at their iteration
cap, a loose tolerance), the difference a converged solve makes. Every other variant is then made converged too."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from harness.budget.inputs import Runs, States, by_name
from harness.budget.part import Estimates, Evaluating, Part, adds, fraction
from harness.core.figures import FigureName
from harness.engine import variants as V

__all__ = ["PART", "SOLVER_PART_UNCERTAINTY"]

SOLVER_PART_UNCERTAINTY = 0.1
"""The solver part (what a converged solve changes) feeds back into the motion: known to a tenth of itself."""


def over_runs(runs: Runs, estimates: Estimates, kappa: float) -> None:
    """A − A(converged); the other parts are then taken from A(converged). The converged run is made by
    :mod:`harness.families.runs` (:attr:`~harness.budget.inputs.Runs.converged`): every other run is made so too."""
    if runs.converged is not None:
        _apply(estimates, by_name(runs.converged)[estimates.dev.name])


def states(evaluating: Evaluating) -> Mapping[FigureName, np.ndarray] | None:
    """The model with its constraints solved exactly at the states, where its own solver does not converge."""
    return by_name(evaluating.at(None)) if evaluating.exact is not None else None


def at_states(states: States, estimates: Estimates) -> None:
    """As over the runs, at the states."""
    converged = states.own.get("solver", {})
    if estimates.dev.name in converged:
        _apply(estimates, converged[estimates.dev.name])


def _apply(estimates: Estimates, converged) -> None:
    estimates.base = converged
    estimates.explained["solver"] = estimates.dev.values - converged


PART = Part(
    name="solver",
    order=50,
    varies="the constraint solver: Newton to `CONVERGED_TOLERANCE` where the model's own does not converge",
    variant=V.converged_solver,
    explains="CG or PGS stopped short of the solution",
    must_not_absorb="the stop at the solver's tolerance (the `convergence` tolerance's); wrong forces a converged "
                    "solve keeps",
    uncertainty=SOLVER_PART_UNCERTAINTY,
    basis="the solver's difference feeds back into the motion",
    tolerance=fraction("solver", SOLVER_PART_UNCERTAINTY),
    over_runs=over_runs,
    at_states=at_states,
    baseline=True,
    states=states,
    states_gain=adds(2.0),
)

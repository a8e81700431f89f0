"""The ``floors`` part: a point mass's tiny rotational inertia (MuJoCo needs some), from the model with it doubled,
linear in the inertia."""

from __future__ import annotations

from harness.budget.inputs import Runs, States
from harness.budget.part import Estimates, Part, fraction
from harness.engine import variants as V

__all__ = ["FLOOR_UNCERTAINTY", "PART"]

FLOOR_UNCERTAINTY = 0.1
"""A point mass's floor inertia (at most 1e-6 m L²) acts linearly: a tenth of the floors' part bounds the rest."""


def over_runs(runs: Runs, estimates: Estimates, kappa: float) -> None:
    """D − A, run once and shared by the integrators (:attr:`~harness.budget.inputs.Runs.floors`)."""
    measure = estimates.dev.name.measure
    if runs.floors is not None and measure in runs.floors:
        estimates.explained["floors"] = runs.floors[measure]


def at_states(states: States, estimates: Estimates) -> None:
    """D − A (or D − the lighter base, both without fluid forces)."""
    name = estimates.dev.name
    if name in states.heavier:
        estimates.explained["floors"] = states.heavier[name] - states.lighter.get(name, estimates.base)


PART = Part(
    name="floors",
    varies="the point masses' floor inertia (at most 1e-6 m L²), doubled",
    variant=V.floors_pair,
    explains="the tiny inertia a point mass needs in MuJoCo",
    must_not_absorb="extra inertia on a rigid body (a fault); the inertia-box fluid force, sized by the same inertia "
                    "(both runs are made without fluid)",
    uncertainty=FLOOR_UNCERTAINTY,
    basis="an inertia ≤ 1e-6 m L² acts linearly",
    tolerance=fraction("floors", FLOOR_UNCERTAINTY),
    over_runs=over_runs,
    at_states=at_states,
)

"""The ``integration`` part: the integrator's truncation error at the model's timestep (runs only: nothing is
integrated at the sampled states)."""

from __future__ import annotations

from collections.abc import Mapping

from harness.budget.inputs import Runs, by_name
from harness.budget.part import Estimates, Part
from harness.engine import variants as V

__all__ = ["INTEGRATION_UNCERTAINTY", "PART"]

INTEGRATION_UNCERTAINTY = 0.25
"""Richardson removes the leading term; what remains is the next order, relatively O(ω h) of the correction: a
quarter of it allows ω h up to about 1/2 (past the asymptotic range the run at h/4 measures it instead)."""


def over_runs(runs: Runs, estimates: Estimates, kappa: float) -> None:
    """κ(A − B), at the model's own softness (A the base: converged or completed where that applies); with the run at
    h/4, the next order measured: twice the distance between the extrapolations from (h, h/2) and (h/2, h/4)."""
    name, a = estimates.dev.name, estimates.base
    b = by_name(runs.half_step)[name]
    estimates.explained["integration"] = kappa * (a - b)
    if runs.quarter_step is not None:
        q = by_name(runs.quarter_step)[name]
        estimates.uncertainty["integration"] = 2.0 * ((a - kappa * (a - b)) - (b - kappa * (b - q)))


def tolerance(estimates: Estimates, explained: Mapping[str, float]) -> float:
    """:data:`INTEGRATION_UNCERTAINTY` of the part; where the next order is measured, never below that."""
    theory = INTEGRATION_UNCERTAINTY * explained["integration"]
    measured = estimates.uncertainty.get("integration")
    return theory if measured is None else max(theory, estimates.dev.magnitude(measured))


PART = Part(
    name="integration",
    order=10,
    varies="the timestep: the same run at h/2 (and h/4 past the asymptotic range)",
    variant=V.variant,
    explains="truncation error at the model's timestep h",
    must_not_absorb="an error that does not shrink with h at the integrator's order (damping, a wrong coefficient); "
                    "the softness's change with h/τ (each softness level is taken to h → 0 by its own correction)",
    uncertainty=INTEGRATION_UNCERTAINTY,
    basis="Richardson leaves the next order, relatively O(ω h): a quarter allows ω h up to about 1/2; past the "
          "asymptotic range the run at h/4 measures it",
    tolerance=tolerance,
    over_runs=over_runs,
)

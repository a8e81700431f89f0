"""The ``stop`` part (float32 backends only): where the backend's solver stopped at float32's resolution, the
difference the solve completed in float64 makes (:mod:`harness.engine.backends.completion`). No variant of the model:
the same run, each solve completed. Every variant is then taken completed too. Not with the ``solver`` part: where
the model's solver does not converge, that part's converged runs are what the others are taken from."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from harness.budget.inputs import Runs, States, by_name
from harness.budget.part import Estimates, Evaluating, Part, fraction
from harness.budget.solver import SOLVER_PART_UNCERTAINTY
from harness.core.figures import FigureName

__all__ = ["PART"]


def over_runs(runs: Runs, estimates: Estimates, kappa: float) -> None:
    """A − A(completed); the other parts are then taken from A(completed). The completed run is the run at h's own
    (:attr:`~harness.budget.inputs.Runs.completed`, kept by :mod:`harness.families.runs`)."""
    if "solver" not in estimates.explained and runs.completed is not None:
        _apply(estimates, by_name(runs.completed)[estimates.dev.name])


def states(evaluating: Evaluating) -> Mapping[FigureName, np.ndarray] | None:
    """The model as it is with its stopped solves completed (a float32 backend's), no evaluation of its own: the
    same evaluation completed. No weight in the noise gain (not an independent evaluation)."""
    return by_name(evaluating.completed) if evaluating.completed is not None else None


def at_states(states: States, estimates: Estimates) -> None:
    """As over the runs, at the states."""
    completed = states.own.get("stop", {})
    if "solver" not in estimates.explained and estimates.dev.name in completed:
        _apply(estimates, completed[estimates.dev.name])


def _apply(estimates: Estimates, completed) -> None:
    estimates.base = completed
    estimates.explained["stop"] = estimates.dev.values - completed


PART = Part(
    name="stop",
    order=60,
    varies="nothing of the model: each solve completed in float64 where the backend's stopped",
    variant=None,
    explains="a float32 backend's solver stopped at float32's resolution",
    must_not_absorb="balanced but wrong forces (they stay); float32 round-off elsewhere (the `roundoff` tolerance's)",
    uncertainty=SOLVER_PART_UNCERTAINTY,
    basis="the completion is exact on the piecewise-quadratic cost in the piece of the C engine's solution; its "
          "regulariser differs from the backend's by O(1 − d) of a stiff row's share",
    tolerance=fraction("stop", SOLVER_PART_UNCERTAINTY),
    over_runs=over_runs,
    at_states=at_states,
    baseline=True,
    states=states,
)

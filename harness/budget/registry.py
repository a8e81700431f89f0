"""The one list of the budget's parts, and the tolerances no part removes. The runs' budgets
(:mod:`harness.families.runs`) and the sampled states' (:mod:`harness.families.sampled`) both estimate their parts
and tolerances from this list; adding a part is one module of :mod:`harness.budget` with its ``PART``, added here."""

from __future__ import annotations

from collections.abc import Mapping

from harness.budget import convergence, floors, integration, margin, reference, roundoff, softness, solver, stop
from harness.budget.inputs import Runs, States
from harness.budget.part import Estimates, Part
from harness.core.deviation import Deviation

__all__ = ["ALL", "PARTS", "TOLERANCES", "at_states", "over_runs", "tolerances"]

ALL: tuple[Part, ...] = (integration.PART, softness.PART, floors.PART, margin.PART, solver.PART, stop.PART)
"""Every part, in the order the reports show them."""
PARTS = tuple(p.name for p in ALL)
UNREMOVED = (roundoff.NAME, reference.NAME, convergence.NAME)
"""The tolerances no part removes: what every estimate carries."""
TOLERANCES = (*PARTS, *UNREMOVED)

_ESTIMATED = tuple(sorted(ALL, key=lambda p: not p.baseline))  # the baseline parts first: the others read their run
OVER_RUNS = tuple(p for p in _ESTIMATED if p.over_runs is not None)
"""The parts of a run's budget, in the order they are estimated."""
AT_STATES = tuple(p for p in _ESTIMATED if p.at_states is not None)
"""The parts of the sampled states' budget, in the order they are estimated."""


def over_runs(runs: Runs, dev: Deviation, *, kappa: float) -> Estimates:
    """One figure's parts over one integrator's runs (κ: the Richardson factor of its order)."""
    estimates = Estimates(dev, dev.values)
    for part in OVER_RUNS:
        assert part.over_runs is not None
        part.over_runs(runs, estimates, kappa)
    return estimates


def at_states(states: States, dev: Deviation) -> Estimates:
    """One figure's parts at the sampled states."""
    estimates = Estimates(dev, dev.values)
    for part in AT_STATES:
        assert part.at_states is not None
        part.at_states(states, estimates)
    return estimates


def tolerances(estimates: Estimates, explained: Mapping[str, float], *, runs: bool) -> dict[str, float]:
    """The tolerance of each part of a run's budget (``runs``) or of the sampled states', in the order of
    :data:`ALL` (the limit sums them in that order)."""
    return {p.name: p.tolerance(estimates, explained) for p in ALL
            if (p.over_runs if runs else p.at_states) is not None}

"""The ``floors`` part: a point mass's tiny rotational inertia (MuJoCo needs some), from the model with it doubled,
linear in the inertia."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from harness.budget.inputs import Runs, States, by_name
from harness.budget.part import Estimates, Evaluating, Making, Part, fraction
from harness.core.figures import FigureName
from harness.engine import variants as V

__all__ = ["FLOOR_UNCERTAINTY", "PART", "Pair"]

FLOOR_UNCERTAINTY = 0.1
"""A point mass's floor inertia (at most 1e-6 m L²) acts linearly: a tenth of the floors' part bounds the rest."""


def runs(making: Making) -> dict[str, np.ndarray] | None:
    """D − A per figure measure: the point masses' floors doubled (both runs without fluid forces where the model
    has them: :func:`~harness.engine.variants.floors_pair`); made once with the most accurate integrator (a floor
    moves an explicit integrator's error too: a ball joint's spin carries the floor alone) and shared by every
    integrator (:attr:`Part.shared_runs`): a floor is physics, not integration. None without point masses."""
    bodies = making.variants.point_masses
    if not bodies:
        return None
    lighter, more = V.floors_pair(making.model, bodies)
    heavier = making.run(more)
    as_is = {d.name.measure: d.values for d in making.run(lighter)}
    return {d.name.measure: d.values - as_is[d.name.measure] for d in heavier}


def over_runs(runs: Runs, estimates: Estimates, kappa: float) -> None:
    """D − A, run once and shared by the integrators (:func:`runs`)."""
    measure = estimates.dev.name.measure
    floors = runs.own.get("floors")
    if floors is not None and measure in floors:
        estimates.explained["floors"] = floors[measure]


@dataclass(frozen=True)
class Pair:
    """The floors' evaluations at the sampled states: ``heavier`` (the floors doubled) and, where the model has fluid
    forces, ``lighter`` (the base without them, which the part is then taken from instead of A)."""

    heavier: Mapping[FigureName, np.ndarray]
    lighter: Mapping[FigureName, np.ndarray] = field(default_factory=dict)


def states(evaluating: Evaluating) -> Pair | None:
    """The pair (:func:`~harness.engine.variants.floors_pair`) at the states; None without point masses."""
    bodies = evaluating.variants.point_masses
    if not bodies:
        return None
    base, more = V.floors_pair(evaluating.model, bodies)
    return Pair(by_name(evaluating.at(more)), by_name(evaluating.at(base)) if base is not None else {})


def at_states(states: States, estimates: Estimates) -> None:
    """D − A (or D − the lighter base, both without fluid forces)."""
    name = estimates.dev.name
    pair = states.own.get("floors")
    if pair is not None and name in pair.heavier:
        estimates.explained["floors"] = pair.heavier[name] - pair.lighter.get(name, estimates.base)


def states_gain(pair: Any, noise: float) -> float:
    """D − A: its two evaluations, each with weight ±1, add 2."""
    return noise + 2.0 if pair.heavier else noise


PART = Part(
    name="floors",
    order=30,
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
    runs=runs,
    shared_runs=True,
    diverged="the budget's run with the point masses' floors doubled",
    runs_gain=2.0,
    states=states,
    states_gain=states_gain,
)

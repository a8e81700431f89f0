"""The ``margin`` part: a contact pair's margin (the contact pushes before it touches), from the sampled states with
every margin doubled, linear in the margin (instantaneous figures only)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from harness.budget.floors import FLOOR_UNCERTAINTY
from harness.budget.inputs import States, by_name
from harness.budget.part import Estimates, Evaluating, Part, adds, fraction
from harness.core.figures import FigureName
from harness.engine import variants as V

__all__ = ["PART"]


def states(evaluating: Evaluating) -> Mapping[FigureName, np.ndarray] | None:
    """The model with every contact margin doubled (:func:`~harness.engine.variants.wider_margins`) at the states;
    None where no margin is set."""
    wider = V.wider_margins(evaluating.model)
    return by_name(evaluating.at(wider)) if wider is not None else None


def at_states(states: States, estimates: Estimates) -> None:
    """A with every margin doubled, minus A."""
    name = estimates.dev.name
    wider = states.own.get("margin", {})
    if name in wider:
        estimates.explained["margin"] = wider[name] - estimates.base


PART = Part(
    name="margin",
    order=40,
    varies="every contact margin, doubled (sampled states only)",
    variant=V.wider_margins,
    explains="a contact pair's `margin`, pushing before it touches",
    must_not_absorb="a contact's softness (the softness part's); a wrong contact geometry",
    uncertainty=FLOOR_UNCERTAINTY,
    basis="the reference acceleration k·(distance − margin) is linear in the margin; the impedance moves with it by "
          "(margin/width)²",
    tolerance=fraction("margin", FLOOR_UNCERTAINTY),
    at_states=at_states,
    states=states,
    states_gain=adds(2.0),
)

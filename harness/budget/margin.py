"""The ``margin`` part: a contact pair's margin (the contact pushes before it touches), from the sampled states with
every margin doubled, linear in the margin (instantaneous figures only)."""

from __future__ import annotations

from harness.budget.floors import FLOOR_UNCERTAINTY
from harness.budget.inputs import States
from harness.budget.part import Estimates, Part, fraction
from harness.engine import variants as V

__all__ = ["PART"]


def at_states(states: States, estimates: Estimates) -> None:
    """A with every margin doubled, minus A."""
    name = estimates.dev.name
    if name in states.wider:
        estimates.explained["margin"] = states.wider[name] - estimates.base


PART = Part(
    name="margin",
    varies="every contact margin, doubled (sampled states only)",
    variant=V.wider_margins,
    explains="a contact pair's `margin`, pushing before it touches",
    must_not_absorb="a contact's softness (the softness part's); a wrong contact geometry",
    uncertainty=FLOOR_UNCERTAINTY,
    basis="the reference acceleration k·(distance − margin) is linear in the margin; the impedance moves with it by "
          "(margin/width)²",
    tolerance=fraction("margin", FLOOR_UNCERTAINTY),
    at_states=at_states,
)

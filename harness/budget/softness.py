"""The ``softness`` part: MuJoCo's soft constraints (solref/solimp), from the model with every constraint's effective
softness scaled (by ½, or by 2 where it is already at MuJoCo's stiffest; or at the near-rigid levels), extrapolated
to the rigid limit; with contacts, plus the part linear in their time constant τ."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from harness.budget.extrapolation import RIGID_GAIN, from_rigid, gain, linearity_note, to_zero
from harness.budget.inputs import Runs, States, by_name
from harness.budget.part import Estimates, Evaluating, Part
from harness.core.figures import FigureName
from harness.engine import variants as V

__all__ = ["PART", "Levels"]

SOFTNESS_UNCERTAINTY = 0.25
"""A softness part from two levels is linear in ε up to relative terms O(ε) and O(h/τ): a quarter of it bounds
them for ε up to 1/4 (harness/families/runs.py)."""


def over_runs(runs: Runs, estimates: Estimates, kappa: float) -> None:
    """The levels brought to h → 0 (each by its own Richardson correction; the integration error taken bilinear in
    h and ε) and extrapolated to ε → 0; with contacts, plus (y(rτ) − y(τ))/(r − 1) (:mod:`harness.families.runs`'
    docstring). Needs the integration part's estimate first. Its runs are the integration ladder's neighbours, made
    with it by :mod:`harness.families.runs` (:class:`~harness.budget.inputs.Runs`' softness fields)."""
    name, a = estimates.dev.name, estimates.base
    integration = estimates.explained["integration"]
    s, r = runs.eps_factor, runs.tc_factor
    if runs.rigid is not None and runs.rigid_ladder:
        ests, uncertainties = [], []
        for level in runs.rigid_ladder:  # Richardson from h/2s and h/4s; its rest bounded by twice the distance
            x, y, z = (by_name(group)[name] for group in level)  # from the one from h/s and h/2s
            first, second = x - kappa * (x - y), y - kappa * (y - z)
            ests.append(second)
            uncertainties.append(2.0 * (first - second))
        ideal, tail = from_rigid([a, *ests])
        estimates.explained["softness"] = a - integration - ideal
        # ideal = 2 x₀(fε) − x₀(2fε): each level's own extrapolation uncertainty enters with its weight
        estimates.uncertainty["softness"] = np.abs(tail) + np.abs(uncertainties[0]) + 2.0 * np.abs(uncertainties[1])
    elif runs.softness and runs.softness_half_step is not None and runs.rigid is not None:
        f = runs.rigid  # E at fε; at 2fε the integration error is linear in ε between fε and ε (bilinear model)
        levels = [a, *(by_name(group)[name] for group in runs.softness)]
        at_f = kappa * (levels[2] - by_name(runs.softness_half_step)[name])
        corrections = [integration, at_f + (integration - at_f) * f / (1.0 - f), at_f]
        ideal, uncertainty = from_rigid([x - c for x, c in zip(levels, corrections, strict=True)])
        estimates.explained["softness"] = levels[0] - corrections[0] - ideal
        estimates.uncertainty["softness"] = np.abs(uncertainty)
    elif runs.softness and runs.softness_half_step is not None:
        levels = [a, *(by_name(group)[name] for group in runs.softness)]
        corrections = [integration, kappa * (levels[1] - by_name(runs.softness_half_step)[name])]
        for k in range(2, len(levels)):  # the integration error is linear in ε (bilinear model)
            corrections.append(corrections[0] + (corrections[1] - corrections[0]) * (s**k - 1.0) / (s - 1.0))
        at_zero_h = [x - c for x, c in zip(levels, corrections, strict=True)]
        ideal, maybe_uncertainty = to_zero(at_zero_h, s)
        softness = at_zero_h[0] - ideal
        softness_unc = None if maybe_uncertainty is None else np.abs(maybe_uncertainty)
        if runs.slower:
            y_tau, unc_tau = to_zero(levels, s)
            y_slow, unc_slow = to_zero([by_name(group)[name] for group in runs.slower], s)
            timeconst = (y_slow - y_tau) / (r - 1.0)
            softness = softness + timeconst
            estimates.timeconst = timeconst
            if softness_unc is not None and unc_tau is not None and unc_slow is not None:
                softness_unc = softness_unc + (r * np.abs(unc_tau) + np.abs(unc_slow)) / (r - 1.0)
        estimates.explained["softness"] = softness
        if softness_unc is not None:
            estimates.uncertainty["softness"] = softness_unc
    if runs.rigid is not None and runs.stiffest is not None and len(runs.softness) == 2 \
            and not runs.rigid_ladder and not runs.rigid_unresolved:  # at h: only inside the asymptotic range
        said = linearity_note(estimates.dev.magnitude, by_name(runs.softness[0])[name],
                              by_name(runs.softness[1])[name], by_name(runs.stiffest)[name])
        if said:
            estimates.notes.append(said)


@dataclass(frozen=True)
class Levels:
    """The softness's evaluations at the sampled states: the softer levels (every ε × s, s²; or the near-rigid 2fε
    and fε with ``rigid``), each figure's values by name; ``eps_factor``: s; ``lowest``: with ``rigid``, the model
    at fε/2 (only for :func:`~harness.budget.extrapolation.linearity_note`)."""

    levels: Sequence[Mapping[FigureName, np.ndarray]]
    eps_factor: float = 2.0
    rigid: bool = False
    lowest: Mapping[FigureName, np.ndarray] = field(default_factory=dict)


def states(evaluating: Evaluating) -> Levels | None:
    """Every ε × s (and s²; :func:`~harness.engine.variants.softness_factor`), or the near-rigid 2fε and fε and fε/2
    (:func:`~harness.engine.variants.rigid_factor`), at the states; None without soft constraints."""
    if not evaluating.variants.soft:
        return None
    model = evaluating.model
    eps_factor = V.softness_factor(model)
    rigid = V.rigid_factor(model)
    levels = (2.0 * rigid, rigid) if rigid is not None else (eps_factor, eps_factor**2) if eps_factor < 1 \
        else (eps_factor,)
    at = tuple(by_name(evaluating.at(V.variant(model, eps_factor=f))) for f in levels)
    lowest = by_name(evaluating.at(V.variant(model, eps_factor=rigid / 2.0))) if rigid is not None else {}
    return Levels(at, eps_factor, rigid is not None, lowest)  # fε/2: 1e-4 (the cap)


def at_states(states: States, estimates: Estimates) -> None:
    """A minus the levels extrapolated to ε → 0 (from the near-rigid levels, or linearly from two, quadratically
    from three)."""
    own = states.own.get("softness")
    if own is None or not own.levels:
        return
    name, a = estimates.dev.name, estimates.base
    at = [a, *(level[name] for level in own.levels)]
    ideal, uncertainty = from_rigid(at) if own.rigid else to_zero(at, own.eps_factor)
    estimates.explained["softness"] = a - ideal
    if uncertainty is not None:
        estimates.uncertainty["softness"] = uncertainty
    if own.rigid and len(own.levels) == 2 and name in own.lowest:
        said = linearity_note(estimates.dev.magnitude, own.levels[0][name], own.levels[1][name], own.lowest[name])
        if said:
            estimates.notes.append(said)


def states_gain(own: Any, noise: float) -> float:
    """The extrapolation's Σ |w| in place of A's own 1 (A is its first level)."""
    if not own.levels:
        return noise
    return noise - 1.0 + (RIGID_GAIN if own.rigid else gain(len(own.levels) + 1, own.eps_factor))


def tolerance(estimates: Estimates, explained: Mapping[str, float]) -> float:
    """Measured where it is (a third level, the near-rigid tail), plus :data:`SOFTNESS_UNCERTAINTY` of the contacts'
    τ share; else :data:`SOFTNESS_UNCERTAINTY` of the part."""
    measured = estimates.uncertainty.get("softness")
    if measured is None:
        return SOFTNESS_UNCERTAINTY * explained.get("softness", 0.0)
    found = estimates.dev.magnitude(measured)
    if estimates.timeconst is not None:
        found += SOFTNESS_UNCERTAINTY * estimates.dev.magnitude(estimates.timeconst)
    return found


PART = Part(
    name="softness",
    order=20,
    varies="every constraint's effective ε = 1 − d (× ½, or × 2 at the stiffest; or the near-rigid 2fε and "
           "fε), and with contacts their τ (× 1.5)",
    variant=V.variant,
    explains="`solref`/`solimp`: constraints that give a little",
    must_not_absorb="the integration error at each level (the cross term is counted once, in the integration part); a "
                    "spring or damping the reference lacks",
    uncertainty=SOFTNESS_UNCERTAINTY,
    basis="two levels are linear in ε up to relative terms O(ε) and O(h/τ); three: the distance between the quadratic "
          "and the linear estimate; near-rigid: the whole tail beyond fε (RIGID_TAIL)",
    tolerance=tolerance,
    over_runs=over_runs,
    at_states=at_states,
    states=states,
    states_gain=states_gain,
)

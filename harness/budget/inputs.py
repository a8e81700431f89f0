"""What a figure's budget is estimated from: one integrator's runs of the model and its variants (:class:`Runs`,
made by :mod:`harness.families.runs`), or the variants evaluated at the sampled states (:class:`States`, made by
:mod:`harness.families.sampled`), each as deviations from the reference. The parts
(:mod:`harness.budget.registry`) read them: what they share (the model as it is, the integration ladder with the
softness levels on it, the baseline solves, the round-off copies) by its field, and each part's own runs and
evaluations, which it makes itself (:attr:`harness.budget.part.Part.runs`, ``states``), under its name in
``own``."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from harness.core.deviation import Deviation
from harness.core.figures import FigureName

__all__ = ["Runs", "States", "by_name"]


def by_name(group: Sequence[Deviation] | None) -> dict[FigureName, np.ndarray]:
    """Each deviation's values by its figure's name (none for None)."""
    return {d.name: d.values for d in group or ()}


@dataclass(frozen=True)
class Runs:
    """One integrator's runs of the model (:mod:`harness.families.runs`' docstring), each as its deviations from the
    reference on the grid of the run at h.

    Attributes:
        as_is: A (h, ε, τ).
        half_step: B (h/2).
        quarter_step: h/4, only past the asymptotic range.
        softness: at h with ε × s (C) and, where ε is not at the stiffest, also × s² (C₂).
        softness_half_step: E (h/2, ε × s).
        slower: with contacts, at h with τ × r and ε, ε × s (and ε × s²): C′, C″ (and C‴).
        converged: where the model's own constraint solver does not converge (CG, PGS, a loose
            tolerance), A with the constraints solved exactly (Newton); every other run is then made
            that way too, and A − converged is the ``solver`` part.
        perturbed: on a float32 backend, :data:`~harness.budget.roundoff.PERTURBED_RUNS` copies of A from
            its masses an ulp or two away (:func:`~harness.engine.variants.roundoff_copy`): their
            spread measures A's round-off (empty on float64, where :data:`harness.families.runs.ROUNDOFF` applies).
        represented: on a float32 backend, each figure's shift (by measure) with the model's constants and
            the initial state held in float32 (:func:`harness.families.runs._represented`): what every copy
            shares, so none measures it.
        quantized: on a float32 backend, each figure's response (by measure) to the initial state moved by
            half an ulp, on the C engine (:func:`harness.families.runs._quantized`): ×
            :data:`~harness.budget.roundoff.QUANTIZATION`, the state's own quantization.
        completed: on a float32 backend with constraints, A with each sample's stopped solve completed in
            float64 (:attr:`harness.core.trajectory.Trajectory.completed`); every other run is then taken
            completed too, and A − completed is the ``stop`` part.
        eps_factor, tc_factor: s and r.
        rigid: f where the softness levels are the near-rigid 2fε and fε, and E is at fε
            (:func:`~harness.engine.variants.rigid_factor`); None where they are sε (and s²ε).
        rigid_ladder: where the near-rigid levels' runs at h, h/2 and h/4 are outside the integrator's
            asymptotic range (:func:`harness.families.runs.rigid_resolved`), each level (2fε, then fε) at the
            first h/s, h/2s, h/4s (s = 4, 16, 64) that is inside it: their value at h → 0 is taken from there
            (:mod:`harness.budget.softness`); ``rigid_split`` is that s. ``rigid_unresolved``: why no s down to
            :data:`harness.families.runs.RIGID_SPLITS`' last is (the integrator's figures then fail with that
            reason: :func:`harness.families.runs.unresolved`).
        stiffest: with ``rigid``, the run at h at fε/2 (the smallest ε at MuJoCo's stiffest): not in any part,
            only to say where the softness is not linear down there
            (:func:`~harness.budget.extrapolation.linearity_note`), from the levels at h where those are inside
            the asymptotic range (elsewhere their differences at h are the integrator's as much as the
            softness's).
        own: each part's own runs (:attr:`harness.budget.part.Part.runs`), by the part's name, where it has any
            for this model: the floors' D − A per figure (:attr:`FigureName.measure`, shared by the integrators:
            a point mass's floor is physics, not integration), a new part's runs.
    """

    as_is: Sequence[Deviation]
    half_step: Sequence[Deviation]
    quarter_step: Sequence[Deviation] | None = None
    softness: Sequence[Sequence[Deviation]] = ()
    softness_half_step: Sequence[Deviation] | None = None
    slower: Sequence[Sequence[Deviation]] = ()
    converged: Sequence[Deviation] | None = None
    perturbed: Sequence[Sequence[Deviation]] = ()
    represented: Mapping[str, float] = field(default_factory=dict)
    quantized: Mapping[str, float] = field(default_factory=dict)
    eps_factor: float = 2.0
    tc_factor: float = 1.5
    completed: Sequence[Deviation] | None = None
    rigid: float | None = None
    rigid_ladder: Sequence[Sequence[Sequence[Deviation]]] = ()
    rigid_split: int = 1
    rigid_unresolved: str = ""
    stiffest: Sequence[Deviation] | None = None
    own: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class States:
    """The variants evaluated at the sampled states beside the model as it is, each part's own by its name
    (:attr:`harness.budget.part.Part.states`), and the round-off copies' evaluations.

    Attributes:
        own: each part's evaluations where they apply, by the part's name, as its module makes and reads them
            (the softness's levels, the floors' pair, the converged or completed solve, the wider margins:
            each figure's values by name, :func:`by_name`).
        perturbed: on a float32 backend (and on the C engine where the model has constraints), the figures from
            the round-off copies of the model at the same states
            (:attr:`harness.families.sampled.Evaluation.perturbed`).
        represented: on a float32 backend, each figure's shift with the model's constants and the states held in
            float32 (:attr:`harness.families.sampled.Evaluation.represented`).
    """

    own: Mapping[str, Any] = field(default_factory=dict)
    perturbed: Sequence[Sequence[Deviation]] = ()
    represented: Mapping[FigureName, float] = field(default_factory=dict)

"""A budget part: one setting of the model that moves a figure, and how much of the figure it explains.

A :class:`Part` says what it varies, how its variant is made (the spec edit of :mod:`harness.engine.variants`, or
None for a part estimated without a variant of the model), how its variant's runs and evaluations at the sampled
states are made (:attr:`Part.runs`, :attr:`Part.states`: from what :class:`Making` and :class:`Evaluating` hand it),
how its size is estimated from them (over the runs, at the sampled states, or both: :mod:`harness.budget.inputs`,
where they come back as ``own[name]``), how they weigh in the noise gain, the uncertainty of that estimate with
its basis, and, for the docs and the tests, what it may explain and what it must not absorb. Each part is a module
of :mod:`harness.budget` with its ``PART``; :mod:`harness.budget.registry` finds them.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from harness.budget.inputs import Runs, States
from harness.core.deviation import Deviation

__all__ = ["Estimates", "Evaluating", "Making", "Part", "adds", "fraction"]


@dataclass
class Estimates:
    """One figure's parts as the parts estimate them, in order (a working record, filled part by part).

    Attributes:
        dev: the figure (MuJoCo's model as it is against the reference).
        base: the values the parts are taken from: ``dev.values``, or where a part whose variant every other
            variant is made with applies (:attr:`Part.baseline`: the converged or completed solve), that run's.
        explained: each part's size, sample by sample, by name.
        uncertainty: a part's uncertainty where it is measured (the integration's from the run at h/4, the
            softness's from a third level), sample by sample, by name; absent where only theory bounds it.
        timeconst: the contacts' τ share of the softness part (inside ``explained["softness"]``), or None.
        notes: what a part has to say about this figure's estimate (a line each, after the budget's own notes).
    """

    dev: Deviation
    base: np.ndarray
    explained: dict[str, np.ndarray] = field(default_factory=dict)
    uncertainty: dict[str, np.ndarray] = field(default_factory=dict)
    timeconst: np.ndarray | None = None
    notes: list[str] = field(default_factory=list)


OverRuns = Callable[[Runs, Estimates, float], None]
"""A part's estimate over one integrator's runs: reads the runs (and κ, the Richardson factor of the integrator's
order), writes its size (and a measured uncertainty) into the estimates; writes nothing where it does not apply."""
AtStates = Callable[[States, Estimates], None]
"""A part's estimate at the sampled states, as :data:`OverRuns` is over the runs."""
Tolerance = Callable[[Estimates, Mapping[str, float]], float]
"""A part's tolerance in the figure's unit, from its estimates and the parts' sizes as the figure is reduced."""


@dataclass(frozen=True)
class Making:
    """What a part's runs are made with (:attr:`Part.runs`), by :mod:`harness.families.runs`: one integrator's, or
    with :attr:`Part.shared_runs` once for every integrator (with the most accurate one).

    Attributes:
        model: the model under test, compiled with that integrator (read its settings, make its edit from it).
        run: the model with a spec edit (None: none) run over the horizon from the case's initial state, as its
            deviations from the reference on the grid of the run at h; made with the baseline parts' variant too
            (the converged solve where the model's own does not converge) and taken completed where a float32
            backend's solve stopped, as every variant run is (:attr:`Part.baseline`).
        variants: which variants the model has (:class:`harness.engine.variants.Variants`).
    """

    model: Any
    run: Callable[[Callable[..., None] | None], Sequence[Deviation]]
    variants: Any


@dataclass(frozen=True)
class Evaluating:
    """What a part's evaluations at the sampled states are made with (:attr:`Part.states`), by
    :mod:`harness.families.sampled`.

    Attributes:
        model: the model under test as compiled.
        at: the model with a spec edit (None: none) evaluated at the sampled states, as its deviations from the
            reference, made with the baseline parts' variant too and taken completed on a float32 backend.
        variants: which variants the model has (:class:`harness.engine.variants.Variants`).
        exact: the edit that solves the constraints exactly where the model's own solver does not converge, or None.
        completed: on a float32 backend, the model as it is with its stopped solves completed, or None.
    """

    model: Any
    at: Callable[[Callable[..., None] | None], Sequence[Deviation]]
    variants: Any
    exact: Callable[..., None] | None = None
    completed: Sequence[Deviation] | None = None


MakeRuns = Callable[[Making], Any]
"""A part's runs: made from :class:`Making`, its record (handed back as ``Runs.own[name]``), or None where it does
not apply to the model. Runs of the model are lists of deviations (:attr:`Making.run`'s), alone or in tuples: the
noise gain weighs each such run by linearity (:func:`harness.families.runs.noise_gain`)."""
MakeStates = Callable[[Evaluating], Any]
"""A part's evaluations at the sampled states: made from :class:`Evaluating`, its record (handed back as
``States.own[name]``), or None where it does not apply."""
GainAtStates = Callable[[Any, float], float]
"""The noise gain of the sampled states' estimate with a part's evaluations counted (its record, the gain so far,
from A's own 1): Σ |w| of the evaluations' weights. A part taken as a difference from A adds 2."""


@dataclass(frozen=True)
class Part:
    """One part of the error budget.

    Attributes:
        name: its key in :attr:`harness.core.budget.Budget.explained` and ``tolerance``, and of its own runs and
            evaluations in :attr:`harness.budget.inputs.Runs.own` and :attr:`harness.budget.inputs.States.own`.
        order: where the reports show it (and its tolerance), the smallest first.
        varies: what setting of the model it varies, in words.
        variant: how the variant is made: the :mod:`harness.engine.variants` function that edits the model, or
            None where the part needs no variant of the model.
        explains: what it may explain (the docs' words).
        must_not_absorb: what moves with its variant but is not its to explain (the docs' words): a part explains
            only what it names.
        uncertainty: the estimate's uncertainty as theory bounds it, a fraction of the part.
        basis: why that fraction (or what measures the uncertainty instead).
        tolerance: the part's tolerance from its estimates (``uncertainty`` × its size, or what is measured).
        over_runs: its estimate over the runs (None: not a part of a run's budget).
        at_states: its estimate at the sampled states (None: not a part of their budget).
        baseline: every other variant is made with this part's variant too (a converged or completed solve), so
            it is estimated first and the others are taken from its run. The runs' baseline variants are made by
            :mod:`harness.families.runs` itself (each other run is made with them), as is the integration ladder
            (h, h/2, h/4) with the softness levels on it; every other part makes its own with :attr:`runs`.
        runs: how its variant runs are made (:data:`MakeRuns`), for one integrator at a time; None: it has none
            of its own (or they are the shared ones above).
        shared_runs: its runs are made once, with the most accurate integrator, and shared by every integrator
            (physics, not integration: a point mass's floor).
        diverged: where its shared runs diverge, the words every integrator's figures then fail with, before why.
        runs_gain: what its runs add to the runs' noise gain beyond the runs weighed by linearity (a difference
            of two runs made elsewhere, kept as numbers: 2).
        states: how its evaluations at the sampled states are made (:data:`MakeStates`); None: none.
        states_gain: their weight in the sampled states' noise gain (:data:`GainAtStates`); None: none.
    """

    name: str
    order: int
    varies: str
    variant: Callable[..., object] | None
    explains: str
    must_not_absorb: str
    uncertainty: float
    basis: str
    tolerance: Tolerance
    over_runs: OverRuns | None = None
    at_states: AtStates | None = None
    baseline: bool = False
    runs: MakeRuns | None = None
    shared_runs: bool = False
    diverged: str = ""
    runs_gain: float = 0.0
    states: MakeStates | None = None
    states_gain: GainAtStates | None = None


def adds(weight: float) -> GainAtStates:
    """The :data:`GainAtStates` of a part whose evaluations enter with total weight ``weight`` (D − A: 2); an empty
    record (nothing evaluated) weighs nothing."""
    def gain(own: Any, noise: float) -> float:
        return noise + weight if own else noise

    return gain


def fraction(name: str, uncertainty: float) -> Tolerance:
    """The tolerance of a part known to ``uncertainty`` of itself (theory only, nothing measured)."""
    def tolerance(estimates: Estimates, explained: Mapping[str, float]) -> float:
        return uncertainty * explained.get(name, 0.0)

    return tolerance

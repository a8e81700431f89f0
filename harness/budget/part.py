"""A budget part: one setting of the model that moves a figure, and how much of the figure it explains.

A :class:`Part` says what it varies, how its variant is made (the spec edit of :mod:`harness.engine.variants`, or
None for a part estimated without a variant of the model), how its size is estimated from the variants' results
(over the runs, at the sampled states, or both: :mod:`harness.budget.inputs`), the uncertainty of that estimate
with its basis, and, for the docs and the tests, what it may explain and what it must not absorb. Each part is a
module of :mod:`harness.budget`; the one list of them is :mod:`harness.budget.registry`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from harness.budget.inputs import Runs, States
from harness.core.deviation import Deviation

__all__ = ["Estimates", "Part", "fraction"]


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
    """

    dev: Deviation
    base: np.ndarray
    explained: dict[str, np.ndarray] = field(default_factory=dict)
    uncertainty: dict[str, np.ndarray] = field(default_factory=dict)
    timeconst: np.ndarray | None = None


OverRuns = Callable[[Runs, Estimates, float], None]
"""A part's estimate over one integrator's runs: reads the runs (and κ, the Richardson factor of the integrator's
order), writes its size (and a measured uncertainty) into the estimates; writes nothing where it does not apply."""
AtStates = Callable[[States, Estimates], None]
"""A part's estimate at the sampled states, as :data:`OverRuns` is over the runs."""
Tolerance = Callable[[Estimates, Mapping[str, float]], float]
"""A part's tolerance in the figure's unit, from its estimates and the parts' sizes as the figure is reduced."""


@dataclass(frozen=True)
class Part:
    """One part of the error budget.

    Attributes:
        name: its key in :attr:`harness.core.budget.Budget.explained` and ``tolerance``.
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
            it is estimated first and the others are taken from its run.
    """

    name: str
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


def fraction(name: str, uncertainty: float) -> Tolerance:
    """The tolerance of a part known to ``uncertainty`` of itself (theory only, nothing measured)."""
    def tolerance(estimates: Estimates, explained: Mapping[str, float]) -> float:
        return uncertainty * explained.get(name, 0.0)

    return tolerance

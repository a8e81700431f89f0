"""The budget's parts, found, and the tolerances no part removes. Every module of :mod:`harness.budget` with a
``PART`` (a :class:`~harness.budget.part.Part`) is a part, shown in the order of its :attr:`~Part.order`; nothing
lists them by hand. The runs' budgets (:mod:`harness.families.runs`) and the sampled states' budgets
(:mod:`harness.families.sampled`) both make each part's own runs and evaluations, hand them back under its name,
and estimate its size and tolerance from this list: adding a part is one module of :mod:`harness.budget` (and its
tests)."""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Iterable, Mapping

from harness.budget import convergence, reference, roundoff
from harness.budget.inputs import Runs, States
from harness.budget.part import Estimates, Part
from harness.core.deviation import Deviation

__all__ = ["ALL", "PARTS", "TOLERANCES", "at_states", "over_runs", "tolerances"]

PACKAGE = "harness.budget"


def discover(paths: Iterable[str] | None = None) -> tuple[Part, ...]:
    """The ``PART`` of every module of :mod:`harness.budget` (its ``__path__``, or ``paths``), by
    :attr:`~harness.budget.part.Part.order` (two parts of one order, or of one name, are refused)."""
    if paths is None:
        paths = importlib.import_module(PACKAGE).__path__  # lazy: this module is imported by the package's own
    found = []
    for info in sorted(pkgutil.iter_modules(list(paths)), key=lambda i: i.name):
        if info.ispkg or info.name.startswith("_"):
            continue
        part = getattr(importlib.import_module(f"{PACKAGE}.{info.name}"), "PART", None)
        if isinstance(part, Part):
            found.append(part)
    for key in ("order", "name"):
        values = [getattr(p, key) for p in found]
        if len(set(values)) != len(values):
            raise ValueError(f"budget parts share an {key}: {sorted(map(str, values))}")
    return tuple(sorted(found, key=lambda p: p.order))


def lists(parts: tuple[Part, ...]) -> dict[str, tuple]:
    """What this module derives from the parts (:data:`ALL` and the lists after it), by name."""
    names = tuple(p.name for p in parts)
    estimated = tuple(sorted(parts, key=lambda p: not p.baseline))  # the baseline parts first: the others read theirs
    return {"ALL": parts, "PARTS": names, "TOLERANCES": (*names, *UNREMOVED),
            "OVER_RUNS": tuple(p for p in estimated if p.over_runs is not None),
            "AT_STATES": tuple(p for p in estimated if p.at_states is not None)}


UNREMOVED = (roundoff.NAME, reference.NAME, convergence.NAME)
"""The tolerances no part removes: what every estimate carries."""
_LISTS = lists(discover())
ALL: tuple[Part, ...] = _LISTS["ALL"]
"""Every part, in the order the reports show them."""
PARTS: tuple[str, ...] = _LISTS["PARTS"]
TOLERANCES: tuple[str, ...] = _LISTS["TOLERANCES"]
OVER_RUNS: tuple[Part, ...] = _LISTS["OVER_RUNS"]
"""The parts of a run's budget, in the order they are estimated."""
AT_STATES: tuple[Part, ...] = _LISTS["AT_STATES"]
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

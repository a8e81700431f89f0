"""What the harness checks: one module per family of figures, each declaring its figures' names, how it measures
them and their budget (or their limit from theory).

==============  ======================================  =============================================
family          figures                                 measured on
==============  ======================================  =============================================
instant         ``instant.QUANTITY[.CONSTRAINT]``       the sampled states (:mod:`.sampled`)
reactions       ``instant.sensor.*``, ``.interaction.*``  the sampled states
peers           ``instant.peer.*``                      MuJoCo, the tree and Pinocchio at states
reference       ``reference.*``                         the reference's own solution
trajectory      ``INTEGRATOR.position`` … ``series.*``  each integrator's run (:mod:`.runs`)
invariants      ``INTEGRATOR.drift.*``, ``.energy`` …   each integrator's run
convergence     ``converge.INTEGRATOR.order_shortfall``  ladders of runs at several timesteps
balance         ``INTEGRATOR.balance``                  the model as it is, every force acting
==============  ======================================  =============================================

A family is a module with ``NAME``, ``owns(name)``, ``names(case, model)``, ``gated(name, constrained=)``,
``theory_limit(name)`` and ``measure(bench)`` (:class:`~harness.families.bench.Family`); one that compares at the
sampled states or over runs also has ``compare``, which the shared measurements call for every state or run
(:data:`COMPARISONS`). The run (:func:`harness.pipeline.run.run_case`) is a loop over :data:`FAMILIES` on one
:class:`~harness.families.bench.Bench`.
"""

from __future__ import annotations

import mujoco

from harness.cases import Case
from harness.core.checks import Limit
from harness.core.figures import FigureName
from harness.engine.models import compile_model
from harness.families import (
    balance,
    convergence,
    instant,
    invariants,
    peers,
    reactions,
    reference,
    trajectory,
)
from harness.families.bench import Comparisons, Family

__all__ = ["COMPARISONS", "FAMILIES", "figure_names", "gated", "theory_limit"]

FAMILIES: tuple[Family, ...] = (instant, reactions, peers, reference, trajectory, invariants, convergence, balance)
"""Every family, in the order a case is measured and its figures are listed."""

COMPARISONS = Comparisons(at_states=(instant.compare, reactions.compare),
                          over_runs=(trajectory.compare, invariants.compare))
"""What the shared measurements compare: at the sampled states, over every run (variants included)."""


def family_of(name: FigureName) -> Family:
    """The family whose figure ``name`` is."""
    for family in FAMILIES:
        if family.owns(name):
            return family
    raise ValueError(f"figure {name!r} belongs to no family")  # every name FigureName parses has one


def figure_names(case: Case, model: mujoco.MjModel | None = None) -> frozenset[str]:
    """Every figure name a run can give ``case``, known without running it (no derivation, no sympy): a superset
    (a figure a case lacks on every MuJoCo, e.g. ``instant.forcing`` of a ball joint, is in it); ``model``: its
    shipped model, compiled (default: compiled here)."""
    model = model if model is not None else compile_model(case.mjcf)
    return frozenset(str(n) for family in FAMILIES for n in family.names(case, model))


def gated(name: FigureName, *, constrained: bool) -> bool:
    """Which figures a case without a limits file gates: its family's rule."""
    return family_of(name).gated(name, constrained=constrained)


def theory_limit(name: FigureName) -> Limit | None:
    """The limit theory sets for the figure ``name`` whatever the case (None where its budget judges it)."""
    return family_of(name).theory_limit(name)

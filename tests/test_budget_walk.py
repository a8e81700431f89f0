"""The walk "add a budget part" (docs/design.md): a part is one module of harness.budget with its ``PART``, and
nothing else is edited. A toy part, written as a module into a folder put on the budget package's path (the same
discovery every shipped part goes through: harness.budget.registry.discover), with a variant of its own: its runs
are made for each integrator and its evaluations at the sampled states, its estimate and tolerance show in the
budgets, its runs weigh in the noise gain, and taking it away leaves every budget as it was."""

from __future__ import annotations

import sys

import pytest

import harness.budget
from harness import cases
from harness.budget import registry
from harness.core.options import RunOptions

TOY = '''
"""A toy part: the gravity made 0.1 % stronger (a test's, tests/test_budget_walk.py)."""

from __future__ import annotations

from dataclasses import dataclass

from harness.budget.inputs import Runs, States, by_name
from harness.budget.part import Estimates, Evaluating, Making, Part, adds, fraction

CALLS = {"runs": [], "states": 0}


@dataclass(frozen=True)
class Stronger:
    """The spec edit: gravity × 1.001 (a value, so the variant is compiled once)."""

    def __call__(self, spec) -> None:
        spec.option.gravity = [1.001 * g for g in spec.option.gravity]


def runs(making: Making):
    CALLS["runs"].append(making.model.opt.integrator)
    return making.run(Stronger())


def over_runs(runs: Runs, estimates: Estimates, kappa: float) -> None:
    if "toy" in runs.own:
        estimates.explained["toy"] = by_name(runs.own["toy"])[estimates.dev.name] - estimates.base


def states(evaluating: Evaluating):
    CALLS["states"] += 1
    return by_name(evaluating.at(Stronger()))


def at_states(states: States, estimates: Estimates) -> None:
    own = states.own.get("toy", {})
    if estimates.dev.name in own:
        estimates.explained["toy"] = own[estimates.dev.name] - estimates.base


PART = Part(
    name="toy", order=70, varies="the gravity, 0.1 % stronger", variant=Stronger, explains="a toy's",
    must_not_absorb="anything else", uncertainty=0.5, basis="a test's", tolerance=fraction("toy", 0.5),
    over_runs=over_runs, at_states=at_states, runs=runs, states=states, states_gain=adds(2.0))
'''


def _budgets() -> tuple[dict, dict]:
    from harness.families import COMPARISONS
    from harness.families.bench import Bench

    bench = Bench(cases.get("pendulum"), RunOptions(integrators=("RK4",)), COMPARISONS)
    return dict(bench.run_budgets.budgets), dict(bench.sampled.budgets)


def _with_toy(tmp_path, monkeypatch, text: str = TOY) -> None:
    """The toy module in a folder on harness.budget's path, and the registry's lists as discovery now finds them."""
    (tmp_path / "toy.py").write_text(text, encoding="utf-8")
    monkeypatch.setattr(harness.budget, "__path__", [*harness.budget.__path__, str(tmp_path)])
    monkeypatch.delitem(sys.modules, "harness.budget.toy", raising=False)
    for key, value in registry.lists(registry.discover()).items():
        monkeypatch.setattr(registry, key, value)


def test_a_new_part_is_one_module(tmp_path, monkeypatch):
    """The toy part, one module and nothing else: discovered after the shipped parts (by its order), run once for
    the one integrator and evaluated once at the states, in every budget's explained parts and tolerances (its own
    estimate, nonzero where gravity moves the figure), its runs weighed in the noise gain (the round-off and
    convergence tolerances grow), every other part's estimate and tolerance untouched; and without it, the
    budgets exactly as before."""
    runs_before, states_before = _budgets()
    _with_toy(tmp_path, monkeypatch)
    assert registry.PARTS[-1] == "toy" and registry.PARTS[:-1] == tuple(p.name for p in harness.budget.ALL)
    assert registry.TOLERANCES.index("toy") == len(harness.budget.PARTS)  # before the three no part removes
    toy = sys.modules["harness.budget.toy"]
    runs_with, states_with = _budgets()
    assert len(toy.CALLS["runs"]) == 1 and toy.CALLS["states"] == 1
    for before, after in ((runs_before, runs_with), (states_before, states_with)):
        assert set(before) == set(after) and before
        for name, budget in after.items():
            old = before[name]
            assert "toy" in budget.explained and "toy" in budget.tolerance, name
            kept = [k for k in old.tolerance if k not in registry.UNREMOVED]
            assert list(budget.tolerance) == [*kept, "toy", *[k for k in old.tolerance if k not in kept]], name
            assert {k: v for k, v in budget.explained.items() if k != "toy"} == old.explained, name
            for key, value in old.tolerance.items():
                if key in ("roundoff", "convergence"):  # × the noise gain, which now counts the toy's runs
                    assert value == 0.0 or budget.tolerance[key] > value, (name, key)
                else:
                    assert budget.tolerance[key] == value, (name, key)
        assert sum(budget.explained["toy"] > 0 for budget in after.values()) >= 2  # kinematics ignore gravity
    monkeypatch.undo()
    assert "toy" not in registry.PARTS
    runs_after, states_after = _budgets()
    assert runs_after == runs_before and states_after == states_before


def test_discovery_refuses_two_parts_of_one_order(tmp_path, monkeypatch):
    """The report order is each part's declared order: a module whose part takes a shipped part's order is refused,
    naming the order, rather than shown in an order nobody chose."""
    with pytest.raises(ValueError, match="share an order"):
        _with_toy(tmp_path, monkeypatch, TOY.replace("order=70", "order=10"))

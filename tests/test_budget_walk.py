"""The walk "add a budget part" (docs/design.md): a part is one module of harness.budget with its ``PART``, and
nothing else is edited. A toy part, written as a module into a folder put on the budget package's path (the same
discovery every shipped part goes through: harness.budget.registry.discover), with a variant of its own: its runs
are made for each integrator and its evaluations at the sampled states, its estimate and tolerance show in the
budgets, its runs weigh in the noise gain, and taking it away leaves every budget as it was."""

from __future__ import annotations

import sys

import numpy as np
import pytest

import harness.budget
from harness import cases
from harness.budget import registry
from harness.budget.part import adds
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
        if hasattr(harness.budget, key):  # the package's names of them too
            monkeypatch.setattr(harness.budget, key, value)


def test_a_new_part_is_one_module(tmp_path, monkeypatch):
    """The toy part, one module and nothing else: discovered after the shipped parts (by its order), run once for
    the one integrator and evaluated once at the states, in every budget's explained parts and tolerances (its own
    estimate, nonzero where gravity moves the figure), its runs weighed in the noise gain (the round-off and
    convergence tolerances grow), every other part's estimate and tolerance untouched; and without it, the
    budgets exactly as before."""
    runs_before, states_before = _budgets()
    shipped = harness.budget.PARTS
    _with_toy(tmp_path, monkeypatch)
    assert registry.PARTS == harness.budget.PARTS == (*shipped, "toy")
    assert (*shipped, "toy", *registry.UNREMOVED) == registry.TOLERANCES
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
    assert registry.PARTS == harness.budget.PARTS == shipped
    runs_after, states_after = _budgets()
    assert runs_after == runs_before and states_after == states_before


def test_a_new_part_without_its_words_in_the_docs_fails_the_docs_test(tmp_path, monkeypatch):
    """The one thing a new part asks beyond its module and tests is its words in the docs (README's and
    docs/design.md's parts tables, the budget line): tests/test_budget_parts.py fails, naming it, until they are
    there."""
    from tests import test_budget_parts

    _with_toy(tmp_path, monkeypatch)
    with pytest.raises(AssertionError, match=r"leaves out parts of the code: \['toy'\]"):
        test_budget_parts.test_the_docs_name_the_parts_the_code_has()
    with pytest.raises(AssertionError):
        test_budget_parts.test_the_docs_words_for_each_part_are_its_fields()


def test_discovery_refuses_two_parts_of_one_order(tmp_path, monkeypatch):
    """The report order is each part's declared order: a module whose part takes a shipped part's order is refused,
    naming the order, rather than shown in an order nobody chose."""
    with pytest.raises(ValueError, match="share an order"):
        _with_toy(tmp_path, monkeypatch, TOY.replace("order=70", "order=10"))


def test_a_new_parts_runs_weigh_in_the_noise_gain(tmp_path, monkeypatch):
    """The runs' noise gain weighs a part's own runs by linearity, with nothing declared: with the toy's D − A beside
    the integration's κ(A − B) (order 4, κ = 16/15), ideal = (2 − κ) A + κ B − D, Σ|w| = 14/15 + 16/15 + 1 = 3;
    without the toy, |1 − κ| + κ = 17/15 (and 2, not 3, were D left unweighed)."""
    import numpy as np

    from harness.core.deviation import Deviation
    from harness.core.figures import FigureName
    from harness.families import runs

    d = [Deviation(FigureName("x.position"), np.array([0.0]), "scalar", "1", "")]
    assert runs.noise_gain(runs.Runs(as_is=d, half_step=d), order=4) == pytest.approx(17 / 15)
    _with_toy(tmp_path, monkeypatch)
    assert runs.noise_gain(runs.Runs(as_is=d, half_step=d, own={"toy": d}), order=4) == pytest.approx(3.0)


def test_a_parts_evaluations_weigh_their_weight_and_an_empty_record_nothing():
    """adds(w): the noise gain grows by w where the part evaluated something (margin's and solver's D − A: 2), by
    nothing where its record is empty."""
    gain = adds(2.0)
    assert gain({"instant.qacc": np.zeros(3)}, 1.0) == 3.0
    assert gain({}, 1.0) == 1.0
    by_part = {part.name: part for part in registry.ALL}
    for name in ("margin", "solver"):
        assert by_part[name].states_gain({"instant.qacc": np.zeros(3)}, 1.0) == 3.0
        assert by_part[name].states_gain({}, 1.0) == 1.0

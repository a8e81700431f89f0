"""The families of figures (harness/families): each a module with the same declarations, every figure a run gives
owned by exactly one family, and the run a loop over them on one bench."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from harness import cases, families
from harness.core.figures import FigureName
from harness.engine.models import compile_model
from tests.conftest import shipped_run

ROOT = Path(__file__).resolve().parent.parent
DECLARED = ("NAME", "owns", "names", "gated", "theory_limit", "measure")


def test_every_family_declares_the_same_things_once():
    assert len({f.NAME for f in families.FAMILIES}) == len(families.FAMILIES)
    for family in families.FAMILIES:
        missing = [d for d in DECLARED if not hasattr(family, d)]
        assert not missing, f"{family.__name__} lacks {missing}"
    compares = {*families.COMPARISONS.at_states, *families.COMPARISONS.over_runs}
    assert compares == {f.compare for f in families.FAMILIES if hasattr(f, "compare")}


@pytest.mark.parametrize("name", ["pendulum", "atwood", "hoop_ramp_contact", "double_pendulum"])
def test_every_figure_of_a_run_is_one_familys_and_named_by_it(name):
    """Each figure a shipped case measures belongs to exactly one family, which can name it before the case runs
    (the vocabulary a config is checked against), and whose default rule and theory limit are the ones applied."""
    result = shipped_run(name)
    case = cases.get(name)
    model = compile_model(case.mjcf)
    for figure in result.figures:
        owners = [f.NAME for f in families.FAMILIES if f.owns(figure.name)]
        assert len(owners) == 1, (figure.name, owners)
        assert str(figure.name) in {str(n) for n in families.family_of(figure.name).names(case, model)}, figure.name
    for budgeted in result.budgets:  # a budget only where a family measured its figure
        assert families.family_of(FigureName(budgeted)).owns(FigureName(budgeted))


def test_a_name_no_family_owns_is_refused():
    class Nobody:
        NAME = "nobody"

        @staticmethod
        def owns(name):
            return False

    assert families.family_of(FigureName("RK4.position")).NAME == "trajectory"
    assert families.family_of(FigureName("RK4.drift.energy")).NAME == "invariants"
    assert families.family_of(FigureName("instant.sensor.pivot_force")).NAME == "reactions"
    assert families.family_of(FigureName("instant.peer.qacc")).NAME == "peers"
    assert families.family_of(FigureName("converge.RK4.order_shortfall")).NAME == "convergence"
    assert families.family_of(FigureName("RK4.balance")).NAME == "balance"
    original = families.FAMILIES
    try:
        families.FAMILIES = (Nobody,)
        with pytest.raises(ValueError, match="belongs to no family"):
            families.family_of(FigureName("RK4.position"))
    finally:
        families.FAMILIES = original


def test_the_run_lists_figures_family_by_family():
    """The run's figures come family by family in FAMILIES' order (the two families measured over the runs
    together, integrator by integrator), so a report lists them as the families are measured."""
    result = shipped_run("pendulum")
    order = [f.NAME for f in families.FAMILIES]
    seen = []
    for figure in result.figures:
        family = families.family_of(figure.name).NAME
        family = "runs" if family in ("trajectory", "invariants") else family
        if not seen or seen[-1] != family:
            seen.append(family)
    merged = list(dict.fromkeys("runs" if f in ("trajectory", "invariants") else f for f in order))
    assert seen == [f for f in merged if f in seen]


def test_the_engine_is_passed_never_read_from_ambient_state():
    """No module keeps the backend (or anything else) in a context variable: the bench holds the engine and
    hands it to every measurement (the backend was once set with a context manager and read four calls down)."""
    found = []
    for path in sorted((ROOT / "harness").rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.Import | ast.ImportFrom):
                modules = [a.name for a in node.names] if isinstance(node, ast.Import) else [node.module or ""]
                if "contextvars" in modules:
                    found.append(str(path.relative_to(ROOT)))
    assert not found, found

"""The error budget's parts and tolerances as the docs name them and as the code makes them: the same names, both
ways. The docs read: README.md's parts table ("Read a verdict: the error budget"), docs/design.md's budget line
(``measured = explained parts (…) + unexplained``) and its tolerance table. The code read: the parts the registry
finds (harness.budget.registry) and the tolerances,
the part modules, and the keys the runs' and the sampled states' budgets actually produce (each budget made from
one synthetic figure)."""

from __future__ import annotations

import importlib
import inspect
import re
from pathlib import Path

import numpy as np

import harness.budget as B
from harness.budget import registry
from harness.budget.floors import Pair
from harness.budget.inputs import States, by_name
from harness.budget.part import Part
from harness.budget.softness import Levels
from harness.core.deviation import Deviation
from harness.core.figures import FigureName
from harness.families import runs, sampled

ROOT = Path(__file__).resolve().parent.parent


def _section(text: str, heading: str) -> str:
    """The text under a markdown heading, up to the next heading of the same or a higher level."""
    level = len(heading) - len(heading.lstrip("#"))
    start = text.index(heading + "\n") + len(heading) + 1
    end = re.search(rf"^#{{1,{level}}} ", text[start:], flags=re.M)
    return text[start:start + end.start()] if end else text[start:]


def _rows(section: str, header: str) -> list[list[str]]:
    """The cells of each row of the markdown table whose header row starts ``| header |``."""
    lines = section.splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith(f"| {header} |"))
    rows = []
    for line in lines[first + 2:]:
        if not line.startswith("|"):
            break
        rows.append([cell.strip() for cell in line.strip().strip("|").split(" | ")])
    return rows


def _table_names(section: str, header: str) -> list[str]:
    """The backticked names in the first column of the markdown table whose header row starts ``| header |``."""
    return [re.fullmatch(r"`(\w+)`", row[0]).group(1) for row in _rows(section, header)]


def _readme_parts() -> list[str]:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    return _table_names(_section(text, "## Read a verdict: the error budget"), "part")


def _design() -> str:
    return _section((ROOT / "docs" / "design.md").read_text(encoding="utf-8"), "## Verdicts: the error budget")


def _design_parts() -> list[str]:
    line = re.search(r"^measured = explained parts \(([^)]*)\) \+ unexplained$", _design(), flags=re.M)
    assert line, "docs/design.md: the budget line 'measured = explained parts (…) + unexplained' is gone"
    return [p.strip() for p in line.group(1).split(",")]


def _design_tolerances() -> list[str]:
    return _table_names(_section(_design(), "### The tolerances and their bases"), "tolerance")


def _made() -> tuple[set[str], set[str], set[str], set[str]]:
    """The explained and tolerance keys of a runs' budget and of a sampled states' budget, one synthetic figure
    each, with every part that context has present (so the explained keys are every part it can make)."""
    name = FigureName("Euler.position")

    def dev(values: list[float]) -> list[Deviation]:
        return [Deviation(name, np.asarray(values, dtype=float), "scalar", "m", "", size=1.0)]

    a = dev([1.0, 2.0])
    made = runs.budgets(runs.Runs(as_is=a, half_step=dev([0.9, 1.9]), softness=(dev([0.8, 1.8]),),
                                  softness_half_step=dev([0.7, 1.7]), converged=dev([0.95, 1.95]),
                                  own={"floors": {"position": np.array([0.1, 0.1])}}),
                        order=1.0, steps=1, rtol=1e-12, solver_tolerance=1e-10)[name]
    stopped = runs.budgets(runs.Runs(as_is=a, half_step=dev([0.9, 1.9]), completed=dev([0.95, 1.95])),
                           order=1.0, steps=1, rtol=1e-12, solver_tolerance=1e-10)[name]
    at_states = sampled.budgets(a, States(own={"softness": Levels([by_name(dev([0.8, 1.8]))]),
                                               "floors": Pair(by_name(dev([1.1, 2.1]))),
                                               "margin": by_name(dev([1.2, 2.2])),
                                               "solver": by_name(dev([0.95, 1.95]))}))[name]
    at_states_stopped = sampled.budgets(a, States(own={"stop": by_name(dev([0.95, 1.95]))}))[name]
    return (set(made.explained) | set(stopped.explained), set(made.tolerance) | set(stopped.tolerance),
            set(at_states.explained) | set(at_states_stopped.explained),
            set(at_states.tolerance) | set(at_states_stopped.tolerance))


def test_the_docs_name_the_parts_the_code_has():
    """README's parts table and docs/design.md's budget line each name exactly the code's parts: none the code lacks
    (``roundoff`` is a tolerance, not a part), none left out."""
    code = set(B.PARTS)
    for where, named in (("README.md's parts table", _readme_parts()), ("docs/design.md's budget line",
                                                                        _design_parts())):
        assert len(named) == len(set(named)), f"{where} names a part twice: {named}"
        assert not set(named) - code, f"{where} names parts the code lacks: {sorted(set(named) - code)}"
        assert not code - set(named), f"{where} leaves out parts of the code: {sorted(code - set(named))}"


def test_the_docs_name_the_tolerances_the_code_has():
    """docs/design.md's tolerance table names exactly the code's tolerances (a row for each, no other)."""
    named = _design_tolerances()
    assert len(named) == len(set(named)), named
    assert set(named) == set(B.TOLERANCES), (sorted(set(named) - set(B.TOLERANCES)),
                                             sorted(set(B.TOLERANCES) - set(named)))


def test_the_declared_parts_and_tolerances_are_what_the_budgets_make():
    """The declared lists are the code's truth: the runs' and the sampled states' budgets make exactly the declared
    parts between them (each a part of the declared list) and exactly the declared tolerances; every part is one
    of the tolerances (its own estimate's uncertainty)."""
    run_parts, run_tolerances, state_parts, state_tolerances = _made()
    assert run_parts | state_parts == set(B.PARTS)
    assert run_tolerances | state_tolerances == set(B.TOLERANCES)
    assert set(B.PARTS) <= set(B.TOLERANCES)
    assert {"integration", "reference"} <= run_tolerances - state_tolerances  # nothing is integrated at states
    assert "margin" in state_parts - run_parts


def test_the_readers_fail_on_drift():
    """The readers are not vacuous: a part added to the docs or left out of them is seen."""
    assert _readme_parts() and _design_parts() and _design_tolerances()
    drifted = set(_readme_parts()) | {"roundoff"}
    assert drifted - set(B.PARTS) == {"roundoff"}


def test_each_part_is_a_module_with_its_part_and_the_registry_is_the_one_list():
    """Every part of the registry is its own module's ``PART`` (harness/budget/NAME.py), a :class:`Part` whose
    words the docs can use (what it varies, explains, must not absorb, its basis), whose variant is an edit of
    harness.engine.variants, its own module's, or None, with an estimate for at least one budget; and the
    tolerances are the parts' and the three no part removes."""
    from harness.engine import variants

    assert tuple(p.name for p in B.ALL) == B.PARTS and len(set(B.PARTS)) == len(B.PARTS)
    assert (*B.PARTS, *registry.UNREMOVED) == B.TOLERANCES
    for part in B.ALL:
        module = importlib.import_module(f"harness.budget.{part.name}")
        assert module.PART is part and isinstance(part, Part)
        for text in (part.varies, part.explains, part.must_not_absorb, part.basis):
            assert text.strip(), part.name
        assert 0 < part.uncertainty < 1, part.name
        assert part.variant is None or inspect.getmodule(part.variant) in (variants, module), part.name
        assert part.over_runs is not None or part.at_states is not None, part.name
    for name in registry.UNREMOVED:  # a module each, named by the tolerance it holds
        assert name == importlib.import_module(f"harness.budget.{name}").NAME
    # the parts a converged or completed solve replaces the base of are estimated first
    assert [p.name for p in registry.OVER_RUNS][:2] == ["solver", "stop"]
    assert [p.name for p in registry.AT_STATES][:2] == ["solver", "stop"]


def test_design_names_the_part_modules_that_exist():
    """docs/design.md's "Where it lives" names each part's module, and each module it names under harness/budget/
    exists."""
    section = _section(_design(), "### Where it lives")
    named = set(re.findall(r"`(\w+)\.py`", section.split("Each family's figures")[0]))
    modules = {p.stem for p in (ROOT / "harness" / "budget").glob("*.py")} - {"__init__"}
    assert {f"{p}" for p in B.PARTS} <= named
    assert named <= modules | {"budget", "variants"}, sorted(named - modules)


def test_the_constants_the_tolerance_table_names_exist():
    """Every constant docs/design.md's tolerance table names (a backticked UPPER_CASE name, or a dotted path to
    one) is a constant of the budget package, or of the runs' or the sampled states' module where a path says so
    or the table's preamble does (``ROUNDOFF``, ``ASYMPTOTIC``)."""
    import harness.budget.convergence
    import harness.budget.extrapolation
    import harness.budget.reference
    import harness.budget.roundoff
    import harness.engine.variants

    section = _section(_design(), "### The tolerances and their bases")
    table = "\n".join(line for line in section.splitlines() if line.startswith("| `"))
    homes = [importlib.import_module(f"harness.budget.{p}") for p in B.PARTS] + [
        harness.budget.extrapolation, harness.budget.roundoff, harness.budget.reference, harness.budget.convergence,
        runs, harness.engine.variants]
    named = re.findall(r"`((?:[a-z_]+\.)*[A-Z][A-Z0-9_]+)`", table)
    assert len(named) >= 10, named
    for name in named:
        if "." in name:
            module, _, constant = name.rpartition(".")
            assert hasattr(importlib.import_module(module), constant), name
        else:
            assert any(hasattr(m, name) for m in homes), f"the tolerance table names {name}: no such constant"


def test_the_docs_words_for_each_part_are_its_fields():
    """docs/design.md's parts table is each part's own words (what it varies, what it may explain, what it must not
    absorb: the Part's fields), in the registry's order; README's "what it is" is what the part may explain."""
    design = _rows(_section(_design(), "### The parts and their variants"), "part")
    assert design == [[f"`{p.name}`", p.varies, p.explains, p.must_not_absorb] for p in B.ALL]
    readme = _rows(_section((ROOT / "README.md").read_text(encoding="utf-8"), "## Read a verdict: the error budget"),
                   "part")
    assert [row[:2] for row in readme] == [[f"`{p.name}`", p.explains] for p in B.ALL]


def test_a_new_shared_variant_field_is_a_tripwire_for_the_noise_gain():
    """The runs' noise gain (runs.noise_gain) weighs the shared variant runs it lists, and each part's own runs
    (Runs.own) by linearity; the states' (sampled.budgets' ``noise``) is each part's own ``states_gain``. A shared
    variant field added to the budget's inputs without its weight in runs.noise_gain would make the round-off and
    convergence tolerances silently too small: this test lists the shared fields as the gain knows them; a new field
    fails it until the gain counts it (and the list here is extended). A part's own variants need no field here."""
    import dataclasses

    from harness.budget.inputs import Runs, States

    assert [f.name for f in dataclasses.fields(Runs)] == [
        "as_is", "half_step", "quarter_step", "softness", "softness_half_step", "slower", "converged",
        "perturbed", "represented", "quantized", "eps_factor", "tc_factor", "completed", "rigid", "rigid_ladder",
        "rigid_split", "rigid_unresolved", "stiffest", "own"]
    assert [f.name for f in dataclasses.fields(States)] == ["own", "perturbed", "represented"]
    for part in B.ALL:  # a part with evaluations of its own at the states weighs them (stop: A's own, completed)
        assert part.states is None or part.states_gain is not None or part.name == "stop", part.name

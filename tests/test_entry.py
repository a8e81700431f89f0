"""One pipeline entry (:func:`harness.pipeline.entry.evaluate`): ``check``, ``run``, :func:`harness.validate` (and
through it the pytest fixture) and the zoo all run and judge through it, and judge alike."""

from __future__ import annotations

import json
import math
import sys

import pytest

import harness
from harness import cases, zoo
from harness.cli.commands import main
from harness.core.checks import Limit
from harness.core.options import RunOptions
from harness.engine.models import mjcf_path
from harness.pipeline import entry
from harness.pipeline.entry import Judging, evaluate

RK4 = ("RK4",)


@pytest.fixture
def through_entry(monkeypatch):
    """The cases each run through the entry (the names of the cases of each call of its runner)."""
    calls: list[tuple[str, ...]] = []
    real = entry.run_all

    def spied(selected, *args, **kwargs):
        calls.append(tuple(c.name for c in selected))
        return real(selected, *args, **kwargs)

    monkeypatch.setattr(entry, "run_all", spied)
    return calls


def test_validate_check_and_evaluate_judge_alike(through_entry, capsys):
    validated = harness.validate("pendulum", integrators=RK4)
    assert main(["check", "pendulum", "--integrators", "RK4", "--json", "-j", "1"]) == 0
    doc = json.loads(capsys.readouterr().out)
    evaluated = evaluate(cases.get("pendulum"), options=RunOptions(integrators=RK4))
    assert through_entry == [("pendulum",)] * 3  # validate, check, evaluate: one door
    assert tuple(evaluated.checks["pendulum"]) == validated.checks
    assert evaluated.outcome.exit_code == 0 and validated.passed
    assert {name: c["passed"] for name, c in doc["cases"]["pendulum"]["checks"].items()} == \
        {str(c.name): c.passed for c in validated.checks}


def test_limits_given_to_the_entry_judge_the_figure(through_entry):
    free = evaluate(cases.get("pendulum"), options=RunOptions(integrators=RK4))
    measured = next(c for c in free.checks["pendulum"] if c.passed and math.isfinite(c.value) and c.value > 0
                    and c.budget is None)
    tight = Judging(limits={str(measured.name): Limit("user", measured.value / 10, "a tenth of what it measured")})
    judged = evaluate(cases.get("pendulum"), options=RunOptions(integrators=RK4), judging=tight)
    again = next(c for c in judged.checks["pendulum"] if c.name == measured.name)
    assert not again.passed and again.threshold == measured.value / 10
    assert judged.outcome.exit_code == 1
    assert sum(not c.passed for c in judged.checks["pendulum"]) == 1  # that figure alone


def test_the_zoo_judges_a_model_through_the_entry(through_entry):
    result = zoo.judge(zoo.ZooModel(name="own/pendulum", package="own", path=mjcf_path("pendulum")),
                       integrators=RK4)
    assert result.verdict == "pass", result.reason
    assert len(through_entry) == 1


def test_a_model_of_ones_own_is_evaluated_as_validate_judges_it(through_entry):
    path = mjcf_path("pendulum")
    evaluated = evaluate(str(path), options=RunOptions(integrators=RK4))
    validated = harness.validate(mjcf=path, integrators=RK4)
    assert [r.case.tree is not None for r in evaluated.results] == [True]  # judged against its own tree
    assert tuple(evaluated.checks[validated.case]) == validated.checks
    assert through_entry == [(validated.case,)] * 2


def test_baseline_figures_and_limits_run_through_the_entry(through_entry, tmp_path, capsys):
    assert main(["baseline", "spring", "--write", str(tmp_path / "b.json"), "-j", "1"]) == 0
    assert main(["figures", "spring", "-j", "1"]) == 0
    assert "spring" in capsys.readouterr().out
    assert through_entry == [("spring",)] * 2
    assert not hasattr(sys.modules["harness.cli.subcommands.limits"], "run_all")  # limits --write: the entry's


def test_the_figures_commands_neither_check_nor_judge_requirements(through_entry):
    """baseline, figures and limits read the figures and checks alone (requirements=False), as they did before
    they came through the entry: a requirement naming no measured figure stops check, never them."""
    from harness.core.errors import ConfigError
    from harness.pipeline.require import Requirement

    judging = Judging(require=(Requirement("nosuch", 1e-3),))
    with pytest.raises(ConfigError, match="nosuch"):
        evaluate(cases.get("pendulum"), options=RunOptions(integrators=RK4), judging=judging)
    done = evaluate(cases.get("pendulum"), options=RunOptions(integrators=RK4), judging=judging, requirements=False)
    assert done.outcome.exit_code == 0 and not done.outcome.unmet

"""Shared fixtures: one run per case (and per breakage) for the whole session."""

from __future__ import annotations

import functools

import pytest

from harness import cases
from harness.core.checks import Check
from harness.engine.compat import joint_types, known_defect, unavailable_reason
from harness.engine.models import compile_model
from harness.pipeline.limits import load_limits
from harness.pipeline.run import CaseResult, run_case
from harness.pipeline.verdict import judge

pytest_plugins = ["pytester"]


@functools.cache
def shipped_run(name: str) -> CaseResult:
    """run_case at the shipped settings, computed once per session."""
    return run_case(cases.get(name))


@pytest.fixture(scope="session")
def config():
    """Every case's shipped limits."""
    return load_limits()


def judged(result: CaseResult) -> dict[str, Check]:
    """Every gated figure's check, by name (the gates of integrators the run left out are not judged; those
    of a diverged or unmeasurable run are failures)."""
    return {c.name: c for c in judge(result, load_limits().for_case(result.case.name))}


def failing(result: CaseResult) -> set[str]:
    """Gated figures that fail."""
    return {name for name, check in judged(result).items() if not check.passed}


def breakable(case: str, names) -> set[str]:
    """The check names of ``case`` this MuJoCo can fail: without those of integrators it lacks (n/a)
    and those a documented defect of this version already fails on the case's model (known defects).
    For tests that expect a broken variant to fail a set of gates."""
    joints = joint_types(compile_model(cases.get(case).mjcf))
    return {n for n in names if not unavailable_reason(n) and not known_defect(joints, n)}


def case_ids() -> list[str]:
    return list(cases.names())


@pytest.fixture
def cached_runs(monkeypatch):
    """A shipped case run as shipped returns the session's cached run (variants still run for real)."""
    from harness.pipeline import run as pipeline

    real = pipeline.RunOptions.run

    def run(options, case, *, edit=None):
        return shipped_run(case.name) if options.shipped and edit is None else real(options, case, edit=edit)

    monkeypatch.setattr(pipeline.RunOptions, "run", run)


"""Shared fixtures: one run per case (and per breakage) for the whole session."""

from __future__ import annotations

import functools

import pytest

from harness import cases
from harness.config import load_config
from harness.pipeline import CaseResult, run_case
from harness.verdict import verdict


@functools.cache
def shipped_run(name: str) -> CaseResult:
    """run_case at the shipped settings, computed once per session."""
    return run_case(cases.get(name))


@pytest.fixture(scope="session")
def config():
    return load_config()


def failing(result: CaseResult) -> set[str]:
    """Gated figures over their limit (thresholds restricted to the figures this run measured)."""
    limits = load_config().for_case(result.case.name)
    measured = {f.name for f in result.figures}
    checks = verdict(result.case.name, result.figures, {k: v for k, v in limits.items() if k in measured})
    return {c.name for c in checks if not c.passed}


def case_ids() -> list[str]:
    return list(cases.names())

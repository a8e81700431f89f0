"""Shared fixtures: one run per case (and per breakage) for the whole session."""

from __future__ import annotations

import functools

import pytest

from harness import cases
from harness.config import load_config
from harness.pipeline import CaseResult, run_case


@functools.cache
def shipped_run(name: str) -> CaseResult:
    """run_case at the shipped settings, computed once per session."""
    return run_case(cases.get(name))


@pytest.fixture(scope="session")
def config():
    return load_config()


def case_ids() -> list[str]:
    return list(cases.names())

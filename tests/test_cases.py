"""Generic checks every registered case inherits: finite outputs, determinism, gates pass (or fail only
as a documented defect of this MuJoCo, which --accept-known-defects accepts)."""

from __future__ import annotations

import numpy as np
import pytest

from harness import cases
from harness.engine.compat import known_defect
from harness.pipeline.run import run_case
from harness.pipeline.verdict import judge
from tests.conftest import case_ids, shipped_run


@pytest.mark.parametrize("name", case_ids())
def test_outputs_are_finite(name):
    result = shipped_run(name)
    assert all(np.isfinite(f.value) for f in result.figures)
    assert result.reference.is_finite()
    assert all(sim.is_finite() for sim in result.simulations.values())


@pytest.mark.parametrize("name", case_ids())
def test_runs_are_bit_identical(name):
    again = run_case(cases.get(name))
    first = shipped_run(name)
    assert [(f.name, f.value) for f in again.figures] == [(f.name, f.value) for f in first.figures]


@pytest.mark.parametrize("name", case_ids())
def test_every_case_has_gates_and_they_pass_at_shipped_settings(name, config):
    limits = config.for_case(name)
    assert limits, f"case {name!r} gates nothing (mjcf/{name}.limits.toml)"
    result = shipped_run(name)
    checks = judge(result, limits)
    failed = [(c.name, c.value, c.judged, c.threshold, c.reason) for c in checks if not c.passed and not c.known]
    assert not failed
    # a failure may be a known defect only where this MuJoCo has a documented one for the model's joints
    known = [c.name for c in checks if c.known]
    assert all(known_defect(result.joints, n) for n in known), known


@pytest.mark.parametrize("name", case_ids())
def test_every_integrator_is_gated(name, config):
    """Each integrator's position error is a gate: none is reported without a verdict."""
    result = shipped_run(name)
    for integrator in result.simulations:
        assert f"{integrator}.position" in config.for_case(name)


def test_unknown_case_lists_known_ones():
    with pytest.raises(ValueError, match=r"known cases: .*pendulum"):
        cases.get("pendulumm")


@pytest.mark.parametrize("typo, closest", [("pendulm", "pendulum"), ("Spring", "spring"),
                                           ("double-pendulum", "double_pendulum"), ("xyzzy", None)])
def test_an_unknown_case_suggests_the_closest_name(typo, closest):
    """A typo is answered with the closest known name first (difflib), in one line; a name close to none
    gets only the list."""
    with pytest.raises(ValueError) as err:
        cases.get(typo)
    message = str(err.value)
    assert "\n" not in message and message.startswith(f"unknown case {typo!r}; ")
    if closest is None:
        assert "did you mean" not in message
    else:
        assert f"; did you mean {closest!r}? known cases: atwood" in message

"""Every gate can fail: each gated figure fails under at least one fault.

The faults are the generic catalog of :mod:`harness.studies.faults` (spec edits
that add physics the analytic system lacks), so every case in the registry is
covered without case-specific code; a case adds its own in its test module for
gates these do not reach. The reference's own gates (its residual and its
cross-check) fail on a reference with a wrong constraint acceleration.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import pytest

from analytic.dynamics import Dynamics
from analytic.solvers import solve
from harness import cases
from harness.core.checks import Check
from harness.core.figures import FigureName
from harness.core.options import RunOptions
from harness.engine.models import compile_model
from harness.families.reference import reference_figures
from harness.pipeline.run import run_case
from harness.studies import faults
from tests.conftest import breakable, case_ids, failing

# gates no generic fault reaches on a case, with the test module whose own faults reach them
OWN_FAULTS: dict[str, tuple[set[str], str]] = {
    "hoop_ramp_contact": ({"series.penetration", "instant.sensor.world_accel"},
                          "tests/test_hoop_ramp.py (rim radius); tests/test_reactions.py (gravity disabled)"),
    "hoop_plane": ({"instant.sensor.world_accel"}, "tests/test_reactions.py (gravity disabled)"),
    "spherical_pendulum_ball": ({"instant.kinematics"}, "tests/test_spherical_pendulum.py (centre of mass)"),
    "torque_free_body": ({"instant.kinematics"}, "tests/test_torque_free_body.py (binding in the wrong Euler order)"),
    # an accelerometer on the world body reads −g whatever the mechanism does: gravity disabled reaches it
    "pendulum": ({"instant.sensor.pivot_accel"}, "tests/test_reactions.py (gravity disabled)"),
    "physical_pendulum": ({"instant.sensor.pivot_accel"}, "tests/test_reactions.py (gravity disabled)"),
    "slider_crank": ({"instant.sensor.pivot_accel"}, "tests/test_reactions.py (gravity disabled)"),
    "welded_pendulum": ({"instant.sensor.axle_accel"}, "tests/test_reactions.py (gravity disabled)"),
    "symmetric_top": ({"instant.kinematics", "instant.sensor.pivot_accel"},
                      "tests/test_symmetric_top.py (centre of mass off the axle); tests/test_reactions.py "
                      "(gravity disabled)"),
    "atwood_tendon": ({"instant.sensor.world_accel", "violation.string1", "violation.string2", "series.stretch"},
                      "tests/test_atwood_tendon.py (gravity disabled; a string held 1 cm long: the catalog's "
                      "equality faults edit joint equalities only)"),
}


def _reached_elsewhere(name: str, gate: str) -> bool:
    quantities, _ = OWN_FAULTS.get(name, (set(), ""))
    return any(gate == q or gate.endswith("." + q) for q in quantities)


@functools.cache
def _caught(name: str) -> frozenset[str]:
    """The gates of ``name`` that fail under some fault of the catalog, at its size at the shipped settings."""
    case = cases.get(name)
    caught: set[str] = set()
    for fault in faults.FAULTS:
        if not fault.reason_not(case):
            caught |= failing(run_case(case, RunOptions(edit=fault.edit(case, fault.sizes[0]))))
    return frozenset(caught)


@pytest.mark.slow
@pytest.mark.parametrize("name", case_ids())
def test_every_gate_fails_under_some_fault(name, config):
    """Each gated figure of each case fails under at least one fault of the catalog (harness.studies.faults),
    so no gate is decoration; the few a generic fault cannot reach on a model are reached by that system's
    own faults (OWN_FAULTS, in its test module). Gates of an integrator this MuJoCo lacks are n/a and those
    a documented defect already fails are known defects: neither can be broken further."""
    gated = breakable(name, {k for k in config.for_case(name) if not k.startswith("reference.")})
    missing = {g for g in gated - _caught(name) if not _reached_elsewhere(name, g)}
    assert missing == set(), f"gates no fault reaches: {sorted(missing)}"


@pytest.mark.parametrize("name", case_ids())
def test_reference_gates_fail_on_a_broken_reference(name, config):
    case = cases.get(name)
    thresholds = {k: v for k, v in config.for_case(name).items() if k.startswith("reference.")}
    if not thresholds:
        pytest.skip(f"{name} gates no reference figure")
    model = compile_model(case.mjcf)
    good = case.reference(model)
    dyn = good.dynamics
    funcs = dict(dyn._funcs)
    gamma = funcs["gamma"]
    funcs["gamma"] = lambda *a: gamma(*a) + 1e-2  # a wrong constraint acceleration
    broken_dyn = Dynamics(dyn.coordinates, dyn.constraint_names, dyn.point_names, dyn.cyclic,
                          dyn.params, funcs, constraint_sizes=dyn.constraint_sizes)
    loose = solve(broken_dyn if dyn.constraint_names else dyn, q0=good.q0(), qd0=good.qd0(),
                  t_end=case.horizon, rtol=1e-6, atol=1e-6)
    broken = dataclasses.replace(good, solution=loose)
    t = np.linspace(0.0, case.horizon, 501)
    figures = reference_figures(broken, t)
    by_name = {f.name: f for f in figures}
    checks = [Check(name, FigureName(k), by_name[k].value, limit.value, by_name[k].unit)
              for k, limit in thresholds.items()]  # theory limits: on the figure itself
    assert {c.name for c in checks if not c.passed} == set(thresholds)

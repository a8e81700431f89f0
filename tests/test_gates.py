"""Every gate can fail: each gated figure fails under at least one deliberately broken variant.

The breakages are generic MjSpec edits (or settings), so every case in the
registry is covered without case-specific code; a case may add its own in its
test module for gates these do not reach.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import mujoco
import numpy as np
import pytest

from analytic.dynamics import Dynamics
from analytic.solvers import solve
from harness import cases
from harness.engine.compat import set_damping
from harness.engine.models import compile_model
from harness.layers.reference import reference_figures
from harness.pipeline.run import run_case
from harness.pipeline.verdict import judge, verdict
from tests.conftest import breakable, case_ids


def _damping(spec: mujoco.MjSpec) -> None:
    """Damping on every hinge and slide. Not on ball joints: there it also damps the spin about the rod,
    which carries only the point mass's tiny inertia, and explicit integrators diverge (pinned in
    tests/test_spherical_pendulum.py)."""
    for j in spec.joints:
        if j.type in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
            set_damping(j, 0.02)  # linear; a float in MuJoCo 3.3, (linear, quadratic, cubic) later


def _mass(spec: mujoco.MjSpec) -> None:
    for b in spec.bodies:
        if b.mass > 0:
            b.mass *= 1.02


def _soft(spec: mujoco.MjSpec) -> None:
    for e in spec.equalities:
        e.solref = [0.05, 1.0]
        e.solimp = [0.9, 0.95, 0.001, 0.5, 2.0]


def _offset(spec: mujoco.MjSpec) -> None:
    for e in spec.equalities:
        if e.type == mujoco.mjtEq.mjEQ_JOINT:
            e.data[0] += 0.01


def _geometry(spec: mujoco.MjSpec) -> None:
    for b in spec.bodies[1:]:
        b.pos = np.asarray(b.pos) * 1.02
    for j in spec.joints:
        j.pos = np.asarray(j.pos) * 1.02


def _gravity(spec: mujoco.MjSpec) -> None:
    spec.option.gravity = np.asarray(spec.option.gravity) * 1.02


BREAKAGES: dict[str, Callable[[mujoco.MjSpec], None]] = {
    "damping": _damping, "mass": _mass, "soft": _soft, "offset": _offset,
    "geometry": _geometry, "gravity": _gravity,
}


def _failed(name: str, config, **kwargs) -> set[str]:
    result = run_case(cases.get(name), **kwargs)
    return {c.name for c in judge(result, config.for_case(name)) if not c.passed}


@pytest.mark.parametrize("name", case_ids())
def test_every_model_gate_fails_on_some_broken_model(name, config):
    # gates of an integrator this MuJoCo lacks are n/a, and those a documented defect of this MuJoCo
    # already fails are known defects (harness.engine.compat): neither can be broken further
    gated = breakable(name, {k for k in config.for_case(name) if not k.startswith("reference.")})
    timestep = compile_model(cases.get(name).mjcf).opt.timestep
    caught = _failed(name, config, timestep=timestep * 10)
    for edit in BREAKAGES.values():
        caught |= _failed(name, config, edit=edit)
    assert gated - caught == set(), f"gates no breakage reaches: {sorted(gated - caught)}"


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
                          dyn.params, funcs)
    loose = solve(broken_dyn if dyn.constraint_names else dyn, q0=good.q0(), qd0=good.qd0(),
                  t_end=case.horizon, rtol=1e-6, atol=1e-6)
    broken = dataclasses.replace(good, solution=loose)
    t = np.linspace(0.0, case.horizon, 501)
    figures = reference_figures(broken, t)
    failed = {c.name for c in verdict(name, figures, thresholds) if not c.passed}
    assert failed == set(thresholds)

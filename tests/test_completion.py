"""The completion of a float32 backend's stopped constraint solve (harness/engine/backends/completion.py).

A stopped solve is made here on the C engine in float64, where the answer is known: from MuJoCo's own
solution (a*, f*) at a sampled state, the iterate a = a* + δa that a primal solver would hold, with its
forces f = F(J a − a_ref) read off it as MJX and Warp do. Its residual M a + c − τ − Jᵀf is the gradient
the stop left; completing must give back (a*, f*) and the sensors at them, and must leave alone what
the residual does not show (a backend whose forces are wrong but balanced).
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from harness import cases
from harness.budget.inputs import States, by_name
from harness.budget.softness import Levels
from harness.core.deviation import Deviation
from harness.core.figures import FigureName
from harness.engine.backends import Forward, get
from harness.engine.backends.completion import completed_forward, resolution
from harness.engine.compat import set_damping
from harness.engine.constraints import equality_rows
from harness.engine.models import compile_model
from harness.families.sampled import budgets as instant_budgets
from harness.families.sampled import mujoco_states, sample_states

EPS32 = float(np.finfo(np.float32).eps)


def _states(name: str, count: int = 6):
    try:
        case = cases.get(name)
    except ValueError as exc:  # welded_pendulum needs MuJoCo >= 3.7.0 (J̇v in the weld's bias)
        pytest.skip(str(exc))
    model = compile_model(case.mjcf)
    ref = case.reference(model)
    probe = case.probe(ref.dynamics)
    q, qd = sample_states(ref, count)
    qpos, qvel = mujoco_states(model, probe, q, qd)
    exact = get("c").forward_many(model, probe, qpos, qvel)
    return model, probe, qpos, qvel, exact


def _stopped(model, qpos, qvel, exact: Forward, probe, *, fraction: float) -> Forward:
    """``exact`` moved to a primal iterate a* + δa whose remaining improvement ½ rᵀH⁻¹r is ``fraction`` of
    what float32 resolves (:func:`resolution` × u₃₂ × the cost), with the forces, qfrc_constraint and sensors
    read off that iterate."""
    data = mujoco.MjData(model)
    out = {f: getattr(exact, f).copy() for f in ("qacc", "qfrc_constraint", "sensordata", "cfrc_int", "cfrc_ext")}
    equality = {c: v.copy() for c, v in exact.equality.items()}
    rng = np.random.default_rng(7)
    for k in range(len(qpos)):
        mujoco.mj_resetData(model, data)
        data.qpos[:], data.qvel[:] = qpos[k], qvel[k]
        mujoco.mj_forward(model, data)
        n = data.nefc
        assert not mujoco.mj_isSparse(model)  # the rows' Jacobian is dense for these small models
        jac = data.efc_J[:n * model.nv].reshape(n, model.nv)
        hessian = exact.mass[k] + jac.T @ (data.efc_D[:n, None] * jac)
        gap = data.qacc - data.qacc_smooth
        cost = 0.5 * gap @ exact.mass[k] @ gap + 0.5 * float(np.sum(data.efc_D[:n]
                                                                   * (jac @ data.qacc - data.efc_aref[:n]) ** 2))
        direction = np.linalg.solve(hessian, rng.standard_normal(model.nv))
        # ½ δaᵀ H δa = improvement × u × cost
        improvement = fraction * resolution(model.nv, n)
        delta = direction * np.sqrt(2 * improvement * EPS32 * cost / (direction @ hessian @ direction))
        acc = data.qacc + delta
        jar = jac @ acc - data.efc_aref[:n]
        mujoco.mj_constraintUpdate(model, data, jar, None, 0)
        out["qacc"][k] = acc
        out["qfrc_constraint"][k] = data.qfrc_constraint
        for c in equality:
            equality[c][k] = data.efc_force[equality_rows(model, data, c)]
        data.qacc[:] = acc
        mujoco.mj_rnePostConstraint(model, data)
        mujoco.mj_sensorAcc(model, data)
        out["sensordata"][k], out["cfrc_int"][k], out["cfrc_ext"][k] = data.sensordata, data.cfrc_int, data.cfrc_ext
    return dataclasses.replace(exact, equality=equality, **out)


def _complete(model, qpos, qvel, fwd):
    def set_state(data, k):
        data.qpos[:], data.qvel[:] = qpos[k], qvel[k]

    return completed_forward(model, fwd, EPS32, set_state)


@pytest.mark.parametrize("name", ["welded_pendulum", "pendulum"])
def test_a_stop_within_float32s_resolution_is_completed_to_the_solution(name):
    """At half the improvement float32 can resolve, the completion gives back MuJoCo's solution: qacc,
    the equality's forces, the reaction sensors (welded_pendulum's socket and top)."""
    model, probe, qpos, qvel, exact = _states(name)
    stopped = _stopped(model, qpos, qvel, exact, probe, fraction=0.5)
    assert np.max(np.abs(stopped.qacc - exact.qacc)) > 1e-6  # the stop moved it
    done = _complete(model, qpos, qvel, stopped)
    assert not done.kept.any()
    scale = np.max(np.abs(exact.qacc))
    assert np.max(np.abs(done.forward.qacc - exact.qacc)) < 1e-9 * scale
    for c in probe.constraints:
        force_scale = np.max(np.abs(exact.equality[c]))
        assert np.max(np.abs(stopped.equality[c] - exact.equality[c])) > 1e-6 * force_scale
        assert np.max(np.abs(done.forward.equality[c] - exact.equality[c])) < 1e-9 * force_scale
    if exact.sensordata is not None and model.nsensordata:
        size = np.max(np.abs(exact.sensordata))
        assert np.max(np.abs(done.forward.sensordata - exact.sensordata)) < 1e-9 * size


def test_a_stop_beyond_float32s_resolution_keeps_the_backends_numbers():
    """A solve that stopped with more left than float32 can resolve is not the precision's: those states
    keep the backend's numbers (and the figure stays unexplained), with a note saying so."""
    model, probe, qpos, qvel, exact = _states("pendulum")
    stopped = _stopped(model, qpos, qvel, exact, probe, fraction=10.0)
    done = _complete(model, qpos, qvel, stopped)
    assert done.kept.all()
    assert np.array_equal(done.forward.qacc, stopped.qacc)
    assert "keep its numbers" in done.note()


def test_balanced_but_wrong_forces_are_left_alone():
    """The completion removes only the residual of the backend's own arrays: a forward of the damped
    pendulum (a fault: damping the analytic system lacks) is balanced, so it comes back unchanged."""
    _, probe, qpos, qvel, _ = _states("pendulum")
    faulty = compile_model(cases.get("pendulum").mjcf,
                           edit=lambda spec: set_damping(spec.joint("theta"), 1e-3))
    wrong = get("c").forward_many(faulty, probe, qpos, qvel)
    done = _complete(faulty, qpos, qvel, wrong)
    assert np.max(np.abs(done.forward.qacc - wrong.qacc)) < 1e-12 * np.max(np.abs(wrong.qacc))
    for c in probe.constraints:
        assert np.max(np.abs(done.forward.equality[c] - wrong.equality[c])) < 1e-12 * np.max(np.abs(wrong.equality[c]))


def _dev(values) -> Deviation:
    return Deviation(FigureName("instant.sensor.hub_force"), np.asarray(values, float), "scalar", "1", "")


def test_the_stop_part_explains_what_completion_removes_and_nothing_else():
    """In the budget the stop is a part of its own (A − completed, tolerance 1/10 of it), the softness levels
    are taken completed; an error the completion does not remove stays unexplained and fails."""
    name = FigureName("instant.sensor.hub_force")
    as_is, done = _dev([1e-3, -2e-3]), _dev([1e-9, 2e-9])
    level = [_dev([1.5e-9, 2.5e-9])]  # a softened level, completed: the softness part is 5e-10
    got = instant_budgets([as_is], States(own={"softness": Levels([by_name(level)]), "stop": by_name([done])}))[name]
    assert got.explained["stop"] == pytest.approx(2e-3, rel=1e-6)
    assert got.tolerance["stop"] == pytest.approx(2e-4, rel=1e-6)
    assert got.passed
    kept = instant_budgets([as_is], States(own={"softness": Levels([by_name(level)]),
                                                "stop": by_name([as_is])}))[name]  # nothing completed
    assert not kept.passed
    without = instant_budgets([as_is], States(own={"softness": Levels([by_name([_dev([4e-3, 1e-3])])])}))[
        name]  # the old way: levels' stops
    assert not without.passed

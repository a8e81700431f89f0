"""Version fallbacks (harness/compat.py): each pinned against an independent computation, on any MuJoCo."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from harness import cases
from harness.core.figures import Figure
from harness.engine import compat
from harness.engine.models import compile_model, mjcf_path
from harness.pipeline.verdict import verdict


def _random_state(model: mujoco.MjModel, data: mujoco.MjData, seed: int = 0) -> None:
    rng = np.random.default_rng(seed)
    mujoco.mj_resetData(model, data)
    data.qvel[:] = rng.normal(size=model.nv)
    mujoco.mj_integratePos(model, data.qpos, rng.normal(size=model.nv), 1.0)
    mujoco.mj_forward(model, data)


@pytest.mark.parametrize("name", ["spherical_pendulum_ball", "pendulum"])
def test_jac_dot_is_the_time_derivative_of_the_jacobian(name):
    """J̇ qvel + J qacc against a 4th-order central difference of the point velocity J(q(t)) q̇(t)."""
    model = compile_model(mjcf_path(name))
    data = mujoco.MjData(model)
    _random_state(model, data)
    body = model.nbody - 1
    point = data.xipos[body].copy()

    def velocity(eps: float) -> np.ndarray:
        d = mujoco.MjData(model)
        d.qpos[:] = data.qpos
        mujoco.mj_integratePos(model, d.qpos, data.qvel + 0.5 * eps * data.qacc, eps)
        d.qvel[:] = data.qvel + eps * data.qacc
        mujoco.mj_forward(model, d)
        jac = np.zeros((3, model.nv))
        mujoco.mj_jacBodyCom(model, d, jac, None, body)
        return jac @ d.qvel

    e = 1e-4
    fd = (-velocity(2 * e) + 8 * velocity(e) - 8 * velocity(-e) + velocity(-2 * e)) / (12 * e)
    jac = np.zeros((3, model.nv))
    mujoco.mj_jacBodyCom(model, data, jac, None, body)
    acc = jac @ data.qacc + compat.jac_dot(model, data, point, body) @ data.qvel
    np.testing.assert_allclose(acc, fd, atol=1e-7 * max(1.0, np.max(np.abs(fd))))


def test_set_damping_sets_the_linear_term_on_any_version():
    spec = mujoco.MjSpec.from_file(str(mjcf_path("pendulum")))
    compat.set_damping(spec.joints[0], 0.02)
    model = spec.compile()
    assert model.dof_damping[model.joint(spec.joints[0].name).dofadr[0]] == pytest.approx(0.02)


def test_set_stiffness_sets_the_linear_term_on_any_version():
    spec = mujoco.MjSpec.from_file(str(mjcf_path("spring")))
    compat.set_stiffness(spec.joint("x"), 21.0)
    assert float(spec.compile().joint("x").stiffness[0]) == 21.0


def test_solver_iterations_is_within_the_limit():
    model = compile_model(mjcf_path("pendulum"))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert 0 <= compat.solver_iterations(data) <= model.opt.iterations


def test_a_missing_integrator_makes_its_thresholds_n_a(monkeypatch):
    monkeypatch.setattr(compat, "available_integrators", lambda: ("Euler", "implicit", "implicitfast", "RK4"))
    assert compat.unavailable_reason("discrete.position").startswith("integrator discrete is not in MuJoCo")
    assert compat.unavailable_reason("converge.discrete.order_shortfall")
    assert compat.unavailable_reason("RK4.position") == ""
    figures = [Figure("RK4.position", 1e-9, "m", "")]
    checks = verdict("pendulum", figures, {"RK4.position": 1e-8, "discrete.position": 1e-3})
    na = next(c for c in checks if c.name == "discrete.position")
    assert na.status == "n/a" and na.passed and math.isnan(na.value) and "discrete" in na.note
    with pytest.raises(ValueError, match="unmeasured"):  # anything else missing is still a config error
        verdict("pendulum", figures, {"nonsense.figure": 1.0})


def _joints(name: str) -> frozenset[int]:
    return compat.joint_types(compile_model(cases.get(name).mjcf))


def test_a_documented_defect_explains_a_failure_only_on_an_affected_version(monkeypatch):
    if "spherical_pendulum_ball" not in cases.names():
        pytest.skip("the ball case is not registered")
    figures = [Figure("RK4.position", 1e-6, "m", ""), Figure("Euler.position", 1.0, "m", "")]
    limits = {"RK4.position": 1e-9, "Euler.position": 1e-3}
    monkeypatch.setattr(compat, "_version", lambda: (3, 3, 0))
    ball, hinges = _joints("spherical_pendulum_ball"), _joints("pendulum")
    checks = {c.name: c for c in verdict("spherical_pendulum_ball", figures, limits, joints=ball)}
    assert checks["RK4.position"].status == "known defect" and "Munthe-Kaas" in checks["RK4.position"].known
    assert checks["Euler.position"].status == "FAIL"  # not RK4: no excuse
    assert verdict("pendulum", figures, limits, joints=hinges)[0].status == "FAIL"  # no ball joint: no excuse
    monkeypatch.setattr(compat, "_version", lambda: (4, 0, 0))
    assert verdict("spherical_pendulum_ball", figures, limits, joints=ball)[0].status == "FAIL"


def test_diagexact_fallback_reproduces_the_exact_diagonal(monkeypatch, tmp_path):
    """Parse atwood as a MuJoCo without diagexact would (attribute removed, invweights emulated):
    the constraint forces equal those of the exact diagonal (diagexact on, where it exists)."""
    if "atwood" not in cases.names():
        pytest.skip("atwood is not registered")
    path = tmp_path / "atwood.xml"
    path.write_text(mjcf_path("atwood").read_text())
    monkeypatch.setattr(compat, "missing_flags", lambda: ("diagexact",))
    with pytest.warns(UserWarning, match="diagexact"):
        emulated = compile_model(path)
    notes = compat.fallbacks(str(path))
    assert any("removed" in n for n in notes) and any("emulated" in n for n in notes)
    monkeypatch.undo()
    data = mujoco.MjData(emulated)
    mujoco.mj_forward(emulated, data)
    reference = compile_model(mjcf_path("atwood"))
    if hasattr(mujoco.mjtEnableBit, "mjENBL_DIAGEXACT"):
        rdata = mujoco.MjData(reference)
        mujoco.mj_forward(reference, rdata)
        np.testing.assert_allclose(data.efc_force[: data.nefc], rdata.efc_force[: rdata.nefc], rtol=1e-9)
    # independently: with R_ii = (1 − d)/d · A_ii exact, the t = 0 force error is (A + R)⁻¹ R λ*
    from harness.layers.orders import initial_force_floor

    ref = cases.get("atwood").reference(reference, t_end=0.1)
    lam = ref.solution.multipliers([0.0])[0]
    err = np.max(np.abs(data.efc_force[: data.nefc] - lam)) / ref.scales.force
    assert err == pytest.approx(initial_force_floor(emulated, ref), rel=1e-3)

"""Version fallbacks (harness/compat.py): each pinned against an independent computation, on any MuJoCo."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from harness import cases
from harness.core.budget import Budget
from harness.core.checks import gate
from harness.core.figures import Figure
from harness.engine import compat
from harness.engine.models import compile_model, mjcf_path
from harness.pipeline.limits import Limit
from harness.pipeline.run import CaseResult
from harness.pipeline.settings import ModelSettings, RunSettings
from harness.pipeline.verdict import judge


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


def _result(name: str, figures: list[Figure], *, joints: frozenset[int] = frozenset(),
            orders: dict[str, float] | None = None, defect_budgets: dict[str, Budget] | None = None) -> CaseResult:
    """A CaseResult carrying only what judge() reads: the figures, the joints, the fitted orders and the
    budgets at a defect's order."""
    ran = tuple(dict.fromkeys(f.name.integrator for f in figures if f.name.integrator))
    settings = RunSettings(model=ModelSettings.of(compile_model(mjcf_path(name))), mjcf=str(mjcf_path(name)),
                           horizon=1.0, settle=0.0, params={}, q0={}, qd0={}, integrators=ran, recorder="")
    return CaseResult(case=cases.get(name), figures=tuple(figures), reference=None, simulations={}, settings=settings,
                      joints=joints, orders=orders or {}, defect_budgets=defect_budgets or {})


def test_a_missing_integrator_makes_its_thresholds_n_a(monkeypatch):
    monkeypatch.setattr(compat, "available_integrators", lambda: ("Euler", "implicit", "implicitfast", "RK4"))
    assert compat.unavailable_reason("discrete.position").startswith("integrator discrete is not in MuJoCo")
    assert compat.unavailable_reason("converge.discrete.order_shortfall")
    assert compat.unavailable_reason("RK4.position") == ""
    result = _result("pendulum", [Figure("RK4.position", 1e-9, "m", "")])
    checks = judge(result, {"RK4.position": Limit("user", 1e-8), "discrete.position": Limit("user", 1e-3)})
    na = next(c for c in checks if c.name == "discrete.position")
    assert na.status == "n/a" and na.passed and math.isnan(na.value) and "discrete" in na.note
    with pytest.raises(ValueError, match="unmeasured"):  # anything else missing is still a config error
        judge(result, {"nonsense.figure": Limit("user", 1.0)})


def _joints(name: str) -> frozenset[int]:
    return compat.joint_types(compile_model(cases.get(name).mjcf))


def test_a_documented_defect_is_a_failure_with_its_name_only_where_its_signature_shows(monkeypatch):
    """On an affected version, a failed RK4 figure of a ball-joint model is labelled with the defect only
    when RK4's observed order is the degraded one (2) and the budget at that order explains the figure;
    it still fails (status FAIL (known defect)): the gate decides separately whether to accept it."""
    if "spherical_pendulum_ball" not in cases.names():
        pytest.skip("the ball case is not registered")
    figures = [Figure("RK4.position", 1e-6, "m", ""), Figure("Euler.position", 1.0, "m", "")]
    limits = {"RK4.position": Limit("user", 1e-9), "Euler.position": Limit("user", 1e-3)}
    at_order_2 = {"RK4.position": Budget(1e-6, {"integration": 1e-6}, 1e-10, {"integration": 1e-8})}
    monkeypatch.setattr(compat, "_version", lambda: (3, 3, 0))
    ball, hinges = _joints("spherical_pendulum_ball"), _joints("pendulum")
    signature = dict(orders={"RK4": 2.02, "Euler": 1.0}, defect_budgets=at_order_2)

    checks = {c.name: c for c in judge(_result("spherical_pendulum_ball", figures, joints=ball, **signature),
                                       limits)}
    assert checks["RK4.position"].status == "FAIL (known defect)" and not checks["RK4.position"].passed
    assert "Munthe-Kaas" in checks["RK4.position"].known
    assert checks["Euler.position"].status == "FAIL"  # not RK4: no excuse
    assert gate(checks.values(), accept_known_defects=True) is False  # Euler's failure is not a defect
    assert gate([checks["RK4.position"]], accept_known_defects=True) is True
    assert gate([checks["RK4.position"]], accept_known_defects=False) is False

    def status(name, **kwargs) -> str:
        return {c.name: c for c in judge(_result(name, figures, **kwargs), limits)}["RK4.position"].status

    assert status("pendulum", joints=hinges, **signature) == "FAIL"  # no ball joint: no excuse
    assert status("spherical_pendulum_ball", joints=ball, orders={"RK4": 4.0},
                  defect_budgets=at_order_2) == "FAIL"  # RK4 at its full order: another regression
    unexplained = {"RK4.position": Budget(1e-6, {"integration": 1e-8}, 1e-6, {"integration": 1e-9})}
    assert status("spherical_pendulum_ball", joints=ball, orders={"RK4": 2.0},
                  defect_budgets=unexplained) == "FAIL"  # order 2, but the defect does not explain the size
    monkeypatch.setattr(compat, "_version", lambda: (4, 0, 0))
    assert status("spherical_pendulum_ball", joints=ball, **signature) == "FAIL"  # fixed in 4.0.0


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
    from harness.families.convergence import initial_force_floor

    ref = cases.get("atwood").reference(reference, t_end=0.1)
    lam = ref.solution.multipliers([0.0])[0]
    err = np.max(np.abs(data.efc_force[: data.nefc] - lam)) / ref.scales.force
    assert err == pytest.approx(initial_force_floor(emulated, ref), rel=1e-3)


def test_full_mass_matrix_is_the_inertia_of_mj_mulM():
    """Column by column, M e_i from ``mj_mulM`` (an API whose signature never changed): the dense matrix of
    the installed release, whichever ``mj_fullM`` signature it has (CI runs this on 4.0.0 and on 3.3.0)."""
    model = compile_model(mjcf_path("double_pendulum"))
    data = mujoco.MjData(model)
    _random_state(model, data)
    columns = []
    for i in range(model.nv):
        unit, out = np.zeros(model.nv), np.zeros(model.nv)
        unit[i] = 1.0
        mujoco.mj_mulM(model, data, out, unit)
        columns.append(out)
    np.testing.assert_allclose(compat.full_mass_matrix(model, data), np.array(columns).T, rtol=1e-14, atol=1e-16)


@pytest.mark.parametrize(("release", "old_signature"), [((3, 9, 0), True), ((3, 10, 0), False), ((4, 0, 0), False)])
def test_full_mass_matrix_picks_the_signature_by_release(monkeypatch, release, old_signature):
    """3.10.0 still has ``mjData.qM`` but already the new ``mj_fullM(m, d, dst)`` (changelog 3.10.0, item 14):
    the release decides. A stand-in ``mj_fullM`` records which arguments it was given."""
    model = compile_model(mjcf_path("pendulum"))

    class Data:  # what both signatures read: qM (gone from mjData after 3.10) and the data itself
        qM = np.zeros(model.nM)

    calls: list[tuple[type, type]] = []
    monkeypatch.setattr(compat, "_version", lambda: release)
    monkeypatch.setattr(compat.mujoco, "mj_fullM", lambda m, a, b: calls.append((type(a), type(b))))
    compat.full_mass_matrix(model, Data())
    assert calls == ([(np.ndarray, np.ndarray)] if old_signature else [(Data, np.ndarray)])

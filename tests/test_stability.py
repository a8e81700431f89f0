"""An explicit integrator beyond its stability limit at the model's step: the method's limit, stated, never MuJoCo's
failure; inside the limit every run is judged as before, a fault included (harness/families/stability.py).

The model is a damped spring (one slide, mass m, stiffness k, damping c): its eigenvalues are the roots of
m λ² + c λ + k = 0, so every limit has a closed form to be compared with.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from analytic.tree.dynamics import TreeDynamics
from harness.cases.own import from_mjcf
from harness.core.options import RunOptions
from harness.families import stability as st
from harness.pipeline.limits import case_limits, load_limits
from harness.pipeline.run import run_case
from harness.pipeline.verdict import judge
from harness.reference.tree import read_tree

SPRING = """<mujoco model="dspring">
  <option timestep="0.001" integrator="{integrator}" gravity="0 0 -9.81"/>
  <worldbody>
    <body name="mass">
      <joint name="x" type="slide" axis="1 0 0" stiffness="{k}" damping="{c}"/>
      <inertial pos="0 0 0" mass="{m}" diaginertia="1e-4 1e-4 1e-4"/>
    </body>
  </worldbody>
</mujoco>
"""
M, K, C = 0.5, 20000.0, 20.0  # ω = 200/s, ζ = 0.1: λ = −20 ± 199.0i


def _write(tmp_path, name="dspring.xml", *, k=K, c=C, m=M, integrator="RK4"):
    path = tmp_path / name
    path.write_text(SPRING.format(k=k, c=c, m=m, integrator=integrator))
    return path


def _dynamics(*, k=K, c=C, m=M) -> TreeDynamics:
    model = mujoco.MjModel.from_xml_string(SPRING.format(k=k, c=c, m=m, integrator="RK4"))
    return TreeDynamics.of(read_tree(model))


def _exact(*, k=K, c=C, m=M) -> np.ndarray:
    return np.roots([m, c, k])


# ---- the regions, against theory ------------------------------------------------------------------------------
def test_rk4_region_ends_where_theory_puts_it_on_both_axes():
    # negative real axis: R(x) = 1 again (R stays above −1 there), x (1 + x/2 + x²/6 + x³/24) = 0: the cubic's real
    # root (numpy's roots, not ours)
    real = np.roots([1 / 24, 1 / 6, 1 / 2, 1])
    expected = -float(min(r.real for r in real if abs(r.imag) < 1e-12))
    assert abs(st.RK4_REAL - expected) <= 1e-12 * expected
    assert abs(st.RK4_REAL - 2.785) <= 5e-4
    # imaginary axis: |R(iy)|² = 1 − y⁶/72 + y⁸/576 = 1 at y = √8
    assert st.rk4_boundary(math.pi / 2) == pytest.approx(2 * math.sqrt(2), rel=1e-12)


def test_linearization_gives_the_closed_form_eigenvalues():
    lin = st.linearize(_dynamics(), np.array([[0.01], [-0.02]]), np.array([[0.3], [0.0]]))
    for values in lin.eigenvalues:
        assert np.sort_complex(values) == pytest.approx(np.sort_complex(_exact()), rel=1e-9)


@pytest.mark.parametrize(("c", "ray"), [(0.0, "imaginary"), (1000.0, "negative real")])
def test_rk4_limit_on_each_axis_matches_theory(c, ray):
    found = st.assess(_dynamics(c=c), np.zeros((2, 1)), np.zeros((2, 1)), timestep=1e-3, integrators=("RK4",))
    lam = _exact(c=c)
    # undamped: λ = ±iω, the limit 2√2/ω; overdamped: the fast real root bounds the step, 2.785/|λ|
    expected = (2 * math.sqrt(2) / math.sqrt(K / M) if ray == "imaginary"
                else st.RK4_REAL / float(np.max(np.abs(lam))))
    assert found["RK4"].limit == pytest.approx(expected, rel=1e-8)
    assert found["RK4"].h_lambda == pytest.approx(1e-3 * float(np.max(np.abs(lam))), rel=1e-8)


@pytest.mark.parametrize("eulerdamp", [True, False])
def test_euler_limit_matches_semi_implicit_euler_as_mujoco_applies_it(eulerdamp):
    """Semi-implicit Euler on ẍ = −ω²x − γẋ (γ = c/m): with the damping implicit (eulerdamp) stable iff
    h²ω² ≤ 4 + 2hγ; with it explicit iff h²ω² + 2hγ ≤ 4 (the trace and determinant of the one-step map)."""
    w2, g = K / M, C / M
    expected = (g + math.sqrt(g * g + 4 * w2)) / w2 if eulerdamp else (-g + math.sqrt(g * g + 4 * w2)) / w2
    found = st.assess(_dynamics(), np.zeros((1, 1)), np.zeros((1, 1)), timestep=1e-3, integrators=("Euler",),
                      implicit_damping=eulerdamp)
    assert found["Euler"].limit == pytest.approx(expected, rel=1e-5)


def test_a_mode_growing_in_the_motion_is_no_numerical_limit():
    # a negative stiffness (an inverted pendulum's linearization): λ = ±√(k/m) real, the motion itself grows
    found = st.assess(_dynamics(k=-200.0, c=0.0), np.zeros((1, 1)), np.zeros((1, 1)), timestep=1e-3,
                      integrators=("RK4", "Euler"))
    assert not found["RK4"].beyond and not found["Euler"].beyond


# ---- the verdict ----------------------------------------------------------------------------------------------
def _judged(path, *, timestep, integrators=("RK4",), reference=None):
    case = from_mjcf(path, reference=reference)
    result = run_case(case, RunOptions(timestep=timestep, integrators=integrators))
    return result, judge(result, case_limits(load_limits(), case, result.judged_names))


def _rk4_limit() -> float:
    return st.rk4_limit(_exact())[0]


def test_a_run_just_above_the_limit_diverges_and_is_reported_beyond_it_not_failed(tmp_path):
    h = 1.05 * _rk4_limit()
    result, checks = _judged(_write(tmp_path), timestep=h)
    assert "RK4" in result.diverged  # it does diverge: the statement is about a real run
    rk4 = [c for c in checks if c.name.integrator == "RK4"]
    assert rk4
    for c in rk4:
        assert c.status == "n/a", c
        assert c.reason.startswith(f"RK4 at h={h:g} s is beyond its stability limit (h·|λ|max = ")
        assert "λ from the linearization at the run's states" in c.reason
        assert f"stable below h ≈ {_rk4_limit():.3g} s" in c.reason
        assert "its run diverged" in c.reason
    # the report says it where the case is shown, and the job summary in its own section
    from harness.outputs.report import render_markdown, section_case

    page = section_case(result, checks, None, plots="")
    assert "Stability at the model's step" in page and "is beyond its stability limit" in page
    summary = render_markdown([result], {result.case.name: checks})
    assert "## Beyond a stability limit" in summary and f"RK4 at h={h:g} s is beyond" in summary


def test_a_run_below_the_limit_is_judged_as_always(tmp_path):
    result, checks = _judged(_write(tmp_path), timestep=0.95 * _rk4_limit())
    assert not result.stability["RK4"].beyond and "RK4" not in result.diverged
    rk4 = [c for c in checks if c.name.integrator == "RK4"]
    assert rk4 and all(c.status == "pass" for c in rk4), [(c.name, c.status, c.reason) for c in rk4]


def test_a_fault_at_a_stable_step_still_fails(tmp_path):
    """The engine's spring made 10× stiffer (the reference read from the clean file): the engine's run diverges at a
    step the reference's dynamics call stable, so the limit must not absorb it: FAIL, diverged."""
    clean = _write(tmp_path)
    faulty = _write(tmp_path, "faulty.xml", k=10 * K)
    result, checks = _judged(faulty, timestep=0.95 * _rk4_limit(), reference=clean)
    assert not result.stability["RK4"].beyond
    assert "RK4" in result.diverged
    rk4 = [c for c in checks if c.name.integrator == "RK4"]
    assert rk4 and all(c.status == "FAIL" and c.diverged for c in rk4)


def test_the_integrator_the_model_names_leads(tmp_path):
    for named in ("Euler", "implicitfast"):
        result, checks = _judged(_write(tmp_path, integrator=named), timestep=None,
                                 integrators=("RK4", named))
        assert next(iter(result.simulations)) == named
        assert next(c.name.integrator for c in checks if c.name.integrator) == named


def test_check_says_so_and_exits_0(tmp_path, capsys):
    from harness.cli.commands import main

    h = 1.05 * _rk4_limit()
    code = main(["check", "--mjcf", str(_write(tmp_path)), "--timestep", f"{h:.6g}", "--integrators", "RK4", "-q"])
    out = capsys.readouterr().out
    assert code == 0, out
    assert f"dspring: RK4 at h={float(f'{h:.6g}'):g} s is beyond its stability limit" in " ".join(out.split())


def test_the_zoo_leads_with_the_models_own_integrator():
    from harness import zoo

    said = {"RK4": "RK4 at h=0.01 s is beyond its stability limit (…); stable below h ≈ 0.00185 s",
            "Euler": "Euler at h=0.01 s is beyond its stability limit (…); stable below h ≈ 0.005 s"}
    row = zoo.ZooResult("dm_control/x", "dm_control", "x.xml", zoo.PASS, 1.0, nv=3, checks=10, own="Euler",
                        stability={"Euler": said["Euler"], "RK4": said["RK4"]})
    assert row.line().index("Euler at h") < row.line().index("RK4 at h")
    text = zoo.zoo_markdown(zoo.ZooRun(results=(row,)))
    table_row = next(line for line in text.splitlines() if line.startswith("| dm_control/x "))
    assert said["Euler"] in table_row and said["RK4"] not in table_row
    assert "## Beyond a stability limit" in text
    assert f"**dm_control/x** (its own integrator: Euler): {said['Euler']}; {said['RK4']}" in text


CHAIN = """<mujoco model="chain">
  <option timestep="{h}" integrator="{integrator}" gravity="0 0 0"/>
  <worldbody>
    <body name="upper" euler="0 0.4 0">
      <joint name="a" type="hinge" axis="0 1 0" damping="0.3" stiffness="40"/>
      <inertial pos="0 0 -0.5" mass="1" diaginertia="0.02 0.03 0.04"/>
      <body name="lower" pos="0 0 -1" euler="0 -0.7 0">
        <joint name="b" type="hinge" axis="0 1 0" damping="0.4" stiffness="2"/>
        <inertial pos="0 0 -0.3" mass="0.05" diaginertia="1e-4 2e-4 3e-4"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _step_jacobian(model: mujoco.MjModel, qpos: np.ndarray, qvel: np.ndarray, delta: float = 1e-6) -> np.ndarray:
    """∂(qpos, qvel)⁺/∂(qpos, qvel) of one mj_step (hinges: qpos and qvel alike), by central differences."""
    data = mujoco.MjData(model)
    x0 = np.concatenate([qpos, qvel])
    n = model.nv

    def step(x):
        data.qpos[:], data.qvel[:], data.time = x[:n], x[n:], 0.0
        mujoco.mj_step(model, data)
        return np.concatenate([data.qpos, data.qvel])

    return np.column_stack([(step(x0 + delta * e) - step(x0 - delta * e)) / (2 * delta) for e in np.eye(2 * n)])


@pytest.mark.parametrize("integrator", ["RK4", "Euler"])
def test_mujocos_own_step_map_agrees_with_the_one_applied(integrator):
    """An independent check, never the source: MuJoCo's own step (mj_step), differentiated at a state near rest of
    a damped, sprung double pendulum (h·|λ|max ≈ 2.2: near both limits), has the eigenvalues of the one-step map
    applied to the reference's linearization (RK4: R(hλ); Euler: G(h) with the joints' damping implicit). Near
    rest the step's own nonlinearity (the stages' A moving with the state) is ~1e-6 of it.
    (mjd_transitionFD would do, but MuJoCo 4.0 refuses it for RK4.)"""
    h = 0.02
    model = mujoco.MjModel.from_xml_string(CHAIN.format(h=h, integrator=integrator))
    qpos, qvel = np.array([1e-3, -2e-3]), np.array([1e-3, -2e-3])
    engine = np.sort_complex(np.linalg.eigvals(_step_jacobian(model, qpos, qvel)))
    lin = st.linearize(TreeDynamics.of(read_tree(model)), qpos[None, :], qvel[None, :])
    assert 1.5 < h * np.max(np.abs(lin.eigenvalues)) < 3
    if integrator == "RK4":
        ours = st.rk4_amplification(h * lin.eigenvalues[0])
    else:
        ours = np.linalg.eigvals(st.euler_map(lin, h, implicit_damping=True)[0])
    assert np.sort_complex(ours) == pytest.approx(engine, abs=1e-5)


def test_euler_drifting_on_a_gyroscopic_mode_is_judged_not_declared_unstable():
    """A spinning top: semi-implicit Euler amplifies its gyroscopic modes (imaginary λ from velocity coupling) by
    ~1 + h²ω²/2 at every step whatever h, so strictly it is never inside its region; over the horizon that is a
    drift its budget judges (×GROWTH at most), so at 10 times the shipped step it is not beyond the limit."""
    from harness.cases import get
    from harness.engine.models import compile_model

    case = get("symmetric_top")
    ref = case.reference(compile_model(case.mjcf))
    q, qd = ref.solution.state(np.linspace(0.0, case.horizon, st.STATES))
    undamped = {"integrators": ("Euler",), "implicit_damping": False}  # the top has no damping
    strict = st.assess(ref.dynamics, q, qd, timestep=0.01, **undamped)["Euler"]
    over_the_run = st.assess(ref.dynamics, q, qd, timestep=0.01, horizon=case.horizon, **undamped)
    assert strict.beyond and strict.region > 1.0  # outside the region, strictly
    assert not over_the_run["Euler"].beyond
    assert over_the_run["Euler"].limit > 0.01


@pytest.mark.slow
def test_dm_control_finger_rk4_is_beyond_its_stability_limit_and_euler_is_judged():
    """A model nobody here wrote (docs/findings/zoo.md): finger's distal link, damped and light, has a mode at
    λ ≈ −1509/s, so RK4 at the model's 10 ms (h|λ| ≈ 15) is beyond its limit (stable below ≈ 1.85 ms) and its run
    diverges; Euler, the model's own integrator, takes the damping implicitly and is judged, and leads."""
    from harness import zoo

    pytest.importorskip("dm_control")
    models, skipped = zoo.discover()
    finger = zoo.select(["dm_control/finger"], models, skipped)[0]
    row = zoo.judge(finger, integrators=("RK4", "Euler"))
    assert row.verdict == zoo.PASS and row.own == "Euler", row.line()
    assert list(row.stability) == ["RK4"]
    said = row.stability["RK4"]
    assert said.startswith("RK4 at h=0.01 s is beyond its stability limit (h·|λ|max = 15.1")
    assert "stable below h ≈ 0.00185 s" in said

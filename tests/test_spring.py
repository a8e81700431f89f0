"""Mass on a spring: seed equation, closed form against our reference and MuJoCo, energy
bookkeeping, the faults that trip every gate and the legitimate changes that pass them.

The closed form x(t) = c1 sin ωt + c2 cos ωt, ω² = k/m, c1 = ẋ0/ω, c2 = x0 is typed here by
hand (the seed's solution) and reads k and m straight from the MJCF, independently of
``spring.params_from_model``.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
import sympy as sp

from analytic import systems
from analytic.systems import spring
from harness import cases
from harness.engine import compat
from harness.engine.models import compile_model, mjcf_path
from harness.pipeline import run as pipeline
from harness.pipeline.limits import load_limits
from tests.conftest import assert_faults_cover, assert_passes, assert_trips, failing, shipped_run
from tests.helpers import armature, damping, each_integrator, stiffness

P = systems.symbols("spring")  # the parameters as sympy symbols

CASE = cases.get("spring")


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return compile_model(mjcf_path("spring"))


@pytest.fixture(scope="module")
def shipped() -> pipeline.CaseResult:
    return shipped_run("spring")


def physical(model: mujoco.MjModel) -> tuple[float, float, float]:
    """(m, k, l0) read directly from the compiled model."""
    return (float(model.body("mass").mass[0]), float(model.joint("x").stiffness[0]),
            float(model.body("mass").pos[0]))


def closed_form(t: np.ndarray, model: mujoco.MjModel) -> np.ndarray:
    """The seed's solution q(t) = c1 sin ωt + c2 cos ωt from the case's initial state."""
    m, k, _ = physical(model)
    omega = math.sqrt(k / m)
    c1, c2 = CASE.qd0["x"] / omega, CASE.q0["x"]
    return c1 * np.sin(omega * t) + c2 * np.cos(omega * t)


def test_derivation_is_the_seed_equation() -> None:
    der = systems.build("spring").derive()
    (x,), (x_d,) = der.system.q, der.system.qd
    x_dd = sp.Symbol("x_ddot", real=True)
    m, k = P.m, P.k
    assert sp.simplify(der.equations[0] - (m * x_dd + k * x)) == 0
    assert sp.simplify(der.energy - (m * x_d**2 / 2 + k * x**2 / 2)) == 0
    assert der.cyclic == ()


def test_params_come_from_the_model(model) -> None:
    m, k, l0 = physical(model)
    assert spring.params_from_model(model) == {"m": m, "k": k, "l0": l0}


def test_springref_other_than_zero_is_refused() -> None:
    def edit(spec: mujoco.MjSpec) -> None:
        spec.joint("x").springref = 0.1

    with pytest.raises(ValueError, match="springref"):
        spring.params_from_model(compile_model(mjcf_path("spring"), edit=edit))


def test_horizon_covers_several_periods(model) -> None:
    m, k, _ = physical(model)
    assert CASE.horizon / (2 * math.pi * math.sqrt(m / k)) > 4


def test_closed_form_matches_reference(model) -> None:
    ref = CASE.reference(model)
    t = np.linspace(0.0, CASE.horizon, 2001)
    q, _ = ref.solution.state(t)
    assert np.max(np.abs(q[:, 0] - closed_form(t, model))) < 1e-10


def test_closed_form_matches_mujoco_rk4(model, shipped) -> None:
    """RK4's error on ẍ = −ω²x is a phase lag of (ωh)⁵/120 per step, so after time T the
    position is off by at most A ω T (ωh)⁴/120; we allow ×2 and require the error to be of
    that order (≥ 1/4 of it), i.e. that the theory explains it."""
    m, k, l0 = physical(model)
    omega, h = math.sqrt(k / m), float(model.opt.timestep)
    amplitude = math.hypot(CASE.q0["x"], CASE.qd0["x"] / omega)
    bound = amplitude * omega * CASE.horizon * (omega * h) ** 4 / 120
    sim = shipped.simulations["RK4"]
    err = float(np.max(np.abs(sim.positions["mass"][:, 0] - l0 - closed_form(sim.t, model))))
    assert bound / 4 <= err <= 2 * bound


def test_mujoco_energy_is_spring_plus_kinetic(model) -> None:
    """The energy flag puts ½ k x² into energy[0]; gravity adds nothing at z = 0."""
    m, k, _ = physical(model)
    data = mujoco.MjData(model)
    for x, v in [(0.0, 0.0), (0.2, 1.0), (-0.3, -0.4)]:
        data.qpos[0], data.qvel[0] = x, v
        mujoco.mj_forward(model, data)
        assert data.energy[0] == pytest.approx(k * x**2 / 2, abs=1e-15)
        assert data.energy[1] == pytest.approx(m * v**2 / 2, abs=1e-15)


def _needs(integrator: str):
    """The integrator as a test parameter, skipped (with the reason) on a MuJoCo that lacks it."""
    why = compat.unavailable_reason(f"{integrator}.position")
    return pytest.param(integrator, marks=pytest.mark.skipif(bool(why), reason=why))


@pytest.mark.parametrize("name", [_needs("RK4"), _needs("discrete")])
def test_energy_drift_matches_integrator_theory(model, shipped, name) -> None:
    """RK4 loses N (ωh)⁶/72 of the energy; discrete (implicit in position, M + h²K) keeps a
    factor 1/(1 + (ωh)²) per step."""
    m, k, _ = physical(model)
    wh = math.sqrt(k / m) * float(model.opt.timestep)
    steps = len(shipped.simulations["RK4"].t) - 1
    expected = {"RK4": steps * wh**6 / 72, "discrete": 1 - (1 + wh**2) ** -steps}[name]
    energy = shipped.simulations[name].invariants["energy"]
    assert 1 - energy[-1] / energy[0] == pytest.approx(expected, rel=0.01), name


def test_shipped_case_passes_every_gate(shipped) -> None:
    limits = load_limits().for_case("spring")
    assert failing(shipped) == set()  # judge raises if a limit names no figure
    assert "reference.residual" not in limits  # identically 0 without constraints: cannot fail


def _set_mass(spec: mujoco.MjSpec) -> None:
    spec.body("mass").mass *= 1.02


def _tilt(spec: mujoco.MjSpec) -> None:
    spec.joint("x").axis = [1.0, 0.0, 0.02]


# Faults: physics the seed's system does not have -> the gates they must trip. Damping adds a force
# (forcing, accelerations) that drains energy; a tilted slide lets gravity push along it (forcing) and
# moves the mass off the x axis (kinematics); armature adds inertia the reference lacks (mass matrix,
# kinetic energy). Each changes the motion, so every integrator's position fails too.
FAULTS = {
    "damping 0.05 N s/m": (dict(edit=damping("x", 0.05)),
                           {"instant.forcing", "instant.qacc", "instant.point_acceleration",
                            # the slide transmits the damping force too: m(a − g) is off the spring's pull
                            "instant.sensor.slide_force", "instant.interaction.mass", "instant.sensor.mass_accel"}
                           | each_integrator("position", "drift.energy")),
    "slide tilted 20 mrad": (dict(edit=_tilt), {"instant.kinematics", "instant.forcing"} | each_integrator("position")),
    "armature 1e-3 kg": (dict(edit=armature("x", 1e-3)),
                         {"instant.mass_matrix", "instant.kinetic_energy", "instant.qacc"}
                         | each_integrator("position")),
}

# Legitimate changes: another stiffness or mass is another spring, which the reference reads from the
# model under test; a coarser timestep is explained by each integrator's order. Every gate passes.
SETTINGS = {
    "stiffness +2%": dict(edit=stiffness("x", 20.4)),
    "mass +2%": dict(edit=_set_mass),
    "timestep x4": dict(timestep=0.004),
}


@pytest.mark.parametrize("fault", list(FAULTS))
def test_a_fault_trips_its_gates(fault: str) -> None:
    assert_trips(CASE, *FAULTS[fault], fault)


@pytest.mark.parametrize("setting", list(SETTINGS))
def test_a_legitimate_change_passes_every_gate(setting: str) -> None:
    assert_passes(CASE, SETTINGS[setting], setting)


def test_every_gate_has_a_fault() -> None:
    assert_faults_cover("spring", FAULTS, generic=("converge",))

"""The double pendulum's own checks: the textbook equations and normal modes as independent closed
forms, MuJoCo's linearisation against them, and the horizon's claim about the chaos.

The generic checks (finite, deterministic, gates that pass and can fail, the report) come from the
registry like every case's; nothing here is needed for them.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
import sympy as sp

from analytic import systems
from analytic.solvers import solve
from harness import cases
from harness.core.options import RunOptions
from harness.engine.compat import full_mass_matrix
from harness.engine.models import compile_model
from harness.pipeline.run import run_case
from harness.reference.derivations import dynamics_of

CASE = cases.get("double_pendulum")
P = systems.symbols("double_pendulum")  # the parameters as sympy symbols


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return compile_model(CASE.mjcf)


def test_equations_are_the_textbook_ones_in_absolute_angles():
    """With φ1 = θ1, φ2 = θ1 + θ2 (absolute angles, as textbooks write it):
    (m1 + m2) l1 φ̈1 + m2 l2 φ̈2 cos(φ1 − φ2) + m2 l2 φ̇2² sin(φ1 − φ2) + (m1 + m2) g sin φ1 = 0,
    l2 φ̈2 + l1 φ̈1 cos(φ1 − φ2) − l1 φ̇1² sin(φ1 − φ2) + g sin φ2 = 0  (typed here, independently)."""
    d = systems.build("double_pendulum").derive()
    (t1, t2), (t1d, t2d) = d.system.q, d.system.qd
    t1dd, t2dd = sp.symbols("theta1_ddot theta2_ddot", real=True)
    m1, m2, l1, l2, g = P.m1, P.m2, P.l1, P.l2, P.g
    f1, f2 = t1, t1 + t2
    f1d, f2d, f1dd, f2dd = t1d, t1d + t2d, t1dd, t1dd + t2dd
    book1 = ((m1 + m2) * l1 * f1dd + m2 * l2 * f2dd * sp.cos(f1 - f2) + m2 * l2 * f2d**2 * sp.sin(f1 - f2)
             + (m1 + m2) * g * sp.sin(f1))
    book2 = l2 * f2dd + l1 * f1dd * sp.cos(f1 - f2) - l1 * f1d**2 * sp.sin(f1 - f2) + g * sp.sin(f2)
    # Lagrange's equations for θ1 and θ2 are combinations of the textbook's (θ1's is the φ1 and φ2
    # equations summed, θ2's the φ2 equation alone): E_θ2 = m2 l2 book2, E_θ1 = l1 book1 + m2 l2 book2
    eq_t1, eq_t2 = d.equations
    assert sp.simplify(eq_t2 - m2 * l2 * book2) == 0
    assert sp.simplify(eq_t1 - (l1 * book1 + m2 * l2 * book2)) == 0
    assert d.cyclic == ()


def _normal_modes(params: dict[str, float]) -> np.ndarray:
    """ω² of the two small-oscillation modes, closed form (absolute angles): ω² = g (m1 + m2) /
    (2 m1 l1 l2) · [(l1 + l2) ± √((l1 + l2)² − 4 m1 l1 l2 / (m1 + m2))]."""
    m1, m2, l1, l2, g = (params[k] for k in ("m1", "m2", "l1", "l2", "g"))
    root = np.sqrt((l1 + l2) ** 2 - 4 * m1 * l1 * l2 / (m1 + m2))
    return np.sort(g * (m1 + m2) / (2 * m1 * l1 * l2) * np.array([l1 + l2 - root, l1 + l2 + root]))


def _linearised(mass: np.ndarray, stiffness: np.ndarray) -> np.ndarray:
    return np.sort(np.linalg.eigvals(np.linalg.solve(mass, stiffness)).real)


def test_small_oscillations_have_the_closed_form_frequencies_in_both_models(model):
    params = systems.load("double_pendulum").params_from_model(model)
    expected = _normal_modes(params)
    # the reference: M(0) and K = −∂F/∂q at rest, by central differences of the derived forcing
    dyn = dynamics_of("double_pendulum", model)
    eps, zero = 1e-6, np.zeros(2)
    stiffness = -np.column_stack([(dyn.forcing(eps * e, zero) - dyn.forcing(-eps * e, zero)) / (2 * eps)
                                  for e in np.eye(2)])
    np.testing.assert_allclose(_linearised(dyn.mass_matrix(zero), stiffness), expected, rtol=1e-8)
    # MuJoCo: mj_fullM at rest, and K = ∂(qfrc_bias)/∂qpos (gravity) by the same differences
    data = mujoco.MjData(model)

    def bias(q: np.ndarray) -> np.ndarray:
        data.qpos[:], data.qvel[:] = q, 0.0
        mujoco.mj_forward(model, data)
        return data.qfrc_bias.copy()

    k_mj = np.column_stack([(bias(eps * e) - bias(-eps * e)) / (2 * eps) for e in np.eye(2)])
    bias(zero)
    # the point masses' inertia floor (diaginertia 1e-10 against m l² ≥ 0.125) bounds the agreement
    np.testing.assert_allclose(_linearised(full_mass_matrix(model, data), k_mj), expected, rtol=1e-8)


def test_the_horizon_keeps_the_chaos_small_and_the_motion_is_chaotic():
    """The docstring's claim: a perturbation of θ1(0) grows about 14× by the 3 s horizon, and by
    orders of magnitude beyond it (the motion is chaotic, so the horizon is what keeps the figures
    about the integrator)."""
    dyn = CASE.dynamics()
    q0 = np.array([CASE.q0["theta1"], CASE.q0["theta2"]])
    qd0 = np.array([CASE.qd0["theta1"], CASE.qd0["theta2"]])
    a = solve(dyn, q0=q0, qd0=qd0, t_end=6.0)
    b = solve(dyn, q0=q0 + np.array([1e-9, 0.0]), qd0=qd0, t_end=6.0)
    t = np.linspace(0.0, 6.0, 601)
    grown = np.linalg.norm(dyn.points(a.state(t)[0]) - dyn.points(b.state(t)[0]), axis=(1, 2)) / 1e-9
    within = np.max(grown[t <= CASE.horizon])
    assert CASE.horizon == 3.0 and within < 50
    assert np.max(grown) > 1e3 * within / 14  # beyond the horizon it grows by orders of magnitude


def test_mujoco_rk4_follows_the_reference_over_the_horizon():
    """The shipped integrator (RK4, 0.5 ms) stays within 1e-8 m of the reference over the 3 s (measured
    6.6e-10 m) and conserves energy to 1e-10 of m g L: the chaos does not swamp the comparison."""
    result = run_case(CASE, RunOptions(integrators=["RK4"]))
    assert result.figure("RK4.position").value < 1e-8
    assert result.figure("RK4.drift.energy").value < 1e-10

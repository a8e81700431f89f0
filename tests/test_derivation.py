"""Layer 1 for the pendulum: sympy's equations vs closed forms; the solvers vs each other."""

from __future__ import annotations

import numpy as np
import sympy as sp

from analytic import systems
from analytic.dynamics import Dynamics
from analytic.lagrangian import Constraint, LagrangianSystem, coordinates
from analytic.solvers import solve

SYM = systems.symbols("pendulum")  # the parameters as sympy symbols

P = {"m": 1.3, "g": 9.81, "l": 0.7}


def test_pendulum_equations_match_textbook():
    d = systems.build("pendulum").derive()
    m, g = SYM.m, SYM.g
    (theta, r), (theta_d, r_d) = d.system.q, d.system.qd
    # hand-typed independent forms: M = diag(m r², m); F = (−m r (g sinθ + 2 ṙ θ̇), m (r θ̇² + g cosθ))
    assert sp.simplify(d.mass_matrix - sp.diag(m * r**2, m)) == sp.zeros(2)
    expected_f = sp.Matrix([-m * r * (g * sp.sin(theta) + 2 * r_d * theta_d),
                            m * (r * theta_d**2 + g * sp.cos(theta))])
    assert sp.simplify(d.forcing - expected_f) == sp.zeros(2, 1)
    assert d.jacobian == sp.Matrix([[0, 1]])
    assert d.cyclic == ()


def test_multiplier_is_minus_tension_closed_form():
    """Convention pinned: λ = −(m l θ̇² + m g cos θ) on the constraint (λ outward radial force)."""
    dyn = Dynamics.build(systems.build("pendulum").derive(), P)
    rng = np.random.default_rng(1)
    th, thd = rng.uniform(-3, 3, 50), rng.uniform(-4, 4, 50)
    q = np.stack([th, np.full(50, P["l"])], axis=1)
    qd = np.stack([thd, np.zeros(50)], axis=1)
    qdd, lam = dyn.accelerations(q, qd)
    tension = P["m"] * P["l"] * thd**2 + P["m"] * P["g"] * np.cos(th)
    np.testing.assert_allclose(lam[:, 0], -tension, rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(qdd[:, 0], -P["g"] / P["l"] * np.sin(th), rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(qdd[:, 1], 0.0, atol=1e-12)


def test_dae_matches_minimal_ode_and_tension_over_time():
    dyn = Dynamics.build(systems.build("pendulum").derive(), P)
    dyn_min = Dynamics.build(systems.build("pendulum", minimal=True).derive(), P)
    t = np.linspace(0.0, 10.0, 2001)
    sol = solve(dyn, q0=[1.2, P["l"]], qd0=[0.3, 0.0], t_end=10.0, rtol=1e-12)
    sol_min = solve(dyn_min, q0=[1.2], qd0=[0.3], t_end=10.0, rtol=1e-12)
    q, qd = sol.state(t)
    qm, _ = sol_min.state(t)
    assert np.max(np.abs(q[:, 0] - qm[:, 0])) < 1e-9  # two independent paths, rtol 1e-12 each
    pos, vel = sol.residuals(t)
    assert np.max(np.abs(pos)) < 1e-12 and np.max(np.abs(vel)) < 1e-12
    tension = P["m"] * P["l"] * qd[:, 0] ** 2 + P["m"] * P["g"] * np.cos(q[:, 0])
    np.testing.assert_allclose(sol.multipliers(t)[:, 0], -tension, rtol=1e-9, atol=1e-9)
    energy = dyn.energy(q, qd)
    assert np.max(np.abs(energy - energy[0])) < 1e-9


def test_stabilization_controls_drift_of_a_broken_gamma():
    """With γ corrupted, Baumgarte keeps the residual bounded and the solution reports it."""
    dyn = Dynamics.build(systems.build("pendulum").derive(), P)
    broken = dict(dyn._funcs)
    good_gamma = broken["gamma"]
    broken["gamma"] = lambda *a: good_gamma(*a) + 1e-3
    bad = Dynamics(dyn.coordinates, dyn.constraint_names, dyn.point_names, dyn.cyclic, dyn.params, broken)
    t = np.linspace(0, 5, 501)
    pos, _ = solve(bad, q0=[1.0, P["l"]], qd0=[0.0, 0.0], t_end=5.0).residuals(t)
    assert np.max(np.abs(pos)) > 1e-6  # the fault is visible in the reported residual ...
    assert np.max(np.abs(pos)) < 1e-3 / 100 * 2  # ... and held near γ-error/ω² = 1e-5 by stabilization


def test_pfaffian_constraint_is_accepted_and_linear_checked():
    (x, phi), (xd, phid) = coordinates("x phi")
    a = sp.Symbol("a", positive=True)
    sys_ = LagrangianSystem(name="disk", q=(x, phi), qd=(xd, phid), kinetic=(xd**2 + phid**2) / 2,
                            potential=0, params=(a,),
                            constraints=(Constraint("roll", xd - a * phid, "pfaffian"),))
    assert sys_.derive().jacobian == sp.Matrix([[1, -a]])
    try:
        LagrangianSystem(name="bad", q=(x, phi), qd=(xd, phid), kinetic=xd**2, potential=0, params=(),
                         constraints=(Constraint("c", xd**2, "pfaffian"),))
    except ValueError as exc:
        assert "linear in velocities" in str(exc)
    else:
        raise AssertionError("non-linear Pfaffian row accepted")


def test_inconsistent_initial_state_is_refused():
    dyn = Dynamics.build(systems.build("pendulum").derive(), P)
    try:
        solve(dyn, q0=[0.1, P["l"] + 0.1], qd0=[0.0, 0.0], t_end=1.0)
    except ValueError as exc:
        assert "rod" in str(exc)
    else:
        raise AssertionError("off-manifold initial state accepted")


def test_tidy_simplifies_small_entries_and_only_expands_large_ones(monkeypatch):
    """Small entries keep simplify's exact form; a large one never reaches simplify (its cost, not its
    result, is what the threshold is about) and stays the same expression."""
    import analytic.lagrangian as lagrangian

    x, y = sp.symbols("x y", real=True)
    assert lagrangian.tidy(sp.sin(x) ** 2 + sp.cos(x) ** 2) == 1
    assert lagrangian.tidy((x**2 - 1) / (x - 1)) == x + 1
    large = sum(sp.sin(k * x + y) * (x + k) ** 2 for k in range(1, 30))
    assert sp.count_ops(large) > lagrangian.SIMPLIFY_MAX_OPS

    def refuse(expr, **_):
        raise AssertionError("simplify called on a large entry")

    monkeypatch.setattr(lagrangian.sp, "simplify", refuse)
    tidied = lagrangian.tidy(large)
    assert sp.count_ops(tidied) <= sp.count_ops(large)
    assert sp.expand(tidied - large) == 0

"""Our Radau IIA (analytic/radau.py): its constants are the method's, its steps converge at the method's orders on a
stiff linear problem with a closed form, its errors follow the tolerance, it agrees with an independent
implementation (scipy's Radau) and with our DOP853 where the motion is not stiff, and it does in a few hundred steps
a stiff motion DOP853 cannot do within its bound."""

from __future__ import annotations

import math

import numpy as np
import pytest

from analytic import dop853, radau

SQRT6 = math.sqrt(6.0)


# ------------------------------------------------------------------ the method's constants
def test_the_nodes_and_butcher_matrix_are_radau_iia():
    """Row sums are the nodes; the collocation conditions A c^(k−1) = c^k / k hold for k = 1..3 (stage order 3); the
    last row (the weights) integrates polynomials of degree 4 exactly (order 5)."""
    a, c = radau.A, radau.C
    assert np.abs(a.sum(axis=1) - c).max() < 1e-14
    for k in (1, 2, 3):
        assert np.abs(a @ c ** (k - 1) - c ** k / k).max() < 1e-14
    for k in range(5):
        assert math.isclose(float(a[-1] @ c ** k), 1.0 / (k + 1), rel_tol=0, abs_tol=1e-14)
    assert not math.isclose(float(a[-1] @ c ** 5), 1.0 / 6, rel_tol=0, abs_tol=1e-6)


def test_the_transformation_block_diagonalizes_the_inverse_matrix():
    """T⁻¹ A⁻¹ T = diag(γ, [[α, β], [−β, α]]) with Hairer's closed forms γ = 3 + 3^(2/3) − 3^(1/3),
    α − iβ = 3 + (3^(1/3) − 3^(2/3))/2 − i (3^(5/6) + 3^(7/6))/2."""
    gamma = 3 + 3 ** (2 / 3) - 3 ** (1 / 3)
    mu = complex(3 + 0.5 * (3 ** (1 / 3) - 3 ** (2 / 3)), -0.5 * (3 ** (5 / 6) + 3 ** (7 / 6)))
    assert math.isclose(radau.GAMMA, gamma, rel_tol=1e-14)
    assert abs(radau.MU - mu) < 1e-13
    block = radau.TI @ np.linalg.inv(radau.A) @ radau.T
    expected = np.array([[gamma, 0, 0], [0, mu.real, -mu.imag], [0, mu.imag, mu.real]])
    assert np.abs(block - expected).max() < 1e-12


def test_the_error_weights_vanish_on_the_collocation_polynomials_of_degree_below_three():
    """The embedded estimate γ₀ h f₀ + Σ e_i Z_i is zero for solutions the embedded formula integrates exactly: with
    Z_i = c_i^k (y = t^k, h = 1) and f₀ = y'(0), k = 1..3 (E is in units of γ₀ = 1/γ)."""
    for k in (1, 2, 3):
        f0 = 1.0 if k == 1 else 0.0
        assert abs(f0 + radau.E @ radau.C ** k) < 1e-13


# ------------------------------------------------------------------ a stiff linear problem with its closed form
LAMBDA = -1e6
STIFF = np.array([[LAMBDA, -1.0 - LAMBDA], [0.0, -1.0]])
"""y' = L y: a slow mode e^(−t) and one decaying at 1e6/s; y = (e^(−t) + (y₁(0) − 1) e^(λt), e^(−t)) from (y₁(0), 1)."""


def stiff(t, y):
    return y @ STIFF.T


def stiff_exact(t, y10=1.0):
    t = np.asarray(t, dtype=float)
    return np.stack([np.exp(-t) + (y10 - 1.0) * np.exp(LAMBDA * t), np.exp(-t)], axis=-1)


def one_step(h: float, at: float) -> float:
    """The error of one step of length h (tried first, and a tolerance of 1 accepts it; the exact Jacobian makes the
    collocation system, linear here, solved to round-off), read at the fraction ``at`` of the step."""
    res = radau.integrate(stiff, h, np.array([1.0, 1.0]), rtol=1.0, atol=1.0, jac=lambda t, y, f: STIFF,
                           first_step=h)
    assert res.steps == 1
    return float(np.abs(res.dense(np.array([at * h]))[0] - stiff_exact(at * h)).max())


def test_step_error_is_sixth_order_locally_on_a_stiff_problem():
    """Order 5: one step's error O(h⁶), so each halving divides it by 2⁶ = 64 in the limit (measured 57 and 60),
    though h λ is 5e4 and more; an explicit method's step would be unstable there, a lower order's ratio ≤ 32."""
    e = [one_step(h, 1.0) for h in (0.2, 0.1, 0.05)]
    assert e[0] / e[1] > 48 and e[1] / e[2] > 48, e


def test_interpolant_error_is_fourth_order_locally():
    """The collocation polynomial has stage order 3: mid-step error O(h⁴), each halving ÷ 16 (measured 15.7, 15.9)."""
    e = [one_step(h, 0.5) for h in (0.2, 0.1, 0.05)]
    assert e[0] / e[1] > 13 and e[1] / e[2] > 13, e


@pytest.mark.parametrize("rtol", [1e-6, 1e-9, 1e-12])
def test_the_error_follows_the_tolerance_through_the_stiff_transient(rtol):
    """From y₁(0) = 2 (off the slow manifold: a transient of 1 µs), over [0, 2], dense output anywhere: the
    error in units of atol + rtol |y| stays O(1) at every tolerance (measured 0.22, 0.16, 0.17)."""
    res = radau.integrate(stiff, 2.0, np.array([2.0, 1.0]), rtol=rtol, atol=rtol)
    t = np.concatenate([np.linspace(0.0, 1e-5, 201), np.linspace(1e-5, 2.0, 2001)])
    exact = stiff_exact(t, 2.0)
    assert np.max(np.abs(res.dense(t) - exact) / (rtol + rtol * np.abs(exact))) < 5


def test_a_stiff_motion_dop853_cannot_do_within_its_bound():
    """The stiff mode bounds DOP853's step by stability (|h λ| ≲ 6 at λ = −1e6): 2,000 steps reach ≈ 0.01 s of 1 s.
    Radau IIA needs a few hundred (measured 413, most of them through the 1 µs transient) at the same tolerance."""
    with pytest.raises(dop853.StepBudgetExceeded, match=r"reached t = 0\.01"):
        dop853.integrate(stiff, 1.0, np.array([2.0, 1.0]), rtol=1e-10, atol=1e-10, max_steps=2_000)
    res = radau.integrate(stiff, 1.0, np.array([2.0, 1.0]), rtol=1e-10, atol=1e-10)
    assert res.steps < 1000
    t = np.linspace(0.0, 1.0, 1001)
    assert np.abs(res.dense(t) - stiff_exact(t, 2.0)).max() < 1e-9


# ------------------------------------------------------------------ other problems, other solvers
def pendulum(t, y):
    return np.array([y[1], -9.81 * np.sin(y[0])])


def test_agrees_with_dop853_on_a_motion_that_is_not_stiff():
    """A pendulum at large amplitude over 5 s at rtol 1e-12: within the tolerance's units of our DOP853 solved
    10× tighter, step ends and dense output alike (measured 0.71)."""
    rtol = 1e-12
    ours = radau.integrate(pendulum, 5.0, np.array([2.5, 0.3]), rtol=rtol, atol=rtol)
    truth = dop853.integrate(pendulum, 5.0, np.array([2.5, 0.3]), rtol=rtol / 10, atol=rtol / 10)
    t = np.linspace(0.0, 5.0, 3001)
    ref = truth.dense(t)
    assert np.max(np.abs(ours.dense(t) - ref) / (rtol + rtol * np.abs(ref))) < 5
    assert np.array_equal(ours.dense(ours.dense.t_start), ours.dense.y_start)


def van_der_pol(t, y, mu=100.0):
    return np.array([y[1], mu * ((1.0 - y[0] ** 2) * y[1]) - y[0]])


def test_agrees_with_scipy_radau_on_a_stiff_nonlinear_problem():
    """Van der Pol at μ = 100 over one relaxation (stiff on its slow branches, fast through the jumps), rtol 1e-8:
    as many steps as scipy's Radau within 30 % (the same method and controller, another first step: measured 736
    and 737), and our error against DOP853 at 1e-12 no larger than 10× scipy's (measured 8.0 and 13.5 units of
    atol + rtol |y|: at the jumps the error is the global one of the tolerance, for both)."""
    solve_ivp = pytest.importorskip("scipy.integrate").solve_ivp
    y0 = np.array([2.0, 0.0])
    ours = radau.integrate(van_der_pol, 100.0, y0, rtol=1e-8, atol=1e-8)
    theirs = solve_ivp(van_der_pol, (0.0, 100.0), y0, method="Radau", rtol=1e-8, atol=1e-8, dense_output=True)
    assert abs(ours.steps - (len(theirs.t) - 1)) < 0.3 * ours.steps, (ours.steps, len(theirs.t) - 1)
    truth = dop853.integrate(van_der_pol, 100.0, y0, rtol=1e-12, atol=1e-12)
    t = np.linspace(0.0, 100.0, 4001)
    ref = truth.dense(t)
    units = 1e-8 + 1e-8 * np.abs(ref)
    ours_err = np.max(np.abs(ours.dense(t) - ref) / units)
    theirs_err = np.max(np.abs(theirs.sol(t).T - ref) / units)
    assert ours_err < 10 * max(theirs_err, 1.0), (ours_err, theirs_err)


# ------------------------------------------------------------------ failing loudly
def test_a_singularity_is_an_error_naming_the_time():
    with pytest.raises(dop853.IntegrationError, match=r"step size fell below .* at t = 1"):
        radau.integrate(lambda t, y: y * y, 2.0, np.array([1.0]), rtol=1e-6, atol=1e-6)


def test_a_non_finite_start_and_a_bad_argument_are_errors():
    with pytest.raises(dop853.IntegrationError, match="not finite at t = 0"):
        radau.integrate(lambda t, y: y * np.inf, 1.0, np.array([1.0]), rtol=1e-10, atol=1e-10)
    with pytest.raises(ValueError, match="t_end must be positive, got 0"):
        radau.integrate(pendulum, 0.0, np.array([1.0, 0.0]), rtol=1e-12, atol=1e-12)


def test_step_budget():
    with pytest.raises(dop853.StepBudgetExceeded, match="more than 5 steps"):
        radau.integrate(pendulum, 100.0, np.array([1.0, 0.0]), rtol=1e-12, atol=1e-12, max_steps=5)

"""Our DOP853 (analytic/dop853.py): its table satisfies the order conditions, it converges at its
orders, it agrees with an independent implementation (scipy's), and it fails loudly."""

from __future__ import annotations

import math

import numpy as np
import pytest

from analytic import dop853
from analytic import dop853_table as table

A = np.zeros((16, 16))
for s, row in enumerate(table.A):
    A[s, :s] = row
B = np.array(table.B)
C = np.array(table.C)


def test_stage_nodes_are_row_sums():
    """c_s = Σ_j a_sj for every stage, the extension's included: each stage is at its own time."""
    assert np.abs(A.sum(axis=1) - C).max() < 1e-14


@pytest.mark.parametrize("k", range(8))
def test_quadrature_conditions_to_order_8(k):
    """Σ b_i c_i^k = 1/(k+1), k = 0..7: the weights integrate polynomials of degree 7 exactly."""
    assert math.isclose(float(B @ C[:12] ** k), 1.0 / (k + 1), rel_tol=0, abs_tol=1e-14)


@pytest.mark.parametrize(("k", "m"), [(k, m) for k in range(7) for m in range(7 - k)])
def test_tree_conditions_to_order_8(k, m):
    """Σ_i b_i c_i^m Σ_j a_ij c_j^k = 1/((k+1)(k+m+2)) for k + m + 2 ≤ 8: the order conditions of the
    trees with one stage nested in another, which a stage row with a mistyped entry breaks."""
    a, c = A[:12, :12], C[:12]
    exact = 1.0 / ((k + 1) * (k + m + 2))
    assert math.isclose(float(B @ (c ** m * (a @ c ** k))), exact, rel_tol=0, abs_tol=1e-13)


def test_fsal_stage_and_error_estimators_are_consistent():
    """Stage 12 is the 8th-order solution itself; each estimator is a difference of two methods, so
    it annihilates constants (Σ e = 0) and linear functions (Σ e c = 0)."""
    assert np.array_equal(A[12, :12], B)
    for e in (np.array(table.E5), np.array(table.E3)):
        assert abs(e.sum()) < 1e-14
        assert abs(e @ C[:13]) < 1e-14


def oscillator(t, y):
    return np.array([y[1], -y[0]])


def test_dense_output_matches_the_closed_form():
    """y'' = −y from (1, 0): cos t everywhere in [0, 20], between and on step boundaries."""
    res = dop853.integrate(oscillator, 20.0, np.array([1.0, 0.0]), rtol=1e-12, atol=1e-12)
    t = np.linspace(0.0, 20.0, 4001)
    y = res.dense(t)
    assert y.shape == (4001, 2)
    assert np.abs(y[:, 0] - np.cos(t)).max() < 2e-11
    assert np.abs(y[:, 1] + np.sin(t)).max() < 2e-11
    assert res.dense.t_end == 20.0
    assert np.array_equal(res.dense(res.dense.t_start), res.dense.y_start)


def blow_up(t, y):
    """y' = y², y(0) = 1: y = 1/(1 − t), nonlinear (a linear test problem would flatter the method)."""
    return y * y


def one_step_errors(at: float) -> list[float]:
    """Errors of single steps h = 0.4, 0.2, 0.1 (a tolerance of 1 accepts the first try), read at
    the fraction ``at`` of the step through the dense output."""
    errors = []
    for h in (0.4, 0.2, 0.1):
        res = dop853.integrate(blow_up, h, np.array([1.0]), rtol=1.0, atol=1.0)
        assert res.steps == 1
        errors.append(abs(res.dense(np.array([at * h]))[0, 0] - 1.0 / (1.0 - at * h)))
    return errors


def test_step_error_is_at_least_ninth_order_locally():
    """An 8th-order step has local error O(h⁹): each halving of h divides it by ≥ 2⁹ = 512 in the
    limit (measured 2300 and 1009 here, where the small 9th-order term still competes with the
    10th); a mistyped weight or stage row drops the order and the ratio far below 400."""
    e = one_step_errors(1.0)
    assert e[0] / e[1] > 400 and e[1] / e[2] > 400, e


def test_interpolant_error_is_at_least_eighth_order_locally():
    """The continuous extension has order 7, local error O(h⁸): halving h divides the mid-step error
    by ≥ 2⁸ = 256 in the limit (measured 445 and 346); a wrong D entry leaves ≤ 2⁴."""
    e = one_step_errors(0.5)
    assert e[0] / e[1] > 180 and e[1] / e[2] > 180, e


def test_agrees_with_scipy_step_for_step():
    """The same published algorithm in scipy: as many steps and evaluations, the same values, on a
    nonlinear problem (a pendulum at large amplitude)."""
    solve_ivp = pytest.importorskip("scipy.integrate").solve_ivp

    def pendulum(t, y):
        return np.array([y[1], -9.81 * np.sin(y[0])])

    y0 = np.array([2.5, 0.3])
    ours = dop853.integrate(pendulum, 10.0, y0, rtol=1e-10, atol=1e-10)
    theirs = solve_ivp(pendulum, (0.0, 10.0), y0, method="DOP853", rtol=1e-10, atol=1e-10, dense_output=True)
    # as many steps (one more or fewer allowed: an accept/reject decision at the edge of the
    # tolerance may fall the other way under another summation order; measured: equal, and equal nfev)
    assert abs(ours.steps - (len(theirs.t) - 1)) <= 1
    # the step sizes follow from error estimates that are differences of nearly equal numbers, so a
    # different summation order moves the grid in its 9th digit (measured 6e-9) ...
    if ours.steps == len(theirs.t) - 1:
        assert np.abs(np.append(ours.dense.t_start, 10.0) - theirs.t).max() < 1e-7
    # ... while the solution agrees far below the tolerance (measured 7e-14)
    t = np.linspace(0.0, 10.0, 777)
    assert np.abs(ours.dense(t) - theirs.sol(t).T).max() < 1e-12


def test_a_singularity_is_an_error_naming_the_time():
    """y' = y² from 1 blows up at t = 1: the step size collapses there, and the error says so."""
    with pytest.raises(dop853.IntegrationError, match=r"step size fell below .* at t = 1$"):
        dop853.integrate(lambda t, y: y * y, 2.0, np.array([1.0]), rtol=1e-10, atol=1e-10)


def test_a_non_finite_right_hand_side_is_an_error():
    with pytest.raises(dop853.IntegrationError, match="not finite at t = 0"):
        dop853.integrate(lambda t, y: y * np.inf, 1.0, np.array([1.0]), rtol=1e-10, atol=1e-10)
    with pytest.raises(dop853.IntegrationError, match="step size fell below"):
        dop853.integrate(lambda t, y: np.sqrt(1.0 - t) * y if t < 0.5 else y + np.nan, 1.0, np.array([1.0]),
                         rtol=1e-10, atol=1e-10)


def test_t_end_must_be_positive():
    with pytest.raises(ValueError, match="t_end must be positive, got 0"):
        dop853.integrate(oscillator, 0.0, np.array([1.0, 0.0]), rtol=1e-12, atol=1e-12)


def test_step_budget():
    with pytest.raises(dop853.IntegrationError, match="more than 5 steps"):
        dop853.integrate(oscillator, 100.0, np.array([1.0, 0.0]), rtol=1e-12, atol=1e-12, max_steps=5)

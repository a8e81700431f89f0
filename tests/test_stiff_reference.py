"""The tree reference's stiff path (issue 43): Radau IIA chosen up front by a stated criterion, its Jacobian's
columns exact (on robots: tests/test_state_jacobian.py), and its accuracy against a closed form on a stiff model
(a damped slide on a light body)."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from analytic.solvers import STABILITY, explicit_steps, solve, state_jacobian
from analytic.tree import TreeDynamics
from harness.budget.reference import REFERENCE
from harness.reference.tree import read_tree

MASS, DAMPING, STIFFNESS = 1e-3, 1e3, 1e2  # ẍ = −1e6 ẋ − 1e5 x: a decay at 1e6 /s beside a slow one at 0.1 /s


def _slide(mass: float = MASS, damping: float = DAMPING, stiffness: float = STIFFNESS) -> TreeDynamics:
    xml = f"""<mujoco><option gravity="0 0 0"/><worldbody><body name="b">
      <joint name="x" type="slide" axis="1 0 0" damping="{damping}" stiffness="{stiffness}" springref="0"/>
      <inertial pos="0 0 0" mass="{mass}" diaginertia="1 1 1"/></body></worldbody></mujoco>"""
    return TreeDynamics.of(read_tree(mujoco.MjModel.from_xml_string(xml)))


def _rhs(dyn: TreeDynamics):
    n = dyn.n

    def rhs(_t, y):
        qdd, _ = dyn.accelerations(y[..., :n], y[..., n:])
        return np.concatenate([y[..., n:], qdd], axis=-1)
    return rhs


def test_the_jacobians_columns_are_exact():
    """m ẍ = −c ẋ − k x: ∂ẍ/∂ẋ = −c/m and ∂ẍ/∂x = −k/m exactly (to round-off)."""
    dyn = _slide()
    rhs = _rhs(dyn)
    y = np.array([0.3, -2.0])
    jac = state_jacobian(dyn, rhs, 0.0, y, rhs(0.0, y))
    assert jac[0].tolist() == [0.0, 1.0]
    assert jac[1, 1] == pytest.approx(-DAMPING / MASS, rel=1e-14)
    assert jac[1, 0] == pytest.approx(-STIFFNESS / MASS, rel=1e-14)


def test_a_stiff_motion_goes_to_radau_up_front_and_matches_the_closed_form():
    """c/m = 1e6 /s: DOP853 would need t ρ / 6.39 ≈ 1.6e5 steps over 1 s by stability alone, past the 20 000
    bound, so Radau IIA is chosen before any explicit step; its solution of the overdamped oscillator matches
    x(t) = A e^{r₁t} + B e^{r₂t} within the budget's reference allowance (REFERENCE × rtol × the size)."""
    dyn = _slide()
    rhs = _rhs(dyn)
    slow = -STIFFNESS / DAMPING * (1 + STIFFNESS / DAMPING * MASS / DAMPING)  # r₁ to second order in k m / c²
    y0 = np.array([1.0, slow])  # on the slow mode, as the own-model kick starts a robot (it spares the fast ones)
    steps, radius = explicit_steps(dyn, rhs, y0, 1.0)
    assert radius == pytest.approx(DAMPING / MASS, rel=1e-6) and steps == pytest.approx(radius / STABILITY)
    sol = solve(dyn, q0=y0[:1], qd0=y0[1:], t_end=1.0, max_steps=20_000, stiff=True)
    assert sol.method == "Radau IIA" and "by stability alone" in sol.why
    a, b = -DAMPING / MASS, -STIFFNESS / MASS  # ẍ = a ẋ + b x: r² − a r − b = 0
    r1, r2 = (a + math.sqrt(a * a + 4 * b)) / 2, (a - math.sqrt(a * a + 4 * b)) / 2
    c1 = (y0[1] - r2 * y0[0]) / (r1 - r2)  # x(0) = c₁ + c₂, ẋ(0) = r₁c₁ + r₂c₂
    c2 = y0[0] - c1
    assert abs(c2) < 1e-12  # the fast mode (1e6 /s) only as round-off stirs it: its stiffness bounds DOP853 still
    t = np.linspace(0.0, 1.0, 201)
    exact = c1 * np.exp(r1 * t) + c2 * np.exp(r2 * t)
    got = sol.state(t)[0][:, 0]
    assert np.max(np.abs(got - exact)) < REFERENCE * sol.rtol * np.max(np.abs(exact))
    assert sol.nfev < 5_000  # seconds, not the hours an explicit method's 1.6e5 steps would take


def test_a_motion_that_is_not_stiff_keeps_dop853():
    """The criterion's other side: a body of 1 kg on the same spring and a tenth of the damping (c/m = 100 /s, ω = 10
    rad/s) leaves DOP853 its solve."""
    dyn = _slide(mass=1.0, damping=DAMPING / 10)
    sol = solve(dyn, q0=np.array([1.0]), qd0=np.array([0.0]), t_end=1.0, max_steps=20_000, stiff=True)
    assert sol.method == "DOP853"


def test_the_stability_interval_is_dop853s():
    """STABILITY is where DOP853's stability function leaves the unit disc on the negative real axis, from its table."""
    from analytic import dop853_table as table

    a = np.array([list(row) + [0.0] * (12 - len(row)) for row in table.A[:12]])[:, :12]
    b = np.array(table.B)

    def modulus(x: float) -> float:
        return abs(1.0 - x * b @ np.linalg.solve(np.eye(12) + x * a, np.ones(12)))

    assert modulus(STABILITY - 0.01) <= 1.0 < modulus(STABILITY + 0.01)
    assert all(modulus(x) <= 1.0 for x in np.linspace(0.01, STABILITY - 0.01, 200))

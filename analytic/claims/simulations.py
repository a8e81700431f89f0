"""Claims of seed 001_c29a5107db08e1d9.txt ("Physics Simulations"): mass on a spring, the r-pendulum.

Transcribed as printed, in the document's variables. The document's
pendulum uses θ from the downward vertical (V = m g r (1 − cos θ) is zero at
the bottom) and, in its example, the sign convention
d/dt ∂L/∂q̇ − ∂L/∂q = λ ∂f/∂q, which is ours (M q̈ = F + Jᵀλ).
"""

from __future__ import annotations

import sympy as sp

from analytic.claims import Claim, doc_frame
from analytic.claims.view import T_SYMBOL, DocView
from analytic.systems import symbols

DOC = "001_c29a5107db08e1d9.txt"


def _spring_claims() -> list[Claim]:
    f = doc_frame("spring", "q", {"x": "q"})
    (q,), (qd,), (qdd,) = f.q, f.qd, f.qdd
    sym = symbols("spring")
    m, k = sym.m, sym.k
    omega = sp.sqrt(k / m)
    q0, v0 = sp.symbols("q0 v0", real=True)
    sec = "Mass on a Spring"

    def solution_check(view: DocView) -> tuple[bool, str]:
        c1, c2 = sp.symbols("c1 c2")
        sol = c1 * sp.sin(omega * T_SYMBOL) + c2 * sp.cos(omega * T_SYMBOL)
        eom = view.derivation.equations[0].subs({view.ours_qdd["x"]: sp.diff(sol, T_SYMBOL, 2),
                                                 view.ours_q["x"]: sol})
        general = sp.dsolve(m * sp.Function("x")(T_SYMBOL).diff(T_SYMBOL, 2) + k * sp.Function("x")(T_SYMBOL))
        two_constants = len(general.rhs.free_symbols - {T_SYMBOL, m, k}) == 2
        holds = sp.simplify(eom) == 0 and two_constants
        return holds, "solves m q̈ + k q = 0 for all c1, c2, and the general solution has two constants"

    return [
        Claim("001.spring.T", DOC, f"{sec}: T", r"T = \frac{1}{2}m\dot q^2", f, "value",
              claimed=m * qd**2 / 2, truth=lambda v: v.T, measure="kinetic"),
        Claim("001.spring.U", DOC, f"{sec}: U", r"U = \frac{1}{2}kq^2", f, "value",
              claimed=k * q**2 / 2, truth=lambda v: v.V, measure="potential"),
        Claim("001.spring.L", DOC, f"{sec}: L", r"L = T - U = \frac{1}{2}(m\dot q^2 - k q^2)", f, "value",
              claimed=(m * qd**2 - k * q**2) / 2, truth=lambda v: v.L, measure="lagrangian"),
        Claim("001.spring.eom", DOC, f"{sec}: equation of motion", r"m\ddot{q} + kq = 0", f, "equation",
              claimed=m * qdd + k * q),
        Claim("001.spring.omega", DOC, f"{sec}: ω² = k/m", r"\ddot q = -\frac{k}{m} q, \omega^2 = k/m", f,
              "value", claimed=-omega**2 * q, truth=lambda v: qdd, measure=None),
        Claim("001.spring.solution", DOC, f"{sec}: solution",
              r"q(t) = c_1 \sin(\omega t) + c_2 \cos(\omega t)", f, "statement",
              claimed=v0 / omega * sp.sin(omega * T_SYMBOL) + q0 * sp.cos(omega * T_SYMBOL),
              check=solution_check, measure="trajectory:x",
              note="c1 = q̇(0)/ω and c2 = q(0) fix the constants from the initial state"),
    ]


def _pendulum_claims() -> list[Claim]:
    f = doc_frame("pendulum", "theta r", lam={"rod": "lambda"})
    (th, r), (thd, rd), (thdd, rdd) = f.q, f.qd, f.qdd
    lam = f.lam["rod"]
    sym = symbols("pendulum")
    m, g, l = sym.m, sym.g, sym.l
    on_rod = {r: l, rd: 0, rdd: 0}
    small = {sp.sin(th): th, sp.cos(th): 1}
    sec = "Constraints (pendulum example)"
    doc_l = m * r**2 * thd**2 / 2 - m * g * r * (1 - sp.cos(th))
    return [
        Claim("001.pendulum.L", DOC, f"{sec}: Lagrangian",
              r"L = \frac{1}{2}mr^2\dot\theta^2 - mgr(1-\cos\theta)", f, "value_up_to_constant",
              claimed=doc_l, truth=lambda v: v.L, measure="lagrangian",
              note="as a function of (θ, r) it omits ½ m ṙ² and gives V an r-dependence m g r that the "
                   "bob's height −r cos θ does not have; on the constraint (r = l, ṙ = 0) it equals the "
                   "true L up to the constant m g l, so motions cannot tell, but the radial force can",
              numeric_blind="the difference vanishes on the constraint manifold, where MuJoCo's motion stays"),
        Claim("001.pendulum.eom_r", DOC, f"{sec}: r-equation after substitution",
              r"mr\dot \theta^2 + mg(1-\cos\theta) = \lambda", f, "equation",
              claimed=m * r * thd**2 + m * g * (1 - sp.cos(th)) - lam, manifold=on_rod,
              intended=-m * r * thd**2 - m * g * sp.cos(th) - lam,
              note="from the document's own L the r-equation is −m r θ̇² + m g (1 − cos θ) = λ (sign of "
                   "m r θ̇² lost); from the true L it is −m r θ̇² − m g cos θ = λ: λ is minus the tension"),
        Claim("001.pendulum.eom_theta", DOC, f"{sec}: θ-equation after substitution",
              r"mr^2 \ddot \theta + mgr \sin \theta= 0", f, "equation",
              claimed=m * r**2 * thdd + m * g * r * sp.sin(th), manifold=on_rod,
              note="omits 2 m r ṙ θ̇, which vanishes on the constraint (ṙ = 0)"),
        Claim("001.pendulum.small_angle_lambda", DOC, f"{sec}: small-angle tension",
              r"ml\dot \theta^2 = \lambda", f, "equation",
              claimed=m * l * thd**2 - lam, manifold=on_rod, approximation=small, approx_symbol=th,
              small_motion=0.05, intended=-m * l * thd**2 - m * g - lam,
              note="'the magnitude of the force acting on the mass to maintain the constraint': the "
                   "tension is m g + m l θ̇² to this order; the weight m g is missing"),
        Claim("001.pendulum.small_angle_eom", DOC, f"{sec}: small-angle equation of motion",
              r"ml^2 \ddot \theta + mgl\theta = 0", f, "equation",
              claimed=m * l**2 * thdd + m * g * l * th, manifold=on_rod, approximation=small,
              approx_symbol=th, small_motion=0.05),
    ]


def _general_claims() -> list[Claim]:
    f = doc_frame("pendulum", "theta r", lam={"rod": "lambda"})

    def sign_convention(view: DocView) -> tuple[bool, str]:
        return False, ("the general equation has +Σλ ∂f/∂q on the left (λ = +tension for the pendulum) "
                       "while the example puts λ ∂f/∂q on the right (λ = −tension); the document says the "
                       "sign of λ is arbitrary, so neither is wrong, but the two displays disagree")

    def inequality(view: DocView) -> tuple[bool, str]:
        return False, ("calls inequality constraints nonholonomic (as Goldstein does); seed 000 calls them "
                       "holonomic: a terminology the two documents do not share")

    return [
        Claim("001.general.lambda_sign", DOC, "Constraints: Euler–Lagrange equation with constraints",
              r"\frac{d}{dt}\frac{\partial L}{\partial \dot q_i} - \frac{\partial L}{\partial q_i} + "
              r"\sum_j \lambda_j \frac{\partial f_j}{\partial q_i} = 0", f, "statement",
              check=sign_convention, ambiguity="sign of λ"),
        Claim("001.general.inequality", DOC, "Constraints: definition",
              "A nonholonomic constraint is any constraint inexpressible in this manner (e.g. an inequality).",
              f, "statement", check=inequality, ambiguity="whether inequalities count as holonomic"),
    ]


def claims() -> list[Claim]:
    return [*_spring_claims(), *_pendulum_claims(), *_general_claims()]

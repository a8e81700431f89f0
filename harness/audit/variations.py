"""Claims of seed 001 ("Physics Simulations"), lines 9–14: the principle of least action and the calculus of variations.

The displays hold for any Lagrangian and any path, so they are checked as
identities for a generic L(q, q̇) (an undefined sympy function) along a path
q(t) with a variation η(t) = δq(t): q, q̇, q̈, η, η̇ are independent symbols and
d/dt applies the chain rule. Where a display says something about motions
(the action is stationary, or least, on the true path) it is checked on the
document's own example, the mass on a spring, and numerically on MuJoCo's
path of that spring (harness/audit/numbers.py, kind "action").
"""

from __future__ import annotations

import functools

import sympy as sp

from harness.audit import Claim, ClaimReading, Frame, doc_frame
from harness.audit.checks import stationary
from harness.audit.frames import SIMULATIONS as DOC
from harness.audit.frames import spring_frame
from harness.audit.view import T_SYMBOL, DocView

__all__ = ["claims"]

SEC_ACTION = "Principle of Least Action"
SEC_COV = "Calculus of Variations"
LANDAU = ("Landau & Lifshitz, Mechanics, 3rd ed., §2 (the action need be a minimum only over short enough "
          "segments of the path); Goldstein, Classical Mechanics, 3rd ed., §2.1 (Hamilton's principle: the "
          "action has a stationary value)")

Q, QD, QDD, ETA, ETAD, EPS = sp.symbols("q q_dot q_ddot eta eta_dot epsilon", real=True)
GENERIC_L = sp.Function("L")(Q, QD)


def _ddt(expr: sp.Expr) -> sp.Expr:
    """d/dt along the path and the variation: q → q̇ → q̈, η → η̇ (η̈ does not occur in these displays)."""
    return sp.diff(expr, Q) * QD + sp.diff(expr, QD) * QDD + sp.diff(expr, ETA) * ETAD


def _first_order() -> sp.Expr:
    """The first-order change of L(q + εη, q̇ + εη̇): d/dε at ε = 0."""
    return sp.diff(GENERIC_L.subs({Q: Q + EPS * ETA, QD: QD + EPS * ETAD}, simultaneous=True), EPS).subs(
        EPS, 0).doit()


def _identity(name: str, lhs: sp.Expr, rhs: sp.Expr) -> tuple[bool, str]:
    holds = sp.simplify(lhs - rhs) == 0
    return holds, f"{name}, for a generic L(q, q̇): {'identical' if holds else 'not identical'}"


def _expansion_printed(_: DocView) -> tuple[bool, str]:
    return False, ("S = ∫L dt is a functional of the whole path; ∂S/∂q at an instant is not defined. The "
                   "expansion holds for the integrand L, which the next line uses")


def _expansion_intended(_: DocView) -> tuple[bool, str]:
    dl = sp.diff(GENERIC_L, Q) * ETA + sp.diff(GENERIC_L, QD) * ETAD
    return _identity("δL = ∂L/∂q δq + ∂L/∂q̇ δq̇ to first order", _first_order(), dl)


def _first_variation(_: DocView) -> tuple[bool, str]:
    integrand = sp.diff(GENERIC_L, Q) * ETA + sp.diff(GENERIC_L, QD) * ETAD  # (∂L/∂q + ∂L/∂q̇ d/dt) δq
    return _identity("the first-order change of L along q + εη", _first_order(), integrand)


def _by_parts(_: DocView) -> tuple[bool, str]:
    before = sp.diff(GENERIC_L, Q) * ETA + sp.diff(GENERIC_L, QD) * ETAD
    after = (sp.diff(GENERIC_L, Q) - _ddt(sp.diff(GENERIC_L, QD))) * ETA
    boundary = ETA * sp.diff(GENERIC_L, QD)
    return _identity("the integrands differ by d/dt(δq ∂L/∂q̇), the boundary term", before, after + _ddt(boundary))


def _boundary(_: DocView) -> tuple[bool, str]:
    boundary = ETA * sp.diff(GENERIC_L, QD)
    holds = boundary.subs(ETA, 0) == 0
    return holds, "δq ∂L/∂q̇ vanishes at t₁ and t₂ because δq(t₁) = δq(t₂) = 0"


@functools.cache
def _second_variation(view: DocView) -> tuple[sp.Expr, sp.Symbol, sp.Expr]:
    """(δ²S for η = sin(πt/τ) over [0, τ], τ, the τ beyond which it is negative) for a quadratic L."""
    tau = sp.Symbol("tau", positive=True)
    (q,), (qd,) = view.frame.q, view.frame.qd
    lag = view.L
    coeffs = [sp.diff(lag, qd, 2), sp.diff(lag, q, qd), sp.diff(lag, q, 2)]
    if any(c.free_symbols & {q, qd} for c in coeffs):
        raise ValueError("the second variation is computed for a Lagrangian quadratic in q, q̇")
    eta = sp.sin(sp.pi * T_SYMBOL / tau)
    eta_d = sp.diff(eta, T_SYMBOL)
    second = sp.simplify(sp.integrate(coeffs[0] * eta_d**2 + 2 * coeffs[1] * eta * eta_d + coeffs[2] * eta**2,
                                      (T_SYMBOL, 0, tau)))
    (limit,) = sp.solve(second, tau)
    return second, tau, limit


def _least(view: DocView) -> tuple[bool, str]:
    second, tau, limit = _second_variation(view)
    longer = sp.simplify(second.subs(tau, 2 * limit))
    holds = not longer.is_negative
    return holds, (f"δ²S[sin(πt/τ)] = {second} (times ε²) is negative once τ > {limit} = π/ω: over a longer "
                   "interval the true path is a saddle of S, not a minimum")


def _stationary_and_short(view: DocView) -> tuple[bool, str]:
    holds, why = stationary()(view)
    second, tau, limit = _second_variation(view)
    shorter = sp.simplify(second.subs(tau, limit / 2))
    return holds and bool(shorter.is_positive), f"{why}; a minimum for τ < {limit}"


def _solution(view: DocView) -> tuple[sp.Expr, sp.Symbol, sp.Symbol]:
    (q,), (qdd,) = view.frame.q, view.frame.qdd
    omega = sp.sqrt(sp.simplify(-view.solved[qdd] / q))
    c1, c2 = sp.symbols("c1 c2", real=True)
    return c1 * sp.sin(omega * T_SYMBOL) + c2 * sp.cos(omega * T_SYMBOL), c1, c2


def _ends_in_q(view: DocView) -> tuple[bool, str]:
    path, c1, c2 = _solution(view)
    tau = sp.Symbol("tau", positive=True)
    system = sp.Matrix([path.subs(T_SYMBOL, 0), path.subs(T_SYMBOL, tau)]).jacobian([c1, c2])
    det = sp.simplify(system.det())
    return det != 0, (f"q(t₁) = q₁, q(t₂) = q₂ fix the spring's path (determinant {det}, nonzero unless τ is a "
                      "multiple of the half period): q̇ at the ends follows from it")


def _ends_in_state(view: DocView) -> tuple[bool, str]:
    path, c1, c2 = _solution(view)
    tau = sp.Symbol("tau", positive=True)
    conditions = sp.Matrix([path.subs(T_SYMBOL, 0), sp.diff(path, T_SYMBOL).subs(T_SYMBOL, 0),
                            path.subs(T_SYMBOL, tau), sp.diff(path, T_SYMBOL).subs(T_SYMBOL, tau)])
    rank = conditions.jacobian([c1, c2]).rank(simplify=True)
    return rank >= conditions.rows, (f"four conditions (q and q̇ at both ends) on a path with {rank} free "
                                     "constants: q̇₁, q̇₂ cannot be prescribed as well, and δq̇ at the ends is not zero")


@functools.cache
def _spherical_ours() -> Frame:
    return doc_frame("spherical_pendulum", "theta phi", reading="our spherical pendulum (θ from the downward "
                                                                "vertical): an instance with two coordinates")


def claims() -> list[Claim]:
    f = spring_frame()
    lagrange_form = "d/dt ∂L/∂q̇ − ∂L/∂q = 0"
    identity = "an identity of the calculus of variations (any L, any path): checked symbolically, no motion tests it"
    return [
        Claim("001.action.least", DOC, f"{SEC_ACTION}: the principle",
              "The principle of least action states that the equations of motion are defined by minimizing the "
              r"action: \delta S = 0", f, "statement", check=_least, claimed=lambda v: v.L, measure="action:minimum",
              intended_check=_stationary_and_short,
              corrected_text="the equations of motion make the action stationary, δS = 0; S is a minimum only "
                             "over short enough intervals (for the spring, t₂ − t₁ < π/ω)",
              project_text=f"δS = 0 ⇔ {lagrange_form} (Hamilton's principle)",
              note=f"'minimizing' is repeated in the calculus-of-variations paragraph (line 14). See {LANDAU}"),
        Claim("001.cov.endpoints", DOC, f"{SEC_COV}: fixed ends",
              r"a path in phase space from the point $(q_1, \dot{q_1})$ to $(q_2, \dot{q_2})$", f, "statement",
              check=_ends_in_q, no_numbers="a statement about which end conditions are fixed",
              ambiguity="which ends are fixed: the variation below fixes q only (δq(t₁) = δq(t₂) = 0); a path "
                        "'from (q₁, q̇₁) to (q₂, q̇₂)' suggests the velocities too",
              readings=(ClaimReading("only q₁ and q₂ are prescribed; (q, q̇) at the ends are the path's own",
                                text="q(t₁) = q₁, q(t₂) = q₂, δq(t₁) = δq(t₂) = 0", check=_ends_in_q),
                        ClaimReading("both q and q̇ prescribed at each end",
                                text="q(t₁) = q₁, q̇(t₁) = q̇₁, q(t₂) = q₂, q̇(t₂) = q̇₂", check=_ends_in_state)),
              note="'phase space' usually means (q, p); here (q, q̇), which for the spring is the same up to p = m q̇"),
        Claim("001.cov.expansion", DOC, f"{SEC_COV}: first-order expansion",
              r"\delta S = \frac{\partial S}{\partial q}\delta q + \frac{\partial S}{\partial \dot{q}}\delta \dot q",
              f, "statement", check=_expansion_printed, intended_check=_expansion_intended,
              corrected_text="δL = ∂L/∂q δq + ∂L/∂q̇ δq̇ (and δS = ∫ δL dt)", project_text="the same",
              slip="S for L: the text says 'expand S', but the next display integrates ∂L/∂q δq + ∂L/∂q̇ δq̇",
              no_numbers=identity),
        Claim("001.cov.first_variation", DOC, f"{SEC_COV}: first variation",
              r"\delta S = \int_{t_1}^{t_2} \left(\frac{\partial L}{\partial q} + \frac{\partial L}{\partial \dot{q}}"
              r"\frac{d}{dt}\right) \delta q dt", f, "statement", check=_first_variation, no_numbers=identity),
        Claim("001.cov.by_parts", DOC, f"{SEC_COV}: integration by parts",
              r"\delta S = \int_{t_1}^{t_2} \left(\frac{\partial L}{\partial q} - \frac{d}{dt}\frac{\partial L}"
              r"{\partial \dot{q}}\right) \delta q dt + \delta q\frac{\partial L}{\partial \dot{q}}\bigg\rvert_{t_1}"
              r"^{t_2}", f, "statement", check=_by_parts, no_numbers=identity),
        Claim("001.cov.boundary", DOC, f"{SEC_COV}: boundary term",
              r"The boundary term from the integral is $0$ because $\delta q$ doesn't change the path at the "
              "boundaries", f, "statement", check=_boundary, no_numbers=identity),
        Claim("001.cov.stationary_integral", DOC, f"{SEC_COV}: stationarity",
              r"\int_{t_1}^{t_2} \left(\frac{\partial L}{\partial q} - \frac{d}{dt}\frac{\partial L}{\partial "
              r"\dot{q}}\right)\delta q dt = 0", f, "statement", check=stationary(), claimed=lambda v: v.L,
              measure="action:stationary", note="instance: the spring, along MuJoCo's path"),
        Claim("001.cov.euler_lagrange", DOC, f"{SEC_COV}: Euler–Lagrange equation",
              r"\frac{d}{dt}\frac{\partial L}{\partial \dot{q}}-\frac{\partial L}{\partial q} = 0", f, "equation",
              claimed=lambda v: v.lagrange(), note="instance: the spring, our L"),
        Claim("001.cov.eq1", DOC, f"{SEC_COV}: equation (1)",
              r"\frac{d}{dt}\frac{\partial L}{\partial \dot{q_i}}-\frac{\partial L}{\partial q_i} = 0",
              _spherical_ours(), "equation", claimed=lambda v: v.lagrange(),
              note="the multi-dimensional case, on an unconstrained system with two coordinates: our spherical "
                   "pendulum (the document's own examples have one coordinate or constraints)"),
    ]

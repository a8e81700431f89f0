"""Claims of seed 001_c29a5107db08e1d9.txt ("Physics Simulations"): mass on a spring, constraints, the r-pendulum.

Transcribed as printed, in the document's variables. The document's
pendulum uses θ from the downward vertical (V = m g r (1 − cos θ) is zero at
the bottom). Its λ is fixed by the augmented action it writes,
S = ∫(L + Σ λ_j f_j) dt, whose Euler–Lagrange equations are
d/dt ∂L/∂q̇ − ∂L/∂q = Σ λ ∂f/∂q: our convention (M q̈ = F + Jᵀλ), so λ is our
``rod`` multiplier, minus the rod tension. Its example uses the same sign;
its general equation (2) the opposite one (001.general.lambda_sign). The least
action and calculus-of-variations part (lines 9–14) is in
:mod:`harness.audit.variations`.
"""

from __future__ import annotations

import sympy as sp

from analytic.systems import symbols
from harness.audit import Claim, ClaimReading, variations
from harness.audit.checks import inequality_bounds_a_region, position_check, solves
from harness.audit.frames import GOLDSTEIN_1_3, SIMULATIONS, pendulum_frame, pendulum_frame_flipped, spring_frame
from harness.audit.view import T_SYMBOL, DocView

__all__ = ["claims"]

DOC = SIMULATIONS

def _spring_claims() -> list[Claim]:
    f = spring_frame()
    (q,), (qd,), (qdd,) = f.q, f.qd, f.qdd
    sym = symbols("spring")
    m, k = sym.m, sym.k
    omega = sp.sqrt(k / m)
    q0, v0 = sp.symbols("q0 v0", real=True)
    sec = "Mass on a Spring"

    c1, c2 = sp.symbols("c1 c2", real=True)
    general = c1 * sp.sin(omega * T_SYMBOL) + c2 * sp.cos(omega * T_SYMBOL)

    def solution_check(view: DocView) -> tuple[bool, str]:
        holds, why = solves(general)(view)
        # two constants, and independent ones: the Wronskian of sin ωt, cos ωt is −ω ≠ 0
        modes = [sp.diff(general, c) for c in (c1, c2)]
        wronskian = sp.simplify(sp.Matrix([modes, [sp.diff(mode, T_SYMBOL) for mode in modes]]).det())
        return holds and wronskian != 0, f"{why} for all c1, c2, two independent constants (Wronskian {wronskian})"

    return [
        Claim("001.spring.T", DOC, f"{sec}: T", r"T = \frac{1}{2}m\dot q^2", f, "value",
              claimed=m * qd**2 / 2, truth=lambda v: v.T, measure="kinetic", lhs="T"),
        Claim("001.spring.U", DOC, f"{sec}: U", r"U = \frac{1}{2}kq^2", f, "value",
              claimed=k * q**2 / 2, truth=lambda v: v.V, measure="potential", lhs="U"),
        Claim("001.spring.L", DOC, f"{sec}: L", r"L = T - U = \frac{1}{2}(m\dot q^2 - k q^2)", f, "value",
              claimed=(m * qd**2 - k * q**2) / 2, truth=lambda v: v.L, measure="lagrangian", lhs="L"),
        Claim("001.spring.eom", DOC, f"{sec}: equation of motion", r"m\ddot{q} + kq = 0", f, "equation",
              claimed=m * qdd + k * q),
        Claim("001.spring.omega", DOC, f"{sec}: ω² = k/m", r"\ddot q = -\frac{k}{m} q, \omega^2 = k/m", f,
              "value", claimed=-omega**2 * q, truth=lambda v: qdd, lhs="q̈"),
        Claim("001.spring.solution", DOC, f"{sec}: solution",
              r"q(t) = c_1 \sin(\omega t) + c_2 \cos(\omega t)", f, "statement",
              claimed=v0 / omega * sp.sin(omega * T_SYMBOL) + q0 * sp.cos(omega * T_SYMBOL),
              check=solution_check, measure="trajectory:x",
              note="c1 = q̇(0)/ω and c2 = q(0) fix the constants from the initial state"),
    ]


def _pendulum_claims() -> list[Claim]:
    f = pendulum_frame()
    (th, r), (thd, rd), (thdd, rdd) = f.q, f.qd, f.qdd
    lam = f.lam["rod"]
    tension = sp.Symbol("T_rod", real=True)  # the rod tension; T is the kinetic energy in this document
    sym = symbols("pendulum")
    m, g, l = sym.m, sym.g, sym.l
    on_rod = {r: l, rd: 0, rdd: 0}
    small = {sp.sin(th): th, sp.cos(th): 1}
    sec = "Constraints (pendulum example)"
    doc_l = m * r**2 * thd**2 / 2 - m * g * r * (1 - sp.cos(th))
    lagrange = 1  # index of r in (theta, r)

    def unit_gradient(view: DocView) -> tuple[bool, str]:
        x, z = sp.symbols("x z", real=True)
        dist = sp.sqrt(x**2 + z**2) - l  # f = r − l in the bob's Cartesian position
        norm = sp.simplify(sp.sqrt(sum(sp.diff(dist, c) ** 2 for c in (x, z))))
        holds = norm == 1 and sp.diff(view.rows[0], rd) == 1
        return holds, ("|∇f| = 1 for f = r − l in the bob's (x, z): the force λ ∇f on the bob has magnitude |λ| "
                       "(our λ = −tension)")

    def sign_free(view: DocView) -> tuple[bool, str]:
        d = view.derivation
        qdd = sp.Matrix([view.ours_qdd[c.name] for c in d.system.q])
        flipped = sp.solve(list(d.mass_matrix * qdd - d.forcing + d.jacobian.T * sp.Matrix(d.multiplier_symbols))
                           + list(-d.jacobian * qdd + d.gamma), [*qdd, *d.multiplier_symbols], dict=True)[0]
        same = all(sp.simplify(view.doc(flipped[a]) - view.doc(a).subs(view.solved)) == 0 for a in qdd)
        return same, "writing −λ for λ leaves q̈ as it is and only flips λ's sign"

    return [
        Claim("001.pendulum.L", DOC, f"{sec}: Lagrangian",
              r"L = \frac{1}{2}mr^2\dot\theta^2 - mgr(1-\cos\theta)", f, "value_up_to_constant",
              claimed=doc_l, truth=lambda v: v.L, measure="lagrangian", projection=on_rod, lhs="L",
              intended=m * (r**2 * thd**2 + rd**2) / 2 + m * g * r * sp.cos(th),
              note="as a function of (θ, r) it omits ½ m ṙ² and gives V an r-dependence m g r that the "
                   "bob's height −r cos θ does not have; on the constraint (r = l, ṙ = 0) it equals the "
                   "true L up to the constant m g l, so motions cannot tell, but the radial equation can "
                   "(001.pendulum.eom_r)",
              numeric_blind="on the constraint manifold the claim differs from the true L by the constant m g l; "
                            "MuJoCo's soft equality lets r drift (about 1e-8 m), and that drift's effect on the "
                            "claim (the r-dependence m g r) is allowed for in the floor"),
        Claim("001.pendulum.constraint", DOC, f"{sec}: the constraint", r"r - l = 0", f, "statement",
              claimed=r - l, check=position_check(r - l), measure="position"),
        Claim("001.pendulum.lambda_arbitrary", DOC, f"{sec}: sign of λ", "the sign on λ is arbitrary", f,
              "statement", check=sign_free),
        Claim("001.pendulum.el_r", DOC, f"{sec}: Euler–Lagrange equation for r",
              r"\frac{d}{dt}\frac{\partial L}{\partial \dot r} - \frac{\partial L}{\partial r} = "
              r"\lambda \frac{\partial}{\partial r}\left[r-l\right]", f, "equation",
              claimed=lambda v: v.lagrange()[lagrange] - lam * sp.diff(r - l, r),
              note="instance: our L (the general form, before the document's L is put in)"),
        Claim("001.pendulum.el_theta", DOC, f"{sec}: Euler–Lagrange equation for θ",
              r"\frac{d}{dt}\frac{\partial L}{\partial \dot \theta} - \frac{\partial L}{\partial \theta} = "
              r"\lambda \frac{\partial}{\partial \theta}\left[r-l\right]", f, "equation",
              claimed=lambda v: v.lagrange()[0] - lam * sp.diff(r - l, th),
              note="instance: our L (the general form, before the document's L is put in)"),
        Claim("001.pendulum.eom_r", DOC, f"{sec}: r-equation after substitution",
              r"mr\dot \theta^2 + mg(1-\cos\theta) = \lambda", f, "equation",
              claimed=m * r * thd**2 + m * g * (1 - sp.cos(th)) - lam, manifold=on_rod,
              intended=sp.Eq(m * r * thd**2 + m * g * sp.cos(th), tension), aliases={tension: -lam},
              note="from the document's own L the r-equation is −m r θ̇² + m g (1 − cos θ) = λ (sign of "
                   "m r θ̇² lost); from the true L it is −m r θ̇² − m g cos θ = λ: λ is minus the rod tension T_rod"),
        Claim("001.pendulum.eom_theta", DOC, f"{sec}: θ-equation after substitution",
              r"mr^2 \ddot \theta + mgr \sin \theta= 0", f, "equation",
              claimed=m * r**2 * thdd + m * g * r * sp.sin(th), manifold=on_rod,
              note="omits 2 m r ṙ θ̇, which vanishes on the constraint (ṙ = 0)"),
        Claim("001.pendulum.small_angle_lambda", DOC, f"{sec}: small-angle tension",
              r"ml\dot \theta^2 = \lambda", f, "equation",
              claimed=m * l * thd**2 - lam, manifold=on_rod, approximation=small, approx_symbol=th,
              small_motion=0.05, intended=sp.Eq(m * l * thd**2 + m * g, tension), aliases={tension: -lam},
              note="'the magnitude of the force acting on the mass to maintain the constraint': the "
                   "rod tension T_rod = −λ is m g + m l θ̇² to this order; the weight m g is missing"),
        Claim("001.pendulum.small_angle_eom", DOC, f"{sec}: small-angle equation of motion",
              r"ml^2 \ddot \theta + mgl\theta = 0", f, "equation",
              claimed=m * l**2 * thdd + m * g * l * th, manifold=on_rod, approximation=small,
              approx_symbol=th, small_motion=0.05,
              note="'the usual equation of motion for a simple pendulum': θ̈ = −(g/l) θ"),
        Claim("001.pendulum.force_magnitude", DOC, f"{sec}: meaning of λ",
              "The first equation tells us the magnitude of the force acting on the mass to maintain the "
              "constraint", f, "statement", check=unit_gradient,
              note="true of λ (|λ| = T_rod, the rod tension); the value the printed first equation gives it, "
                   "m l θ̇², is not that magnitude (001.pendulum.small_angle_lambda)"),
    ]


def _general_claims() -> list[Claim]:
    f = pendulum_frame()
    flipped = pendulum_frame_flipped()
    sec = "Constraints"

    def multipliers(view: DocView) -> tuple[bool, str]:
        holds = all(lam in view.solved for lam in view.frame.lam.values())
        return holds, "q̈ and λ solve uniquely from the Lagrange equations with multipliers and the constraint"

    def independent_terms(view: DocView) -> tuple[bool, str]:
        r_col = view.xi[:, view.frame.q.index(sp.Symbol("r", real=True))]
        holds = sp.Matrix(r_col).rank(simplify=True) == view.xi.rows
        return holds, ("the δq_i are not independent under r − l = 0, but λ can be chosen to zero the r term "
                       "(∂f/∂r = 1 ≠ 0), and then θ is free: each term vanishes")

    def inequality(view: DocView) -> tuple[bool, str]:
        return inequality_bounds_a_region()

    return [
        Claim("001.general.inequality", DOC, f"{sec}: definition",
              "A nonholonomic constraint is any constraint inexpressible in this manner (e.g. an inequality).",
              f, "statement", check=inequality,
              note=f"decided against {GOLDSTEIN_1_3}. Seed 000 says the opposite (000.general.inequality)"),
        Claim("001.general.multipliers", DOC, f"{sec}: multipliers",
              "Holonomic constraints can be incorporated into the system using Lagrange Multipliers.", f,
              "statement", check=multipliers,
              note="instance: the r-pendulum; seed 000 applies the method to nonholonomic (Pfaffian) rows too"),
        Claim("001.constraints.augmented_action", DOC, f"{sec}: augmented action",
              r"S = \int_{t_1}^{t_2}\left( L+\sum_{j=1}^{m}\lambda_j f_j \right)dt", f, "equation",
              claimed=lambda v: v.lagrange() - v.xi.T * v.multipliers,
              note="checked through its stationarity: the Euler–Lagrange equations of L + Σλf (f = 0 from "
                   "varying λ), instance: the r-pendulum"),
        Claim("001.constraints.delta_S", DOC, f"{sec}: variation of the augmented action",
              r"\delta S = \int \sum_{i=1}^N\left( \frac{d}{dt}\frac{\partial L}{\partial \dot q_i} - \frac{\partial "
              r"L}{\partial q_i} + \sum_{j=1}^m \lambda_j \frac{\partial f_j}{\partial q_i} \right)\delta q_i dt = 0",
              f, "equation", claimed=lambda v: v.lagrange() + v.xi.T * v.multipliers,
              intended=lambda v: v.lagrange() - v.xi.T * v.multipliers,
              corrected_text="δS = ∫ Σ_i (∂L/∂q_i − d/dt ∂L/∂q̇_i + Σ_j λ_j ∂f_j/∂q_i) δq_i dt = 0",
              project_text="d/dt ∂L/∂q̇ − ∂L/∂q = Jᵀλ (M q̈ = F + Jᵀλ)",
              note="varying ∫(L + Σλf) dt gives ∂L/∂q − d/dt ∂L/∂q̇ + Σλ ∂f/∂q: the display flips the sign of the "
                   "L part but not of the λ part; equation (2) inherits it. Instance: the r-pendulum"),
        Claim("001.constraints.independent_terms", DOC, f"{sec}: each term zero",
              "This requires each term of the first sum to independently be zero.", f, "statement",
              check=independent_terms,
              note="the δq_i are constrained; the step needs the λ_j chosen to zero the dependent terms (seed 000, "
                   "lines 73–80) or varied as extra coordinates"),
        Claim("001.general.lambda_sign", DOC, f"{sec}: Euler–Lagrange equation with constraints (2)",
              r"\frac{d}{dt}\frac{\partial L}{\partial \dot q_i} - \frac{\partial L}{\partial q_i} + "
              r"\sum_j \lambda_j \frac{\partial f_j}{\partial q_i} = 0", flipped, "equation",
              claimed=lambda v: v.lagrange() + v.xi.T * v.multipliers,
              ambiguity="the sign of λ: with the λ of the action the document writes, S = ∫(L + Σλf) dt, and "
                        "of its own example (λ ∂f/∂q on the right), (2) is wrong; the document declares the sign "
                        "arbitrary, and with the opposite λ (S = ∫(L − Σλf) dt) it holds",
              readings=(ClaimReading("λ of S = ∫(L + Σλf) dt and of the example (our λ_rod = −tension)", f,
                                lambda v: v.lagrange() - v.xi.T * v.multipliers,
                                text="d/dt ∂L/∂q̇_i − ∂L/∂q_i − Σ_j λ_j ∂f_j/∂q_i = 0"),
                        ClaimReading("λ of the opposite sign, S = ∫(L − Σλf) dt (λ = +tension)", flipped,
                                lambda v: v.lagrange() + v.xi.T * v.multipliers,
                                text="d/dt ∂L/∂q̇_i − ∂L/∂q_i + Σ_j λ_j ∂f_j/∂q_i = 0")),
              note="instance: the r-pendulum, our L"),
    ]


def claims() -> list[Claim]:
    return [*variations.claims(), *_spring_claims(), *_general_claims(), *_pendulum_claims()]

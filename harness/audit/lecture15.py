"""Claims of seed 000_53d3a09bcd5afa0f.txt (Lecture 15): spherical pendulum, rolling hoops, Atwood.

Transcribed as printed, in the document's variables (a leading "−" on a
display line is the converted list bullet, not a minus sign: read as a sign it
would make line 9 say T = −½mv²):

- spherical pendulum: the document says only "θ from the vertical"; its
  V = m g l cos θ with the pivot as zero fixes θ from the UPWARD vertical,
  the only reading under which the document agrees with itself. Our θ is from
  the downward vertical, so the frame is θ_ours = π − θ_doc.
- Atwood: z3 = a θ (θ_ours = z3 / a); λ1, λ2 multiply the rows
  Ξ1 = (1, 0, −1), Ξ2 = (0, 1, 1) with the document's d/dt ∂L/∂q̇ − ∂L/∂q =
  Σ λ Ξ, which is our convention, so λ1, λ2 are our ``string1``, ``string2``.
- hoops: x along the slope / plane axes, φ the rolling angle, θ the heading
  from the x axis, as ours.

The general derivation of the multiplier method (lines 59–85) is in
:mod:`harness.audit.lecture15_method`.
"""

from __future__ import annotations

import sympy as sp

from analytic import systems
from analytic.systems import symbols
from harness.audit import Claim, ClaimReading, Frame, doc_frame, lecture15_method
from harness.audit.checks import (
    accessible,
    energy_conserved,
    exact,
    inequality_bounds_a_region,
    on_constraints,
    position_check,
    reachable,
    rows_check,
)
from harness.audit.frames import GOLDSTEIN_1_3, LECTURE15, atwood_frame, plane_frame, ramp_frame, spherical_frame
from harness.audit.notation import doc_text
from harness.audit.view import DocView

__all__ = ["claims"]

DOC = LECTURE15


def _d(var: sp.Symbol):
    return lambda v: sp.diff(v.L, var)


def _ddt(var: sp.Symbol):
    return lambda v: v.ddt(sp.diff(v.L, var))


def _spherical() -> list[Claim]:
    f = spherical_frame()
    (th, ph), (thd, phd), (thdd, phdd) = f.q, f.qd, f.qdd
    sym = symbols("spherical_pendulum")
    m, g, l = sym.m, sym.g, sym.l
    sec = "Example: Spherical Pendulum"
    s, c = sp.sin(th), sp.cos(th)
    down = doc_frame("spherical_pendulum", "theta phi",
                     reading="θ_doc from the downward vertical: θ_doc = θ_ours")
    doc_t = m * l**2 * (thd**2 + phd**2 * s**2) / 2

    def coordinates(view: DocView) -> tuple[bool, str]:
        d = view.derivation
        det = sp.factor(sp.simplify(view.doc(d.mass_matrix.det())))
        holds = not d.system.constraints and len(d.system.q) == 2 and det != 0
        return holds, f"two coordinates, no constraint, det M = {doc_text(det)} ≠ 0 away from sin θ = 0"

    def cyclic(view: DocView) -> tuple[bool, str]:
        holds = "phi" in [q.name for q in view.derivation.cyclic]
        return holds, "φ is absent from L (Derivation.cyclic), so p_φ = ∂L/∂φ̇ is constant on motions"

    return [
        Claim("000.spherical.coordinates", DOC, f"{sec}: generalized coordinates", r"q_1 = \phi, q_2 = \theta", f,
              "statement", check=coordinates,
              note="a valid pair except at θ = 0, π (the poles), where φ is undefined and the mass matrix is "
                   "singular"),
        Claim("000.spherical.T_components", DOC, f"{sec}: kinetic energy from two velocity components",
              r"T = \frac{1}{2}mv^{2} = \frac{1}{2}m\left((l\dot{\theta})^{2} + (l\dot{\phi}\sin\theta)^{2}\right)",
              f, "value", claimed=m * ((l * thd)**2 + (l * phd * s)**2) / 2, truth=lambda v: v.T,
              measure="kinetic", lhs="T",
              note="the two components l θ̇ and l φ̇ sin θ are perpendicular, so their squares add"),
        Claim("000.spherical.T", DOC, f"{sec}: kinetic energy",
              r"T = \frac{1}{2}ml^{2}(\dot{\theta}^{2} + \dot{\phi}^{2}\sin^{2}\theta)", f, "value",
              claimed=doc_t, truth=lambda v: v.T, measure="kinetic", lhs="T"),
        Claim("000.spherical.V", DOC, f"{sec}: potential, pivot as zero", r"V = mgl\cos\theta", f, "value",
              claimed=m * g * l * c, truth=lambda v: v.V, measure="potential", lhs="V",
              ambiguity="holds only if θ is measured from the UPWARD vertical; the document says 'from the "
                        "vertical', and with θ from the downward vertical (bob below the pivot at θ = 0) "
                        "the potential is −m g l cos θ",
              readings=(ClaimReading("θ from the upward vertical (the document's own derivatives follow it)", f,
                                m * g * l * c),
                        ClaimReading("θ from the downward vertical (the bob hangs at θ = 0)", down, -m * g * l * c))),
        Claim("000.spherical.conservative", DOC, f"{sec}: no non-conservative forces",
              r"\text{No } Q_{k,\triangle} \text{: no non-conservative forces}", f, "statement",
              check=energy_conserved, claimed=doc_t + m * g * l * c, measure="conserved:energy",
              note="numbers: the document's T + V along MuJoCo's run"),
        Claim("000.spherical.L", DOC, f"{sec}: Lagrangian",
              r"L = \frac{1}{2}ml^2(\dot\theta^2 + \dot\phi^2\sin^2\theta) - mgl\cos\theta", f, "value",
              claimed=doc_t - m * g * l * c, truth=lambda v: v.L, measure="lagrangian", lhs="L"),
        Claim("000.spherical.dL_dthetadot", DOC, f"{sec}: derivatives",
              r"\partial L/\partial\dot\theta = ml^2\dot\theta", f, "value", claimed=m * l**2 * thd, truth=_d(thd),
              lhs="∂L/∂θ̇"),
        Claim("000.spherical.ddt_dL_dthetadot", DOC, f"{sec}: derivatives",
              r"\frac{d}{dt}\left(\frac{\partial L}{\partial \dot{\theta}}\right) ml^2 \ddot{\theta}", f, "value",
              claimed=m * l**2 * thdd, truth=_ddt(thd), lhs="d/dt(∂L/∂θ̇)",
              note="the display lacks its '='; the content is unaffected"),
        Claim("000.spherical.dL_dtheta", DOC, f"{sec}: derivatives",
              r"\partial L/\partial\theta = ml^2 \dot{\phi}^2 \sin \theta \cos \theta + mgl \sin \theta", f, "value",
              claimed=m * l**2 * phd**2 * s * c + m * g * l * s, truth=_d(th), lhs="∂L/∂θ"),
        Claim("000.spherical.dL_dphidot", DOC, f"{sec}: derivatives",
              r"\partial L/\partial\dot\phi = ml^2 \dot{\phi} \sin^2 \theta", f, "value",
              claimed=m * l**2 * phd * s**2, truth=_d(phd), lhs="∂L/∂φ̇"),
        Claim("000.spherical.ddt_dL_dphidot", DOC, f"{sec}: derivatives",
              r"\frac{d}{dt}\frac{\partial L}{\partial \dot{\phi}} = ml^2 \ddot{\phi} \sin^2 \theta "
              r"- 2ml^2 \dot{\theta} \dot{\phi} \sin \theta \cos \theta", f, "value",
              claimed=m * l**2 * phdd * s**2 - 2 * m * l**2 * thd * phd * s * c, truth=_ddt(phd),
              intended=m * l**2 * phdd * s**2 + 2 * m * l**2 * thd * phd * s * c, lhs="d/dt(∂L/∂φ̇)",
              note="product rule: d/dt sin²θ = +2 sin θ cos θ θ̇; the wrong sign is carried into the "
                   "φ equation below, so it is an error of derivation, not of typesetting"),
        Claim("000.spherical.dL_dphi", DOC, f"{sec}: derivatives", r"\partial L/\partial\phi = 0", f, "value",
              claimed=sp.Integer(0), truth=_d(ph), lhs="∂L/∂φ"),
        Claim("000.spherical.eom_theta", DOC, f"{sec}: the two equations (θ)",
              r"ml^2\theta - ml^2\phi^2\sin\theta\cos\theta - mgl\sin\theta = 0", f, "equation",
              claimed=m * l**2 * th - m * l**2 * ph**2 * s * c - m * g * l * s,
              intended=sp.Eq(m * l**2 * thdd - m * l**2 * phd**2 * s * c - m * g * l * s, 0),
              slip="the dots are missing: the lines above give m l² θ̈ and m l² φ̇² sin θ cos θ"),
        Claim("000.spherical.eom_phi", DOC, f"{sec}: the two equations (φ)",
              r"ml^2\ddot{\phi}\sin^2\theta - 2ml^2\dot{\theta}\dot{\phi}\sin\theta\cos\theta = 0", f, "equation",
              claimed=m * l**2 * phdd * s**2 - 2 * m * l**2 * thd * phd * s * c,
              intended=sp.Eq(m * l**2 * phdd * s**2 + 2 * m * l**2 * thd * phd * s * c, 0),
              note="inherits the sign error of d/dt ∂L/∂φ̇"),
        Claim("000.spherical.cyclic", DOC, f"{sec}: ignorable coordinate",
              r"\frac{d}{dt}\left(\frac{\partial L}{\partial \dot{\phi}} \right) = 0 \Rightarrow "
              r"\frac{\partial L}{\partial \dot{\phi}} \text{ constant; } \phi \text{ ignorable (cyclic)}", f,
              "statement", check=cyclic, claimed=m * l**2 * phd * s**2, measure="conserved:p_phi"),
        Claim("000.spherical.p_phi", DOC, f"{sec}: physical meaning",
              r"ml^2 \dot{\phi} \sin^2 \theta \text{ is the angular momentum about the vertical axis}", f,
              "value", claimed=m * l**2 * phd * s**2, truth=_d(phd), measure="invariant:p_phi", lhs="p_φ"),
    ]


def _constraint_claim(cid: str, location: str, quote: str, f: Frame, claimed: sp.Expr | sp.Matrix,
                      intended: sp.Expr | None = None, **kw) -> Claim:
    """A constraint printed at velocity level (dx = a dφ): true iff a combination of our rows."""
    fix = {} if intended is None else {"intended": intended, "intended_check": rows_check(intended)}
    return Claim(cid, DOC, location, quote, f, "statement", claimed=claimed, check=rows_check(claimed),
                 measure="constraint", **fix, **kw)


def _position_claim(cid: str, location: str, quote: str, f: Frame, claimed: sp.Expr | sp.Matrix, **kw) -> Claim:
    """A constraint printed at position level (x = aφ + x₀): true iff a combination of our holonomic f(q)."""
    return Claim(cid, DOC, location, quote, f, "statement", claimed=claimed, check=position_check(claimed),
                 measure="position", **kw)


def _dof(expected: int, what: str):
    def check(view: DocView) -> tuple[bool, str]:
        d = view.derivation
        n = len(d.system.q) - d.jacobian.rank(simplify=True)
        return n == expected, f"{len(d.system.q)} coordinates − rank J = {n} {what}"
    return check


def _substitutable(view: DocView) -> tuple[bool, str]:
    """x = aφ + x₀ substituted into L gives one coordinate whose equation has the multiplier solution's ẍ."""
    reduced = systems.build(view.frame.system, minimal=True).derive()
    (x,) = reduced.system.q
    xdd = sp.Symbol(f"{x.name}_ddot", real=True)
    (acc,) = sp.solve(reduced.equations[0], xdd)
    full = view.solved[view.frame.qdd[view.frame.q.index(sp.Symbol(x.name, real=True))]]
    holds = sp.simplify(acc - full) == 0
    return holds, f"the one-coordinate Lagrangian gives ẍ = {doc_text(acc)}, as the multipliers do"


def _hoops() -> list[Claim]:
    sec = "Constraints – Method of Lagrange Multipliers"
    ramp = ramp_frame()
    x, _s, phi = ramp.q
    xd, _sd, phid = ramp.qd
    a = symbols("hoop_ramp").a
    plane = plane_frame()
    _px, _py, _pz, th, _pphi = plane.q
    pxd, pyd, _pzd, _thd, pphid = plane.qd
    ap = symbols("hoop_plane").a
    x0 = sp.Symbol("x0", real=True)

    def non_integrable(view: DocView) -> tuple[bool, str]:
        allowed, reach, _n = reachable(view)
        return reach > allowed, (f"the rolling rows allow {allowed} directions whose Lie brackets reach {reach}: "
                                 "not integrable (Frobenius), so x, y cannot be written as functions of θ, φ")

    def velocities(view: DocView) -> tuple[bool, str]:
        return _dof(2, "independent velocities")(view)

    def configurations(view: DocView) -> tuple[bool, str]:
        _allowed, reach, _n = reachable(view)
        return reach == 2, (f"the reachable configurations (x, y, θ, φ at z = a) form a {reach}-dimensional set: "
                            "4 coordinates are needed to say where the hoop is")

    def inequality(view: DocView) -> tuple[bool, str]:
        nonholonomic, why = inequality_bounds_a_region()
        return not nonholonomic, (f"{why}; nonholonomic by Goldstein's classification and by the document's own "
                                  "definition (line 59: holonomic = integrable, written φ(x, ϕ) = 0)")

    return [
        Claim("000.hoop_ramp.dof", DOC, f"{sec}: hoop down a ramp", "we only have 1 independent coordinate",
              ramp, "statement", check=_dof(1, "independent coordinate")),
        _constraint_claim("000.hoop_ramp.rolling", f"{sec}: hoop down a ramp", r"dx = a d\phi", ramp,
                          xd - a * phid),
        _position_claim("000.hoop_ramp.integrated", f"{sec}: hoop down a ramp", r"x = a\phi + x_0", ramp,
                        x - a * phi - x0),
        Claim("000.hoop_ramp.integrable", DOC, f"{sec}: hoop down a ramp",
              "Starting from the differential form we were able to integrate this", ramp, "statement",
              check=exact(xd - a * phid)),
        Claim("000.hoop_ramp.substitute", DOC, f"{sec}: hoop down a ramp",
              "If we had an expression involving x, we can simply replace it by an expression of ϕ", ramp,
              "statement", check=_substitutable),
        _constraint_claim("000.hoop_plane.rolling_x", f"{sec}: hoop on a plane", r"dx = a d\phi \cos \theta",
                          plane, pxd - ap * pphid * sp.cos(th)),
        _constraint_claim("000.hoop_plane.rolling_y", f"{sec}: hoop on a plane", r"dy = a d\phi \sin \theta",
                          plane, pyd - ap * pphid * sp.sin(th)),
        Claim("000.hoop_plane.dof", DOC, f"{sec}: hoop on a plane", "We have 2 independent coordinates",
              plane, "statement", check=velocities,
              ambiguity="'independent coordinates' in two senses: independent velocities (degrees of freedom) "
                        "or coordinates enough to fix the configuration; the document's line 58 itself says x "
                        "and y cannot be written in terms of θ and φ",
              readings=(ClaimReading("independent velocities (degrees of freedom)", text="n − rank Ξ = 4 − 2 = 2",
                                check=velocities),
                        ClaimReading("coordinates that fix the configuration",
                                text="dim of the reachable (x, y, θ, φ) = 4: all four are needed",
                                check=configurations))),
        Claim("000.hoop_plane.nonholonomic", DOC, f"{sec}: hoop on a plane",
              "we can no longer directly integrate our differential constraints", plane, "statement",
              check=non_integrable),
        Claim("000.general.inequality", DOC, f"{sec}: holonomic vs non-holonomic",
              "Note that inequality constraints are holonomic", plane, "statement", check=inequality,
              corrected_text="inequality constraints are nonholonomic",
              project_text="holonomic: f(q, t) = 0; anything else, inequalities included, is nonholonomic",
              intended_check=lambda v: inequality_bounds_a_region(),
              note=f"decided against {GOLDSTEIN_1_3}. Contradicts this document's own definition (line 59) "
                   "and seed 001, which calls an inequality nonholonomic (001.general.inequality)"),
        Claim("000.general.holonomic_where", DOC, f"{sec}: holonomic vs non-holonomic",
              "Holonomic constraints tell you \"where\" you can go", ramp, "statement", check=accessible("where")),
        Claim("000.general.nonholonomic_how", DOC, f"{sec}: holonomic vs non-holonomic",
              "Non-holonomic constraints tell you \"how\" you can go", plane, "statement",
              check=accessible("how")),
    ]


def _atwood() -> list[Claim]:
    sym = symbols("atwood")
    f = atwood_frame()
    (z1, z2, z3), (z1d, z2d, z3d), (z1dd, z2dd, z3dd) = f.q, f.qd, f.qdd
    l1, l2 = f.lam["string1"], f.lam["string2"]
    m1, m2, mp, g = sym.m1, sym.m2, sym.m_p, sym.g
    sec = "Example: Atwood's Machine"
    total = mp + m1 + m2
    printed_xi = sp.Matrix([[1, 0, -1], [0, 1, 1]])
    doc_t = (m1 * z1d**2 + m2 * z2d**2 + mp * z3d**2) / 2
    doc_v = m1 * g * z1 + m2 * g * z2

    def positive_tensions(view: DocView) -> tuple[bool, str]:
        sol = view.solved
        holds = all(sp.simplify(sol[lam]).is_positive for lam in (l1, l2))
        return holds, "both solved multipliers are positive for all positive masses: the strings pull up"

    def xi_equal(view: DocView) -> tuple[bool, str]:
        holds = sp.simplify(view.xi - printed_xi) == sp.zeros(*printed_xi.shape)
        return holds, f"our rows' coefficients in (z1, z2, z3) are {view.xi.tolist()}"

    def effective_g(view: DocView) -> tuple[bool, str]:
        ratio = sp.simplify(view.solved[z1dd] / g)
        small = sp.simplify(ratio.subs(m2, m1)) == 0
        below = all(sp.simplify(total + sign * (m1 - m2)).is_positive for sign in (1, -1))
        return small and below, f"z̈₁/g = {doc_text(ratio)}: below 1 in size, and 0 when m₁ = m₂"

    def ideal(view: DocView) -> tuple[bool, str]:
        power = sp.simplify(on_constraints((view.xi.T * view.multipliers).dot(sp.Matrix(f.qd)), view))
        return power == 0, ("Σ_k (Σ_j λ_j Ξ_jk) q̇_k = 0 on allowed motions: the λ_j are the forces of ideal "
                            "constraints (the tensions here), doing no work")

    def deriv(cid: str, quote: str, lhs: str, claimed: sp.Expr, truth) -> Claim:
        return Claim(cid, DOC, f"{sec}: derivatives", quote, f, "value", claimed=claimed, truth=truth, lhs=lhs)

    return [
        Claim("000.atwood.dof", DOC, f"{sec}: setup", "We have 1 degree of freedom ... all 3 coordinates and "
              "2 constraints", f, "statement", check=_dof(1, "degree of freedom")),
        _position_claim("000.atwood.positions", f"{sec}: constraints", r"z_1 = a\theta = z_3 = -z_2", f,
                        sp.Matrix([z1 - z3, z2 + z3]),
                        note="the '−' before z₁ is the list bullet: read as a sign (−z₁ = aθ) the rows would be "
                             "dz₁ + dz₃ = 0, against the Ξ printed beside them"),
        _constraint_claim("000.atwood.constraint1", f"{sec}: constraints", r"dz_1 - dz_3 = 0", f, z1d - z3d),
        _constraint_claim("000.atwood.constraint2", f"{sec}: constraints", r"dz_2 + dz_3 = 0", f, z2d + z3d,
                          note="the cases display prints dz₂ + dz₃ = 0 twice (three rows for two constraints): a "
                               "typesetting repeat"),
        Claim("000.atwood.Xi", DOC, f"{sec}: constraints",
              r"\Xi_{11} = 1, \Xi_{12} = 0, \Xi_{13} = -1; \Xi_{21} = 0, \Xi_{22} = 1, \Xi_{23} = 1", f,
              "statement", check=xi_equal),
        Claim("000.atwood.T", DOC, f"{sec}: kinetic energy",
              r"T = \frac{1}{2}m_1\dot{z}_1^2 + \frac{1}{2}m_2\dot{z}_2^2 + \frac{1}{2}m_p\dot{z}_3^2", f, "value",
              claimed=doc_t, truth=lambda v: v.T, measure="kinetic", lhs="T",
              note="the pulley's mass on its rim moves at ż₃ = a θ̇, so its ½ I θ̇² is ½ m_p ż₃² (I = m_p a²)"),
        Claim("000.atwood.V", DOC, f"{sec}: potential energy", r"V = m_1gz_1 + m_2gz_2", f,
              "value_up_to_constant", claimed=doc_v, truth=lambda v: v.V, measure="potential", lhs="V"),
        deriv("000.atwood.dL_dz1dot", r"\partial L/\partial \dot z_1 = m_1 \dot z_1", "∂L/∂ż₁", m1 * z1d, _d(z1d)),
        deriv("000.atwood.ddt_dL_dz1dot", r"\frac{d}{dt}\partial L/\partial \dot z_1 = m_1 \ddot z_1",
              "d/dt(∂L/∂ż₁)", m1 * z1dd, _ddt(z1d)),
        deriv("000.atwood.dL_dz1", r"\partial L/\partial z_1 = -m_1 g", "∂L/∂z₁", -m1 * g, _d(z1)),
        deriv("000.atwood.dL_dz2dot", r"\partial L/\partial \dot z_2 = m_2 \dot z_2", "∂L/∂ż₂", m2 * z2d, _d(z2d)),
        deriv("000.atwood.ddt_dL_dz2dot", r"\frac{d}{dt}\partial L/\partial \dot z_2 = m_2 \ddot z_2",
              "d/dt(∂L/∂ż₂)", m2 * z2dd, _ddt(z2d)),
        deriv("000.atwood.dL_dz2", r"\partial L/\partial z_2 = -m_2 g", "∂L/∂z₂", -m2 * g, _d(z2)),
        deriv("000.atwood.dL_dz3dot", r"\partial L/\partial \dot z_3 = m_p \dot z_3", "∂L/∂ż₃", mp * z3d, _d(z3d)),
        deriv("000.atwood.ddt_dL_dz3dot", r"\frac{d}{dt}\partial L/\partial \dot z_3 = m_p \ddot z_3",
              "d/dt(∂L/∂ż₃)", mp * z3dd, _ddt(z3d)),
        deriv("000.atwood.dL_dz3", r"\partial L/\partial z_3 = 0", "∂L/∂z₃", sp.Integer(0), _d(z3)),
        Claim("000.atwood.conservative", DOC, f"{sec}: no non-conservative forces",
              r"\text{Assume no non-conservative forces}", f, "statement", check=energy_conserved,
              claimed=doc_t + doc_v, measure="conserved:energy",
              note="numbers: the document's T + V along MuJoCo's run"),
        Claim("000.atwood.eom1", DOC, f"{sec}: Lagrange's equations",
              r"m_1 \ddot{z}_1 + m_1 g = \lambda_1 \Xi_{11} + \lambda_2 \Xi_{21} = \lambda_1", f,
              "equation", claimed=m1 * z1dd + m1 * g - (l1 * printed_xi[0, 0] + l2 * printed_xi[1, 0])),
        Claim("000.atwood.eom2", DOC, f"{sec}: Lagrange's equations",
              r"m_2 \ddot{z}_2 + m_2 g = \lambda_1 \Xi_{12} + \lambda_2 \Xi_{22} = \lambda_2", f,
              "equation", claimed=m2 * z2dd + m2 * g - (l1 * printed_xi[0, 1] + l2 * printed_xi[1, 1])),
        Claim("000.atwood.eom3", DOC, f"{sec}: Lagrange's equations",
              r"m_p \ddot{z}_3 = \lambda_1 \Xi_{13} + \lambda_2 \Xi_{23} = -\lambda_1 + \lambda_2", f,
              "equation", claimed=mp * z3dd - (l1 * printed_xi[0, 2] + l2 * printed_xi[1, 2])),
        _constraint_claim("000.atwood.constraint_eq1", f"{sec}: constraint equations", r"\dot{z}_1 \dot{z}_3 = 0",
                          f, z1d * z3d, intended=z1d - z3d,
                          slip="the '−' is missing: the constraint rows above are dz₁ − dz₃ = 0 (Ξ₁ = (1, 0, −1))"),
        _constraint_claim("000.atwood.constraint_eq2", f"{sec}: constraint equations", r"\dot{z}_2 + \dot{z}_3 = 0",
                          f, z2d + z3d),
        Claim("000.atwood.z1ddot", DOC, f"{sec}: solution",
              r"\ddot{z}_1 = -\frac{m_1 - m_2}{m_p + m_1 + m_2}g", f, "value",
              claimed=-(m1 - m2) / total * g, truth=lambda v: z1dd, lhs="z̈₁"),
        Claim("000.atwood.z2ddot", DOC, f"{sec}: solution", r"\ddot{z}_2 = -\ddot{z}_1", f, "value",
              claimed=(m1 - m2) / total * g, truth=lambda v: z2dd, lhs="z̈₂"),
        Claim("000.atwood.z3ddot", DOC, f"{sec}: solution", r"\ddot{z}_3 = \ddot{z}_1", f, "value",
              claimed=-(m1 - m2) / total * g, truth=lambda v: z3dd, lhs="z̈₃"),
        Claim("000.atwood.lambda1", DOC, f"{sec}: solution",
              r"\lambda_1 = \frac{m_p + 2m_2}{m_p + m_1 + m_2} m_1 g", f, "value",
              claimed=(mp + 2 * m2) / total * m1 * g, truth=lambda v: l1, lhs="λ₁"),
        Claim("000.atwood.lambda2", DOC, f"{sec}: solution",
              r"\lambda_2 = \frac{m_p + 2m_1}{-m_p + m_1 + m_2} m_2 g", f, "value",
              claimed=(mp + 2 * m1) / (-mp + m1 + m2) * m2 * g, truth=lambda v: l2, lhs="λ₂",
              intended=(mp + 2 * m1) / total * m2 * g,
              slip="the sign of m_p in the denominator: λ1's and the accelerations' common denominator is "
                   "m_p + m1 + m2, and λ2 must follow from λ1 by exchanging 1 ↔ 2"),
        Claim("000.atwood.effective_g", DOC, f"{sec}: meaning",
              "choose the masses to be nearly equal, so we get an effective g that's very small", f, "statement",
              check=effective_g),
        Claim("000.atwood.tensions", DOC, f"{sec}: meaning",
              "λ1 and λ2 turn out to be the tension on the two sides of the string", f, "statement",
              check=positive_tensions),
        Claim("000.general.multiplier_meaning", DOC, f"{sec}: meaning",
              "the Lagrange multipliers have meaning they are associated with the constraint forces", f,
              "statement", check=ideal),
    ]


def claims() -> list[Claim]:
    return [*_spherical(), *_hoops(), *lecture15_method.claims(), *_atwood()]

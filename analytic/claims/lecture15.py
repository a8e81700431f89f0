"""Claims of seed 000_53d3a09bcd5afa0f.txt (Lecture 15): spherical pendulum, rolling hoops, Atwood.

Transcribed as printed, in the document's variables:

- spherical pendulum: the document says only "θ from the vertical"; its
  V = m g l cos θ with the pivot as zero fixes θ from the UPWARD vertical,
  the only reading under which the document agrees with itself. Our θ is from
  the downward vertical, so the frame is θ_ours = π − θ_doc.
- Atwood: z3 = a θ (θ_ours = z3 / a); λ1, λ2 multiply the rows
  Ξ1 = (1, 0, −1), Ξ2 = (0, 1, 1) with the document's d/dt ∂L/∂q̇ − ∂L/∂q =
  Σ λ Ξ, which is our convention, so λ1, λ2 are our ``string1``, ``string2``.
- hoops: x along the slope / plane axes, φ the rolling angle, θ the heading
  from the x axis, as ours.
"""

from __future__ import annotations

import sympy as sp

from analytic.claims import Claim, doc_frame
from analytic.claims.view import DocView
from analytic.systems import symbols

DOC = "000_53d3a09bcd5afa0f.txt"


def _spherical() -> list[Claim]:
    f = doc_frame("spherical_pendulum", "theta phi", {"theta": "pi - theta", "phi": "phi"},
                  reading="θ_doc from the upward vertical: θ_ours = π − θ_doc")
    (th, ph), (thd, phd), (thdd, phdd) = f.q, f.qd, f.qdd
    sym = symbols("spherical_pendulum")
    m, g, l = sym.m, sym.g, sym.l
    sec = "Example: Spherical Pendulum"
    s, c = sp.sin(th), sp.cos(th)

    def d(var):
        return lambda v: sp.diff(v.L, var)

    def ddt(var):
        return lambda v: v.ddt(sp.diff(v.L, var))

    def cyclic(view: DocView) -> tuple[bool, str]:
        holds = "phi" in [q.name for q in view.derivation.cyclic]
        return holds, "φ is absent from L (Derivation.cyclic), so p_φ = ∂L/∂φ̇ is constant on motions"

    return [
        Claim("000.spherical.T", DOC, f"{sec}: kinetic energy",
              r"T = \frac{1}{2}ml^{2}(\dot{\theta}^{2} + \dot{\phi}^{2}\sin^{2}\theta)", f, "value",
              claimed=m * l**2 * (thd**2 + phd**2 * s**2) / 2, truth=lambda v: v.T, measure="kinetic"),
        Claim("000.spherical.V", DOC, f"{sec}: potential, pivot as zero", r"V = mgl\cos\theta", f, "value",
              claimed=m * g * l * c, truth=lambda v: v.V, measure="potential",
              ambiguity="holds only if θ is measured from the UPWARD vertical; the document says 'from the "
                        "vertical', and with θ from the downward vertical (bob below the pivot at θ = 0) "
                        "the potential is −m g l cos θ"),
        Claim("000.spherical.L", DOC, f"{sec}: Lagrangian",
              r"L = \frac{1}{2}ml^2(\dot\theta^2 + \dot\phi^2\sin^2\theta) - mgl\cos\theta", f, "value",
              claimed=m * l**2 * (thd**2 + phd**2 * s**2) / 2 - m * g * l * c, truth=lambda v: v.L,
              measure="lagrangian"),
        Claim("000.spherical.dL_dthetadot", DOC, f"{sec}: derivatives",
              r"\partial L/\partial\dot\theta = ml^2\dot\theta", f, "value", claimed=m * l**2 * thd, truth=d(thd)),
        Claim("000.spherical.ddt_dL_dthetadot", DOC, f"{sec}: derivatives",
              r"\frac{d}{dt}\left(\frac{\partial L}{\partial \dot{\theta}}\right) ml^2 \ddot{\theta}", f, "value",
              claimed=m * l**2 * thdd, truth=ddt(thd),
              note="the display lacks its '='; the content is unaffected"),
        Claim("000.spherical.dL_dtheta", DOC, f"{sec}: derivatives",
              r"\partial L/\partial\theta = ml^2 \dot{\phi}^2 \sin \theta \cos \theta + mgl \sin \theta", f, "value",
              claimed=m * l**2 * phd**2 * s * c + m * g * l * s, truth=d(th)),
        Claim("000.spherical.dL_dphidot", DOC, f"{sec}: derivatives",
              r"\partial L/\partial\dot\phi = ml^2 \dot{\phi} \sin^2 \theta", f, "value",
              claimed=m * l**2 * phd * s**2, truth=d(phd)),
        Claim("000.spherical.ddt_dL_dphidot", DOC, f"{sec}: derivatives",
              r"\frac{d}{dt}\frac{\partial L}{\partial \dot{\phi}} = ml^2 \ddot{\phi} \sin^2 \theta "
              r"- 2ml^2 \dot{\theta} \dot{\phi} \sin \theta \cos \theta", f, "value",
              claimed=m * l**2 * phdd * s**2 - 2 * m * l**2 * thd * phd * s * c, truth=ddt(phd),
              intended=m * l**2 * phdd * s**2 + 2 * m * l**2 * thd * phd * s * c,
              note="product rule: d/dt sin²θ = +2 sin θ cos θ θ̇; the wrong sign is carried into the "
                   "φ equation below, so it is an error of derivation, not of typesetting"),
        Claim("000.spherical.dL_dphi", DOC, f"{sec}: derivatives", r"\partial L/\partial\phi = 0", f, "value",
              claimed=sp.Integer(0), truth=d(ph)),
        Claim("000.spherical.eom_theta", DOC, f"{sec}: the two equations (θ)",
              r"ml^2\theta - ml^2\phi^2\sin\theta\cos\theta - mgl\sin\theta = 0", f, "equation",
              claimed=m * l**2 * th - m * l**2 * ph**2 * s * c - m * g * l * s,
              intended=m * l**2 * thdd - m * l**2 * phd**2 * s * c - m * g * l * s,
              slip="the dots are missing: the lines above give m l² θ̈ and m l² φ̇² sin θ cos θ"),
        Claim("000.spherical.eom_phi", DOC, f"{sec}: the two equations (φ)",
              r"ml^2\ddot{\phi}\sin^2\theta - 2ml^2\dot{\theta}\dot{\phi}\sin\theta\cos\theta = 0", f, "equation",
              claimed=m * l**2 * phdd * s**2 - 2 * m * l**2 * thd * phd * s * c,
              intended=m * l**2 * phdd * s**2 + 2 * m * l**2 * thd * phd * s * c,
              note="inherits the sign error of d/dt ∂L/∂φ̇"),
        Claim("000.spherical.cyclic", DOC, f"{sec}: ignorable coordinate",
              r"\frac{d}{dt}\left(\frac{\partial L}{\partial \dot{\phi}} \right) = 0 \Rightarrow "
              r"\frac{\partial L}{\partial \dot{\phi}} \text{ constant}", f, "statement", check=cyclic,
              claimed=m * l**2 * phd * s**2, measure="conserved:p_phi"),
        Claim("000.spherical.p_phi", DOC, f"{sec}: physical meaning",
              r"ml^2 \dot{\phi} \sin^2 \theta \text{ is the angular momentum about the vertical axis}", f,
              "value", claimed=m * l**2 * phd * s**2, truth=d(phd), measure="invariant:p_phi"),
    ]


def _span_check(rows_doc: list[sp.Expr], claimed: sp.Expr, qd: tuple[sp.Symbol, ...]) -> bool:
    """Is ``claimed`` (linear in velocities) a combination of our constraint rows?"""
    mu = sp.symbols(f"mu0:{len(rows_doc)}")
    diff = sp.expand(claimed - sum(k * r for k, r in zip(mu, rows_doc, strict=True)))
    eqs = [diff.coeff(v) for v in qd] + [diff.subs({v: 0 for v in qd})]
    return bool(sp.solve([sp.simplify(e) for e in eqs], mu, dict=True))


def _constraint_claim(cid: str, location: str, quote: str, f, claimed: sp.Expr, **kw) -> Claim:
    def check(view: DocView) -> tuple[bool, str]:
        rows = [view.doc(r) for r in view.derivation.constraint_rows]
        holds = _span_check(rows, claimed, view.frame.qd)
        return holds, ("a combination of our constraint rows J q̇ + b" if holds
                       else "not in the span of our constraint rows")

    return Claim(cid, DOC, location, quote, f, "statement", claimed=claimed, check=check,
                 measure="constraint", **kw)


def _dof(expected: int, what: str):
    def check(view: DocView) -> tuple[bool, str]:
        d = view.derivation
        n = len(d.system.q) - d.jacobian.rank(simplify=True)
        return n == expected, f"{len(d.system.q)} coordinates − rank J = {n} {what}"
    return check


def _hoops() -> list[Claim]:
    sec = "Constraints – Method of Lagrange Multipliers"
    ramp = doc_frame("hoop_ramp", "x s phi")
    _x, _s, _phi = ramp.q
    xd, _sd, phid = ramp.qd
    a = symbols("hoop_ramp").a
    plane = doc_frame("hoop_plane", "x y z theta phi")
    _px, _py, _pz, th, _pphi = plane.q
    pxd, pyd, _pzd, _thd, pphid = plane.qd
    ap = symbols("hoop_plane").a

    def non_integrable(view: DocView) -> tuple[bool, str]:
        # fields allowed by the rolling rows (ignoring the normal row): ∂θ and a cosθ ∂x + a sinθ ∂y + ∂φ
        # Frobenius: their bracket −a sinθ ∂x + a cosθ ∂y must leave their span for non-integrability.
        d1 = sp.Matrix([0, 0, 1, 0])                       # (x, y, θ, φ)
        d2 = sp.Matrix([ap * sp.cos(th), ap * sp.sin(th), 0, 1])
        coords = [_px, _py, th, _pphi]
        bracket = d2.jacobian(coords) * d1 - d1.jacobian(coords) * d2
        rank = sp.Matrix.hstack(d1, d2, bracket).rank(simplify=True)
        return rank == 3, f"[∂θ, a cosθ ∂x + a sinθ ∂y + ∂φ] = (−a sinθ, a cosθ, 0, 0) ∉ span: rank {rank}"

    def inequality(view: DocView) -> tuple[bool, str]:
        return False, ("calls inequality constraints holonomic; seed 001 (and Goldstein) call them "
                       "nonholonomic: a terminology the two documents do not share")

    return [
        _constraint_claim("000.hoop_ramp.rolling", f"{sec}: hoop down a ramp", r"dx = a d\phi \implies x = a\phi + x_0",
                          ramp, xd - a * phid),
        Claim("000.hoop_ramp.dof", DOC, f"{sec}: hoop down a ramp", "we only have 1 independent coordinate",
              ramp, "statement", check=_dof(1, "independent coordinate")),
        _constraint_claim("000.hoop_plane.rolling_x", f"{sec}: hoop on a plane", r"dx = a d\phi \cos \theta",
                          plane, pxd - ap * pphid * sp.cos(th)),
        _constraint_claim("000.hoop_plane.rolling_y", f"{sec}: hoop on a plane", r"dy = a d\phi \sin \theta",
                          plane, pyd - ap * pphid * sp.sin(th)),
        Claim("000.hoop_plane.dof", DOC, f"{sec}: hoop on a plane", "We have 2 independent coordinates",
              plane, "statement", check=_dof(2, "independent velocities")),
        Claim("000.hoop_plane.nonholonomic", DOC, f"{sec}: hoop on a plane",
              "we can no longer directly integrate our differential constraints", plane, "statement",
              check=non_integrable),
        Claim("000.general.inequality", DOC, f"{sec}: holonomic vs non-holonomic",
              "Note that inequality constraints are holonomic", plane, "statement", check=inequality,
              ambiguity="whether inequalities count as holonomic"),
    ]


def _atwood() -> list[Claim]:
    sym = symbols("atwood")
    f = doc_frame("atwood", "z1 z2 z3", {"z1": "z1", "z2": "z2", "theta": sp.Symbol("z3", real=True) / sym.a},
                  lam={"string1": "lambda1", "string2": "lambda2"}, reading="z3 = a θ")
    (z1, z2, _z3), (z1d, z2d, z3d), (z1dd, z2dd, z3dd) = f.q, f.qd, f.qdd
    l1, l2 = f.lam["string1"], f.lam["string2"]
    m1, m2, mp, g = sym.m1, sym.m2, sym.m_p, sym.g
    sec = "Example: Atwood's Machine"
    total = mp + m1 + m2

    def positive_tensions(view: DocView) -> tuple[bool, str]:
        sol = view.solved
        holds = all(sp.simplify(sol[lam]).is_positive for lam in (l1, l2))
        return holds, "both solved multipliers are positive for all positive masses: the strings pull up"

    return [
        _constraint_claim("000.atwood.constraint1", f"{sec}: constraints", r"dz_1 - dz_3 = 0 \;(\Xi_1 = (1, 0, -1))",
                          f, z1d - z3d),
        _constraint_claim("000.atwood.constraint2", f"{sec}: constraints", r"dz_2 + dz_3 = 0 \;(\Xi_2 = (0, 1, 1))",
                          f, z2d + z3d, note="printed twice in the cases display; a typesetting repeat"),
        Claim("000.atwood.T", DOC, f"{sec}: kinetic energy",
              r"T = \frac{1}{2}m_1\dot{z}_1^2 + \frac{1}{2}m_2\dot{z}_2^2 + \frac{1}{2}m_p\dot{z}_3^2", f, "value",
              claimed=(m1 * z1d**2 + m2 * z2d**2 + mp * z3d**2) / 2, truth=lambda v: v.T, measure="kinetic"),
        Claim("000.atwood.V", DOC, f"{sec}: potential energy", r"V = m_1gz_1 + m_2gz_2", f,
              "value_up_to_constant", claimed=m1 * g * z1 + m2 * g * z2, truth=lambda v: v.V, measure="potential"),
        Claim("000.atwood.dL_dz1", DOC, f"{sec}: derivatives", r"\partial L/\partial z_1 = -m_1 g", f, "value",
              claimed=-m1 * g, truth=lambda v: sp.diff(v.L, z1)),
        Claim("000.atwood.dL_dz3dot", DOC, f"{sec}: derivatives", r"\partial L/\partial \dot z_3 = m_p \dot z_3", f,
              "value", claimed=mp * z3d, truth=lambda v: sp.diff(v.L, z3d)),
        Claim("000.atwood.eom1", DOC, f"{sec}: Lagrange's equations", r"m_1 \ddot{z}_1 + m_1 g = \lambda_1", f,
              "equation", claimed=m1 * z1dd + m1 * g - l1),
        Claim("000.atwood.eom2", DOC, f"{sec}: Lagrange's equations", r"m_2 \ddot{z}_2 + m_2 g = \lambda_2", f,
              "equation", claimed=m2 * z2dd + m2 * g - l2),
        Claim("000.atwood.eom3", DOC, f"{sec}: Lagrange's equations", r"m_p \ddot{z}_3 = -\lambda_1 + \lambda_2", f,
              "equation", claimed=mp * z3dd + l1 - l2),
        Claim("000.atwood.z1ddot", DOC, f"{sec}: solution",
              r"\ddot{z}_1 = -\frac{m_1 - m_2}{m_p + m_1 + m_2}g", f, "value",
              claimed=-(m1 - m2) / total * g, truth=lambda v: z1dd),
        Claim("000.atwood.z2ddot", DOC, f"{sec}: solution", r"\ddot{z}_2 = -\ddot{z}_1", f, "value",
              claimed=(m1 - m2) / total * g, truth=lambda v: z2dd),
        Claim("000.atwood.z3ddot", DOC, f"{sec}: solution", r"\ddot{z}_3 = \ddot{z}_1", f, "value",
              claimed=-(m1 - m2) / total * g, truth=lambda v: z3dd),
        Claim("000.atwood.lambda1", DOC, f"{sec}: solution",
              r"\lambda_1 = \frac{m_p + 2m_2}{m_p + m_1 + m_2} m_1 g", f, "value",
              claimed=(mp + 2 * m2) / total * m1 * g, truth=lambda v: l1),
        Claim("000.atwood.lambda2", DOC, f"{sec}: solution",
              r"\lambda_2 = \frac{m_p + 2m_1}{-m_p + m_1 + m_2} m_2 g", f, "value",
              claimed=(mp + 2 * m1) / (-mp + m1 + m2) * m2 * g, truth=lambda v: l2,
              intended=(mp + 2 * m1) / total * m2 * g,
              slip="the sign of m_p in the denominator: λ1's and the accelerations' common denominator is "
                   "m_p + m1 + m2, and λ2 must follow from λ1 by exchanging 1 ↔ 2"),
        Claim("000.atwood.tensions", DOC, f"{sec}: meaning",
              "λ1 and λ2 turn out to be the tension on the two sides of the string", f, "statement",
              check=positive_tensions),
    ]


def claims() -> list[Claim]:
    return [*_spherical(), *_hoops(), *_atwood()]

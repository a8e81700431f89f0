"""Slider-crank: a closed kinematic loop of crank, connecting rod and piston, closed by a ``connect``.

A crank (uniform bar, mass m1, length r, centre of mass d1 from the pivot,
inertia I1 about it) turns about a fixed pivot at the origin; a connecting rod
(mass m2, length l, centre of mass d2 from the crank pin, inertia I2) hangs
from the crank pin; a piston (point mass m3) slides along the world x axis.
The rod's end and the piston's pin are joined by a ball joint outside the
kinematic tree, MuJoCo's ``connect`` equality ``wrist_pin``. Vertical plane
x–z, gravity −z::

        z ^
          |     crank pin P = r (cos θ, 0, sin θ)
          |    o
          |   / \\  rod, at θ + φ from +x
          |  /θ  \\
    pivot o-/------o========== x      piston pin (x, y, 0) on the guide z = 0
                  rod end E = P + l (cos(θ + φ), 0, sin(θ + φ))

Coordinates q = (theta, phi, x, y), MuJoCo's joints of the same names:

    theta  crank angle from +x towards +z (hinge about −y at the origin);
    phi    rod angle relative to the crank (hinge about −y at the crank pin),
           so the rod points at θ + φ from +x;
    x, y   the piston's world x and y (slides; z is held at 0 by the guide).

The piston also slides sideways (``y``): in a loop of parallel hinges the
connect's out-of-plane row would have a zero Jacobian row, a multiplier no
mechanics determines. With the sideways slide all three rows are constraints
(J has full rank 3 and the loop one degree of freedom), and the y row holds the
piston in the crank's plane; nothing pushes it out, so λ_y = 0 on the motion.

The loop closure ``wrist_pin`` is a block of three rows in MuJoCo's order, the
world x, y, z components of anchor1 − anchor2 (site ``rod_end`` on the rod,
body1, minus site ``piston_pin`` on the piston, body2)::

    f = (r cos θ + l cos(θ + φ) − x,  −y,  r sin θ + l sin(θ + φ)) = 0

Sign of the multipliers: with M q̈ = F + Jᵀλ and J = ∂f/∂q, λ enters the rod's
coordinates as (∂E/∂q)ᵀλ and the piston's as −λ: λ = (λ_x, λ_y, λ_z) is the
world force the piston exerts on the rod's end (the pin force), and the rod
pushes the piston with −λ. MuJoCo's connect has exactly these rows
(cpos = anchor1 − anchor2, J = J1 − J2), so its ``efc_force`` is λ row by row.

T = ½ m1 |ċ1|² + ½ I1 θ̇² + ½ m2 |ċ2|² + ½ I2 (θ̇ + φ̇)² + ½ m3 (ẋ² + ẏ²) and
V = g (m1 c1_z + m2 c2_z) with the pivot and the guide at height 0 (MuJoCo's
potential energy exactly). One degree of freedom: released at rest with the
crank 0.5 rad below +x, the loop swings through the crank's lowest position to
the mirror position and back, the piston shuttling along the guide.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from analytic.systems import Motion, Parameters, Scales

if TYPE_CHECKING:
    from analytic.lagrangian import LagrangianSystem

__all__ = ["MOTION", "PARAMETERS", "build", "params_from_model", "scales"]

PARAMETERS = "m1 I1 d1 r m2 I2 d2 l m3 g"

MOTION = Motion(
    description="slider-crank, a closed loop of crank, rod and piston held by a connect (3 rows: the pin force)",
    # θ = −0.5 rad at rest; φ and x close the loop for r = 0.3 m, l = 0.6 m (the reference projects them
    # onto the model's own loop, to round-off, for any other lengths). The crank swings to about −π + 0.5
    # and back, 0.5 rad short of the inner dead centre: through a dead centre (released at θ = 1 rad)
    # MuJoCo's default softness (solref 0.02) moves the loop visibly, where its effect is no longer the
    # smooth function of ε the budget extrapolates, and that setting fails (docs/findings/bases.md)
    q0={"theta": -0.5, "phi": 0.7420699834873062, "x": 0.8457810807767445, "y": 0.0},
    qd0={"theta": 0.0, "phi": 0.0, "x": 0.0, "y": 0.0},
    horizon=2.0,
    tags=frozenset({"fast", "ci", "constrained"}),
)


def build(p: Parameters) -> LagrangianSystem:
    import sympy as sp  # lazy: sympy, only to derive

    from analytic.lagrangian import Constraint, LagrangianSystem, coordinates  # lazy: loads sympy
    from analytic.rigid import RigidBody, axis_rotation, point_mass  # lazy: loads sympy

    (theta, phi, x, y), qd = coordinates("theta phi x y")
    theta_d, phi_d, x_d, y_d = qd
    crank = sp.Matrix([sp.cos(theta), 0, sp.sin(theta)])
    rod = sp.Matrix([sp.cos(theta + phi), 0, sp.sin(theta + phi)])
    c1 = p.d1 * crank
    pin = p.r * crank
    c2 = pin + p.d2 * rod
    end = pin + p.l * rod
    piston = sp.Matrix([x, y, 0])

    def speed2(point: sp.Matrix) -> sp.Expr:
        v = point.jacobian([theta, phi, x, y]) * sp.Matrix(qd)
        return v.dot(v)

    kinetic = (p.m1 * speed2(c1) + p.I1 * theta_d**2 + p.m2 * speed2(c2) + p.I2 * (theta_d + phi_d)**2
               + p.m3 * (x_d**2 + y_d**2)) / 2
    return LagrangianSystem(
        name="slider_crank",
        q=(theta, phi, x, y),
        qd=qd,
        kinetic=sp.simplify(kinetic),
        potential=p.g * (p.m1 * c1[2] + p.m2 * c2[2]),
        params=(p.m1, p.I1, p.d1, p.r, p.m2, p.I2, p.d2, p.l, p.m3, p.g),
        constraints=(Constraint("wrist_pin", list(end - piston)),),
        points={"crank": tuple(c1), "rod": tuple(c2), "piston": tuple(piston)},
        # the links turn about −y only (ω ∥ y): of their inertia only the moment about y enters
        bodies={"crank": RigidBody(mass=p.m1, inertia=sp.diag(0, p.I1, 0), com=c1,
                                   rotation=axis_rotation("y", -theta)),
                "rod": RigidBody(mass=p.m2, inertia=sp.diag(0, p.I2, 0), com=c2,
                                 rotation=axis_rotation("y", -(theta + phi))),
                "piston": point_mass(p.m3, piston)},
    )


def _on_x(model, vector, what: str) -> float:
    """The x component of a body-frame vector that must lie on the body's x axis (ValueError otherwise)."""
    v = np.asarray(vector, dtype=float)
    if np.any(np.abs(v[1:]) > 1e-12 * max(1.0, abs(v[0]))):
        raise ValueError(f"{what} must lie on its body's x axis, got {v.tolist()}")
    return float(v[0])


def params_from_model(model) -> dict[str, float]:
    """The crank and rod from their bodies (mass, centre of mass on the body's x axis, inertia about the
    hinge axis y), r from the rod body's position on the crank, l from the site ``rod_end`` on the rod,
    m3 from the body ``piston``, g from gravity. ValueError where the model is not of this shape (a
    hinge away from its body's origin, a centre of mass off the bar, gravity not along −z)."""
    gravity = np.asarray(model.opt.gravity, dtype=float)
    if np.any(gravity[:2] != 0) or not gravity[2] < 0:
        raise ValueError(f"gravity must point along −z, got {gravity.tolist()}")
    for joint, body in (("theta", "crank"), ("phi", "rod")):
        jid = model.joint(joint).id
        if int(model.jnt_bodyid[jid]) != model.body(body).id or np.any(model.jnt_pos[jid] != 0):
            raise ValueError(f"hinge {joint!r} must sit at the origin of body {body!r}")
    if int(model.body_parentid[model.body("rod").id]) != model.body("crank").id:
        raise ValueError("body 'rod' must be a child of body 'crank'")
    site = model.site("rod_end")
    if int(model.site_bodyid[site.id]) != model.body("rod").id:
        raise ValueError("site 'rod_end' must be on body 'rod'")
    out = {"g": float(-gravity[2]), "m3": float(model.body("piston").mass[0])}
    for label, body in (("1", "crank"), ("2", "rod")):
        b = model.body(body)
        if not np.allclose(np.abs(model.body_iquat[b.id]), [1, 0, 0, 0], rtol=0, atol=1e-12):
            raise ValueError(f"body {body!r} must have its principal axes along its frame's")
        out[f"m{label}"] = float(b.mass[0])
        out[f"I{label}"] = float(model.body_inertia[b.id][1])
        out[f"d{label}"] = _on_x(model, model.body_ipos[b.id], f"the centre of mass of {body!r}")
    out["r"] = _on_x(model, model.body_pos[model.body("rod").id], "the crank pin (body 'rod')")
    out["l"] = _on_x(model, model.site_pos[site.id], "site 'rod_end'")
    return out


def scales(params: dict[str, float]) -> Scales:
    """Length r + l (the piston's stroke reach), force the total weight (m1 + m2 + m3) g."""
    return Scales.gravity(mass=params["m1"] + params["m2"] + params["m3"], g=params["g"],
                          length=params["r"] + params["l"])

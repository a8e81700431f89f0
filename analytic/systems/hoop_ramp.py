"""Hoop rolling without slipping down an incline (seed 000, "Constraints – Method of Lagrange Multipliers").

A thin hoop (ring mass m, radius a, moment of inertia m a² about its axle)
rolls down a plane inclined at α, drawn in the world x–z plane (y into the
page)::

        z ^
          |
          o-._        .-.              d = (cos α, 0, −sin α)   downhill, along the slope
          |   `-._   ( C )             n = (sin α, 0,  cos α)   out of the slope
          |       `-._`-'              C = x·d + s·n            the hoop's centre
          |           `-._
          +---------------`-._------> x
                 slope, α below +x, through the origin

The centre's height is z_C = −x sin α + s cos α, and V = m g z_C.

Coordinates q = (x, s, phi):

    x    distance along the slope from the origin, downhill positive;
    s    distance of the centre from the slope surface (s = a in contact);
    phi  rotation of the hoop about world +y (= n × d); φ̇ > 0 rolls downhill.

Two holonomic constraints, named like the MJCF equalities (or read from the
contact in the ``hoop_ramp_contact`` case):

    normal: f = s − a = 0,       J = (0, 1,  0)
    roll:   f = x − a φ = 0,     J = (1, 0, −a)   (the seed's dx = a dφ, integrated)

Sign of the multipliers: with M q̈ = F + Jᵀλ the rows read

    m ẍ     = m g sin α + λ_roll,       m s̈ = −m g cos α + λ_normal,
    m a² φ̈  = −a λ_roll,

so λ_roll is the component along d (downhill) of the contact force on the
hoop — the friction force — and λ_normal its component along n, the normal
force. Rolling needs friction pointing uphill: λ_roll = −m g sin α / 2 < 0
(magnitude m g sin α / 2) and λ_normal = +m g cos α, with ẍ = g sin α / 2.
MuJoCo's joint equality ``joint1=x joint2=phi polycoef="0 a 0 0 0"`` has the
row (1, −a) of ``roll``, and the equality on the slide ``s`` the row of
``normal``, so their ``efc_force`` are λ with the same sign. On a real contact
(``hoop_ramp_contact``) the same two numbers are the contact force on the hoop
along the slides ``x`` and ``s`` (``harness.contact.slide_force``).

The Pfaffian form of ``roll`` (ẋ − a φ̇ = 0, the seed's starting point) gives
the same J and γ, hence the same motion and multipliers: ``build(form="pfaffian")``.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Literal

import mujoco

from analytic.assumptions import thin_hoop
from analytic.systems import Motion, Parameters, Scales

if TYPE_CHECKING:
    from analytic.lagrangian import LagrangianSystem

__all__ = ["MOTION", "PARAMETERS", "build", "minimal", "params_from_model", "scales"]

PARAMETERS = "m g a alpha"

MOTION = Motion(
    description="hoop rolling down a 30° incline, rolling and contact as joint equalities "
                "(multipliers = friction, normal force)",
    q0={"x": 0.0, "s": 0.25, "phi": 0.0},
    qd0={"x": 0.5, "s": 0.0, "phi": 2.0},  # rolling: ẋ = a φ̇ with a = 0.25 m
    horizon=2.0,
    tags=frozenset({"fast", "ci", "constrained"}),
)

RollForm = Literal["holonomic", "pfaffian"]


def build(p: Parameters, *, form: RollForm = "holonomic") -> LagrangianSystem:
    """The hoop in (x, s, φ); ``form`` writes ``roll`` as x − aφ = 0 or as ẋ − aφ̇ = 0."""
    import sympy as sp  # lazy: sympy, only to derive

    from analytic.lagrangian import Constraint, LagrangianSystem, coordinates  # lazy: loads sympy
    from analytic.rigid import RigidBody, axis_rotation  # lazy: loads sympy

    m, g, a, alpha = p.m, p.g, p.a, p.alpha
    (x, s, phi), (x_d, s_d, phi_d) = coordinates("x s phi")
    if form == "holonomic":
        roll = Constraint("roll", x - a * phi)
    elif form == "pfaffian":
        roll = Constraint("roll", x_d - a * phi_d, kind="pfaffian")
    else:
        raise ValueError(f"form must be 'holonomic' or 'pfaffian', got {form!r}")
    d = sp.Matrix([sp.cos(alpha), 0, -sp.sin(alpha)])
    n = sp.Matrix([sp.sin(alpha), 0, sp.cos(alpha)])
    centre = x * d + s * n
    velocity = centre.jacobian([x, s, phi]) * sp.Matrix([x_d, s_d, phi_d])
    axle_inertia = m * a**2  # thin hoop: all mass on the rim
    return LagrangianSystem(
        name="hoop_ramp",
        q=(x, s, phi),
        qd=(x_d, s_d, phi_d),
        kinetic=m * velocity.dot(velocity) / 2 + axle_inertia * phi_d**2 / 2,
        potential=m * g * centre[2],
        params=(m, g, a, alpha),
        constraints=(Constraint("normal", s - a), roll),
        points={"hoop": tuple(centre)},
        # the body "hoop" (the slope's frame turned by α about y, then the hinge φ about the same axis):
        # a thin ring, m a² about its axle, ½ m a² about its diameters
        bodies={"hoop": RigidBody(mass=m, inertia=sp.diag(axle_inertia / 2, axle_inertia, axle_inertia / 2),
                                  com=centre, rotation=axis_rotation("y", alpha + phi))},
    )


def minimal(p: Parameters) -> LagrangianSystem:
    """x alone, with s = a and φ = x/a substituted: 2m ẍ = m g sin α."""
    from analytic.lagrangian import coordinates  # lazy: loads sympy

    a = p.a
    full = build(p)
    x, s, phi = full.q
    (u,), (u_d,) = coordinates("x")
    return full.reduce(q=(u,), qd=(u_d,), embedding={x: u, s: a, phi: u / a})


def params_from_model(model: mujoco.MjModel) -> dict[str, float]:
    """m from body ``hoop``; a from the slide ``s``'s reference (qpos0, the centre's
    height above the slope); α from the world direction of the slide ``x``; g from gravity."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    downhill = data.xaxis[model.joint("x").id]
    params = {
        "m": float(model.body("hoop").mass[0]),
        "a": float(model.joint("s").qpos0[0]),
        "g": float(-model.opt.gravity[2]),
        "alpha": math.atan2(-downhill[2], downhill[0]),
    }
    thin_hoop(model, "hoop", mass=params["m"], radius=params["a"], what="hoop")
    return params


def scales(params: dict[str, float]) -> Scales:
    """Length a (the radius), force m g, energy m g a, momentum m √(g a) a."""
    return Scales.gravity(mass=params["m"], g=params["g"], length=params["a"])

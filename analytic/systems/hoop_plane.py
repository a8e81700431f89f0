"""Vertical hoop rolling on a horizontal plane (seed 000, "Constraints – Method of Lagrange Multipliers").

A thin hoop (ring mass m, radius a; m a² about its axle, m a²/2 about a
diameter) stands upright on the plane z = 0 and rolls in the direction it
heads. Seen from above::

        y ^        h
          |   w   /          h = (cos θ, sin θ, 0)    heading, the rolling direction
          |    \\ /           w = (−sin θ, cos θ, 0)   the hoop's axle, h turned 90° left
          |     C  θ         C = (x, y, z)            centre, above the contact point (x, y, 0)
          |      ‾‾‾‾‾
          +----------------> x

Coordinates q = (x, y, z, theta, phi):

    x, y   horizontal position of the centre (= of the contact point);
    z      height of the centre (z = a in contact);
    theta  heading, about world +z, from +x towards +y;
    phi    spin about the axle w; φ̇ > 0 rolls forward (along +h).

The hoop's angular velocity is ω = θ̇ ẑ + φ̇ w, so with the axle inertia
m a² and the diameter inertia m a²/2 (ẑ lies in the hoop's plane)
T = ½ m |Ċ|² + ½ m a² φ̇² + ¼ m a² θ̇², V = m g z. The joint structure holds
the hoop upright: the tilting torque of the contact force is taken by it.

Constraints, named like the case's contact readings (``mujoco_forces`` in ``harness/cases.py``):

    normal:  f = z − a = 0                    (holonomic),  J = (0, 0, 1, 0, 0)
    roll_x:  ẋ − a φ̇ cos θ = 0               (Pfaffian),   J = (1, 0, 0, 0, −a cos θ)
    roll_y:  ẏ − a φ̇ sin θ = 0               (Pfaffian),   J = (0, 1, 0, 0, −a sin θ)

The rolling rows are the seed's dx = a dφ cos θ, dy = a dφ sin θ: they cannot
be integrated to a relation between positions (x and y depend on the history
of θ and φ), so they stay Pfaffian rows and no minimal-coordinate ODE exists.

Sign of the multipliers: with M q̈ = F + Jᵀλ the rows read m ẍ = λ_roll_x,
m ÿ = λ_roll_y, m z̈ = −m g + λ_normal, so (λ_roll_x, λ_roll_y, λ_normal) are
the world components of the contact force on the hoop: friction in x and y,
and the normal force (+m g). The spin row m a² φ̈ = −a (λ_roll_x cos θ +
λ_roll_y sin θ) is the moment of that force about the axle.

Motion: θ̈ = 0 and φ̈ = 0, so the centre runs round a circle of radius
R = a φ̇ / θ̇ about C₀ + R w(θ₀), at speed v = a φ̇; the friction is purely
lateral, m v θ̇ along w (towards the circle's centre).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from analytic.assumptions import thin_hoop
from analytic.systems import Motion, Parameters, Scales

if TYPE_CHECKING:
    from analytic.lagrangian import LagrangianSystem

__all__ = ["MOTION", "PARAMETERS", "build", "params_from_model", "scales"]

PARAMETERS = "m g a"

MOTION = Motion(
    description="vertical hoop rolling on a plane, heading turning: circular path, Pfaffian rolling "
                "rows on a frictional contact",
    q0={"x": 0.0, "y": 0.0, "z": 0.5, "theta": 0.0, "phi": 0.0},
    # v = a φ̇ = 1 m/s, θ̇ = 1 rad/s: a circle of radius 1 m about (0, 1)
    qd0={"x": 1.0, "y": 0.0, "z": 0.0, "theta": 1.0, "phi": 2.0},
    horizon=2.0,
    tags=frozenset({"fast", "ci", "constrained", "contact"}),
)


def build(p: Parameters) -> LagrangianSystem:
    import sympy as sp  # lazy: sympy, only to derive

    from analytic.lagrangian import Constraint, LagrangianSystem, coordinates  # lazy: loads sympy
    from analytic.rigid import RigidBody, axis_rotation  # lazy: loads sympy

    m, g, a = p.m, p.g, p.a
    (x, y, z, theta, phi), qd = coordinates("x y z theta phi")
    x_d, y_d, z_d, theta_d, phi_d = qd
    centre = sp.Matrix([x, y, z])
    velocity = sp.Matrix([x_d, y_d, z_d])
    axle = sp.Matrix([-sp.sin(theta), sp.cos(theta), 0])
    omega = theta_d * sp.Matrix([0, 0, 1]) + phi_d * axle
    spin = omega.dot(axle)
    in_plane = omega - spin * axle
    axle_inertia, diameter_inertia = m * a**2, m * a**2 / 2  # thin hoop
    kinetic = (m * velocity.dot(velocity) + axle_inertia * spin**2
               + diameter_inertia * in_plane.dot(in_plane)) / 2
    return LagrangianSystem(
        name="hoop_plane",
        q=(x, y, z, theta, phi),
        qd=qd,
        kinetic=sp.simplify(kinetic),
        potential=m * g * z,
        params=(m, g, a),
        constraints=(
            Constraint("normal", z - a),
            Constraint("roll_x", x_d - a * phi_d * sp.cos(theta), kind="pfaffian"),
            Constraint("roll_y", y_d - a * phi_d * sp.sin(theta), kind="pfaffian"),
        ),
        points={"hoop": tuple(centre)},
        # the body "hoop": heading θ about world z, then the spin φ about its own y (the axle w), as the
        # model's hinges compose; a thin ring, m a² about its axle, ½ m a² about its diameters
        bodies={"hoop": RigidBody(mass=m, inertia=sp.diag(diameter_inertia, axle_inertia, diameter_inertia),
                                  com=centre, rotation=axis_rotation("z", theta) * axis_rotation("y", phi))},
    )


def params_from_model(model) -> dict[str, float]:
    """m from body ``hoop``; a from the slide ``z``'s reference (qpos0, the centre's
    height in contact); g from gravity."""
    params = {
        "m": float(model.body("hoop").mass[0]),
        "a": float(model.joint("z").qpos0[0]),
        "g": float(-model.opt.gravity[2]),
    }
    thin_hoop(model, "hoop", mass=params["m"], radius=params["a"], what="hoop")
    return params


def scales(params: dict[str, float]) -> Scales:
    """Length a (the radius), force m g, energy m g a, momentum m √(g a) a."""
    return Scales.gravity(mass=params["m"], g=params["g"], length=params["a"])

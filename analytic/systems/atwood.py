"""Atwood's machine with a massive pulley (seed 000, "Example: Atwood's Machine").

Two point masses m1, m2 hang from a string over a pulley of radius a whose
mass m_p sits on its rim (moment of inertia m_p a² about the axle). The string
does not stretch or slip, so the seed's z1 = z3 = −z2 with z3 = aθ::

                z ^
                  |      pulley: centre (0, 0, h), radius a, hinge ``theta``
               .--o--.   about +y; θ > 0 raises the left rim (x = −a)
               |     |
       string1 |     | string2
               |     |
            m1 ●     ● m2        mass1 at (−a, 0, z1), mass2 at (a, 0, z2)
               x=−a  x=a

Coordinates q = (z1, z2, theta): the heights of the masses (MuJoCo: vertical
slides ``z1``, ``z2``, qpos = height) and the pulley angle (hinge ``theta``).
All three are kept and tied by two holonomic constraints, named like the
MJCF joint equalities:

    string1: f1 = z1 − aθ = 0,   J1 = (1, 0, −a)
    string2: f2 = z2 + aθ = 0,   J2 = (0, 1,  a)

T = ½ m1 ż1² + ½ m2 ż2² + ½ m_p a² θ̇²,  V = m1 g z1 + m2 g z2 + m_p g h (the
last term is constant; it makes V the same number as MuJoCo's potential).

Sign of the multipliers: with M q̈ = F + Jᵀλ the z1 row reads
m1 z̈1 = −m1 g + λ1, so λ1 = λ_string1 is the upward pull of string 1 on m1:
the tension in string 1, positive while the string is taut. Likewise
λ2 = λ_string2 is the tension in string 2. The pulley feels the torque
a(λ2 − λ1) about +y; a massive pulley needs unequal tensions to accelerate.
MuJoCo's joint equality ``joint1=z1 joint2=theta polycoef="0 a 0 0 0"``
(and ``joint1=z2``, ``polycoef="0 −a 0 0 0"``) has exactly these Jacobian
rows, so its ``efc_force`` is λ with the same sign.

Reactions (:mod:`analytic.reactions`): the bodies are MuJoCo's ``mass1``,
``mass2`` and ``pulley`` (a thin hoop about +y). The string pulls mass1 up with
λ1 ẑ, mass2 with λ2 ẑ, and the pulley down with both at its rims, so the axle
carries F = (m_p g + λ1 + λ2) ẑ: both tensions and the pulley's weight. Where
the string is a joint equality (``mjcf/atwood.xml``) MuJoCo has no string
force in space at all: its coupling is a joint-space force, which its
``mj_rnePostConstraint`` attributes to the joints, so its axle sensor reads
m_p g only; the spatial tendons of ``mjcf/atwood_tendon.xml`` apply the
tensions at the rims and hooks, and its sensors read the physics.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from analytic.assumptions import thin_hoop
from analytic.systems import Motion, Parameters, Scales

if TYPE_CHECKING:
    from analytic.lagrangian import LagrangianSystem

__all__ = ["MOTION", "PARAMETERS", "build", "minimal", "params_from_model", "scales"]

PARAMETERS = "m1 m2 m_p a g h"

MOTION = Motion(
    description="Atwood's machine, massive pulley; two string equalities (multipliers = tensions)",
    q0={"z1": 0.0, "z2": 0.0, "theta": 0.0},
    qd0={"z1": 0.0, "z2": 0.0, "theta": 0.0},  # from rest: consistent for any radius a
    horizon=1.5,
    tags=frozenset({"fast", "ci", "constrained"}),
)


def build(p: Parameters) -> LagrangianSystem:
    import sympy as sp  # lazy: sympy, only to derive

    from analytic.lagrangian import Constraint, LagrangianSystem, coordinates  # lazy: loads sympy
    from analytic.rigid import RigidBody, axis_rotation, point_mass  # lazy: loads sympy

    m1, m2, m_p, a, g, h = p.m1, p.m2, p.m_p, p.a, p.g, p.h
    (z1, z2, theta), (z1_d, z2_d, theta_d) = coordinates("z1 z2 theta")
    return LagrangianSystem(
        name="atwood",
        q=(z1, z2, theta),
        qd=(z1_d, z2_d, theta_d),
        kinetic=(m1 * z1_d**2 + m2 * z2_d**2 + m_p * a**2 * theta_d**2) / 2,
        potential=m1 * g * z1 + m2 * g * z2 + m_p * g * h,
        params=(m1, m2, m_p, a, g, h),
        constraints=(Constraint("string1", z1 - a * theta), Constraint("string2", z2 + a * theta)),
        points={"mass1": (-a, 0, z1), "mass2": (a, 0, z2)},
        bodies={"mass1": point_mass(m1, (-a, 0, z1)), "mass2": point_mass(m2, (a, 0, z2)),
                # a thin hoop turning about +y: I = m_p a² about its axle, ½ m_p a² about its diameters
                "pulley": RigidBody(mass=m_p, inertia=sp.diag(m_p * a**2 / 2, m_p * a**2, m_p * a**2 / 2),
                                    com=sp.Matrix([0, 0, h]), rotation=axis_rotation("y", theta))},
    )


def minimal(p: Parameters) -> LagrangianSystem:
    """z1 alone, with z2 = −z1 and θ = z1/a substituted: (m1 + m2 + m_p) z̈1 = −(m1 − m2) g."""
    from analytic.lagrangian import coordinates  # lazy: loads sympy

    a = p.a
    full = build(p)
    z1, z2, theta = full.q
    (s,), (s_d,) = coordinates("z1")
    return full.reduce(q=(s,), qd=(s_d,), embedding={z1: s, z2: -s, theta: s / a})


def params_from_model(model) -> dict[str, float]:
    """Masses from bodies ``mass1``, ``mass2``, ``pulley``; a from equality ``string1``'s
    polycoef (z1 = a·θ) where the string is a joint equality, else (a tendon equality: the string
    as a tendon wrapped over the pulley, ``mjcf/atwood_tendon.xml``) from the radius of the
    cylinder ``pulley`` it wraps; h from the pulley's height; g from gravity."""
    import mujoco  # lazy: only the constant, with the model at hand

    string1 = model.equality("string1")
    joint = int(model.eq_type[string1.id]) == int(mujoco.mjtEq.mjEQ_JOINT)
    params = {
        "m1": float(model.body("mass1").mass[0]),
        "m2": float(model.body("mass2").mass[0]),
        "m_p": float(model.body("pulley").mass[0]),
        "a": float(string1.data[1]) if joint else float(model.geom("pulley").size[0]),
        "g": float(-model.opt.gravity[2]),
        "h": float(model.body("pulley").pos[2]),
    }
    # the pulley's own radius (its geom's), not a string's coefficient: a string wound on another radius is a
    # fault of that string, not another pulley
    thin_hoop(model, "pulley", mass=params["m_p"], radius=float(model.geom("pulley").size[0]), what="pulley")
    return params


def scales(params: dict[str, float]) -> Scales:
    """Forces against the hanging weight (m1 + m2) g, lengths against the radius a."""
    return Scales.gravity(mass=params["m1"] + params["m2"], g=params["g"], length=params["a"])

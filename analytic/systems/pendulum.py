"""Planar pendulum whose length is held by a constraint (seed 001, "Constraints").

A point mass m on a massless rod, pivot at the origin, in the x–z plane::

        z ^
          |
    pivot o------> x
           \\
            \\  r        θ from the downward vertical,
             \\          positive towards +x
              ● m       bob at (r sin θ, 0, −r cos θ)

Coordinates q = (theta, r). The radius r is kept as a coordinate and held by
the holonomic constraint ``rod``: f = r − l = 0, J = ∂f/∂q = (0, 1).

Sign of the multiplier: with M q̈ = F + Jᵀλ, λ is the generalized force on r,
i.e. the radial force on the bob, positive outward. The rod pulls inward, so
λ = −(rod tension) = −(m l θ̇² + m g cos θ) on the constraint. MuJoCo's joint
equality on the slide ``r`` has the same Jacobian row, so its ``efc_force``
is λ with the same sign.

Reactions (:mod:`analytic.reactions`): the bob is MuJoCo's body ``bob``, child
of the world through the hinge and the slide. The force the parent exerts on it
is m(a − g) = λ r̂ = −T r̂ (r̂ the unit vector from the pivot to the bob): the
rod's pull toward the pivot, of magnitude the tension T; its moment about the
pivot is zero.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from analytic.systems import Motion, Parameters, Scales

if TYPE_CHECKING:
    from analytic.lagrangian import LagrangianSystem

__all__ = ["MOTION", "PARAMETERS", "build", "minimal", "params_from_model", "scales"]

PARAMETERS = "m g l"

MOTION = Motion(
    description="planar pendulum, length held by a constraint (multiplier = −rod tension)",
    q0={"theta": 1.0, "r": 1.0},
    qd0={"theta": 0.5, "r": 0.0},
    horizon=5.0,
    tags=frozenset({"fast", "ci", "constrained"}),
)


def build(p: Parameters) -> LagrangianSystem:
    import sympy as sp  # lazy: sympy, only to derive

    from analytic.lagrangian import Constraint, LagrangianSystem, coordinates  # lazy: loads sympy
    from analytic.rigid import point_mass  # lazy: loads sympy

    m, g, l = p.m, p.g, p.l
    (theta, r), (theta_d, r_d) = coordinates("theta r")
    x, z = r * sp.sin(theta), -r * sp.cos(theta)
    vx, vz = sp.diff(x, theta) * theta_d + sp.diff(x, r) * r_d, sp.diff(z, theta) * theta_d + sp.diff(z, r) * r_d
    return LagrangianSystem(
        name="pendulum",
        q=(theta, r),
        qd=(theta_d, r_d),
        kinetic=m * (vx**2 + vz**2) / 2,
        potential=m * g * z,
        params=(m, g, l),
        constraints=(Constraint("rod", r - l),),
        points={"bob": (x, 0, z)},
        bodies={"bob": point_mass(m, (x, 0, z))},
    )


def minimal(p: Parameters) -> LagrangianSystem:
    """θ alone, with r = l substituted: the textbook pendulum ODE."""
    from analytic.lagrangian import coordinates  # lazy: loads sympy

    l = p.l
    full = build(p)
    theta, r = full.q
    (s,), (s_d,) = coordinates("theta")
    return full.reduce(q=(s,), qd=(s_d,), embedding={theta: s, r: l})


def params_from_model(model) -> dict[str, float]:
    """m from the bob's mass, l from the slide's reference (qpos0), g from gravity."""
    return {
        "m": float(model.body("bob").mass[0]),
        "l": float(model.joint("r").qpos0[0]),
        "g": float(-model.opt.gravity[2]),
    }


def scales(params: dict[str, float]) -> Scales:
    """Length l, force m g, energy m g l, momentum m √(g l) l."""
    return Scales.gravity(mass=params["m"], g=params["g"], length=params["l"])

"""Mass on a spring (seed 001, "Mass on a Spring").

A point mass m slides without friction along a horizontal line, tied to a wall
by a linear spring of stiffness k that is relaxed when the mass sits at its
rest position, a distance l0 from the wall::

    wall
     |/                 x > 0: spring stretched, force −k x
     |/\\/\\/\\/\\/\\/●------> x
     |/          m       mass at (l0 + x, 0, 0)
     |/<-- l0 -->|
                 x = 0 (rest)

Coordinate q = (x,): the displacement from rest along +x (MuJoCo: slide joint
``x``, axis +x, stiffness k, springref 0, so qpos = x). T = ½ m ẋ², U = ½ k x².

The slide is horizontal, so gravity (along −z) does no work on it and the
mass's height is constant (z = 0, so MuJoCo's gravitational potential
m g z is 0 too); MuJoCo's potential energy then equals the spring's ½ k x²
(included by the energy flag). There are no constraints and no multipliers.
The rest length l0 enters only the observable position and the scales.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from analytic.systems import Motion, Parameters, Scales

if TYPE_CHECKING:
    from analytic.lagrangian import LagrangianSystem

__all__ = ["MOTION", "PARAMETERS", "build", "params_from_model", "scales"]

PARAMETERS = "m k l0"

MOTION = Motion(
    description="mass on a horizontal spring: x = c1 sin ωt + c2 cos ωt, about 5 periods",
    q0={"x": 0.2},
    qd0={"x": 1.0},
    horizon=5.0,
)


def build(p: Parameters) -> LagrangianSystem:
    from analytic.lagrangian import LagrangianSystem, coordinates  # lazy: loads sympy
    from analytic.rigid import point_mass  # lazy: loads sympy

    m, k, l0 = p.m, p.k, p.l0
    (x,), (x_d,) = coordinates("x")
    return LagrangianSystem(
        name="spring",
        q=(x,),
        qd=(x_d,),
        kinetic=m * x_d**2 / 2,
        potential=k * x**2 / 2,
        params=(m, k, l0),
        points={"mass": (l0 + x, 0, 0)},
        bodies={"mass": point_mass(m, (l0 + x, 0, 0))},
    )


def params_from_model(model) -> dict[str, float]:
    """m from the body ``mass``, k from the stiffness of slide ``x``, l0 from the body's x position.

    Raises ValueError if the spring is not relaxed at x = 0 (springref ≠ 0),
    which U = ½ k x² assumes.
    """
    joint = model.joint("x")
    springref = float(model.qpos_spring[joint.qposadr[0]])
    if springref != 0.0:
        raise ValueError(f"joint 'x' must have springref 0 (spring relaxed at x = 0), got {springref}")
    return {
        "m": float(model.body("mass").mass[0]),
        "k": float(joint.stiffness[0]),
        "l0": float(model.body("mass").pos[0]),
    }


def scales(params: dict[str, float]) -> Scales:
    """The rest length l0 and the spring's force k l0 and energy k l0² at that stretch."""
    m_, k_, l_ = params["m"], params["k"], params["l0"]
    return Scales(length=l_, force=k_ * l_, energy=k_ * l_**2, momentum=(m_ * k_) ** 0.5 * l_)

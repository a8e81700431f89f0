"""Cart-pole: a pendulum hanging from a cart that slides freely along a horizontal rail.

A cart of mass M slides along x; a point mass m hangs from a hinge on the cart
on a massless rod of length l, swinging in the x–z plane::

        z ^
          |      x (cart position, slide "x", axis +x)
    ======[ M ]=========> x        rail at z = 0
           o  hinge "theta" on the cart
            \\
             \\ l     θ from the downward vertical,
              \\      positive towards +x (hinge axis −y)
               ● m    bob at (x + l sin θ, 0, −l cos θ)

Coordinates q = (x, theta); no constraints, so no multipliers. T = ½ M ẋ² +
½ m |v_bob|², V = −m g l cos θ (the cart stays at z = 0: MuJoCo's potential
m g z is the bob's alone). x is cyclic: the horizontal momentum
(M + m) ẋ + m l cos θ θ̇ is conserved, and so is the energy.

Parameters are read from the model (the one source of truth): M and m from
the bodies ``cart`` and ``bob``, l from the bob's offset below the cart, g
from gravity.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from analytic.systems import Motion, Parameters, Scales

if TYPE_CHECKING:
    from analytic.lagrangian import LagrangianSystem

PARAMETERS = "M m g l"

MOTION = Motion(
    description="cart-pole: a pendulum hanging from a cart on a frictionless rail, released at 1 rad "
                "with the cart moving; energy and horizontal momentum conserved",
    q0={"x": 0.0, "theta": 1.0},
    qd0={"x": 0.5, "theta": 0.0},
    horizon=3.0,
    tags={"fast", "ci"},
)


def build(p: Parameters) -> LagrangianSystem:
    import sympy as sp  # lazy: only a derivation needs sympy

    from analytic.lagrangian import LagrangianSystem, coordinates
    from analytic.rigid import point_mass

    M, m, g, l = p.M, p.m, p.g, p.l
    (x, theta), (x_d, theta_d) = coordinates("x theta")
    bob = (x + l * sp.sin(theta), 0, -l * sp.cos(theta))
    bob_vx = x_d + l * sp.cos(theta) * theta_d
    bob_vz = l * sp.sin(theta) * theta_d
    return LagrangianSystem(
        name="cartpole",
        q=(x, theta),
        qd=(x_d, theta_d),
        kinetic=M * x_d**2 / 2 + m * (bob_vx**2 + bob_vz**2) / 2,
        potential=m * g * bob[2],
        params=(M, m, g, l),
        points={"cart": (x, 0, 0), "bob": bob},
        bodies={"cart": point_mass(M, (x, 0, 0)), "bob": point_mass(m, bob)},
    )


def params_from_model(model) -> dict[str, float]:
    """M and m from the bodies' masses, l from the bob's offset below the cart, g from gravity."""
    return {
        "M": float(model.body("cart").mass[0]),
        "m": float(model.body("bob").mass[0]),
        "l": float(-model.body("bob").pos[2]),
        "g": float(-model.opt.gravity[2]),
    }


def scales(params: dict[str, float]) -> Scales:
    """Length l, force m g, energy m g l, momentum m √(g l) l: the pole's, whose swing carries the motion."""
    return Scales.gravity(mass=params["m"], g=params["g"], length=params["l"])

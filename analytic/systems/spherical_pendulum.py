r"""Spherical pendulum (seed 000, "Example: Spherical Pendulum").

A point mass m on a massless rod of length l, pivot at the origin, free to
swing in every direction::

    side view at φ = 0:                       seen from above:
          z ^
            |                                      y ^
      pivot o------> x  (y into the page)            |   ● bob
            |\                                      |  /
            |θ\  l      θ: polar angle from the      | /  φ: azimuth about +z,
            |  \           DOWNWARD vertical          |/ )    from +x towards +y
            |   ● m        (θ = 0: hanging)    pivot o--------> x
           −z

    bob at (l sin θ cos φ,  l sin θ sin φ,  −l cos θ)

Coordinates q = (theta, phi). They are minimal (the rod length is built into
the parametrization), so there are no constraints and no multipliers.

    T = ½ m l² (θ̇² + sin²θ φ̇²),    V = −m g l cos θ    (zero at the pivot height)

The seed writes V = m g l cos θ, which is this potential with θ measured from
the UPWARD vertical (θ → π − θ); the kinetic energy is the same either way.
The seed's d/dt(∂L/∂φ̇) = m l² φ̈ sin²θ − 2 m l² θ̇ φ̇ sin θ cos θ has a sign slip:
the derivative of sin²θ gives +2 sin θ cos θ θ̇ under either convention
(tests/test_spherical_pendulum.py pins the + sign).

φ does not appear in L, so it is cyclic and

    p_phi = ∂L/∂φ̇ = m l² sin²θ φ̇

is conserved: the vertical component of the bob's angular momentum about
the pivot, positive counter-clockwise seen from above.

MuJoCo models: ``mjcf/spherical_pendulum.xml`` realises the angles as two
hinges at the pivot (azimuth ``phi`` about +z, then polar ``theta`` about the
rotated −y axis), so its qpos is (φ, θ); ``mjcf/spherical_pendulum_ball.xml``
uses one ball joint whose orientation is R = R_z(φ) R_{−y}(θ), the same body
frame as the two-hinge model (harness/ball_binding.py maps the state).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from analytic.systems import Motion, Parameters, Scales

if TYPE_CHECKING:
    from analytic.lagrangian import LagrangianSystem

__all__ = ["MOTION", "PARAMETERS", "build", "params_from_model", "scales"]

PARAMETERS = "m g l"

MOTION = Motion(
    description="spherical pendulum on two hinges (azimuth, polar); precessing orbit, p_phi conserved",
    q0={"theta": 1.0, "phi": 0.0},
    qd0={"theta": 0.0, "phi": 2.0},  # conical orbit at θ = 1 needs φ̇ = √(g/(l cos θ)) = 4.26 rad/s
    horizon=5.0,
)

BOB = "bob"


def build(p: Parameters) -> LagrangianSystem:
    import sympy as sp  # lazy: sympy, only to derive

    from analytic.lagrangian import LagrangianSystem, coordinates  # lazy: loads sympy
    from analytic.rigid import point_mass  # lazy: loads sympy

    m, g, l = p.m, p.g, p.l
    (theta, phi), (theta_d, phi_d) = coordinates("theta phi")
    pos = sp.Matrix([l * sp.sin(theta) * sp.cos(phi), l * sp.sin(theta) * sp.sin(phi), -l * sp.cos(theta)])
    vel = pos.jacobian([theta, phi]) * sp.Matrix([theta_d, phi_d])
    # simplified so that φ is structurally absent from T (Derivation.cyclic tests ∂L/∂φ == 0 as is)
    kinetic = sp.simplify(m * vel.dot(vel) / 2)
    return LagrangianSystem(
        name="spherical_pendulum",
        q=(theta, phi),
        qd=(theta_d, phi_d),
        kinetic=kinetic,
        potential=m * g * pos[2],
        params=(m, g, l),
        points={BOB: tuple(pos)},
        bodies={BOB: point_mass(m, pos)},
    )


def params_from_model(model) -> dict[str, float]:
    """m from the bob's mass, g from gravity, l from the pivot-to-bob distance.

    The pivot is the anchor of the bob's joints (both hinges, or the ball);
    l = |joint pos − centre of mass| in the bob's frame, so moving either in
    the MJCF changes l consistently. Raises ValueError if the bob's joints do
    not share one anchor or gravity is not along −z.
    """
    bid = model.body(BOB).id
    first, count = int(model.body_jntadr[bid]), int(model.body_jntnum[bid])
    if count == 0:
        raise ValueError(f"body {BOB!r} has no joints; expected two hinges or one ball joint at the pivot")
    anchors = np.asarray(model.jnt_pos[first:first + count])
    if np.max(np.abs(anchors - anchors[0])) > 1e-12:
        raise ValueError(f"the joints of body {BOB!r} must share one anchor (the pivot), got {anchors.tolist()}")
    gravity = np.asarray(model.opt.gravity, dtype=float)
    if np.any(gravity[:2] != 0) or not gravity[2] < 0:
        raise ValueError(f"gravity must point along −z, got {gravity.tolist()}")
    return {
        "m": float(model.body_mass[bid]),
        "l": float(np.linalg.norm(anchors[0] - model.body_ipos[bid])),
        "g": float(-gravity[2]),
    }


def scales(params: dict[str, float]) -> Scales:
    """Length l, force m g, energy m g l, angular momentum m l √(g l)."""
    return Scales.gravity(mass=params["m"], g=params["g"], length=params["l"])

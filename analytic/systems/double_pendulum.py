"""Double pendulum: two point masses on massless rods, two hinges, in the x–z plane.

The first rod (length l1) hangs from a fixed pivot at the origin and carries
the mass m1 at its end; the second rod (length l2) hangs from m1 and carries
m2. Both hinges turn about −y, so an angle is positive towards +x::

        z ^
          |
    pivot o------> x
           \\  θ1            θ1: rod 1 from the downward vertical
            \\ l1
             ● m1
              |\\            θ2: rod 2 relative to rod 1 (the elbow angle),
              | \\ l2        so rod 2 is at θ1 + θ2 from the downward vertical
                 ● m2

    m1 at  p1 = (l1 sin θ1, 0, −l1 cos θ1)
    m2 at  p2 = p1 + (l2 sin(θ1 + θ2), 0, −l2 cos(θ1 + θ2))

Coordinates q = (theta1, theta2): the two hinge angles exactly as MuJoCo's
joints measure them (the second hinge sits on the first body, so its angle
is relative), so qpos = q. T = ½ m1 |ṗ1|² + ½ m2 |ṗ2|², V = g (m1 z1 + m2 z2)
with the pivot at zero height. No constraints and no multipliers: the rods
are rigid through the hinge structure. Energy is conserved; no coordinate is
cyclic.

The motion MOTION runs (θ1 = 2.5 rad from rest) is chaotic: nearby motions
separate exponentially. Past a few seconds any integration error is amplified
until it saturates at the length scale, and the figures would measure the
chaos, not the integrator. The 3 s horizon keeps the amplification small
(tests/test_double_pendulum.py measures it; the rate and the errors:
docs/findings/bases.md): at the model's 0.5 ms a first-order integrator's
error stays a small fraction of the 1.5 m length scale, RK4's stays far above
the reference's own (its rtol of 1e-12, amplified alike) and the point-mass
inertia floor, and halving h still halves (first order) or divides by 16
(RK4) the error over the whole convergence ladder, which is what layer 4
checks. The same amplification is why the model's point masses carry a
diaginertia of only 1e-14 (see mjcf/double_pendulum.xml).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from analytic.systems import Motion, Parameters, Scales

if TYPE_CHECKING:
    from analytic.lagrangian import LagrangianSystem

__all__ = ["MOTION", "PARAMETERS", "build", "params_from_model", "scales"]

PARAMETERS = "m1 m2 l1 l2 g"

MOTION = Motion(
    description="double pendulum on two hinges, point masses on massless rods; chaotic, energy conserved",
    q0={"theta1": 2.5, "theta2": 0.0},
    qd0={"theta1": 0.0, "theta2": 0.0},
    horizon=3.0,
)

BODIES = ("bob1", "bob2")


def build(p: Parameters) -> LagrangianSystem:
    import sympy as sp  # lazy: sympy, only to derive

    from analytic.lagrangian import LagrangianSystem, coordinates  # lazy: loads sympy
    from analytic.rigid import point_mass  # lazy: loads sympy

    (th1, th2), (th1_d, th2_d) = coordinates("theta1 theta2")
    p1 = sp.Matrix([p.l1 * sp.sin(th1), 0, -p.l1 * sp.cos(th1)])
    p2 = p1 + sp.Matrix([p.l2 * sp.sin(th1 + th2), 0, -p.l2 * sp.cos(th1 + th2)])
    rates = sp.Matrix([th1_d, th2_d])
    v1, v2 = p1.jacobian([th1, th2]) * rates, p2.jacobian([th1, th2]) * rates
    return LagrangianSystem(
        name="double_pendulum",
        q=(th1, th2),
        qd=(th1_d, th2_d),
        kinetic=sp.simplify((p.m1 * v1.dot(v1) + p.m2 * v2.dot(v2)) / 2),
        potential=p.g * (p.m1 * p1[2] + p.m2 * p2[2]),
        params=(p.m1, p.m2, p.l1, p.l2, p.g),
        points={"bob1": tuple(p1), "bob2": tuple(p2)},
        bodies={"bob1": point_mass(p.m1, p1), "bob2": point_mass(p.m2, p2)},
    )


def _rod(model, body: str, joint: str) -> float:
    """The distance from the hinge ``joint`` of ``body`` to the body's centre of mass (its rod)."""
    jid, bid = model.joint(joint).id, model.body(body).id
    if int(model.jnt_bodyid[jid]) != bid:
        raise ValueError(f"joint {joint!r} must be on body {body!r}")
    return float(np.linalg.norm(model.jnt_pos[jid] - model.body_ipos[bid]))


def params_from_model(model) -> dict[str, float]:
    """m1, m2 from the bodies ``bob1``, ``bob2``; each rod from its hinge's anchor to the body's centre of
    mass; g from gravity. Raises ValueError unless ``bob2`` hangs from ``bob1`` and gravity is along −z."""
    if int(model.body_parentid[model.body("bob2").id]) != model.body("bob1").id:
        raise ValueError("body 'bob2' must be a child of body 'bob1'")
    gravity = np.asarray(model.opt.gravity, dtype=float)
    if np.any(gravity[:2] != 0) or not gravity[2] < 0:
        raise ValueError(f"gravity must point along −z, got {gravity.tolist()}")
    return {"m1": float(model.body("bob1").mass[0]), "m2": float(model.body("bob2").mass[0]),
            "l1": _rod(model, "bob1", "theta1"), "l2": _rod(model, "bob2", "theta2"), "g": float(-gravity[2])}


def scales(params: dict[str, float]) -> Scales:
    """Length l1 + l2, force (m1 + m2) g, energy (m1 + m2) g (l1 + l2), momentum (m1 + m2) √(g L) L."""
    return Scales.gravity(mass=params["m1"] + params["m2"], g=params["g"], length=params["l1"] + params["l2"])

"""Welded pendulum: a physical-pendulum link held to its hub by a ``weld`` equality, force and moment.

A hub (a disc of mass m_h, inertia I_h about its axle, centre of mass on the
axle) turns on a hinge about −y at the origin. A link (mass m, principal inertias I1, I2,
I3 about its centre of mass along its frame's x, y, z) is a separate body with
all six degrees of freedom of its own; the weld ``glue`` holds the link's frame
at its top (site ``top``) to the hub's frame at the socket (site ``socket``, a
below the axle). Together they swing as one compound pendulum::

        z ^
          |
     axle o------> x        hub: θ from the downward vertical, towards +x
          |  a              socket S = a (sin θ, 0, −cos θ)
          S  <- weld "glue": link top = S, link frame = hub frame
          |
          |  d              link centre of mass c = top + R_link (0, e, −d):
          ●  (e out of      d below the top, e off the swing plane along y,
              the plane)    so the weld's moment has x and z parts as well

Coordinates q = (theta, x, y, z, pitch, roll, yaw), MuJoCo's joints of the
same names: ``theta`` the hub's hinge (about −y); x, y, z the world position of
the link's top (slides; z's ref is the top's height at qpos0, so qpos = world
z); pitch, roll, yaw the link's hinges in that order, about −y, x and z of its
frame as turned by the ones before (MuJoCo composes a body's joints in order):
R_link = R_−y(pitch) R_x(roll) R_z(yaw), R_hub = R_−y(θ).

The weld's six rows, in MuJoCo's order (engine_core_constraint.c, mjEQ_WELD,
site semantics; body1 = the link, body2 = the hub)::

    position:     top − S                          (world x, y, z)
    orientation:  s · vec(q̄_hub ⊗ q_link)         (the axis part of the relative quaternion)

with q_hub, q_link the frames' unit quaternions (axis-angle of each hinge,
multiplied in the hinges' order) and s the weld's ``torquescale`` (a length).
MuJoCo's Jacobian of the orientation rows is ½ s vec(q̄_hub ⊗ (ω_link − ω_hub) ⊗
q_link), exactly the time derivative of these rows, so they are holonomic
constraints f(q) = 0 with J = ∂f/∂q and the multipliers compare row by row.

Sign and meaning of the multipliers (M q̈ = F + Jᵀλ): the position rows' λ_F is
the world force the hub exerts on the link at its top; the orientation rows'
λ_τ is the moment of the weld on the link, τ = (s/2) R_hub λ_τ (from the
virtual work λ_τ · δf = τ · δφ_link and δf = (s/2) R_hubᵀ δφ_link where the
weld holds): λ_τ = (2/s) R_hubᵀ τ, the moment in the hub's frame times 2/s.
The link's Newton–Euler equations give both in closed form (tests/test_welded_pendulum.py).

T = ½ I_h θ̇² + ½ m |ċ|² + ½ ω_bᵀ diag(I1, I2, I3) ω_b, V = m g c_z (the hub's
centre of mass is on the axle at height 0: MuJoCo's potential energy exactly).
On the motion the link turns with the hub (pitch = θ, roll = yaw = 0, its top
at S), a compound pendulum of inertia I_h + I2 + m (a + d)² about the axle.

Bodies (for the reaction sensors, :mod:`analytic.reactions`): ``hub`` (m_h on the
axle, turning about y only, so of its inertia only I_h enters) and ``link``; the
point ``socket`` is S on the hub (its accelerometer's site). The hub's hinge
carries the hub's weight and dL/dt less the weld's wrench on it (−λ_F at S, −τ);
the link's six joints carry nothing (its Newton–Euler is the weld's wrench).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from analytic.systems import Motion, Parameters, Scales

if TYPE_CHECKING:
    import sympy as sp

    from analytic.lagrangian import LagrangianSystem

__all__ = ["MOTION", "PARAMETERS", "build", "params_from_model", "scales"]

PARAMETERS = "I_h m_h a m I1 I2 I3 d e s g"

MOTION = Motion(
    description="physical pendulum: a free link welded to a hinged hub (6 weld rows: force and moment on the link)",
    # θ = 0.8 rad at rest, the link on the hub: its top at the socket for a = 0.2 m (the reference projects
    # the state onto the model's own weld, to round-off, for any other a)
    q0={"theta": 0.8, "x": 0.14347121817990457, "y": 0.0, "z": -0.1393413418694331,
        "pitch": 0.8, "roll": 0.0, "yaw": 0.0},
    qd0={"theta": 0.0, "x": 0.0, "y": 0.0, "z": 0.0, "pitch": 0.0, "roll": 0.0, "yaw": 0.0},
    horizon=2.0,
    tags=frozenset({"fast", "ci", "constrained"}),
)


def _quat(axis: tuple[int, int, int], angle: sp.Expr) -> sp.Matrix:
    """The unit quaternion (w, x, y, z) of a rotation by ``angle`` about the unit ``axis``."""
    import sympy as sp  # lazy: sympy, only to derive

    return sp.Matrix([sp.cos(angle / 2), *(k * sp.sin(angle / 2) for k in axis)])


def _qmul(p: sp.Matrix, q: sp.Matrix) -> sp.Matrix:
    """The Hamilton product p ⊗ q of quaternions (w, x, y, z)."""
    import sympy as sp  # lazy: sympy, only to derive

    pw, pv, qw, qv = p[0], sp.Matrix(p[1:]), q[0], sp.Matrix(q[1:])
    return sp.Matrix([pw * qw - pv.dot(qv), *(pw * qv + qw * pv + pv.cross(qv))])


def build(p: Parameters) -> LagrangianSystem:
    import sympy as sp  # lazy: sympy, only to derive

    from analytic.lagrangian import Constraint, LagrangianSystem, coordinates  # lazy: loads sympy
    from analytic.rigid import RigidBody, axis_rotation  # lazy: loads sympy

    q, qd = coordinates("theta x y z pitch roll yaw")
    theta, x, y, z, pitch, roll, yaw = q
    top = sp.Matrix([x, y, z])
    rotation = axis_rotation("y", -pitch) * axis_rotation("x", roll) * axis_rotation("z", yaw)
    link = RigidBody(mass=p.m, inertia=sp.diag(p.I1, p.I2, p.I3), com=top + rotation * sp.Matrix([0, p.e, -p.d]),
                     rotation=rotation)
    socket = axis_rotation("y", -theta) * sp.Matrix([0, 0, -p.a])
    q_hub = _quat((0, -1, 0), theta)
    q_link = _qmul(_qmul(_quat((0, -1, 0), pitch), _quat((1, 0, 0), roll)), _quat((0, 0, 1), yaw))
    conj_hub = sp.Matrix([q_hub[0], *(-k for k in q_hub[1:])])
    relative = _qmul(conj_hub, q_link)
    rows = [*(top - socket), *(p.s * relative[1:, 0])]
    return LagrangianSystem(
        name="welded_pendulum",
        q=q,
        qd=qd,
        kinetic=p.I_h * qd[0] ** 2 / 2 + link.kinetic(q, qd),
        potential=p.m * p.g * link.com[2],
        params=(p.I_h, p.m_h, p.a, p.m, p.I1, p.I2, p.I3, p.d, p.e, p.s, p.g),
        constraints=(Constraint("glue", rows),),
        points={"link": tuple(link.com), "top": tuple(top), "socket": tuple(socket)},
        # the hub turns about −y only (ω ∥ y, a principal axis): of its inertia only I_h enters
        bodies={"hub": RigidBody(mass=p.m_h, inertia=sp.diag(0, p.I_h, 0), com=sp.zeros(3, 1),
                                 rotation=axis_rotation("y", -theta)),
                "link": link},
    )


def params_from_model(model) -> dict[str, float]:
    """I_h and m_h from body ``hub`` (its inertia about y; centre of mass on the axle), a from the site ``socket``
    (on the hub, a below the axle), the link's m, I1, I2, I3 and its centre of mass (0, e, −d) from body
    ``link`` (principal axes along its frame), s from the weld ``glue``'s torquescale, g from gravity.
    ValueError where the model is not of this shape."""
    gravity = np.asarray(model.opt.gravity, dtype=float)
    if np.any(gravity[:2] != 0) or not gravity[2] < 0:
        raise ValueError(f"gravity must point along −z, got {gravity.tolist()}")
    hub, link = model.body("hub"), model.body("link")
    socket, top = model.site("socket"), model.site("top")
    if int(model.site_bodyid[socket.id]) != hub.id or int(model.site_bodyid[top.id]) != link.id:
        raise ValueError("site 'socket' must be on body 'hub' and site 'top' on body 'link'")
    if np.any(model.site_pos[top.id] != 0) or np.any(model.site_pos[socket.id][:2] != 0):
        raise ValueError("site 'top' must be at the link's origin and site 'socket' on the hub's z axis")
    if np.any(model.body_ipos[hub.id] != 0):
        raise ValueError("the hub's centre of mass must be on its axle (body 'hub' ipos 0)")
    ipos = np.asarray(model.body_ipos[link.id], dtype=float)
    if ipos[0] != 0:
        raise ValueError(f"the link's centre of mass must lie in its frame's y–z plane, got {ipos.tolist()}")
    for body in (hub, link):
        if not np.allclose(np.abs(model.body_iquat[body.id]), [1, 0, 0, 0], rtol=0, atol=1e-12):
            raise ValueError(f"body {body.name!r} must have its principal axes along its frame's")
    glue = model.equality("glue").id
    inertia = model.body_inertia[link.id]
    return {"I_h": float(model.body_inertia[hub.id][1]), "m_h": float(hub.mass[0]),
            "a": float(-model.site_pos[socket.id][2]),
            "m": float(link.mass[0]), "I1": float(inertia[0]), "I2": float(inertia[1]), "I3": float(inertia[2]),
            "d": float(-ipos[2]), "e": float(ipos[1]), "s": float(model.eq_data[glue][10]),
            "g": float(-gravity[2])}


def scales(params: dict[str, float]) -> Scales:
    """Length a + d (the axle to the link's centre of mass), force the link's weight m g."""
    return Scales.gravity(mass=params["m"], g=params["g"], length=params["a"] + params["d"])

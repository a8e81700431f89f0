r"""Torque-free asymmetric rigid body on a free joint (issue 18, system 3): the Dzhanibekov flip.

A rigid body of mass m with principal moments I₁ < I₂ < I₃ about its centre
of mass flies free: no gravity, no contact, no force at all. It is spun
mostly about its INTERMEDIATE axis ê₂, which is unstable, so the body flips
over every half period (the "tennis racket" or Dzhanibekov effect)::

    world frame (z along the angular momentum L):      body frame (principal axes, origin at the com):

          z ^  L (fixed)                                         ê₃ (I₃, largest)
            |                                                     ^   ● tip3 at d ê₃
            |    ê₂ spins about here, and                         |
            |    every T/2 turns over (ê₂·L/|L| changes sign)     |
            +-------> y                                       com o------> ê₂ (I₂)  ● tip2 at d ê₂
           /  com c(t) = c₀ + v t (uniform)                      /
          x                                                     ê₁ (I₁, smallest)   ● tip1 at d ê₁

Coordinates q = (x, y, z, phi, theta, psi):

    x, y, z          world position of the centre of mass (m);
    phi, theta, psi  ZXZ Euler angles of the body frame, R = R_z(φ) R_x(θ) R_z(ψ)
                     (:func:`analytic.rigid.euler_zxz`): precession φ about world +z,
                     nutation θ about the line of nodes, spin ψ about the body's ê₃;
                     R maps body → world, so the body axis ê_k points along R ê_k.

    T = ½ m |ċ|² + ½ ω_bᵀ diag(I₁, I₂, I₃) ω_b,   [ω_b]× = Rᵀ Ṙ   (analytic.rigid.RigidBody),   V = 0.

Why Euler angles and not a quaternion held at |q| = 1 by the DAE path: with
world z chosen along the (conserved) angular momentum L, the world z axis
seen from the body is Rᵀẑ = (sin θ sin ψ, sin θ cos ψ, cos θ) = L_b/|L|, so
cos θ = L₃/|L| (L_b = I ω_b, the angular momentum in body axes). ZXZ angles are
singular only at sin θ = 0, i.e. where L lies along ê₃. On an orbit near the
separatrix that never happens: L₂ changes sign on every orbit (the flip), and
L₃² is largest where L₂ = 0 (of L₁²(1/I₁ − 1/I₃) + L₂²(1/I₂ − 1/I₃) = 2E − L²/I₃,
the smallest L₁² + L₂² puts it all in L₁), so from L₁² + L₃² = L² and
L₁²/I₁ + L₃²/I₃ = 2E,

    max cos²θ = (L²/I₁ − 2E) / (L² (1/I₁ − 1/I₃)),

which tends to a/(a + b) < 1 on the separatrix (a = 1/I₁ − 1/I₂,
b = 1/I₂ − 1/I₃): 0.672 for the shipped orbit (sin θ ≥ 0.57; the
minimum of sin θ over the run is checked in tests/test_torque_free_body.py).
So the reference is a plain 6-coordinate ODE with a regular mass matrix, no
constraint and no projection drift; φ is cyclic and its momentum
p_φ = ∂L/∂φ̇ = L·ẑ = |L| is a reference invariant, and x, y, z are cyclic with
p_x, p_y, p_z = m ċ (the linear momentum). A quaternion state would need the
DAE path for a constraint that only fixes a gauge, with a mass matrix
singular along q itself. Nothing is lost by the choice: MuJoCo's side keeps
its quaternion and is compared through world-frame observables only (the
centre of mass and the three body-fixed tips), never through angles.

Why gravity is 0: with no external force the linear momentum is conserved and
the centre of mass moves uniformly, c(t) = c₀ + v t, which the issue asks to
check. (Uniform gravity would leave the rotation torque-free, as it exerts no
torque about the com, but would bend the com's path into a parabola.) The
com starts at the world origin, so the angular momentum about the origin,
L_o = L_c + (c − 0) × m ċ = L_c + (v t) × m v = L_c, equals the spin's at all
times: that is what MuJoCo's reading (about the world site ``origin``) gives.

Signs: the world components of L_c are conserved, L_c = |L| ẑ exactly at the
shipped parameters (the initial Euler state below is solved for that), so
p_φ = |L| > 0; the flip shows as sign changes of ê₂·ẑ = sin θ cos ψ.

Flip period (Landau & Lifshitz, Mechanics §37; Euler's equations solved by
Jacobi elliptic functions): with E the kinetic energy of rotation and
L² > 2EI₂,

    k² = (I₂ − I₁)(2EI₃ − L²) / ((I₃ − I₂)(L² − 2EI₁)),
    T  = 4 K(k) √(I₁I₂I₃ / ((I₃ − I₂)(L² − 2EI₁)))

is the period of ω (ω₂ ∝ sn has period 4K in τ = t √((I₃−I₂)(L²−2EI₁)/(I₁I₂I₃))),
so ê₂ turns over every T/2; for L² < 2EI₂, exchange I₁ ↔ I₃ in both formulas.
:func:`flip_period` gives it (scipy's ``ellipk`` takes the parameter m = k²).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from analytic.systems import Motion, Parameters, Scales

if TYPE_CHECKING:
    from analytic.lagrangian import LagrangianSystem

__all__ = ["BODY", "COORDINATES", "MOTION", "ORIGIN_SITE", "PARAMETERS", "build", "euler_rate_matrix",
           "params_from_model", "scales"]

PARAMETERS = "m I1 I2 I3 d"

BODY = "body"
ORIGIN_SITE = "origin"
TIPS = ("tip1", "tip2", "tip3")  # sites at d ê₁, d ê₂, d ê₃ (body frame)
COORDINATES = ("x", "y", "z", "phi", "theta", "psi")

SHIPPED_INERTIA = (0.02, 0.03, 0.04)    # kg m², the principal moments of mjcf/torque_free_body.xml
OMEGA_BODY = (0.3, 10.0, 1.0)           # rad/s, ω in body axes at t = 0: mostly about ê₂ (the intermediate one)
COM_VELOCITY = (0.3, -0.2, 0.1)         # m/s, the centre of mass's (uniform) velocity
SPIN = 10.0                             # rad/s, the angular-rate scale of :func:`scales`


def euler_rate_matrix(theta, psi) -> np.ndarray:
    """A(θ, ψ) with ω_b = A (φ̇, θ̇, ψ̇) for R = R_z(φ) R_x(θ) R_z(ψ) (numpy; accepts complex angles).

    Typed by hand for the numeric side (initial state, MuJoCo binding); pinned against the
    sympy-derived :func:`analytic.rigid.body_angular_velocity` in tests/test_torque_free_body.py.
    """
    st, ct, sp_, cp = np.sin(theta), np.cos(theta), np.sin(psi), np.cos(psi)
    zero, one = 0 * theta, 0 * theta + 1
    return np.array([[st * sp_, cp, zero], [st * cp, -sp_, zero], [ct, zero, one]])


def euler_state(inertia: Sequence[float], omega_body: Sequence[float]) -> tuple[tuple[float, float, float],
                                                                                tuple[float, float, float]]:
    """((φ, θ, ψ), (φ̇, θ̇, ψ̇)) of the body turning at ``omega_body`` (body axes) with its angular
    momentum L = I ω_b along world +z: Rᵀẑ = L_b/|L| gives cos θ = L₃/|L|, ψ = atan2(L₁, L₂), φ = 0,
    and the rates solve A(θ, ψ) (φ̇, θ̇, ψ̇) = ω_b."""
    omega = np.asarray(omega_body, dtype=float)
    momentum = np.asarray(inertia, dtype=float) * omega
    size = float(np.linalg.norm(momentum))
    theta = math.acos(momentum[2] / size)
    psi = math.atan2(momentum[0], momentum[1])
    rates = np.linalg.solve(euler_rate_matrix(theta, psi), omega)
    return (0.0, theta, psi), (float(rates[0]), float(rates[1]), float(rates[2]))


def flip_period(inertia: Sequence[float], omega_body: Sequence[float]) -> float:
    """The period T of ω(t) (Landau–Lifshitz §37): ê₂ turns over every T/2. Needs I₁ < I₂ < I₃ and an
    orbit off the separatrix (L² ≠ 2EI₂)."""
    from scipy.special import ellipk  # lazy: scipy.special, only for this closed form

    i1, i2, i3 = (float(v) for v in inertia)
    if not i1 < i2 < i3:
        raise ValueError(f"flip_period needs I1 < I2 < I3, got {inertia}")
    omega = np.asarray(omega_body, dtype=float)
    momentum = np.array([i1, i2, i3]) * omega
    l2 = float(momentum @ momentum)
    twice_e = float(np.array([i1, i2, i3]) @ omega**2)
    if l2 < twice_e * i2:  # the orbit circles ê₁: the same formulas with I₁ ↔ I₃
        i1, i3 = i3, i1
    k2 = (i2 - i1) * (twice_e * i3 - l2) / ((i3 - i2) * (l2 - twice_e * i1))
    return float(4 * ellipk(k2) * math.sqrt(i1 * i2 * i3 / ((i3 - i2) * (l2 - twice_e * i1))))


def max_cos2_theta(inertia: Sequence[float], omega_body: Sequence[float]) -> float:
    """max over the orbit of cos²θ = L₃²/L², the closed form of the module docstring (reached where
    L₂ = 0, which every orbit crosses); < 1 means the ZXZ singularity sin θ = 0 is never reached."""
    i1, _, i3 = (float(v) for v in inertia)
    omega = np.asarray(omega_body, dtype=float)
    momentum = np.asarray(inertia, dtype=float) * omega
    l2 = float(momentum @ momentum)
    twice_e = float(np.asarray(inertia, dtype=float) @ omega**2)
    return float((l2 / i1 - twice_e) / (l2 * (1 / i1 - 1 / i3)))


_ANGLES, _RATES = euler_state(SHIPPED_INERTIA, OMEGA_BODY)

MOTION = Motion(
    description="torque-free asymmetric body on a free joint, spun near its intermediate axis: it flips "
                "(Dzhanibekov); L (world), energy and linear momentum conserved",
    q0={"x": 0.0, "y": 0.0, "z": 0.0, "phi": _ANGLES[0], "theta": _ANGLES[1], "psi": _ANGLES[2]},
    qd0={"x": COM_VELOCITY[0], "y": COM_VELOCITY[1], "z": COM_VELOCITY[2],
         "phi": _RATES[0], "theta": _RATES[1], "psi": _RATES[2]},
    horizon=3.0,  # the ω period is 3.63 s: ê₂ turns over at t ≈ 0.97 s and 2.78 s
)


def build(p: Parameters) -> LagrangianSystem:
    import sympy as sp  # lazy: sympy, only to derive

    from analytic.lagrangian import LagrangianSystem, coordinates  # lazy: loads sympy
    from analytic.rigid import RigidBody, euler_zxz  # lazy: loads sympy

    q, qd = coordinates(" ".join(COORDINATES))
    x, y, z, phi, theta, psi = q
    body = RigidBody(mass=p.m, inertia=sp.diag(p.I1, p.I2, p.I3), com=sp.Matrix([x, y, z]),
                     rotation=euler_zxz(phi, theta, psi))
    axes = ((p.d, 0, 0), (0, p.d, 0), (0, 0, p.d))
    return LagrangianSystem(
        name="torque_free_body",
        q=q,
        qd=qd,
        kinetic=sp.simplify(body.kinetic(q, qd)),
        potential=sp.Integer(0),
        params=(p.m, p.I1, p.I2, p.I3, p.d),
        points={BODY: (x, y, z), **{tip: body.point(axis) for tip, axis in zip(TIPS, axes, strict=True)}},
        bodies={BODY: body},
    )


def params_from_model(model) -> dict[str, float]:
    """m and I₁, I₂, I₃ from body ``body`` (its principal moments), d from the site ``tip1``.

    Raises ValueError unless the model is what the coordinates assume: no gravity, the body's
    inertial frame is its body frame (centre of mass at the body origin, principal axes along the
    body axes, moments increasing), and the tips sit at distance d along ê₁, ê₂, ê₃.
    """
    bid = model.body(BODY).id
    gravity = np.asarray(model.opt.gravity, dtype=float)
    if np.any(gravity != 0):
        raise ValueError(f"gravity must be 0 for the torque-free body, got {gravity.tolist()}")
    if np.max(np.abs(model.body_ipos[bid])) > 1e-12:
        raise ValueError(f"body {BODY!r}: the centre of mass must be at the body origin, got "
                         f"{np.asarray(model.body_ipos[bid]).tolist()}")
    if np.max(np.abs(np.abs(model.body_iquat[bid]) - [1, 0, 0, 0])) > 1e-12:
        raise ValueError(f"body {BODY!r}: the principal axes must be the body axes (diaginertia), got "
                         f"iquat {np.asarray(model.body_iquat[bid]).tolist()}")
    inertia = [float(v) for v in model.body_inertia[bid]]
    if not inertia[0] < inertia[1] < inertia[2]:
        raise ValueError(f"body {BODY!r}: the principal moments must increase, I1 < I2 < I3, got {inertia}")
    d = float(model.site_pos[model.site(TIPS[0]).id][0])
    for k, tip in enumerate(TIPS):
        expected = np.zeros(3)
        expected[k] = d
        if (int(model.site_bodyid[model.site(tip).id]) != bid
                or np.max(np.abs(model.site_pos[model.site(tip).id] - expected)) > 1e-12):
            raise ValueError(f"site {tip!r} must be on body {BODY!r} at {expected.tolist()} (d along axis {k + 1})")
    return {"m": float(model.body_mass[bid]), "I1": inertia[0], "I2": inertia[1], "I3": inertia[2], "d": d}


def scales(params: dict[str, float]) -> Scales:
    """Length d (the tips' distance), rate Ω = SPIN: force m d Ω², energy ½ I₂ Ω², momentum I₂ Ω
    (the rotation's; the linear momentum m|v| is measured on it too, a per-length figure)."""
    d, i2 = params["d"], params["I2"]
    return Scales(length=d, force=params["m"] * d * SPIN**2, energy=i2 * SPIN**2 / 2, momentum=i2 * SPIN)

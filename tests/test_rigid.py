"""analytic/rigid.py against hand-typed closed forms (independent checks, not the code's own output)."""

from __future__ import annotations

import pytest
import sympy as sp

from analytic.lagrangian import coordinates
from analytic.rigid import RigidBody, axis_rotation, body_angular_velocity, euler_zxz, world_angular_velocity


def test_euler_zxz_body_angular_velocity_is_the_textbook_one():
    """Goldstein (4.87): ω_b = (φ̇ sinθ sinψ + θ̇ cosψ, φ̇ sinθ cosψ − θ̇ sinψ, φ̇ cosθ + ψ̇)."""
    (phi, theta, psi), (pd, td, sd) = coordinates("phi theta psi")
    omega = body_angular_velocity(euler_zxz(phi, theta, psi), (phi, theta, psi), (pd, td, sd))
    expected = sp.Matrix([pd * sp.sin(theta) * sp.sin(psi) + td * sp.cos(psi),
                          pd * sp.sin(theta) * sp.cos(psi) - td * sp.sin(psi),
                          pd * sp.cos(theta) + sd])
    assert (omega - expected).applyfunc(sp.simplify) == sp.zeros(3, 1)


def test_world_angular_velocity_is_the_rotated_body_one():
    (phi, theta, psi), qd = coordinates("phi theta psi")
    rot = euler_zxz(phi, theta, psi)
    q = (phi, theta, psi)
    diff = world_angular_velocity(rot, q, qd) - rot * body_angular_velocity(rot, q, qd)
    assert diff.applyfunc(sp.simplify) == sp.zeros(3, 1)


def test_symmetric_top_kinetic_energy_is_lagranges():
    """I₁ = I₂: T = ½ I₁ (θ̇² + φ̇² sin²θ) + ½ I₃ (ψ̇ + φ̇ cosθ)², centre of mass on the pivot."""
    (phi, theta, psi), (pd, td, sd) = coordinates("phi theta psi")
    i1, i3, m = sp.symbols("I1 I3 m", positive=True)
    body = RigidBody(mass=m, inertia=sp.diag(i1, i1, i3), com=sp.zeros(3, 1), rotation=euler_zxz(phi, theta, psi))
    expected = i1 * (td**2 + pd**2 * sp.sin(theta) ** 2) / 2 + i3 * (sd + pd * sp.cos(theta)) ** 2 / 2
    assert sp.simplify(body.kinetic((phi, theta, psi), (pd, td, sd)) - expected) == 0


def test_parallel_axis_and_product_of_inertia_in_a_hinged_link():
    """A link turning by θ about world y, centre of mass at distance d along the body −z:
    T = ½ (I_yy + m d²) θ̇² — the products of inertia I_xy, I_yz do not enter a rotation about y."""
    (theta,), (td,) = coordinates("theta")
    m, d, ixx, iyy, izz, ixy, iyz = sp.symbols("m d Ixx Iyy Izz Ixy Iyz", positive=True)
    rot = axis_rotation("y", theta)
    inertia = sp.Matrix([[ixx, ixy, 0], [ixy, iyy, iyz], [0, iyz, izz]])
    body = RigidBody(mass=m, inertia=inertia, com=rot * sp.Matrix([0, 0, -d]), rotation=rot)
    assert sp.simplify(body.kinetic((theta,), (td,)) - (iyy + m * d**2) * td**2 / 2) == 0
    assert sp.simplify(sp.Matrix(body.point((0, 0, -1))) - rot * sp.Matrix([0, 0, -d - 1])) == sp.zeros(3, 1)


@pytest.mark.parametrize("bad", [dict(inertia=sp.Matrix([[1, 2, 0], [0, 1, 0], [0, 0, 1]])),
                                 dict(com=sp.Matrix([0, 0])),
                                 dict(rotation=sp.eye(2))])
def test_bad_rigid_bodies_are_refused(bad):
    args = dict(mass=1, inertia=sp.eye(3), com=sp.zeros(3, 1), rotation=sp.eye(3)) | bad
    with pytest.raises(ValueError):
        RigidBody(**args)


def test_unknown_axis_is_refused():
    with pytest.raises(ValueError, match="axis must be"):
        axis_rotation("w", sp.Symbol("a"))

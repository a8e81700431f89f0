"""Rigid bodies in a Lagrangian: kinetic energy from an inertia tensor and the body's angular velocity.

A rigid body is given by its mass m, its inertia tensor I_c about its centre of
mass in its own (body) frame, the world position of the centre of mass c(q)
and its orientation R(q) (body → world: a vector v_b fixed in the body points
along R v_b in the world). Then, with ω_b the angular velocity in the body
frame (König's theorem),

    T = ½ m ċ·ċ + ½ ω_bᵀ I_c ω_b,        [ω_b]× = Rᵀ Ṙ,   Ṙ = Σ_k (∂R/∂q_k) q̇_k

and the world angular velocity is ω = R ω_b ([ω]× = Ṙ Rᵀ). Nothing here is
specific to a system: a system builds R(q) (for instance :func:`euler_zxz`,
or a fixed axis :func:`axis_rotation`) and c(q), and adds :meth:`RigidBody.kinetic`
to its T. A point fixed in the body at offset r_b from the centre of mass is at
c + R r_b (:meth:`RigidBody.point`), the observable a system names to compare
orientations through world positions, never through angles.

The parallel-axis term needs no special case: c(q) carries the offset of the
centre of mass from a joint, and ½ m ċ·ċ is its contribution.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import sympy as sp

__all__ = ["RigidBody", "axis_rotation", "body_angular_velocity", "euler_zxz", "point_mass", "world_angular_velocity"]


def axis_rotation(axis: str, angle: sp.Expr) -> sp.Matrix:
    """The rotation by ``angle`` about the world axis ``"x"``, ``"y"`` or ``"z"`` (right-handed)."""
    c, s = sp.cos(angle), sp.sin(angle)
    matrices = {
        "x": sp.Matrix([[1, 0, 0], [0, c, -s], [0, s, c]]),
        "y": sp.Matrix([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
        "z": sp.Matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]]),
    }
    if axis not in matrices:
        raise ValueError(f"axis must be 'x', 'y' or 'z', got {axis!r}")
    return matrices[axis]


def euler_zxz(phi: sp.Expr, theta: sp.Expr, psi: sp.Expr) -> sp.Matrix:
    """R = R_z(φ) R_x(θ) R_z(ψ): precession φ about world z, nutation θ about the line of nodes,
    spin ψ about the body's own z (the classical Euler angles of a top; singular at sin θ = 0)."""
    return axis_rotation("z", phi) * axis_rotation("x", theta) * axis_rotation("z", psi)


def _vee(skew: sp.Matrix) -> sp.Matrix:
    """The vector w of a skew-symmetric matrix [w]× (read from its lower triangle)."""
    return sp.Matrix([skew[2, 1], skew[0, 2], skew[1, 0]])


def _rate(matrix: sp.Matrix, q: Sequence[sp.Symbol], qd: Sequence[sp.Symbol]) -> sp.Matrix:
    """d/dt of ``matrix``(q) along q̇: Σ_k ∂/∂q_k · q̇_k."""
    return sum((matrix.diff(qk) * vk for qk, vk in zip(q, qd, strict=True)), sp.zeros(*matrix.shape))


def _simplified(expr: sp.Expr) -> sp.Expr:
    return sp.trigsimp(sp.expand(expr))


def body_angular_velocity(rotation: sp.Matrix, q: Sequence[sp.Symbol], qd: Sequence[sp.Symbol]) -> sp.Matrix:
    """ω_b with [ω_b]× = Rᵀ Ṙ: the angular velocity in the body frame, trigonometrically simplified
    (expanded first: trigsimp then finds the sin² + cos² pairs sooner, with the same result)."""
    return _vee(rotation.T * _rate(rotation, q, qd)).applyfunc(_simplified)


def world_angular_velocity(rotation: sp.Matrix, q: Sequence[sp.Symbol], qd: Sequence[sp.Symbol]) -> sp.Matrix:
    """ω with [ω]× = Ṙ Rᵀ: the angular velocity in the world frame, trigonometrically simplified."""
    return _vee(_rate(rotation, q, qd) * rotation.T).applyfunc(_simplified)


@dataclass(frozen=True)
class RigidBody:
    """One rigid body: mass, inertia about its centre of mass in the body frame, where its centre of
    mass is and how it is turned, all as expressions in the system's coordinates.

    ``inertia`` is a symmetric 3×3 matrix (a full tensor: off-diagonal products of inertia are
    allowed); ``com`` the world position of the centre of mass; ``rotation`` R(q), body → world.
    """

    mass: sp.Expr
    inertia: sp.Matrix
    com: sp.Matrix
    rotation: sp.Matrix

    def __post_init__(self) -> None:
        inertia, com, rotation = sp.Matrix(self.inertia), sp.Matrix(self.com), sp.Matrix(self.rotation)
        if inertia.shape != (3, 3) or (inertia - inertia.T) != sp.zeros(3, 3):
            raise ValueError(f"inertia must be a symmetric 3x3 matrix, got {inertia}")
        if com.shape != (3, 1):
            raise ValueError(f"com must be a 3-vector, got shape {com.shape}")
        if rotation.shape != (3, 3):
            raise ValueError(f"rotation must be a 3x3 matrix, got shape {rotation.shape}")
        object.__setattr__(self, "inertia", inertia)
        object.__setattr__(self, "com", com)
        object.__setattr__(self, "rotation", rotation)

    def kinetic(self, q: Sequence[sp.Symbol], qd: Sequence[sp.Symbol]) -> sp.Expr:
        """T = ½ m ċ·ċ + ½ ω_bᵀ I_c ω_b (König: translation of the centre of mass plus rotation about it)."""
        velocity = self.com.jacobian(list(q)) * sp.Matrix(qd)
        omega = body_angular_velocity(self.rotation, q, qd)
        return (self.mass * velocity.dot(velocity) + (omega.T * self.inertia * omega)[0, 0]) / 2

    def angular_momentum(self, q: Sequence[sp.Symbol], qd: Sequence[sp.Symbol]) -> sp.Matrix:
        """L_c = R I_c ω_b: the world angular momentum about the centre of mass (zero for a point mass)."""
        if self.inertia == sp.zeros(3, 3):
            return sp.zeros(3, 1)
        return self.rotation * self.inertia * body_angular_velocity(self.rotation, q, qd)

    def point(self, offset: Sequence[sp.Expr]) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
        """World position c + R r_b of the body point at ``offset`` r_b from the centre of mass
        (body frame)."""
        return tuple(self.com + self.rotation * sp.Matrix(offset))


def point_mass(mass: sp.Expr, position: Sequence[sp.Expr]) -> RigidBody:
    """A point mass at ``position`` as a :class:`RigidBody` with no inertia (its orientation, the
    identity, never enters: it has no angular momentum about its centre of mass)."""
    return RigidBody(mass=sp.sympify(mass), inertia=sp.zeros(3, 3), com=sp.Matrix(list(position)),
                     rotation=sp.eye(3))

"""The symmetric_top case: the heavy symmetric top on one ball joint (quaternion state).

The analytic top (analytic/systems/symmetric_top.py) is turned by the Euler
angles R(φ, θ, ψ) = R_z(φ) R_x(θ) R_z(ψ); the MJCF body ``top`` has its frame
at the pivot, unturned, so the ball joint's orientation is R itself. What this
model needs beyond the generic wiring:

- the binding: qpos ← the quaternion of R (MuJoCo order w, x, y, z; the
  product of the three axis quaternions, as R is of the three rotations);
  qvel ← ω_b, the angular velocity in the body's LOCAL frame (a ball joint's
  qvel, as for mjcf/spherical_pendulum_ball.py), which is B(q) q̇ with

      ω_b = ( φ̇ sinθ sinψ + θ̇ cosψ,   φ̇ sinθ cosψ − θ̇ sinψ,   φ̇ cosθ + ψ̇ )

  (Goldstein (4.87); :func:`velocity_map`, pinned against the sympy
  ``analytic.rigid.body_angular_velocity`` and against ``mj_integratePos`` in
  tests/test_symmetric_top.py). B is singular where sin θ = 0, which the
  motion never reaches.
- the conserved momenta from MuJoCo's own state, never through Euler angles:
  p_φ = ẑ · L and p_ψ = e₃ · L, with L the body's angular momentum about the
  pivot and e₃ its symmetry axis as MuJoCo turns it (the body's z, ``xmat``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from harness.cases import Wiring
from harness.engine.bindings import QuaternionJointBinding
from harness.engine.readings.momentum import axial_angular_momentum

__all__ = ["WIRING", "EulerBallBinding", "orientation"]

COORDINATES = ("phi", "theta", "psi")
AXES = {"phi": np.array([0.0, 0.0, 1.0]), "theta": np.array([1.0, 0.0, 0.0]), "psi": np.array([0.0, 0.0, 1.0])}


def orientation(phi: float, theta: float, psi: float) -> np.ndarray:
    """Quaternion (w, x, y, z) of R_z(φ) R_x(θ) R_z(ψ)."""
    out = np.array([1.0, 0.0, 0.0, 0.0])
    for name, angle in zip(COORDINATES, (phi, theta, psi), strict=True):
        turn = np.zeros(4)
        mujoco.mju_axisAngle2Quat(turn, AXES[name], angle)
        product = np.zeros(4)
        mujoco.mju_mulQuat(product, out, turn)
        out = product
    return out


def body_rates(phi, theta, psi) -> np.ndarray:
    """B₀(φ, θ, ψ), (3, 3): ω_b = B₀ (φ̇, θ̇, ψ̇) for the Euler angles in the order (φ, θ, ψ). numpy
    operations only, so a complex angle goes through (complex-step derivatives)."""
    st, ct, sp_, cp = np.sin(theta), np.cos(theta), np.sin(psi), np.cos(psi)
    zero, one = 0.0 * st, 1.0 + 0.0 * st
    return np.array([[st * sp_, cp, zero],
                     [st * cp, -sp_, zero],
                     [ct, zero, one]])


@dataclass(frozen=True)
class EulerBallBinding(QuaternionJointBinding):
    """Analytic (phi, theta, psi), in the order ``coordinates``, ↔ the ball joint ``joint``."""

    COORDINATES = COORDINATES
    JOINT_TYPE = mujoco.mjtJoint.mjJNT_BALL

    joint: str = "ball"

    def _angles(self, values: Sequence | np.ndarray) -> tuple:
        named = self._named(values)
        return tuple(named[c] for c in COORDINATES)

    def _order(self) -> list[int]:
        """Column k of B(q) (analytic coordinate k) is column _order()[k] of B₀."""
        return [COORDINATES.index(c) for c in self.coordinates]

    def set_state(self, model: mujoco.MjModel, data: mujoco.MjData,
                  q: Sequence[float] | np.ndarray, qd: Sequence[float] | np.ndarray) -> None:
        """qpos ← quaternion of R(φ, θ, ψ); qvel ← ω_b = B(q) q̇ (the local angular velocity)."""
        jnt = model.joint(self.joint)
        data.qpos[jnt.qposadr[0]:jnt.qposadr[0] + 4] = orientation(*(float(v) for v in self._angles(q)))
        rates = body_rates(*(float(v) for v in self._angles(q))) @ np.array(self._angles(qd), dtype=float)
        data.qvel[jnt.dofadr[0]:jnt.dofadr[0] + 3] = rates

    def velocity_map(self, model: mujoco.MjModel, q: Sequence | np.ndarray) -> np.ndarray:
        """B(q), shape (nv, 3): qvel = B(q) q̇; accepts a complex q (numpy operations only)."""
        jnt = model.joint(self.joint)
        block = body_rates(*self._angles(q))[:, self._order()]
        out = np.zeros((model.nv, 3), dtype=block.dtype)
        out[jnt.dofadr[0]:jnt.dofadr[0] + 3] = block
        return out


WIRING = Wiring(
    description="heavy symmetric top on a ball joint (quaternion state): spinning, precessing and nutating; "
                "p_phi and p_psi conserved",
    binding=EulerBallBinding,
    invariants={"p_phi": axial_angular_momentum(body="top", site="pivot"),
                "p_psi": axial_angular_momentum(body="top", site="pivot", frame="top")},
)

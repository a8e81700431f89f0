"""The spherical_pendulum_ball case: the spherical pendulum on one ball joint (quaternion state).

Its system is ``spherical_pendulum`` (the same orbit as the two-hinge model);
what this model needs beyond the generic wiring is the binding below, a ball
joint standing in for the spherical angles (θ, φ), and the axial angular
momentum p_φ read from MuJoCo's own state.

The analytic convention (analytic/systems/spherical_pendulum.py) turns the bob
first by φ about +z, then by θ about the turned −y axis::

    R(θ, φ) = R_z(φ) R_−y(θ),        rod direction R·(0, 0, −1) = (sinθ cosφ, sinθ sinφ, −cosθ)

which is exactly the two-hinge model's body frame. The ball joint's qpos is the
quaternion of R (MuJoCo order w, x, y, z) and its qvel is the angular velocity
in the child body's LOCAL frame, ω_local = Rᵀ ω_world with
ω_world = φ̇ ẑ + θ̇ R_z(φ)(−ŷ) (pinned numerically against mj_integratePos and
against the two-hinge model in tests/test_spherical_pendulum.py).

No constant matrix relates qvel to (θ̇, φ̇), so :meth:`dof_matrix` is None;
:meth:`velocity_map` gives the state-dependent B(θ, φ) with qvel = B (θ̇, φ̇),
through which the instantaneous layer compares MuJoCo's mass matrix, forcing and
accelerations with the analytic ones (nv = 3 > n = 2: the twist about the rod is
a degree of freedom the point mass does not have; see
:func:`harness.families.sampled.pull_back`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from harness.cases import Wiring
from harness.engine.bindings import QuaternionJointBinding
from harness.engine.readings.momentum import axial_angular_momentum

__all__ = ["WIRING", "BallBinding"]

AZIMUTH_AXIS = np.array([0.0, 0.0, 1.0])   # φ, about world +z
POLAR_AXIS = np.array([0.0, -1.0, 0.0])    # θ, about −y of the frame turned by φ
COORDINATES = ("theta", "phi")


def _axis_quat(axis: np.ndarray, angle: float) -> np.ndarray:
    quat = np.zeros(4)
    mujoco.mju_axisAngle2Quat(quat, axis, angle)
    return quat


def _rotate(vec: np.ndarray, quat: np.ndarray) -> np.ndarray:
    out = np.zeros(3)
    mujoco.mju_rotVecQuat(out, vec, quat)
    return out


def orientation(theta: float, phi: float) -> np.ndarray:
    """Quaternion (w, x, y, z) of R_z(φ) R_−y(θ)."""
    out = np.zeros(4)
    mujoco.mju_mulQuat(out, _axis_quat(AZIMUTH_AXIS, phi), _axis_quat(POLAR_AXIS, theta))
    return out


def world_angular_velocity(theta_d: float, phi: float, phi_d: float) -> np.ndarray:
    """ω_world = φ̇ ẑ + θ̇ (R_z(φ) applied to the polar axis)."""
    return phi_d * AZIMUTH_AXIS + theta_d * _rotate(POLAR_AXIS, _axis_quat(AZIMUTH_AXIS, phi))


@dataclass(frozen=True)
class BallBinding(QuaternionJointBinding):
    """Analytic (theta, phi) in the order ``coordinates`` ↔ the ball joint ``joint``."""

    COORDINATES = COORDINATES
    JOINT_TYPE = mujoco.mjtJoint.mjJNT_BALL

    joint: str = "ball"

    def _split(self, values: Sequence[float] | np.ndarray) -> tuple[float, float]:
        named = self._named(values)
        return float(named["theta"]), float(named["phi"])

    def set_state(self, model: mujoco.MjModel, data: mujoco.MjData,
                  q: Sequence[float] | np.ndarray, qd: Sequence[float] | np.ndarray) -> None:
        """qpos ← quaternion of R(θ, φ); qvel ← Rᵀ ω_world (local angular velocity)."""
        theta, phi = self._split(q)
        theta_d, phi_d = self._split(qd)
        quat = orientation(theta, phi)
        inverse = np.zeros(4)
        mujoco.mju_negQuat(inverse, quat)
        jnt = model.joint(self.joint)
        data.qpos[jnt.qposadr[0]:jnt.qposadr[0] + 4] = quat
        data.qvel[jnt.dofadr[0]:jnt.dofadr[0] + 3] = _rotate(world_angular_velocity(theta_d, phi, phi_d), inverse)

    def read_state(self, model: mujoco.MjModel, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """(q, q̇) in ``coordinates`` order from the rod direction and its rate.

        Inverse of :meth:`set_state` up to a twist about the rod, which does not
        move the bob. Valid for 0 < θ < π (φ and φ̇ are undefined on the axis).
        """
        jnt = model.joint(self.joint)
        quat = np.array(data.qpos[jnt.qposadr[0]:jnt.qposadr[0] + 4])
        quat /= np.linalg.norm(quat)
        rod = _rotate(np.array([0.0, 0.0, -1.0]), quat)
        rod_rate = np.cross(_rotate(np.array(data.qvel[jnt.dofadr[0]:jnt.dofadr[0] + 3]), quat), rod)
        theta = float(np.arccos(np.clip(-rod[2], -1.0, 1.0)))
        phi = float(np.arctan2(rod[1], rod[0]))
        e_theta = np.array([np.cos(theta) * np.cos(phi), np.cos(theta) * np.sin(phi), np.sin(theta)])
        e_phi = np.array([-np.sin(phi), np.cos(phi), 0.0])
        rates = {"theta": float(rod_rate @ e_theta), "phi": float(rod_rate @ e_phi) / np.sin(theta)}
        angles = {"theta": theta, "phi": phi}
        return (np.array([angles[c] for c in self.coordinates]),
                np.array([rates[c] for c in self.coordinates]))

    def velocity_map(self, model: mujoco.MjModel, q: Sequence[float] | np.ndarray) -> np.ndarray:
        """B(θ, φ) with qvel = B (θ̇, φ̇) in ``coordinates`` order, shape (nv, 2): the ball's local
        angular velocity ω_local = R_−y(θ)ᵀ (φ̇ ẑ + θ̇ (−ŷ)) (R_z(φ) leaves ẑ fixed and, turned back,
        takes the turned −y axis to −y; R_−y(θ) leaves −y fixed), so

            column θ̇: (0, −1, 0),        column φ̇: R_−y(θ)ᵀ ẑ = (sin θ, 0, cos θ)

        in the rows of the ball's dofs. Plain numpy, so a complex q gives Ḃ q̇ by complex step
        (pinned against :meth:`set_state` and a finite difference in tests/test_spherical_pendulum.py)."""
        theta = self._named(q)["theta"]
        columns = {"theta": np.array([0.0, -1.0, 0.0]) + 0 * theta,
                   "phi": np.array([np.sin(theta), 0 * theta, np.cos(theta)])}
        out = np.zeros((model.nv, 2), dtype=np.result_type(theta, float))
        adr = model.joint(self.joint).dofadr[0]
        for k, name in enumerate(self.coordinates):
            out[adr:adr + 3, k] = columns[name]
        return out


WIRING = Wiring(
    system="spherical_pendulum",
    description="spherical pendulum on one ball joint (quaternion state); same orbit as spherical_pendulum",
    binding=BallBinding,
    invariants={"p_phi": axial_angular_momentum(body="bob", site="pivot")},
)

"""The torque_free_body case: a free joint standing in for (x, y, z, φ, θ, ψ), and the conserved
momenta read from MuJoCo's own state.

MuJoCo's free joint (pinned against mj_integratePos in tests/test_torque_free_body.py):

    qpos = (world position of the body frame, quaternion w x y z of R body → world)
    qvel = (linear velocity of the body origin in the WORLD frame, angular velocity in the LOCAL frame)

The model's body frame is the inertial frame (com at the origin, principal axes along x, y, z), so
qpos[:3] is the centre of mass c = (x, y, z), the quaternion is that of R_z(φ) R_x(θ) R_z(ψ), and

    qvel = B(θ, ψ) q̇,   B = [[1₃, 0], [0, A(θ, ψ)]],   ω_b = A(θ, ψ) (φ̇, θ̇, ψ̇)

(:func:`analytic.systems.torque_free_body.euler_rate_matrix`), a state-dependent map given to the
instant layer as :meth:`FreeBinding.velocity_map`; no constant dof matrix exists.

Readings: the three world components of the angular momentum about the world site ``origin``
(the com starts there and moves along its velocity, so this is the spin's, L_c; see the system's
docstring), of which the z one is the reference's p_φ = |L|, and the linear momentum p_x, p_y,
p_z (the reference's cyclic momenta of x, y, z), all from MuJoCo's cinert·cvel.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from analytic.systems.torque_free_body import BODY, COORDINATES, ORIGIN_SITE, euler_rate_matrix
from harness.cases import Wiring
from harness.engine.bindings import QuaternionJointBinding
from harness.engine.readings import Reading
from harness.engine.readings.momentum import axial_angular_momentum, subtree

__all__ = ["WIRING", "FreeBinding", "euler_angles", "orientation"]


def _axis_quat(axis: int, angle: float) -> np.ndarray:
    quat = np.zeros(4)
    unit = np.zeros(3)
    unit[axis] = 1.0
    mujoco.mju_axisAngle2Quat(quat, unit, angle)
    return quat


def orientation(phi: float, theta: float, psi: float) -> np.ndarray:
    """Quaternion (w, x, y, z) of R_z(φ) R_x(θ) R_z(ψ)."""
    first, out = np.zeros(4), np.zeros(4)
    mujoco.mju_mulQuat(first, _axis_quat(2, phi), _axis_quat(0, theta))
    mujoco.mju_mulQuat(out, first, _axis_quat(2, psi))
    return out


def euler_angles(quat: np.ndarray) -> tuple[float, float, float]:
    """(φ, θ, ψ) of the rotation ``quat``, 0 < θ < π: R₃₃ = cos θ, (R₁₃, R₂₃) = sin θ (sin φ, −cos φ),
    (R₃₁, R₃₂) = sin θ (sin ψ, cos ψ)."""
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, np.asarray(quat, dtype=float) / np.linalg.norm(quat))
    r = mat.reshape(3, 3)
    return (float(np.arctan2(r[0, 2], -r[1, 2])), float(np.arccos(np.clip(r[2, 2], -1.0, 1.0))),
            float(np.arctan2(r[2, 0], r[2, 1])))


@dataclass(frozen=True)
class FreeBinding(QuaternionJointBinding):
    """Analytic (x, y, z, φ, θ, ψ), in the order ``coordinates``, ↔ the free joint ``joint``."""

    COORDINATES = COORDINATES
    JOINT_TYPE = mujoco.mjtJoint.mjJNT_FREE

    joint: str = "free"

    def set_state(self, model: mujoco.MjModel, data: mujoco.MjData,
                  q: Sequence[float] | np.ndarray, qd: Sequence[float] | np.ndarray) -> None:
        """qpos ← (c, quaternion of R(φ, θ, ψ)); qvel ← (ċ, A(θ, ψ)(φ̇, θ̇, ψ̇))."""
        pos = self._named([float(v) for v in q])
        rates = np.asarray(list(self._named(qd).values()), dtype=float)  # length checked; in coordinates order
        jnt = model.joint(self.joint)
        qpos, dof = int(jnt.qposadr[0]), int(jnt.dofadr[0])
        data.qpos[qpos:qpos + 3] = [pos["x"], pos["y"], pos["z"]]
        data.qpos[qpos + 3:qpos + 7] = orientation(pos["phi"], pos["theta"], pos["psi"])
        data.qvel[dof:dof + 6] = self.velocity_map(model, q)[dof:dof + 6] @ rates

    def read_state(self, model: mujoco.MjModel, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """(q, q̇) in ``coordinates`` order: the inverse of :meth:`set_state` for 0 < θ < π."""
        jnt = model.joint(self.joint)
        qpos, dof = int(jnt.qposadr[0]), int(jnt.dofadr[0])
        phi, theta, psi = euler_angles(np.array(data.qpos[qpos + 3:qpos + 7]))
        rates = np.linalg.solve(euler_rate_matrix(theta, psi), np.array(data.qvel[dof + 3:dof + 6]))
        values = dict(zip(("x", "y", "z"), data.qpos[qpos:qpos + 3], strict=True)) | {
            "phi": phi, "theta": theta, "psi": psi}
        speeds = dict(zip(("x", "y", "z"), data.qvel[dof:dof + 3], strict=True)) | dict(
            zip(("phi", "theta", "psi"), rates, strict=True))
        return (np.array([float(values[c]) for c in self.coordinates]),
                np.array([float(speeds[c]) for c in self.coordinates]))

    def velocity_map(self, model: mujoco.MjModel, q: Sequence | np.ndarray) -> np.ndarray:
        """B(q) with qvel = B q̇, shape (nv, 6) (numpy; a complex q gives a complex B)."""
        named = self._named(list(q))
        angular = euler_rate_matrix(named["theta"], named["psi"])
        dtype = np.result_type(angular.dtype, float)
        out = np.zeros((model.nv, len(self.coordinates)), dtype=dtype)
        dof = int(model.joint(self.joint).dofadr[0])
        for k, name in enumerate(self.coordinates):
            if name in ("x", "y", "z"):
                out[dof + ("x", "y", "z").index(name), k] = 1.0
            else:
                out[dof + 3:dof + 6, k] = angular[:, ("phi", "theta", "psi").index(name)]
        return out


def linear_momentum(*, body: str, axis: int) -> Reading:
    """A reading of the world component ``axis`` (0, 1, 2) of the linear momentum of the subtree
    rooted at ``body`` (kg m/s): Σ_b m_b × the velocity of b's centre of mass, the linear half of
    cinert_b · cvel_b (mju_mulInertVec)."""

    def evaluate(model: mujoco.MjModel, rec: Mapping[str, np.ndarray]) -> np.ndarray:
        total = 0.0
        for b in subtree(model, model.body(body).id):
            i, v = rec["cinert"][:, b].T, rec["cvel"][:, b].T
            # only this reading's component (each is computed apart from the others)
            if axis == 0:
                total = total + (i[8] * v[1] - i[7] * v[2] + i[9] * v[3])
            elif axis == 1:
                total = total + (i[6] * v[2] - i[8] * v[0] + i[9] * v[4])
            else:
                total = total + (i[7] * v[0] - i[6] * v[1] + i[9] * v[5])
        return np.asarray(total, dtype=float)

    return Reading(fields=("cinert", "cvel"), evaluate=evaluate,
                   description=f"world {'xyz'[axis]} component of the linear momentum of subtree {body!r} (kg m/s)")


WIRING = Wiring(
    binding=FreeBinding,
    invariants={
        "p_phi": axial_angular_momentum(body=BODY, site=ORIGIN_SITE, axis=(0.0, 0.0, 1.0)),
        "L_x": axial_angular_momentum(body=BODY, site=ORIGIN_SITE, axis=(1.0, 0.0, 0.0)),
        "L_y": axial_angular_momentum(body=BODY, site=ORIGIN_SITE, axis=(0.0, 1.0, 0.0)),
        **{f"p_{c}": linear_momentum(body=BODY, axis=k) for k, c in enumerate("xyz")},
    },
)

"""How an analytic system's coordinates sit in a MuJoCo model.

The default binding is one hinge or slide joint per analytic coordinate, of
the same name, with qpos equal to the coordinate; generalized forces then map
through the constant dof matrix D (qvel = D q̇, analytic force = Dᵀ f_mujoco).
A model whose coordinates differ (a ball joint) supplies its own binding; where
no constant D exists its ``dof_matrix`` returns None. Such a binding may give the
state-dependent map instead, ``velocity_map(model, q) -> B(q)`` with qvel = B(q) q̇
(:func:`velocity_map`); the instantaneous layer then compares the mass matrix,
forcing, accelerations and constraint forces through B(q) as it does through D.
Without either, the harness compares only observables (point positions,
velocities, accelerations, kinetic energy).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar, Protocol

import mujoco
import numpy as np

from analytic.tree.rotations import exp_map, mat_to_quat, quat_to_mat, right_jacobian
from harness.core.errors import ModelMismatch

__all__ = ["ONE_DOF", "Binding", "JointBinding", "QuaternionJointBinding", "TreeBinding", "velocity_map"]

ONE_DOF = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


class Binding(Protocol):
    """What the harness needs to put an analytic state into a MuJoCo model."""

    def validate(self, model: mujoco.MjModel) -> None:
        """Raise ModelMismatch if ``model`` lacks the joints this binding drives."""

    def set_state(self, model: mujoco.MjModel, data: mujoco.MjData,
                  q: Sequence[float] | np.ndarray, qd: Sequence[float] | np.ndarray) -> None:
        """Write qpos and qvel for the analytic state (q, q̇)."""

    def dof_matrix(self, model: mujoco.MjModel) -> np.ndarray | None:
        """Constant D with qvel = D q̇, shape (nv, n); None where qvel is not a constant
        linear map of q̇ (a ball joint's local angular velocity)."""

    # Optional (a binding of ball or free joints): ``velocity_map(model, q) -> np.ndarray``, the
    # state-dependent B(q) with qvel = B(q) q̇, shape (nv, n), written with numpy operations that also
    # accept a complex q, so that the instant layer gets Ḃ q̇ = Im B(q + i h q̇) / h by complex step,
    # exact to round-off (qacc = B q̈ + Ḃ q̇). A binding with a constant D needs none.


def require_joint(model: mujoco.MjModel, name: str, types: tuple[int, ...], kind: str) -> int:
    """The id of joint ``name``, which must be of one of ``types`` (``kind`` names them in the error:
    "a ball joint"); ModelMismatch listing the model's joints where it has none of that name."""
    jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
    if jid < 0:
        known = [model.joint(i).name for i in range(model.njnt)]
        raise ModelMismatch(f"model has no joint {name!r} (joints: {known})")
    if int(model.jnt_type[jid]) not in types:
        raise ModelMismatch(f"joint {name!r} must be {kind}")
    return jid


@dataclass(frozen=True)
class JointBinding:
    """Analytic coordinate k is the MuJoCo joint ``joints[k]`` (hinge or slide).

    A hinge's angle is counted from the pose the model is written in, where MuJoCo's qpos is the joint's
    ``ref`` (qpos0): qpos = θ + ref, so a hinge ``ref`` moves only the angle's zero, as MuJoCo documents it
    (0 in every shipped model). A slide's qpos is its coordinate: its ``ref`` is a length the systems read
    (the pendulum's l is the slide ``r``'s qpos0)."""

    joints: tuple[str, ...]

    def validate(self, model: mujoco.MjModel) -> None:
        for name in self.joints:
            require_joint(model, name, ONE_DOF, "a hinge or slide")

    def set_state(self, model: mujoco.MjModel, data: mujoco.MjData,
                  q: Sequence[float] | np.ndarray, qd: Sequence[float] | np.ndarray) -> None:
        for name, qk, vk in zip(self.joints, q, qd, strict=True):
            jnt = model.joint(name)
            adr = int(jnt.qposadr[0])
            hinge = int(model.jnt_type[jnt.id]) == int(mujoco.mjtJoint.mjJNT_HINGE)
            data.qpos[adr] = qk + (float(model.qpos0[adr]) if hinge else 0.0)
            data.qvel[jnt.dofadr[0]] = vk

    def dof_matrix(self, model: mujoco.MjModel) -> np.ndarray:
        """D with qvel = D q̇, shape (nv, n)."""
        mat = np.zeros((model.nv, len(self.joints)))
        for k, name in enumerate(self.joints):
            mat[model.joint(name).dofadr[0], k] = 1.0
        return mat


@dataclass(frozen=True)
class QuaternionJointBinding:
    """Analytic coordinates that one ball or free joint ``joint`` stands in for: the subclass's ``COORDINATES``,
    in any order ``coordinates``. Its qvel holds the angular velocity in the body's local frame, not a constant
    linear map of q̇ (no dof matrix): the subclass writes the state and gives ``velocity_map``."""

    COORDINATES: ClassVar[tuple[str, ...]]
    JOINT_TYPE: ClassVar[mujoco.mjtJoint]  # mjJNT_BALL or mjJNT_FREE

    coordinates: tuple[str, ...]
    joint: str

    def __post_init__(self) -> None:
        if sorted(self.coordinates) != sorted(self.COORDINATES):
            raise ValueError(f"{type(self).__name__} binds the coordinates {self.COORDINATES}, got {self.coordinates}")

    def _named(self, values: Sequence | np.ndarray) -> dict:
        """``values`` by coordinate name; ValueError where there is not one per coordinate."""
        if len(values) != len(self.COORDINATES):
            raise ValueError(f"expected {len(self.COORDINATES)} values for {self.coordinates}, got {len(values)}")
        return dict(zip(self.coordinates, values, strict=True))

    def validate(self, model: mujoco.MjModel) -> None:
        kind = {mujoco.mjtJoint.mjJNT_BALL: "a ball joint", mujoco.mjtJoint.mjJNT_FREE: "a free joint"}[self.JOINT_TYPE]
        require_joint(model, self.joint, (int(self.JOINT_TYPE),), kind)

    def dof_matrix(self, model: mujoco.MjModel) -> None:
        """None: the local angular velocity is not a constant linear map of q̇ (see ``velocity_map``)."""
        return None


COMPLEX_STEP = 1e-20
"""The complex step h of Ḃ q̇ = Im B(q + i h q̇) q̇ / h: no subtraction, so no cancellation; the
truncation error is O(h² |q̇|²) relative (1e-40 here), far below round-off."""


def velocity_map(binding: Binding, model: mujoco.MjModel, q: np.ndarray, qd: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray | None] | None:
    """(B, Ḃ q̇) at the state (q, q̇), with qvel = B q̇ (shape (nv, n)) and qacc = B q̈ + Ḃ q̇ (Ḃ q̇ of
    shape (nv,)), for any binding: its ``velocity_map`` where it has one (Ḃ q̇ by complex step,
    exact to round-off), else its constant dof matrix D (Ḃ q̇ None: exactly zero); None where it has
    neither."""
    given = getattr(binding, "velocity_map", None)
    if given is None:
        dof = binding.dof_matrix(model)
        return None if dof is None else (dof, None)
    q, qd = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
    mat = np.asarray(given(model, q), dtype=float)
    if mat.shape != (model.nv, len(q)):
        raise ValueError(f"velocity_map must return shape (nv, n) = ({model.nv}, {len(q)}), got {mat.shape}")
    rate = np.imag(np.asarray(given(model, q + 1j * COMPLEX_STEP * qd))) / COMPLEX_STEP
    return mat, rate @ qd


@dataclass(frozen=True)
class TreeBinding:
    """The tree reference's coordinates (:mod:`analytic.tree.model`) in MuJoCo's state: every joint of the
    model in dof order; a hinge's or slide's coordinate is its qpos; a ball's rotation vector θ sets its
    quaternion to R₀ Exp(θ) and its qvel to J_r(θ) θ̇ (body frame); a free joint's position is its qpos
    and qvel (world), its rotation as a ball's. ``charts``: R₀ (w, x, y, z) by joint id."""

    coordinates: tuple[str, ...]
    charts: tuple[tuple[int, tuple[float, ...]], ...] = ()

    def _chart(self, j: int) -> np.ndarray:
        return np.array(dict(self.charts).get(j, (1.0, 0.0, 0.0, 0.0)))

    def validate(self, model: mujoco.MjModel) -> None:
        if model.nv != len(self.coordinates):
            raise ModelMismatch(f"the model has {model.nv} degrees of freedom, its tree reference "
                                f"{len(self.coordinates)}: it is not the model the reference was read from")

    def set_state(self, model: mujoco.MjModel, data: mujoco.MjData,
                  q: Sequence[float] | np.ndarray, qd: Sequence[float] | np.ndarray) -> None:
        q, qd = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
        for j in range(model.njnt):
            kind, adr, dof = int(model.jnt_type[j]), int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j])
            if kind in ONE_DOF:
                data.qpos[adr], data.qvel[dof] = q[dof], qd[dof]
                continue
            rot = dof if kind == mujoco.mjtJoint.mjJNT_BALL else dof + 3
            if kind == mujoco.mjtJoint.mjJNT_FREE:
                data.qpos[adr:adr + 3], data.qvel[dof:dof + 3] = q[dof:dof + 3], qd[dof:dof + 3]
                adr += 3
            theta = q[rot:rot + 3]
            data.qpos[adr:adr + 4] = mat_to_quat(quat_to_mat(self._chart(j)) @ exp_map(theta))
            data.qvel[rot:rot + 3] = right_jacobian(theta) @ qd[rot:rot + 3]

    def dof_matrix(self, model: mujoco.MjModel) -> np.ndarray | None:
        if all(int(t) in ONE_DOF for t in model.jnt_type):
            return np.eye(model.nv)
        return None

    def velocity_map(self, model: mujoco.MjModel, q: np.ndarray) -> np.ndarray:
        """B(q) with qvel = B q̇ (complex q accepted: the instant layer's Ḃ q̇ by complex step)."""
        q = np.asarray(q)
        out = np.eye(model.nv, dtype=np.result_type(q.dtype, float))
        for j in range(model.njnt):
            kind, dof = int(model.jnt_type[j]), int(model.jnt_dofadr[j])
            if kind in ONE_DOF:
                continue
            rot = dof if kind == mujoco.mjtJoint.mjJNT_BALL else dof + 3
            out[rot:rot + 3, rot:rot + 3] = right_jacobian(q[rot:rot + 3])
        return out

"""Pinocchio built from MuJoCo's compiled model, and the conventions between the two.

The model is read from the ``MjModel`` the compiler made (body tree, body frames, joint anchors and axes,
masses, inertias in their principal frames, armature, gravity), never from the MJCF: what the comparison
then judges is MuJoCo's dynamics of its own model, not two parsers. Forces the rigid-body algorithms do
not include (springs, damping, actuators, constraints, contacts, gravity compensation) are left out on
both sides (:func:`rigid`).

Conventions, pinned by tests/test_peers.py:

- a hinge's or slide's Pinocchio coordinate is MuJoCo's ``qpos - qpos0`` (MuJoCo turns a body by
  ``qpos - qpos0`` about the axis; ``ref`` sets qpos0);
- quaternions: MuJoCo's qpos holds (w, x, y, z), Pinocchio's q (x, y, z, w);
- a ball's velocity is the angular velocity in the body frame on both sides;
- a free joint: MuJoCo's qvel is (linear velocity of the body origin in the world frame, angular
  velocity in the body frame); Pinocchio's v is both in the body frame. With R the body's orientation,
  v_lin = Rᵀ qvel_lin, so generalized forces map by the transpose (τ_mj = Tᵀ τ_pin, T = blockdiag(Rᵀ, I))
  and accelerations pick up the frame's turning: a_lin = Rᵀ qacc_lin − ω × v_lin. Without this map a
  humanoid's bias forces differ by factors, not by round-off.
"""

from __future__ import annotations

import copy
import importlib.util
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import mujoco
import numpy as np

from harness.core.errors import ModelError

__all__ = ["INSTALL", "JOINT_BALL", "JOINT_FREE", "JOINT_HINGE", "JOINT_NDOF", "JOINT_SLIDE", "available", "build",
           "rigid"]

INSTALL = "pip install 'mjharness[pin]'"
"""How to get the optional extra every second opinion needs."""


def available() -> bool:
    """Whether Pinocchio (the ``pin`` package) can be imported here."""
    return importlib.util.find_spec("pinocchio") is not None


def rigid(model: mujoco.MjModel) -> mujoco.MjModel:
    """A copy of ``model`` whose forward dynamics are the rigid-body algorithms' alone: springs, dampers,
    actuation, constraints (equalities, contacts, limits) and gravity compensation off, gravity kept. What
    the three-way comparison evaluates on every side, so that no force one side models and another does not
    can enter it."""
    out = copy.deepcopy(model)
    flags = mujoco.mjtDisableBit
    for name in ("mjDSBL_SPRING", "mjDSBL_DAMPER", "mjDSBL_PASSIVE", "mjDSBL_ACTUATION", "mjDSBL_CONSTRAINT"):
        if hasattr(flags, name):
            out.opt.disableflags |= int(getattr(flags, name))
    out.body_gravcomp[:] = 0.0
    return out


@dataclass(frozen=True)
class PinocchioModel:
    """Pinocchio's model of an ``MjModel`` and the map between their coordinates.

    Attributes:
        model: the ``pinocchio.Model``.
        joints: per MuJoCo joint, (kind, qpos address, dof address, Pinocchio idx_q, Pinocchio idx_v).
        qpos0: MuJoCo's reference configuration (a hinge's or slide's Pinocchio coordinate is measured from it).
    """

    model: Any  # a pinocchio.Model (pinocchio ships no type hints)
    joints: tuple[tuple[int, int, int, int, int], ...]
    qpos0: np.ndarray

    def q(self, qpos: np.ndarray) -> np.ndarray:
        """Pinocchio's configuration of MuJoCo's ``qpos``."""
        qpos0 = self.qpos0
        out = np.zeros(self.model.nq)
        for kind, adr, _, iq, _ in self.joints:
            if kind in (JOINT_HINGE, JOINT_SLIDE):
                out[iq] = qpos[adr] - qpos0[adr]
            elif kind == JOINT_BALL:
                out[iq:iq + 4] = _xyzw(qpos[adr:adr + 4])
            else:
                out[iq:iq + 3] = qpos[adr:adr + 3]
                out[iq + 3:iq + 7] = _xyzw(qpos[adr + 3:adr + 7])
        return out

    def frames(self, qpos: np.ndarray) -> np.ndarray:
        """T with Pinocchio's v = T qvel at ``qpos``: Rᵀ on each free joint's linear block, else the identity."""
        nv = self.model.nv
        t = np.eye(nv)
        for kind, adr, _, _, iv in self.joints:
            if kind == JOINT_FREE:
                t[iv:iv + 3, iv:iv + 3] = _rotation(qpos[adr + 3:adr + 7]).T
        return t

    def v(self, qpos: np.ndarray, qvel: np.ndarray) -> np.ndarray:
        return self.frames(qpos) @ self._ordered(qvel)

    def _ordered(self, x: np.ndarray) -> np.ndarray:
        """MuJoCo's dof vector in Pinocchio's order."""
        out = np.zeros(len(x))
        out[self._order] = x
        return out

    def _mujoco(self, x: np.ndarray) -> np.ndarray:
        """Pinocchio's dof vector in MuJoCo's order."""
        return x[self._order]

    def acceleration(self, qpos: np.ndarray, qvel: np.ndarray, qacc: np.ndarray) -> np.ndarray:
        """Pinocchio's a of MuJoCo's ``qacc``: T qacc, less ω × v_lin on each free joint's linear block."""
        v = self.v(qpos, qvel)
        a = self.frames(qpos) @ self._ordered(qacc)
        for kind, _, _, _, iv in self.joints:
            if kind == JOINT_FREE:
                a[iv:iv + 3] -= np.cross(v[iv + 3:iv + 6], v[iv:iv + 3])
        return a

    def qacc(self, qpos: np.ndarray, qvel: np.ndarray, a: np.ndarray) -> np.ndarray:
        """MuJoCo's qacc of Pinocchio's ``a`` (the inverse of :meth:`acceleration`)."""
        v = self.v(qpos, qvel)
        a = np.array(a, dtype=float)
        for kind, _, _, _, iv in self.joints:
            if kind == JOINT_FREE:
                a[iv:iv + 3] += np.cross(v[iv + 3:iv + 6], v[iv:iv + 3])
        return self._mujoco(self.frames(qpos).T @ a)

    def force(self, qpos: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """MuJoCo's generalized force of Pinocchio's ``tau``: Tᵀ tau (the same power on both sides)."""
        return self._mujoco(self.frames(qpos).T @ tau)

    def pin_force(self, qpos: np.ndarray, force: np.ndarray) -> np.ndarray:
        """Pinocchio's tau of MuJoCo's generalized ``force`` (T is orthogonal: T force)."""
        return self.frames(qpos) @ self._ordered(force)

    def mass_matrix(self, qpos: np.ndarray) -> np.ndarray:
        """Pinocchio's M (CRBA, symmetrized), mapped to MuJoCo's dofs: Tᵀ M T."""
        import pinocchio as pin  # lazy: Pinocchio is optional (the pin extra)

        data = self.model.createData()
        upper = np.array(pin.crba(self.model, data, self.q(qpos)))
        m = np.triu(upper) + np.triu(upper, 1).T
        t = self.frames(qpos)
        order = self._order
        return (t.T @ m @ t)[np.ix_(order, order)]

    @cached_property
    def _order(self) -> np.ndarray:
        """Pinocchio's dof index of each MuJoCo dof."""
        out = np.zeros(self.model.nv, dtype=int)
        for kind, _, dof, _, iv in self.joints:
            k = JOINT_NDOF[kind]
            out[dof:dof + k] = np.arange(iv, iv + k)
        return out

    def bias(self, qpos: np.ndarray, qvel: np.ndarray) -> np.ndarray:
        """MuJoCo's qfrc_bias by Pinocchio's RNEA: the force that gives qacc = 0 (not a = 0: on a free joint
        the two differ by the frame's turning)."""
        return self.inverse(qpos, qvel, np.zeros_like(qvel))

    def inverse(self, qpos: np.ndarray, qvel: np.ndarray, qacc: np.ndarray) -> np.ndarray:
        """The generalized force that gives ``qacc`` (RNEA, armature included), in MuJoCo's dofs."""
        import pinocchio as pin  # lazy: Pinocchio is optional (the pin extra)

        data = self.model.createData()
        tau = pin.rnea(self.model, data, self.q(qpos), self.v(qpos, qvel),
                       self.acceleration(qpos, qvel, qacc))
        return self.force(qpos, np.array(tau))

    def forward(self, qpos: np.ndarray, qvel: np.ndarray, force: np.ndarray) -> np.ndarray:
        """The qacc that the generalized ``force`` gives (ABA, armature included), in MuJoCo's dofs."""
        import pinocchio as pin  # lazy: Pinocchio is optional (the pin extra)

        data = self.model.createData()
        a = pin.aba(self.model, data, self.q(qpos), self.v(qpos, qvel), self.pin_force(qpos, force))
        return self.qacc(qpos, qvel, np.array(a))


JOINT_HINGE, JOINT_SLIDE, JOINT_BALL, JOINT_FREE = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE),
                                int(mujoco.mjtJoint.mjJNT_BALL), int(mujoco.mjtJoint.mjJNT_FREE))
JOINT_NDOF = {JOINT_HINGE: 1, JOINT_SLIDE: 1, JOINT_BALL: 3, JOINT_FREE: 6}


def _xyzw(wxyz: np.ndarray) -> np.ndarray:
    quat = np.asarray(wxyz, dtype=float)
    quat = quat / np.linalg.norm(quat)
    return np.array([quat[1], quat[2], quat[3], quat[0]])


def _rotation(wxyz: np.ndarray) -> np.ndarray:
    out = np.zeros(9)
    quat = np.asarray(wxyz, dtype=float)
    mujoco.mju_quat2Mat(out, quat / np.linalg.norm(quat))
    return out.reshape(3, 3)


def build(model: mujoco.MjModel) -> PinocchioModel:
    """Pinocchio's model of the compiled ``model``: one Pinocchio joint per MuJoCo joint, in MuJoCo's body
    order, placed at the joint's anchor in the body frame; each body's inertia on the last joint that moves
    it (a body without joints on its parent's); gravity as MuJoCo applies it (none where its flag disables it).
    ModelError for what Pinocchio cannot represent."""
    import pinocchio as pin  # lazy: Pinocchio is optional (the pin extra)

    pm = pin.Model()
    off = int(model.opt.disableflags) & int(mujoco.mjtDisableBit.mjDSBL_GRAVITY)
    gravity = np.zeros(3) if off else np.asarray(model.opt.gravity, dtype=float)
    pm.gravity = pin.Motion(np.concatenate([gravity, np.zeros(3)]))
    # per MuJoCo body: the Pinocchio joint that carries it, and the body frame in that joint's frame
    carrier: list[tuple[int, pin.SE3]] = [(0, pin.SE3.Identity())]
    joints: list[tuple[int, int, int, int, int]] = []
    armature: list[tuple[int, float]] = []
    for b in range(1, model.nbody):
        parent_joint, parent_frame = carrier[int(model.body_parentid[b])]
        offset = pin.SE3(_rotation(model.body_quat[b]), np.asarray(model.body_pos[b], dtype=float))
        frame = parent_frame * offset  # the body frame in its parent joint's frame, before its own joints
        jid, anchor = parent_joint, np.zeros(3)
        start, count = int(model.body_jntadr[b]), int(model.body_jntnum[b])
        if int(model.body_mocapid[b]) >= 0:
            count = 0  # a mocap body sits at its mocap pose, the body frame as compiled
        for j in range(start, start + count):
            kind = int(model.jnt_type[j])
            pos = np.asarray(model.jnt_pos[j], dtype=float)
            if kind == JOINT_FREE:
                if jid != 0 or count != 1:
                    raise ModelError(f"joint {model.joint(j).name or j!r}: a free joint that is not the only joint "
                                     "of a body hanging from the world; accepted: free joints in top-level bodies")
                placement, jm = pin.SE3.Identity(), pin.JointModelFreeFlyer()
            else:
                placement = frame * pin.SE3(np.eye(3), pos - anchor)
                axis = np.asarray(model.jnt_axis[j], dtype=float)
                jm = {JOINT_HINGE: lambda a=axis: pin.JointModelRevoluteUnaligned(a),
                      JOINT_SLIDE: lambda a=axis: pin.JointModelPrismaticUnaligned(a),
                      JOINT_BALL: pin.JointModelSpherical}[kind]()
            name = model.joint(j).name or f"joint{j}"
            jid = pm.addJoint(jid, jm, placement, name)
            frame, anchor = pin.SE3.Identity(), pos
            joints.append((kind, int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j]),
                           int(pm.idx_qs[jid]), int(pm.idx_vs[jid])))
            for k in range(JOINT_NDOF[kind]):
                armature.append((int(pm.idx_vs[jid]) + k, float(model.dof_armature[int(model.jnt_dofadr[j]) + k])))
        if jid != parent_joint:
            frame = pin.SE3(np.eye(3), -anchor)  # the body frame in its last joint's frame
        carrier.append((jid, frame))
        mass = float(model.body_mass[b])
        if mass > 0 or np.any(model.body_inertia[b]):
            rot = _rotation(model.body_iquat[b])
            inertia = pin.Inertia(mass, np.asarray(model.body_ipos[b], dtype=float),
                                  rot @ np.diag(np.asarray(model.body_inertia[b], dtype=float)) @ rot.T)
            pm.appendBodyToJoint(jid, inertia, frame)
    arm = np.zeros(pm.nv)
    for k, value in armature:
        arm[k] = value
    pm.armature = arm
    return PinocchioModel(model=pm, joints=tuple(joints), qpos0=np.array(model.qpos0, dtype=float))

"""Forward kinematics of a :class:`~analytic.tree.model.Tree`, and the Jacobians of body-fixed points.

Our own: every pose is composed from the tree's frames and the coordinates as
the model defines them (a hinge rotates its body about its anchor and axis, a
slide translates it, a ball and a free joint rotate it by R₀ Exp(θ)), never
read from an engine. Every function broadcasts over leading batch dimensions
of q and accepts a complex q, so that the dynamics can differentiate through
it by complex step (:mod:`analytic.tree.dynamics`), and a dual-number q
(:class:`analytic.dual.Dual`) for the derivatives of those.

The Jacobian columns are the exact derivatives of the poses: a hinge's column
is (a × (x − o), a) with a its world axis and o its anchor, a slide's (a, 0),
a ball's or free joint's rotational columns those of R J_r(θ) (the body-frame
angular velocity's map, turned into the world), a free joint's translational
ones the world axes. ``tests/test_tree.py`` checks them against the complex-
step derivative of the poses themselves.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from analytic.dual import Dual
from analytic.tree.model import BALL, FREE, HINGE, SLIDE, Tree
from analytic.tree.rotations import cross, exp_and_jacobian, mat_vec, quat_to_mat, right_jacobian, skew

__all__ = ["Layout", "Pose", "forward", "point_jacobians", "points_on", "velocity_map"]

Array = np.ndarray


@dataclass(frozen=True)
class Layout:
    """Index bookkeeping of a tree, computed once: each joint's first coordinate, and which coordinates
    move each body (its own joints' and all its ancestors')."""

    tree: Tree

    @cached_property
    def first(self) -> tuple[int, ...]:
        starts = np.cumsum([0, *(j.ndof for j in self.tree.joints)])
        return tuple(int(s) for s in starts[:-1])

    @cached_property
    def n(self) -> int:
        """The number of coordinates (the tree's, computed once)."""
        return self.tree.n

    @cached_property
    def moves(self) -> np.ndarray:
        """(nbodies, n) boolean: coordinate k moves body b."""
        tree = self.tree
        mask = np.zeros((len(tree.bodies), tree.n), dtype=bool)
        for b, body in enumerate(tree.bodies):
            if body.parent >= 0:
                mask[b] = mask[body.parent]
            for j in body.joints:
                mask[b, self.first[j]:self.first[j] + tree.joints[j].ndof] = True
        return mask

    @cached_property
    def body_rotations(self) -> np.ndarray:
        """Each body's constant rotation in its parent's frame, (nb, 3, 3)."""
        return np.array([quat_to_mat(b.quat) for b in self.tree.bodies]).reshape(-1, 3, 3)

    @cached_property
    def joint_constants(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per joint: skew(axis) and its square (a hinge's Rodrigues terms), and the chart R₀, each (nj, 3, 3)."""
        axes = np.array([j.axis for j in self.tree.joints], dtype=float)
        k = skew(axes)
        charts = np.array([quat_to_mat(j.chart) for j in self.tree.joints])
        return k, k @ k, charts

    @cached_property
    def hinges(self) -> np.ndarray:
        """The indices of the hinge joints."""
        return np.array([j for j, joint in enumerate(self.tree.joints) if joint.kind == HINGE], dtype=int)

    @cached_property
    def hinge_coordinates(self) -> np.ndarray:
        """Each hinge's coordinate, in :attr:`hinges` order."""
        return np.array([self.first[j] for j in self.hinges], dtype=int)

    @cached_property
    def hinge_refs(self) -> np.ndarray:
        """Each hinge's ``ref`` (its coordinate where the body sits at its frame), in :attr:`hinges` order."""
        return np.array([self.tree.joints[j].ref for j in self.hinges], dtype=float)

    @cached_property
    def rotation_vectors(self) -> tuple[np.ndarray, np.ndarray]:
        """The ball and free joints, and the coordinates (nr, 3) of each one's rotation vector: their Exp(θ) and
        J_r(θ) are computed together, once per pose."""
        joints = [j for j, joint in enumerate(self.tree.joints) if joint.kind in (BALL, FREE)]
        coords = [[self.first[j] + (3 if self.tree.joints[j].kind == FREE else 0) + a for a in range(3)]
                  for j in joints]
        return np.array(joints, dtype=int), np.array(coords, dtype=int).reshape(-1, 3)

    @cached_property
    def plan(self) -> tuple[tuple[int, np.ndarray | None, np.ndarray | None, tuple[tuple, ...], bool], ...]:
        """Per body, what :func:`forward` does, decided once: its parent, its offset in the parent's frame and
        its constant rotation (None where zero or the identity: nothing to add or multiply), and per joint
        (kind, first coordinate, anchor or None where at the body's origin, axis, the index of its rotation or
        Exp(θ) in the batched ones, the joint's index), and whether only hinges at its origin move it
        (:attr:`centred`)."""
        hinge_of = {int(j): i for i, j in enumerate(self.hinges)}
        rotation_of = {int(j): i for i, j in enumerate(self.rotation_vectors[0])}
        out = []
        for b, body in enumerate(self.tree.bodies):
            pos = np.asarray(body.pos, dtype=float)
            rot = self.body_rotations[b]
            steps = []
            for j in body.joints:
                joint = self.tree.joints[j]
                anchor = np.asarray(joint.pos, dtype=float)
                steps.append((joint.kind, self.first[j], anchor if np.any(anchor) else None,
                              np.asarray(joint.axis, dtype=float), hinge_of.get(j, rotation_of.get(j, -1)), j))
            centred = all(kind == HINGE and anchor is None for kind, _, anchor, _, _, _ in steps)
            out.append((body.parent, pos if body.parent < 0 or np.any(pos) else None,
                        None if np.array_equal(rot, np.eye(3)) else rot, tuple(steps), centred))
        return tuple(out)

    @cached_property
    def centred(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The hinges of the bodies that only hinges at their origin move (most of a robot's): their coordinates,
        bodies and axes (m, 3) in the body frame. Such a hinge turns about the body's origin, which none of them
        moves: its anchor is the body's final origin, and its world axis the frame's rotation before its turn
        times its axis, both set for all of them at once after the bodies are posed."""
        coords, bodies, axes = [], [], []
        for b, (_, _, _, steps, centred) in enumerate(self.plan):
            if centred:
                coords += [k for _, k, _, _, _, _ in steps]
                bodies += [b] * len(steps)
                axes += [axis for _, _, _, axis, _, _ in steps]
        return (np.array(coords, dtype=int), np.array(bodies, dtype=int),
                np.array(axes, dtype=float).reshape(-1, 3))

    @cached_property
    def body_of_coordinate(self) -> np.ndarray:
        out = np.empty(self.tree.n, dtype=int)
        for j, joint in enumerate(self.tree.joints):
            out[self.first[j]:self.first[j] + joint.ndof] = joint.body
        return out


@dataclass(frozen=True)
class Pose:
    """Where everything is at a batch of configurations.

    ``origin``/``rotation``: each body frame's world position (..., nb, 3) and orientation (..., nb, 3, 3);
    ``axes``/``anchors``: per coordinate, the world angular direction (..., n, 3) it turns about (zero for
    a translation) and the world point it turns about (..., n, 3); ``shifts``: per coordinate, the world
    translation direction (..., n, 3) (zero for a rotation); ``rates``: J_r(θ) of each ball's and free joint's
    rotation vector (..., nr, 3, 3), in :attr:`Layout.rotation_vectors` order (what qvel = B(q) q̇ needs).
    """

    origin: Array
    rotation: Array
    axes: Array
    anchors: Array
    shifts: Array
    rates: Array


def forward(tree: Tree, layout: Layout, q: Array) -> Pose:
    """Every body's world pose and every coordinate's world motion at configurations q (..., n) (complex, or
    :class:`~analytic.dual.Dual`: the arrays filled here are allocated ``like`` q)."""
    q = q if isinstance(q, Dual) else np.asarray(q)
    batch = q.shape[:-1]
    dtype = np.result_type(q.dtype, float)
    n = layout.n
    axes = np.zeros((*batch, n, 3), dtype=dtype, like=q)
    anchors = np.zeros((*batch, n, 3), dtype=dtype, like=q)
    shifts = np.zeros((*batch, n, 3), dtype=dtype, like=q)
    _, _, charts = layout.joint_constants
    hinges = layout.hinges
    if hinges.size:  # every hinge's rotation at once (Rodrigues), not one joint at a time
        skews, squares, _ = layout.joint_constants
        angle = q[..., layout.hinge_coordinates] - layout.hinge_refs
        turns = (np.eye(3) + np.sin(angle)[..., None, None] * skews[hinges]
                 + (1 - np.cos(angle))[..., None, None] * squares[hinges])
    if layout.rotation_vectors[0].size:  # every ball's and free joint's Exp(θ) and J_r(θ) at once
        exps, jacobians = exp_and_jacobian(q[..., layout.rotation_vectors[1]])
    else:
        jacobians = np.zeros((*batch, 0, 3, 3), dtype=dtype)
    origins: list[Array] = []  # each body's, stacked at the end
    rotations: list[Array] = []
    before = []  # each centred hinge's frame before its turn (Layout.centred)
    for parent, pos, rot, steps, centred in layout.plan:
        if parent >= 0:
            p, r = origins[parent], rotations[parent]
            if pos is not None:
                p = p + r @ pos
        else:  # under the world: its frame as placed (the world's identity rotation changes no bit), in q's type
            assert pos is not None  # a body under the world keeps its offset (Layout.plan)
            p = np.broadcast_to(pos.astype(dtype), (*batch, 3))
            r = np.broadcast_to(np.eye(3, dtype=dtype), (*batch, 3, 3))
        if rot is not None:
            r = r @ rot
        for kind, k, offset, axis, i, j in steps:
            if kind == HINGE:
                anchor = p if offset is None else p + r @ offset  # at the body's origin: the origin stays put
                if centred:  # its axis and anchor with the other centred hinges' (below)
                    before.append(r)
                else:
                    axes[..., k, :] = r @ axis
                    anchors[..., k, :] = anchor
                r = r @ turns[..., i, :, :]
                p = anchor if offset is None else anchor - r @ offset
            elif kind == SLIDE:
                shifts[..., k, :] = r @ axis
                p = p + shifts[..., k, :] * (q[..., k] - tree.joints[j].ref)[..., None]
            elif kind == BALL:
                anchor = p if offset is None else p + r @ offset
                r = r @ charts[j] @ exps[..., i, :, :]
                p = anchor if offset is None else anchor - r @ offset
                axes[..., k:k + 3, :] = np.swapaxes(r @ jacobians[..., i, :, :], -1, -2)
                anchors[..., k:k + 3, :] = anchor[..., None, :]
            elif kind == FREE:
                p = q[..., k:k + 3]
                r = charts[j] @ exps[..., i, :, :]
                shifts[..., k:k + 3, :] = np.eye(3)
                axes[..., k + 3:k + 6, :] = np.swapaxes(r @ jacobians[..., i, :, :], -1, -2)
                anchors[..., k + 3:k + 6, :] = p[..., None, :]
            else:
                raise ValueError(f"joint {tree.joints[j].name!r}: unknown kind {kind!r}")
        origins.append(p)
        rotations.append(r)
    origin, rotation = np.stack(origins, axis=-2, dtype=dtype), np.stack(rotations, axis=-3, dtype=dtype)
    coords, bodies, axis = layout.centred
    if before:
        axes[..., coords, :] = (np.stack(before, axis=-3) @ axis[:, :, None])[..., 0]
        anchors[..., coords, :] = origin[..., bodies, :]
    return Pose(origin=origin, rotation=rotation, axes=axes, anchors=anchors, shifts=shifts, rates=jacobians)


def points_on(pose: Pose, bodies: Array, offsets: Array) -> Array:
    """World positions (..., k, 3) of body-fixed points: ``offsets`` (k, 3) in the frames of ``bodies`` (k,)."""
    return pose.origin[..., bodies, :] + mat_vec(pose.rotation[..., bodies, :, :], offsets)


def point_jacobians(pose: Pose, layout: Layout, bodies: Array, x: Array) -> tuple[Array, Array]:
    """Linear (..., k, 3, n) and angular (..., k, 3, n) world Jacobians of points at world positions
    ``x`` (..., k, 3) fixed on ``bodies`` (k,): ẋ = J_lin q̇, the body's ω = J_ang q̇."""
    mask = layout.moves[bodies]  # (k, n)
    # a rotation about axis w through anchor o moves x at w × (x − o); a translation at its direction
    rel = x[..., :, None, :] - pose.anchors[..., None, :, :]  # (..., k, n, 3)
    lin = cross(pose.axes[..., None, :, :], rel) + pose.shifts[..., None, :, :]
    ang = np.broadcast_to(pose.axes[..., None, :, :], lin.shape)
    lin = np.where(mask[..., None], lin, 0.0)
    ang = np.where(mask[..., None], ang, 0.0)
    return np.swapaxes(lin, -1, -2), np.swapaxes(ang, -1, -2)


def velocity_map(tree: Tree, layout: Layout, q: Array) -> Array:
    """B(q), (..., n, n): MuJoCo's qvel = B(q) q̇ (identity for hinges and slides, J_r(θ) on a ball's
    and a free joint's rotation vector)."""
    q = q if isinstance(q, Dual) else np.asarray(q)
    n = layout.n
    out = np.zeros((*q.shape[:-1], n, n), dtype=np.result_type(q.dtype, float), like=q)
    out[..., np.arange(n), np.arange(n)] = 1.0
    blocks = layout.rotation_vectors[1]
    if blocks.size:
        rates = right_jacobian(q[..., blocks])
        for i, k in enumerate(blocks[:, 0]):
            out[..., k:k + 3, k:k + 3] = rates[..., i, :, :]
    return out

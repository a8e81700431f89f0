"""The tree reference's equations of motion: Lagrange's equations of the tree's own Lagrangian,
differentiated exactly by complex step.

    T(q, q̇) = Σ_b ½ m_b |ċ_b|² + ½ ω_bᵀ I_b ω_b + ½ Σ_dof armature · qvel²      (qvel = B(q) q̇)
    V(q)    = −Σ_b m_b g·c_b + Σ_joints Σ_terms V_term(q_joint)      (analytic.tree.terms: springs)
    d/dt ∂T/∂q̇ − ∂T/∂q + ∂V/∂q = Q   ⇒   M q̈ = Q − Ṁ q̇ + ∂T/∂q − ∂V/∂q =: F

T is quadratic in q̇, so M(q) = ∂²T/∂q̇² is read off the quadratic form built
from the point Jacobians (:mod:`analytic.tree.kinematics`). Every derivative
with respect to q is a complex step, f′(q) v = Im f(q + i h v)/h with
h = 1e-30, exact to round-off: Ṁ q̇ from the momentum M q̇ at q + i h q̇, ∂T/∂q
and ∂V/∂q from T and V at q + i h e_k, all in one batched evaluation; at those
n + 2 configurations T and M q̇ are summed through each coordinate's world twist
(:meth:`TreeDynamics._momentum_and_kinetic`), no Jacobian formed. The non-conservative Q
are applied forces through their Jacobians: joint damping −Bᵀ d(qvel)
(MuJoCo's polynomial), gravity compensation Jᵀ(−m g · gravcomp) at each
centre of mass, and actuators at a fixed control, moment × force, each clipped to its force range and their
sum on a joint to the joint's range (a clamp is a function of the state: its slope jumps where it switches,
:meth:`TreeDynamics.clamp_arguments`). Nothing here
calls an engine; ``tests/test_tree.py`` holds the independent checks (Kane's
form of the same equations, the hand-derived systems, MuJoCo as the thing judged).

Constraints are blocks of rows f(q) = 0 with J = ∂f/∂q written from the point
Jacobians and γ = −J̇ q̇ by complex step on J, in the sign convention of
:class:`analytic.dynamics.Dynamics`: M q̈ = F + Jᵀ λ.

The same code takes dual-number states (:mod:`analytic.dual`: y + ε d, ε² = 0,
ε independent of the complex step's i), so that q̈'s own derivatives in q and
q̇ are exact too (the stiff solver's Jacobian, :func:`analytic.solvers.state_jacobian`):
arrays it fills are allocated ``like`` its input, clamps compare real values.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import cast

import numpy as np

from analytic.dual import Dual
from analytic.dynamics import Dynamics, chunk_states
from analytic.tree.kinematics import Layout, Pose, forward, point_jacobians, points_on, velocity_map
from analytic.tree.model import FREE, Tree
from analytic.tree.rotations import cross, mat_t_vec, mat_vec, quat_to_mat, right_jacobian, skew, vee

__all__ = ["TreeDynamics"]

Array = np.ndarray

STEP = 1e-30
"""The complex step h: Im f(q + i h v)/h = f′(q) v + O(h² |v|³), so any h far below round-off will do."""



def _chunked(evaluate, q: Array, qd: Array, n: int) -> tuple:
    """``evaluate(q, qd)`` (a tuple of arrays or None, each with the states' leading shape) over at most
    :func:`~analytic.dynamics.chunk_states` states at a time, joined; at once where the batch is that small or the
    states are dual numbers."""
    lead = q.shape[:-1]
    states = int(np.prod(lead)) if lead else 1
    per = chunk_states(n)
    if states <= per or not isinstance(q, np.ndarray) or not isinstance(qd, np.ndarray):
        return evaluate(q, qd)
    q, qd = q.reshape(states, -1), qd.reshape(states, -1)
    parts = [evaluate(q[i:i + per], qd[i:i + per]) for i in range(0, states, per)]
    return tuple(None if group[0] is None else np.concatenate(group).reshape(*lead, *group[0].shape[1:])
                 for group in zip(*parts, strict=True))


def _clip(x: Array, lo: Array, hi: Array) -> Array:
    """x clipped to [lo, hi] by its real part (a complex step through the clip keeps the branch it is on: slope 0 where
    clipped)."""
    return np.where(x.real > hi, hi, np.where(x.real < lo, lo, x))


def _state(x: Array | Dual) -> Array | Dual:
    """A state's q or q̇ as a float array, or as given where a dual number."""
    return x if isinstance(x, Dual) else np.asarray(x, dtype=float)


def _member(pose: Pose, i: int) -> Pose:
    """The pose of the i-th configuration of a batch (..., k, n) of them."""
    return Pose(*(x[..., i, :, :] if x.ndim == pose.origin.ndim else x[..., i, :, :, :] for x in
                  (pose.origin, pose.rotation, pose.axes, pose.anchors, pose.shifts, pose.rates)))


@dataclass(frozen=True, kw_only=True)
class TreeDynamics(Dynamics):
    """:class:`~analytic.dynamics.Dynamics` of a :class:`~analytic.tree.model.Tree`: the same interface the
    hand-derived systems give, so every layer of the harness runs on it.

    Points are the tree's named points; bodies (for reactions) every body with mass."""

    tree: Tree
    _funcs: dict = field(default_factory=dict)

    @classmethod
    def of(cls, tree: Tree) -> TreeDynamics:
        equalities = tree.equalities
        return cls(coordinates=tree.coordinates, constraint_names=tuple(e.name for e in equalities),
                   point_names=tuple(p.name for p in tree.points), cyclic=(), params=tree.params(),
                   constraint_sizes=tuple(e.rows for e in equalities),
                   body_names=tuple(b.name for b in tree.bodies if b.mass > 0), tree=tree)

    # ---- bookkeeping ------------------------------------------------------------------------------
    @cached_property
    def layout(self) -> Layout:
        return Layout(self.tree)

    @cached_property
    def _bodies(self) -> dict[str, Array]:
        tree = self.tree
        massive = np.array([i for i, b in enumerate(tree.bodies) if b.mass > 0], dtype=int)
        return {
            "index": massive,
            "mass": np.array([tree.bodies[i].mass for i in massive]),
            "inertia": np.array([tree.bodies[i].inertia for i in massive]).reshape(-1, 3),
            "ipos": np.array([tree.bodies[i].ipos for i in massive]).reshape(-1, 3),
            "irot": np.array([quat_to_mat(tree.bodies[i].iquat) for i in massive]).reshape(-1, 3, 3),
            "gravcomp": np.array([tree.bodies[i].gravcomp for i in massive]),
        }

    @cached_property
    def _body_inertia(self) -> Array:
        """Each body's inertia tensor about its centre of mass in its body frame, F diag(I) Fᵀ with F the principal
        frame's rotation, (nb, 3, 3): a constant, so that I ω in the world is R (F diag(I) Fᵀ) Rᵀ ω."""
        rot, inertia = self._bodies["irot"], self._bodies["inertia"]
        return np.einsum("bij,bj,bkj->bik", rot, inertia, rot)

    @cached_property
    def _armature(self) -> Array:
        out = np.zeros(self.tree.n)
        for j, joint in enumerate(self.tree.joints):
            out[self.layout.first[j]:self.layout.first[j] + joint.ndof] = joint.armature
        return out

    @cached_property
    def _damping(self) -> Array:
        out = np.zeros((self.tree.n, 3))
        for j, joint in enumerate(self.tree.joints):
            out[self.layout.first[j]:self.layout.first[j] + joint.ndof] = joint.damping
        return out

    # ---- the Lagrangian's pieces at a batch of (possibly complex) configurations -----------------------
    def _com_jacobians(self, pose: Pose) -> tuple[Array, Array, Array, Array]:
        """Centres of mass (..., nb, 3), their linear and angular Jacobians (..., nb, 3, n), and the world
        inertia tensors (..., nb, 3, 3) of the bodies with mass."""
        bodies = self._bodies
        com = points_on(pose, bodies["index"], bodies["ipos"])
        lin, ang = point_jacobians(pose, self.layout, bodies["index"], com)
        rot = pose.rotation[..., bodies["index"], :, :] @ bodies["irot"]
        inertia = np.einsum("...bij,bj,...bkj->...bik", rot, bodies["inertia"], rot)
        return com, lin, ang, inertia

    def _mass(self, q: Array, pose: Pose) -> Array:
        _, lin, ang, inertia = self._com_jacobians(pose)
        return self._mass_from(q, lin, ang, inertia)

    def _mass_from(self, q: Array, lin: Array, ang: Array, inertia: Array) -> Array:
        """M = Σ_b m J_vᵀ J_v + J_ωᵀ I J_ω + Bᵀ diag(armature) B, (..., n, n), from the real Jacobians (..., nb, 3, n)
        and world inertias (..., nb, 3, 3): the bodies' and their three rows stacked, one matrix product each."""
        stacked = (*lin.shape[:-3], -1, lin.shape[-1])
        m = self._bodies["mass"][:, None, None]
        mass = (np.swapaxes(lin.reshape(stacked), -1, -2) @ (m * lin).reshape(stacked)
                + np.swapaxes(ang.reshape(stacked), -1, -2) @ (inertia @ ang).reshape(stacked))
        b = velocity_map(self.tree, self.layout, q)
        return mass + np.swapaxes(b, -1, -2) @ (self._armature[:, None] * b)

    def _potential(self, pose: Pose, q: Array, com: Array | None = None) -> Array:
        """V at configurations q posed as ``pose``; ``com``: the centres of mass where already computed."""
        if com is None:
            com = points_on(pose, self._bodies["index"], self._bodies["ipos"])
        v = -np.einsum("b,...bi,i->...", self._bodies["mass"], com, self.tree.gravity)
        for j, joint in enumerate(self.tree.joints):
            for term in joint.terms:
                v = v + term.energy(q[..., self.layout.first[j]:self.layout.first[j] + joint.ndof])
        return v

    @property
    def dual_states(self) -> bool:
        """The tree's equations take :class:`~analytic.dual.Dual` states: every derivative inside them is a complex
        step, in i, and ε is independent of it."""
        return True

    @property
    def velocity_polynomial(self) -> bool:
        """q̈ at a fixed q is a polynomial of degree ≤ 3 in q̇ (velocity products, damping a v + c v³, actuators'
        affine l̇, γ quadratic) unless a joint's damping has the v|v| term; only piecewise where a clamp acts on a
        velocity-dependent force (a servo's kv under its force range): the forward-difference path's stencil
        (``state_jacobian(differences=True)``, no longer the tree's) can straddle its switch."""
        return not np.any(self._damping[:, 1])

    def damping_modes(self, q: Array) -> tuple[Array, Array]:
        """The decay rates (1/s) the linear damping gives the motion at a configuration q, fastest first, and
        their modes (columns, M-orthonormal): D v = r M v, D = Bᵀ diag(a) B + Σ_actuators −(g₂ c + b₂) m mᵀ in
        these coordinates: the joints' damping and the actuators' velocity feedback (a position servo's kv),
        which act alike. Far above the motion's own rates (damping on a light link) they make the motion stiff."""
        q = np.asarray(q, dtype=float)
        b = velocity_map(self.tree, self.layout, q)
        damping = b.T @ (self._damping[:, 0][:, None] * b)
        if self.tree.actuators:
            acts = self._actuators
            feedback = -(acts["gain"][:, 2] * acts["ctrl"] + acts["bias"][:, 2])  # N s per unit of l̇ = m · q̇
            damping = damping + acts["moment"].T @ (feedback[:, None] * acts["moment"])
        chol = np.linalg.cholesky(self.mass_matrix(q))
        half = np.linalg.solve(chol, damping)
        rates, vectors = np.linalg.eigh(np.linalg.solve(chol, half.T))
        order = np.argsort(rates)[::-1]
        return rates[order], np.linalg.solve(chol.T, vectors[:, order])

    def damping_matrix(self, q: Array, qd: Array) -> Array:
        """D = −∂Q_damping/∂q̇ at (q, q̇), (..., n, n): the joints' own damping alone, Bᵀ diag(d′(qvel)) B with
        d′ the derivative of MuJoCo's damping polynomial (what MuJoCo's Euler integrates implicitly)."""
        q, qd = np.broadcast_arrays(np.asarray(q, dtype=float), np.asarray(qd, dtype=float))
        b = velocity_map(self.tree, self.layout, q)
        qvel = self._qvel(q, qd)
        d = self._damping
        slope = d[:, 0] + 2.0 * d[:, 1] * np.abs(qvel) + 3.0 * d[:, 2] * qvel * qvel
        return np.swapaxes(b, -1, -2) @ (slope[..., :, None] * b)

    def _applied(self, q: Array, qd: Array, lin: Array) -> Array:
        """The non-conservative generalized forces Q at (q, q̇): damping, gravity compensation, actuators
        (:meth:`actuation`)."""
        rates = self._rates(q) if self.layout.rotation_vectors[0].size else None
        qvel = self._qvel(q, qd, rates=rates)
        d = self._damping
        damper = -(d[:, 0] * qvel + d[:, 1] * qvel * np.abs(qvel) + d[:, 2] * qvel ** 3)
        out = self._qvel(q, damper, transpose=True, rates=rates)
        comp = self._gravcomp(lin)
        if comp is not None:
            out = out + comp * self._gravcomp_route[0]
        if self.tree.actuators or self.tree.limits:
            out = out + self._actuation(q, qvel, comp)[0]
        return out

    def _gravcomp(self, lin: Array) -> Array | None:
        """Gravity compensation's generalized force Jᵀ(−m g · gravcomp) summed over the bodies, None where none."""
        comp = self._bodies["gravcomp"]
        if not np.any(comp):
            return None
        force = -(self._bodies["mass"] * comp)[:, None] * self.tree.gravity  # (nb, 3)
        return np.einsum("...bik,bi->...k", lin, force)

    @cached_property
    def _gravcomp_route(self) -> tuple[Array, Array]:
        """Per coordinate, 1 where the joint's gravity compensation is a passive force, and 1 where it is added to
        the actuators' force (MuJoCo's ``actuatorgravcomp``)."""
        passive, actuator = np.zeros(self.tree.n), np.zeros(self.tree.n)
        for j, joint in enumerate(self.tree.joints):
            block = slice(self.layout.first[j], self.layout.first[j] + joint.ndof)
            passive[block] = joint.gravcomp == "passive"
            actuator[block] = joint.gravcomp == "actuator"
        return passive, actuator

    def _actuation(self, q: Array, qvel: Array, comp: Array | None) -> tuple[Array, Array]:
        """The actuators' generalized force and every clamp's argument, as MuJoCo applies them (engine_forward.c,
        mj_fwdActuation): each actuator's affine force; the forces on a tendon with an ``actuatorfrcrange`` scaled by
        the end over their sum where the sum leaves it; each force clipped to its ``forcerange``; their sum through
        the moments, plus gravity compensation routed to the actuators; each joint's total clipped to its
        ``actuatorfrcrange``. The second array holds, per clamp (the tendons' limits, the actuators' force ranges,
        then the joints' limits), its argument (the force or sum before it is clipped or scaled). A clip compares
        real parts only, so that a complex step through it differentiates the branch it is on."""
        acts = self._actuators
        moment = acts["moment"]
        length = q @ moment.T
        speed = qvel @ moment.T
        gain, bias = acts["gain"], acts["bias"]
        force = ((gain[:, 0] + gain[:, 1] * length + gain[:, 2] * speed) * acts["ctrl"]
                 + bias[:, 0] + bias[:, 1] * length + bias[:, 2] * speed)
        tendons = []
        for lim in self.tree.tendon_limits:  # before the actuators' own ranges (engine_forward.c)
            members = list(lim.actuators)
            total = np.sum(force[..., members], axis=-1)
            tendons.append(total)
            scale = np.where(total.real > lim.hi, lim.hi / np.where(total.real > lim.hi, total, 1.0),
                             np.where(total.real < lim.lo, lim.lo / np.where(total.real < lim.lo, total, 1.0), 1.0))
            force = force.copy()
            force[..., members] = force[..., members] * scale[..., None]
        limited = acts["limited"]
        before = force[..., limited]
        force = _clip(force, acts["lo"], acts["hi"])
        total = force @ moment
        if comp is not None:
            total = total + comp * self._gravcomp_route[1]
        dofs, lo, hi = self._limits
        summed = total[..., dofs]
        if len(dofs):
            total = total.copy()
            total[..., dofs] = _clip(summed, lo, hi)
        return total, np.concatenate([*(t[..., None] for t in tendons), before, summed], axis=-1)

    @cached_property
    def _limits(self) -> tuple[Array, Array, Array]:
        limits = self.tree.limits
        return (np.array([lim.dof for lim in limits], dtype=int), np.array([lim.lo for lim in limits], dtype=float),
                np.array([lim.hi for lim in limits], dtype=float))

    @cached_property
    def clamp_ranges(self) -> tuple[tuple[str, float, float], ...]:
        """Every clamp on the actuation, by name, with its range: the tendons' ``actuatorfrcrange``, the actuators'
        ``forcerange`` (in actuator order), then the joints' ``actuatorfrcrange`` (:meth:`clamp_arguments` gives their
        arguments in the same order)."""
        tendons = [(f"tendon {lim.name} actuatorfrcrange", lim.lo, lim.hi) for lim in self.tree.tendon_limits]
        acts = [(f"actuator {a.name} forcerange", *a.forcerange) for a in self.tree.actuators
                if a.forcerange is not None]
        return (*tendons, *acts, *((f"joint {lim.name} actuatorfrcrange", lim.lo, lim.hi) for lim in self.tree.limits))

    def clamp_arguments(self, q: Array, qd: Array) -> Array:
        """What each clamp of :attr:`clamp_ranges` clips at (q, q̇) (..., clamps): a clamp switches (its force's
        slope in the state jumps) where its argument crosses either end of its range."""
        q, qd = np.broadcast_arrays(np.asarray(q, dtype=float), np.asarray(qd, dtype=float))
        if not self.clamp_ranges:
            return np.zeros((*q.shape[:-1], 0))
        comp = None
        if np.any(self._gravcomp_route[1]) and np.any(self._bodies["gravcomp"]):
            _, lin, _, _ = self._com_jacobians(forward(self.tree, self.layout, q))
            comp = self._gravcomp(lin)
        return self._actuation(q, self._qvel(q, qd), comp)[1]

    @cached_property
    def _actuators(self) -> dict[str, Array]:
        acts = self.tree.actuators
        limited = np.array([a.forcerange is not None for a in acts], dtype=bool)
        ranges = np.array([a.forcerange if a.forcerange is not None else (-np.inf, np.inf) for a in acts],
                          dtype=float).reshape(-1, 2)
        return {"moment": np.array([a.moment for a in acts], dtype=float).reshape(len(acts), self.n),
                "gain": np.array([a.gain for a in acts], dtype=float).reshape(-1, 3),
                "bias": np.array([a.bias for a in acts], dtype=float).reshape(-1, 3),
                "ctrl": np.array([a.ctrl for a in acts], dtype=float), "limited": limited,
                "lo": ranges[:, 0], "hi": ranges[:, 1]}

    def _perturbed(self, q: Array, directions: Array) -> Array:
        """Configurations q + i h d for each direction d (..., k, n) -> (..., k, n) complex."""
        return q[..., None, :] + 1j * STEP * directions

    # ---- the Dynamics interface ----------------------------------------------------------------------------
    def mass_matrix(self, q: Array) -> Array:
        q = np.asarray(q, dtype=float)
        return self._mass(q, forward(self.tree, self.layout, q))

    def _momentum_and_kinetic(self, c: Array, qd: Array, pose: Pose, com: Array) -> tuple[Array, Array]:
        """At configurations c (..., k, n) with the real velocity q̇ (..., n), posed as ``pose`` with the bodies'
        centres of mass ``com``: the momentum ∂T/∂q̇ = M(c) q̇ (..., k, n) and T(c, q̇) (..., k), without forming M
        or any Jacobian.

        The same sums as Σ_b J_bᵀ (m v, I ω), reassociated: each coordinate's world twist (its axis a times q̇_k
        and the velocity (o − r) × a + s it gives the world point r) summed over the coordinates that move a body
        gives the body's ω and velocity; each body's linear and angular momentum summed over the bodies a
        coordinate moves gives that coordinate's momentum. Two products with the (bodies × coordinates) mask,
        O(nb · n) per configuration instead of the Jacobians' O(nb · n) entries each multiplied out.
        The reference point r is the first body's origin at the real configuration (a constant: it changes
        no derivative), so that nothing cancels over the tree's distance from the world origin."""
        bodies = self._bodies
        mask = self._mask
        ref = pose.origin[(*(0,) * (pose.origin.ndim - 2), 0)].real
        qdk = qd[..., None, :, None]  # against (..., k, n, 3)
        omega_k = pose.axes * qdk
        move_k = (cross(pose.anchors - ref, pose.axes) + pose.shifts) * qdk
        omega = mask @ omega_k  # (..., k, nb, 3)
        rel = com - ref
        rot = pose.rotation[..., bodies["index"], :, :]
        m = bodies["mass"][:, None]
        v = mask @ move_k + cross(omega, rel)
        # I ω = R I_b Rᵀ ω, R the body's rotation, I_b its constant inertia tensor (by components: no BLAS call
        # per 3×3)
        iw = mat_vec(rot, mat_vec(self._body_inertia, mat_t_vec(rot, omega)))
        linear = m * v
        linear_k = mask.T @ linear  # (..., k, n, 3): the momentum of everything coordinate k moves
        angular_k = mask.T @ (cross(rel, linear) + iw) - cross(pose.anchors - ref, linear_k)
        momentum = np.sum(pose.axes * angular_k + pose.shifts * linear_k, axis=-1)
        qvel = self._qvel(c, np.broadcast_to(qd[..., None, :], c.shape), rates=pose.rates)
        aq = self._armature * qvel
        momentum = momentum + self._qvel(c, aq, transpose=True, rates=pose.rates)
        kinetic = 0.5 * (np.sum(linear * v, axis=(-1, -2)) + np.sum(omega * iw, axis=(-1, -2))
                         + np.sum(qvel * aq, axis=-1))
        return momentum, kinetic

    @cached_property
    def _mask(self) -> Array:
        """(bodies with mass, n) as floats: coordinate k moves body b."""
        return self.layout.moves[self._bodies["index"]].astype(float)

    def _rates(self, c: Array) -> Array:
        """J_r(θ) of every rotation vector (a ball's, a free joint's last three) at configurations c, (..., nr, 3, 3):
        where B(c) ≠ I."""
        return right_jacobian(c[..., self.layout.rotation_vectors[1]])

    def _qvel(self, c: Array, x: Array, *, transpose: bool = False, rates: Array | None = None) -> Array:
        """B(c) x (MuJoCo's qvel for x = q̇), or B(c)ᵀ x, without forming B: J_r(θ) on each rotation vector's
        block, the identity elsewhere. ``rates``: :meth:`_rates` at c where already computed."""
        blocks = self.layout.rotation_vectors[1]
        if not blocks.size:
            return x
        jr = self._rates(c) if rates is None else rates
        if transpose:
            jr = np.swapaxes(jr, -1, -2)
        out = np.array(x, dtype=np.result_type(c.dtype, x.dtype), like=x if isinstance(jr, np.ndarray) else jr)
        out[..., blocks] = (jr @ x[..., blocks, None])[..., 0]
        return out

    def mass_and_forcing(self, q: Array, qd: Array) -> tuple[Array, Array]:
        """M(q) and F(q, q̇) from one batched evaluation: the real configuration, q + i h q̇ (for Ṁ q̇ = d/dt ∂T/∂q̇
        at q̈ = 0), and q + i h e_k (for ∂L/∂q_k)."""
        q, qd = np.broadcast_arrays(np.asarray(q, dtype=float), np.asarray(qd, dtype=float))
        return _chunked(lambda a, b: self._mass_and_forcing(a, b)[:2], q, qd, self.n)

    def kkt_terms(self, q: Array, qd: Array, *, stabilization: tuple[float, float] = (0.0, 0.0)
                  ) -> tuple[Array, Array, Array | None, Array | None]:
        """M, F, J and the constraints' right-hand side (:meth:`constraint_terms`) from one pass of the kinematics:
        the constraints' configuration q + i h q̇ is the second of the batch M and F are computed at. Dual-number
        states (:attr:`dual_states`) give each block's exact tangent."""
        q, qd = np.broadcast_arrays(_state(q), _state(qd))

        def terms(q: Array, qd: Array) -> tuple[Array, Array, Array | None, Array | None]:
            mass, force, c, pose = self._mass_and_forcing(q, qd)
            if self.rows == 0:
                return mass, force, None, None
            return (mass, force, *self._constraint_terms(qd, *self._rows(c[..., 1, :], _member(pose, 1)),
                                                         stabilization=stabilization))

        return _chunked(terms, q, qd, self.n)

    def _mass_and_forcing(self, q: Array, qd: Array) -> tuple[Array, Array, Array, Pose]:
        """M, F, and the configurations (..., n + 2, n) they were computed at with their pose."""
        n = self.n
        directions = np.concatenate([np.zeros_like(qd)[..., None, :], qd[..., None, :],
                                     np.broadcast_to(np.eye(n), (*q.shape[:-1], n, n))], axis=-2)
        c = self._perturbed(q, directions)
        pose = forward(self.tree, self.layout, c)
        com = points_on(pose, self._bodies["index"], self._bodies["ipos"])
        momentum, kinetic = self._momentum_and_kinetic(c, qd, pose, com)
        mdot_qd = momentum[..., 1, :].imag / STEP
        potential = self._potential(pose, c, com)
        dl_dq = (kinetic[..., 2:] - potential[..., 2:]).imag / STEP
        _, lin, ang, inertia = self._com_jacobians(_member(pose, 0))
        lin0, ang0, inertia0 = lin.real, ang.real, inertia.real
        return self._mass_from(q, lin0, ang0, inertia0), self._applied(q, qd, lin0) - mdot_qd + dl_dq, c, pose

    def forcing(self, q: Array, qd: Array) -> Array:
        return self.mass_and_forcing(q, qd)[1]

    def energy(self, q: Array, qd: Array) -> Array:
        """T + V with V gravity's and the joint springs' (MuJoCo's energy: gravity compensation and
        actuators are forces, not potentials)."""
        q, qd = np.broadcast_arrays(np.asarray(q, dtype=float), np.asarray(qd, dtype=float))
        pose = forward(self.tree, self.layout, q)
        kinetic = 0.5 * np.einsum("...i,...ij,...j->...", qd, self._mass(q, pose), qd)
        return kinetic + self._potential(pose, q)

    def momenta(self, q: Array, qd: Array) -> Array:
        return np.zeros((*np.shape(q)[:-1], 0))

    @cached_property
    def free_floating(self) -> bool:
        """Whether the tree's total linear and angular momentum are conserved: no gravity, every moving body hangs
        from a free joint at its root, and no constraint holds a body to the world or to a body that never moves."""
        tree = self.tree
        if np.any(tree.gravity):
            return False
        moves = np.asarray(self.layout.moves.any(axis=1))
        for b in range(len(tree.bodies)):
            root = b
            while tree.bodies[root].parent >= 0:
                root = tree.bodies[root].parent
            first = tree.bodies[root].joints[:1]
            if moves[b] and not (first and tree.joints[first[0]].kind == FREE):
                return False
        anchored = [e for e in tree.equalities if e.kind in ("connect", "weld")
                    and (e.body1 < 0 or e.body2 < 0 or not moves[e.body1] or not moves[e.body2])]
        return not anchored

    def extra_invariants(self, q: Array, qd: Array) -> dict[str, Array]:
        """For a free-floating tree (:attr:`free_floating`), its total linear momentum Σ m ċ (``p_lin_x`` …) and its
        angular momentum about the world origin Σ (c × m ċ + I ω) (``p_ang_x`` …); else none."""
        if not self.free_floating:
            return {}
        q, qd = np.broadcast_arrays(np.asarray(q, dtype=float), np.asarray(qd, dtype=float))
        com, lin, ang, inertia = self._com_jacobians(forward(self.tree, self.layout, q))
        m = self._bodies["mass"]
        v = np.einsum("...bij,...j->...bi", lin, qd)
        w = np.einsum("...bij,...j->...bi", ang, qd)
        linear = np.einsum("b,...bi->...i", m, v)
        angular = (np.einsum("b,...bi->...i", m, np.cross(com, v))
                   + np.einsum("...bij,...bj->...i", inertia, w))
        return ({f"p_lin_{a}": linear[..., k] for k, a in enumerate("xyz")}
                | {f"p_ang_{a}": angular[..., k] for k, a in enumerate("xyz")})

    # ---- points ------------------------------------------------------------------------------------
    @cached_property
    def _point_index(self) -> tuple[Array, Array]:
        pts = self.tree.points
        return (np.array([p.body for p in pts], dtype=int),
                np.array([p.pos for p in pts], dtype=float).reshape(-1, 3))

    def points(self, q: Array) -> Array:
        bodies, offsets = self._point_index
        return points_on(forward(self.tree, self.layout, np.asarray(q, dtype=float)), bodies, offsets)

    def _point_jac(self, q: Array) -> Array:
        bodies, offsets = self._point_index
        pose = forward(self.tree, self.layout, q)
        return point_jacobians(pose, self.layout, bodies, points_on(pose, bodies, offsets))[0]

    def point_jacobians(self, q: Array) -> Array:
        return self._point_jac(np.asarray(q, dtype=float))

    def point_velocities(self, q: Array, qd: Array) -> Array:
        return np.einsum("...pij,...j->...pi", self.point_jacobians(q), np.asarray(qd, dtype=float))

    def point_accelerations(self, q: Array, qd: Array, qdd: Array) -> Array:
        q, qd = np.broadcast_arrays(np.asarray(q, dtype=float), np.asarray(qd, dtype=float))
        jac = self._point_jac(q)
        jdot_qd = np.einsum("...pij,...j->...pi", self._point_jac(q + 1j * STEP * qd).imag, qd) / STEP
        return np.einsum("...pij,...j->...pi", jac, np.asarray(qdd, dtype=float)) + jdot_qd

    # ---- bodies (reactions) ------------------------------------------------------------------------
    def body_masses(self) -> Array:
        return self._bodies["mass"].copy()

    def body_coms(self, q: Array) -> Array:
        return points_on(forward(self.tree, self.layout, np.asarray(q, dtype=float)), self._bodies["index"],
                         self._bodies["ipos"])

    def _body_rates(self, q: Array, qd: Array, qdd: Array) -> tuple[Array, Array]:
        q, qd = np.broadcast_arrays(np.asarray(q, dtype=float), np.asarray(qd, dtype=float))
        qdd = np.asarray(qdd, dtype=float)
        _, lin, ang, inertia = self._com_jacobians(forward(self.tree, self.layout, q))
        _, lin_c, ang_c, _ = self._com_jacobians(forward(self.tree, self.layout, q + 1j * STEP * qd))
        acc = np.einsum("...bij,...j->...bi", lin, qdd) + np.einsum("...bij,...j->...bi", lin_c.imag, qd) / STEP
        omega = np.einsum("...bij,...j->...bi", ang, qd)
        alpha = np.einsum("...bij,...j->...bi", ang, qdd) + np.einsum("...bij,...j->...bi", ang_c.imag, qd) / STEP
        iw = np.einsum("...bij,...bj->...bi", inertia, omega)
        rate = np.einsum("...bij,...bj->...bi", inertia, alpha) + np.cross(omega, iw)
        return acc, rate

    def body_accelerations(self, q: Array, qd: Array, qdd: Array) -> Array:
        return self._body_rates(q, qd, qdd)[0]

    def body_momentum_rates(self, q: Array, qd: Array, qdd: Array) -> Array:
        return self._body_rates(q, qd, qdd)[1]

    # ---- constraints --------------------------------------------------------------------------------
    def _rows(self, q: Array, pose: Pose | None = None) -> tuple[Array, Array]:
        """f(q) (..., rows) and J(q) (..., rows, n) at (possibly complex) configurations; ``pose``: their pose
        where already computed."""
        tree = self.tree
        batch = q.shape[:-1]
        dtype = np.result_type(q.dtype, float)
        f = np.zeros((*batch, self.rows), dtype=dtype, like=q)
        jac = np.zeros((*batch, self.rows, tree.n), dtype=dtype, like=q)
        if not tree.equalities:
            return f, jac
        if pose is None:
            pose = forward(tree, self.layout, q)
        bodies, offsets, sides = self._anchors
        anchors = None
        if bodies.size:  # every anchor's position and Jacobians at once
            x = points_on(pose, bodies, offsets)
            anchors = (x, *point_jacobians(pose, self.layout, bodies, x))
        start = 0
        for eq, (i1, i2) in zip(tree.equalities, sides, strict=True):
            if eq.kind in ("connect", "weld"):
                p1, l1, a1, r1 = self._anchor(pose, batch, eq.body1, eq.anchor1, anchors, i1)
                p2, l2, a2, r2 = self._anchor(pose, batch, eq.body2, eq.anchor2, anchors, i2)
                f[..., start:start + 3] = p1 - p2
                jac[..., start:start + 3, :] = l1 - l2
                if eq.kind == "weld":
                    s = r1 @ quat_to_mat(eq.frame1) @ quat_to_mat(eq.relquat)
                    e = np.swapaxes(s, -1, -2) @ r2 @ quat_to_mat(eq.frame2)  # I when the weld holds
                    # E's quaternion (w, v), w = ½√(1 + tr E) (analytic near a weld that holds), v = vec part
                    w = 0.5 * np.sqrt(1.0 + np.trace(e, axis1=-2, axis2=-1))
                    v = vee(e - np.swapaxes(e, -1, -2)) / (4.0 * w[..., None])
                    # the rows are those of Eᵀ's quaternion, (w, −v): MuJoCo's (checked row by row, tests/test_tree.py)
                    f[..., start + 3:start + 6] = -eq.torquescale * v
                    # Ė = [u]× E with u = Sᵀ(ω₂ − ω₁), so q̇_E = ½ (0, u) ⊗ q_E and v̇ = ½ (w I − [v]×) u
                    lead = -0.5 * eq.torquescale * (w[..., None, None] * np.eye(3) - skew(v))
                    jac[..., start + 3:start + 6, :] = lead @ np.swapaxes(s, -1, -2) @ (a2 - a1)
            else:
                assert eq.y is not None  # a joint or tendon equality has its row y
                y = q @ eq.y - eq.y0
                s = q @ eq.x - eq.x0 if eq.x is not None else np.zeros(batch, dtype=dtype)
                poly = eq.poly
                f[..., start] = y - sum(a * s ** k for k, a in enumerate(poly))
                slope = cast(Array, sum(k * a * s ** (k - 1) for k, a in enumerate(poly) if k >= 1))  # (or duals)
                jac[..., start, :] = eq.y - (slope[..., None] * eq.x if eq.x is not None else 0.0)
            start += eq.rows
        return f, jac

    @cached_property
    def _anchors(self) -> tuple[Array, Array, tuple[tuple[int, int], ...]]:
        """The connects' and welds' anchors on bodies (not on the world, body −1): their bodies (k,) and offsets (k, 3),
        and per equality the index of its two anchors among them (−1: on the world, or no anchor)."""
        bodies: list[int] = []
        offsets: list[Array] = []
        sides: list[tuple[int, int]] = []
        for eq in self.tree.equalities:
            pair = [-1, -1]
            if eq.kind in ("connect", "weld"):
                for side, (body, offset) in enumerate(((eq.body1, eq.anchor1), (eq.body2, eq.anchor2))):
                    if body >= 0:
                        pair[side] = len(bodies)
                        bodies.append(body)
                        offsets.append(np.asarray(offset, dtype=float))
            sides.append((pair[0], pair[1]))
        return np.array(bodies, dtype=int), np.array(offsets, dtype=float).reshape(-1, 3), tuple(sides)

    def _anchor(self, pose: Pose, batch: tuple[int, ...], body: int, offset: Array,
                anchors: tuple[Array, Array, Array] | None, i: int) -> tuple[Array, Array, Array, Array]:
        """A body-fixed point's world position, its linear and the body's angular Jacobian, and the body's
        rotation, the i-th of ``anchors`` (positions, linear and angular Jacobians); the world (body −1) stands
        still."""
        if body < 0:
            zero = np.zeros((*batch, 3, self.tree.n))
            return np.broadcast_to(offset, (*batch, 3)), zero, zero, np.broadcast_to(np.eye(3), (*batch, 3, 3))
        assert anchors is not None  # computed wherever an equality has an anchor on a body
        x, lin, ang = anchors
        return x[..., i, :], lin[..., i, :, :], ang[..., i, :, :], pose.rotation[..., body, :, :]

    def jacobian(self, q: Array) -> Array:
        return self._rows(np.asarray(q, dtype=float))[1]

    def position_residual(self, q: Array) -> Array:
        return self._rows(np.asarray(q, dtype=float))[0]

    def velocity_residual(self, q: Array, qd: Array) -> Array:
        return np.einsum("...ij,...j->...i", self.jacobian(q), np.asarray(qd, dtype=float))

    def constraint_terms(self, q: Array, qd: Array, *, stabilization: tuple[float, float] = (0.0, 0.0)
                         ) -> tuple[Array, Array]:
        """J, and γ − α Jq̇ − β f, from one pass of the kinematics at q + i h q̇: its real parts are f(q) and
        J(q) (the step's h² terms vanish below round-off), its imaginary part J̇q̇ h."""
        q, qd = np.broadcast_arrays(np.asarray(q, dtype=float), np.asarray(qd, dtype=float))
        return self._constraint_terms(qd, *self._rows(q + 1j * STEP * qd), stabilization=stabilization)

    @staticmethod
    def _constraint_terms(qd: Array, f: Array, jac: Array, *, stabilization: tuple[float, float]
                          ) -> tuple[Array, Array]:
        """J and γ − α Jq̇ − β f from f and J at q + i h q̇."""
        real = jac.real
        gamma = -np.einsum("...ij,...j->...i", jac.imag, qd) / STEP
        alpha, beta = stabilization
        if alpha or beta:
            gamma = gamma - alpha * np.einsum("...ij,...j->...i", real, qd) - beta * f.real
        return real, gamma

    def gamma(self, q: Array, qd: Array) -> Array:
        q, qd = np.broadcast_arrays(np.asarray(q, dtype=float), np.asarray(qd, dtype=float))
        jac = self._rows(q + 1j * STEP * qd)[1]
        return -np.einsum("...ij,...j->...i", jac.imag, qd) / STEP

    def checked(self) -> TreeDynamics:
        q = np.zeros(self.n)
        self.accelerations(q, q)
        return self

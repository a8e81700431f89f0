"""A kinematic tree as plain data: what the tree reference's Lagrangian is built from.

Nothing here knows MuJoCo: the description is read from a compiled model on
the harness side (:mod:`harness.reference.tree`) and could as well come from a
URDF. Frames follow MuJoCo's compiled model: each body's frame is placed in
its parent's by (``pos``, ``quat``) at the reference configuration; a joint's
anchor ``pos`` and ``axis`` are in its body's frame; a body's inertial frame
is (``ipos``, ``iquat``) in the body frame with principal moments ``inertia``.

Coordinates (one per degree of freedom, in MuJoCo's dof order):

- hinge: the joint's qpos, an angle about ``axis`` measured from ``ref``
  (the body sits as placed when qpos = ref); slide: qpos, a displacement
  along ``axis`` from ``ref``;
- ball: a rotation vector θ (3 coordinates ``NAME_rx``, ``NAME_ry``,
  ``NAME_rz``) with the joint's rotation R = R₀ Exp(θ), R₀ = ``chart`` (the
  orientation where θ = 0); qvel = J_r(θ) θ̇ is the body-frame angular velocity;
- free: the body origin's world position (``NAME_x``, ``NAME_y``, ``NAME_z``;
  qvel: its world velocity) and a rotation vector as for ball.
"""

from __future__ import annotations

import hashlib
import pickle
from dataclasses import dataclass, field

import numpy as np

from analytic.tree.terms import Term

__all__ = ["BALL", "FREE", "HINGE", "SLIDE", "Actuator", "Body", "Equality", "ForceLimit", "Joint", "Point",
           "TendonLimit", "Tree"]

HINGE, SLIDE, BALL, FREE = "hinge", "slide", "ball", "free"
DOFS = {HINGE: 1, SLIDE: 1, BALL: 3, FREE: 6}


@dataclass(frozen=True)
class Joint:
    """One joint: its kind, body, anchor and axis in the body frame, and its passive parameters.

    ``terms`` are what the joint adds to the potential (:mod:`analytic.tree.terms`: its spring).
    ``damping`` is MuJoCo's polynomial (a, b, c): f(v) = −(a v + b v|v| + c v³) per dof.
    ``chart`` is the reference orientation R₀ (w, x, y, z) of a ball or free joint's rotation vector.
    ``gravcomp`` says where the bodies' gravity compensation on this joint's dofs goes: ``passive`` (a passive
    force), ``actuator`` (added to the actuators' force before the joint's :class:`ForceLimit` clamps it: MuJoCo's
    ``actuatorgravcomp``) or ``off`` (nowhere: routed to actuators in a model whose actuation is off).
    """

    name: str
    kind: str
    body: int
    dof: int
    pos: np.ndarray
    axis: np.ndarray
    ref: float = 0.0
    terms: tuple[Term, ...] = ()
    damping: tuple[float, float, float] = (0.0, 0.0, 0.0)
    armature: float = 0.0
    chart: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 0.0]))
    gravcomp: str = "passive"

    @property
    def ndof(self) -> int:
        return DOFS[self.kind]

    @property
    def coordinates(self) -> tuple[str, ...]:
        if self.kind == BALL:
            return tuple(f"{self.name}_r{a}" for a in "xyz")
        if self.kind == FREE:
            return (*(f"{self.name}_{a}" for a in "xyz"), *(f"{self.name}_r{a}" for a in "xyz"))
        return (self.name,)


@dataclass(frozen=True)
class Body:
    """A rigid body: its parent (−1 for the world's children), its frame in the parent's at the reference
    configuration, its inertial frame and principal moments, and the joints that move it (in order)."""

    name: str
    parent: int
    pos: np.ndarray
    quat: np.ndarray
    ipos: np.ndarray
    iquat: np.ndarray
    mass: float
    inertia: np.ndarray
    joints: tuple[int, ...] = ()
    gravcomp: float = 0.0


@dataclass(frozen=True)
class Point:
    """A named body-fixed point (a site, or a body's centre of mass): ``pos`` in the body's frame."""

    name: str
    body: int
    pos: np.ndarray


@dataclass(frozen=True)
class Equality:
    """An equality constraint, as a block of rows f(q) = 0.

    kinds: ``connect`` (3 rows: world anchor on body1 − world anchor on body2; ``anchor1``/``anchor2`` in
    their bodies' frames); ``weld`` (6 rows: the anchors as for connect, then ``torquescale`` × the vector part of
    the quaternion of Eᵀ, E = (R₁ F₁ R_rel)ᵀ R₂ F₂, which is the identity when body2 sits at ``relquat`` in body1:
    MuJoCo's weld, row for row, so that its rows and multipliers compare one by one; F₁, F₂ = ``frame1``,
    ``frame2`` the weld's frames in the bodies, the sites' where it welds sites, else the bodies'); ``joint`` and
    ``tendon``
    (1 row: y − y₀ − Σₖ aₖ (x − x₀)ᵏ with y, x linear in the coordinates: ``y``/``x`` are the
    coefficient vectors, ``y0``/``x0`` their reference values, ``poly`` the a₀…a₄).
    """

    name: str
    kind: str
    body1: int = -1
    body2: int = -1
    anchor1: np.ndarray = field(default_factory=lambda: np.zeros(3))
    anchor2: np.ndarray = field(default_factory=lambda: np.zeros(3))
    relquat: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 0.0]))
    torquescale: float = 1.0
    frame1: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 0.0]))
    frame2: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 0.0]))
    y: np.ndarray | None = None
    x: np.ndarray | None = None
    y0: float = 0.0
    x0: float = 0.0
    poly: tuple[float, ...] = (0.0, 1.0, 0.0, 0.0, 0.0)

    @property
    def rows(self) -> int:
        return {"connect": 3, "weld": 6}.get(self.kind, 1)


@dataclass(frozen=True)
class Actuator:
    """An actuator with an affine force at a fixed control: force = (g₀ + g₁ l + g₂ l̇) ctrl + b₀ + b₁ l + b₂ l̇,
    with length l = moment · q (a joint's or a fixed tendon's transmission, linear in the coordinates; the moment
    carries the gear), clamped to ``forcerange`` (lo, hi) where it has one, and the generalized force
    moment × force."""

    name: str
    moment: np.ndarray
    gain: tuple[float, float, float]
    bias: tuple[float, float, float]
    ctrl: float = 0.0
    length0: float = 0.0
    forcerange: tuple[float, float] | None = None


@dataclass(frozen=True)
class ForceLimit:
    """A joint's clamp on the total generalized force of every actuator on its dof (MuJoCo's joint
    ``actuatorfrcrange``), applied after the actuators' forces are clamped and summed: the actuators' force on
    coordinate ``dof`` is clipped to [``lo``, ``hi``]."""

    name: str
    dof: int
    lo: float
    hi: float


@dataclass(frozen=True)
class TendonLimit:
    """A tendon's clamp on the total force of the actuators pulling it (MuJoCo's tendon ``actuatorfrcrange``), applied
    before each actuator's own force range: where their summed force T leaves [``lo``, ``hi``], each actuator's force
    (``actuators``: indices into :attr:`Tree.actuators`) is scaled by the end over T."""

    name: str
    actuators: tuple[int, ...]
    lo: float
    hi: float


@dataclass(frozen=True)
class Tree:
    """The whole description: bodies in an order where every parent precedes its children, the joints,
    gravity, named points, equality constraints and actuators."""

    bodies: tuple[Body, ...]
    joints: tuple[Joint, ...]
    gravity: np.ndarray
    points: tuple[Point, ...] = ()
    equalities: tuple[Equality, ...] = ()
    actuators: tuple[Actuator, ...] = ()
    limits: tuple[ForceLimit, ...] = ()
    """The joints' clamps on their actuators' summed force, applied after :attr:`actuators` are summed."""
    tendon_limits: tuple[TendonLimit, ...] = ()
    """The tendons' clamps on their actuators' summed force, applied before each actuator's own force range."""
    size: float = 0.0
    """The mean size of the bodies (the length scale where the bodies' layout gives none: a lone point mass)."""

    def __post_init__(self) -> None:
        for i, b in enumerate(self.bodies):
            if not -1 <= b.parent < i:
                raise ValueError(f"body {b.name!r}: its parent must come before it")
        if not self.joints:
            raise ValueError("the tree has no joints: nothing moves")

    @property
    def coordinates(self) -> tuple[str, ...]:
        return tuple(c for j in self.joints for c in j.coordinates)

    @property
    def n(self) -> int:
        return sum(j.ndof for j in self.joints)

    @property
    def quaternion_joints(self) -> tuple[int, ...]:
        return tuple(i for i, j in enumerate(self.joints) if j.kind in (BALL, FREE))

    def digest(self) -> str:
        """A fingerprint of every number and index in the description (what a cached solve is keyed by)."""
        return hashlib.sha256(pickle.dumps(self, protocol=4)).hexdigest()[:16]

    def params(self) -> dict[str, float]:
        """Every number the physics depends on, by a readable name (what the report lists as changed)."""
        out: dict[str, float] = {f"gravity.{a}": float(g) for a, g in zip("xyz", self.gravity, strict=True)}
        for b in self.bodies:
            out[f"{b.name}.mass"] = float(b.mass)
            out |= {f"{b.name}.inertia.{k}": float(v) for k, v in enumerate(b.inertia)}
            out |= {f"{b.name}.ipos.{k}": float(v) for k, v in enumerate(b.ipos)}
            out |= {f"{b.name}.iquat.{k}": float(v) for k, v in enumerate(b.iquat)}
            out |= {f"{b.name}.pos.{k}": float(v) for k, v in enumerate(b.pos)}
            out |= {f"{b.name}.quat.{k}": float(v) for k, v in enumerate(b.quat)}
            if b.gravcomp:
                out[f"{b.name}.gravcomp"] = float(b.gravcomp)
        for j in self.joints:
            out |= {f"{j.name}.pos.{k}": float(v) for k, v in enumerate(j.pos)}
            out |= {f"{j.name}.axis.{k}": float(v) for k, v in enumerate(j.axis)}
            out[f"{j.name}.ref"] = float(j.ref)
            for term in j.terms:
                out |= term.params(j.name)
            # every joint has the rows of a spring, 0 where it has none: the same rows for every kind of joint
            out |= {f"{j.name}.{key}": 0.0 for key in ("stiffness", "springref") if f"{j.name}.{key}" not in out}
            out[f"{j.name}.armature"] = float(j.armature)
            out |= {f"{j.name}.damping.{k}": float(v) for k, v in enumerate(j.damping)}
            if j.gravcomp != "passive":
                out[f"{j.name}.gravcomp_to_actuator"] = float(j.gravcomp == "actuator")
        for a in self.actuators:
            out |= {f"actuator.{a.name}.gain.{k}": float(v) for k, v in enumerate(a.gain)}
            out |= {f"actuator.{a.name}.bias.{k}": float(v) for k, v in enumerate(a.bias)}
            out[f"actuator.{a.name}.ctrl"] = float(a.ctrl)
            if a.forcerange is not None:
                out |= {f"actuator.{a.name}.forcerange.{k}": float(v) for k, v in enumerate(a.forcerange)}
        limits: tuple[ForceLimit | TendonLimit, ...] = (*self.limits, *self.tendon_limits)
        for lim in limits:
            out |= {f"{lim.name}.actuatorfrcrange.0": float(lim.lo), f"{lim.name}.actuatorfrcrange.1": float(lim.hi)}
        return out

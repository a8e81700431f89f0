"""Equations of motion from a Lagrangian, with constraints through multipliers.

The convention used everywhere in mjharness (design.md, "Conventions"):

    M(q) q̈ = F(q, q̇) + Jᵀ(q) λ,        J q̈ = γ(q, q̇)

where the constraint rows are either holonomic, f(q) = 0 with J = ∂f/∂q, or
Pfaffian, A(q) q̇ + b(q) = 0 with J = A.  With L = T − V,

    M = ∂²T/∂q̇∂q̇,    F = ∂L/∂q − (∂/∂q (∂T/∂q̇)) q̇,    γ = −(∂(J q̇ + b)/∂q) q̇.

This is MuJoCo's own sign convention (``qfrc_constraint = Jᵀ efc_force``), so a
multiplier and the ``efc_force`` of the equality it models are the same number
when both sides write the constraint with the same scaling.

The class follows sympy's ``LagrangesMethod``: inputs are validated in
``__init__``, :meth:`LagrangianSystem.derive` does the work once, results are
properties of the returned :class:`Derivation`.
"""

from __future__ import annotations

import contextlib
import importlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Literal

import sympy as sp

from analytic.rigid import RigidBody

__all__ = ["Constraint", "Derivation", "LagrangianSystem", "coordinates", "preload"]

ConstraintKind = Literal["holonomic", "pfaffian"]


# sympy modules a first derivation imports lazily: the tensor module on the first sum (Add.flatten),
# physics.units on the first simplify, the code printers on the first lambdify: a cost each process pays once
_LAZY = ("sympy.tensor.tensor", "sympy.physics.units", "sympy.codegen.ast", "sympy.printing.numpy",
         "sympy.assumptions.wrapper", "sympy.sets.setexpr")


def preload() -> None:
    """Import what a first derivation would import on its way (see ``_LAZY``), so that a process that
    forks workers to derive pays for it once instead of in every worker side by side. A name a
    later sympy no longer has is skipped: this only moves work earlier."""
    for name in _LAZY:
        with contextlib.suppress(ImportError):
            importlib.import_module(name)


# Above this many operations (sympy's count_ops of the entry as derived) an entry is not given to
# simplify: simplify tries every strategy it has and its cost grows much faster than the expression
# (a cold derivation of welded_pendulum's 7 coordinates and quaternion rows spent nearly all of its time in
# simplify: docs/findings/speed.md). Such an entry is kept as derived or expanded, whichever is shorter: the
# same expression, written longer, which only the numbers use (lambdified with common subexpressions). The
# small systems' entries stay below it and keep simplify's exact forms, which their tests compare and the
# report shows.
SIMPLIFY_MAX_OPS = 150


def tidy(expr: sp.Expr) -> sp.Expr:
    """``expr`` simplified by :func:`sympy.simplify` if it is small (≤ ``SIMPLIFY_MAX_OPS``
    operations), else the shorter of ``expr`` and its expansion (see ``SIMPLIFY_MAX_OPS``)."""
    expr = sp.sympify(expr)
    ops = sp.count_ops(expr)
    if ops <= SIMPLIFY_MAX_OPS:
        return sp.simplify(expr)
    expanded = sp.expand(expr)
    return expanded if sp.count_ops(expanded) < ops else expr


def _tidied(matrix: sp.Matrix) -> sp.Matrix:
    return matrix.applyfunc(tidy)


def coordinates(names: str) -> tuple[tuple[sp.Symbol, ...], tuple[sp.Symbol, ...]]:
    """Real symbols for generalized coordinates and their velocities.

    ``coordinates("theta r")`` gives ``((theta, r), (theta_dot, r_dot))``.
    """
    q = sp.symbols(names, real=True, seq=True)
    qd = tuple(sp.Symbol(f"{s.name}_dot", real=True) for s in q)
    return tuple(q), qd


@dataclass(frozen=True)
class Constraint:
    """One named constraint: a single row, or a block of rows held together.

    holonomic: ``expr`` is f(q), held at f = 0; J = ∂f/∂q.
    pfaffian:  ``expr`` is A(q)·q̇ + b(q), linear in the velocities; J = A.
    ``expr`` may be a sequence: a block of rows under one name, each with its
    own multiplier, as MuJoCo keeps one equality's rows together (a
    ``connect`` has 3: the world x, y, z components of anchor1 − anchor2, in
    that order; a ``weld`` 6). The name is the one the MJCF equality (or
    contact) carries; it may not contain a dot (it is part of figure names).
    """

    name: str
    expr: sp.Expr | Sequence[sp.Expr]
    kind: ConstraintKind = "holonomic"

    @property
    def rows(self) -> tuple[sp.Expr, ...]:
        """The constraint's rows, each a scalar expression (one for a scalar ``expr``)."""
        if isinstance(self.expr, sp.MatrixBase | list | tuple):
            return tuple(sp.sympify(e) for e in self.expr)
        return (sp.sympify(self.expr),)

    @property
    def size(self) -> int:
        return len(self.rows)


class LagrangianSystem:
    """A mechanical system given by T, V, coordinates and constraints.

    Args:
        name: the system name, shared with ``mjcf/NAME.xml`` and the test id.
        q, qd: coordinate and velocity symbols (see :func:`coordinates`).
        kinetic: T(q, q̇), quadratic in q̇.
        potential: V(q).
        params: symbols of physical parameters, bound to numbers later.
        constraints: holonomic or Pfaffian rows, with their names.
        points: named world positions (x, y, z) of material points, the
            observables compared with MuJoCo bodies of the same name.
        bodies: the system's bodies by the name of the MuJoCo body each is
            (:class:`analytic.rigid.RigidBody`, or :func:`analytic.rigid.point_mass`):
            mass, centre of mass, inertia and orientation, what the reaction
            forces at an attachment are made of (:mod:`analytic.reactions`).
            Optional; where given, their kinetic energies add up to T
            (``tests/test_reactions.py`` checks every shipped system's).
    """

    def __init__(
        self,
        *,
        name: str,
        q: Sequence[sp.Symbol],
        qd: Sequence[sp.Symbol],
        kinetic: sp.Expr,
        potential: sp.Expr,
        params: Sequence[sp.Symbol],
        constraints: Sequence[Constraint] = (),
        points: Mapping[str, Sequence[sp.Expr]] | None = None,
        bodies: Mapping[str, RigidBody] | None = None,
    ) -> None:
        if len(q) == 0 or len(q) != len(qd):
            raise ValueError(f"q and qd must be non-empty and of equal length, got {len(q)}, {len(qd)}")
        allowed = set(q) | set(qd) | set(params)
        for label, expr in [("kinetic", kinetic), ("potential", potential)]:
            stray = sp.sympify(expr).free_symbols - allowed
            if stray:
                raise ValueError(f"{label} has symbols that are neither coordinates nor params: {stray}")
        if sp.sympify(potential).free_symbols & set(qd):
            raise ValueError("potential must not depend on velocities")
        names = [c.name for c in constraints]
        if len(set(names)) != len(names):
            raise ValueError(f"constraint names must be unique, got {names}")
        for label in names:
            if not label or "." in label:
                raise ValueError(f"a constraint name must be non-empty and contain no dot, got {label!r}")
        for c in constraints:
            _validate_constraint(c, q, qd)
        self.name = name
        self.q = tuple(q)
        self.qd = tuple(qd)
        self.kinetic = sp.sympify(kinetic)
        self.potential = sp.sympify(potential)
        self.params = tuple(params)
        self.constraints = tuple(constraints)
        self.points = {k: tuple(sp.sympify(e) for e in v) for k, v in (points or {}).items()}
        self.bodies = dict(bodies or {})
        for key, body in self.bodies.items():
            stray = (sp.sympify(body.mass).free_symbols | body.inertia.free_symbols | body.com.free_symbols
                     | body.rotation.free_symbols) - set(q) - set(params)
            if stray:
                raise ValueError(f"body {key!r} has symbols that are neither coordinates nor params: {stray}")
        for key, pos in self.points.items():
            if len(pos) != 3:
                raise ValueError(f"point {key!r} must have 3 components, got {len(pos)}")

    @property
    def lagrangian(self) -> sp.Expr:
        return self.kinetic - self.potential

    def derive(self) -> Derivation:
        """Derive the equations of motion (symbolic; see :class:`Derivation`)."""
        return Derivation(self)

    def reduce(
        self,
        *,
        q: Sequence[sp.Symbol],
        qd: Sequence[sp.Symbol],
        embedding: Mapping[sp.Symbol, sp.Expr],
        name: str | None = None,
    ) -> LagrangianSystem:
        """The same system in minimal coordinates s, through q = φ(s).

        Every holonomic constraint must hold identically under the embedding;
        a Pfaffian one cannot be eliminated this way and raises ValueError.
        """
        if set(embedding) != set(self.q):
            raise ValueError(f"embedding must give every coordinate {self.q}, got {tuple(embedding)}")
        phi = [sp.sympify(embedding[qi]) for qi in self.q]
        vel = [sum(sp.diff(p, s) * sd for s, sd in zip(q, qd, strict=True)) for p in phi]
        subs = dict(zip(self.q, phi, strict=True)) | dict(zip(self.qd, vel, strict=True))
        for c in self.constraints:
            if c.kind != "holonomic" or any(sp.simplify(row.subs(subs)) != 0 for row in c.rows):
                raise ValueError(f"constraint {c.name!r} does not vanish identically under the embedding")
        return LagrangianSystem(
            name=name or f"{self.name}_minimal",
            q=q,
            qd=qd,
            kinetic=sp.simplify(self.kinetic.subs(subs)),
            potential=sp.simplify(self.potential.subs(subs)),
            params=self.params,
            points={k: [sp.simplify(e.subs(subs)) for e in v] for k, v in self.points.items()},
            bodies={k: RigidBody(mass=b.mass, inertia=b.inertia, com=sp.simplify(b.com.subs(subs)),
                                 rotation=sp.simplify(b.rotation.subs(subs))) for k, b in self.bodies.items()},
        )


def _validate_constraint(c: Constraint, q: Sequence[sp.Symbol], qd: Sequence[sp.Symbol]) -> None:
    if c.kind not in ("holonomic", "pfaffian"):
        raise ValueError(f"constraint kind must be 'holonomic' or 'pfaffian', got {c.kind!r}")
    if not c.rows:
        raise ValueError(f"constraint {c.name!r} has no rows")
    for expr in c.rows:
        if c.kind == "holonomic" and expr.free_symbols & set(qd):
            raise ValueError(f"holonomic constraint {c.name!r} must not involve velocities")
        if c.kind == "pfaffian" and any(sp.diff(expr, v, 2) != 0 for v in qd):
            raise ValueError(f"Pfaffian constraint {c.name!r} must be linear in velocities")


class Derivation:
    """Symbolic results for one :class:`LagrangianSystem`, computed lazily once."""

    def __init__(self, system: LagrangianSystem) -> None:
        self.system = system

    @cached_property
    def mass_matrix(self) -> sp.Matrix:
        s = self.system
        return _tidied(sp.hessian(s.kinetic, s.qd))

    @cached_property
    def forcing(self) -> sp.Matrix:
        """F in M q̈ = F + Jᵀλ: generalized forces minus velocity-product terms."""
        s = self.system
        lag = s.lagrangian
        p = sp.Matrix([sp.diff(s.kinetic, v) for v in s.qd])
        qd = sp.Matrix(s.qd)
        dl_dq = sp.Matrix([sp.diff(lag, c) for c in s.q])
        return _tidied(dl_dq - p.jacobian(s.q) * qd)

    @cached_property
    def constraint_rows(self) -> sp.Matrix:
        """J q̇ + b for every row: the velocity-level constraint (zero when satisfied)."""
        s = self.system
        rows = []
        for c in s.constraints:
            for expr in c.rows:
                if c.kind == "holonomic":
                    rows.append(sum(sp.diff(expr, qi) * vi for qi, vi in zip(s.q, s.qd, strict=True)))
                else:
                    rows.append(expr)
        return sp.Matrix(rows) if rows else sp.zeros(0, 1)

    @cached_property
    def jacobian(self) -> sp.Matrix:
        s = self.system
        if not s.constraints:
            return sp.zeros(0, len(s.q))
        return _tidied(self.constraint_rows.jacobian(s.qd))

    @cached_property
    def gamma(self) -> sp.Matrix:
        """γ with J q̈ = γ, from differentiating J q̇ + b = 0 once in time."""
        s = self.system
        if not s.constraints:
            return sp.zeros(0, 1)
        return _tidied(-self.constraint_rows.jacobian(s.q) * sp.Matrix(s.qd))

    @cached_property
    def holonomic_residual(self) -> sp.Matrix:
        """f(q) for holonomic rows (0 for Pfaffian rows, which have no position form)."""
        s = self.system
        if not s.constraints:
            return sp.zeros(0, 1)
        return sp.Matrix([expr if c.kind == "holonomic" else 0 for c in s.constraints for expr in c.rows])

    @cached_property
    def energy(self) -> sp.Expr:
        return tidy(self.system.kinetic + self.system.potential)

    @cached_property
    def momenta(self) -> sp.Matrix:
        """Generalized momenta p_k = ∂L/∂q̇_k."""
        s = self.system
        return sp.Matrix([tidy(sp.diff(s.lagrangian, v)) for v in s.qd])

    @cached_property
    def cyclic(self) -> tuple[sp.Symbol, ...]:
        """Coordinates absent from L and from every constraint: their momenta are conserved."""
        s = self.system
        jac = self.jacobian
        out = []
        for k, c in enumerate(s.q):
            if any(jac[j, k] != 0 for j in range(jac.rows)):
                continue  # in a constraint: not cyclic, whatever L does
            # simplified: a coordinate can hide in L behind an identity such as sin² + cos² = 1
            if sp.simplify(sp.diff(s.lagrangian, c)) == 0:
                out.append(c)
        return tuple(out)

    @cached_property
    def equations(self) -> sp.Matrix:
        """Lagrange's equations d/dt ∂L/∂q̇ − ∂L/∂q − Jᵀλ (zero on motions), with q̈ and λ symbols."""
        s = self.system
        qdd = sp.Matrix([sp.Symbol(f"{c.name}_ddot", real=True) for c in s.q])
        lam = sp.Matrix(self.multiplier_symbols)
        jt_lam = self.jacobian.T * lam if s.constraints else sp.zeros(len(s.q), 1)
        rows = self.mass_matrix * qdd - self.forcing - jt_lam
        # a sum of parts each already tidied: a small row is simplified again, a large one expanded at most
        return rows.applyfunc(tidy)

    @cached_property
    def multiplier_symbols(self) -> tuple[sp.Symbol, ...]:
        """One per row: ``lambda_NAME`` for a one-row constraint, ``lambda_NAME_I`` (I = 0, 1, …) for a
        block's rows."""
        return tuple(sp.Symbol(f"lambda_{label}", real=True) for label in row_labels(self.system.constraints))


def row_labels(constraints: Sequence[Constraint]) -> tuple[str, ...]:
    """Every constraint row's label: the constraint's name, or ``NAME_I`` for row I of a block."""
    return tuple(c.name if c.size == 1 else f"{c.name}_{i}" for c in constraints for i in range(c.size))

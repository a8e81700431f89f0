"""Our derivation seen in a document's variables, and the symbolic verdict on a claim."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import sympy as sp

from analytic.lagrangian import Derivation
from harness.audit import Claim, Frame

__all__ = ["T_SYMBOL", "DocView", "resolve", "symbolic_check"]

T_SYMBOL = sp.Symbol("t", real=True)


class DocView:
    """Our Lagrangian, energies, solved q̈ and λ, rewritten in a Frame's variables."""

    def __init__(self, derivation: Derivation, frame: Frame) -> None:
        self.derivation = derivation
        self.frame = frame
        s = derivation.system
        if set(frame.to_ours) != {c.name for c in s.q}:
            raise ValueError(f"frame for {frame.system!r} must map every coordinate {[c.name for c in s.q]}")
        self.ours_q = {c.name: c for c in s.q}
        self.ours_qd = dict(zip([c.name for c in s.q], s.qd, strict=True))
        self.ours_qdd = {c.name: sp.Symbol(f"{c.name}_ddot", real=True) for c in s.q}
        self.ours_lam = dict(zip([c.name for c in s.constraints], derivation.multiplier_symbols, strict=True))

    # --- time derivatives in the document's variables
    def ddt(self, expr: sp.Expr) -> sp.Expr:
        f = self.frame
        out = sum(sp.diff(expr, q) * qd for q, qd in zip(f.q, f.qd, strict=True))
        out += sum(sp.diff(expr, qd) * qdd for qd, qdd in zip(f.qd, f.qdd, strict=True))
        return out

    @cached_property
    def to_doc(self) -> dict[sp.Symbol, sp.Expr]:
        """Our q, q̇, q̈ and λ symbols as expressions in the document's variables."""
        subs: dict[sp.Symbol, sp.Expr] = {}
        for name, expr in self.frame.to_ours.items():
            subs[self.ours_q[name]] = expr
            vel = self.ddt(expr)
            subs[self.ours_qd[name]] = vel
            subs[self.ours_qdd[name]] = self.ddt(vel)
        for name, sym in self.ours_lam.items():
            subs[sym] = self.frame.lam_sign.get(name, 1) * self.frame.lam.get(name, sym)
        return subs

    @cached_property
    def to_ours(self) -> dict[sp.Symbol, sp.Expr]:
        """The document's variables as expressions in ours (the inverse map)."""
        f = self.frame
        # solve for stand-ins: a document symbol may be the very symbol of ours it maps to
        stand = {q: sp.Dummy(q.name) for q in f.q}
        eqs = [self.ours_q[n] - sp.sympify(e).subs(stand) for n, e in f.to_ours.items()]
        sol = sp.solve(eqs, list(stand.values()), dict=True)
        if len(sol) != 1:
            raise ValueError(f"frame for {f.system!r} is not invertible")
        q_of = {q: sp.simplify(sol[0][stand[q]]) for q in f.q}
        subs = dict(q_of)
        for q, qd, qdd in zip(f.q, f.qd, f.qdd, strict=True):
            vel = sum(sp.diff(q_of[q], c) * self.ours_qd[n] for n, c in self.ours_q.items())
            acc = sum(sp.diff(vel, self.ours_qd[n]) * self.ours_qdd[n] for n in self.ours_q)
            acc += sum(sp.diff(vel, c) * self.ours_qd[n] for n, c in self.ours_q.items())
            subs[qd], subs[qdd] = vel, acc
        for name, sym in f.lam.items():
            subs[sym] = f.lam_sign.get(name, 1) * self.ours_lam[name]
        return subs

    def doc(self, expr: sp.Expr) -> sp.Expr:
        return sp.sympify(expr).subs(self.to_doc, simultaneous=True)

    @property
    def T(self) -> sp.Expr:
        return self.doc(self.derivation.system.kinetic)

    @property
    def V(self) -> sp.Expr:
        return self.doc(self.derivation.system.potential)

    @property
    def L(self) -> sp.Expr:
        return self.T - self.V

    @cached_property
    def solved(self) -> dict[sp.Symbol, sp.Expr]:
        """q̈ and λ on motions (KKT solved symbolically), in the document's variables."""
        d = self.derivation
        eqs = list(d.equations)
        qdd = [self.ours_qdd[c.name] for c in d.system.q]
        if d.system.constraints:
            eqs += list(d.jacobian * sp.Matrix(qdd) - d.gamma)
        unknowns = qdd + list(d.multiplier_symbols)
        sol = sp.solve(eqs, unknowns, dict=True)
        if len(sol) != 1:
            raise ValueError(f"cannot solve the equations of {d.system.name!r} for q̈, λ")
        ours = {k: sp.simplify(v) for k, v in sol[0].items()}
        out: dict[sp.Symbol, sp.Expr] = {}
        # q̈_doc: invert the linear relation between our q̈ and the document's
        acc_eqs = [self.doc(self.ours_qdd[c.name]) - self.doc(ours[self.ours_qdd[c.name]]) for c in d.system.q]
        acc = sp.solve(acc_eqs, self.frame.qdd, dict=True)
        out.update({k: sp.simplify(v) for k, v in acc[0].items()})
        for name, sym in self.frame.lam.items():
            out[sym] = sp.simplify(self.frame.lam_sign.get(name, 1) * self.doc(ours[self.ours_lam[name]]))
        return out

    # --- the pieces a general display is made of, in the document's variables
    @cached_property
    def rows(self) -> sp.Matrix:
        """Our constraint rows J q̇ + b, in the document's variables."""
        return sp.Matrix([sp.simplify(self.doc(r)) for r in self.derivation.constraint_rows])

    @cached_property
    def xi(self) -> sp.Matrix:
        """The coefficients Ξ_jk of the document's velocities in our constraint rows (row j, column k)."""
        if not self.rows:
            return sp.zeros(0, len(self.frame.q))
        return sp.simplify(self.rows.jacobian(self.frame.qd))

    @property
    def multipliers(self) -> sp.Matrix:
        """The document's multipliers, in the order of our constraints."""
        names = [c.name for c in self.derivation.system.constraints]
        missing = [n for n in names if n not in self.frame.lam]
        if missing:
            raise ValueError(f"frame for {self.frame.system!r} names no multiplier for {missing}")
        return sp.Matrix([self.frame.lam[n] for n in names])

    def lagrange(self, lagrangian: sp.Expr | None = None) -> sp.Matrix:
        """d/dt ∂L/∂q̇_k − ∂L/∂q_k for every document coordinate k (our L unless one is given)."""
        lag = self.L if lagrangian is None else lagrangian
        f = self.frame
        return sp.Matrix([self.ddt(sp.diff(lag, v)) - sp.diff(lag, c) for c, v in zip(f.q, f.qd, strict=True)])

    @property
    def forces(self) -> sp.Matrix:
        """The generalized forces Q_k = −∂V/∂q_k of the potential (the systems have no other forces)."""
        return sp.Matrix([-sp.diff(self.V, c) for c in self.frame.q])

    def on_motion(self, expr: sp.Expr, claim: Claim) -> sp.Expr:
        """Replace q̈, λ by their solved values, then the claim's manifold and approximation."""
        out = sp.sympify(expr).subs(self.solved, simultaneous=True)
        if claim.manifold:
            out = out.subs(claim.manifold, simultaneous=True)
        if claim.approximation:
            out = out.subs(claim.approximation, simultaneous=True)
        return out


def resolve(formula: object, view: DocView) -> sp.Expr | sp.Matrix:
    """A claim's formula: as given, or made from the view where it is a general display's instance."""
    if callable(formula) and not isinstance(formula, sp.Basic | sp.MatrixBase):
        return formula(view)
    return formula


@dataclass(frozen=True)
class SymbolicResult:
    holds: bool
    residual: sp.Expr | sp.Matrix | None
    reason: str = ""


def _vanishes(expr: sp.Expr | sp.Matrix) -> bool:
    if isinstance(expr, sp.MatrixBase):
        return all(_vanishes(e) for e in expr)
    return _vanishes_simplified(sp.simplify(expr))


def _vanishes_simplified(expr: sp.Expr | sp.Matrix) -> bool:
    """:func:`_vanishes` of an expression ``expr`` is already :func:`_simplified` (the first simplify done)."""
    if isinstance(expr, sp.MatrixBase):
        return all(_vanishes_simplified(e) for e in expr)
    return sp.simplify(sp.expand_trig(expr)) == 0


def _simplified(expr: sp.Expr | sp.Matrix) -> sp.Expr | sp.Matrix:
    return expr.applyfunc(sp.simplify) if isinstance(expr, sp.MatrixBase) else sp.simplify(expr)


def _checked(residual: sp.Expr | sp.Matrix) -> SymbolicResult:
    """Whether ``residual`` vanishes, and it simplified: one simplification serves both (it is the costly part)."""
    simplified = _simplified(residual)
    return SymbolicResult(_vanishes_simplified(simplified), simplified)


def symbolic_check(claim: Claim, view: DocView, formula: object = None) -> SymbolicResult:
    """Does ``formula`` (default: the claim as printed) hold against our derivation?"""
    if claim.kind == "statement":
        holds, reason = claim.check(view)  # type: ignore[misc]
        return SymbolicResult(holds, None, reason)
    claimed = resolve(claim.claimed if formula is None else formula, view)
    if isinstance(claimed, sp.Equality):
        claimed = claimed.lhs - claimed.rhs
    claimed = sp.sympify(claimed).subs(claim.aliases, simultaneous=True) if claim.aliases else claimed
    if claim.kind == "equation":
        return _checked(view.on_motion(claimed, claim))
    truth = claim.truth(view)  # type: ignore[misc]
    residual = view.on_motion(claimed - truth, claim)
    if claim.kind == "value_up_to_constant":
        variables = [*view.frame.q, *view.frame.qd]
        return SymbolicResult(all(_vanishes(sp.diff(residual, v)) for v in variables), _simplified(residual))
    return _checked(residual)

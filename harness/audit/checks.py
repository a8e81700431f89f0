"""Statement checks shared by the claims: constraint rows and functions against ours, integrability,
reachable sets, solvability, energy. Each returns (holds, reason) for a :class:`~harness.audit.view.DocView`,
computed from our derivation, never from a hand-typed answer.
"""

from __future__ import annotations

from collections.abc import Sequence

import sympy as sp

from harness.audit import StatementCheck
from harness.audit.view import T_SYMBOL, DocView

__all__ = ["accessible", "conserved", "energy_conserved", "exact", "inequality_bounds_a_region", "on_constraints",
           "position_check", "reachable", "rows_check", "saddle_rank", "solves", "stationary"]


def _solvable(residuals: Sequence[sp.Expr], unknowns: Sequence[sp.Symbol]) -> bool:
    return bool(sp.solve([sp.simplify(e) for e in residuals], list(unknowns), dict=True))


def in_row_span(claimed: sp.Expr, view: DocView) -> bool:
    """Is ``claimed`` (linear in the document's velocities) a combination of our constraint rows?"""
    rows = list(view.rows)
    mu = sp.symbols(f"mu0:{len(rows)}")
    diff = sp.expand(claimed - sum(k * r for k, r in zip(mu, rows, strict=True)))
    qd = view.frame.qd
    eqs = [diff.coeff(v) for v in qd] + [diff.subs({v: 0 for v in qd})]
    if any(sp.diff(diff, v, 2) != 0 for v in qd):
        return False
    return _solvable(eqs, mu)


def rows_check(formula: sp.Expr | sp.Matrix) -> StatementCheck:
    """Every row of ``formula`` (= 0, linear in velocities) is a combination of our constraint rows."""
    def check(view: DocView) -> tuple[bool, str]:
        rows = list(formula) if isinstance(formula, sp.MatrixBase) else [formula]
        holds = all(in_row_span(sp.sympify(r), view) for r in rows)
        return holds, ("a combination of our constraint rows J q̇ + b" if holds
                       else "not in the span of our constraint rows J q̇ + b")
    return check


def position_check(formula: sp.Expr | sp.Matrix) -> StatementCheck:
    """Every f of ``formula`` (= 0 up to its unknown constants) is a combination of our holonomic constraints."""
    def check(view: DocView) -> tuple[bool, str]:
        d = view.derivation
        ours = [view.doc(c.expr) for c in d.system.constraints if c.kind == "holonomic"]
        known = {*view.frame.q, *d.system.params}
        fs = list(formula) if isinstance(formula, sp.MatrixBase) else [sp.sympify(formula)]
        holds = True
        for f in fs:
            mu = sp.symbols(f"mu0:{len(ours)}")
            diff = sp.expand(f - sum(k * g for k, g in zip(mu, ours, strict=True)))
            constants = diff.free_symbols - known - set(mu)
            rest = diff.subs({c: 0 for c in constants})
            if rest == 0:
                continue
            # the remainder must vanish for every configuration: all its coefficients in q (polynomial f only)
            holds = holds and _solvable(sp.Poly(rest, *view.frame.q).coeffs(), mu)
        return holds, ("a combination of our holonomic constraints f(q) = 0 (up to the stated constant)" if holds
                       else "not a combination of our holonomic constraints")
    return check


def exact(row: sp.Expr) -> StatementCheck:
    """The Pfaffian row Σ A_k dq_k is exact (closed: ∂A_i/∂q_j = ∂A_j/∂q_i), so it integrates to f(q) = c."""
    def check(view: DocView) -> tuple[bool, str]:
        f = view.frame
        coeffs = [sp.diff(row, v) for v in f.qd]
        asym = [sp.simplify(sp.diff(coeffs[i], f.q[j]) - sp.diff(coeffs[j], f.q[i]))
                for i in range(len(f.q)) for j in range(i)]
        holds = all(a == 0 for a in asym)
        return holds, ("its coefficients are constant (closed and exact): it integrates to f(q) = constant"
                       if holds else "not closed: no function f(q) has it as its differential")
    return check


def _bracket(x: sp.Matrix, y: sp.Matrix, q: Sequence[sp.Symbol]) -> sp.Matrix:
    return sp.simplify(y.jacobian(q) * x - x.jacobian(q) * y)


def reachable(view: DocView, depth: int = 3) -> tuple[int, int, int]:
    """(allowed directions, directions reachable by combining them, coordinates), in our coordinates.

    The allowed velocities are the null space of J; Lie brackets of them give the directions reachable by
    wiggling along them (Chow–Rashevskii). Holonomic rows leave the rank unchanged (Frobenius: the
    allowed directions are tangent to a surface); nonholonomic rows let the brackets reach further.
    """
    d = view.derivation
    q = list(d.system.q)
    fields = [sp.simplify(v) for v in d.jacobian.nullspace(simplify=True)]
    allowed = len(fields)
    span = list(fields)
    frontier = list(fields)
    for _ in range(depth):
        new = []
        for x in fields:
            for y in frontier:
                b = _bracket(x, y, q)
                if any(e != 0 for e in b) and sp.Matrix.hstack(*span, b).rank(simplify=True) > len(span):
                    span.append(b)
                    new.append(b)
        frontier = new
        if not new:
            break
    return allowed, len(span), len(q)


def accessible(expect_reach: str) -> StatementCheck:
    """"where": the reachable set is as low-dimensional as the allowed velocities; "how": the brackets of
    the allowed velocities reach every coordinate the holonomic rows leave free."""
    def check(view: DocView) -> tuple[bool, str]:
        allowed, reach, n = reachable(view)
        d = view.derivation
        holonomic = sum(c.kind == "holonomic" for c in d.system.constraints)
        if expect_reach == "where":
            holds = reach == allowed
            return holds, (f"{n} coordinates, {allowed} allowed directions, and their brackets add none: the "
                           f"motion stays on a {allowed}-dimensional set fixed by where it starts")
        holds = reach == n - holonomic > allowed
        return holds, (f"{allowed} allowed directions, but with their brackets {reach} of the {n - holonomic} "
                       "coordinates the holonomic rows leave free are reached: every configuration, by some path")
    return check


def saddle_rank(view: DocView) -> tuple[int, int]:
    """(rank, size) of [[M, −Jᵀ], [J, 0]], the linear system for q̈ and λ (n + m unknowns)."""
    d = view.derivation
    n, m = len(d.system.q), d.jacobian.rows
    kkt = sp.Matrix(sp.BlockMatrix([[d.mass_matrix, -d.jacobian.T], [d.jacobian, sp.zeros(m, m)]]))
    return kkt.rank(simplify=True), n + m


def on_constraints(expr: sp.Expr, view: DocView) -> sp.Expr:
    """``expr`` with the velocities the constraint rows fix replaced (rows = 0 solved for some of them)."""
    rows = [r for r in view.rows if r != 0]
    if not rows:
        return expr
    sol = sp.solve(rows, list(view.frame.qd), dict=True)
    return sp.sympify(expr).subs(sol[0], simultaneous=True) if sol else expr


def energy_conserved(view: DocView) -> tuple[bool, str]:
    """d/dt (T + V) vanishes on motions: every force derives from V (no non-conservative Q_k)."""
    rate = view.ddt(view.T + view.V).subs(view.solved, simultaneous=True)
    rate = sp.simplify(on_constraints(sp.simplify(rate), view))
    return rate == 0, "d/dt (T + V) = 0 on motions: the only forces are −∂V/∂q and ideal constraints"


def conserved(expr: sp.Expr) -> StatementCheck:
    """``expr`` (in the document's variables) is constant on motions: its rate vanishes once q̈, λ take
    their solved values and the velocities satisfy the constraint rows."""
    def check(view: DocView) -> tuple[bool, str]:
        rate = sp.simplify(view.ddt(expr).subs(view.solved, simultaneous=True))
        rate = sp.simplify(on_constraints(rate, view))
        return rate == 0, f"d/dt of it on motions: {rate}"
    return check


def stationary(lagrangian: sp.Expr | None = None) -> StatementCheck:
    """The action of ``lagrangian`` (default: ours) is stationary on the true path: ∂L/∂q − d/dt ∂L/∂q̇
    vanishes on motions, so δS = 0 for every δq fixed at the ends."""
    def check(view: DocView) -> tuple[bool, str]:
        residual = sp.simplify(view.lagrange(lagrangian).subs(view.solved, simultaneous=True))
        holds = residual == sp.zeros(*residual.shape)
        return holds, ("∂L/∂q − d/dt ∂L/∂q̇ vanishes on the true path, so δS = 0 for every δq fixed at the ends: "
                       "the action is stationary" if holds else f"∂L/∂q − d/dt ∂L/∂q̇ on the true path: {residual}")
    return check


def solves(path: sp.Expr) -> StatementCheck:
    """``path`` (the document's single coordinate as a function of t) satisfies our Lagrange equation."""
    def check(view: DocView) -> tuple[bool, str]:
        (q,), (qd,), (qdd,) = view.frame.q, view.frame.qd, view.frame.qdd
        on_path = {q: path, qd: sp.diff(path, T_SYMBOL), qdd: sp.diff(path, T_SYMBOL, 2)}
        residual = sp.simplify(view.lagrange()[0].subs(on_path, simultaneous=True))
        return residual == 0, ("it solves our equation of motion" if residual == 0
                               else f"our equation of motion along it leaves {residual}")
    return check


def inequality_bounds_a_region() -> tuple[bool, str]:
    """Whether an inequality constraint is of the holonomic form f(q, t) = 0: it is not. A slack string
    g = l − r ≥ 0 holds strictly at r = l/2, so it holds on a whole neighbourhood there: it removes no
    coordinate, while an equation f = 0 (∇f ≠ 0) leaves a set one dimension lower."""
    r, l = sp.symbols("r l", positive=True)
    interior = bool((l - r).subs(r, l / 2).is_positive)
    return interior, ("an inequality g(q) ≥ 0 (e.g. a slack string, l − r ≥ 0) holds on an open set, not on a "
                      "surface f(q, t) = 0: it removes no coordinate, so it is not holonomic")

"""Claims of seed 000 (Lecture 15), lines 64–85: the general derivation of the method of Lagrange multipliers.

The displays are general (any n coordinates, m constraints Σ_k Ξ_jk δq_k = 0);
each is checked on an instance, the document's own examples: line 64
(independent coordinates, all forces in Q_k) on the spherical pendulum, the
multiplier displays on Atwood's machine (n = 3, m = 2, with z1, z2 the
dependent coordinates k = 1..m and z3 the independent one). An instance applies
the display's operations to our derived T, V, L and constraint rows, in the
document's variables; Q_{k,Δ} (the non-conservative forces) are zero in both.
A display whose operator is missing (a product where a difference is meant) is
instantiated as printed, so the check and the numbers show what it says.
"""

from __future__ import annotations

import sympy as sp

from harness.audit import Claim
from harness.audit.checks import rows_check, saddle_rank
from harness.audit.frames import LECTURE15 as DOC
from harness.audit.frames import atwood_frame, spherical_frame
from harness.audit.view import DocView

__all__ = ["claims"]

SEC = "Constraints – Method of Lagrange Multipliers: general derivation"
PRINTED_XI = sp.Matrix([[1, 0, -1], [0, 1, 1]])  # Atwood's Ξ as line 93 prints it


def _momentum_rates(v: DocView) -> sp.Matrix:
    return sp.Matrix([v.ddt(sp.diff(v.T, qd)) for qd in v.frame.qd])


def _dt_dq(v: DocView) -> sp.Matrix:
    return sp.Matrix([sp.diff(v.T, q) for q in v.frame.q])


def _constraint_forces(v: DocView) -> sp.Matrix:
    """Σ_j λ_j Ξ_jk for every k."""
    return v.xi.T * v.multipliers


def _bracket(v: DocView) -> sp.Matrix:
    """d/dt ∂L/∂q̇_k − ∂L/∂q_k − Q_{k,Δ} − Σ_j λ_j Ξ_jk (Q_{k,Δ} = 0)."""
    return v.lagrange() - _constraint_forces(v)


def _admissible(v: DocView) -> list[sp.Matrix]:
    """Variations δq allowed by the constraints: the null space of Ξ."""
    return [sp.simplify(n) for n in v.xi.nullspace(simplify=True)]


def _as_product(v: DocView) -> sp.Matrix:
    """d/dt(∂L/∂q̇_k) times ∂L/∂q_k, as line 81 prints them side by side."""
    return sp.Matrix([v.ddt(sp.diff(v.L, qd)) * sp.diff(v.L, q) for q, qd in zip(v.frame.q, v.frame.qd,
                                                                                  strict=True)])


def _dependent(v: DocView) -> int:
    return v.xi.rows


def _multiply_check(v: DocView) -> tuple[bool, str]:
    return False, ("as printed the indices do not bind: λ_j stands outside the sum over j, Σ_i sums nothing, "
                   "and k is left free")


def _multiply_intended(v: DocView) -> tuple[bool, str]:
    total = sum((v.multipliers.T * v.xi * n)[0] for n in _admissible(v))
    return sp.simplify(total) == 0, "Σ_j λ_j Σ_k Ξ_jk δq_k = 0 for every admissible δq, whatever the λ_j"


def _independent_rows(v: DocView) -> tuple[bool, str]:
    rank = v.xi.rank(simplify=True)
    return rank == v.xi.rows, f"Atwood's Ξ has rank {rank} = m = {v.xi.rows}"


def _count(v: DocView) -> tuple[bool, str]:
    rank, size = saddle_rank(v)
    return rank == size, (f"[[M, −Ξᵀ], [Ξ, 0]] has rank {rank} = n + m = {size}: the n Lagrange equations and the "
                          "m constraints (differentiated) fix q̈ and λ")


def claims() -> list[Claim]:
    sph, atw = spherical_frame(), atwood_frame()
    general = "d/dt ∂L/∂q̇_k − ∂L/∂q_k = Q_{k,Δ} + Σ_j λ_j Ξ_jk (M q̈ = F + Ξᵀλ)"
    return [
        Claim("000.general.dalembert", DOC, f"{SEC}: independent coordinates",
              r"\sum_{k} \left[Q_k \frac{\mathrm{d}}{\mathrm{d}t} \left(\frac{\partial T}{\partial \dot{q}_k} "
              r"\right) + \frac{\partial T}{\partial q_k} \right] \delta q_k = 0", sph, "equation",
              claimed=lambda v: sp.Matrix([Q * r + t for Q, r, t in zip(v.forces, _momentum_rates(v), _dt_dq(v),
                                                                           strict=True)]),
              intended=lambda v: v.forces - _momentum_rates(v) + _dt_dq(v),
              corrected_text="Σ_k [Q_k − d/dt(∂T/∂q̇_k) + ∂T/∂q_k] δq_k = 0",
              project_text="d/dt ∂T/∂q̇_k − ∂T/∂q_k = Q_k for each k (M q̈ = F)",
              slip="a '−' is missing between Q_k and d/dt(∂T/∂q̇_k): as printed they multiply, which is not "
                   "even a force; lines 69–81 have the difference",
              note="instance: the spherical pendulum (its independent θ, φ), Q_k = −∂V/∂q_k"),
        Claim("000.general.independent_rows", DOC, f"{SEC}: the constraints",
              r"\sum_{k} \Xi_{jk} \delta q_k = 0 \text{ for } j = 1, \dots, m \text{ (linearly independent)}", atw,
              "statement", check=_independent_rows, note="instance: Atwood's machine (line 93)"),
        Claim("000.general.multiply", DOC, f"{SEC}: multiplying by λ_j",
              r"\sum_{i} \lambda_j \sum_{j} \Xi_{jk} \delta q_k = 0", atw, "statement", check=_multiply_check,
              intended_check=_multiply_intended, corrected_text="Σ_j λ_j Σ_k Ξ_jk δq_k = 0",
              project_text="λᵀ Ξ δq = 0 for every δq with Ξ δq = 0",
              slip="the summation indices are swapped: the outer sum must run over j (the constraints) and the "
                   "inner over k (the coordinates), as line 69 has them"),
        Claim("000.general.sum", DOC, f"{SEC}: the combined sum",
              r"\sum_{k=1}^{n} \left[\frac{d}{dt}\frac{\partial L}{\partial \dot{q}_{k}} - \frac{\partial L}"
              r"{\partial q_{k}} - Q_{k, \Delta} - \sum_{j=1}^{m} \lambda_{j} \Xi_{jk} \right] \delta q_{k} = 0",
              atw, "equation", claimed=lambda v: sp.Matrix([_bracket(v).dot(n) for n in _admissible(v)]),
              note="instance: Atwood, δq admissible (Ξ δq = 0); holds whatever the λ_j, as it must"),
        Claim("000.general.choose_lambda", DOC, f"{SEC}: choosing the λ_j",
              r"\frac{d}{dt}\frac{\partial L}{\partial \dot{q}_k} - \frac{\partial L}{\partial q_k} = "
              r"Q_{k,\triangle} + \sum_{j=1}^m \lambda_j \Xi_{jk} \text{ for } k = 1, \ldots, m", atw, "equation",
              claimed=lambda v: _bracket(v)[: _dependent(v), :],
              note="instance: Atwood, k = 1, 2 (z1, z2); possible because that block of Ξ is invertible"),
        Claim("000.general.remaining", DOC, f"{SEC}: the independent coordinates",
              r"\sum_{k=m+1}^{n} \left[\frac{d}{dt}\frac{\partial L}{\partial \dot{q}_k} - \frac{\partial L}"
              r"{\partial q_k} - Q_{k,\triangle} - \sum_{j=1}^{m} \lambda_j \Xi_{jk} \right] \delta q_k = 0", atw,
              "equation", claimed=lambda v: _bracket(v)[_dependent(v):, :],
              note="instance: Atwood, k = 3 (z3), each bracket zero as δz3 is free"),
        Claim("000.general.all_coordinates", DOC, f"{SEC}: for all coordinates",
              r"\frac{d}{dt}\left(\frac{\partial L}{\partial \dot{q}_k}\right) \frac{\partial L}{\partial q_k} = "
              r"Q_{k,\triangle} + \sum_{i=1}^m \lambda_j \Xi_{jk}", atw, "equation",
              claimed=lambda v: _as_product(v) - _constraint_forces(v), intended=_bracket,
              corrected_text=f"{general}, for every k", project_text="M q̈ = F + Jᵀλ",
              slip="a '−' is missing between d/dt(∂L/∂q̇_k) and ∂L/∂q_k (as printed they multiply), and the sum "
                   "runs over i while its terms carry j; lines 75 and 78 have both right"),
        Claim("000.general.count", DOC, f"{SEC}: unknowns and equations",
              "we have n + m unknowns (the q_k and λ_j), which are matched by our n + m equations", atw,
              "statement", check=_count),
        Claim("000.general.velocity_form", DOC, f"{SEC}: Pfaffian form",
              r"\sum_{k=1}^{n} \Xi_{jk} \dot{q}_k + \Xi_{jt} = 0", atw, "statement",
              claimed=PRINTED_XI * sp.Matrix(atw.qd), check=rows_check(PRINTED_XI * sp.Matrix(atw.qd)),
              measure="constraint", note="instance: Atwood's Ξ as line 93 prints it, Ξ_jt = 0 (nothing moves the "
                                         "pulley's axle)"),
    ]

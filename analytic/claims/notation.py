"""Formulas on one line in the documents' notation: θ̇ for theta_dot, λ₁ for lambda1, m l θ̇² for m*l*theta_dot**2.

The audit prints corrected formulas this way (beside the project's form), so a
reader compares them with the printed display rather than with sympy's
``sstr``. Deterministic: sympy's canonical term order, nothing rearranged.
"""

from __future__ import annotations

import sympy as sp
from sympy.printing.precedence import PRECEDENCE
from sympy.printing.str import StrPrinter

_GREEK = {"alpha": "α", "theta": "θ", "phi": "φ", "lambda": "λ", "omega": "ω", "eta": "η", "epsilon": "ε",
          "tau": "τ", "mu": "μ", "pi": "π", "varphi": "ϕ", "Xi": "Ξ"}
_SUB = str.maketrans("0123456789", "₀₁₂₃₄₅₆₇₈₉")
_SUP = str.maketrans("0123456789-", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻")
_DOTS = {"_dot": "\u0307", "_ddot": "\u0308"}


def doc_name(name: str) -> str:
    """``theta_dot`` → θ̇, ``z1_ddot`` → z̈₁, ``lambda2`` → λ₂, ``m_p`` → m_p, ``lambda_string2`` → λ_string2."""
    accent = ""
    for suffix, mark in _DOTS.items():
        if name.endswith(suffix) and name != suffix:
            name, accent = name[: -len(suffix)], mark
    stem = name.rstrip("0123456789")
    digits = name[len(stem):]
    head, sep, tail = stem.partition("_")
    head = _GREEK.get(head, head)
    return head[:1] + accent + head[1:] + sep + tail + (digits if sep else digits.translate(_SUB))


class _DocPrinter(StrPrinter):
    def _print_Symbol(self, expr: sp.Symbol) -> str:
        return doc_name(expr.name)

    _print_Dummy = _print_Symbol

    def _print_Pow(self, expr: sp.Pow, rational: bool = False) -> str:
        exp = expr.exp
        if exp.is_Integer and 2 <= int(exp) <= 9:
            return self.parenthesize(expr.base, PRECEDENCE["Pow"], strict=True) + str(int(exp)).translate(_SUP)
        if exp == sp.S.Half:
            return "√(" + self._print(expr.base) + ")"
        return super()._print_Pow(expr, rational=rational)

    def _print_Pi(self, expr: sp.Expr) -> str:
        return "π"


def doc_text(expr: object) -> str:
    """One line in the documents' notation; an Equality prints as "lhs = rhs", a column as [a, b]."""
    if isinstance(expr, sp.Equality):
        return f"{doc_text(expr.lhs)} = {doc_text(expr.rhs)}"
    if isinstance(expr, sp.MatrixBase):
        return "[" + ", ".join(doc_text(e) for e in expr) + "]"
    return _DocPrinter().doprint(sp.sympify(expr)).replace("*", " ")

"""Formulas on one line in the documents' notation: θ̇ for theta_dot, λ₁ for lambda1, m l θ̇² for m*l*theta_dot**2.

The audit prints corrected formulas this way (beside the project's form), so a
reader compares them with the printed display rather than with sympy's
``sstr``. Deterministic: sympy's canonical term order, nothing rearranged.
"""

from __future__ import annotations

import sympy as sp
from sympy.printing.precedence import PRECEDENCE
from sympy.printing.str import StrPrinter

__all__ = ["doc_text", "latex_text"]

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


# --- the documents' LaTeX as the same one-line notation (for pages that show a display as printed)

_LATEX_SYMBOLS = {
    **{name: ch for name, ch in _GREEK.items() if name != "varphi"}, "varphi": "φ", "beta": "β", "gamma": "γ",
    "delta": "δ", "kappa": "κ", "nu": "ν", "rho": "ρ", "sigma": "σ", "chi": "χ", "psi": "ψ", "zeta": "ζ",
    "Delta": "Δ", "Gamma": "Γ", "Lambda": "Λ", "Omega": "Ω", "Phi": "Φ", "Psi": "Ψ", "Sigma": "Σ", "Theta": "Θ",
    "partial": "∂", "int": "∫", "sum": "Σ", "prod": "Π", "cdot": "·", "times": "×", "pm": "±", "infty": "∞",
    "approx": "≈", "neq": "≠", "ne": "≠", "leq": "≤", "le": "≤", "geq": "≥", "ge": "≥", "to": "→",
    "rightarrow": "→", "Rightarrow": "⇒", "implies": "⇒", "iff": "⇔", "triangle": "Δ", "vartriangle": "Δ",
    "nabla": "∇", "ldots": "…", "dots": "…", "cdots": "⋯", "prime": "′", "rvert": "|", "lvert": "|",
    "vert": "|", "mid": "|", "quad": " ", "qquad": " ", ",": " ", ";": " ", ":": " ", "!": "", " ": " ",
    "\\": " ", "{": "{", "}": "}", "%": "%", "$": "$", "_": "_",
}
_FUNCTIONS = {"sin", "cos", "tan", "cot", "sec", "csc", "sinh", "cosh", "tanh", "exp", "ln", "log", "det", "max",
              "min", "dim", "rank"}
_ACCENTS = {"dot": "\u0307", "ddot": "\u0308", "hat": "\u0302", "bar": "\u0304", "tilde": "\u0303", "vec": "\u20d7"}
_WORDS = {"text", "mathrm", "mathit", "mathbf", "mathsf", "operatorname", "textrm", "textit", "mbox"}
_SIZES = {"left", "right", "big", "Big", "bigg", "Bigg", "bigl", "bigr", "Bigl", "Bigr", "biggl", "biggr",
          "displaystyle", "textstyle"}
_SUPERSCRIPT = dict(zip("0123456789+-=()nT", "⁰¹²³⁴⁵⁶⁷⁸⁹⁺⁻⁼⁽⁾ⁿᵀ", strict=True))
_SUBSCRIPT = dict(zip("0123456789+-=()", "₀₁₂₃₄₅₆₇₈₉₊₋₌₍₎", strict=True))


class _Latex:
    """A small reader of the LaTeX the documents print: symbols, accents, fractions, scripts, text."""

    def __init__(self, source: str) -> None:
        self.s, self.i = source, 0

    def _command(self) -> str:
        start = self.i = self.i + 1  # past the backslash
        if self.i < len(self.s) and not self.s[self.i].isalpha():
            self.i += 1
            return self.s[start:self.i]
        while self.i < len(self.s) and self.s[self.i].isalpha():
            self.i += 1
        name = self.s[start:self.i]
        rest = self.s[self.i:].lstrip(" ")
        if rest[:1].isalnum() or rest[:1] == "\\":  # δ q → δq, ∂ S → ∂S; but θ + m keeps its spaces
            self.i = len(self.s) - len(rest)
        return name

    def _argument(self) -> str:
        """The next group or single token, converted."""
        while self.i < len(self.s) and self.s[self.i] == " ":
            self.i += 1
        if self.i >= len(self.s):
            return ""
        if self.s[self.i] == "{":
            return self.group()
        return self.token()

    def group(self) -> str:
        """From an opening brace to its closing one, converted."""
        self.i += 1
        out = []
        while self.i < len(self.s) and self.s[self.i] != "}":
            out.append(self.token())
        self.i += 1
        return "".join(out)

    def _raw_group(self) -> str:
        """From an opening brace to its closing one, as written (the words of ``\\text{...}``)."""
        depth, start = 0, self.i
        while self.i < len(self.s):
            depth += {"{": 1, "}": -1}.get(self.s[self.i], 0)
            self.i += 1
            if depth == 0:
                break
        return self.s[start + 1:self.i - 1]

    def _script(self, table: dict[str, str], mark: str) -> str:
        body = self._argument()
        if body and all(ch in table for ch in body):
            return "".join(table[ch] for ch in body)
        return f"{mark}{body}" if len(body) == 1 else f"{mark}{{{body}}}"

    def token(self) -> str:
        ch = self.s[self.i]
        if ch == "\\":
            return self._after(self._command())
        if ch == "{":
            return self.group()
        self.i += 1
        if ch == "^":
            return self._script(_SUPERSCRIPT, "^")
        if ch == "_":
            return self._script(_SUBSCRIPT, "_")
        return {"$": "", "~": " "}.get(ch, ch)

    def _after(self, name: str) -> str:
        if name in ("frac", "dfrac", "tfrac"):
            num, den = self._argument(), self._argument()
            return f" {_wrapped(num)}/{_wrapped(den)} "
        if name in _ACCENTS:
            arg = self._argument()
            return arg[:1] + _ACCENTS[name] + arg[1:]
        if name == "sqrt":
            return f"√{_wrapped(self._argument())}"
        if name in _WORDS and self.i < len(self.s) and self.s[self.i] == "{":
            return self._raw_group()
        if name in _SIZES:
            return "" if self.s[self.i:self.i + 1] != "." else self._skip_dot()
        if name in _FUNCTIONS:
            return f" {name} "
        return _LATEX_SYMBOLS.get(name, name)

    def _skip_dot(self) -> str:
        self.i += 1
        return ""

    def text(self) -> str:
        out = []
        while self.i < len(self.s):
            out.append(self.token())
        return "".join(out)


def _wrapped(part: str) -> str:
    part = part.strip()
    return f"({part})" if any(ch in part for ch in " +−-=·,") else part


def latex_text(source: str) -> str:
    """The documents' LaTeX (a display, or prose with ``$...$`` or bare commands in it) on one line in
    this module's notation: ``\\frac{\\partial L}{\\partial \\dot q_i}`` → ∂L/∂q̇_i, ``\\sin^2\\theta`` →
    sin²θ, ``m_1`` → m₁, ``\\text{ for }`` → for. Scripts with no Unicode form keep their braces
    (``Q_{k,Δ}``) for a page to set as sub- or superscripts. Text without LaTeX comes back unchanged."""
    out = _Latex(source).text()
    out = out.replace(" ²", "²").replace(" ³", "³")
    return " ".join(out.split()).replace("( ", "(").replace(" )", ")").replace("/ ", "/")

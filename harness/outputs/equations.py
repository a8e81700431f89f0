"""The derived equations of motion as LaTeX and as PNG images, for the report.

The LaTeX is sympy's own printer (``sp.latex``) applied to the Derivation,
with readable names for the symbols the derivation invents (``theta_ddot`` →
θ̈, ``lambda_rod`` → λ_rod). Images are drawn by matplotlib's mathtext, which
needs no TeX installation and no network (no MathJax), and are byte-identical
for identical inputs. A formula wider than :data:`MAX_WIDTH_PX` is broken
between the terms of its sum onto several lines, so that the page shows it at
its drawn size (a shrunk image is illegible).
"""

from __future__ import annotations

import base64
import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import sympy as sp

from analytic.lagrangian import Derivation
from harness.core.plotting import formula_png, pyplot

__all__ = ["MAX_WIDTH_PX", "equations", "png_data_uri", "width_px"]

DPI, FONTSIZE = 110, 13.0
MAX_WIDTH_PX = 540
"""The widest line drawn: beside the model still at a 1000 px window there are about 560 px."""


@dataclass(frozen=True)
class Equation:
    """One displayed formula: what it is (``label``), its LaTeX on one line without dollar signs, and
    the lines it is drawn on (the same LaTeX broken between terms where it is too wide)."""

    label: str
    latex: str
    lines: tuple[str, ...] = ()

    @property
    def shown(self) -> tuple[str, ...]:
        return self.lines or (self.latex,)


def symbol_names(derivation: Derivation) -> dict[sp.Symbol, str]:
    """LaTeX for q̇, q̈ and λ symbols, matched by name (their assumptions may differ)."""
    system = derivation.system
    exprs = [*derivation.equations, system.kinetic, system.potential, *(r for c in system.constraints for r in c.rows)]
    free = set().union(*(sp.sympify(e).free_symbols for e in exprs))
    coords = {q.name: sp.latex(q) for q in system.q}
    lams = {lam.name for lam in derivation.multiplier_symbols}
    names: dict[sp.Symbol, str] = {}
    for s in free:
        stem, _, suffix = s.name.rpartition("_")
        if suffix in ("dot", "ddot") and stem in coords:
            names[s] = rf"\{suffix}{{{coords[stem]}}}"
        elif s.name in lams:
            label = s.name.removeprefix("lambda_").replace("_", r"\_")
            names[s] = rf"\lambda_{{\mathrm{{{label}}}}}"
    return names


def equations(derivation: Derivation) -> list[Equation]:
    """T, V, each constraint f(q) = 0 and each of Lagrange's equations (= 0 along a motion)."""
    system = derivation.system
    names = symbol_names(derivation)

    def tex(expr: sp.Expr) -> str:  # display-size fractions (mathtext's \frac is script-size)
        return sp.latex(expr, symbol_names=names).replace(r"\frac{", r"\dfrac{")

    def equation(label: str, lhs: str, expr: sp.Expr, rhs: str) -> Equation:
        return Equation(label, f"{lhs}{tex(expr)}{rhs}", broken(lhs, expr, rhs, tex))

    out = [equation("kinetic energy", "T = ", sp.simplify(system.kinetic), ""),
           equation("potential energy", "V = ", sp.simplify(system.potential), "")]
    for c in system.constraints:
        level = "" if c.kind == "holonomic" else " (velocity level)"
        for i, row in enumerate(c.rows):
            label = f"constraint {c.name}" + (f" row {i}" if c.size > 1 else "")
            out.append(equation(f"{label}{level}", "", row, " = 0"))
    for q, eq in zip(system.q, derivation.equations, strict=True):
        out.append(equation(f"equation for {q.name}", "", eq, " = 0"))
    return out


@functools.cache
def width_px(latex: str) -> float:
    """The drawn width of one line of LaTeX in pixels (without the image's margin)."""
    pyplot()  # selects the Agg backend before mathtext is used
    from matplotlib.font_manager import FontProperties  # lazy: matplotlib, loaded by pyplot() above
    from matplotlib.mathtext import MathTextParser  # lazy: as above

    return float(MathTextParser("path").parse(f"${latex}$", dpi=DPI, prop=FontProperties(size=FONTSIZE))[0])


def broken(lhs: str, expr: sp.Expr, rhs: str, tex: Callable[[sp.Expr], str], *,
           width: Callable[[str], float] = width_px, limit: float = MAX_WIDTH_PX) -> tuple[str, ...]:
    """``lhs expr rhs`` as lines no wider than ``limit`` where it can be: one line when it fits, else the
    terms of the sum packed line by line, each line after the first starting with its sign. The sum is
    ``expr`` as it is where each of its terms fits a line, else expanded; a term wider than ``limit``
    still keeps a line of its own."""
    whole = f"{lhs}{tex(expr)}{rhs}"
    if width(whole) <= limit:
        return (whole,)
    sums = [e for e in (expr, sp.expand(expr)) if isinstance(e, sp.Add)]
    if not sums:
        return (whole,)
    form = next((e for e in sums if all(width(rf"\qquad + {tex(t)}") <= limit for t in e.args)), sums[-1])
    lines: list[str] = []
    current = lhs.rstrip()
    for k, term in enumerate(form.as_ordered_terms()):
        piece = tex(term) if k == 0 else (f"- {tex(-term)}" if term.could_extract_minus_sign() else f"+ {tex(term)}")
        candidate = f"{current} {piece}".strip()
        if k > 0 and width(candidate) > limit:
            lines.append(current)
            candidate = rf"\qquad {piece}"
        current = candidate
    return (*lines, f"{current}{rhs}")


def png_data_uri(latex: str | Sequence[str], *, fontsize: float = FONTSIZE) -> str | None:
    """The formula (a line of LaTeX, or several drawn one under the other) as a PNG data URI, or None if
    mathtext cannot typeset it."""
    png = formula_png(latex, fontsize=fontsize, dpi=DPI)
    return None if png is None else "data:image/png;base64," + base64.b64encode(png).decode("ascii")

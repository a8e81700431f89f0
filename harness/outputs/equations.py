"""The derived equations of motion as LaTeX and as PNG images, for the report.

The LaTeX is sympy's own printer (``sp.latex``) applied to the Derivation,
with readable names for the symbols the derivation invents (``theta_ddot`` →
θ̈, ``lambda_rod`` → λ_rod). Images are drawn by matplotlib's mathtext, which
needs no TeX installation and no network (no MathJax), and are byte-identical
for identical inputs.
"""

from __future__ import annotations

import base64
import io
from dataclasses import dataclass

import sympy as sp

from analytic.lagrangian import Derivation
from harness.core.plotting import pyplot


@dataclass(frozen=True)
class Equation:
    """One displayed line: what it is (``label``) and its LaTeX, without dollar signs."""

    label: str
    latex: str


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

    out = [Equation("kinetic energy", f"T = {tex(sp.simplify(system.kinetic))}"),
           Equation("potential energy", f"V = {tex(sp.simplify(system.potential))}")]
    for c in system.constraints:
        level = "" if c.kind == "holonomic" else " (velocity level)"
        for i, row in enumerate(c.rows):
            label = f"constraint {c.name}" + (f" row {i}" if c.size > 1 else "")
            out.append(Equation(f"{label}{level}", f"{tex(row)} = 0"))
    for q, eq in zip(system.q, derivation.equations, strict=True):
        out.append(Equation(f"equation for {q.name}", f"{tex(eq)} = 0"))
    return out


def png_data_uri(latex: str, *, fontsize: float = 13.0) -> str | None:
    """The formula as a PNG data URI, or None if mathtext cannot typeset it."""
    plt = pyplot()
    fig = plt.figure(figsize=(0.01, 0.01))
    fig.text(0, 0, f"${latex}$", fontsize=fontsize)
    buf = io.BytesIO()
    try:
        fig.savefig(buf, format="png", dpi=110, bbox_inches="tight", pad_inches=0.04,
                    metadata={"Software": None}, transparent=False, facecolor="white")
    except ValueError:  # mathtext's parse error
        return None
    finally:
        plt.close(fig)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")

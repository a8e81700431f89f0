"""The seed documents' derived results, as named claims the audit checks.

Each :class:`Claim` is a formula as the document prints it, transcribed
faithfully in the document's own variables (its :class:`Frame`), with where it
stands. The audit (``harness/audit.py``) checks it symbolically against our
sympy derivation (expressed in the same variables) and numerically against
MuJoCo at sampled states.

Kinds of claim and what "true" means:

- ``value``: ``claimed`` equals the quantity ``truth`` (an energy, a
  derivative, a momentum, a multiplier, an acceleration). Derived quantities
  that involve q̈ or λ are compared on motions: q̈ and λ are replaced by their
  solved values.
- ``value_up_to_constant``: as ``value`` up to an additive constant (a
  potential measured from another zero).
- ``equation``: the document asserts ``claimed`` = 0 on motions; true iff it
  vanishes identically once q̈ and λ take their solved values (so a multiple
  or a combination of Lagrange's equations is accepted).
- ``statement``: not a formula; ``check`` returns (holds, reason).

``manifold``: substitutions the document makes that hold on the constraint
manifold (e.g. r = l, ṙ = 0); ``approximation``: substitutions of an
approximation the claim states (e.g. sin θ → θ), with ``approx_symbol`` the
small quantity, compared to first order. ``slip`` marks a display with an
evident typographic slip (the next line contradicts it) and gives the intended
formula in ``intended``; ``ambiguity`` names a convention the document leaves
open.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

import sympy as sp

if TYPE_CHECKING:
    from analytic.claims.view import DocView

ClaimKind = Literal["value", "value_up_to_constant", "equation", "statement"]


@dataclass(frozen=True)
class Frame:
    """The document's variables for one system, and how they map to ours.

    ``q``, ``qd``, ``qdd``: the document's coordinates and their rates;
    ``to_ours``: each of our coordinates as an expression in the document's
    (e.g. θ_ours = π − θ_doc); ``lam``: the document's multipliers by our
    constraint names. ``reading`` says in words which convention the mapping
    encodes.
    """

    system: str
    q: tuple[sp.Symbol, ...]
    qd: tuple[sp.Symbol, ...]
    qdd: tuple[sp.Symbol, ...]
    to_ours: Mapping[str, sp.Expr]
    lam: Mapping[str, sp.Symbol] = field(default_factory=dict)
    reading: str = "the document's coordinates are ours"


@dataclass(frozen=True)
class Claim:
    id: str
    document: str
    location: str
    quote: str
    frame: Frame
    kind: ClaimKind
    claimed: sp.Expr | None = None
    truth: Callable[[DocView], sp.Expr] | None = None
    check: Callable[[DocView], tuple[bool, str]] | None = None
    measure: str | None = None  # MuJoCo's own reading: "kinetic", "potential", "lagrangian",
    # "force:NAME", "qacc:COORD", "invariant:NAME", "coordinate:COORD" (for solutions), or None
    manifold: Mapping[sp.Symbol, sp.Expr] = field(default_factory=dict)
    approximation: Mapping[sp.Expr, sp.Expr] = field(default_factory=dict)
    approx_symbol: sp.Symbol | None = None
    slip: str = ""
    intended: sp.Expr | None = None
    ambiguity: str = ""
    note: str = ""
    numeric_blind: str = ""  # why motions cannot show the difference (e.g. it lies off the manifold)
    small_motion: float = 1.0  # numeric check from the case's initial state scaled by this


def doc_frame(system: str, names: str, to_ours: Mapping[str, str | sp.Expr] | None = None,
              *, lam: Mapping[str, str] | None = None, reading: str = "") -> Frame:
    """A Frame with the document's coordinates ``names`` (space separated).

    ``to_ours`` maps each of our coordinate names to an expression in the
    document's names (strings are sympified with the document's symbols);
    identity by name when omitted.
    """
    q = tuple(sp.Symbol(n, real=True) for n in names.split())
    qd = tuple(sp.Symbol(f"{s.name}_dot", real=True) for s in q)
    qdd = tuple(sp.Symbol(f"{s.name}_ddot", real=True) for s in q)
    local = {s.name: s for s in q}
    mapping = {k: sp.sympify(v, locals=local) if isinstance(v, str) else v
               for k, v in (to_ours or {s.name: s for s in q}).items()}
    lams = {k: sp.Symbol(v, real=True) for k, v in (lam or {}).items()}
    return Frame(system=system, q=q, qd=qd, qdd=qdd, to_ours=mapping, lam=lams,
                 reading=reading or "the document's coordinates are ours")

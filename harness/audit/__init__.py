"""The seed audit: the seed documents' displays and statements of fact, as named claims, and their checks.

Each :class:`Claim` is a formula or statement as the document prints it,
transcribed faithfully in the document's own variables (its :class:`Frame`).
The audit (:mod:`harness.audit.verdicts`) checks it symbolically against our
sympy derivation (expressed in the same variables; :mod:`harness.audit.view`,
:mod:`harness.audit.checks`) and numerically against MuJoCo at sampled states
(:mod:`harness.audit.numbers`; MuJoCo runs, hence here in ``harness`` and not
in ``analytic``). Which lines of which document (``documents/``) each claim
comes from, and why the remaining lines hold no claim, is the coverage list
(:mod:`harness.audit.coverage`). The claims themselves: document 001 in
:mod:`harness.audit.simulations` and :mod:`harness.audit.variations`, document
000 in :mod:`harness.audit.lecture15` and :mod:`harness.audit.lecture15_method`,
every one in :func:`harness.audit.registry.all_claims`, in their variables
(:mod:`harness.audit.frames`) and notation (:mod:`harness.audit.notation`).
The audit's table, page and JSON: :mod:`harness.outputs.audit`.

Kinds of claim and what "true" means:

- ``value``: ``claimed`` equals the quantity ``truth`` (an energy, a
  derivative, a momentum, a multiplier, an acceleration). Derived quantities
  that involve q̈ or λ are compared on motions: q̈ and λ are replaced by their
  solved values.
- ``value_up_to_constant``: as ``value`` up to an additive constant (a
  potential measured from another zero).
- ``equation``: the document asserts ``claimed`` = 0 on motions; true iff it
  vanishes identically once q̈ and λ take their solved values (so a multiple
  or a combination of Lagrange's equations is accepted). ``claimed`` may be a
  column (one equation per coordinate, as a general display Σ_k [...]_k δq_k = 0
  with independent δq_k asserts).
- ``statement``: not a formula about one quantity; ``check`` returns
  (holds, reason).

A general display (the multiplier method, the calculus of variations) is
checked on an instance: ``claimed`` may be a function of the
:class:`~harness.audit.view.DocView`, applying the display's operations to
our derived L, T, V and constraint rows in the document's variables.

``manifold``: substitutions the document makes that hold on the constraint
manifold (e.g. r = l, ṙ = 0); ``projection``: the same, used only to allow
numerically for MuJoCo's soft constraint leaving the manifold (where the
claim must not be checked on it symbolically); ``approximation``:
substitutions of an approximation the claim states (e.g. sin θ → θ), with
``approx_symbol`` the small quantity, compared to first order. A refuted
claim's corrected form is ``intended`` (a formula in the document's notation;
``aliases`` names the document's own symbols such as a tension T = −λ) or, for
a statement, ``corrected_text`` with ``intended_check``; ``slip`` marks an
evident typographic slip (the document's next lines contradict the display).
``readings`` lists the readings of an ambiguous claim, each with the formula
that holds under it; ``note`` is shown with the verdict whatever it is.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal, Union

import sympy as sp

if TYPE_CHECKING:
    from harness.audit.view import DocView

__all__ = ["Claim", "ClaimReading", "Frame", "StatementCheck", "doc_frame"]

ClaimKind = Literal["value", "value_up_to_constant", "equation", "statement"]
Formula = Union[sp.Expr, sp.Matrix, "Callable[[DocView], sp.Expr | sp.Matrix]"]
StatementCheck = Callable[["DocView"], tuple[bool, str]]


@dataclass(frozen=True)
class Frame:
    """The document's variables for one system, and how they map to ours.

    ``q``, ``qd``, ``qdd``: the document's coordinates and their rates;
    ``to_ours``: each of our coordinates as an expression in the document's
    (e.g. θ_ours = π − θ_doc); ``lam``: the document's multipliers by our
    constraint names, ``lam_sign``: −1 where the document's multiplier is minus
    ours (λ_ours = lam_sign · λ_doc). ``reading`` says in words which
    convention the mapping encodes.
    """

    system: str
    q: tuple[sp.Symbol, ...]
    qd: tuple[sp.Symbol, ...]
    qdd: tuple[sp.Symbol, ...]
    to_ours: Mapping[str, sp.Expr]
    lam: Mapping[str, sp.Symbol] = field(default_factory=dict)
    reading: str = "the document's coordinates are ours"
    lam_sign: Mapping[str, int] = field(default_factory=dict)


@dataclass(frozen=True)
class ClaimReading:
    """One reading of an ambiguous claim, and the formula that holds under it.

    Either a ``frame`` (the reading as a convention: which vertical θ is measured
    from, which sign λ has) with ``formula``, the claim as it must read in that
    convention (checked symbolically; the printed claim is checked too), or a
    ``check`` that says whether the printed claim holds under the reading, with
    ``text``, the reading's formula in words.
    """

    label: str
    frame: Frame | None = None
    formula: Formula | None = None
    text: str = ""
    check: StatementCheck | None = None


@dataclass(frozen=True)
class Claim:
    id: str
    document: str
    location: str
    quote: str
    frame: Frame
    kind: ClaimKind
    claimed: Formula | None = None
    truth: Callable[[DocView], sp.Expr] | None = None
    check: StatementCheck | None = None
    measure: str | None = None  # what MuJoCo reading the numeric check uses (harness/audit/numbers.py)
    manifold: Mapping[sp.Symbol, sp.Expr] = field(default_factory=dict)
    projection: Mapping[sp.Symbol, sp.Expr] = field(default_factory=dict)
    approximation: Mapping[sp.Expr, sp.Expr] = field(default_factory=dict)
    approx_symbol: sp.Symbol | None = None
    slip: str = ""
    intended: Formula | None = None
    aliases: Mapping[sp.Symbol, sp.Expr] = field(default_factory=dict)
    lhs: str = ""  # a value claim's quantity in the document's notation ("λ₂"), for its corrected form
    corrected_text: str = ""
    project_text: str = ""
    intended_check: StatementCheck | None = None
    ambiguity: str = ""
    readings: tuple[ClaimReading, ...] = ()
    note: str = ""
    numeric_blind: str = ""  # why motions cannot show the difference (e.g. it lies off the manifold)
    small_motion: float = 1.0  # numeric check from the case's initial state scaled by this
    window: float = 0.0  # action claims: the interval [0, window] of the motion (0: the case's horizon)
    no_numbers: str = ""  # why no motion can test the claim, where it is a formula


def doc_frame(system: str, names: str, to_ours: Mapping[str, str | sp.Expr] | None = None,
              *, lam: Mapping[str, str] | None = None, reading: str = "") -> Frame:
    """A Frame with the document's coordinates ``names`` (space separated).

    ``to_ours`` maps each of our coordinate names to an expression in the
    document's names (strings are sympified with the document's symbols);
    identity by name when omitted. ``lam`` names the document's multiplier for
    each of our constraints; a leading "-" says it is minus ours.
    """
    q = tuple(sp.Symbol(n, real=True) for n in names.split())
    qd = tuple(sp.Symbol(f"{s.name}_dot", real=True) for s in q)
    qdd = tuple(sp.Symbol(f"{s.name}_ddot", real=True) for s in q)
    local = {s.name: s for s in q}
    mapping = {k: sp.sympify(v, locals=local) if isinstance(v, str) else v
               for k, v in (to_ours or {s.name: s for s in q}).items()}
    lams = {k: sp.Symbol(v.lstrip("-"), real=True) for k, v in (lam or {}).items()}
    signs = {k: -1 for k, v in (lam or {}).items() if v.startswith("-")}
    return Frame(system=system, q=q, qd=qd, qdd=qdd, to_ours=mapping, lam=lams,
                 reading=reading or "the document's coordinates are ours", lam_sign=signs)

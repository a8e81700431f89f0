"""The audit: each of the seed documents' claims judged, symbolic against our derivation, numeric against MuJoCo.

Each claim (:func:`harness.audit.registry.all_claims`) gets one of three verdicts:

- ``confirmed``: it holds symbolically, and MuJoCo's measurements agree with
  it as closely as with our own derivation;
- ``refuted``: it fails symbolically; the row gives the corrected formula in
  the document's notation and sign convention beside the project's form, and
  the numbers that refute it, and says whether the cause is a transcription
  slip (the display is contradicted by the document's next lines) or an error
  of physics, derivation or classification;
- ``ambiguous``: it holds under one reading of a convention the document
  leaves open and fails under another; the row gives each reading's formula.

What the numbers are, per kind of numeric check, is in
:mod:`harness.audit.numbers` (``KINDS``). Lines of the documents that
hold no claim are listed with the reason in :mod:`harness.audit.coverage`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import sympy as sp

from harness.audit import Claim, coverage
from harness.audit.notation import doc_text
from harness.audit.numbers import Numbers, numeric_check
from harness.audit.registry import all_claims
from harness.audit.view import DocView, resolve, symbolic_check
from harness.reference.derivations import derivation

__all__ = ["AuditRow", "audit", "audit_claim", "consistent", "counts"]


@dataclass(frozen=True)
class ReadingRow:
    """One reading of an ambiguous claim: its formula, and whether the printed claim holds under it."""

    label: str
    formula: str
    printed_holds: bool
    reason: str = ""


@dataclass(frozen=True)
class AuditRow:
    """A claim's verdict and everything the table, the report and the JSON show of it (plain data: a
    report worker sends it without its claim)."""

    claim: Claim | None
    claim_id: str
    lines: str
    verdict: str  # confirmed | refuted | ambiguous
    cause: str  # "", "transcription slip", "error"
    holds: bool  # the symbolic check of the claim as printed (in its main reading)
    symbolic: str  # "identically equal", or the reason, or the residual
    residual: str  # the symbolic residual in sympy's plain text ("" for a statement)
    corrected: str  # the corrected formula in the document's notation and sign convention
    corrected_project: str  # the same in our variables and convention (M q̈ = F + Jᵀλ)
    corrected_latex: str
    readings: tuple[ReadingRow, ...]
    numbers: Numbers
    blind: str  # why motions cannot show what the symbolic check finds ("" when they can)
    coordinates: str  # the reading of the document's variables the checks used
    why: str
    note: str

    @property
    def numeric_error(self) -> float | None:
        return self.numbers.error

    @property
    def numeric_floor(self) -> float | None:
        return self.numbers.floor

    @property
    def numeric_agrees(self) -> bool | None:
        return self.numbers.agrees


def _view(claim: Claim, frame, views: dict[int, DocView] | None) -> DocView:
    views = {} if views is None else views
    if id(frame) not in views:
        views[id(frame)] = DocView(derivation(frame.system), frame)
    return views[id(frame)]


def _residual_text(residual: object) -> str:
    if residual is None:
        return ""
    if isinstance(residual, sp.MatrixBase):
        return "[" + ", ".join(sp.sstr(e) for e in residual) + "]"
    return sp.sstr(residual)


def _shortest(expr: sp.Expr) -> sp.Expr:
    """The expression as given, expanded or factored: whichever prints shortest (deterministic)."""
    forms = [sp.expand(expr), expr, sp.factor(expr)]
    return min(forms, key=lambda e: (len(doc_text(e)), forms.index(e)))


def _ours(expr: sp.Expr, claim: Claim, view: DocView) -> sp.Expr:
    """A formula in the document's variables, written in ours (aliases such as T = −λ replaced)."""
    out = sp.sympify(expr).subs(claim.aliases, simultaneous=True) if claim.aliases else sp.sympify(expr)
    return _shortest(out.subs(view.to_ours, simultaneous=True))


def _quantity_in_ours(claim: Claim, view: DocView) -> str:
    """A value claim's left-hand side in our variables: our multiplier or acceleration where it is one."""
    truth = sp.sympify(claim.truth(view)) if claim.truth is not None else None
    if truth is not None and truth in {*view.frame.lam.values(), *view.frame.qdd}:
        return doc_text(_ours(truth, claim, view))
    return claim.lhs or "value"


def _project_form(fixed: object, claim: Claim, view: DocView) -> str:
    """The corrected relation in our variables, solved for our multiplier where it has one."""
    prefix = "" if view.frame.reading == "the document's coordinates are ours" else f"({view.frame.reading}) "
    if claim.kind in ("value", "value_up_to_constant"):
        return f"{prefix}{_quantity_in_ours(claim, view)} = {doc_text(_ours(fixed, claim, view))}"
    relation = fixed.lhs - fixed.rhs if isinstance(fixed, sp.Equality) else fixed
    if isinstance(relation, sp.MatrixBase):
        return f"{prefix}{doc_text(relation.applyfunc(lambda e: _ours(e, claim, view)))} = 0"
    ours = _ours(relation, claim, view)
    lams = [s for s in view.derivation.multiplier_symbols if s in ours.free_symbols]
    if len(lams) == 1:
        (solved,) = sp.solve(ours, lams[0])
        return f"{prefix}{doc_text(lams[0])} = {doc_text(_shortest(solved))}"
    return f"{prefix}{doc_text(ours)} = 0"


def _doc_form(fixed: object, claim: Claim) -> str:
    """The corrected formula as the document would print it, with its own symbols (a tension T_rod = −λ)."""
    where = "".join(f", where {doc_text(k)} = {doc_text(v)}" for k, v in claim.aliases.items())
    if claim.kind in ("value", "value_up_to_constant"):
        constant = " + constant" if claim.kind == "value_up_to_constant" else ""
        return f"{claim.lhs or 'value'} = {doc_text(fixed)}{constant}{where}"
    if isinstance(fixed, sp.Equality):
        return doc_text(fixed) + where
    return f"{doc_text(fixed)} = 0{where}"


def _corrected(claim: Claim, view: DocView) -> tuple[str, str, str]:
    """(document's notation, project's form, LaTeX) of the corrected claim; each correction is checked."""
    fixed = resolve(claim.intended, view) if claim.intended is not None else None
    if claim.kind == "statement":
        if claim.intended_check is not None:
            ok, why = claim.intended_check(view)
            if not ok:
                raise AssertionError(f"corrected form of {claim.id} does not hold either: {why}")
        if fixed is None:
            return claim.corrected_text, claim.project_text or claim.corrected_text, ""
        return (claim.corrected_text or _doc_form(fixed, claim),
                claim.project_text or _project_form(fixed, claim, view), sp.latex(fixed))
    if fixed is None and claim.truth is not None:
        fixed = sp.simplify(view.on_motion(claim.truth(view), claim))
    if fixed is None:
        return claim.corrected_text, claim.project_text, ""
    if claim.intended is not None and not symbolic_check(claim, view, claim.intended).holds:
        raise AssertionError(f"intended formula of {claim.id} does not hold either")
    doc = claim.corrected_text or _doc_form(fixed, claim)
    project = claim.project_text or _project_form(fixed, claim, view)
    return doc, project, sp.latex(fixed)


def _readings(claim: Claim, view: DocView, views: dict[int, DocView] | None) -> tuple[ReadingRow, ...]:
    out = []
    for r in claim.readings:
        if r.frame is not None:
            v = _view(claim, r.frame, views)
            printed = symbolic_check(claim, v).holds
            formula = r.text
            if r.formula is not None:
                if not symbolic_check(claim, v, r.formula).holds:
                    raise AssertionError(f"reading {r.label!r} of {claim.id}: its formula does not hold")
                formula = formula or _doc_form(resolve(r.formula, v), claim)
            out.append(ReadingRow(r.label, formula, printed, r.frame.reading))
        else:
            printed, reason = r.check(view)  # type: ignore[misc]
            out.append(ReadingRow(r.label, r.text, printed, reason))
    return tuple(out)


def _verdict(claim: Claim, holds: bool, readings: tuple[ReadingRow, ...]) -> tuple[str, str]:
    if claim.ambiguity and not readings:
        raise ValueError(f"claim {claim.id}: an ambiguous claim must give its readings")
    if readings:
        held = [r.printed_holds for r in readings]
        verdict = "ambiguous" if any(held) and not all(held) else ("confirmed" if all(held) else "refuted")
    else:
        verdict = "confirmed" if holds else "refuted"
    cause = "" if verdict != "refuted" else ("transcription slip" if claim.slip else "error")
    return verdict, cause


def audit_claim(claim: Claim, view: DocView | None = None, *, views: dict[int, DocView] | None = None) -> AuditRow:
    """One claim's row; ``view``, the claim's frame read against our derivation, is built here unless
    given (``audit`` builds one per frame and shares it: its symbolic solve is the costly part)."""
    view = view if view is not None else _view(claim, claim.frame, views)
    sym = symbolic_check(claim, view)
    readings = _readings(claim, view, views)
    verdict, cause = _verdict(claim, sym.holds, readings)
    numbers = numeric_check(claim, view)
    symbolic = sym.reason or ("identically equal" if sym.holds else f"residual {_residual_text(sym.residual)}")
    corrected, project, latex = _corrected(claim, view) if verdict == "refuted" else ("", "", "")
    why = claim.slip or claim.ambiguity or claim.note or sym.reason
    if verdict == "refuted" and not why:
        why = symbolic
    return AuditRow(claim=claim, claim_id=claim.id, lines=coverage.lines_text(claim.id, default="-"), verdict=verdict,
                    cause=cause, holds=sym.holds, symbolic=symbolic, residual=_residual_text(sym.residual),
                    corrected=corrected, corrected_project=project, corrected_latex=latex, readings=readings,
                    numbers=numbers, blind=claim.numeric_blind, coordinates=claim.frame.reading, why=why,
                    note=claim.note)


def audit(claims: Sequence[Claim] | None = None) -> list[AuditRow]:
    views: dict[int, DocView] = {}  # one per frame, shared by its claims and readings
    return [audit_claim(c, views=views) for c in (claims if claims is not None else all_claims())]


def consistent(row: AuditRow) -> bool:
    """Symbolic and numeric verdicts tell the same story (a disagreement is a harness defect)."""
    if row.numeric_agrees is None or row.verdict == "ambiguous":
        return True
    if row.blind:
        return True
    return (row.verdict != "refuted") == row.numeric_agrees


def counts(rows: Sequence[AuditRow]) -> dict[str, int]:
    """Verdicts and causes; ``of``: how many claims the documents hold (a report audits those about the
    systems it runs)."""
    out = {v: sum(r.verdict == v for r in rows) for v in ("confirmed", "refuted", "ambiguous")}
    out["errors"] = sum(r.cause == "error" for r in rows)
    out["transcription slips"] = sum(r.cause == "transcription slip" for r in rows)
    return {"claims": len(rows), "of": len(all_claims()), **out}

"""Audit of the seed documents' claims: symbolic against our derivation, numeric against MuJoCo.

Each claim (``analytic/claims``) gets one of three verdicts:

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
:mod:`harness.studies.audit_numbers` (``KINDS``). Lines of the documents that
hold no claim are listed with the reason in :mod:`analytic.claims.coverage`.
"""

from __future__ import annotations

import html
from collections.abc import Sequence
from dataclasses import dataclass

import sympy as sp

from analytic.claims import Claim, coverage
from analytic.claims.notation import doc_text
from analytic.claims.registry import all_claims
from analytic.claims.view import DocView, resolve, symbolic_check
from harness.reference.derivations import derivation
from harness.studies.audit_numbers import (  # re-exported: the audit's public names
    AGREEMENT,
    KINDS,
    SAMPLES,
    Numbers,
    Samples,
    case_for,
    numeric_check,
    sample,
)
from harness.studies.formulas import quote_html, text_html

__all__ = ["AGREEMENT", "KINDS", "SAMPLES", "AuditRow", "Numbers", "ReadingRow", "Samples", "audit", "audit_claim",
           "case_for", "consistent", "counts", "format_table", "html_section", "json_rows", "numeric_check",
           "sample"]


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
    truth = sp.sympify(claim.truth(view)) if claim.truth is not None else None  # type: ignore[misc]
    if truth is not None and truth in {*view.frame.lam.values(), *view.frame.qdd}:
        return doc_text(_ours(truth, claim, view))
    return claim.lhs or "value"


def _project_form(fixed: object, claim: Claim, view: DocView) -> str:
    """The corrected relation in our variables, solved for our multiplier where it has one."""
    prefix = "" if view.frame.reading == "the document's coordinates are ours" else f"({view.frame.reading}) "
    if claim.kind in ("value", "value_up_to_constant"):
        return f"{prefix}{_quantity_in_ours(claim, view)} = {doc_text(_ours(fixed, claim, view))}"  # type: ignore[arg-type]
    relation = fixed.lhs - fixed.rhs if isinstance(fixed, sp.Equality) else fixed
    if isinstance(relation, sp.MatrixBase):
        return f"{prefix}{doc_text(relation.applyfunc(lambda e: _ours(e, claim, view)))} = 0"
    ours = _ours(relation, claim, view)  # type: ignore[arg-type]
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
    given (``audit`` builds one per frame: its symbolic solve costs 0.1-0.2 s)."""
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


# --- output: the table, the report's section, the JSON, summary.md

def _num(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.2e}"


def counts(rows: Sequence[AuditRow]) -> dict[str, int]:
    """Verdicts and causes; ``of``: how many claims the documents hold (a report audits those about the
    systems it runs)."""
    out = {v: sum(r.verdict == v for r in rows) for v in ("confirmed", "refuted", "ambiguous")}
    out["errors"] = sum(r.cause == "error" for r in rows)
    out["transcription slips"] = sum(r.cause == "transcription slip" for r in rows)
    return {"claims": len(rows), "of": len(all_claims()), **out}


def counts_line(rows: Sequence[AuditRow]) -> str:
    c = counts(rows)
    scope = "" if c["claims"] == c["of"] else f" (of {c['of']}: those about the systems run here)"
    return (f"{c['claims']} claims{scope}: {c['confirmed']} confirmed, {c['refuted']} refuted ({c['errors']} "
            f"errors, {c['transcription slips']} transcription slips), {c['ambiguous']} ambiguous")


def _agrees(row: AuditRow) -> str:
    return "-" if row.numeric_agrees is None else ("yes" if row.numeric_agrees else "no")


def _details(r: AuditRow) -> list[str]:
    doc = r.claim.document if r.claim else ""
    location = r.claim.location if r.claim else ""
    lines = [f"{r.claim_id} ({doc} line {r.lines}, {location}): {r.verdict}" + (f", {r.cause}" if r.cause else ""),
             f"    printed:   {r.claim.quote if r.claim else ''}"]
    if r.corrected:
        lines.append(f"    corrected: {r.corrected}    [the document's notation and sign convention]")
        lines.append(f"    ours:      {r.corrected_project}    [the project's variables, M q̈ = F + Jᵀλ]")
    lines += [f"    reading:   {x.label}: {x.formula} (as printed: {'holds' if x.printed_holds else 'fails'})"
              for x in r.readings]
    lines.append(f"    why:       {r.why}")
    lines.append(f"    symbolic:  {r.symbolic}")
    lines.append(f"    variables: {r.coordinates}")
    lines.append(_numbers_line(r))
    if r.blind:
        lines.append(f"    blind:     {r.blind}")
    return lines


def _numbers_line(r: AuditRow) -> str:
    n = r.numbers
    if n.error is None:
        return f"    numbers:   none ({n.error_is})"
    return (f"    numbers:   [{n.kind}] error {_num(n.error)}, floor {_num(n.floor)}, tolerance {_num(n.tolerance)}, "
            f"agrees {_agrees(r)}; error = {n.error_is}; floor = {n.floor_is}; over {n.states}")


def format_table(rows: Sequence[AuditRow]) -> str:
    """Aligned text table, one claim a row; then every non-confirmed claim in full, the notes on the
    confirmed ones, what the numbers are, the coverage of the documents, and the counts."""
    head = ("claim", "lines", "verdict", "cause", "check", "error", "floor", "agrees")
    body = [(r.claim_id, r.lines, r.verdict, r.cause or "-", r.numbers.kind, _num(r.numeric_error),
             _num(r.numeric_floor), _agrees(r)) for r in rows]
    widths = [max(len(x[i]) for x in [head, *body]) for i in range(len(head))]
    lines = ["  ".join(v.ljust(w) for v, w in zip(x, widths, strict=True)).rstrip() for x in [head, *body]]
    lines.append("")
    for r in rows:
        if r.verdict != "confirmed":
            lines += _details(r)
    noted = [r for r in rows if r.verdict == "confirmed" and r.note]
    if noted:
        lines += ["", "Notes on confirmed claims:"]
        lines += [f"    {r.claim_id} (line {r.lines}): {r.note}" for r in noted]
    lines += ["", "What the numbers are (check kinds):"]
    used = dict.fromkeys(r.numbers.kind for r in rows if r.numbers.kind != "none")
    lines += [f"    {kind}: error = {KINDS[kind][0]}; floor = {KINDS[kind][1]}" for kind in used]
    lines += [f"    agreement: error ≤ {AGREEMENT:g} × floor + 1e-9 (+ the neglected order of an approximation)",
              "", "Coverage of the documents (analytic/claims/coverage.py):"]
    lines += [f"    {line}" for line in coverage.summary()]
    lines.append(counts_line(rows))
    return "\n".join(lines)


def _esc(text: str) -> str:
    return html.escape(text)


def _claim_html(r: AuditRow) -> str:
    """A refuted or ambiguous claim as a card: as printed (typeset), the corrected forms or the readings,
    and why."""
    where = f"{r.claim.document} line {r.lines} · {r.claim.location}" if r.claim else f"line {r.lines}"
    terms = [("as printed", quote_html(r.claim.quote) if r.claim else "")]
    if r.corrected:
        terms += [("corrected", f"{text_html(r.corrected)} <small class='dim'>(the document's notation and sign "
                                "convention)</small>"),
                  ("ours", f"{text_html(r.corrected_project)} <small class='dim'>(the project's variables, "
                           "M q̈ = F + Jᵀλ)</small>")]
    terms += [("reading", f"<i>{text_html(x.label)}</i>: {text_html(x.formula)} <small class='dim'>(as printed "
                          f"it {'holds' if x.printed_holds else 'fails'})</small>") for x in r.readings]
    terms.append(("why", text_html(r.why)))
    verdict = r.verdict + (f" — {r.cause}" if r.cause else "")
    return (f"<div class='claim {'fail' if r.verdict == 'refuted' else 'ambiguous'}'><p><b>{_esc(r.claim_id)}</b> "
            f"<span class='verdict'>{_esc(verdict)}</span> <span class='dim'>{_esc(where)}</span></p><dl>"
            + "".join(f"<dt>{_esc(term)}</dt><dd>{body}</dd>" for term, body in terms) + "</dl></div>")


def html_section(rows: Sequence[AuditRow]) -> str:
    """The audit as an HTML section for the report: the counts, the refuted, slip and ambiguous claims with
    their corrected forms (each display typeset as printed, formulas never as raw LaTeX), then every claim;
    no network assets."""
    flagged = "".join(_claim_html(r) for r in rows if r.verdict != "confirmed")
    cells = []
    for r in rows:
        cls = {"confirmed": "pass", "refuted": "fail"}.get(r.verdict, "ambiguous")
        n = r.numbers
        numbers = (f"[{n.kind}] {_num(n.error)} / {_num(n.floor)} ({_agrees(r)})" if n.error is not None
                   else f"none: {_esc(n.error_is)}")
        cells.append(f"<tr class='{cls}'><td>{_esc(r.claim_id)}</td><td>{_esc(r.lines)}</td><td>{r.verdict}</td>"
                     f"<td>{numbers}</td><td>{text_html(r.note)}</td></tr>")
    legend = "".join(f"<li><b>{k}</b>: error = {_esc(e)}; floor = {_esc(f)}</li>" for k, (e, f) in KINDS.items())
    return ("<section id='audit'><h2>Audit of the seed documents</h2>"
            f"<p><b>{_esc(counts_line(rows))}</b>. Every display and statement of both lecture notes, checked "
            "symbolically against our sympy derivation and numerically against MuJoCo; lines with no claim are "
            f"listed with the reason in analytic/claims/coverage.py ({_esc('; '.join(coverage.summary()))}).</p>"
            "<section id='audit-flagged'><h3>Refuted and ambiguous claims</h3><p class='dim'>Each display as the "
            "document prints it, typeset; the corrected form in the document's notation and in ours.</p>"
            f"<div class='claims'>{flagged}</div></section>"
            "<section id='audit-claims'><h3>Every claim</h3><table class='audit'><tr><th>claim</th><th>lines</th>"
            f"<th>verdict</th><th>numbers: error / floor (agrees)</th><th>note</th></tr>{''.join(cells)}</table>"
            f"<h4>What the numbers are</h4><ul>{legend}</ul></section></section>")


def _row_json(r: AuditRow) -> dict[str, object]:
    n = r.numbers
    return {"verdict": r.verdict, "cause": r.cause, "document": r.claim.document if r.claim else "",
            "lines": r.lines, "location": r.claim.location if r.claim else "",
            "printed": r.claim.quote if r.claim else "", "corrected": r.corrected,
            "corrected_project": r.corrected_project, "corrected_latex": r.corrected_latex,
            "readings": [{"label": x.label, "formula": x.formula, "printed_holds": x.printed_holds,
                          "reason": x.reason} for x in r.readings],
            "symbolic": {"holds": r.holds, "result": r.symbolic, "residual": r.residual},
            "numeric": {"kind": n.kind, "error": n.error, "floor": n.floor, "tolerance": n.tolerance,
                        "agrees": n.agrees, "error_is": n.error_is, "floor_is": n.floor_is, "states": n.states,
                        "blind": r.blind},
            "coordinates": r.coordinates, "why": r.why, "note": r.note}


def json_rows(rows: Sequence[AuditRow]) -> dict[str, object]:
    """The audit for report.json and ``mjharness audit --json``: the counts, every claim by id (every field
    the table shows, with the symbolic residual), and the passages of the documents that hold no claim."""
    return {"counts": counts(rows), "claims": {r.claim_id: _row_json(r) for r in rows},
            "not_checkable": coverage.not_checkable()}

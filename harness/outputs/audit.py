"""The seed audit for people and programs: the terminal's table (``mjharness audit``), the report's page and the
JSON (report.json's "audit", ``mjharness audit --json``)."""

from __future__ import annotations

import html
from collections.abc import Sequence

from harness.audit import coverage
from harness.audit.numbers import AGREEMENT, KINDS
from harness.audit.verdicts import AuditRow, counts
from harness.core.tables import text_table
from harness.outputs.formulas import quote_html, text_html

__all__ = ["counts_line", "format_table", "html_section", "json_rows"]


def _num(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.2e}"


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
    lines = text_table(head, body).split("\n")
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
              "", "Coverage of the documents (harness/audit/coverage.py):"]
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
            f"listed with the reason in harness/audit/coverage.py ({_esc('; '.join(coverage.summary()))}).</p>"
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

"""Checks for a terminal: each figure, what its budget explains, the rest beside its limit, the verdict.

What a person reads by default fits the terminal (:func:`~harness.core.tables.terminal_width`): a
line per case (:func:`harness.pipeline.matrix.case_line`), each failed check with its budget
(:func:`failures_block`), then the verdict; :func:`checks_table`, a row per
check, is the verbose view.

A check judged by its error budget shows the figure as measured, the parts the
model's settings explain (integration, softness, the point masses' floors, a
constraint solver stopped short), the unexplained residual and the limit the
estimates' accuracy sets for it; ``used`` is unexplained ÷ limit. A check with
a fixed limit (theory, or a user's config) shows the figure beside its limit.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from harness.budget import PARTS
from harness.core.checks import Check, ratio
from harness.core.tables import text_table, wrap
from harness.pipeline.outcome import Outcome

__all__ = ["checks_table", "coverage_block", "failures_block", "fitness_line", "fitness_table", "fmt_value",
           "parts_shown", "ratio", "ratio_text", "stability_block", "verdict_line"]


def fmt_value(value: float) -> str:
    return f"{value:.3e}" if np.isfinite(value) else str(value)


def fmt_part(value: float | None) -> str:
    """A budget part: '' where it does not apply, else 2 significant digits."""
    return "" if value is None else f"{value:.2e}"


def ratio_text(r: float) -> str:
    if np.isnan(r):
        return "n/a"
    if not np.isfinite(r):
        return "—"
    return f"{100 * r:.0f}%" if r <= 1 else f"{r:.3g}× over"


def parts_shown(checks: Sequence[Check]) -> tuple[str, ...]:
    """The budget parts any of ``checks`` has (in the order of harness.budget.PARTS)."""
    present = {p for c in checks if c.budget is not None for p in c.budget.explained}
    return tuple(p for p in PARTS if p in present)


def _cells(c: Check, parts: Sequence[str]) -> tuple[str, ...]:
    if c.diverged or c.note:
        return ("—", *("" for _ in parts), "—", "—" if c.diverged else "n/a")
    if c.budget is None:
        return (fmt_value(c.value), *("" for _ in parts), "", fmt_value(c.threshold))
    b = c.budget
    return (fmt_value(b.measured), *(fmt_part(b.explained.get(p)) for p in parts), fmt_value(b.unexplained),
            fmt_value(b.limit))


def _status(c: Check) -> str:
    return f"{c.status}: {c.reason}" if c.reason else c.status


def checks_table(checks: Mapping[str, Sequence[Check]]) -> str:
    """Every check as an aligned row, then one line counting passed, failed, n/a and known defects."""
    everything = [c for cs in checks.values() for c in cs]
    parts = parts_shown(everything)
    rows = [(c.case, c.name, *_cells(c, parts), c.unit, ratio_text(ratio(c)), _status(c)) for c in everything]
    header = ("case", "check", "measured", *parts, "unexplained", "limit", "unit", "used", "verdict")
    return text_table(header, rows) + "\n" + counts_line(everything)


def counts_line(everything: Sequence[Check]) -> str:
    failed = [c for c in everything if not c.passed]
    na = sum(bool(c.note) for c in everything)
    known = sum(bool(c.known) for c in everything)
    diverged = sum(bool(c.diverged) for c in everything)
    return (f"{len(everything) - len(failed) - na} passed, {len(failed)} failed"
            + (f" ({known} of them known defects of this MuJoCo)" if known else "")
            + (f" ({diverged} of them on a run that could not be measured)" if diverged else "")
            + (f", {na} n/a (not in this MuJoCo, or not measurable at these settings)" if na else ""))


def failure_lines(c: Check, width: int) -> list[str]:
    """A failed check in lines of at most ``width`` columns: its status, case, name and unit and how far
    over its limit; then the figure measured, the unexplained residual (a fixed limit: the figure) beside
    the limit; then the parts its budget explains; then the reason (a known defect, a run that could not
    be measured), each wrapped where it is longer."""
    r = ratio(c)
    over = ("not measured" if c.diverged or not np.isfinite(r)
            else f"{r:.3g}× over its limit" if r > 1 else f"{100 * r:.0f}% of its limit")
    unit = f" [{c.unit}]" if c.unit else ""  # a run that diverged has no figure, so no unit
    lines = wrap(f"{c.status} {c.case} {c.name}{unit}: {over}", width)
    if not c.diverged and c.budget is not None:
        b = c.budget
        lines += wrap(f"measured {fmt_value(b.measured)}, unexplained {fmt_value(b.unexplained)} "
                      f"{_beside(b.unexplained, b.limit)} limit {fmt_value(b.limit)}", width, "    ")
        explained = ", ".join(f"{p} {fmt_part(b.explained[p])}" for p in PARTS if p in b.explained)
        lines += wrap(f"explained: {explained}", width, "    ") if explained else []
    elif not c.diverged:
        lines += wrap(f"measured {fmt_value(c.value)} {_beside(c.value, c.threshold)} fixed limit "
                      f"{fmt_value(c.threshold)}", width, "    ")
    if c.reason:
        lines += wrap(f"why: {c.reason}", width, "    ")
    return lines


def _beside(value: float, limit: float) -> str:
    return "≤" if value <= limit else ">"  # a known defect may be within; nan is not


def failures_block(checks: Mapping[str, Sequence[Check]], width: int) -> str:
    """Every failed check as :func:`failure_lines` ("" when none failed)."""
    return "\n".join(line for cs in checks.values() for c in cs if not c.passed for line in failure_lines(c, width))


def _known_text(known: Sequence[Check]) -> str:
    reasons = list(dict.fromkeys(c.known.split(";")[0] for c in known))
    return "; ".join(reasons)


def verdict_line(outcome: Outcome | Mapping[str, Sequence[Check]]) -> str:
    """One line a person reads first: PASS or FAIL, how many checks of how many cases, where the
    failures are (case and count), which of them are documented defects of this MuJoCo, what was not
    judged (n/a), and the engine findings."""
    if not isinstance(outcome, Outcome):
        outcome = Outcome(checks=outcome)
    checks = outcome.checks
    everything = outcome.all_checks
    failed = [c for c in everything if not c.passed]
    na = sum(bool(c.note) for c in everything)
    known = [c for c in failed if c.known]
    findings = sorted({f.function for fs in outcome.findings.values() for f in fs})
    aside = [f"{na} n/a"] * bool(na)
    aside += [f"engine finding{'s' * (len(findings) > 1)}: {', '.join(findings)} disagrees with what it should "
              "compute (see the report)"] * bool(findings)
    tail = f"; {'; '.join(aside)}" if aside else ""
    if not failed:
        within = len(everything) - na
        share = f"{within} of {len(everything)}" if na else f"all {within}"
        return f"PASS — {share} checks of {len(checks)} case(s) within what their budgets explain{tail}"
    where: dict[str, int] = {}
    for c in failed:
        where[c.case] = where.get(c.case, 0) + 1
    head = "FAIL"
    if len(known) == len(failed) and outcome.accept_known_defects:
        head = "FAIL, known defects accepted (exit 0)"
    text = (f"{head} — {len(failed)} of {len(everything)} checks fail, in {len(where)} of {len(checks)} "
            f"case(s): " + ", ".join(f"{case} ({n})" for case, n in where.items()))
    if known:
        share = "all of them" if len(known) == len(failed) else f"{len(known)} of them"
        text += f"; {share} known defects of this MuJoCo ({_known_text(known)})"
        if len(known) == len(failed) and not outcome.accept_known_defects:
            text += "; --accept-known-defects accepts them"
    return text + tail


def fitness_line(outcome: Outcome) -> str:
    """The requirements' verdict, one line ('' where none was stated)."""
    if not outcome.requirements:
        return ""
    stated = ", ".join(f"{r.measure} ≤ {r.value:g}" for r in outcome.requirements)
    unmet = outcome.unmet
    if not unmet:
        judged = sum(len(fs) for fs in outcome.fitness.values())
        return f"REQUIREMENTS MET — {stated}: {judged} figure(s) of the models' own integrators within them"
    worst = ", ".join(f"{f.case} {f.figure} {f.value:.3g} {f.unit} > {f.requirement.value:g}" for f in unmet[:4])
    more = f" and {len(unmet) - 4} more" if len(unmet) > 4 else ""
    return f"REQUIREMENTS NOT MET — {stated}: {worst}{more}"


def fitness_table(outcome: Outcome) -> str:
    """Every figure a requirement judged ('' where none was stated)."""
    rows = [(f.case, str(f.figure), fmt_value(f.value), f"{f.requirement.value:g}", f.unit,
             "met" if f.met else "NOT MET") for fs in outcome.fitness.values() for f in fs]
    if not rows:
        return ""
    return text_table(("case", "figure (own integrator)", "measured", "required", "unit", "verdict"), rows)


def coverage_block(trees: Mapping[str, Mapping[str, str] | None], width: int) -> str:
    """For each model judged against its own tree (``case -> its forces not examined``; None for a
    hand-derived case, left out), what its reference covered and what only the work–energy balance
    judged, wrapped to ``width`` ("" when no case is a tree)."""
    lines: list[str] = []
    for case, gaps in trees.items():
        if gaps is None:
            continue
        if not gaps:
            text = f"{case}: every force MuJoCo applies is in the reference derived from its own tree"
        else:
            text = (f"{case}: the reference derived from its own tree covers every force but {', '.join(gaps)}; "
                    "those were switched off for the comparison, and the model as it is was judged by its "
                    "work–energy balance (INTEGRATOR.balance)")
        lines += wrap(text, width)
    return "\n".join(lines)


def stability_block(limits: Mapping[str, Sequence[str]], width: int) -> str:
    """For each case, each integrator run beyond its stability limit at the model's step (its figures n/a: the
    method's limit, not MuJoCo's defect; :mod:`harness.families.stability`), wrapped to ``width``."""
    return "\n".join(line for case, said in limits.items() for text in said
                     for line in wrap(f"{case}: {text}; its figures are n/a", width))

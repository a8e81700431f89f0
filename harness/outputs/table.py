"""Checks for a terminal: each figure beside its limit, the share of the limit it uses, the verdict."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from harness.core.checks import Check
from harness.core.tables import text_table


def fmt_value(value: float) -> str:
    return f"{value:.3e}" if np.isfinite(value) else str(value)


def ratio(check: Check) -> float:
    """Share of the threshold a figure uses: ≤ 1 passes (non-finite figures fail: inf);
    nan for a check this MuJoCo cannot measure (n/a)."""
    if check.note:
        return float("nan")
    return check.value / check.threshold if np.isfinite(check.value) else float("inf")


def closest(checks: Sequence[Check]) -> Check | None:
    """The measurable check using the largest share of its threshold."""
    return max((c for c in checks if not c.note), key=ratio, default=None)


def ratio_text(r: float) -> str:
    if np.isnan(r):
        return "n/a"
    if not np.isfinite(r):
        return "—"
    return f"{100 * r:.0f}%" if r <= 1 else f"{r:.3g}× over"


def checks_table(checks: Mapping[str, Sequence[Check]]) -> str:
    """Every check as an aligned row, then one line counting passed, failed, n/a and known defects."""
    rows = [(c.case, c.name, "—" if c.diverged else f"{c.value:.3e}", f"{c.threshold:.3e}", c.unit,
             ratio_text(ratio(c)), f"{c.status}: {c.reason}" if c.reason else c.status)
            for cs in checks.values() for c in cs]
    header = ("case", "check", "figure", "threshold", "unit", "used", "verdict")
    failed = sum(not c.passed for cs in checks.values() for c in cs)
    total = sum(len(cs) for cs in checks.values())
    na = sum(bool(c.note) for cs in checks.values() for c in cs)
    known = sum(bool(c.known) for cs in checks.values() for c in cs)
    diverged = sum(bool(c.diverged) for cs in checks.values() for c in cs)
    return (text_table(header, rows) + "\n"
            + f"{total - failed - na - known} passed, {failed} failed"
            + (f" ({diverged} of them on a diverged run)" if diverged else "")
            + (f", {na} n/a (not in this MuJoCo)" if na else "")
            + (f", {known} known defect(s) of this MuJoCo" if known else ""))


def failures_table(checks: Mapping[str, Sequence[Check]]) -> str:
    """The failed checks as an aligned table ("" when none failed)."""
    failed = [c for cs in checks.values() for c in cs if not c.passed]
    if not failed:
        return ""
    rows = [(c.case, c.name, fmt_value(c.value), fmt_value(c.threshold), c.unit, ratio_text(ratio(c)))
            for c in failed]
    return text_table(("case", "failed check", "figure", "threshold", "unit", "used"), rows)


def verdict_line(checks: Mapping[str, Sequence[Check]]) -> str:
    """One line a person reads first: PASS or FAIL, how many checks of how many cases, and where the
    failures are (case and count) or what was not judged (n/a, known defects)."""
    everything = [c for cs in checks.values() for c in cs]
    failed = [c for c in everything if not c.passed]
    na = sum(bool(c.note) for c in everything)
    known = sum(bool(c.known) for c in everything)
    aside = [f"{na} n/a (not in this MuJoCo)"] * bool(na) + [f"{known} known defect(s) of this MuJoCo"] * bool(known)
    tail = f"; {', '.join(aside)}" if aside else ""
    if not failed:
        within = len(everything) - na - known
        share = f"{within} of {len(everything)}" if aside else f"all {within}"
        return f"PASS — {share} checks of {len(checks)} case(s) within their thresholds{tail}"
    where = {c.case: 0 for c in failed}
    for c in failed:
        where[c.case] += 1
    return (f"FAIL — {len(failed)} of {len(everything)} checks over their thresholds, in {len(where)} of "
            f"{len(checks)} case(s): " + ", ".join(f"{case} ({n})" for case, n in where.items()) + tail)

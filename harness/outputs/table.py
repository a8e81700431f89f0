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

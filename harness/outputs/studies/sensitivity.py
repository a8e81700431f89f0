"""The fault catalog's trials and the sensitivity study (:mod:`harness.studies.sensitivity`) as text tables."""

from __future__ import annotations

import math
from collections.abc import Sequence

from harness.core.checks import Check
from harness.core.tables import text_table
from harness.studies.faults import COARSE
from harness.studies.sensitivity import LARGEST, SMALLEST, Sensitivity, Trial

__all__ = ["table", "trials_table"]


def trials_table(rows: Sequence[Trial]) -> str:
    """The catalog as a text table: per case and change, the verdict, the deciding check and its budget."""
    def budget(c: Check | None) -> str:
        if c is None:
            return ""
        if c.diverged:
            return c.diverged
        if c.budget is None:
            return f"{c.value:.3g} vs {c.threshold:.3g} ({c.name.layer} limit)"
        b = c.budget
        parts = ", ".join(f"{k} {v:.2g}" for k, v in b.explained.items() if v)
        return f"measured {b.measured:.3g} = {parts or 'nothing explained'} + {b.unexplained:.2g}; limit {b.limit:.2g}"

    body = [[r.case, r.change, r.kind, r.setting, "" if math.isnan(r.size) else f"{r.size:g}",
             r.verdict + ("" if r.as_expected else " (unexpected)"),
             r.note or (str(r.deciding.name) if r.deciding else ""),
             "" if r.deciding is None else f"{r.deciding.ratio:.2g}", budget(r.deciding)] for r in rows]
    return text_table(["case", "change", "kind", "at", "size", "verdict", "deciding check", "used", "its budget"],
                      body)


def table(rows: Sequence[Sensitivity]) -> str:
    """The study as a text table: per case and fault, the smallest size detected at each setting."""
    by_key: dict[tuple[str, str], dict[str, Sensitivity]] = {}
    for r in rows:
        by_key.setdefault((r.case, r.fault), {})[r.setting] = r

    def cell(r: Sensitivity | None) -> str:
        if r is None:
            return ""
        if r.size is None:
            return f"n/a ({r.note})"
        if math.isnan(r.size):
            return f"> {LARGEST:g}"
        at_floor = "≤ " if r.size <= SMALLEST else ""  # the search's smallest size: detected there, maybe below
        return f"{at_floor}{r.size:.0e} ({r.deciding})"

    body = [[case, fault, cell(s.get("shipped")), cell(s.get(COARSE.name))] for (case, fault), s in by_key.items()]
    return text_table(["case", "fault", "shipped", "2 × timestep, default softness"], body)

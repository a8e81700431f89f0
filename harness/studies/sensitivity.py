"""Sensitivity: the smallest size of each fault each case detects, at the shipped settings and at a coarse one.

A fault below the error budget's resolution hides inside it: the figures it
moves stay within what the model's settings explain, to the estimates' own
accuracy. Rather than shrink the claim ("damping is caught") to the sizes that
happen to be caught, this study measures, for every case, every fault of
:data:`harness.studies.faults.FAULTS` that applies to it and two settings —
the shipped model, and :data:`~harness.studies.faults.COARSE` (2 × the
timestep, MuJoCo's default softness) — the smallest size that fails the
verdict: a search over decades from :data:`SMALLEST` to :data:`LARGEST`, then
1-2-5 steps inside the decade found. "Fails" means a check fails that does not
fail without the fault at the same setting (a documented defect of an older
MuJoCo fails either way).

It runs every case dozens of times (minutes), so it is a study, not a gate:
``mjharness sensitivity`` prints the table and writes it beside the report.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from harness.cases import Case
from harness.core.tables import text_table
from harness.engine.models import compile_model
from harness.engine.variants import compose
from harness.pipeline.limits import load_limits
from harness.pipeline.run import run_case
from harness.pipeline.verdict import judge
from harness.studies.faults import COARSE, FAULTS, Change

SMALLEST = 1e-7
LARGEST = 1.0


@dataclass(frozen=True)
class Sensitivity:
    """The smallest detected size of one fault on one case at one setting (nan: not detected up to
    :data:`LARGEST`; None: the fault does not apply, with ``note``), with the figure that decided."""

    case: str
    fault: str
    setting: str
    size: float | None
    unit: str
    deciding: str = ""
    note: str = ""


def _failures(case: Case, edits: Sequence, timestep_factor: float) -> set[str]:
    h = float(compile_model(case.mjcf).opt.timestep)
    result = run_case(case, edit=compose(*edits), timestep=h * timestep_factor if timestep_factor != 1 else None)
    return {c.name for c in judge(result, load_limits().for_case(case.name)) if not c.passed and not c.note}


def smallest_detected(detects: Callable[[float], str], *, smallest: float = SMALLEST, largest: float = LARGEST
                      ) -> tuple[float, str]:
    """The smallest size at which ``detects(size)`` names a failing figure ('' where it passes): a
    bisection over decades (detection is taken as monotonic in the size), then 1-2-5 inside the decade.
    (nan, '') where even ``largest`` passes."""
    decades = list(range(round(math.log10(smallest)), round(math.log10(largest)) + 1))
    top = detects(10.0 ** decades[-1])
    if not top:
        return math.nan, ""
    lo, hi, found = 0, len(decades) - 1, (10.0 ** decades[-1], top)
    while lo < hi:  # invariant: decades[hi] detects
        mid = (lo + hi) // 2
        deciding = detects(10.0 ** decades[mid])
        if deciding:
            hi, found = mid, (10.0 ** decades[mid], deciding)
        else:
            lo = mid + 1
    if hi > 0:  # 2 and 5 × the decade below the one found, smallest first
        base = 10.0 ** decades[hi - 1]
        for factor in (2.0, 5.0):
            deciding = detects(base * factor)
            if deciding:
                return base * factor, deciding
    return found


def sensitivity(case: Case, fault: Change, *, coarse: bool) -> Sensitivity:
    """One fault's smallest detected size on ``case`` at the shipped or the coarse setting."""
    setting = COARSE.name if coarse else "shipped"
    why = fault.reason_not(case)
    if why:
        return Sensitivity(case.name, fault.name, setting, None, fault.unit, note=why)
    if math.isnan(fault.sizes[0]) or fault.name == "joint-limit":
        return Sensitivity(case.name, fault.name, setting, None, fault.unit, note="has no size")
    base_edits = [COARSE.edit(case)] if coarse else []
    factor = COARSE.timestep if coarse else 1.0
    already = _failures(case, base_edits, factor)

    def detects(size: float) -> str:
        new = sorted(_failures(case, [*base_edits, fault.edit(case, size)], factor) - already)
        return new[0] if new else ""

    size, deciding = smallest_detected(detects)
    return Sensitivity(case.name, fault.name, setting, size, fault.unit, deciding)


def sensitivities(selected: Sequence[Case], *, faults: Sequence[Change] = FAULTS) -> list[Sensitivity]:
    return [sensitivity(case, fault, coarse=coarse) for case in selected for fault in faults
            for coarse in (False, True)]


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
        return f"{r.size:.0e} ({r.deciding})"

    body = [[case, fault, cell(s.get("shipped")), cell(s.get(COARSE.name))] for (case, fault), s in by_key.items()]
    return text_table(["case", "fault", "shipped", "2 × timestep, default softness"], body)

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
``mjharness sensitivity`` prints the table. ``mjharness faults`` runs the
catalog itself once, every setting and every fault at its claimed size, and
prints each verdict with the check that decided it and that check's budget.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from harness import cases
from harness.cases import Case
from harness.core.checks import Check
from harness.core.options import RunOptions
from harness.engine.models import compile_model
from harness.engine.variants import compose
from harness.pipeline.limits import load_limits
from harness.pipeline.run import run_case
from harness.pipeline.verdict import judge
from harness.studies.faults import COARSE, Change, by_name

__all__ = ["LARGEST", "SMALLEST", "Sensitivity", "Trial", "sensitivity_named", "trial_named"]

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


def _checks(case: Case, edits: Sequence, timestep_factor: float) -> list[Check]:
    h = float(compile_model(case.mjcf).opt.timestep)
    edits = [e for e in edits if e is not None]
    result = run_case(case, RunOptions(edit=compose(*edits) if edits else None,
                                       timestep=h * timestep_factor if timestep_factor != 1 else None))
    return judge(result, load_limits().for_case(case.name))


def _failures(case: Case, edits: Sequence, timestep_factor: float) -> set[str]:
    return {c.name for c in _checks(case, edits, timestep_factor) if not c.passed and not c.note}


@dataclass(frozen=True)
class Trial:
    """One change of the catalog judged on one case: a setting must pass, a fault must fail.

    Attributes:
        verdict: ``pass`` or ``FAIL`` (the gate, known defects not accepted); ``n/a`` where the change does
            not apply (``note`` says why).
        deciding: the check that decides: for a FAIL the failed check furthest over its limit (a run that
            could not be measured first), for a pass the one closest to its limit.
    """

    case: str
    change: str
    kind: str
    setting: str
    size: float
    verdict: str
    deciding: Check | None = None
    note: str = ""

    @property
    def as_expected(self) -> bool:
        return self.verdict == "n/a" or (self.verdict == "pass") == (self.kind == "setting")


def trial(case: Case, change: Change, *, coarse: bool = False) -> Trial:
    """``change`` applied to ``case`` (a fault at its size for the setting), at the shipped settings or at
    :data:`~harness.studies.faults.COARSE`, judged as ``mjharness check --mjcf VARIANT`` judges it."""
    setting = COARSE.name if coarse else "shipped"
    size = change.sizes[1 if coarse else 0] if change.kind == "fault" else math.nan
    why = change.reason_not(case)
    if why:
        return Trial(case.name, change.name, change.kind, setting, size, "n/a", note=why)
    edits = [change.edit(case, size), *([COARSE.edit(case)] if coarse else [])]
    checks = [c for c in _checks(case, edits, change.timestep * (COARSE.timestep if coarse else 1.0)) if not c.note]
    failed = [c for c in checks if not c.passed]
    if failed:
        deciding = max(failed, key=lambda c: (bool(c.diverged), c.ratio if math.isfinite(c.ratio) else math.inf))
        return Trial(case.name, change.name, change.kind, setting, size, "FAIL", deciding)
    closest = max(checks, key=lambda c: c.ratio if math.isfinite(c.ratio) else -1.0, default=None)
    return Trial(case.name, change.name, change.kind, setting, size, "pass", closest)


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


def trial_named(case: str, change: str, coarse: bool) -> Trial:
    """:func:`trial` by names (what a worker process is sent: a Change holds functions)."""
    return trial(cases.get(case), by_name(change), coarse=coarse)


def sensitivity_named(case: str, fault: str, coarse: bool) -> Sensitivity:
    """:func:`sensitivity` by names (what a worker process is sent)."""
    return sensitivity(cases.get(case), by_name(fault), coarse=coarse)


"""Gate figures against thresholds: pass/fail per check, with the figure beside its limit."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from harness.config import ConfigError
from harness.figures import Figure


@dataclass(frozen=True)
class Check:
    """A figure beside its limit. A non-empty ``note`` marks a check this MuJoCo cannot
    measure (an integrator it lacks): shown as n/a with the note, and not a failure. A
    non-empty ``known`` marks a failure explained by a documented defect of this MuJoCo
    version: shown with the reason, and not a failure of the run."""

    case: str
    name: str
    value: float
    threshold: float
    unit: str
    note: str = ""
    known: str = ""

    @property
    def passed(self) -> bool:
        return bool(self.note or self.known) or (math.isfinite(self.value) and self.value <= self.threshold)

    @property
    def status(self) -> str:
        """``pass``, ``FAIL``, ``n/a`` (not measurable here) or ``known defect`` (fails on this
        MuJoCo for a reason documented upstream, harness.compat.KNOWN_DEFECTS)."""
        return "n/a" if self.note else "known defect" if self.known else "pass" if self.passed else "FAIL"


def verdict(case: str, figures: Iterable[Figure], thresholds: Mapping[str, float]) -> list[Check]:
    """One Check per threshold; a threshold naming no measured figure is a config error, unless
    it belongs to an integrator this MuJoCo lacks (harness.compat), which gives an n/a Check."""
    from harness.compat import known_defect, unavailable_reason

    by_name = {f.name: f for f in figures}
    missing = {n: unavailable_reason(n) for n in set(thresholds) - set(by_name)}
    unknown = sorted(n for n, why in missing.items() if not why)
    if unknown:
        raise ConfigError(f"thresholds for case {case!r} name unmeasured figure(s) {unknown}; "
                          f"measured: {', '.join(sorted(by_name))}")
    checks = [Check(case, name, math.nan, limit, "", note=missing[name]) if name in missing
              else Check(case, name, by_name[name].value, limit, by_name[name].unit)
              for name, limit in thresholds.items()]
    return [dataclasses.replace(c, known=why) if not c.passed and (why := known_defect(case, c.name)) else c
            for c in checks]

"""Gate figures against thresholds: pass/fail per check, with the figure beside its limit."""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from harness.config import ConfigError
from harness.figures import Figure


@dataclass(frozen=True)
class Check:
    case: str
    name: str
    value: float
    threshold: float
    unit: str

    @property
    def passed(self) -> bool:
        return math.isfinite(self.value) and self.value <= self.threshold


def verdict(case: str, figures: Iterable[Figure], thresholds: Mapping[str, float]) -> list[Check]:
    """One Check per threshold; a threshold naming no measured figure is a config error."""
    by_name = {f.name: f for f in figures}
    unknown = sorted(set(thresholds) - set(by_name))
    if unknown:
        raise ConfigError(f"thresholds for case {case!r} name unmeasured figure(s) {unknown}; "
                          f"measured: {', '.join(sorted(by_name))}")
    return [Check(case, name, by_name[name].value, limit, by_name[name].unit)
            for name, limit in thresholds.items()]

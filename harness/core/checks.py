"""A Check: one figure beside its limit, and the verdict it gets."""

from __future__ import annotations

import math
from dataclasses import dataclass

from harness.core.figures import FigureName


@dataclass(frozen=True)
class Check:
    """A figure beside its limit. A non-empty ``note`` marks a check this MuJoCo cannot
    measure (an integrator it lacks): shown as n/a with the note, and not a failure. A
    non-empty ``known`` marks a failure explained by a documented defect of this MuJoCo
    version: shown with the reason, and not a failure of the run."""

    case: str
    name: FigureName
    value: float
    threshold: float
    unit: str
    note: str = ""
    known: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "name", FigureName(self.name))

    @property
    def passed(self) -> bool:
        return bool(self.note or self.known) or (math.isfinite(self.value) and self.value <= self.threshold)

    @property
    def status(self) -> str:
        """``pass``, ``FAIL``, ``n/a`` (not measurable here) or ``known defect`` (fails on this
        MuJoCo for a reason documented upstream, harness.engine.compat.KNOWN_DEFECTS)."""
        return "n/a" if self.note else "known defect" if self.known else "pass" if self.passed else "FAIL"

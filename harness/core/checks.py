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
    version: shown with the reason, and not a failure of the run. A non-empty ``diverged``
    marks a check whose run diverged ("diverged: mjWARN_BADQACC at t = 0.25 s"): a failure
    with that reason and no number (``value`` is nan)."""

    case: str
    name: FigureName
    value: float
    threshold: float
    unit: str
    note: str = ""
    known: str = ""
    diverged: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "name", FigureName(self.name))

    @property
    def passed(self) -> bool:
        if self.diverged:
            return False
        return bool(self.note or self.known) or (math.isfinite(self.value) and self.value <= self.threshold)

    @property
    def reason(self) -> str:
        """What a verdict says beside its status: why it is n/a, the known defect, or the diverged run ('' if none)."""
        return self.note or self.known or self.diverged

    @property
    def status(self) -> str:
        """``pass``, ``FAIL``, ``n/a`` (not measurable here) or ``known defect`` (fails on this
        MuJoCo for a reason documented upstream, harness.engine.compat.KNOWN_DEFECTS)."""
        return "n/a" if self.note else "known defect" if self.known else "pass" if self.passed else "FAIL"

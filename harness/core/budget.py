"""One figure's error budget as a record: what the figure measures, the parts the model's settings explain, the
residual nothing explains, and the tolerances that bound it (the budget itself, its parts and their estimates:
:mod:`harness.budget`). A core value, as :class:`~harness.core.deviation.Deviation` is: the checks judge it
(:mod:`harness.core.checks`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

__all__ = ["Budget"]


@dataclass(frozen=True)
class Budget:
    """One figure's budget, in the figure's unit.

    Attributes:
        measured: the figure itself (MuJoCo's run against the reference).
        explained: the size of each part (:data:`harness.budget.PARTS`) that the model's settings explain (the
            parts that apply: no softness without soft constraints).
        unexplained: the residual after the parts are removed.
        tolerance: each source of uncertainty of the residual (:data:`harness.budget.TOLERANCES`); they sum to the
            limit.
        notes: how the parts were obtained, where that is not the standard way (e.g. "softness: not
            applicable, no soft constraints").
    """

    measured: float
    explained: Mapping[str, float] = field(default_factory=dict)
    unexplained: float = math.nan
    tolerance: Mapping[str, float] = field(default_factory=dict)
    notes: tuple[str, ...] = ()

    @property
    def limit(self) -> float:
        """The largest residual the estimates' own uncertainty allows."""
        return float(sum(self.tolerance.values()))

    @property
    def passed(self) -> bool:
        return math.isfinite(self.unexplained) and self.unexplained <= self.limit

    def as_dict(self) -> dict[str, object]:
        return {"measured": self.measured, "explained": dict(self.explained), "unexplained": self.unexplained,
                "tolerance": dict(self.tolerance), "limit": self.limit, **({"notes": list(self.notes)}
                                                                            if self.notes else {})}

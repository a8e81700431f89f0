"""A Deviation: one figure before it is reduced to a number.

The families (:mod:`harness.families`) measure how far MuJoCo is from the
reference as arrays — per sample of a run, per sampled state — and reduce each
to its figure the same way (the worst sample's norm, divided by a scale). The
error budget takes the same arrays from other runs of the model, combines them
sample by sample, and reduces the result as the figure is, so a figure and its
budget are always measured alike.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from harness.core.figures import Figure, FigureName

__all__ = ["Deviation"]


@dataclass(frozen=True)
class Deviation:
    """A figure before it is reduced to a number.

    Attributes:
        name, unit, description: the figure's.
        values: MuJoCo minus the reference (or MuJoCo alone, where the physics says 0: a drift, a
            violation, a slip), in SI units, with a leading axis of one row per sample (or state).
        kind: ``vector`` (the last axis is x, y, z: the Euclidean norm, then the worst of the rest) or
            ``scalar`` (each entry's absolute value).
        samples: the rows the figure counts (all, or those after ``Case.settle``).
        final: the figure is the last counted sample's, not the maximum over the horizon.
        scale: what the reduced value is divided by (the case's scale for figures in unit 1; else 1).
        size: a typical magnitude of the quantity itself, in the figure's unit: what round-off and
            tolerances are relative to.
    """

    name: FigureName
    values: np.ndarray
    kind: Literal["vector", "scalar"]
    unit: str
    description: str
    samples: np.ndarray | None = None
    final: bool = False
    scale: float = 1.0
    size: float = 1.0

    def magnitude(self, values: np.ndarray | None = None) -> float:
        """``values`` (default: this deviation's own) reduced as the figure is: the maximum over the
        counted samples (or the last one) of the norm or absolute value, worst entry first, / scale."""
        v = self.values if values is None else values
        if self.samples is not None:
            v = v[self.samples]
        if self.final:
            v = v[-1:]
        if v.size == 0:
            return 0.0
        size = np.linalg.norm(v, axis=-1) if self.kind == "vector" else np.abs(v)
        return float(np.max(size)) / self.scale

    def figure(self) -> Figure:
        return Figure(self.name, self.magnitude(), self.unit, self.description)

"""A Figure is one named, dimensioned number the harness measures and may gate."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Figure:
    """``name`` is dotted: ``LAYER.QUANTITY[.DETAIL]``, e.g. ``RK4.force.rod``."""

    name: str
    value: float
    unit: str
    description: str

    def as_dict(self) -> dict[str, object]:
        return {"value": self.value, "unit": self.unit, "description": self.description}


def max_abs(values) -> float:
    import numpy as np

    arr = np.asarray(values, dtype=float)
    return float(np.max(np.abs(arr))) if arr.size else 0.0

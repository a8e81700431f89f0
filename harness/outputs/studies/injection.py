"""The energy-injection study (:mod:`harness.studies.injection`) as a table cell (the zoo's table, harness/zoo.py)."""

from __future__ import annotations

import math

from harness.outputs.studies.engine_faults import sized, unsized_cell
from harness.studies.injection import SIZES_SEARCHED, Injection

__all__ = ["cell"]


def cell(found: Injection) -> str:
    """One model's cell: the smallest injection caught, with the energy it fed in, or why none was."""
    if unsized := unsized_cell(found, largest=SIZES_SEARCHED[0]):
        return unsized
    assert found.size is not None  # unsized_cell names every model without a size
    if math.isnan(found.energy):
        return f"{sized(found.size)} ({found.deciding}; {found.note})"
    return (f"{sized(found.size)}: {found.of_kinetic:.1e} of the peak kinetic energy, {found.of_scale:.1e} of m g L "
            f"({found.deciding})")

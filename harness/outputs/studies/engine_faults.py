"""The engine-side fault study (:mod:`harness.studies.engine_faults`) as table cells: the smallest size caught, or
why none was (the zoo's tables, harness/zoo.py)."""

from __future__ import annotations

import math

from harness.studies.engine_faults import SIZES, Caught

__all__ = ["cell", "sized", "unsized_cell"]


def cell(found: Caught) -> str:
    """One fault's cell: its smallest size caught and the check that caught it there."""
    if unsized := unsized_cell(found, largest=SIZES[0]):
        return unsized
    assert found.size is not None  # unsized_cell names every fault without a size
    return f"{sized(found.size)} ({found.deciding})"


def unsized_cell(found, *, largest: float) -> str:
    """A study's table cell where nothing was sized (crashed, unfinished, n/a, or not caught at ``largest``), from
    ``found``'s ``crashed``, ``unfinished``, ``size`` and ``note``; '' where a size was found."""
    if found.crashed:
        return f"crashed ({found.crashed})"
    if found.unfinished:
        return f"unfinished ({found.unfinished})"
    if found.size is None:
        return f"n/a ({found.note})"
    if math.isnan(found.size):
        return f"> {largest:g}" + (f" ({found.note})" if found.note else "")
    return ""


def sized(size: float) -> str:
    """A size found, its decade, marked ≤ where it is the search's smallest (caught there, perhaps below)."""
    return f"{'≤ ' if size <= SIZES[-1] else ''}{size:.0e}"

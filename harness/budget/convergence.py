"""The ``convergence`` tolerance: where the constraint solver stops (at its tolerance), independently in each run
or evaluation, which no part removes."""

from __future__ import annotations

__all__ = ["NAME", "SOLVER"]

NAME = "convergence"

SOLVER = 10.0
"""The constraint solver stops when its relative improvement falls below its tolerance: × the tolerance × the
quantity's size bounds what the stop leaves, per run."""

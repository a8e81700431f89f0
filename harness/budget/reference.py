"""The ``reference`` tolerance: the reference's own error, which no part removes (trajectories only: the sampled
states' reference is a closed-form evaluation), and the rtol a stiff tree's reference is solved again to."""

from __future__ import annotations

import math
from collections.abc import Mapping

from harness.core.budget import Budget

__all__ = ["NAME", "REFERENCE", "REFERENCE_SHARE", "reference_rtol", "reference_share"]

NAME = "reference"

REFERENCE = 50.0
"""The reference's global error, in units of its rtol × the quantity's size (its measured basis:
docs/findings/bases.md, REFERENCE)."""

REFERENCE_SHARE = 0.5
"""The most of a figure's tolerance the reference's own part may take where the reference's tolerance is ours to
choose (a stiff tree's Radau IIA solve, first made to :data:`analytic.solvers.STIFF_RTOL`): past it the reference
is solved again at the rtol that brings every figure within (:func:`reference_rtol`). At a half, the reference
never allows more of a residual than the model's own settings and round-off do, so a figure's limit is at most
twice theirs (docs/findings/bases.md, REFERENCE_SHARE)."""


def reference_share(budgets: Mapping[str, Budget]) -> tuple[float, str]:
    """The largest fraction of a figure's limit that is the reference's own tolerance, and that figure's name
    ((0, "") where no budget has a reference part)."""
    shares = [(b.tolerance["reference"] / b.limit, name) for name, b in budgets.items()
              if b.tolerance.get("reference", 0.0) > 0.0 and b.limit > 0.0]
    return max(shares, default=(0.0, ""))


def reference_rtol(budgets: Mapping[str, Budget], *, rtol: float, floor: float) -> float | None:
    """The rtol a reference solved to ``rtol`` must be solved to again so that its part is at most
    :data:`REFERENCE_SHARE` of every figure's limit (the part scales with rtol; the others do not depend on
    it), a power of ten at or below what that needs and at least ``floor``; None where ``rtol`` already does."""
    needed = rtol
    for b in budgets.values():
        own = b.tolerance.get("reference", 0.0)
        if own > 0.0 and own > REFERENCE_SHARE * b.limit:
            rest = b.limit - own
            needed = min(needed, rtol * rest * REFERENCE_SHARE / ((1.0 - REFERENCE_SHARE) * own))
    if needed >= rtol:
        return None
    power = 10.0 ** math.floor(math.log10(needed)) if needed > 0.0 else floor
    return max(float(f"{power:.0e}"), floor) if rtol > floor else None

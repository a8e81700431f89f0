"""Extrapolation to an ideal limit, the arithmetic every part that extrapolates shares: from runs (or evaluations)
at a few settings, the value where the setting vanishes.

In the timestep, Richardson: the truncation error of a run at h is κ × (its difference from the run at h/2),
κ = 2ᵖ/(2ᵖ − 1) for an integrator of order p. In a softness setting ε, from runs at ε, sε (and s²ε): linear from
two levels, quadratic from three, the distance between the quadratic estimate and the line through the two levels
nearest the limit then being the estimate's measured uncertainty; or from the near-rigid levels (:func:`from_rigid`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import cast

import numpy as np

__all__ = ["LINEAR_SHRINK", "RIGID_GAIN", "RIGID_TAIL", "from_rigid", "gain", "linearity_note", "richardson",
           "to_zero"]


def richardson(order: float) -> float:
    """κ: the truncation error of a run at h is κ × (its difference from the run at h/2)."""
    return 2.0**order / (2.0**order - 1.0)


def _linear(far: np.ndarray, near: np.ndarray, s: float) -> np.ndarray:
    """The value at 0 of the line through (1, far) and (s, near)."""
    return (near - s * far) / (1.0 - s)


def _weights(count: int, s: float) -> list[float]:
    """The weights of the levels in the value at 0 (Lagrange on the nodes 1, s, s², …)."""
    nodes = [s**k for k in range(count)]
    weights = []
    for i, ei in enumerate(nodes):
        w = 1.0
        for j, ej in enumerate(nodes):
            if j != i:
                w *= -ej / (ei - ej)
        weights.append(w)
    return weights


def gain(count: int, s: float) -> float:
    """Σ |w|: how much extrapolating from ``count`` levels can amplify noise independent between them."""
    return float(sum(abs(w) for w in _weights(count, s)))


def from_rigid(levels: Sequence[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The value at ε → 0 from ``levels`` = values at ε, 2fε and fε (the near-rigid levels:
    :func:`~harness.engine.variants.rigid_factor`), and its uncertainty per entry: the line through the two
    near-rigid levels (MuJoCo's softness is linear in ε near the rigid limit), and :data:`RIGID_TAIL` of what
    that line extrapolates beyond fε. Nothing is extrapolated from the model's own level: however the effect
    grows between fε and ε (not as a polynomial in closed loops of light links: docs/findings/softness.md),
    that difference is measured."""
    ideal = _linear(levels[1], levels[2], 0.5)
    return ideal, RIGID_TAIL * (levels[2] - ideal)


RIGID_TAIL = 1.0
"""The uncertainty of :func:`from_rigid`'s value at 0, in units of what it extrapolates beyond fε: the whole of
it, which bounds the error wherever the effect's slope below fε is within a factor 2 of its secant between fε and
2fε (a weaker assumption than the linearity :data:`~harness.budget.softness.SOFTNESS_UNCERTAINTY` rests on; its
measured basis, Robotiq 2F-85's linkage leaving 37 % of it: docs/findings/bases.md, RIGID_TAIL)."""


RIGID_GAIN = gain(2, 0.5)
"""Σ |w| of :func:`from_rigid`'s value at 0, 2 x(fε) − x(2fε): 3."""


def to_zero(levels: Sequence[np.ndarray], s: float) -> tuple[np.ndarray, np.ndarray | None]:
    """The value at ε → 0 from ``levels`` = values at ε, sε, s²ε, … (two or three), and its uncertainty
    per entry (None from two levels, whose uncertainty only theory can bound).

    Two levels: the line through them. Three: the parabola through them (Lagrange at 0 on the nodes
    1, s, s²), and as uncertainty the difference between it and the line through the two levels
    nearest 0.
    """
    if len(levels) == 2:
        return _linear(levels[0], levels[1], s), None
    if len(levels) != 3:
        raise ValueError(f"extrapolation takes two or three levels, got {len(levels)}")
    quadratic = cast(np.ndarray, sum(w * x for w, x in zip(_weights(3, s), levels, strict=True)))  # a sum of arrays
    return quadratic, quadratic - _linear(levels[1], levels[2], s)


LINEAR_SHRINK = 1.5
"""A softness linear in ε halves its difference from one near-rigid level to the next (2fε → fε → fε/2, the last at
MuJoCo's stiffest ε: a shrink of 2); below this shrink the effect is said not to be linear there
(:func:`linearity_note`). Measured on Cassie's loops: its achilles connects' Jᵀλ shrinks 2.00, the total's (with the
plantar loops' nearly redundant rows) 1.15; the four-bar written for it near its singular pose 1.20 at 0.5° from it,
2.00 at 60° (docs/findings/softness.md, "generalized force")."""


def linearity_note(magnitude: Callable[[np.ndarray], float], twice: np.ndarray, once: np.ndarray,
                   half: np.ndarray) -> str:
    """Where a figure's softness is not linear down to MuJoCo's stiffest ε ('' where it is): its values at 2fε, fε
    and fε/2 (``twice``, ``once``, ``half``; ``magnitude`` reduces a difference as the figure is) differ by amounts
    whose shrink is below :data:`LINEAR_SHRINK`. :func:`from_rigid`'s line and its tail (:data:`RIGID_TAIL`) then
    rest on a premise the levels contradict: MuJoCo's force error r/(a + r) along an eigenvalue a of J M⁻¹ Jᵀ that is
    small against the regularizer r (nearly redundant rows, a pose near a singular one) saturates rather than
    vanishing linearly in ε."""
    upper, lower = magnitude(twice - once), magnitude(once - half)
    if not lower > 0 or upper / lower >= LINEAR_SHRINK:
        return ""
    return (f"softness: not linear down to MuJoCo's stiffest ε: its differences over 2fε→fε and fε→fε/2 "
            f"({upper:.2g}, {lower:.2g}) shrink {upper / lower:.2f}×, not 2× (nearly redundant constraint rows: "
            f"the soft force's error r/(a + r) saturates along a small eigenvalue a of J M⁻¹ Jᵀ), so the line through "
            f"the near-rigid levels does not bound what lies below them")

"""Extrapolation to an ideal limit from runs at a few settings, with the estimate's own uncertainty.

Pure arithmetic on arrays (one entry per sample or state), shared by the
trajectory and instantaneous budgets:

- in the timestep: Richardson, the truncation error of a run at h being
  κ × (its difference from the run at h/2), κ = 2ᵖ/(2ᵖ − 1) for an integrator
  of order p;
- in a softness setting ε, from runs at ε, sε (and s²ε): linear from two
  levels, quadratic from three — then the distance between the quadratic
  estimate and the linear one through the two levels nearest the limit is the
  estimate's measured uncertainty (the correction the last level made).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


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
    quadratic = sum(w * x for w, x in zip(_weights(3, s), levels, strict=True))
    return quadratic, quadratic - _linear(levels[1], levels[2], s)

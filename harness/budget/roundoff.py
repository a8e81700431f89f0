"""The ``roundoff`` tolerance: float round-off, which no part removes and every estimate carries. Its constants;
how each context applies them (a random walk over a run's steps, an evaluation's) is the runs' and the sampled
states' (:mod:`harness.families.runs`, :mod:`harness.families.sampled`)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["NAME", "PERTURBED_FACTOR", "PERTURBED_RUNS", "QUANTIZATION", "READ_ULPS", "ROUNDOFF_EPS", "ulp_states"]

NAME = "roundoff"

ROUNDOFF_EPS = 64
"""Round-off a step, in machine epsilons of the arithmetic a run is stepped in, relative to the quantity's
size; it accumulates as a random walk over the run's steps (harness/families/runs.py)."""

PERTURBED_RUNS = 4
"""Float32 backends: how many round-off copies of the model (each mass and inertia one ulp away, independent
signs: :func:`harness.engine.variants.roundoff_copy`) the backend runs beside a run, or evaluates at the
sampled states, to measure their round-off."""
PERTURBED_FACTOR = 8.0
"""Float32 backends: the round-off part is this × the largest difference between a figure and its perturbed
copies' (stochastic arithmetic, Vignes' CESTAC: round-off is a random process, and runs an ulp apart round
independently after a few steps, so the run's own round-off e₀ and each copy's eᵢ are draws of one law and
dᵢ = eᵢ − e₀ has √2 times its spread). For a normal law of spread σ: |e₀| ≤ 3.3σ with probability 0.999,
and the largest of 4 |dᵢ| falls below 0.42σ with probability (0.236)⁴ = 0.003: |e₀| ≤ 3.3 / 0.42 ≈ 8 × max|dᵢ|
except with probability below 0.005 per figure."""

READ_ULPS = 8.0
"""Float32 backends: the round-off every number read back carries, in machine epsilons of itself, beside
what the copies measure: its storage (½ ulp) and the roundings of the computation that makes it from the
state (forward kinematics down a chain, a solve), which copies holding the same state share bit for bit
(early in a run the copies' positions are equal floats). Its basis is measured: the largest such error of
MJX and Warp against the C engine where every copy's spread was 0, × a margin (docs/findings/bases.md,
READ_ULPS); the float32 rule as a whole is checked against MJX by tests/test_backends.py
(``test_the_float32_roundoff_rule_covers_mjx_float32_against_the_c_engine``)."""

QUANTIZATION = 4.0
"""Float32 backends, trajectories: the round-off of a float32 state's own quantization, in units of the
figure's response to moving the initial state by half an ulp (each coordinate and velocity × (1 ± ε/2),
:func:`ulp_states`, run on the C engine in float64: physics, not arithmetic). A coordinate held by a stiff
soft constraint (the pendulum's slide at r = 1 under a rod of time constant 2 h) is stored to an ulp; when it
crosses from one float to the next its violation jumps by that ulp and the constraint answers with k × ulp,
a force spike no copy of the arithmetic reproduces at the same instant. Its basis is measured: the largest
such spike on MJX float32, in units of that response, × a margin (docs/findings/bases.md, QUANTIZATION); the rule it
enters is checked as :data:`READ_ULPS`'s is."""


def ulp_states(x: Sequence[float] | np.ndarray, *, epsilon: float, seed: int) -> np.ndarray:
    """``x`` with each component × (1 ± ε/2), the signs seeded by ``seed``: a state half an ulp away in an
    arithmetic of machine epsilon ``epsilon`` (:data:`QUANTIZATION`)."""
    x = np.asarray(x, dtype=float)
    return x * (1.0 + 0.5 * epsilon * np.random.default_rng(seed).choice((-1.0, 1.0), size=x.shape))

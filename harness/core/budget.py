"""An error budget: what a figure's size is made of, and what nothing explains.

Every gated figure measures how far MuJoCo is from the physics. Part of that
distance is expected from the model's own settings, and the budget names it:

- ``integration``: the integrator's truncation error at the model's timestep
  (Richardson: the same run at h/2 and the integrator's documented order);
- ``softness``: MuJoCo's soft constraints (solref/solimp), from runs with every
  constraint's effective softness scaled (by ½, or by 2 where it is already at
  MuJoCo's stiffest), extrapolated to the rigid limit;
- ``floors``: a point mass's tiny rotational inertia (MuJoCo needs some), from a
  run with it doubled, extrapolated to zero;
- ``margin``: a contact pair's margin (the contact pushes before it touches), from
  the sampled states with every margin doubled (instantaneous figures only);
- ``solver``: where the model's constraint solver stops short of the solution
  (CG or PGS at their iteration cap), the difference a converged solve makes;
- ``stop``: on a float32 backend, where its solver stopped at float32's
  resolution, the difference the solve completed in float64 makes.

What remains after removing those parts from MuJoCo's run — the run
extrapolated to the ideal limits, compared with the reference — is the
``unexplained`` residual. The verdict judges it against the ``limit``: the sum
of the uncertainties of the estimates themselves (``tolerance``: each part's
own accuracy, and what no part removes: ``roundoff``, float round-off;
``reference``, the reference's tolerance; ``convergence``, the constraint
solver's). A fault (damping, armature, a wrong coefficient) leaves a
residual no part explains; a legitimate setting (another timestep, softer
constraints) moves the parts, not the residual.

The parts are extrapolations to an ideal limit from runs (or evaluations) at a
few settings, pure arithmetic shared by every budget (the end of this module):
in the timestep, Richardson — the truncation error of a run at h is
κ × (its difference from the run at h/2), κ = 2ᵖ/(2ᵖ − 1) for an integrator of
order p —; in a softness setting ε, from runs at ε, sε (and s²ε), linear from
two levels, quadratic from three, the distance between the quadratic estimate
and the line through the two levels nearest the limit then being the estimate's
measured uncertainty.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import cast

import numpy as np

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

SOFTNESS_UNCERTAINTY = 0.25
"""A softness part from two levels is linear in ε up to relative terms O(ε) and O(h/τ): a quarter of it bounds
them for ε up to 1/4 (harness/families/runs.py)."""
FLOOR_UNCERTAINTY = 0.1
"""A point mass's floor inertia (at most 1e-6 m L²) acts linearly: a tenth of the floors' part bounds the rest."""
SOLVER = 10.0
"""The constraint solver stops when its relative improvement falls below its tolerance: × the tolerance × the
quantity's size bounds what the stop leaves, per run."""
SOLVER_PART_UNCERTAINTY = 0.1
"""The solver part (what a converged solve changes) feeds back into the motion: known to a tenth of itself."""
REFERENCE = 50.0
"""The reference's global error, in units of its rtol × the quantity's size (its measured basis:
docs/findings/bases.md, REFERENCE)."""

REFERENCE_SHARE = 0.5
"""The most of a figure's tolerance the reference's own part may take where the reference's tolerance is ours to
choose (a stiff tree's Radau IIA solve, first made to :data:`analytic.solvers.STIFF_RTOL`): past it the reference
is solved again at the rtol that brings every figure within (:func:`reference_rtol`). At a half, the reference
never allows more of a residual than the model's own settings and round-off do, so a figure's limit is at most
twice theirs (docs/findings/bases.md, REFERENCE_SHARE)."""

PARTS = ("integration", "softness", "floors", "margin", "solver", "stop")
TOLERANCES = ("integration", "softness", "floors", "margin", "solver", "stop", "roundoff", "reference",
              "convergence")


def ulp_states(x: Sequence[float] | np.ndarray, *, epsilon: float, seed: int) -> np.ndarray:
    """``x`` with each component × (1 ± ε/2), the signs seeded by ``seed``: a state half an ulp away in an
    arithmetic of machine epsilon ``epsilon`` (:data:`QUANTIZATION`)."""
    x = np.asarray(x, dtype=float)
    return x * (1.0 + 0.5 * epsilon * np.random.default_rng(seed).choice((-1.0, 1.0), size=x.shape))


@dataclass(frozen=True)
class Budget:
    """One figure's budget, in the figure's unit.

    Attributes:
        measured: the figure itself (MuJoCo's run against the reference).
        explained: the size of each part (:data:`PARTS`) that the model's settings explain (the parts
            that apply: no softness without soft constraints).
        unexplained: the residual after the parts are removed.
        tolerance: each source of uncertainty of the residual (:data:`TOLERANCES`); they sum to the limit.
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


# ----------------------------------------------------------------- extrapolation to an ideal limit
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
2fε (a weaker assumption than the linearity :data:`SOFTNESS_UNCERTAINTY` rests on; its measured basis, Robotiq
2F-85's linkage leaving 37 % of it: docs/findings/bases.md, RIGID_TAIL)."""


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

"""The budget of the instantaneous figures: MuJoCo at the sampled states, extrapolated to the ideal limits.

The instantaneous layer evaluates MuJoCo at states on the constraint manifold
(:func:`harness.layers.instant.sample_states`), so nothing is integrated and
no integration error enters. Two settings of the model still move its figures
(:mod:`harness.engine.variants`): the constraints' impedance and the point
masses' inertia floors. The same states are evaluated on the model as it is (A),
with every ε = 1 − d × s (C: s = 1/2, or 2 at the stiffest ε;
:func:`~harness.engine.variants.softness_factor`) and with the floors doubled
(D), and state by state

- softness = A − (the levels A, C (and C₂, ε × s²) extrapolated to ε → 0, as in
  :mod:`harness.budget.trajectory`): at a consistent state (f = 0, J q̇ = 0) a soft equality's
  force is −(A + R)⁻¹Rλ off the rigid one and its acceleration follows, with
  R = (1 − d)/d · Â (computation/index.rst, "Soft constraints"): linear in
  1 − d up to relative terms O(1 − d);
- floors = D − A: linear in the inertia;
- ideal = A − softness − floors,

each reduced as the figure is. The tolerances: 1/4 of the softness part (the
O(1 − d) terms for 1 − d up to 1/4), 1/10 of the floors', float round-off
(:data:`ROUNDOFF` × the quantity's size: the analytic side is a closed-form
evaluation and one KKT solve, MuJoCo's a forward pass) and the constraint
solver's tolerance (:data:`~harness.budget.trajectory.SOLVER` × tolerance × size),
both × the noise gain of the extrapolation (Σ|w| of the evaluations' weights).

On a float32 backend (MJX, MuJoCo Warp) the round-off part is measured instead
of assumed: the backend also evaluates the same states on
:data:`~harness.core.budget.PERTURBED_RUNS` round-off copies of the model
(masses an ulp or two away: the same motion, every rounding different,
:func:`harness.engine.variants.roundoff_copy`), and the round-off tolerance is
:data:`~harness.core.budget.PERTURBED_FACTOR` × the largest difference between
a copy's figure and the figure (× the same noise gain): the basis is
:data:`~harness.core.budget.PERTURBED_FACTOR`'s. To it is added what no copy
moves: the model's constants and the state held in float32 (each off by up to
½ε relative; a state-independent figure such as the Atwood machine's forcing
(m₁ − m₂)g shows the same shift in every copy, and a coordinate held by a soft
equality, off by half an ulp, draws the constraint's force k ½ε L), measured
as the figure's shift on the C engine in float64 when both are rounded
(:func:`harness.engine.variants.represented_model`), and each number's own
reading, :data:`~harness.core.budget.READ_ULPS` × ε × its size. A figure with no
copies (``instant.kinematics``: the C engine's float64 geometry on every
backend) and every figure on a float64 backend keep :data:`ROUNDOFF`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from harness.budget.extrapolate import gain, to_zero
from harness.budget.trajectory import FLOOR_UNCERTAINTY, SOFTNESS_UNCERTAINTY, SOLVER, SOLVER_PART_UNCERTAINTY
from harness.core.budget import PERTURBED_FACTOR, READ_ULPS, Budget
from harness.core.deviation import Deviation
from harness.core.figures import FigureName

ROUNDOFF = 1e4 * float(np.finfo(float).eps)
"""Round-off of one evaluation, relative to the quantity's size: ~2e-12. Measured at the shipped
settings: at most 4e-16 (kinetic energy, mass matrix, forcing); the margin covers an ill-conditioned
mass matrix (condition number up to 1e4)."""


UNSOLVED = ("kinematics", "kinetic_energy", "mass_matrix", "forcing")
"""The instantaneous figures no linear solve enters (positions, M, F); every other one is M⁻¹ of something on both
sides (q̈, the point accelerations, the constraint forces, the reactions)."""
CONDITIONED = 32.0
"""A solve of M x = b errs by about n ε cond(M) relative (n the size), and both sides solve (the reference its KKT
system, MuJoCo its factorization): where CONDITIONED × n × cond(M) × ε (n · cond(M) is ``conditioning``) exceeds
:data:`ROUNDOFF`, it is the round-off tolerance of the solved figures. Basis, measured: dm_control's swimmer (a light
link, cond(M) = 1.2e3, n = 3) has qacc off by 9.3e-12 = 12 n cond(M) ε; 32 keeps a margin of 2.7 over it. Applied
to models judged against their own tree (their cond(M) is not known in advance); the shipped cases keep ROUNDOFF, with
which their limits and fault tests were measured (on four of them n · cond(M) is 583–1490, where this bound would be
1.9–4.8 × ROUNDOFF: not adopted there until their fault matrix is re-run with it)."""
FLOAT64 = float(np.finfo(float).eps)


def instant_budgets(as_is: Sequence[Deviation], *, softness: Sequence[Sequence[Deviation]] = (),
                    heavier: Sequence[Deviation] | None = None, lighter: Sequence[Deviation] | None = None,
                    converged: Sequence[Deviation] | None = None, margins: Sequence[Deviation] | None = None,
                    eps_factor: float = 2.0, solver_tolerance: float = 0.0, notes: Sequence[str] = (),
                    perturbed: Sequence[Sequence[Deviation]] = (),
                    represented: Mapping[FigureName, float] | None = None,
                    epsilon: float = float(np.finfo(np.float32).eps),
                    completed: Sequence[Deviation] | None = None,
                    conditioning: float = 1.0) -> dict[FigureName, Budget]:
    """Every instantaneous figure's budget from the model's deviations at the sampled states (A) and,
    where they apply, the model's with every ε × s, s² (``softness``, s = ``eps_factor``) and with
    heavier floors (D) at the same states; ``lighter``: where given, the floors' part is D − ``lighter``
    instead of D − A (the pair :func:`~harness.engine.variants.floors_pair` makes without fluid forces).
    ``margins``: A with every contact margin doubled (:func:`~harness.engine.variants.wider_margins`); the
    margin part is that minus A, linear in the margin.
    ``converged``: A with the constraints solved exactly, where the model's own solver does not converge
    (the other evaluations are then made that way too).
    ``completed``: on a float32 backend, A with the backend's stopped solve completed in float64
    (:mod:`harness.engine.backends.completion`; the other evaluations are then passed completed too)."""
    levels = [{d.name: d.values for d in group} for group in softness]
    floors = {d.name: d.values for d in heavier or ()}
    floors_base = {d.name: d.values for d in lighter or ()}
    exact = {d.name: d.values for d in converged or ()}
    stopped = {d.name: d.values for d in completed or ()}
    wider = {d.name: d.values for d in margins or ()}
    noise = (gain(len(levels) + 1, eps_factor) if levels else 1.0) + (2.0 if floors else 0.0) \
        + (2.0 if exact else 0.0) + (2.0 if wider else 0.0)
    copies: dict[FigureName, list[np.ndarray]] = {}
    for group in perturbed:
        for d in group:
            copies.setdefault(d.name, []).append(d.values)
    out = {}
    for dev in as_is:
        parts = {}
        a = dev.values
        if dev.name in exact:
            a = exact[dev.name]
            parts["solver"] = dev.values - a
        elif dev.name in stopped:
            a = stopped[dev.name]
            parts["stop"] = dev.values - a
        softness_unc = None
        if levels:
            ideal_eps, uncertainty = to_zero([a, *(level[dev.name] for level in levels)], eps_factor)
            parts["softness"] = a - ideal_eps
            softness_unc = None if uncertainty is None else dev.magnitude(uncertainty)
        if dev.name in floors:
            parts["floors"] = floors[dev.name] - floors_base.get(dev.name, a)
        if dev.name in wider:
            parts["margin"] = wider[dev.name] - a
        ideal = dev.values - sum(parts.values()) if parts else dev.values
        explained = {part: dev.magnitude(values) for part, values in parts.items()}
        # float64: noise × ROUNDOFF × size, in that order (the C backend's limits bit for bit as before)
        solved = dev.name.quantity not in UNSOLVED  # passes through M⁻¹: its round-off grows with cond(M)
        roundoff = noise * max(ROUNDOFF, CONDITIONED * conditioning * FLOAT64 if solved else 0.0) * dev.size
        if dev.name in copies:
            spread = noise * (PERTURBED_FACTOR * max(dev.magnitude(c - dev.values) for c in copies[dev.name])
                              + (represented or {}).get(dev.name, 0.0) + READ_ULPS * epsilon * dev.size)
            # float32: the copies' spread is the round-off; float64 (a constraint solve): the larger of the two
            roundoff = spread if epsilon > FLOAT64 else max(roundoff, spread)
        tolerance = {"softness": SOFTNESS_UNCERTAINTY * explained.get("softness", 0.0) if softness_unc is None
                     else softness_unc,
                     "floors": FLOOR_UNCERTAINTY * explained.get("floors", 0.0),
                     "margin": FLOOR_UNCERTAINTY * explained.get("margin", 0.0),
                     "solver": SOLVER_PART_UNCERTAINTY * explained.get("solver", 0.0),
                     "stop": SOLVER_PART_UNCERTAINTY * explained.get("stop", 0.0),
                     "roundoff": roundoff,
                     "convergence": noise * SOLVER * solver_tolerance * dev.size}
        out[dev.name] = Budget(measured=dev.magnitude(), explained=explained, unexplained=dev.magnitude(ideal),
                               tolerance=tolerance, notes=tuple(notes))
    return out

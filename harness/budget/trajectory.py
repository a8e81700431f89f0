"""The budget of the trajectory figures: MuJoCo's run extrapolated to the ideal limits, against the reference.

For one integrator the model runs several ways (:mod:`harness.engine.variants`),
each a :class:`~harness.core.deviation.Deviation` per figure (MuJoCo minus the
reference, sample by sample, on the grid of the run at the model's timestep h).
With s the softness factor (1/2, or 2 at the stiffest ε;
:func:`~harness.engine.variants.softness_factor`) and r the contacts'
time-constant factor (1.5):

=====  ======================================  ====================================
run    timestep, effective ε, contacts' τ       where
=====  ======================================  ====================================
A      h, ε, τ  (the model as it is)
B      h/2, ε, τ                                always
h/4    h/4, ε, τ                                past the asymptotic range
C      h, sε, τ                                 soft constraints
E      h/2, sε, τ                               soft constraints
C₂     h, s²ε, τ                                soft, ε above the stiffest (s = 1/2)
C′…    h, ε (sε, s²ε), rτ                       contacts
D      h, floors doubled                        point masses (one run, shared)
=====  ======================================  ====================================

x(h, ε, τ) is smooth in each setting near the ideal (h → 0, ε → 0, τ → 0), so
sample by sample, with κ = 2ᵖ/(2ᵖ − 1) (Richardson; p the integrator's
documented order):

- integration = κ(A − B), the truncation error at the model's own softness;
  at each softness level the same correction, κ(C − E) at sε, and for s²ε the
  line through those two (the bilinear model: integration error linear in ε);
- softness: the levels at h → 0 (x₀(ε) = A − κ(A − B), …) extrapolated to
  ε → 0 (:func:`~harness.budget.extrapolate.to_zero`): linearly from two
  levels (the documented sag a_u ε τ² and force error −(A + R)⁻¹Rλ, R ∝
  ε/(1 − ε), are linear near the rigid limit), quadratically from three —
  from MuJoCo's default solimp (ε = 0.1, 0.05 over a 1 mm width) the effect
  grows like ε/(1 − ε)² with d varying over the width, and a line through ε
  and ε/2 leaves a third of it; plus, for contacts, the part linear in τ,
  (y(rτ) − y(τ))/(r − 1), y the levels at h extrapolated to ε → 0 (a contact's
  friction rows give the slip v ≈ γ τ/2 that no impedance removes);
- floors = D − A (linear in the point masses' inertia);
- ideal = A − integration − softness − floors,

and each part and the residual ``|ideal − reference|`` are reduced as the
figure is. Estimating the softness at h → 0 (run E) matters: under ``discrete``
a constraint's response depends on h/τ (the row is folded into the implicit
step), and without E that interaction would be counted twice — once in each part.

What bounds the residual is each estimate's own accuracy (the tolerances, in
the figure's unit):

- integration: Richardson removes the leading term; what remains is the next
  order, relatively O(ω h) of the correction: :data:`INTEGRATION_UNCERTAINTY`
  = 1/4 of it allows ω h up to about 1/2. Where the correction exceeds
  :data:`ASYMPTOTIC` of the quantity's size, or a soft constraint gets fewer
  than two steps per time constant
  (:func:`~harness.engine.variants.steps_per_timeconst`), the run is past the
  asymptotic range and the integrator also runs at h/4: the next order is then measured,
  as twice the distance between the extrapolations from (h, h/2) and
  (h/2, h/4), and the larger of the two bounds holds;
- softness: from two levels (at the stiffest ε, 1e-4) linear up to relative
  terms O(ε) and O(h/τ): :data:`SOFTNESS_UNCERTAINTY` = 1/4 of it; from three,
  measured: the distance between the quadratic and the linear estimate (the
  last level's correction), plus 1/4 of the contacts' τ part;
- floors: an inertia of at most 1e-6 m L² acts linearly: :data:`FLOOR_UNCERTAINTY`;
- round-off, in float64 (the C engine, ``mjx-f64``): :data:`ROUNDOFF` a step
  (:data:`ROUNDOFF_EPS` machine epsilons), accumulating as a random walk over the
  run's N steps, × the quantity's size, × the noise gain of the combination
  (:func:`noise_gain`: Σ|wᵢ| of the runs' weights in the ideal estimate, from
  1.1 for RK4 alone to about 30 with contacts and three softness levels). It sits
  orders of magnitude below every other tolerance there;
- round-off, in float32 (``mjx``, ``warp``), where it is 2²⁹ times larger and
  decides: measured on the backend itself, as stochastic arithmetic measures it
  (Vignes' CESTAC): :data:`~harness.core.budget.PERTURBED_RUNS` copies of the
  run at h, the same model with its masses an ulp or two away (the same motion:
  :func:`~harness.engine.variants.roundoff_copy`, :attr:`Runs.perturbed`), round
  independently from the first step on, and are carried by the system's own dynamics — a pendulum's
  phase error grows with t, a chaotic double pendulum's exponentially, an energy
  error random-walks — so their spread is the round-off this model accumulates
  in this arithmetic, whatever its dynamics do to it. The part is
  :data:`~harness.core.budget.PERTURBED_FACTOR` × the largest difference
  between the figure and a copy's (the factor's basis is in its docstring), ×
  the noise gain, × √(the most steps of any run of the combination / N) (the
  runs at h/2 and h/4 take more steps: a random walk's √); plus what every copy
  shares and so none measures: the model's constants and the initial state held
  in float32, each off by up to ½ε (:attr:`Runs.represented`: the figure's
  shift on the C engine in float64 when they are rounded; systematic, common to
  every run of the combination, whose weights sum to 1: no noise gain); and
  each number's own reading, :data:`~harness.core.budget.READ_ULPS` × ε × the
  quantity's size (what copies holding the same state share bit for bit); and
  the state's own quantization: :data:`~harness.core.budget.QUANTIZATION` × the
  figure's response to the initial state moved by half an ulp (C engine,
  float64: a stiff constraint's force spike when a stored coordinate crosses
  from one float to the next, :attr:`Runs.quantized`), × the noise gain;
- the reference: :data:`REFERENCE` × its rtol × the quantity's size (its global
  error; measured 11 rtol on the spherical pendulum over 5 s);
- the constraint solver's convergence: :data:`SOLVER` × its tolerance × the
  quantity's size × the noise gain, where the model has constraints (the solver
  stops when the relative improvement falls below its tolerance, independently
  in each run). Where the model's own solver does not converge (CG or PGS
  stopped by its iteration cap, a loose tolerance), every run above is made with
  the constraints solved exactly (Newton,
  :func:`~harness.engine.variants.converged_solver`) and the difference the
  model's own solver makes is the ``solver`` part, known to
  :data:`SOLVER_PART_UNCERTAINTY` of itself (it feeds back into the motion).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from harness.budget.extrapolate import richardson, to_zero
from harness.core.budget import PERTURBED_FACTOR, QUANTIZATION, READ_ULPS, ROUNDOFF_EPS, Budget
from harness.core.deviation import Deviation
from harness.core.figures import FigureName
from harness.core.trajectory import Trajectory

INTEGRATION_UNCERTAINTY = 0.25
SOFTNESS_UNCERTAINTY = 0.25
FLOOR_UNCERTAINTY = 0.1
ROUNDOFF = ROUNDOFF_EPS * float(np.finfo(float).eps)
REFERENCE = 50.0
SOLVER = 10.0
ASYMPTOTIC = 0.01
SOLVER_PART_UNCERTAINTY = 0.1


@dataclass(frozen=True)
class Runs:
    """One integrator's runs of the model (see the module docstring), each as its deviations from the
    reference on the grid of the run at h.

    Attributes:
        as_is: A (h, ε, τ).
        half_step: B (h/2).
        quarter_step: h/4, only past the asymptotic range.
        softness: at h with ε × s (C) and, where ε is not at the stiffest, also × s² (C₂).
        softness_half_step: E (h/2, ε × s).
        slower: with contacts, at h with τ × r and ε, ε × s (and ε × s²): C′, C″ (and C‴).
        floors: D − A per figure (:attr:`FigureName.measure`), shared by the integrators: a point
            mass's floor is physics, not integration.
        converged: where the model's own constraint solver does not converge (CG, PGS, a loose
            tolerance), A with the constraints solved exactly (Newton); every other run is then made
            that way too, and A − converged is the ``solver`` part.
        perturbed: on a float32 backend, :data:`~harness.core.budget.PERTURBED_RUNS` copies of A from
            its masses an ulp or two away (:func:`~harness.engine.variants.roundoff_copy`): their
            spread measures A's round-off (empty on float64, where :data:`ROUNDOFF` applies).
        represented: on a float32 backend, each figure's shift (by measure) with the model's constants and
            the initial state held in float32 (:func:`harness.budget.measure._represented`): what every copy
            shares, so none measures it.
        quantized: on a float32 backend, each figure's response (by measure) to the initial state moved by
            half an ulp, on the C engine (:func:`harness.budget.measure._quantized`): × :data:`QUANTIZATION`,
            the state's own quantization.
        completed: on a float32 backend with constraints, A with each sample's stopped solve completed in
            float64 (:attr:`harness.core.trajectory.Trajectory.completed`); every other run is then taken
            completed too, and A − completed is the ``stop`` part.
        eps_factor, tc_factor: s and r.
    """

    as_is: Sequence[Deviation]
    half_step: Sequence[Deviation]
    quarter_step: Sequence[Deviation] | None = None
    softness: Sequence[Sequence[Deviation]] = ()
    softness_half_step: Sequence[Deviation] | None = None
    slower: Sequence[Sequence[Deviation]] = ()
    floors: Mapping[str, np.ndarray] | None = None
    converged: Sequence[Deviation] | None = None
    perturbed: Sequence[Sequence[Deviation]] = ()
    represented: Mapping[str, float] = field(default_factory=dict)
    quantized: Mapping[str, float] = field(default_factory=dict)
    eps_factor: float = 2.0
    tc_factor: float = 1.5
    completed: Sequence[Deviation] | None = None


def every_nth(sim: Trajectory, n: int) -> Trajectory:
    """A run at h/n on the grid of the run at h (every n-th sample)."""
    if n == 1:
        return sim

    def take(group: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        return {k: v[::n] for k, v in group.items()}

    return Trajectory(t=sim.t[::n], positions=take(sim.positions), velocities=take(sim.velocities),
                      multipliers=take(sim.multipliers),
                      generalized_force=None if sim.generalized_force is None else sim.generalized_force[::n],
                      invariants=take(sim.invariants), violations=take(sim.violations), source=sim.source,
                      series=take(sim.series), completed=None if sim.completed is None else every_nth(sim.completed, n))


def past_asymptotic(as_is: Sequence[Deviation], half_step: Sequence[Deviation], order: float) -> bool:
    """Whether any figure's Richardson correction κ(A − B) exceeds :data:`ASYMPTOTIC` of its quantity's
    size (a relative figure's size is 1), or any figure's error changes with h unlike the documented order
    (:func:`off_order`)."""
    kappa = richardson(order)
    b = _by_name(half_step)
    return any(d.magnitude(kappa * (d.values - b[d.name])) > ASYMPTOTIC * d.size
               or off_order(d, b[d.name], order) for d in as_is)


SHARE_SLACK = 0.15
"""How far the share of a figure's error that halving h removes, |A − B| / |A|, may stray from the documented order's
1 − 2⁻ᵖ before the run at h/4 measures the estimate's own error. An error that behaves at one order higher (semi-
implicit Euler on a conservative motion is conjugate to a second-order method: 0.75 for p = 1) makes κ(A − B)
overestimate by 1.5×; one order up from p = 4 shifts the share by 0.03 and the estimate by 3 %, inside its
tolerance."""
SHARE_FLOOR = 0.1
"""Below this share the error barely changes with h (softness, floors): the estimate is not at stake."""


def off_order(dev: Deviation, half: np.ndarray, order: float) -> bool:
    """Whether ``dev``'s error at h and h/2 (``half``) changes unlike an error of ``order``: the share halving
    removes is at least :data:`SHARE_FLOOR` and strays from 1 − 2⁻ᵖ by more than :data:`SHARE_SLACK`."""
    whole = dev.magnitude(dev.values)
    if not whole > 0:
        return False
    share = dev.magnitude(dev.values - half) / whole
    return share >= SHARE_FLOOR and abs(share - (1.0 - 2.0 ** -order)) > SHARE_SLACK


def _by_name(group: Sequence[Deviation] | None) -> dict[str, np.ndarray]:
    return {d.name: d.values for d in group or ()}


@dataclass(frozen=True)
class Parts:
    """One figure's explained parts, sample by sample, and the uncertainties measured for them (None
    where only theory bounds them): the integration's from the run at h/4, the softness's from a third
    level of ε; ``timeconst`` is the contacts' τ part (inside ``explained["softness"]``)."""

    explained: dict[str, np.ndarray]
    integration_uncertainty: np.ndarray | None = None
    softness_uncertainty: np.ndarray | None = None
    timeconst: np.ndarray | None = None


def parts(runs: Runs, dev: Deviation, *, order: float) -> Parts:
    """The explained parts of one figure, sample by sample (see the module docstring)."""
    kappa = richardson(order)
    s, r = runs.eps_factor, runs.tc_factor
    explained: dict[str, np.ndarray] = {}
    a = dev.values
    if runs.converged is not None:  # the other runs solve their constraints exactly; so does this one
        a = _by_name(runs.converged)[dev.name]
        explained["solver"] = dev.values - a
    elif runs.completed is not None:  # the other runs are taken completed; so is this one
        a = _by_name(runs.completed)[dev.name]
        explained["stop"] = dev.values - a
    b = _by_name(runs.half_step)[dev.name]
    explained["integration"] = kappa * (a - b)
    integration_unc = None
    if runs.quarter_step is not None:
        q = _by_name(runs.quarter_step)[dev.name]
        integration_unc = 2.0 * ((a - kappa * (a - b)) - (b - kappa * (b - q)))
    softness_unc = timeconst = None
    if runs.softness and runs.softness_half_step is not None:
        levels = [a, *(_by_name(group)[dev.name] for group in runs.softness)]
        corrections = [explained["integration"], kappa * (levels[1] - _by_name(runs.softness_half_step)[dev.name])]
        for k in range(2, len(levels)):  # the integration error is linear in ε (bilinear model)
            corrections.append(corrections[0] + (corrections[1] - corrections[0]) * (s**k - 1.0) / (s - 1.0))
        at_zero_h = [x - c for x, c in zip(levels, corrections, strict=True)]
        ideal, uncertainty = to_zero(at_zero_h, s)
        softness = at_zero_h[0] - ideal
        softness_unc = None if uncertainty is None else np.abs(uncertainty)
        if runs.slower:
            y_tau, unc_tau = to_zero(levels, s)
            y_slow, unc_slow = to_zero([_by_name(group)[dev.name] for group in runs.slower], s)
            timeconst = (y_slow - y_tau) / (r - 1.0)
            softness = softness + timeconst
            if softness_unc is not None and unc_tau is not None and unc_slow is not None:
                softness_unc = softness_unc + (r * np.abs(unc_tau) + np.abs(unc_slow)) / (r - 1.0)
        explained["softness"] = softness
    if runs.floors is not None and dev.name.measure in runs.floors:
        explained["floors"] = runs.floors[dev.name.measure]
    return Parts(explained, integration_unc, softness_unc, timeconst)


RESOLVED = 0.5
"""The largest next-order term, relative to the Richardson correction it follows, at which an integrator's
error is still an expansion in h (:func:`unresolved`)."""


def unresolved(runs: Runs, *, order: float, integrator: str) -> str:
    """Why ``runs`` cannot be budgeted at all ('' when they can): the timestep is outside the integrator's
    asymptotic range. Richardson assumes the error is its leading term plus a smaller rest; the run at h/4
    measures the rest (see the module docstring). Where it reaches :data:`RESOLVED` of the leading term on
    the position, h, h/2 and h/4 are not a converging sequence — a pendulum stepped by a sizeable part of its
    period — and no estimate separates integration error from a fault: every figure of the integrator fails
    with this reason rather than pass inside a limit as large as the figure."""
    if runs.quarter_step is None:
        return ""
    for dev in runs.as_is:
        if dev.name.measure != "position":
            continue
        found = parts(runs, dev, order=order)
        if found.integration_uncertainty is None:
            return ""
        leading = dev.magnitude(found.explained["integration"])
        rest = dev.magnitude(found.integration_uncertainty)
        if rest > RESOLVED * leading and leading > ASYMPTOTIC * dev.size:
            return (f"unresolved: the timestep is outside {integrator}'s asymptotic range (the runs at h, h/2 and "
                    f"h/4 give a next-order term {rest:.2g} against a leading term {leading:.2g} on the position, "
                    f"more than {RESOLVED:g} of it), so no budget can tell its error from a fault")
    return ""


def noise_gain(runs: Runs, *, order: float) -> float:
    """Σ |wᵢ|: how much the ideal estimate (a linear combination Σ wᵢ xᵢ of the runs, Σ wᵢ = 1) can
    amplify noise that is independent from run to run (round-off, the constraint solver stopping at its
    tolerance). Found by linearity: the estimate with one run's values 1 and every other's 0 is its
    weight. The floors' part D − A adds 2 (its two runs, each with weight ±1)."""
    name = FigureName("x.position")
    groups = {"as_is": 1, "converged": int(runs.converged is not None), "half_step": 1,
              "quarter_step": int(runs.quarter_step is not None),
              "softness": len(runs.softness), "softness_half_step": int(runs.softness_half_step is not None),
              "slower": len(runs.slower)}

    def unit(hot: tuple[str, int], label: str, index: int = 0) -> list[Deviation]:
        return [Deviation(name, np.array([1.0 if hot == (label, index) else 0.0]), "scalar", "1", "")]

    gain = 0.0
    for label, count in groups.items():
        for index in range(count):
            hot = (label, index)
            probe = Runs(as_is=unit(hot, "as_is"), half_step=unit(hot, "half_step"),
                         converged=unit(hot, "converged") if groups["converged"] else None,
                         quarter_step=unit(hot, "quarter_step") if groups["quarter_step"] else None,
                         softness=tuple(unit(hot, "softness", k) for k in range(groups["softness"])),
                         softness_half_step=unit(hot, "softness_half_step") if groups["softness_half_step"]
                         else None,
                         slower=tuple(unit(hot, "slower", k) for k in range(groups["slower"])),
                         eps_factor=runs.eps_factor, tc_factor=runs.tc_factor)
            dev = probe.as_is[0]
            found = parts(probe, dev, order=order)
            gain += float(abs((dev.values - sum(found.explained.values()))[0]))
    return gain + (2.0 if runs.floors is not None else 0.0)


def budgets(runs: Runs, *, order: float, steps: int, rtol: float, solver_tolerance: float,
            notes: Sequence[str] = (), epsilon: float = float(np.finfo(float).eps)) -> dict[FigureName, Budget]:
    """Every figure's budget from one integrator's runs (see the module docstring): round-off and the
    tolerances are relative to each quantity's size (``Deviation.size``); ``solver_tolerance`` is 0
    where the model has no constraints; ``epsilon`` the machine epsilon of the arithmetic the runs were
    stepped in (float64's: :data:`ROUNDOFF` exactly; a float32 run's round-off is its perturbed copies'
    spread instead, :attr:`Runs.perturbed`)."""
    roundoff = ROUNDOFF if epsilon == float(np.finfo(float).eps) else ROUNDOFF_EPS * epsilon
    walk = math.sqrt(max(steps, 1))
    gain = noise_gain(runs, order=order)
    longest = 4.0 if runs.quarter_step is not None else 2.0  # the most steps of any run, in units of N
    spread = {d.name: 0.0 for d in runs.as_is}
    for copy in runs.perturbed:
        for dev, other in zip(runs.as_is, copy, strict=True):
            spread[dev.name] = max(spread[dev.name], dev.magnitude(other.values - dev.values))
    out = {}
    for dev in runs.as_is:
        found = parts(runs, dev, order=order)
        ideal = dev.values - sum(found.explained.values())
        explained = {part: dev.magnitude(values) for part, values in found.explained.items()}
        integration = INTEGRATION_UNCERTAINTY * explained["integration"]
        if found.integration_uncertainty is not None:  # measured: never below what theory allows
            integration = max(integration, dev.magnitude(found.integration_uncertainty))
        if found.softness_uncertainty is None:
            softness = SOFTNESS_UNCERTAINTY * explained.get("softness", 0.0)
        else:
            softness = dev.magnitude(found.softness_uncertainty)
            if found.timeconst is not None:
                softness += SOFTNESS_UNCERTAINTY * dev.magnitude(found.timeconst)
        tolerance = {"integration": integration,
                     "softness": softness,
                     "solver": SOLVER_PART_UNCERTAINTY * explained.get("solver", 0.0),
                     "stop": SOLVER_PART_UNCERTAINTY * explained.get("stop", 0.0),
                     "floors": FLOOR_UNCERTAINTY * explained.get("floors", 0.0),
                     "roundoff": (gain * PERTURBED_FACTOR * math.sqrt(longest) * spread[dev.name]
                                  + gain * QUANTIZATION * runs.quantized.get(dev.name.measure, 0.0)
                                  + runs.represented.get(dev.name.measure, 0.0) + READ_ULPS * epsilon * dev.size
                                  if runs.perturbed else gain * roundoff * walk * dev.size),
                     "reference": REFERENCE * rtol * dev.size,
                     "convergence": gain * SOLVER * solver_tolerance * dev.size}
        out[dev.name] = Budget(measured=dev.magnitude(), explained=explained, unexplained=dev.magnitude(ideal),
                               tolerance=tolerance, notes=tuple(notes))
    return out

"""The runs over the horizon: each integrator's run at the model's settings, the variants its budget needs, and the
budget of every figure compared over a run — MuJoCo's run extrapolated to the ideal limits, against the reference.

What is compared over a run is the families' (:mod:`harness.families.trajectory`, :mod:`harness.families.invariants`:
:data:`Compare`); every run, variants included, is compared by all of them at once, so that each decision about
an integrator's runs (whether h/4 is needed, whether its runs can be budgeted at all) sees every figure.

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

Where every ε is at least 8 × the stiffest and no contact is soft, C, C₂ and E are at the near-rigid levels
instead: 2fε, fε and (h/2, fε) (:func:`~harness.engine.variants.rigid_factor`), and the softness part is
measured down to fε, not extrapolated across ε (:func:`~harness.budget.extrapolation.from_rigid`).

x(h, ε, τ) is smooth in each setting near the ideal (h → 0, ε → 0, τ → 0), so
sample by sample, with κ = 2ᵖ/(2ᵖ − 1) (Richardson; p the integrator's
documented order):

- integration = κ(A − B), the truncation error at the model's own softness;
  at each softness level the same correction, κ(C − E) at sε, and for s²ε the
  line through those two (the bilinear model: integration error linear in ε);
- softness: the levels at h → 0 (x₀(ε) = A − κ(A − B), …) extrapolated to
  ε → 0 (:func:`~harness.budget.extrapolation.to_zero`): linearly from two
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

Each part's estimate and tolerance is its module's in :mod:`harness.budget` (the
registry's parts, iterated by :func:`parts` and :func:`budgets`), and so are its
own runs (:attr:`harness.budget.part.Part.runs`: D is the floors', made once by
:func:`variant_runs` and shared; a part's own per integrator are made by
:func:`_integrator_runs`), handed back under its name in :attr:`Runs.own`. This
module makes what the parts share: A, the integration ladder (B, h/4) with the
softness levels on it (C, E, C₂, C′…, each taken to h → 0 on the same ladder),
the baseline solves every run is made with (the converged solve, the completed
one), the round-off copies, and the round-off, reference and convergence
tolerances. What bounds the residual is each estimate's own accuracy (the
tolerances, in the figure's unit):

- integration: Richardson removes the leading term; what remains is the next
  order, relatively O(ω h) of the correction: :data:`~harness.budget.integration.INTEGRATION_UNCERTAINTY`
  = 1/4 of it allows ω h up to about 1/2. Where the correction exceeds
  :data:`ASYMPTOTIC` of the quantity's size, or a soft constraint gets fewer
  than two steps per time constant
  (:func:`~harness.engine.variants.steps_per_timeconst`), the run is past the
  asymptotic range and the integrator also runs at h/4: the next order is then measured,
  as twice the distance between the extrapolations from (h, h/2) and
  (h/2, h/4), and the larger of the two bounds holds;
- softness: from two levels (at the stiffest ε, 1e-4) linear up to relative
  terms O(ε) and O(h/τ): :data:`~harness.budget.softness.SOFTNESS_UNCERTAINTY` = 1/4 of it; from three,
  measured: the distance between the quadratic and the linear estimate (the
  last level's correction), plus 1/4 of the contacts' τ part;
- floors: an inertia of at most 1e-6 m L² acts linearly: :data:`~harness.budget.floors.FLOOR_UNCERTAINTY`;
- round-off, in float64 (the C engine, ``mjx-f64``): :data:`ROUNDOFF` a step
  (:data:`~harness.budget.roundoff.ROUNDOFF_EPS` machine epsilons), accumulating as a random walk over the
  run's N steps, × the quantity's size, × the noise gain of the combination
  (:func:`noise_gain`: Σ|wᵢ| of the runs' weights in the ideal estimate, from
  1.1 for RK4 alone to about 30 with contacts and three softness levels). It sits
  orders of magnitude below every other tolerance there;
- round-off, in float32 (``mjx``, ``warp``), where it is 2²⁹ times larger and
  decides: measured on the backend itself, as stochastic arithmetic measures it
  (Vignes' CESTAC): :data:`~harness.budget.roundoff.PERTURBED_RUNS` copies of the
  run at h, the same model with its masses an ulp or two away (the same motion:
  :func:`~harness.engine.variants.roundoff_copy`, :attr:`Runs.perturbed`), round
  independently from the first step on, and are carried by the system's own dynamics — a pendulum's
  phase error grows with t, a chaotic double pendulum's exponentially, an energy
  error random-walks — so their spread is the round-off this model accumulates
  in this arithmetic, whatever its dynamics do to it. The part is
  :data:`~harness.budget.roundoff.PERTURBED_FACTOR` × the largest difference
  between the figure and a copy's (the factor's basis is in its docstring), ×
  the noise gain, × √(the most steps of any run of the combination / N) (the
  runs at h/2 and h/4 take more steps: a random walk's √); plus what every copy
  shares and so none measures: the model's constants and the initial state held
  in float32, each off by up to ½ε (:attr:`Runs.represented`: the figure's
  shift on the C engine in float64 when they are rounded; systematic, common to
  every run of the combination, whose weights sum to 1: no noise gain); and
  each number's own reading, :data:`~harness.budget.roundoff.READ_ULPS` × ε × the
  quantity's size (what copies holding the same state share bit for bit); and
  the state's own quantization: :data:`~harness.budget.roundoff.QUANTIZATION` × the
  figure's response to the initial state moved by half an ulp (C engine,
  float64: a stiff constraint's force spike when a stored coordinate crosses
  from one float to the next, :attr:`Runs.quantized`), × the noise gain;
- the reference: :data:`~harness.budget.reference.REFERENCE` × its rtol × the quantity's size (its global
  error, measured: docs/findings/bases.md);
- the constraint solver's convergence: :data:`~harness.budget.convergence.SOLVER` × its tolerance × the
  quantity's size × the noise gain, where the model has constraints (the solver
  stops when the relative improvement falls below its tolerance, independently
  in each run). Where the model's own solver does not converge (CG or PGS
  stopped by its iteration cap, a loose tolerance), every run above is made with
  the constraints solved exactly (Newton,
  :func:`~harness.engine.variants.converged_solver`) and the difference the
  model's own solver makes is the ``solver`` part, known to
  :data:`~harness.budget.solver.SOLVER_PART_UNCERTAINTY` of itself (it feeds back into the motion).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import os
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from analytic.systems import Scales
from harness.budget import registry
from harness.budget.convergence import SOLVER
from harness.budget.extrapolation import richardson
from harness.budget.inputs import Runs, by_name
from harness.budget.integration import INTEGRATION_UNCERTAINTY
from harness.budget.part import Estimates, Making
from harness.budget.reference import REFERENCE
from harness.budget.roundoff import PERTURBED_FACTOR, PERTURBED_RUNS, QUANTIZATION, READ_ULPS, ROUNDOFF_EPS, ulp_states
from harness.cases import Series
from harness.core.budget import Budget
from harness.core.deviation import Deviation
from harness.core.errors import SimulationDiverged
from harness.core.figures import FigureName
from harness.core.trajectory import Trajectory
from harness.engine import variants as V
from harness.engine.backends import Backend, Request, simulate
from harness.engine.compat import applicable_defect, joint_types
from harness.engine.integrators import EXPECTED_ORDER, integrator_name
from harness.engine.probe import Probe
from harness.engine.recording import record

__all__ = ["INTEGRATION_UNCERTAINTY", "RIGID_SPLITS", "Budgets", "Compare", "Runs", "Target", "budget", "budgets",
           "compared", "every_nth", "largest", "noise_gain", "point_differences", "rigid_resolved", "unresolved"]

ROUNDOFF = ROUNDOFF_EPS * float(np.finfo(float).eps)
ASYMPTOTIC = 0.01


# ----------------------------------------------------------------- what a run is compared with
Compare = Callable[["Target", Trajectory, str], list[Deviation]]
"""A family's comparison of one run (named by its integrator) with the reference: its figures as deviations, a row
per sample on the grid of the run at h."""


@dataclass(frozen=True)
class Target:
    """What every run is compared with: the reference on the runs' grid, the case's scales, settle time and
    MuJoCo-only series, the state every run starts from, the reference's tolerance, and the families'
    comparisons (:data:`Compare`, in family order)."""

    reference: Trajectory
    scales: Scales
    settle: float
    series: Mapping[str, Series]
    q0: np.ndarray
    qd0: np.ndarray
    rtol: float
    compare: tuple[Compare, ...] = ()


def _check_grid(ref: Trajectory, sim: Trajectory) -> None:
    if ref.t.shape != sim.t.shape or not np.allclose(ref.t, sim.t, rtol=0, atol=1e-9):
        raise ValueError("trajectories must share one time grid")
    if set(ref.positions) != set(sim.positions):
        raise ValueError(f"point names differ: {sorted(ref.positions)} vs {sorted(sim.positions)}")


def compared(target: Target, sim: Trajectory, prefix: str) -> list[Deviation]:
    """``sim`` (on the grid of the run at h) compared with the reference by every family, its figures named
    ``prefix`` (the integrator)."""
    _check_grid(target.reference, sim)
    return [d for compare in target.compare for d in compare(target, sim, prefix)]


def point_differences(a: Mapping[str, np.ndarray], b: Mapping[str, np.ndarray]) -> np.ndarray:
    """a − b per point, stacked: shape (N, points, 3)."""
    return np.stack([a[p] - b[p] for p in a], axis=1)


def largest(values: np.ndarray, *, vector: bool = False) -> float:
    """The largest entry's size (the largest vector norm with ``vector``); 0 for no entries."""
    if values.size == 0:
        return 0.0
    return float(np.max(np.linalg.norm(values, axis=-1) if vector else np.abs(values)))


# ----------------------------------------------------------------- the budget's arithmetic

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
    b = by_name(half_step)
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


@dataclass(frozen=True)
class Parts:
    """One figure's explained parts, sample by sample, and the uncertainties measured for them (None
    where only theory bounds them): the integration's from the run at h/4, the softness's from a third
    level of ε; ``timeconst`` is the contacts' τ part (inside ``explained["softness"]``)."""

    explained: dict[str, np.ndarray]
    integration_uncertainty: np.ndarray | None = None
    softness_uncertainty: np.ndarray | None = None
    timeconst: np.ndarray | None = None
    estimates: Estimates | None = None


def parts(runs: Runs, dev: Deviation, *, order: float) -> Parts:
    """The explained parts of one figure, sample by sample (see the module docstring): each part's estimate
    over the runs (:data:`harness.budget.registry.OVER_RUNS`)."""
    found = registry.over_runs(runs, dev, kappa=richardson(order))
    return Parts(found.explained, found.uncertainty.get("integration"), found.uncertainty.get("softness"),
                 found.timeconst, found)


RESOLVED = 0.5
"""The largest next-order term, relative to the Richardson correction it follows, at which an integrator's
error is still an expansion in h (:func:`unresolved`)."""


GROWN = 1e3
"""How many times the motion's own extent (the position figure's :attr:`Deviation.size`) a run's position error may
reach before the run is called diverged rather than judged (:func:`grown`); its basis is in
docs/findings/bases.md."""


def grown(deviations: Sequence[Deviation], *, integrator: str) -> str:
    """Why the run at h diverged although MuJoCo raised no warning ('' when it did not): its points left the
    reference by more than :data:`GROWN` times the motion's own extent. No budget part can explain an error a
    thousand times the motion it approximates, and no number of such a run is a measurement: it is a divergence,
    reported as one, never an "unresolved" figure. (The position, not the energy: a fault in a potential — a stiff
    spring the reference lacks — makes the energy huge in a run that stays put, and that run is judged by its
    numbers.)"""
    for dev in deviations:
        if dev.name.measure != "position" or dev.size <= 0:
            continue
        size = dev.magnitude() / dev.size
        if size > GROWN:
            return (f"diverged: {integrator}'s points left the reference by {size:.3g} times the motion's extent "
                    f"(more than {GROWN:g}) without a MuJoCo warning")
    return ""


def unresolved(runs: Runs, *, order: float, integrator: str) -> str:
    """Why ``runs`` cannot be budgeted at all ('' when they can): the timestep is outside the integrator's
    asymptotic range. Richardson assumes the error is its leading term plus a smaller rest; the run at h/4
    measures the rest (see the module docstring). Where it reaches :data:`RESOLVED` of the leading term on
    the position, h, h/2 and h/4 are not a converging sequence — a pendulum stepped by a sizeable part of its
    period — and no estimate separates integration error from a fault: every figure of the integrator fails
    with this reason rather than pass inside a limit as large as the figure."""
    if runs.rigid_unresolved:
        return runs.rigid_unresolved
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


RIGID_SPLITS = (1, 2, 4, 8, 16, 32, 64)
"""The first split s of the near-rigid levels' runs at h/s, h/2s and h/4s, tried in turn until they are inside the
integrator's asymptotic range (:func:`rigid_resolved`); the deepest run is at h/256. Halving s from one try to the
next costs one new run a try (h/4s; the other two are the last try's) and stops at the shallowest split inside the
range. Under ``discrete`` a closed loop of light links at the near-rigid ε leaves that range at the model's step
while the model's own ε does not (Cassie: docs/findings/softness.md, "discrete")."""


def rigid_resolved(level: Sequence[Sequence[Deviation]], *, order: float) -> bool:
    """Whether one near-rigid level's runs at h/s, h/2s and h/4s (``level``) are inside the integrator's asymptotic
    range: on every figure whose Richardson correction from h/s and h/2s exceeds :data:`ASYMPTOTIC` of its size, the
    next-order rest (twice the distance between the extrapolations from (h/s, h/2s) and (h/2s, h/4s)) is at most
    :data:`RESOLVED` of that correction. The rule :func:`unresolved` applies to the model's own position, here on
    every figure: at a near-rigid ε a loop's connect force can leave the range while the position barely does."""
    kappa = richardson(order)
    x, y, z = (by_name(group) for group in level)
    for dev in level[0]:
        a, b, c = x[dev.name], y[dev.name], z[dev.name]
        leading = dev.magnitude(kappa * (a - b))
        rest = dev.magnitude(2.0 * ((a - kappa * (a - b)) - (b - kappa * (b - c))))
        if leading > ASYMPTOTIC * dev.size and rest > RESOLVED * leading:
            return False
    return True


def noise_gain(runs: Runs, *, order: float) -> float:
    """Σ |wᵢ|: how much the ideal estimate (a linear combination Σ wᵢ xᵢ of the runs, Σ wᵢ = 1) can
    amplify noise that is independent from run to run (round-off, the constraint solver stopping at its
    tolerance). Found by linearity: the estimate with one run's values 1 and every other's 0 is its
    weight; each part's own runs (:attr:`Runs.own`: the lists of deviations in its record) are weighed so too, after
    the shared ones, and a part adds its :attr:`~harness.budget.part.Part.runs_gain` for what it keeps as numbers
    made elsewhere (the floors' D − A: 2, its two runs, each with weight ±1)."""
    name = FigureName("x.position")
    owned = {p.name: _run_count(runs.own[p.name]) for p in registry.ALL if p.name in runs.own}
    groups = {"as_is": 1, "converged": int(runs.converged is not None), "half_step": 1,
              "quarter_step": int(runs.quarter_step is not None),
              "softness": len(runs.softness), "softness_half_step": int(runs.softness_half_step is not None),
              "slower": len(runs.slower), "rigid_ladder": 3 * len(runs.rigid_ladder),
              **{f"own.{part}": count for part, count in owned.items() if count}}

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
                         eps_factor=runs.eps_factor, tc_factor=runs.tc_factor, rigid=runs.rigid,
                         rigid_ladder=tuple(tuple(unit(hot, "rigid_ladder", 3 * level + k) for k in range(3))
                                            for level in range(len(runs.rigid_ladder))),
                         own={part: _with_runs(runs.own[part], functools.partial(unit, hot, f"own.{part}"))
                              for part, count in owned.items() if count})
            dev = probe.as_is[0]
            found = parts(probe, dev, order=order)
            gain += float(abs((dev.values - sum(found.explained.values()))[0]))
    for part in registry.ALL:
        if part.name in runs.own:
            gain += part.runs_gain
    return gain


def _is_run(value: object) -> bool:
    """Whether ``value`` is one run's deviations (a list or tuple of :class:`Deviation`)."""
    return isinstance(value, list | tuple) and bool(value) and all(isinstance(v, Deviation) for v in value)


def _run_count(value: object) -> int:
    """How many runs a part's record holds (:attr:`Runs.own`): its lists of deviations, alone or in tuples."""
    if _is_run(value):
        return 1
    if isinstance(value, list | tuple):
        return sum(_run_count(v) for v in value)
    return 0


def _with_runs(value: object, made: Callable[[int], list[Deviation]], start: int = 0) -> Any:
    """A part's record with its k-th run (in :func:`_run_count`'s order) replaced by ``made(k)``."""
    if _is_run(value):
        return made(start)
    if isinstance(value, list | tuple):
        out = []
        for v in value:
            out.append(_with_runs(v, made, start))
            start += _run_count(v)
        return type(value)(out)
    return value


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
    if runs.rigid_ladder:
        longest = max(longest, 4.0 * runs.rigid_split)
    spread = {d.name: 0.0 for d in runs.as_is}
    for copy in runs.perturbed:
        for dev, other in zip(runs.as_is, copy, strict=True):
            spread[dev.name] = max(spread[dev.name], dev.magnitude(other.values - dev.values))
    if runs.rigid_ladder:
        s = runs.rigid_split
        notes = (*notes, f"softness: the near-rigid levels 2fε, fε taken to h → 0 from their runs at h/{s}, h/{2 * s} "
                         f"and h/{4 * s}: at h, h/2 and h/4 they are outside the integrator's asymptotic range")
    out = {}
    for dev in runs.as_is:
        found = parts(runs, dev, order=order)
        ideal = dev.values - sum(found.explained.values())
        explained = {part: dev.magnitude(values) for part, values in found.explained.items()}
        assert found.estimates is not None
        tolerance = {**registry.tolerances(found.estimates, explained, runs=True),
                     "roundoff": (gain * PERTURBED_FACTOR * math.sqrt(longest) * spread[dev.name]
                                  + gain * QUANTIZATION * runs.quantized.get(dev.name.measure, 0.0)
                                  + runs.represented.get(dev.name.measure, 0.0) + READ_ULPS * epsilon * dev.size
                                  if runs.perturbed else gain * roundoff * walk * dev.size),
                     "reference": REFERENCE * rtol * dev.size,
                     "convergence": gain * SOLVER * solver_tolerance * dev.size}
        out[dev.name] = Budget(measured=dev.magnitude(), explained=explained, unexplained=dev.magnitude(ideal),
                               tolerance=tolerance, notes=(*notes, *found.estimates.notes))
    return out


# ----------------------------------------------------------------- the runs
def _completed(sim: Trajectory) -> Trajectory:
    """A variant run as the budget compares it: with its stopped solves completed where the backend's were
    (:attr:`harness.core.trajectory.Trajectory.completed`), so that two runs differ by their settings, not by
    where each run's float32 solver stopped."""
    return sim if sim.completed is None else sim.completed


def _variant_request(mut: V.ModelUnderTest, engine: Backend, target: Target, model: mujoco.MjModel, *, steps: int,
                     split: int = 1, eps_factor: float = 1.0, tc_factor: float = 1.0, perturb: int = 0) -> Request:
    """One variant of ``model`` (:func:`~harness.engine.variants.variant`) over the horizon, its constraints
    solved exactly where the model's own solver does not converge; ``perturb`` > 0: a round-off copy of the
    run at h (:func:`~harness.engine.variants.roundoff_copy`)."""
    exact = V.exact_solver(model)
    edit = V.compose(exact, V.variant(model, split=split, eps_factor=eps_factor, tc_factor=tc_factor))
    name = integrator_name(model)
    h = float(model.opt.timestep)
    m = mut.compile(integrator=name, timestep=h / split if split > 1 else None, variant=edit)
    if perturb:
        m = V.roundoff_copy(m, epsilon=engine.epsilon, index=perturb)
    return Request(m, np.asarray(target.q0, float), np.asarray(target.qd0, float), split * steps)


Variant = tuple[int, float, float] | tuple[int, float, float, int]
"""(split, eps_factor, tc_factor) of :func:`_variant_request`, and optionally its ``perturb``."""


def _variant_runs(mut: V.ModelUnderTest, probe: Probe, engine: Backend, target: Target, model: mujoco.MjModel, *,
                  steps: int, variants: Sequence[Variant]) -> list[list[Deviation]]:
    """Variants (split, eps_factor, tc_factor[, perturb]) of ``model``, run as one batched call to the backend
    (:meth:`harness.engine.backends.Backend.simulate_many`), each as its deviations on the grid of the run at h."""
    requests = [_variant_request(mut, engine, target, model, steps=steps, split=v[0], eps_factor=v[1], tc_factor=v[2],
                                 perturb=v[3] if len(v) > 3 else 0) for v in variants]
    sims = engine.simulate_many(requests, probe)
    name = integrator_name(model)
    return [compared(target, every_nth(_completed(sim) if len(v) < 4 or not v[3] else sim, v[0]), name)
            for sim, v in zip(sims, variants, strict=True)]


def _variant_run(mut: V.ModelUnderTest, probe: Probe, engine: Backend, target: Target, model: mujoco.MjModel, *,
                 steps: int, split: int = 1, eps_factor: float = 1.0, tc_factor: float = 1.0) -> list[Deviation]:
    """One variant of ``model`` run over the horizon, as its deviations on the grid of the run at h."""
    return _variant_runs(mut, probe, engine, target, model, steps=steps, variants=[(split, eps_factor, tc_factor)])[0]


def _making(mut: V.ModelUnderTest, probe: Probe, engine: Backend, target: Target, sim: Trajectory, name: str, *,
            variants: V.Variants, model: mujoco.MjModel | None = None) -> Making:
    """What a part's own runs are made with (:class:`~harness.budget.part.Making`): the model compiled with the
    integrator ``name`` (``model``, where the caller has it), and each edit of it run over the horizon of ``sim``
    (the run at h, itself where the edit and the baseline's are none) with the constraints solved exactly where the
    model's own solver does not converge, completed where the backend's solve stopped, as its deviations on the
    grid of the run at h."""
    model = mut.compile(integrator=name) if model is None else model
    exact = V.exact_solver(model)
    steps = len(sim.t) - 1

    def run(edit: V.SpecEdit | None) -> list[Deviation]:
        made = sim if exact is None and edit is None else \
            simulate(engine, mut.compile(integrator=name, variant=V.compose(exact, edit)), probe, q0=target.q0,
                     qd0=target.qd0, steps=steps)
        return compared(target, _completed(made), name)

    return Making(model=model, run=run, variants=variants)


def _integrator_runs(mut: V.ModelUnderTest, probe: Probe, engine: Backend, target: Target, sim: Trajectory,
                     name: str, *, as_is: list[Deviation], order: float, variants: V.Variants,
                     shared: Mapping[str, Any], switching: bool = False) -> Runs:
    """One integrator's :class:`Runs`: its variants batched (the module docstring), then each part's own runs
    (:attr:`~harness.budget.part.Part.runs`) beside those made once and shared by every integrator (``shared``)."""
    model = mut.compile(integrator=name)
    steps = len(sim.t) - 1
    eps = V.softness_factor(model)
    slow = V.TIMECONST_FACTOR
    rigid = V.rigid_factor(model) if variants.soft else None
    levels = (2.0 * rigid, rigid) if rigid is not None else (eps, eps * eps) if eps < 1 else (eps,)

    def run(split: int = 1, eps_factor: float = 1.0, tc_factor: float = 1.0) -> list[Deviation]:
        return _variant_run(mut, probe, engine, target, model, steps=steps, split=split, eps_factor=eps_factor,
                            tc_factor=tc_factor)

    # every variant that does not wait on another's result, as one batched call to the backend
    plan: dict[str, Variant] = {"half_step": (2, 1.0, 1.0)}
    if not V.solver_converges(model):
        plan["converged"] = (1, 1.0, 1.0)
    if variants.soft:
        plan |= {f"softness{k}": (1, f, 1.0) for k, f in enumerate(levels)}
        plan["softness_half_step"] = (2, rigid or eps, 1.0)
        if rigid is not None:
            plan["stiffest"] = (1, rigid / 2.0, 1.0)
    if variants.contacts:
        plan |= {f"slower{k}": (1, f, slow) for k, f in enumerate((1.0, *levels))}
    float32 = engine.epsilon > float(np.finfo(np.float64).eps)
    if float32:  # the run's round-off, measured by copies one ulp apart (the module docstring)
        plan |= {f"perturbed{k}": (1, 1.0, 1.0, k) for k in range(1, PERTURBED_RUNS + 1)}
    done = dict(zip(plan, _variant_runs(mut, probe, engine, target, model, steps=steps, variants=list(plan.values())),
                    strict=True))
    half_step = done["half_step"]
    converged = done.get("converged")
    # across a clamp's switch the error is no expansion in h (harness.reference.tree.SWITCHED_ORDER): always measured
    asymptotic = not switching and not past_asymptotic(converged or as_is, half_step, order) \
        and V.steps_per_timeconst(model) <= 0.5
    ladder, rigid_split, rigid_why = _rigid_ladder(mut, probe, engine, target, model, done, steps=steps, order=order,
                                                   rigid=rigid, integrator=name) if rigid is not None else ((), 1, "")
    represented = _represented(probe, target, model, steps=steps) if float32 else {}
    quantized = _quantized(probe, target, model, steps=steps) if float32 else {}
    own = dict(shared)
    makers = [part for part in registry.ALL if part.runs is not None and not part.shared_runs]
    making = _making(mut, probe, engine, target, sim, name, variants=variants, model=model) if makers else None
    for part in makers:
        assert part.runs is not None and making is not None
        if (made := part.runs(making)) is not None:
            own[part.name] = made
    return Runs(
        as_is=as_is,
        half_step=half_step,
        converged=converged,
        quarter_step=None if asymptotic else run(4),
        softness=tuple(done[f"softness{k}"] for k in range(len(levels))) if variants.soft else (),
        softness_half_step=done["softness_half_step"] if variants.soft else None,
        slower=tuple(done[f"slower{k}"] for k in range(1 + len(levels))) if variants.contacts else (),
        own=own,
        perturbed=tuple(done[f"perturbed{k}"] for k in range(1, PERTURBED_RUNS + 1)) if float32 else (),
        completed=None if sim.completed is None else compared(target, sim.completed, name),
        represented=represented,
        quantized=quantized,
        eps_factor=eps, tc_factor=slow, rigid=rigid, rigid_ladder=ladder, rigid_split=rigid_split,
        rigid_unresolved=rigid_why, stiffest=done.get("stiffest"),
    )


def _rigid_ladder(mut: V.ModelUnderTest, probe: Probe, engine: Backend, target: Target, model: mujoco.MjModel,
                  done: Mapping[str, list[Deviation]], *, steps: int, order: float, rigid: float, integrator: str
                  ) -> tuple[tuple[tuple[list[Deviation], ...], ...], int, str]:
    """The near-rigid levels where fε's runs at h, h/2 (``done``) and h/4 are outside the asymptotic range
    (:attr:`Runs.rigid_ladder`): () and split 1 where they are inside (the levels at h are then corrected as
    the module docstring says), else each level at the first h/s, h/2s, h/4s of :data:`RIGID_SPLITS` inside it;
    the third result says why none down to the last is."""
    at = {1: done["softness1"], 2: done["softness_half_step"]}

    def runs_at(splits: Sequence[int], factor: float, have: dict[int, list[Deviation]]) -> None:
        missing = [k for k in splits if k not in have]
        made = _variant_runs(mut, probe, engine, target, model, steps=steps,
                             variants=[(k, factor, 1.0) for k in missing])
        have.update(zip(missing, made, strict=True))

    for s in RIGID_SPLITS:
        runs_at((s, 2 * s, 4 * s), rigid, at)
        if rigid_resolved((at[s], at[2 * s], at[4 * s]), order=order):
            if s == 1:
                return (), 1, ""
            twice: dict[int, list[Deviation]] = {}
            runs_at((s, 2 * s, 4 * s), 2.0 * rigid, twice)
            return ((twice[s], twice[2 * s], twice[4 * s]), (at[s], at[2 * s], at[4 * s])), s, ""
    deepest = 4 * RIGID_SPLITS[-1]
    return (), 1, (f"unresolved: the near-rigid softness level (every ε × {rigid:.3g}) is outside {integrator}'s "
                   f"asymptotic range at every timestep down to h/{deepest} (the runs at h/s, h/2s and h/4s give a "
                   f"next-order term above {RESOLVED:g} of the leading one on some figure), so no budget can tell "
                   f"its softness from a fault")


def _represented(probe: Probe, target: Target, model: mujoco.MjModel, *, steps: int) -> dict[str, float]:
    """Each figure's shift (by measure) when the model's constants and the initial state are held in float32:
    the C engine in float64 runs :func:`~harness.engine.variants.represented_model` from the initial
    coordinates rounded to float32, beside the model as it is. What a float32 backend holds differs so from
    the model before its first step, and no round-off copy moves it (every copy holds the same numbers)."""
    q0, qd0 = np.asarray(target.q0, float), np.asarray(target.qd0, float)
    base = record(model, probe, q0=q0, qd0=qd0, steps=steps)
    rounded = record(V.represented_model(model), probe, q0=q0.astype(np.float32).astype(float),
                         qd0=qd0.astype(np.float32).astype(float), steps=steps)
    rounded = dataclasses.replace(rounded, t=base.t)  # at the nominal times k h, as the backends record theirs
    name = integrator_name(model)
    return {a.name.measure: a.magnitude(b.values - a.values)
            for a, b in zip(compared(target, base, name), compared(target, rounded, name), strict=True)}


def _quantized(probe: Probe, target: Target, model: mujoco.MjModel, *, steps: int) -> dict[str, float]:
    """Each figure's response (by measure) to the initial state moved by half an ulp of float32
    (:func:`~harness.budget.roundoff.ulp_states`, :data:`~harness.budget.roundoff.PERTURBED_RUNS` seeds, the largest):
    the C engine in float64, so the physics' answer to a state's quantization (a stiff constraint's force
    spike), not arithmetic (:data:`~harness.budget.roundoff.QUANTIZATION`)."""
    q0, qd0 = np.asarray(target.q0, float), np.asarray(target.qd0, float)
    eps = float(np.finfo(np.float32).eps)
    name = integrator_name(model)
    base = compared(target, record(model, probe, q0=q0, qd0=qd0, steps=steps), name)
    out = {d.name.measure: 0.0 for d in base}
    for k in range(1, PERTURBED_RUNS + 1):
        moved = record(model, probe, q0=ulp_states(q0, epsilon=eps, seed=k),
                           qd0=ulp_states(qd0, epsilon=eps, seed=PERTURBED_RUNS + k), steps=steps)
        for a, b in zip(base, compared(target, moved, name), strict=True):
            out[a.name.measure] = max(out[a.name.measure], a.magnitude(b.values - a.values))
    return out


def variant_runs(mut: V.ModelUnderTest, probe: Probe, engine: Backend, target: Target,
                 sims: Mapping[str, Trajectory], *, orders: Mapping[str, float], switching: bool = False
                 ) -> tuple[dict[str, Runs], dict[str, str]]:
    """Every integrator's :class:`Runs`: ``sims`` (the runs at the model's
    settings, by integrator) and the variants, each run from the same state over the same horizon; an
    integrator past the asymptotic range (at its documented order in ``orders``), or any where the motion crosses a
    clamp's switch (``switching``), also at h/4. The second
    result says, by integrator, why its budget could not be made (a variant run that diverged: then its
    figures cannot be judged, and fail with that reason)."""
    runs: dict[str, Runs] = {}
    failed: dict[str, str] = {}
    if not sims:
        return runs, failed
    variants = V.Variants.of(mut.compile(integrator=next(iter(sims))), target.scales.length, floors=mut.floors)
    shared: dict[str, Any] = {}  # the parts' runs made once, with the most accurate integrator, for every integrator
    accurate = "RK4" if "RK4" in sims else next(iter(sims))
    for part in registry.ALL:
        if part.runs is None or not part.shared_runs:
            continue
        try:
            made = part.runs(_making(mut, probe, engine, target, sims[accurate], accurate, variants=variants))
        except SimulationDiverged as exc:
            words = part.diverged or f"the budget's run for its {part.name} part"
            return runs, {name: f"{words} {exc.reason}" for name in sims}
        if made is not None:
            shared[part.name] = made
    twins: list[tuple[float, Trajectory, str]] = []  # (order, run at h, the integrator whose variants it has)
    twin_of: dict[str, str] = {}
    jobs: list[tuple[str, Trajectory, list[Deviation]]] = []
    for name, sim in sims.items():
        twin = next((owner for order, other, owner in twins
                     if order == orders[name] and _twins(sim, other, target.scales)), None)
        if twin is not None:  # the same step map: its variants are the same runs
            twin_of[name] = twin
            continue
        twins.append((orders[name], sim, name))
        as_is = compared(target, sim, name)
        why = grown(as_is, integrator=name)
        if why:  # a diverged run has no budget: its variants would only diverge further
            failed[name] = why
            continue
        jobs.append((name, sim, as_is))

    def budgeted(job: tuple[str, Trajectory, list[Deviation]]) -> tuple[Runs | None, str]:
        name, sim, as_is = job
        try:
            made = _integrator_runs(mut, probe, engine, target, sim, name, as_is=as_is, order=orders[name],
                                    variants=variants, shared=shared, switching=switching)
        except SimulationDiverged as exc:
            return None, f"a run of its budget (a variant at h/2, h/4 or softer) {exc.reason}"
        return made, unresolved(made, order=orders[name], integrator=name)

    # each integrator's variants side by side (their steps and compiles run in C, Python's lock released)
    with ThreadPoolExecutor(max_workers=max(1, min(len(jobs), os.cpu_count() or 1))) as pool:
        for (name, _, _), (made, why) in zip(jobs, pool.map(budgeted, jobs), strict=True):
            if why or made is None:
                failed[name] = why
            else:
                runs[name] = made
    for name, twin in twin_of.items():
        if twin in runs:
            runs[name] = _renamed(runs[twin], name, compared(target, sims[name], name))
        else:
            failed[name] = failed[twin]
    order = list(sims)
    return ({k: runs[k] for k in sorted(runs, key=order.index)},
            {k: failed[k] for k in sorted(failed, key=order.index)})


def _renamed(runs: Runs, integrator: str, as_is: Sequence[Deviation]) -> Runs:
    """``runs`` as another integrator's, with that integrator's own run at h: every deviation's figure name
    carries that integrator (every field of deviations, however nested; the rest as it is)."""
    def renamed(value: object) -> object:
        if isinstance(value, Deviation):
            return dataclasses.replace(value, name=FigureName(f"{integrator}.{value.name.measure}"))
        if isinstance(value, list):
            return [renamed(v) for v in value]
        if isinstance(value, tuple):
            return tuple(renamed(v) for v in value)
        if isinstance(value, Mapping):  # the parts' own records (Runs.own) among them
            return {k: renamed(v) for k, v in value.items()}
        return value

    changed: dict[str, Any] = {f.name: renamed(getattr(runs, f.name)) for f in dataclasses.fields(runs)
                               if f.name != "as_is"}
    return dataclasses.replace(runs, **changed, as_is=list(as_is))


TWIN_TOLERANCE = 1e-9
"""Two runs at the model's settings agreeing to this fraction of each recorded quantity's largest size are
one step map's (:func:`_twins`)."""


def _twins(a: Trajectory, b: Trajectory, scales: Scales) -> bool:
    """Whether two integrators' runs at the model's settings are the same up to round-off: every recorded
    number within :data:`TWIN_TOLERANCE` of its quantity's size (its largest value, and at least the case's
    length for positions, violations and series, its force for multipliers: a violation of 1e-8 m differing
    by 1e-16 m is round-off). Semi-implicit Euler, implicitfast and implicit are one step map where no
    velocity-dependent force has a derivative (no damping, no actuator; for implicit, no Coriolis term):
    their factorizations round differently, nothing more (docs/findings/bases.md, TWIN_TOLERANCE). Their
    variant runs then agree as closely, so those are made once and shared: each budget keeps its own run at h,
    and what the sharing changes lies 1e-9 below the figure, under the round-off tolerance. A fault with a
    velocity-dependent force (damping) separates them at first order in h and is budgeted for each."""
    if len(a.t) != len(b.t):
        return False
    groups = [(a.positions, b.positions, scales.length), (a.velocities, b.velocities, 0.0),
              (a.multipliers, b.multipliers, scales.force), (a.invariants, b.invariants, 0.0),
              (a.violations, b.violations, scales.length), (a.series, b.series, scales.length)]
    for left, right, floor in groups:
        if set(left) != set(right):
            return False
        for key in left:
            x, y = np.asarray(left[key], dtype=float), np.asarray(right[key], dtype=float)
            size = max(float(np.max(np.abs(x))) if x.size else 0.0, floor)
            if x.shape != y.shape or not np.all(np.abs(x - y) <= TWIN_TOLERANCE * size):
                return False
    return True


def trajectory_budget(runs: Mapping[str, Runs], *, orders: Mapping[str, float], rtol: float,
                      solver_tolerance: float, notes: Sequence[str] = (),
                      epsilon: float = float(np.finfo(float).eps)) -> dict[FigureName, Budget]:
    """Every trajectory figure's budget, each integrator's with its documented order in ``orders``;
    ``epsilon``: the machine epsilon of the backend's arithmetic (the round-off part scales with it)."""
    out: dict[FigureName, Budget] = {}
    for name, r in runs.items():
        steps = len(r.as_is[0].values) - 1 if r.as_is else 0
        out |= budgets(r, order=orders[name], steps=steps, rtol=rtol, solver_tolerance=solver_tolerance,
                       notes=notes, epsilon=epsilon)
    return out


@dataclass(frozen=True)
class Budgets:
    """Every run figure's budget (by name), and for an integrator a documented defect of this MuJoCo affects, each
    of its figures' budget at the degraded order (``defect``); ``failed``: by integrator, why its runs could not be
    budgeted (a variant that diverged, a timestep outside its asymptotic range)."""

    budgets: Mapping[FigureName, Budget]
    defect: Mapping[FigureName, Budget]
    failed: Mapping[str, str]


def budget(mut: V.ModelUnderTest, probe: Probe, engine: Backend, target: Target, sims: Mapping[str, Trajectory],
           *, model: mujoco.MjModel, settle_note: str = "", orders: Mapping[str, float] = EXPECTED_ORDER,
           switch_note: str = "") -> Budgets:
    """The budgets of every figure of ``sims`` (the runs at the model's settings, by integrator), each integrator's
    at its order in ``orders`` (default: the documented :data:`~harness.engine.integrators.EXPECTED_ORDER`; lower
    where the motion crosses a clamp's switch, which ``switch_note`` then states), from its variant runs on
    ``engine``; ``model``: the model under test as compiled, whose solver, joints and settings the budget reads."""
    runs, failed = variant_runs(mut, probe, engine, target, sims, orders=orders, switching=bool(switch_note))
    variants = V.Variants.of(model, target.scales.length, floors=mut.floors)
    solver_tolerance = variants.solver_tolerance  # the runs' solver: the model's, or Newton converged
    if solver_tolerance and not V.solver_converges(model):
        solver_tolerance = V.CONVERGED_TOLERANCE
    notes = (*variants.notes, *((settle_note,) if settle_note else ()), *((switch_note,) if switch_note else ()))
    made = trajectory_budget(runs, orders=orders, rtol=target.rtol, solver_tolerance=solver_tolerance,
                             notes=notes, epsilon=engine.epsilon)
    joints = joint_types(model)
    defects = {name: d for name in runs if (d := applicable_defect(joints, name)) is not None}
    defect = trajectory_budget({n: runs[n] for n in defects}, orders={n: d.order for n, d in defects.items()},
                               rtol=target.rtol, solver_tolerance=solver_tolerance, notes=notes,
                               epsilon=engine.epsilon) if defects else {}
    return Budgets(budgets=made, defect=defect, failed=failed)

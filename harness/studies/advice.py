"""Which integrator and timestep for a model: every integrator measured over a ladder of steps, and the cheapest
setting that meets the user's accuracy, verified before it is said.

The ladder: for each integrator MuJoCo offers, the model runs from the reference's start at steps h₀·2ᵏ (h₀ the
model's own), from the largest the horizon (:data:`FEWEST_STEPS`) and the stability limit allow down to
h₀/2^HALVINGS, each run compared with the reference by the families' own comparisons (the figures ``check``
measures: ``position``, ``drift.energy``, ``force.*``, …). Each figure has its error bar: what the reference's own
error (:data:`~harness.budget.reference.REFERENCE` × its rtol), round-off (a random walk of
:data:`~harness.budget.roundoff.ROUNDOFF_EPS` ε a step) and, with constraints, the solver's stop
(:data:`~harness.budget.convergence.SOLVER` × its tolerance) leave unknown of it. Each run's cost is measured on
this machine: the CPU seconds of a bare ``mj_step`` loop over the run, per simulated second.

Stability: an explicit integrator's largest stable step is the linearization's (:mod:`harness.families.stability`,
the reference linearized along the run), confirmed by a run at :data:`BELOW` × the limit, which must stay bounded,
and one at :data:`ABOVE` ×, which must grow (:func:`_confirm`); its ladder stays within the limit. The implicit
integrators are not assessed by the linearization: their ladder goes up until a run diverges.

The recommendation (:func:`recommend`): per integrator, the largest step whose errors, interpolated between the
ladder's runs (log–log: exact for a power law), plus their error bars, are :data:`MARGIN` times within every
requirement (below the ladder's finest step only where the order holds there, by the documented order). Each
candidate is verified, cheapest predicted cost first: the model is checked at that setting (``check --integrators I
--timestep h``: every figure with its budget), and the setting is recommended only where every check of its runs
passes and every figure the requirements cover is within them, as measured; the figures, the margin and the cost
printed are the measured ones. Where the reference lacks forces the model has (contacts, limits:
:func:`harness.reference.tree.uncovered`), the model as it is is held to the requirements by what can be known
without the reference: its position by self-convergence, its energy by the work–energy balance
(:mod:`harness.families.balance`).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import os
import time
from collections.abc import Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import mujoco
import numpy as np

from harness.budget.convergence import SOLVER
from harness.budget.reference import REFERENCE
from harness.budget.roundoff import ROUNDOFF_EPS
from harness.cases import Case
from harness.core import progress
from harness.core.checks import Check
from harness.core.deviation import Deviation
from harness.core.errors import SimulationDiverged, UnmodelledElement
from harness.core.figures import FigureName
from harness.core.options import RunOptions
from harness.core.trajectory import Trajectory
from harness.engine.backends import Request, simulate
from harness.engine.integrators import EXPECTED_ORDER, available_integrators, integrator_name
from harness.engine.models import compile_model
from harness.engine.recording import steps_in
from harness.engine.variants import compose
from harness.families import COMPARISONS, runs
from harness.families.bench import Bench
from harness.families.convergence import ORDER_TOLERANCE, reference_grids, scaled_softness
from harness.families.stability import ASSESSED
from harness.pipeline.limits import case_limits, load_limits
from harness.pipeline.require import Requirement
from harness.pipeline.run import run_case
from harness.pipeline.verdict import judge
from harness.reference import solutions as refmod
from harness.reference.tree import TreeEdit

__all__ = ["Advice", "Curve", "Point", "Verification", "advise", "covered"]

HALVINGS = 4
"""The ladder's steps below the model's own h₀: four halvings (an order-1 error shrinks 16×, an order-4 one 65 536×).
Above h₀ it doubles as far as the step allows (:data:`FEWEST_STEPS` over the horizon, the stability limit): a
coarser step is what saves cost, and the coarse runs are the cheap ones."""

FEWEST_STEPS = 16
"""A ladder step takes at least this many steps over the horizon (a coarser one says nothing of the motion)."""

MARGIN = 1.5
"""How far within the requirement a candidate's predicted error (plus its error bar) must be. Below 2, so that for
any order p ≥ 1 twice the step predicts 2ᵖ/MARGIN > 1 of the requirement: the recommendation is the largest step
that meets it, not one of many. The margin printed is the verification's measured one."""

BELOW = 0.9
ABOVE = 1.1
"""The steps, × the linearization's limit, of the runs that confirm it: the one below must stay bounded, the one
above must grow."""

GROWN = 100.0
"""A confirmation run grew where it diverged (MuJoCo's own check) or its largest point speed passed GROWN × that of
the run below the limit."""

CONFIRM_STEPS = (1000, 20000)
"""A confirmation run's steps: the horizon's, at least the first (a mode slightly outside the region grows by
ρᴺ: 1.1 × RK4's limit on the real axis gives ρ ≈ 1.5, 1e16 in 90 steps), at most the second."""

MIN_CPU = 0.02
"""A cost is timed over repeated runs until this much CPU time has passed (s): one run of a small model takes
microseconds."""

MAX_RUN_STEPS = 2 ** 18
"""The most steps one run of the ladder takes (an explicit integrator's steps below a stiff model's stability limit:
each sample is recorded)."""

VERIFY_STEPS = 2 ** 14
"""The most steps over the horizon a verification is asked to run (the check at that setting runs its budget's
variants at h/2 and h/4 too): the bound on what the model as it is may ask for."""

AS_IS_TRIES = 6
"""How many times a candidate's step is made smaller for the model as it is before it is verified as it stands."""

FLAT = 0.8
"""An error that keeps more than this of itself over the ladder's last halving has stopped shrinking with h: a
floor no timestep removes."""

EXTRAPOLATE = 16.0
"""Below the ladder's smallest step a candidate is extrapolated at most this factor (by the documented order, where
it holds there); further needs steps the ladder never measured."""


# ------------------------------------------------------------------ the ladder
@dataclass(frozen=True)
class Point:
    """One run of the ladder.

    Attributes:
        timestep: h, s.
        values: each figure's value, by measure (``position``, ``drift.energy``, ``force.rod``, …), in its unit.
        bars: each figure's error bar, by measure, in its unit.
        units: each figure's unit, by measure.
        cost: CPU seconds of MuJoCo's steps per simulated second, measured on this machine.
        diverged: why the run diverged ('' where it did not).
    """

    timestep: float
    values: Mapping[str, float] = field(default_factory=dict)
    bars: Mapping[str, float] = field(default_factory=dict)
    units: Mapping[str, str] = field(default_factory=dict)
    cost: float = math.nan
    diverged: str = ""


@dataclass(frozen=True)
class Limit:
    """An integrator's largest stable step and how it is known.

    Attributes:
        timestep: the largest stable step, s (inf: none found; nan: not assessed).
        basis: where it comes from, one line.
        below, above: what the confirmation runs at BELOW and ABOVE × the limit did ('' where not run).
        confirmed: both did as the limit says.
    """

    timestep: float
    basis: str
    below: str = ""
    above: str = ""
    confirmed: bool = False

    def as_dict(self) -> dict[str, object]:
        return {"timestep": self.timestep if math.isfinite(self.timestep) else None, "basis": self.basis,
                "below": self.below, "above": self.above, "confirmed": self.confirmed}


@dataclass(frozen=True)
class Curve:
    """One integrator's errors against the timestep.

    Attributes:
        integrator: the integrator.
        order: its documented order over this motion.
        points: the ladder's runs, largest step first.
        limit: its largest stable step.
        floors: per measure whose error stopped shrinking with h, what moves that floor (the constraints'
            softness, or not), one line.
        span: the horizon its runs cover (a whole number of its ladder's largest step), s.
        ordered: per measure, the steps (smallest, largest) over which the observed order holds
            (within :data:`~harness.families.convergence.ORDER_TOLERANCE`, errors above 10 × their bar).
    """

    integrator: str
    order: float
    points: tuple[Point, ...]
    limit: Limit
    ordered: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    span: float = math.nan
    floors: Mapping[str, str] = field(default_factory=dict)

    def measured(self) -> tuple[Point, ...]:
        return tuple(p for p in self.points if not p.diverged)


# ------------------------------------------------------------------ the recommendation
@dataclass(frozen=True)
class Verification:
    """A candidate setting checked as ``check --integrators I --timestep h`` checks it.

    Attributes:
        integrator, timestep: the setting.
        predicted: the error the ladder predicted, by measure (value + bar).
        measured: each figure the requirements cover, as the check measured it, by measure.
        failures: the checks of that integrator's runs that failed (their names), each a reason not to recommend it.
        findings: the other checks of that run that failed (at the sampled states, of the reference): about the
            model, not the setting (no integrator or timestep changes them), said beside the recommendation.
        cost: CPU seconds per simulated second at that setting, measured.
        met: every covered figure within its requirement, no check failed, and what the model as it is gave (where
            the reference lacks forces) within the requirements that name it.
        margin: the smallest requirement / value over the covered figures, measured and (as it is) estimated.
        as_is: with forces the reference does not cover, what the model as it is gave at the setting: by measure,
            (value, how it was obtained).
    """

    integrator: str
    timestep: float
    predicted: Mapping[str, float]
    measured: Mapping[str, float]
    failures: tuple[str, ...]
    cost: float
    met: bool
    margin: float
    as_is: Mapping[str, tuple[float, str]] = field(default_factory=dict)
    findings: tuple[str, ...] = ()


@dataclass(frozen=True)
class Advice:
    """What ``mjharness advise`` found for one model.

    Attributes:
        model: the case's name.
        requirements: what the user needs.
        horizon: the ladder's horizon, s.
        own: the model's own integrator and timestep.
        curves: each integrator's errors against the timestep.
        recommended: the verified setting (None: none meets the requirements).
        tried: every verification made, in order.
        why_none: where none is recommended, why.
        rejected: why each integrator that was not recommended was not, by integrator (one never verified because
            a cheaper one was: not listed).
        uncovered: forces the reference does not model, by kind (what only self-convergence checks).
        seconds: the wall time of each stage.
    """

    model: str
    requirements: tuple[Requirement, ...]
    horizon: float
    own: tuple[str, float]
    curves: tuple[Curve, ...]
    recommended: Verification | None
    tried: tuple[Verification, ...]
    why_none: str
    rejected: Mapping[str, str] = field(default_factory=dict)
    uncovered: Mapping[str, str] = field(default_factory=dict)
    seconds: Mapping[str, float] = field(default_factory=dict)

    def curve(self, integrator: str) -> Curve:
        return next(c for c in self.curves if c.integrator == integrator)


def _bar(dev: Deviation, *, rtol: float, steps: int, solver_tolerance: float) -> float:
    """What is unknown of a figure measured against the reference: the reference's error, round-off, the solver."""
    roundoff = ROUNDOFF_EPS * float(np.finfo(float).eps) * math.sqrt(max(steps, 1))
    return (REFERENCE * rtol + roundoff + SOLVER * solver_tolerance) * dev.size


def _cost(model: mujoco.MjModel, bench: Bench, steps: int) -> float:
    """CPU seconds per simulated second of ``steps`` bare ``mj_step`` calls from the run's start (this thread's
    CPU time: the ladder's runs go side by side)."""
    data = mujoco.MjData(model)
    ref = bench.reference
    spent, simulated = 0.0, 0.0
    while spent < MIN_CPU:
        mujoco.mj_resetData(model, data)
        bench.probe.binding.set_state(model, data, ref.q0(), ref.qd0())
        clock = time.thread_time()
        for _ in range(steps):
            mujoco.mj_step(model, data)
        spent += time.thread_time() - clock
        simulated += steps * float(model.opt.timestep)
    return spent / simulated


def _steps(bench: Bench, limit: float, span_top: float) -> tuple[float, ...]:
    """An integrator's ladder, largest first: h₀·2ᵏ from the largest within ``span_top`` and its stability
    ``limit`` down to h₀/2^HALVINGS, or, where the limit lies below that, as many halvings from the largest h₀·2ᵏ
    within it, each run at most :data:`MAX_RUN_STEPS` steps."""
    h0 = float(bench.model.opt.timestep)
    horizon = bench.case.horizon
    top = min(limit, span_top)
    if not top > 0:
        return ()
    k = math.floor(math.log2(top / h0) + 1e-12)
    ladder = [h0 * 2.0 ** k / 2 ** i for i in range(max(k, 0) + HALVINGS + 1)]
    return tuple(h for h in ladder if horizon / h <= MAX_RUN_STEPS)


Run = tuple[Trajectory, float] | str
"""A ladder run: its trajectory and cost, or why it diverged."""


def _ladder(bench: Bench, integrator: str, steps: Sequence[float], span: float) -> list[tuple[float, Run]]:
    """The integrator's runs at each of ``steps`` over ``span``: each (trajectory, cost), or why it diverged."""
    out: list[tuple[float, Run]] = []
    for h in steps:
        model = bench.mut.compile(integrator=integrator, timestep=h)
        n = steps_in(span, h)
        try:
            sim = simulate(bench.engine, model, bench.probe, q0=bench.reference.q0(), qd0=bench.reference.qd0(),
                           steps=n)
        except (SimulationDiverged, UnmodelledElement) as exc:
            out.append((h, exc.reason))
            continue
        out.append((h, (sim, _cost(model, bench, n))))
    return out


BISECTIONS = 4
"""Where runs bound the step (an implicit integrator's ladder diverged, or an explicit one diverged below the
linearization's limit), the bracket between a bounded and a diverged run is halved this many times in log h (a
factor 2 to 4 %)."""


def _speed(sim: Trajectory) -> float:
    return max((float(np.max(np.linalg.norm(v, axis=1))) for v in sim.velocities.values()), default=0.0)


def _confirmation_run(bench: Bench, integrator: str, h: float) -> tuple[float, str]:
    """A run at ``h`` over the horizon's steps (CONFIRM_STEPS at least and at most): its largest point speed (inf
    where it diverged: MuJoCo's own check), and what it did, one line."""
    steps = min(max(steps_in(bench.case.horizon, h), CONFIRM_STEPS[0]), CONFIRM_STEPS[1])
    model = bench.mut.compile(integrator=integrator, timestep=h)
    try:
        sim = simulate(bench.engine, model, bench.probe, q0=bench.reference.q0(), qd0=bench.reference.qd0(),
                       steps=steps)
    except (SimulationDiverged, UnmodelledElement) as exc:
        return math.inf, f"diverged at h = {h:.3g} s ({exc.reason})"
    speed = _speed(sim)
    return speed, f"h = {h:.3g} s, {steps} steps: largest point speed {speed:.3g} m/s"


def _grows(bench: Bench, integrator: str, h: float, baseline: float) -> tuple[bool, str]:
    """Whether a run at ``h`` grows (diverges, or its largest point speed passes GROWN × ``baseline``), and what
    it did."""
    speed, said = _confirmation_run(bench, integrator, h)
    grew = speed > GROWN * max(baseline, 1e-300)
    return grew, said + (": grew" if grew and math.isfinite(speed) else "")


def _bisected(bench: Bench, integrator: str, lo: float, hi: float, baseline: float) -> Limit:
    """The largest stable step as runs find it, between ``lo`` (a bounded run) and ``hi`` (one that grew)."""
    said_lo, said_hi = "bounded on the ladder", "diverged on the ladder"
    for _ in range(BISECTIONS):
        mid = math.sqrt(lo * hi)
        grew, said = _grows(bench, integrator, mid, baseline)
        if grew:
            hi, said_hi = mid, said
        else:
            lo, said_lo = mid, said
    return Limit(lo, f"runs: bounded at h = {lo:.3g} s, grew at {hi:.3g} s ({BISECTIONS} bisections between the "
                     "ladder's runs; the implicit integrators are not assessed by the linearization, and a "
                     "linearization's limit that a run below it contradicts is replaced)",
                 below=said_lo, above=said_hi, confirmed=True)


def _confirm(bench: Bench, integrator: str, limit: float) -> tuple[str, str, bool]:
    """The runs at BELOW and ABOVE × the limit: what each did, and whether they confirm it."""
    (below, said_below), (above, said_above) = (_confirmation_run(bench, integrator, f * limit) for f in (BELOW, ABOVE))
    below_ok = math.isfinite(below)
    above_grew = not math.isfinite(above) or above > GROWN * max(below, 1e-300)
    if below_ok and above_grew and math.isfinite(above):
        said_above += f", {above / below:.3g}× the run below: grew"
    return said_below, said_above, below_ok and above_grew


def _ordered(points: Sequence[Point], measure: str, order: float) -> tuple[float, float] | None:
    """The steps (smallest, largest) of the longest run of consecutive ladder points over which the local slope
    of ``measure``'s error is the documented order (within ORDER_TOLERANCE), errors above 10 × their bar."""
    pts = [p for p in points if measure in p.values and not p.diverged]
    best: tuple[float, float] | None = None
    start = None
    for a, b in itertools.pairwise(pts):
        ea, eb = a.values[measure], b.values[measure]
        ok = (eb > 10 * b.bars[measure] and ea > 10 * a.bars[measure] and eb > 0
              and abs(math.log(ea / eb) / math.log(a.timestep / b.timestep) - order) <= ORDER_TOLERANCE)
        if ok:
            start = a.timestep if start is None else start
            if best is None or start / b.timestep > best[1] / best[0]:
                best = (b.timestep, start)
        else:
            start = None
    return best


def measure(bench: Bench, *, integrators: Sequence[str], limits: Mapping[str, float]) -> tuple[Curve, ...]:
    """Every integrator's ladder: its runs, their figures with error bars and cost, and its confirmed limit."""
    horizon = bench.case.horizon
    h0 = float(bench.model.opt.timestep)
    span_top = horizon / FEWEST_STEPS
    ladders = {name: _steps(bench, limits.get(name, math.inf), span_top) for name in integrators}
    h_top = max((h for hs in ladders.values() for h in hs), default=h0)
    span = max(1, math.floor(horizon / h_top + 1e-9)) * h_top  # every ladder's grid nests in the finest one
    finest = h0 / 2 ** HALVINGS  # runs below it are compared at its samples (every m-th of theirs)

    def one(name: str) -> tuple[list[tuple[float, Run]], tuple[str, str, bool] | None, Limit | None]:
        limit = limits.get(name, math.inf)
        confirm = _confirm(bench, name, limit) if math.isfinite(limit) and limit > 0 else None
        ladder = _ladder(bench, name, ladders[name], span)
        bounded = [(h, run[0]) for h, run in ladder if not isinstance(run, str)]
        grew = [h for h, run in ladder if isinstance(run, str) and (not bounded or h > bounded[0][0])]
        found = None
        if bounded and (grew or (confirm is not None and confirm[0].startswith("diverged"))):
            hi = min(grew) if grew else BELOW * limit  # runs diverged there: the limit lies below
            lo, sim = bounded[0]
            if hi > lo:
                found = _bisected(bench, name, lo, hi, _speed(sim))
        return ladder, confirm, found

    with ThreadPoolExecutor(max_workers=max(1, min(len(integrators), os.cpu_count() or 1))) as pool:
        done = dict(zip(integrators, pool.map(one, integrators), strict=True))

    def on_grid(sim: Trajectory) -> Trajectory:
        h = float(sim.t[1] - sim.t[0])
        m = round(finest / h) if h < finest * (1 - 1e-9) else 1
        return runs.every_nth(sim, m) if m > 1 else sim

    compared_runs = {(name, h): on_grid(run[0]) for name, (ladder, _, _) in done.items() for h, run in ladder
                     if not isinstance(run, str)}
    grids = reference_grids(bench.reference, [sim.t for sim in compared_runs.values()])
    rtol = bench.reference.solution.rtol
    tolerance = float(bench.model.opt.tolerance) if bench.probe.constraints else 0.0
    curves = []
    for name in integrators:
        ladder, confirm, found = done[name]
        points = []
        for h, run in ladder:
            if isinstance(run, str):
                points.append(Point(timestep=h, diverged=run))
                continue
            sim = compared_runs[(name, h)]
            steps = steps_in(span, h)
            devs = runs.compared(_target(bench, grids[len(sim.t) - 1]), sim, name)
            points.append(Point(timestep=h, values={d.name.measure: d.magnitude() for d in devs},
                                bars={d.name.measure: _bar(d, rtol=rtol, steps=steps, solver_tolerance=tolerance)
                                      for d in devs},
                                units={d.name.measure: d.unit for d in devs}, cost=run[1]))
        order = float(bench.orders.get(name, EXPECTED_ORDER[name]))
        limit = found if found is not None else _limit(name, limits, confirm, points)
        measures = {m for p in points for m in p.values}
        ordered = {m: r for m in sorted(measures) if (r := _ordered(points, m, order)) is not None}
        curves.append(Curve(integrator=name, order=order, points=tuple(points), limit=limit, ordered=ordered,
                            span=span))
    return tuple(curves)


SOFTER = 0.5
"""The factor on every equality's ε = 1 − d (solimp) of the run that tells whether a floor is the softness's."""


def _attributed(bench: Bench, curve: Curve, requirements: Sequence[Requirement]) -> Curve:
    """``curve`` with each floor of a covered measure attributed: one more run at its finest step with every
    equality's ε scaled by SOFTER; a floor that moves by more than a fifth of itself is the softness's."""
    flat = flat_measures(curve, requirements)
    if not flat:
        return curve
    h = curve.measured()[-1].timestep
    model = bench.mut.compile(integrator=curve.integrator, timestep=h, variant=scaled_softness(SOFTER))
    try:
        sim = simulate(bench.engine, model, bench.probe, q0=bench.reference.q0(), qd0=bench.reference.qd0(),
                       steps=steps_in(curve.span, h))
    except (SimulationDiverged, UnmodelledElement) as exc:
        return dataclasses.replace(curve, floors={m: f"with ε = 1 − d halved the run diverged ({exc.reason})"
                                                  for m, _, _ in flat})
    h_grid = h0 / 2 ** HALVINGS if (h0 := float(bench.model.opt.timestep)) else h
    sim = runs.every_nth(sim, round(h_grid / h)) if h < h_grid * (1 - 1e-9) else sim
    reference = refmod.trajectory(bench.reference, sim.t)
    found = {d.name.measure: d.magnitude() for d in runs.compared(_target(bench, reference), sim, curve.integrator)}
    floors = {}
    for m, v, _ in flat:
        softer = found.get(m, math.nan)
        if abs(softer - v) > 0.2 * v:
            floors[m] = (f"with every equality's ε = 1 − d halved it moves to {softer:.3g}: the constraints' "
                         "softness (solref/solimp) sets it, not the timestep")
        else:
            floors[m] = f"with every equality's ε = 1 − d halved it stays at {softer:.3g}: not their softness"
    return dataclasses.replace(curve, floors=floors)


def _target(bench: Bench, reference: Trajectory) -> runs.Target:
    """What a run is compared with: ``reference`` (the reference on that run's grid), as the check compares."""
    ref = bench.reference
    return runs.Target(reference=reference, scales=ref.scales, settle=bench.settle[0], series=bench.case.mujoco_series,
                       q0=ref.q0(), qd0=ref.qd0(), rtol=ref.solution.rtol, compare=COMPARISONS.over_runs)


def _limit(name: str, limits: Mapping[str, float], confirm: tuple[str, str, bool] | None,
           points: Sequence[Point]) -> Limit:
    if name in limits:
        value = limits[name]
        if not math.isfinite(value):
            return Limit(math.inf, "the linearization along the run: no mode bounds the step")
        below, above, ok = confirm or ("", "", False)
        return Limit(value, "the linearization along the run (the reference's, at its states over the horizon)",
                     below=below, above=above, confirmed=ok)
    bounded = [p.timestep for p in points if not p.diverged]
    grew = [p.timestep for p in points if p.diverged]
    if name in ASSESSED:
        return Limit(math.nan, "not assessed (the reference could not be linearized)")
    if grew and bounded and min(grew) > max(bounded):
        return Limit(max(bounded), f"not assessed by the linearization (implicit): the ladder's run at "
                                   f"h = {min(grew):.3g} s diverged, the one at {max(bounded):.3g} s did not")
    return Limit(math.nan, "not assessed by the linearization (implicit): every run of the ladder, up to "
                           f"h = {max(bounded, default=math.nan):.3g} s, stayed bounded")


# ------------------------------------------------------------------ choosing and verifying
def covered(requirement: Requirement, measure: str) -> bool:
    return requirement.covers(FigureName.trajectory("X", *measure.split(".", 1)))


def _excess(point_values: Mapping[str, float], bars: Mapping[str, float],
            requirements: Sequence[Requirement]) -> float:
    """max over covered figures of (value + bar) · MARGIN / required (≤ 1: the point meets every requirement)."""
    worst = 0.0
    for req in requirements:
        for m, v in point_values.items():
            if covered(req, m):
                worst = max(worst, (v + bars[m]) * MARGIN / req.value)
    return worst


def candidate(curve: Curve, requirements: Sequence[Requirement]) -> tuple[float, str]:
    """The largest step the ladder predicts meets every requirement with MARGIN (nan and why where none)."""
    pts = [p for p in curve.measured() if not (math.isfinite(curve.limit.timestep)
                                                and p.timestep > curve.limit.timestep)]
    if not pts:
        return math.nan, "every run of its ladder diverged"
    if not any(covered(r, m) for r in requirements for m in pts[0].values):
        return math.nan, "it measures no figure the requirements name"
    excess = [_excess(p.values, p.bars, requirements) for p in pts]
    cap = BELOW * curve.limit.timestep if math.isfinite(curve.limit.timestep) and curve.limit.confirmed \
        else (curve.limit.timestep if math.isfinite(curve.limit.timestep) else math.inf)
    for i, (p, e) in enumerate(zip(pts, excess, strict=True)):
        if e <= 1.0:
            if i == 0:
                return min(p.timestep, cap), "the ladder's largest step meets it"
            above, e_above = pts[i - 1], excess[i - 1]
            # log–log between the two runs: the step where the excess reaches 1
            slope = math.log(e_above / max(e, 1e-300)) / math.log(above.timestep / p.timestep)
            h = p.timestep * (1.0 / max(e, 1e-300)) ** (1.0 / slope) if slope > 0 else p.timestep
            return min(_round_down(min(h, above.timestep)), cap), "between two runs of its ladder"
    smallest = pts[-1]
    bars = max((smallest.bars[m] * MARGIN / r.value for r in requirements for m in smallest.values if covered(r, m)),
               default=0.0)
    if bars >= 1.0:
        return math.nan, "the requirement is within the reference's own accuracy (the error bar) at its finest step"
    ordered = all(any(covered(r, m) for r in requirements) <= (m in curve.ordered and
                                                              curve.ordered[m][0] <= smallest.timestep * 1.001)
                  for m in smallest.values)
    if not ordered:
        flat = _flat(curve, requirements)
        if flat:
            return math.nan, flat
        return math.nan, (f"its error at the ladder's finest step ({smallest.timestep:.3g} s) is {excess[-1]:.3g}× "
                          "the requirement with the margin, and its order does not hold there to extrapolate")
    h = smallest.timestep * (1.0 / excess[-1]) ** (1.0 / curve.order)
    if h < smallest.timestep / EXTRAPOLATE:
        return math.nan, (f"it would need h ≈ {h:.3g} s, more than {EXTRAPOLATE:g}× below the ladder's finest step")
    return min(_round_down(h), cap), "extrapolated below the ladder by its order"


def flat_measures(curve: Curve, requirements: Sequence[Requirement]) -> list[tuple[str, float, float]]:
    """The covered measures whose error stopped shrinking over the ladder's last halving (more than FLAT of itself
    kept), each with its value there and the fraction kept."""
    pts = curve.measured()
    if len(pts) < 2:
        return []
    a, b = pts[-2], pts[-1]
    out = []
    for m, v in b.values.items():
        if any(covered(r, m) for r in requirements) and a.values.get(m, 0.0) > 0 and v > 10 * b.bars[m]:
            kept = v / a.values[m]
            if kept > FLAT:
                out.append((m, v, kept))
    return out


def _flat(curve: Curve, requirements: Sequence[Requirement]) -> str:
    """Why no step meets the requirements where the errors sit on a floor ('' where they do not)."""
    said = []
    pts = curve.measured()
    for m, v, kept in flat_measures(curve, requirements):
        if not any(covered(r, m) and v * MARGIN > r.value for r in requirements):
            continue
        cause = curve.floors.get(m, "")
        said.append(f"its {m} error no longer shrinks with h: {v:.3g} {pts[-1].units[m]} at h = "
                    f"{pts[-1].timestep:.3g} s, {kept:.2g}× its value at {pts[-2].timestep:.3g} s: a floor no "
                    "timestep removes"
                    + (f"; {cause}" if cause else ""))
    return "; ".join(said)


def _round_down(h: float) -> float:
    """``h`` rounded down to two significant digits (a step a user writes)."""
    if not math.isfinite(h) or h <= 0:
        return h
    e = math.floor(math.log10(h)) - 1
    return math.floor(h / 10.0 ** e * (1 + 1e-12)) * 10.0 ** e


def _predict(curve: Curve, h: float, measure: str) -> float:
    """The ladder's prediction of ``measure``'s error at ``h``, its bar added: log–log between the two runs around
    it, by the documented order beyond the ladder."""
    pts = [p for p in curve.measured() if measure in p.values]
    if not pts:
        return math.nan
    for above, below in itertools.pairwise(pts):
        if below.timestep <= h <= above.timestep:
            ea, eb = above.values[measure], below.values[measure]
            if ea <= 0 or eb <= 0:
                return max(ea, eb) + below.bars[measure]
            w = math.log(h / below.timestep) / math.log(above.timestep / below.timestep)
            return math.exp((1 - w) * math.log(eb) + w * math.log(ea)) + below.bars[measure]
    edge = pts[0] if h > pts[0].timestep else pts[-1]
    return edge.values[measure] * (h / edge.timestep) ** curve.order + edge.bars[measure]


def _predicted_cost(curve: Curve, h: float) -> float:
    """The cost at ``h`` from the nearest ladder run's cost per step."""
    pts = curve.measured()
    nearest = min(pts, key=lambda p: abs(math.log(p.timestep / h)))
    return nearest.cost * nearest.timestep / h


def verify(case: Case, options: RunOptions, curve: Curve, h: float, requirements: Sequence[Requirement], *,
           bench: Bench) -> Verification:
    """The model checked at (integrator, h) as ``check`` checks it; the requirements judged on what it measured."""
    name = curve.integrator
    result = run_case(case, dataclasses.replace(options, integrators=(name,), timestep=h))
    checks: list[Check] = judge(result, case_limits(load_limits(None), case, result.judged_names))
    failures = tuple(str(c.name) for c in checks if not c.passed and c.name.integrator == name)
    findings = tuple(str(c.name) for c in checks if not c.passed and c.name.integrator != name)
    measured = {f.name.measure: f.value for f in result.figures
                if f.name.layer == "trajectory" and f.name.integrator == name
                and any(r.covers(f.name) for r in requirements)}
    within = all(math.isfinite(v) and v <= r.value for r in requirements
                 for m, v in measured.items() if covered(r, m))
    model = bench.mut.compile(integrator=name, timestep=h)
    cost = _cost(model, bench, steps_in(case.horizon, h))
    predicted = {m: _predict(curve, h, m) for m in measured}
    as_is = {}
    if case.tree is not None and case.tree.uncovered:  # forces the reference lacks: the model as it is, on its own
        as_is = _as_is(case, bench, name, h, curve.order)
        balance = [f.value for f in result.figures if str(f.name) == f"{name}.balance"]
        if balance:
            as_is["drift.energy"] = (balance[0], "the work–energy balance of the model as it is (|E(t) − E(0) − "
                                                 "∫P dt| / energy scale)")
    as_is_within = all(value <= r.value for r in requirements for m, (value, _) in as_is.items() if covered(r, m))
    judged = [*measured.items(), *((m, value) for m, (value, _) in as_is.items())]
    margin = min((r.value / v if v > 0 else math.inf for r in requirements for m, v in judged if covered(r, m)),
                 default=math.nan)
    return Verification(integrator=name, timestep=h, predicted=predicted, measured=measured, failures=failures,
                        cost=cost, met=bool(measured) and within and as_is_within and not failures, margin=margin,
                        as_is=as_is, findings=findings)


def _as_is(case: Case, bench: Bench, name: str, h: float, order: float) -> dict[str, tuple[float, str]]:
    """The model as it is (every force on) at ``h``: its position error by self-convergence, κ·|x(h) − x(h/2)|
    with κ = 2ᵖ/(2ᵖ − 1) and p the order its runs at h, h/2 and h/4 show (at most the documented ``order``, at
    least 1/2: impacts lower it, and the documented κ would then understate the error up to twofold)."""
    assert case.tree is not None  # only a model judged against its own tree lacks forces in its reference
    edit = compose(TreeEdit(isolating=False, ctrl=case.tree.ctrl), bench.options.edit)
    steps = steps_in(case.horizon, h)
    requests = [Request(compile_model(bench.path, integrator=name, timestep=h / k, edit=edit), bench.reference.q0(),
                        bench.reference.qd0(), steps * k) for k in (1, 2, 4)]
    try:
        coarse, mid, fine = bench.engine.simulate_many(requests, bench.probe)  # side by side, in C
    except (SimulationDiverged, UnmodelledElement) as exc:
        return {"position": (math.inf, f"the model as it is diverged at h = {h:.3g} s, h/2 or h/4 ({exc.reason})")}
    first = runs.largest(runs.point_differences(coarse.positions, runs.every_nth(mid, 2).positions), vector=True)
    second = runs.largest(runs.point_differences(runs.every_nth(mid, 2).positions, runs.every_nth(fine, 4).positions),
                          vector=True)
    seen = math.log2(first / second) if first > 0 and second > 0 else order
    p = min(order, max(0.5, seen))
    kappa = 2.0 ** p / (2.0 ** p - 1.0)
    return {"position": (kappa * first, f"self-convergence κ·|x(h) − x(h/2)| of the model as it is (order {p:.2g} "
                                        "from its runs at h, h/2, h/4)")}


def recommend(case: Case, options: RunOptions, curves: Sequence[Curve], requirements: Sequence[Requirement], *,
              bench: Bench) -> tuple[Verification | None, tuple[Verification, ...], dict[str, str]]:
    """The cheapest verified setting (None: none), every verification made, and why each integrator not
    recommended was not (those never verified because a cheaper one was: not listed)."""
    found: list[tuple[float, Curve, float]] = []
    reasons: dict[str, str] = {}
    for curve in curves:
        h, why = candidate(curve, requirements)
        if math.isnan(h):
            reasons[curve.integrator] = why
            continue
        found.append((_predicted_cost(curve, h), curve, h))
    found.sort(key=lambda item: item[0])
    tried: list[Verification] = []
    best: Verification | None = None
    for cost, curve, h in found:
        if best is not None and best.cost <= cost:
            break  # every other candidate predicts more than the verified one measured
        if case.tree is not None and case.tree.uncovered:
            progress.stage(f"the model as it is: {curve.integrator} at h = {h:.3g} s")
            h, why = _as_is_step(case, bench, curve, h, requirements)
            if why:
                reasons[curve.integrator] = why
                continue
        progress.stage(f"verifying {curve.integrator} at h = {h:.3g} s")
        v = verify(case, options, curve, h, requirements, bench=bench)
        tried.append(v)
        if not v.met and not v.failures:  # missed as measured: half the step once
            v = verify(case, options, curve, _round_down(h / 2), requirements, bench=bench)
            tried.append(v)
        if v.met and (best is None or v.cost < best.cost):
            best = v
        elif not v.met:
            reasons[curve.integrator] = _missed(v)
    return best, tuple(tried), reasons


def _as_is_step(case: Case, bench: Bench, curve: Curve, h: float, requirements: Sequence[Requirement]
                ) -> tuple[float, str]:
    """``h``, made smaller where the model as it is (every force on) estimates its own position error above a
    requirement with MARGIN: by the order its self-convergence shows between two tries (the documented one at the
    first; impacts make it lower), at most :data:`AS_IS_TRIES` times (its runs are MuJoCo's alone: cheap beside a
    verification). nan, and why, where it would need a step finer than :data:`VERIFY_STEPS` over the horizon (or
    the candidate's, where that is finer)."""
    required = min((r.value for r in requirements if covered(r, "position")), default=math.inf)
    if not math.isfinite(required):
        return h, ""
    finest = min(case.horizon / VERIFY_STEPS, h)  # the finest a verification runs at, or the candidate's
    order = curve.order
    last: tuple[float, float] | None = None
    for _ in range(AS_IS_TRIES):
        error = _as_is(case, bench, curve.integrator, h, curve.order)["position"][0]
        if not math.isfinite(error) or error * MARGIN <= required:
            return h, ""
        if last is not None and last[1] > error > 0:
            order = min(curve.order, max(0.5, math.log(last[1] / error) / math.log(last[0] / h)))
        last = (h, error)
        smaller = _round_down(h * (required / (MARGIN * error)) ** (1.0 / order))
        if smaller < finest:
            lacking = ", ".join(dict(case.tree.uncovered)) if case.tree is not None else ""
            return math.nan, (f"the model as it is (with {lacking} on) estimates its "
                              f"position error at {error:.3g} m at h = {h:.3g} s by self-convergence, converging at "
                              f"order {order:.2g}: it would need h ≈ {smaller:.2g} s, below the finest step a "
                              f"verification runs at ({finest:.3g} s, {VERIFY_STEPS} steps over the horizon)")
        h = smaller
    return h, ""


def _missed(v: Verification) -> str:
    if v.failures:
        return (f"at h = {v.timestep:.3g} s its check fails ({', '.join(v.failures[:3])}): MuJoCo's error there is "
                "not what its settings explain")
    worst = ", ".join(f"{m} {x:.3g}" for m, x in v.measured.items())
    as_is = ", ".join(f"{m} {x:.3g} ({how})" for m, (x, how) in v.as_is.items())
    return f"at h = {v.timestep:.3g} s it measured {worst}" + (f"; as it is, {as_is}" if as_is else "") \
        + ": beyond the requirement"


def advise(case: Case, requirements: Sequence[Requirement], *, options: RunOptions | None = None,
           integrators: Sequence[str] | None = None) -> Advice:
    """Every integrator's errors against the timestep for ``case``, and the cheapest verified setting meeting
    ``requirements``."""
    options = options or RunOptions()
    chosen = tuple(integrators) if integrators is not None else available_integrators()
    seconds: dict[str, float] = {}
    clock = time.perf_counter()
    bench = Bench(case, dataclasses.replace(options, integrators=chosen), COMPARISONS)
    seconds["reference"] = time.perf_counter() - clock
    clock = time.perf_counter()
    limits = {name: s.limit for name, s in bench.stability.items()}
    seconds["stability"] = time.perf_counter() - clock
    clock = time.perf_counter()
    progress.stage("the ladder: every integrator at h₀·2ᵏ")
    curves = measure(bench, integrators=bench.integrators, limits=limits)
    if bench.model.neq:  # an error that stopped shrinking: is it the equality constraints' softness?
        curves = tuple(_attributed(bench, c, requirements) for c in curves)
    seconds["ladder"] = time.perf_counter() - clock
    clock = time.perf_counter()
    best, tried, reasons = recommend(bench.case, options, curves, requirements, bench=bench)
    why = "" if best is not None else "no integrator meets the requirements: " + "; ".join(
        f"{name}: {text}" for name, text in reasons.items())
    seconds["verification"] = time.perf_counter() - clock
    model = bench.model
    return Advice(model=case.name, requirements=tuple(requirements), horizon=bench.case.horizon,
                  own=(integrator_name(model), float(model.opt.timestep)), curves=curves, recommended=best,
                  tried=tried, why_none=why, rejected=reasons,
                  uncovered=dict(case.tree.uncovered) if case.tree is not None else {},
                  seconds=seconds)

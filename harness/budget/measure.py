"""Run the model variants a budget needs and turn them into budgets (the arithmetic is in
:mod:`.instant` and :mod:`.trajectory`, the variants in :mod:`.variants`).

Cost, per integrator: the run at h/2 (2 units of the run at h), and at h/4
(4 more) where the error at h is not yet in its asymptotic range; with soft
constraints one run per further softness level at h and one softer run at h/2
(the cross term); with contacts, runs with their response time lengthened;
where the model's solver stops short (CG, PGS), the runs again with the
constraints solved exactly. Once per case: the floors' run. The instantaneous
budget evaluates the sampled states twice more. ``benchmarks/budget_cost.py``
measures the whole against the revision before the budget.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from analytic.systems import Scales
from harness.budget.instant import instant_budgets
from harness.budget.trajectory import Runs, budgets, every_nth, past_asymptotic, unresolved
from harness.cases import Series
from harness.core.budget import PERTURBED_RUNS, Budget, ulp_states
from harness.core.deviation import Deviation
from harness.core.errors import SimulationDiverged
from harness.core.figures import FigureName
from harness.core.trajectory import Trajectory
from harness.engine import variants as V
from harness.engine.backends import Request, active, simulate, simulate_many
from harness.engine.integrators import integrator_name
from harness.engine.models import compile_model
from harness.engine.probe import Probe
from harness.engine.recording import record
from harness.layers.instant import instant_evaluation
from harness.layers.trajectory import deviations
from harness.reference.solutions import Reference


@dataclass(frozen=True)
class ModelUnderTest:
    """How the model under test is compiled (its file, the timestep asked for, the edit applied), so
    that each variant is the same model with one more change."""

    path: Path
    timestep: float | None = None
    edit: Callable[[mujoco.MjSpec], None] | None = None
    floors: bool = True
    """Whether the reference idealizes point masses (a hand-derived system does: their floor inertia is then a
    budget part); a model's own tree reads that inertia, so it has no floor to budget."""

    def compile(self, *, integrator: str | None = None, timestep: float | None = None,
                variant: V.SpecEdit | None = None) -> mujoco.MjModel:
        return compile_model(self.path, integrator=integrator, timestep=timestep or self.timestep,
                             edit=V.compose(self.edit, variant))


@dataclass(frozen=True)
class Settings:
    """What the budget reads from the model under test once per case."""

    soft: bool
    contacts: bool
    point_masses: tuple[str, ...]
    solver_tolerance: float
    notes: tuple[str, ...]

    @classmethod
    def of(cls, model: mujoco.MjModel, scales: Scales, *, floors: bool = True) -> Settings:
        constrained = model.neq > 0 or V.has_contacts(model)
        bodies = V.point_masses(model, scales.length) if floors else ()
        notes = [*V.softness_notes(model)]
        if bodies:
            notes.append(f"floors: the rotational inertia of the point mass(es) {', '.join(bodies)} "
                         f"(≤ {V.POINT_MASS:g} m L²), doubled and extrapolated to 0"
                         + (" with the fluid forces off (the inertia box they act on is the floor: they are "
                            "not the floor's to explain)" if V.has_fluid(model) else ""))
        return cls(soft=V.has_soft_constraints(model), contacts=V.has_contacts(model), point_masses=bodies,
                   solver_tolerance=float(model.opt.tolerance) if constrained else 0.0, notes=tuple(notes))


def instant_budget(mut: ModelUnderTest, model: mujoco.MjModel, probe: Probe, ref: Reference,
                   as_is: Sequence[Deviation], *, integrator: str | None = None,
                   perturbed: Sequence[Sequence[Deviation]] = (),
                   represented: Mapping[FigureName, float] | None = None,
                   completed: Sequence[Deviation] | None = None, completion_note: str = "",
                   conditioning: float = 1.0) -> dict[FigureName, Budget]:
    """The instantaneous figures' budgets: ``as_is`` (the deviations of ``model``, compiled from ``mut``
    with ``integrator``) beside the same states on the variants: softer, heavier floors, and with the
    constraints solved exactly where the model's own solver does not converge; every evaluation on the
    active backend. ``perturbed``: on a float32 backend, ``as_is`` at the states' one-ulp copies
    (:attr:`harness.layers.instant.InstantEvaluation.perturbed`), whose spread is the round-off part, and
    ``represented`` the figures' shift with the model's constants in float32 (``InstantEvaluation.represented``),
    and ``completed`` ``as_is`` with the backend's stopped solve completed (``InstantEvaluation.completed``); the
    variants are then taken completed too, so their differences are the settings', not where each stop fell."""
    settings = Settings.of(model, ref.scales, floors=mut.floors)
    exact = V.exact_solver(model)

    def evaluate(variant: V.SpecEdit | None) -> list[Deviation]:
        got = instant_evaluation(mut.compile(integrator=integrator, variant=V.compose(exact, variant)), probe, ref)
        return got.completed if got.completed is not None else got.deviations

    eps_factor = V.softness_factor(model)
    levels = (eps_factor, eps_factor**2) if eps_factor < 1 else (eps_factor,)
    softness = tuple(evaluate(V.variant(model, eps_factor=f)) for f in levels) if settings.soft else ()
    heavier = lighter = None
    if settings.point_masses:
        base, more = V.floors_pair(model, settings.point_masses)
        heavier, lighter = evaluate(more), (evaluate(base) if base is not None else None)
    converged = evaluate(None) if exact is not None else None
    wider = V.wider_margins(model)
    margins = evaluate(wider) if wider is not None else None
    return instant_budgets(as_is, conditioning=conditioning, softness=softness, heavier=heavier, lighter=lighter,
                           converged=converged, margins=margins,
                           eps_factor=eps_factor,
                           solver_tolerance=V.CONVERGED_TOLERANCE if exact is not None else settings.solver_tolerance,
                           notes=(*settings.notes, *((completion_note,) if completion_note else ())),
                           perturbed=perturbed, represented=represented, epsilon=active().epsilon,
                           completed=completed)


@dataclass(frozen=True)
class TrajectoryRuns:
    """What the trajectory budget compares: the reference on the runs' grid, the case's settle time and
    MuJoCo-only series, and the state every run starts from."""

    reference: Trajectory
    scales: Scales
    settle: float
    series: Mapping[str, Series]
    q0: np.ndarray
    qd0: np.ndarray
    rtol: float


def _deviations(target: TrajectoryRuns, sim: Trajectory, prefix: str) -> list[Deviation]:
    return deviations(target.reference, sim, target.scales, prefix=prefix, settle=target.settle,
                      series=target.series)


def _completed(sim: Trajectory) -> Trajectory:
    """A variant run as the budget compares it: with its stopped solves completed where the backend's were
    (:attr:`harness.core.trajectory.Trajectory.completed`), so that two runs differ by their settings, not by
    where each run's float32 solver stopped."""
    return sim if sim.completed is None else sim.completed


def _variant_request(mut: ModelUnderTest, target: TrajectoryRuns, model: mujoco.MjModel, *, steps: int,
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
        m = V.roundoff_copy(m, epsilon=active().epsilon, index=perturb)
    return Request(m, np.asarray(target.q0, float), np.asarray(target.qd0, float), split * steps)


Variant = tuple[int, float, float] | tuple[int, float, float, int]
"""(split, eps_factor, tc_factor) of :func:`_variant_request`, and optionally its ``perturb``."""


def _variant_runs(mut: ModelUnderTest, probe: Probe, target: TrajectoryRuns, model: mujoco.MjModel, *, steps: int,
                  variants: Sequence[Variant]) -> list[list[Deviation]]:
    """Variants (split, eps_factor, tc_factor[, perturb]) of ``model``, run as one batched call to the backend
    (:func:`harness.engine.backends.simulate_many`), each as its deviations on the grid of the run at h."""
    requests = [_variant_request(mut, target, model, steps=steps, split=v[0], eps_factor=v[1], tc_factor=v[2],
                                 perturb=v[3] if len(v) > 3 else 0) for v in variants]
    sims = simulate_many(requests, probe)
    name = integrator_name(model)
    return [_deviations(target, every_nth(_completed(sim) if len(v) < 4 or not v[3] else sim, v[0]), name)
            for sim, v in zip(sims, variants, strict=True)]


def _variant_run(mut: ModelUnderTest, probe: Probe, target: TrajectoryRuns, model: mujoco.MjModel, *, steps: int,
                 split: int = 1, eps_factor: float = 1.0, tc_factor: float = 1.0) -> list[Deviation]:
    """One variant of ``model`` run over the horizon, as its deviations on the grid of the run at h."""
    return _variant_runs(mut, probe, target, model, steps=steps, variants=[(split, eps_factor, tc_factor)])[0]


def _floors(mut: ModelUnderTest, probe: Probe, target: TrajectoryRuns, sims: Mapping[str, Trajectory],
            bodies: tuple[str, ...]) -> dict[str, np.ndarray]:
    """D − A per figure measure: the point masses' floors doubled (both runs without fluid forces where the
    model has them: :func:`~harness.engine.variants.floors_pair`), run once with the most accurate integrator
    (a floor moves an explicit integrator's error too: a ball joint's spin carries the floor alone),
    shared by every integrator: a floor is physics, not integration."""
    name = "RK4" if "RK4" in sims else next(iter(sims))
    steps = len(sims[name].t) - 1
    model = mut.compile(integrator=name)
    exact = V.exact_solver(model)
    lighter, more = V.floors_pair(model, bodies)
    heavier = simulate(mut.compile(integrator=name, variant=V.compose(exact, more)),
                       probe, q0=target.q0, qd0=target.qd0, steps=steps)
    base = sims[name] if exact is None and lighter is None else \
        simulate(mut.compile(integrator=name, variant=V.compose(exact, lighter)), probe, q0=target.q0,
                 qd0=target.qd0, steps=steps)
    as_is = {d.name.measure: d.values for d in _deviations(target, _completed(base), name)}
    return {d.name.measure: d.values - as_is[d.name.measure] for d in _deviations(target, _completed(heavier), name)}


def _integrator_runs(mut: ModelUnderTest, probe: Probe, target: TrajectoryRuns, sim: Trajectory, name: str, *,
                     order: float, settings: Settings, floors: Mapping[str, np.ndarray] | None) -> Runs:
    model = mut.compile(integrator=name)
    steps = len(sim.t) - 1
    eps = V.softness_factor(model)
    slow = V.TIMECONST_FACTOR
    levels = (eps, eps * eps) if eps < 1 else (eps,)

    def run(split: int = 1, eps_factor: float = 1.0, tc_factor: float = 1.0) -> list[Deviation]:
        return _variant_run(mut, probe, target, model, steps=steps, split=split, eps_factor=eps_factor,
                            tc_factor=tc_factor)

    as_is = _deviations(target, sim, name)
    # every variant that does not wait on another's result, as one batched call to the backend
    plan: dict[str, Variant] = {"half_step": (2, 1.0, 1.0)}
    if not V.solver_converges(model):
        plan["converged"] = (1, 1.0, 1.0)
    if settings.soft:
        plan |= {f"softness{k}": (1, f, 1.0) for k, f in enumerate(levels)} | {"softness_half_step": (2, eps, 1.0)}
    if settings.contacts:
        plan |= {f"slower{k}": (1, f, slow) for k, f in enumerate((1.0, *levels))}
    float32 = active().epsilon > float(np.finfo(np.float64).eps)
    if float32:  # the run's round-off, measured by copies one ulp apart (harness.budget.trajectory)
        plan |= {f"perturbed{k}": (1, 1.0, 1.0, k) for k in range(1, PERTURBED_RUNS + 1)}
    done = dict(zip(plan, _variant_runs(mut, probe, target, model, steps=steps, variants=list(plan.values())),
                    strict=True))
    half_step = done["half_step"]
    converged = done.get("converged")
    asymptotic = not past_asymptotic(converged or as_is, half_step, order) and V.steps_per_timeconst(model) <= 0.5
    represented = _represented(probe, target, model, steps=steps) if float32 else {}
    quantized = _quantized(probe, target, model, steps=steps) if float32 else {}
    return Runs(
        as_is=as_is,
        half_step=half_step,
        converged=converged,
        quarter_step=None if asymptotic else run(4),
        softness=tuple(done[f"softness{k}"] for k in range(len(levels))) if settings.soft else (),
        softness_half_step=done["softness_half_step"] if settings.soft else None,
        slower=tuple(done[f"slower{k}"] for k in range(1 + len(levels))) if settings.contacts else (),
        floors=floors,
        perturbed=tuple(done[f"perturbed{k}"] for k in range(1, PERTURBED_RUNS + 1)) if float32 else (),
        completed=None if sim.completed is None else _deviations(target, sim.completed, name),
        represented=represented,
        quantized=quantized,
        eps_factor=eps, tc_factor=slow,
    )


def _represented(probe: Probe, target: TrajectoryRuns, model: mujoco.MjModel, *, steps: int) -> dict[str, float]:
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
            for a, b in zip(_deviations(target, base, name), _deviations(target, rounded, name), strict=True)}


def _quantized(probe: Probe, target: TrajectoryRuns, model: mujoco.MjModel, *, steps: int) -> dict[str, float]:
    """Each figure's response (by measure) to the initial state moved by half an ulp of float32
    (:func:`~harness.core.budget.ulp_states`, :data:`~harness.core.budget.PERTURBED_RUNS` seeds, the largest):
    the C engine in float64, so the physics' answer to a state's quantization (a stiff constraint's force
    spike), not arithmetic (:data:`~harness.core.budget.QUANTIZATION`)."""
    q0, qd0 = np.asarray(target.q0, float), np.asarray(target.qd0, float)
    eps = float(np.finfo(np.float32).eps)
    name = integrator_name(model)
    base = _deviations(target, record(model, probe, q0=q0, qd0=qd0, steps=steps), name)
    out = {d.name.measure: 0.0 for d in base}
    for k in range(1, PERTURBED_RUNS + 1):
        moved = record(model, probe, q0=ulp_states(q0, epsilon=eps, seed=k),
                       qd0=ulp_states(qd0, epsilon=eps, seed=PERTURBED_RUNS + k), steps=steps)
        for a, b in zip(base, _deviations(target, moved, name), strict=True):
            out[a.name.measure] = max(out[a.name.measure], a.magnitude(b.values - a.values))
    return out


def trajectory_runs(mut: ModelUnderTest, probe: Probe, target: TrajectoryRuns, sims: Mapping[str, Trajectory],
                    *, orders: Mapping[str, float]) -> tuple[dict[str, Runs], dict[str, str]]:
    """Every integrator's :class:`~harness.budget.trajectory.Runs`: ``sims`` (the runs at the model's
    settings, by integrator) and the variants, each run from the same state over the same horizon; an
    integrator past the asymptotic range (at its documented order in ``orders``) also at h/4. The second
    result says, by integrator, why its budget could not be made (a variant run that diverged: then its
    figures cannot be judged, and fail with that reason)."""
    runs: dict[str, Runs] = {}
    failed: dict[str, str] = {}
    if not sims:
        return runs, failed
    settings = Settings.of(mut.compile(integrator=next(iter(sims))), target.scales, floors=mut.floors)
    floors = None
    if settings.point_masses:
        try:
            floors = _floors(mut, probe, target, sims, settings.point_masses)
        except SimulationDiverged as exc:
            return runs, {name: f"the budget's run with the point masses' floors doubled {exc.reason}"
                          for name in sims}
    twins: list[tuple[float, Trajectory, str]] = []  # (order, run at h, the integrator whose variants it has)
    for name, sim in sims.items():
        twin = next((owner for order, other, owner in twins
                     if order == orders[name] and _twins(sim, other, target.scales)), None)
        if twin is not None:  # the same step map: its variants are the same runs
            if twin in runs:
                runs[name] = _renamed(runs[twin], name, _deviations(target, sim, name))
            else:
                failed[name] = failed[twin]
            continue
        twins.append((orders[name], sim, name))
        try:
            made = _integrator_runs(mut, probe, target, sim, name, order=orders[name], settings=settings,
                                    floors=floors)
        except SimulationDiverged as exc:
            failed[name] = f"a run of its budget (a variant at h/2, h/4 or softer) {exc.reason}"
            continue
        why = unresolved(made, order=orders[name], integrator=name)
        if why:
            failed[name] = why
        else:
            runs[name] = made
    return runs, failed


def _renamed(runs: Runs, integrator: str, as_is: Sequence[Deviation]) -> Runs:
    """``runs`` as another integrator's, with that integrator's own run at h: every deviation's figure name
    carries that integrator."""
    def devs(values: Sequence[Deviation] | None) -> list[Deviation] | None:
        if values is None:
            return None
        return [dataclasses.replace(d, name=FigureName(f"{integrator}.{d.name.measure}")) for d in values]

    return dataclasses.replace(runs, as_is=list(as_is), half_step=devs(runs.half_step),
                               converged=devs(runs.converged), quarter_step=devs(runs.quarter_step),
                               softness=tuple(devs(r) for r in runs.softness),
                               softness_half_step=devs(runs.softness_half_step),
                               slower=tuple(devs(r) for r in runs.slower),
                               perturbed=tuple(devs(r) for r in runs.perturbed), completed=devs(runs.completed))


TWIN_TOLERANCE = 1e-9
"""Two runs at the model's settings agreeing to this fraction of each recorded quantity's largest size are
one step map's (:func:`_twins`)."""


def _twins(a: Trajectory, b: Trajectory, scales: Scales) -> bool:
    """Whether two integrators' runs at the model's settings are the same up to round-off: every recorded
    number within :data:`TWIN_TOLERANCE` of its quantity's size (its largest value, and at least the case's
    length for positions, violations and series, its force for multipliers: a violation of 1e-8 m differing
    by 1e-16 m is round-off). Semi-implicit Euler, implicitfast and implicit are one step map where no
    velocity-dependent force has a derivative (no damping, no actuator; for implicit, no Coriolis term):
    their factorizations round differently (1e-13 relative here), nothing more. Their variant runs then
    agree as closely, so those are made once and shared: each budget keeps its own run at h, and what the
    sharing changes lies 1e-9 below the figure, under the round-off tolerance. A fault with a
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

"""The bench a case is measured on, and the contract between the run and the families.

:class:`Bench` prepares a case once — its model under test compiled as the options ask, the
numeric dynamics and the reference solved from that model, the probe, the engine every run goes
to — and makes, on first use and once, the measurements several families share: the evaluation
at the sampled states (:mod:`.sampled`) and the runs over the horizon with the variants their
budget needs (:mod:`.runs`). What a family compares in those measurements is the family's own
(:class:`Comparisons`, built from the families by the run); what it gives back is a
:class:`Measured`.

A family (:class:`Family`) is a module of :mod:`harness.families` that declares its figures'
names, which of them a case without a limits file gates, their limits from theory, and how it
measures them on a bench.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import Protocol, TypeVar

import mujoco
import numpy as np

from analytic.solvers import STIFF_RTOL
from harness.cases import Case
from harness.core import bounds, progress
from harness.core.budget import Budget
from harness.core.checks import Limit
from harness.core.errors import BackendUnavailable, SimulationDiverged, UnmodelledElement
from harness.core.figures import Figure, FigureName
from harness.core.findings import Finding
from harness.core.options import RunOptions
from harness.core.trajectory import Trajectory
from harness.engine import backends
from harness.engine.backends import simulate
from harness.engine.integrators import EXPECTED_ORDER, available_integrators, integrator_name
from harness.engine.models import compile_model
from harness.engine.recording import steps_in
from harness.engine.variants import SETTLE_TIMECONSTS, ModelUnderTest, compose, contact_timeconst
from harness.families import runs, sampled, stability
from harness.reference import derivations
from harness.reference import solutions as refmod
from harness.reference.tree import switch_note, switched_orders, switches

__all__ = ["Bench", "Comparisons", "Family", "Measured", "perturbed", "settle_time"]

T = TypeVar("T")  # what a timed stage returns


@dataclass(frozen=True)
class Measured:
    """What one family measured of a case.

    Attributes:
        figures: its figures, in the family's order.
        budgets: each figure's error budget, by name (a figure judged by theory has none).
        defect_budgets: for an integrator a documented defect of this MuJoCo affects, each of its figures' budget
            at the order the defect degrades it to (the defect's signature).
        unmeasured: figures that could not be measured at these settings, each with why (their checks are n/a).
        diverged: figures (or runs: ``INTEGRATOR``, ``converge.INTEGRATOR``) whose run diverged or whose model made
            them unmeasurable, each with why (their checks fail with it).
        orders: each integrator's observed convergence order.
        findings: engine functions found to disagree while measuring.
        settings: what the family adds to the run's settings, by key.
    """

    figures: tuple[Figure, ...] = ()
    budgets: Mapping[str, Budget] = field(default_factory=dict)
    defect_budgets: Mapping[str, Budget] = field(default_factory=dict)
    unmeasured: Mapping[str, str] = field(default_factory=dict)
    diverged: Mapping[str, str] = field(default_factory=dict)
    orders: Mapping[str, float] = field(default_factory=dict)
    findings: tuple[Finding, ...] = ()
    settings: Mapping[str, object] = field(default_factory=dict)


class Family(Protocol):
    """A module of :mod:`harness.families`: one family of figures."""

    NAME: str

    def owns(self, name: FigureName) -> bool:
        """Whether ``name`` is one of this family's figures."""

    def names(self, case: Case, model: mujoco.MjModel) -> set[FigureName]:
        """Every figure name this family can give ``case`` (whose shipped model is ``model``): a superset, known
        without running it."""

    def gated(self, name: FigureName, *, constrained: bool) -> bool:
        """Whether a case without a limits file gates the figure ``name`` (``constrained``: it has constraint
        forces)."""

    def theory_limit(self, name: FigureName) -> Limit | None:
        """The limit theory sets for the figure whatever the case; None where its budget judges it."""

    def measure(self, bench: Bench) -> Measured:
        """The family's figures of the case on ``bench``."""


@dataclass(frozen=True)
class Comparisons:
    """How the families compare MuJoCo with the reference, handed to the shared measurements: at the sampled
    states (:data:`harness.families.sampled.Compare`) and over a run (:data:`harness.families.runs.Compare`),
    each family's in the order of :data:`harness.families.FAMILIES`."""

    at_states: tuple[sampled.Compare, ...]
    over_runs: tuple[runs.Compare, ...]


def perturbed(case: Case, size: float) -> Case:
    """``case`` with every initial coordinate and velocity x moved to x + size · max(|x|, 1).

    At ``size`` of a few units of float round-off (``mjharness versions`` uses 1e-15) nothing physical
    changes: the reference and MuJoCo start from the same moved state (the reference is built from it),
    every sampled state of the instantaneous figures moves with it, and what a figure does is what round-off
    does to it. The difference from the unperturbed run is that figure's run-to-run noise, which a
    deterministic engine never shows on one machine (``harness.versions.changes``)."""
    if not (math.isfinite(size) and size != 0):
        raise ValueError(f"perturb must be a nonzero finite number, got {size}")
    return case.with_motion(q0={k: v + size * max(abs(v), 1.0) for k, v in case.q0.items()},
                            qd0={k: v + size * max(abs(v), 1.0) for k, v in case.qd0.items()})


def settle_time(case: Case, model: mujoco.MjModel, horizon: float) -> tuple[float, str]:
    """When the force and MuJoCo-only figures start counting: the case's ``settle``, or
    :data:`~harness.engine.variants.SETTLE_TIMECONSTS` response times of the model's slowest contact
    if longer (a softer contact settles later), at most half the horizon; with a note where capped."""
    wanted = max(case.settle, SETTLE_TIMECONSTS * contact_timeconst(model))
    if wanted <= horizon / 2:
        return wanted, ""
    return horizon / 2, (f"settle: the contacts' response time asks for {wanted:g} s before force figures count; "
                         f"capped at half the horizon ({horizon / 2:g} s): what remains of the transient is "
                         "not in any budget")


def _engine_integrators(engine: backends.Backend, mut: ModelUnderTest, chosen: tuple[str, ...], *,
                        given: bool) -> tuple[tuple[str, ...], dict[str, str]]:
    """The integrators ``engine`` runs of ``chosen``, and why it skips the others. One it cannot run raises
    BackendUnavailable (the feature, the fix) where the user named it, or where it can run none."""
    reasons = {name: engine.unsupported(mut.compile(integrator=name)) for name in chosen}
    runnable = tuple(name for name in chosen if not reasons[name])
    refused = {name: why for name, why in reasons.items() if why}
    if refused and (given or not runnable):
        raise BackendUnavailable(next(iter(refused.values())))
    return runnable, refused


class Bench:
    """One case prepared to be measured, and the measurements its families share, each made once.

    Attributes:
        case: the case with the options' motion (horizon, q0, qd0, perturbation) applied.
        options: how it runs.
        engine: the backend every run and evaluation goes to.
        mut: the model under test (its file, the timestep asked for, the case's preparation and the user's edit).
        model: that model compiled (the model's own integrator).
        shipped: the case's shipped model, compiled (what the settings are compared with).
        reference: the reference solved from ``model`` (a stiff tree's to ``stiff_rtol``).
        probe: what is read from MuJoCo's runs of it.
        integrators: the integrators run (those asked for that the engine can run); ``skipped``: why the others
            are not.
        timings: seconds per stage, the shared measurements' and each family's.
    """

    def __init__(self, case: Case, options: RunOptions, comparisons: Comparisons, *,
                 stiff_rtol: float = STIFF_RTOL) -> None:
        self.options = options
        self.comparisons = comparisons
        self.engine = backends.get(options.backend)
        edit = options.edit
        if case.prepare is not None:  # a tree case: its model prepared (and isolated) before any edit of the user's
            edit = compose(case.prepare, edit)
        if options.horizon is not None or options.q0 or options.qd0:
            case = case.with_motion(q0=options.q0, qd0=options.qd0, horizon=options.horizon)
        if options.perturb is not None:
            case = perturbed(case, options.perturb)
        self.case = case
        chosen = options.integrators if options.integrators is not None else available_integrators()
        for name in chosen:
            if name not in available_integrators():
                raise ValueError(f"unknown integrator {name!r}; this MuJoCo offers "
                                 f"{', '.join(available_integrators())}")
        self.timings: dict[str, float] = {}
        clock = time.perf_counter()
        self.path = options.mjcf if options.mjcf is not None else case.mjcf
        self.mut = ModelUnderTest(path=self.path, timestep=options.timestep, edit=edit, floors=case.tree is None)
        self.model = self.mut.compile()
        h = float(self.model.opt.timestep)
        bounds.check_steps(steps_in(case.horizon, h), horizon=case.horizon, timestep=h)  # before any work
        own = integrator_name(self.model)  # the integrator the model itself names leads every list of runs
        leading = sorted(chosen, key=lambda name: name != own)
        self.integrators, self.skipped = _engine_integrators(self.engine, self.mut, tuple(leading),
                                                             given=options.integrators is not None)
        self.shipped = compile_model(case.mjcf, edit=case.prepare)
        compiling = time.perf_counter() - clock  # counted with the reference, which reads the model
        clock = time.perf_counter()
        # numeric dynamics at the model's parameters: loaded from the on-disk cache, or derived (and cached)
        params = case.params_from_model(self.model)
        if case.tree is None:  # a tree case has no derivation: its dynamics are read from the model
            derivations.dynamics(case.system, params)
            derivations.minimal_dynamics(case.system, params)
        self.timings["derivation"] = time.perf_counter() - clock
        clock = time.perf_counter()
        progress.stage("solving the reference")
        self.reference = case.reference(self.model, stiff_rtol=stiff_rtol)
        self.timings["reference"] = compiling + (time.perf_counter() - clock)
        self.probe = case.probe(self.reference.dynamics)

    def timed(self, stage: str, work: Callable[[], T]) -> T:
        """``work()``, its seconds added to the timings under ``stage`` (and named in the progress lines until it
        ends: a stage timed inside another, the budget's switches inside its runs, gives the name back)."""
        previous = progress.stage(stage)
        clock = time.perf_counter()
        try:
            return work()
        finally:
            self.timings[stage] = self.timings.get(stage, 0.0) + time.perf_counter() - clock
            progress.stage(previous)

    # ------------------------------------------------------------------ the sampled states
    @cached_property
    def instant_model(self) -> mujoco.MjModel:
        """The model the sampled states are evaluated on: its own integrator, but Euler where it is ``discrete``
        (qacc is the step map there; the states ask for continuous time)."""
        return self.mut.compile(integrator=self._instant_integrator)

    @property
    def _instant_integrator(self) -> str | None:
        return "Euler" if integrator_name(self.model) == "discrete" else None

    @cached_property
    def sampled(self) -> sampled.Evaluation:
        """MuJoCo at the sampled states, compared by every family that compares there, with every figure's
        budget (:func:`harness.families.sampled.evaluate`)."""
        conditioning = 1.0  # a model judged against its own tree: the solved figures' round-off grows with n cond(M)
        if self.case.tree is not None:
            ref = self.reference
            configurations = ref.solution.state(np.linspace(0.0, ref.solution.t_end, 24))[0]  # those sampled
            conditioning = ref.dynamics.n * float(np.max(np.linalg.cond(ref.dynamics.mass_matrix(configurations))))
        return self.timed("instant", lambda: sampled.evaluate(
            self.mut, self.instant_model, self.probe, self.reference, self.engine, self.comparisons.at_states,
            integrator=self._instant_integrator, conditioning=conditioning))

    @cached_property
    def stability(self) -> dict[str, stability.Stability]:
        """Each explicit integrator run against its stability region at the model's step, the reference linearized
        at :func:`~harness.families.stability.states_for` of its states over the horizon
        (:func:`harness.families.stability.assess`); empty where the reference cannot be linearized there."""
        model = self.model
        times = np.linspace(0.0, self.case.horizon, stability.states_for(self.reference.dynamics.n))
        q, qd = self.reference.solution.state(times)
        eulerdamp = not model.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_EULERDAMP)
        try:
            return self.timed("stability", lambda: stability.assess(
                self.reference.dynamics, q, qd, timestep=float(model.opt.timestep), integrators=self.integrators,
                implicit_damping=eulerdamp and bool(np.any(model.dof_damping > 0)), horizon=self.case.horizon))
        except np.linalg.LinAlgError:  # a singular KKT system at a state: no statement, every run judged as it is
            return {}

    # ------------------------------------------------------------------ the runs
    @cached_property
    def steps(self) -> int:
        return steps_in(self.case.horizon, self.model.opt.timestep)

    @cached_property
    def _runs_at_h(self) -> tuple[dict[str, Trajectory], dict[str, str]]:
        sims: dict[str, Trajectory] = {}
        diverged: dict[str, str] = {}  # a diverged run is a verdict of its own, never a number (pipeline.verdict)

        def run() -> None:
            for name in self.integrators:
                try:
                    sims[name] = simulate(self.engine, self.mut.compile(integrator=name), self.probe,
                                          q0=self.reference.q0(), qd0=self.reference.qd0(), steps=self.steps)
                except (SimulationDiverged, UnmodelledElement) as exc:
                    diverged[name] = exc.reason

        self.timed("mujoco", run)
        return sims, diverged

    @property
    def sims(self) -> dict[str, Trajectory]:
        """Each integrator's run at the model's settings over the horizon, by integrator (those that did not
        diverge)."""
        return self._runs_at_h[0]

    @property
    def diverged(self) -> dict[str, str]:
        """Why each integrator's run over the horizon diverged, by integrator."""
        return self._runs_at_h[1]

    @cached_property
    def grid(self) -> np.ndarray:
        """The runs' sample times."""
        sims = self.sims
        return next(iter(sims.values())).t if sims else np.arange(self.steps + 1) * self.model.opt.timestep

    @cached_property
    def reference_run(self) -> Trajectory:
        """The reference on the runs' grid."""
        return self.timed("compare", lambda: refmod.trajectory(self.reference, self.grid))

    @cached_property
    def settle(self) -> tuple[float, str]:
        """When force and MuJoCo-only figures start counting, and a note where it was capped (:func:`settle_time`)."""
        return settle_time(self.case, self.model, self.case.horizon)

    @cached_property
    def target(self) -> runs.Target:
        """What every run is compared with: the reference on the grid, the scales, the settle time, the case's
        MuJoCo-only series, the starting state, and the families' comparisons."""
        return runs.Target(reference=self.reference_run, scales=self.reference.scales, settle=self.settle[0],
                           series=self.case.mujoco_series, q0=self.reference.q0(), qd0=self.reference.qd0(),
                           rtol=self.reference.solution.rtol, compare=self.comparisons.over_runs)

    @cached_property
    def run_deviations(self) -> dict[str, list]:
        """Each run at h compared with the reference by every family that compares runs, by integrator."""
        return self.timed("compare", lambda: {name: runs.compared(self.target, sim, name)
                                              for name, sim in self.sims.items()})

    def measured_at_states(self, owns: Callable[[FigureName], bool]) -> Measured:
        """The figures ``owns`` claims of the evaluation at the sampled states, with their budgets, those n/a and
        those the model makes unmeasurable (what a family that compares at the states measures)."""
        found = self.sampled
        return Measured(figures=tuple(d.figure() for d in found.deviations if owns(d.name)),
                        budgets={k: v for k, v in found.budgets.items() if owns(FigureName(k))},
                        unmeasured={k: v for k, v in found.unavailable.items() if owns(FigureName(k))},
                        diverged={k: v for k, v in found.failing.items() if owns(FigureName(k))})

    def measured_over_runs(self, owns: Callable[[FigureName], bool]) -> Measured:
        """The figures ``owns`` claims of the runs at h, with their budgets and those at a documented defect's
        order (what a family that compares over the runs measures)."""
        made = self.run_budgets
        return Measured(figures=tuple(d.figure() for devs in self.run_deviations.values() for d in devs
                                      if owns(d.name)),
                        budgets={k: v for k, v in made.budgets.items() if owns(FigureName(k))},
                        defect_budgets={k: v for k, v in made.defect.items() if owns(FigureName(k))})

    @cached_property
    def run_budgets(self) -> runs.Budgets:
        """Every run figure's budget from the variant runs (:func:`harness.families.runs.budget`), each integrator's
        at its order over this motion (:attr:`orders`)."""
        return self.timed("budget", lambda: runs.budget(self.mut, self.probe, self.engine, self.target, self.sims,
                                                         model=self.model, settle_note=self.settle[1],
                                                         orders=self.orders, switch_note=switch_note(self.switches)))

    @cached_property
    def switches(self) -> tuple[tuple[str, float], ...]:
        """Where the reference motion crosses a clamp's switch (an actuator's forcerange, a joint's
        actuatorfrcrange), located on the reference (:func:`harness.reference.tree.switches`)."""
        ref = self.reference
        return self.timed("reference", lambda: switches(ref.dynamics, ref.solution.state, ref.solution.t_end))

    @cached_property
    def orders(self) -> dict[str, int]:
        """Each integrator's order over this motion: the documented one, at most
        :data:`~harness.reference.tree.SWITCHED_ORDER` across a clamp's switch."""
        return switched_orders(EXPECTED_ORDER, self.switches)

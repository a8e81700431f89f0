"""Run one case through every layer: reference, instantaneous checks, trajectories, orders, budgets.

Pure function of its inputs: the CLI, the Python API, the tests and the CI
gate all call :func:`run_case` and differ only in what they do with the result.

The reference describes the model under test: its parameters are read from
that model (shipped or the user's ``mjcf``), its initial state is brought onto
the constraints at those parameters, and what differs from the shipped model
is listed in the settings (``changed``). Every figure gets its error budget
from runs of the same model with one setting changed (:mod:`harness.budget`).
"""

from __future__ import annotations

import math
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from harness.budget.measure import (
    ModelUnderTest,
    Settings,
    TrajectoryRuns,
    instant_budget,
    trajectory_budget,
    trajectory_runs,
)
from harness.cases import Case
from harness.core import bounds
from harness.core.budget import Budget
from harness.core.errors import BackendUnavailable, SimulationDiverged, UnmodelledElement
from harness.core.figures import Figure, FigureName
from harness.core.findings import Finding
from harness.core.trajectory import Trajectory
from harness.engine import backends, recording, variants
from harness.engine.backends import simulate
from harness.engine.compat import applicable_defect, fallbacks, joint_types, unavailable_reason
from harness.engine.integrators import available_integrators, integrator_name
from harness.engine.models import authored, compile_model
from harness.engine.recording import recorder, steps_in
from harness.layers.balance import balance_figures
from harness.layers.instant import engine_findings, instant_evaluation
from harness.layers.orders import EXPECTED_ORDER, VERDICT_QUANTITY, convergence_study, order_figures
from harness.layers.reference import reference_figures
from harness.layers.trajectory import deviations
from harness.opinions.threeway import three_way
from harness.reference import derivations
from harness.reference import solutions as refmod
from harness.reference.tree import TreeEdit


@dataclass(frozen=True)
class CaseResult:
    """Everything one case produced: figures, their budgets, trajectories and the settings used
    (``reference`` None and ``simulations`` empty where a parallel run sent back figures only:
    ``check``, ``baseline``).

    Attributes:
        budgets: each instantaneous and trajectory figure's error budget, by figure name.
        defect_budgets: for an integrator a documented defect of this MuJoCo affects on this model, each
            of its figures' budget at the order the defect degrades it to (the defect's signature).
        orders: each integrator's observed convergence order (the converge layer's fit).
        findings: engine functions found to disagree while measuring.
        unmeasured: figures that could not be measured at these settings, each with the reason (a
            convergence order hidden under a softness floor): their checks are n/a, with the reason.
        joints: the joint types of the model run (known defects match them).
    """

    case: Case
    figures: tuple[Figure, ...]
    reference: Trajectory | None
    simulations: dict[str, Trajectory]
    settings: dict[str, object]
    timings: dict[str, float] = field(default_factory=dict)
    joints: frozenset[int] = frozenset()
    budgets: Mapping[str, Budget] = field(default_factory=dict)
    defect_budgets: Mapping[str, Budget] = field(default_factory=dict)
    orders: Mapping[str, float] = field(default_factory=dict)
    findings: tuple[Finding, ...] = ()
    unmeasured: Mapping[str, str] = field(default_factory=dict)
    diverged: dict[str, str] = field(default_factory=dict)  # INTEGRATOR, converge.INTEGRATOR, instant figure -> why

    def figure(self, name: str) -> Figure:
        for f in self.figures:
            if f.name == name:
                return f
        raise KeyError(name)

    @property
    def judged_names(self) -> list[str]:
        """Every figure the run measured, could not measure (n/a with why), or would have measured had its run not
        diverged (the balance's own runs, an instantaneous figure the model made unmeasurable, every figure of an
        integrator whose run diverged). A diverged run has no figure of its own, and where limits are made from the
        figures (a model judged against its own tree) its checks would vanish with them, a silent pass. A diverged
        integrator's names are its siblings' (the same quantities of every other integrator run), else those every
        run has."""
        names = [*(str(f.name) for f in self.figures), *self.unmeasured]
        names += [k for k in self.diverged if "." in k and not k.startswith("budget.")  # a figure's own run diverged
                  and not (k.startswith("converge.") and k.count(".") == 1)]  # (a ladder's key names no figure)
        lost = [k for k in self.diverged if "." not in k]  # the integrators whose run diverged
        if lost:
            kinds = {(f.layer, f.quantity, f.detail) for f in map(FigureName, names) if f.integrator}
            kinds |= {("trajectory", "position", ""), ("trajectory", "drift", "energy"),
                      ("converge", "order_shortfall", "")}
            for integrator in lost:
                for layer, quantity, detail in sorted(kinds):
                    names.append(str(FigureName.converge(integrator, quantity) if layer == "converge"
                                     else FigureName.trajectory(integrator, quantity, detail)))
        return list(dict.fromkeys(names))


@dataclass(frozen=True)
class RunOptions:
    """What a user may change of how a case runs (CLI flags, the API's keywords; picklable, so workers get
    them): the model file, the timestep, the integrators run, the horizon and the initial state (the
    coordinates named; a case's motion gives the rest). All None: the case as shipped."""

    mjcf: Path | None = None
    timestep: float | None = None
    integrators: tuple[str, ...] | None = None
    horizon: float | None = None
    q0: Mapping[str, float] | None = None
    qd0: Mapping[str, float] | None = None
    perturb: float | None = None
    backend: str = "c"

    @property
    def shipped(self) -> bool:
        return self == RunOptions()

    def run(self, case: Case, *, edit: Callable[[mujoco.MjSpec], None] | None = None) -> CaseResult:
        return run_case(case, mjcf=self.mjcf, integrators=self.integrators, timestep=self.timestep,
                        horizon=self.horizon, q0=self.q0, qd0=self.qd0, perturb=self.perturb, edit=edit,
                        backend=self.backend)


def perturbed(case: Case, size: float) -> Case:
    """``case`` with every initial coordinate and velocity x moved to x + size · max(|x|, 1).

    At ``size`` of a few units of float round-off (``mjharness versions`` uses 1e-15) nothing physical
    changes: the reference and MuJoCo start from the same moved state (the reference is built from it),
    every sampled state of the instant layer moves with it, and what a figure does is what round-off
    does to it. The difference from the unperturbed run is that figure's run-to-run noise, which a
    deterministic engine never shows on one machine (``harness.versions.changes``)."""
    if not (math.isfinite(size) and size != 0):
        raise ValueError(f"perturb must be a nonzero finite number, got {size}")
    return case.with_motion(q0={k: v + size * max(abs(v), 1.0) for k, v in case.q0.items()},
                            qd0={k: v + size * max(abs(v), 1.0) for k, v in case.qd0.items()})


INSTANT_NOTE = (
    "the instantaneous layer reads the backend's forward dynamics at the sampled states (one batched forward_many: "
    "mass matrix, qfrc_passive - qfrc_bias, qacc, the equalities' efc_force, qfrc_constraint, force/torque/"
    "accelerometer sensors and cfrc_int); kinematics (point positions, the Jacobians J and J-dot, site frames, "
    "an equality's efc_J) from MuJoCo's C engine in float64 at the same qpos; on a float32 backend its round-off "
    "part from 4 one-ulp copies of the states in the same call, plus each figure's shift with the model's "
    "constants rounded to float32 (the C engine in float64). MJX computes no acceleration sensors or cfrc_int "
    "in a model without constraint rows (its forward returns before sensor_acc): they are computed in float64 "
    "from MJX's qacc; where a backend's reactions are missing and the C engine's constraint rows include "
    "contact or limit rows (whose order differs), the sensor and interaction figures are n/a with that reason")
"""What the report's settings say the instantaneous layer reads on a backend other than C
(:func:`harness.layers.instant.instant_evaluation`)."""


def model_settings(model: mujoco.MjModel) -> dict[str, object]:
    """The settings that matter for a comparison, as recorded in the report."""
    out: dict[str, object] = {
        "timestep": float(model.opt.timestep),
        "integrator": integrator_name(model),
        "solver": mujoco.mjtSolver(int(model.opt.solver)).name.removeprefix("mjSOL_"),
        "iterations": int(model.opt.iterations),
        "tolerance": float(model.opt.tolerance),
        "cone": mujoco.mjtCone(int(model.opt.cone)).name.removeprefix("mjCONE_"),
        "impratio": float(model.opt.impratio),
        "noslip_iterations": int(model.opt.noslip_iterations),
    }
    for i in range(model.neq):
        eq = model.equality(i)
        out[f"equality.{eq.name}.solref"] = [float(x) for x in eq.solref]
        out[f"equality.{eq.name}.solimp"] = [float(x) for x in eq.solimp]
    for i in range(model.npair):
        pair = model.pair(i)
        for key in ("solref", "solimp", "friction", "margin"):
            out[f"pair.{pair.name}.{key}"] = [float(x) for x in np.atleast_1d(getattr(pair, key))]
    return out


def changed_settings(shipped: Mapping[str, object], tested: Mapping[str, object]) -> dict[str, dict[str, object]]:
    """Every setting or parameter whose value differs between the shipped model and the one tested:
    ``{name: {"shipped": a, "tested": b}}`` (a name only one has shows None on the other side)."""
    return {k: {"shipped": shipped.get(k), "tested": tested.get(k)}
            for k in dict.fromkeys([*shipped, *tested]) if shipped.get(k) != tested.get(k)}


_SETTINGS_OF = {"option": {"timestep", "integrator", "solver", "iterations", "tolerance", "cone", "impratio",
                            "noslip_iterations"},
                "equality": {"solref", "solimp"}, "pair": {"solref", "solimp", "friction", "margin"}}
"""Attributes :func:`model_settings` lists already, by the element kind (equalities of every type)."""


def _element_key(element: ET.Element, parent: str, index: int) -> str:
    """An element's label: its kind and name where it has one (MuJoCo's names are unique per kind), else its
    parent's label and its place among its kind there."""
    name = element.get("name")
    if name is not None:
        return f"{element.tag} {name!r}"
    own = element.tag + (f"[{index}]" if index else "")
    return f"{parent}/{own}" if parent and parent != "mujoco" else own


def _covered(element: ET.Element, parent: ET.Element | None, attribute: str) -> bool:
    kind = "equality" if parent is not None and parent.tag == "equality" else element.tag
    return attribute in _SETTINGS_OF.get(kind, set())


def authored_differences(shipped: str, tested: str) -> dict[str, dict[str, object]]:
    """Every attribute of every element in which two models as MuJoCo writes them differ
    (:func:`harness.engine.models.authored`): ``{"mjcf: ELEMENT ATTRIBUTE": {"shipped": a, "tested": b}}``
    ("default": MuJoCo's; an element one lacks: ``{"mjcf: ELEMENT": "absent" / "present"}``), less what
    :func:`model_settings` lists. Compared as written, so a joint's added damping, a geom's margin or a new
    body shows however the model was changed."""
    out: dict[str, dict[str, object]] = {}

    def children(element: ET.Element | None, label: str) -> dict[str, ET.Element]:
        found: dict[str, ET.Element] = {}
        counts: dict[str, int] = {}
        for child in element if element is not None else ():
            index = counts.get(child.tag, 0)
            counts[child.tag] = index + 1
            found[_element_key(child, label, index)] = child
        return found

    def walk(a: ET.Element | None, b: ET.Element | None, label: str, parent: ET.Element | None) -> None:
        if a is None or b is None:
            out[f"mjcf: {label}"] = {"shipped": "absent" if a is None else "present",
                                     "tested": "absent" if b is None else "present"}
            return
        for attribute in dict.fromkeys([*a.attrib, *b.attrib]):
            if a.get(attribute) != b.get(attribute) and not _covered(a, parent, attribute):
                out[f"mjcf: {label} {attribute}"] = {"shipped": a.get(attribute, "default"),
                                                     "tested": b.get(attribute, "default")}
        ca, cb = children(a, label), children(b, label)
        for key in dict.fromkeys([*ca, *cb]):
            walk(ca.get(key), cb.get(key), key, a)

    root_a, root_b = ET.fromstring(shipped), ET.fromstring(tested)
    walk(root_a, root_b, "mujoco", None)
    return out


def settle_time(case: Case, model: mujoco.MjModel, horizon: float) -> tuple[float, str]:
    """When the force and MuJoCo-only figures start counting: the case's ``settle``, or
    :data:`~harness.engine.variants.SETTLE_TIMECONSTS` response times of the model's slowest contact
    if longer (a softer contact settles later), at most half the horizon; with a note where capped."""
    wanted = max(case.settle, variants.SETTLE_TIMECONSTS * variants.contact_timeconst(model))
    if wanted <= horizon / 2:
        return wanted, ""
    return horizon / 2, (f"settle: the contacts' response time asks for {wanted:g} s before force figures count; "
                         f"capped at half the horizon ({horizon / 2:g} s): what remains of the transient is "
                         "not in any budget")


def _backend_integrators(engine: backends.Backend, mut: ModelUnderTest, chosen: tuple[str, ...], *,
                         given: bool) -> tuple[tuple[str, ...], dict[str, str]]:
    """The integrators ``engine`` runs of ``chosen``, and why it skips the others. One it cannot run raises
    BackendUnavailable (the feature, the fix) where the user named it, or where it can run none."""
    reasons = {name: engine.unsupported(mut.compile(integrator=name)) for name in chosen}
    runnable = tuple(name for name in chosen if not reasons[name])
    refused = {name: why for name, why in reasons.items() if why}
    if refused and (given or not runnable):
        raise BackendUnavailable(next(iter(refused.values())))
    return runnable, refused


def run_case(
    case: Case,
    *,
    mjcf: Path | str | None = None,
    integrators: Sequence[str] | None = None,
    timestep: float | None = None,
    horizon: float | None = None,
    q0: Mapping[str, float] | None = None,
    qd0: Mapping[str, float] | None = None,
    perturb: float | None = None,
    edit: Callable[[mujoco.MjSpec], None] | None = None,
    backend: str = "c",
) -> CaseResult:
    """All layers and budgets for ``case``.

    ``mjcf`` replaces the shipped model and ``edit`` modifies the model through MjSpec; the reference
    is built from the model so made. ``timestep`` and ``integrators`` change how it runs, ``horizon``,
    ``q0`` and ``qd0`` the motion (the coordinates they name; see :meth:`Case.with_motion`); ``perturb``
    then moves the whole initial state at round-off level (:func:`perturbed`).
    ``backend`` (:data:`harness.engine.backends.BACKENDS`) runs every simulation of the case, the
    budget's and the convergence ladder's included; :class:`BackendUnavailable` where it cannot.
    """
    with backends.use(backend):
        return _run_case(case, mjcf=mjcf, integrators=integrators, timestep=timestep, horizon=horizon, q0=q0,
                         qd0=qd0, perturb=perturb, edit=edit)


def _run_case(
    case: Case,
    *,
    mjcf: Path | str | None,
    integrators: Sequence[str] | None,
    timestep: float | None,
    horizon: float | None,
    q0: Mapping[str, float] | None,
    qd0: Mapping[str, float] | None,
    perturb: float | None,
    edit: Callable[[mujoco.MjSpec], None] | None,
) -> CaseResult:
    user_edit = edit
    if case.prepare is not None:  # a tree case: its model prepared (and isolated) before any edit of the user's
        edit = variants.compose(case.prepare, edit)
    if horizon is not None or q0 or qd0:
        case = case.with_motion(q0=q0, qd0=qd0, horizon=horizon)
    if perturb is not None:
        case = perturbed(case, perturb)
    chosen = tuple(integrators) if integrators is not None else available_integrators()
    for name in chosen:
        if name not in available_integrators():
            raise ValueError(f"unknown integrator {name!r}; this MuJoCo offers {', '.join(available_integrators())}")
    timings: dict[str, float] = {}
    recorder_notes = len(recording.notes())
    clock = time.perf_counter()
    path = Path(mjcf) if mjcf is not None else case.mjcf
    mut = ModelUnderTest(path=path, timestep=timestep, edit=edit, floors=case.tree is None)
    model = mut.compile()
    h = float(model.opt.timestep)
    bounds.check_steps(steps_in(case.horizon, h), horizon=case.horizon, timestep=h)  # before any work
    engine = backends.active()
    chosen, skipped = _backend_integrators(engine, mut, chosen, given=integrators is not None)
    shipped = compile_model(case.mjcf, edit=case.prepare)
    compiling = time.perf_counter() - clock  # counted with the reference, which reads the model
    clock = time.perf_counter()
    # numeric dynamics at the model's parameters: loaded from the on-disk cache, or derived (and cached)
    params = case.params_from_model(model)
    if case.tree is None:  # a tree case has no derivation: its dynamics are read from the model
        derivations.dynamics(case.system, params)
        derivations.minimal_dynamics(case.system, params)
    timings["derivation"] = time.perf_counter() - clock
    clock = time.perf_counter()
    ref = case.reference(model)
    timings["reference"] = compiling + (time.perf_counter() - clock)
    probe = case.probe(ref.dynamics)
    figures: list[Figure] = []
    budgets: dict[str, Budget] = {}

    clock = time.perf_counter()
    instant_integrator = None
    if integrator_name(model) == "discrete":  # qacc is the step map there; use continuous time
        instant_integrator = "Euler"
    instant_model = mut.compile(integrator=instant_integrator)
    instant = instant_evaluation(instant_model, probe, ref, perturbed=True)
    as_is = instant.deviations
    figures += [d.figure() for d in as_is]
    conditioning = 1.0  # a model judged against its own tree: the solved figures' round-off grows with n cond(M)
    if case.tree is not None:
        states = ref.solution.state(np.linspace(0.0, ref.solution.t_end, 24))[0]  # the sampled configurations
        conditioning = ref.dynamics.n * float(np.max(np.linalg.cond(ref.dynamics.mass_matrix(states))))
    budgets |= instant_budget(mut, instant_model, probe, ref, as_is, integrator=instant_integrator,
                              conditioning=conditioning,
                              perturbed=instant.perturbed, represented=instant.represented,
                              completed=instant.completed, completion_note=instant.completion_note)
    findings = tuple(engine_findings(instant_model, probe, ref))
    timings["instant"] = time.perf_counter() - clock
    peers = None
    if engine.name == "c":  # MuJoCo's C engine, the tree and Pinocchio (a second opinion on the C engine alone)
        clock = time.perf_counter()
        peers = three_way(instant_model)
        figures += peers.figures()
        timings["peers"] = time.perf_counter() - clock

    clock = time.perf_counter()
    sims: dict[str, Trajectory] = {}
    diverged: dict[str, str] = {}  # a diverged run is a verdict of its own, never a number (pipeline.verdict)
    steps = steps_in(case.horizon, model.opt.timestep)
    for name in chosen:
        try:
            sims[name] = simulate(mut.compile(integrator=name), probe, q0=ref.q0(), qd0=ref.qd0(), steps=steps)
        except (SimulationDiverged, UnmodelledElement) as exc:
            diverged[name] = exc.reason
    timings["mujoco"] = time.perf_counter() - clock

    clock = time.perf_counter()
    grid = next(iter(sims.values())).t if sims else np.arange(steps + 1) * model.opt.timestep
    ref_traj = refmod.trajectory(ref, grid)
    settle, settle_note = settle_time(case, model, case.horizon)
    figures += reference_figures(ref, grid)
    for name, sim in sims.items():
        figures += [d.figure() for d in deviations(ref_traj, sim, ref.scales, prefix=name, settle=settle,
                                                   series=case.mujoco_series)]
    timings["compare"] = time.perf_counter() - clock

    clock = time.perf_counter()  # layer 4, fast subset: observed vs documented order per integrator
    orders: dict[str, float] = {}
    unmeasured: dict[str, str] = {}
    if sims:  # an integrator whose run diverged has no ladder: its order's verdict is that run's
        study = convergence_study(case, fast=True, integrators=list(sims), mjcf=path, timestep=timestep,
                                  edit=edit, reference=ref)
        figures += order_figures(study)
        diverged |= {f"converge.{s.integrator}": s.diverged for s in study.verdicts if s.diverged}
        orders = {s.integrator: s.fit.order for s in study.verdicts}
        gated = VERDICT_QUANTITY[study.constrained]
        unmeasured = {str(FigureName.converge(s.integrator, "order_shortfall")): s.note for s in study.series
                      if s.quantity == gated and s.expected is None and s.note and not s.diverged}
    unmeasured |= instant.unavailable  # a figure the backend's arrays cannot give: n/a, with the reason
    diverged |= instant.failing  # a figure the model's own forces make unmeasurable: fails, with the reason
    timings["converge"] = time.perf_counter() - clock

    clock = time.perf_counter()
    target = TrajectoryRuns(reference=ref_traj, scales=ref.scales, settle=settle, series=case.mujoco_series,
                            q0=ref.q0(), qd0=ref.qd0(), rtol=ref.solution.rtol)
    runs, unbudgeted = trajectory_runs(mut, probe, target, sims, orders=EXPECTED_ORDER)
    diverged |= {f"budget.{name}": why for name, why in unbudgeted.items()}
    settings_here = Settings.of(model, ref.scales, floors=mut.floors)
    solver_tolerance = settings_here.solver_tolerance  # the runs' solver: the model's, or Newton converged
    if solver_tolerance and not variants.solver_converges(model):
        solver_tolerance = variants.CONVERGED_TOLERANCE
    notes = (*settings_here.notes, *((settle_note,) if settle_note else ()))
    budgets |= trajectory_budget(runs, orders=EXPECTED_ORDER, rtol=ref.solution.rtol,
                                 solver_tolerance=solver_tolerance, notes=notes, epsilon=engine.epsilon)
    joints = joint_types(model)
    defects = {name: d for name in runs if (d := applicable_defect(joints, name)) is not None}
    defect_budgets = trajectory_budget({n: runs[n] for n in defects}, orders={n: d.order for n, d in defects.items()},
                                       rtol=ref.solution.rtol, solver_tolerance=solver_tolerance,
                                       notes=notes, epsilon=engine.epsilon) if defects else {}
    timings["budget"] = time.perf_counter() - clock

    if case.tree is not None and case.tree.uncovered:  # the model as it is, by the work–energy balance
        clock = time.perf_counter()
        as_is = variants.compose(TreeEdit(isolating=False, ctrl=case.tree.ctrl), user_edit)
        found, balance_budgets, balance_diverged, balance_unjudged = balance_figures(
            path, as_is, probe.binding, integrators=tuple(sims), q0=ref.q0(), qd0=ref.qd0(), horizon=case.horizon,
            energy_scale=ref.scales.energy, orders=EXPECTED_ORDER, not_examined=tuple(dict(case.tree.uncovered)))
        figures += found
        budgets |= balance_budgets
        diverged |= balance_diverged
        unmeasured |= balance_unjudged  # n/a with why: impacts the timestep does not resolve
        timings["balance"] = time.perf_counter() - clock

    tested = model_settings(model) | {f"param.{k}": v for k, v in ref.params.items()}
    original = model_settings(shipped) | {f"param.{k}": v for k, v in case.params_from_model(shipped).items()}
    settings: dict[str, object] = model_settings(model) | {
        "mjcf": str(path), "horizon": case.horizon, "settle": settle, "params": dict(ref.params),
        "q0": dict(zip(ref.dynamics.coordinates, ref.initial[0], strict=True)),
        "qd0": dict(zip(ref.dynamics.coordinates, ref.initial[1], strict=True)),
        "integrators": list(sims), "recorder": recorder()}
    changed = changed_settings(original, tested)
    if changed or path != case.mjcf or edit is not None:  # and every other difference, as the files are written
        try:
            changed |= authored_differences(authored(case.mjcf), authored(path, timestep=timestep, edit=edit))
        except Exception as exc:  # MuJoCo cannot write one of them (to_xml): said, never silent, never fatal
            changed["mjcf"] = {"shipped": str(case.mjcf), "tested": f"{path} (not compared attribute by attribute: "
                                                                    f"{' '.join(str(exc).split())})"}
    if changed:
        settings["changed"] = changed
    if ref.projected:
        settings["projected"] = list(ref.projected)
    if case.tree is not None:  # what the model's own tree covers, and how its horizon was chosen
        settings["tree"] = {"not examined": dict(case.tree.uncovered), "horizon": case.tree.horizon_note,
                            "switched off for the comparison": bool(case.tree.uncovered),
                            "the model as it is": "judged by the work–energy balance (INTEGRATOR.balance)"
                            if case.tree.uncovered else "the comparison itself",
                            "reference solver": ref.solution.method + (f": {ref.solution.why}" if ref.solution.why
                                                                       else ""),
                            "seconds": {"horizon": case.tree.horizon_seconds, "reference": timings["reference"]}}
    if peers is not None:
        settings["peers"] = peers.as_dict()
    fallbacks_here = tuple(dict.fromkeys(recording.notes()[recorder_notes:]))
    if fallbacks_here:  # the batch recorder handed some runs to the loop: shown, never silent
        settings["recorder_fallbacks"] = list(fallbacks_here)
    missing = [n for n in ("discrete",) if unavailable_reason(f"{n}.position")]  # shown, never silently skipped
    compat_notes = [*fallbacks(str(path)), *(unavailable_reason(f"{n}.position") for n in missing)]
    if compat_notes:
        settings["compat"] = compat_notes
    if engine.name != "c":  # the C backend's settings stay as they always were (baselines, reports)
        settings["backend"] = {"name": engine.name, "precision": engine.precision,
                               "instant": INSTANT_NOTE, "skipped": skipped,
                               "adapted": list(engine.adaptations(model))}
    return CaseResult(case=case, figures=tuple(figures), reference=ref_traj, simulations=sims,
                      settings=settings, timings=timings, joints=joints, budgets=budgets,
                      defect_budgets=defect_budgets, orders={k: v for k, v in orders.items() if math.isfinite(v)},
                      findings=findings, unmeasured=unmeasured, diverged=diverged)

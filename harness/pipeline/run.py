"""Run one case: every family of figures measured on one bench, then the case's result assembled.

A pure function of its inputs: the CLI, the Python API, the tests and the CI gate all call :func:`run_case`
with a :class:`~harness.core.options.RunOptions` and differ only in what they do with the result.

The reference describes the model under test: its parameters are read from that model (shipped or the user's
``mjcf``), its initial state is brought onto the constraints at those parameters, and what differs from the
shipped model is listed in the settings (``changed``). Every figure gets its error budget from runs of the same
model with one setting changed, or a limit from theory (:mod:`harness.families`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from analytic.solvers import DEFAULT_RTOL, STIFF_RTOL
from harness.budget.reference import REFERENCE_SHARE, reference_rtol, reference_share
from harness.cases import Case
from harness.core import progress
from harness.core.budget import Budget
from harness.core.errors import ModelError, RunTooLong
from harness.core.figures import Figure, FigureName
from harness.core.findings import Finding
from harness.core.options import RunOptions
from harness.core.trajectory import Trajectory
from harness.engine import recording
from harness.engine.compat import fallbacks, joint_types, unavailable_reason
from harness.engine.models import authored
from harness.families import COMPARISONS, FAMILIES, invariants, trajectory
from harness.families.bench import Bench, Measured
from harness.families.stability import Stability
from harness.pipeline.settings import ModelSettings, RunSettings, authored_differences, changed_settings

__all__ = ["CaseResult", "run_case"]


@dataclass(frozen=True)
class CaseResult:
    """Everything one case produced: figures, their budgets, trajectories and the settings used
    (``reference`` None and ``simulations`` empty where a parallel run sent back figures only:
    ``check``, ``baseline``).

    Attributes:
        budgets: each instantaneous and trajectory figure's error budget, by figure name.
        defect_budgets: for an integrator a documented defect of this MuJoCo affects on this model, each
            of its figures' budget at the order the defect degrades it to (the defect's signature).
        orders: each integrator's observed convergence order (the convergence family's fit).
        findings: engine functions found to disagree while measuring.
        unmeasured: figures that could not be measured at these settings, each with the reason (a
            convergence order hidden under a softness floor): their checks are n/a, with the reason.
        joints: the joint types of the model run (known defects match them).
        stability: each explicit integrator's stability at the model's step (:mod:`harness.families.stability`):
            where it is beyond its limit, every figure of that integrator is n/a with the statement.
    """

    case: Case
    figures: tuple[Figure, ...]
    reference: Trajectory | None
    simulations: dict[str, Trajectory]
    settings: RunSettings
    timings: dict[str, float] = field(default_factory=dict)
    joints: frozenset[int] = frozenset()
    budgets: Mapping[str, Budget] = field(default_factory=dict)
    defect_budgets: Mapping[str, Budget] = field(default_factory=dict)
    orders: Mapping[str, float] = field(default_factory=dict)
    findings: tuple[Finding, ...] = ()
    unmeasured: Mapping[str, str] = field(default_factory=dict)
    diverged: dict[str, str] = field(default_factory=dict)  # INTEGRATOR, converge.INTEGRATOR, instant figure -> why
    stability: Mapping[str, Stability] = field(default_factory=dict)

    def without_case(self) -> CaseResult:
        """This result without its case, to send to another process (a case's system may hold closures, which do
        not pickle); the receiver puts the case back."""
        return dataclasses.replace(self, case=None)  # type: ignore[arg-type]  # (None only in transit)

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
"""What the report's settings say the sampled states read on a backend other than C
(:mod:`harness.families.sampled`)."""

_RUN_QUANTITIES = {"position": 0, "position_final": 1, "velocity": 2, "force": 4, "violation": 4,
                   "generalized_force": 5, "series": 6}
"""Where each run figure stands among an integrator's figures (an invariant's, 3, between the velocity and the
forces): the order the report lists them in."""


def _listed(measured: Sequence[tuple[str, Measured]], integrators: Sequence[str]) -> tuple[Figure, ...]:
    """Every family's figures in family order, but the two families measured over the runs (the trajectory and the
    invariants) together, integrator by integrator in the order the runs were made, each integrator's figures by
    quantity (:data:`_RUN_QUANTITIES`)."""
    runs = {trajectory.NAME, invariants.NAME}
    out: list[Figure] = []
    together: list[Figure] = []
    for name, found in measured:
        if name in runs:
            together += found.figures
            if name == invariants.NAME:
                rank = {integrator: k for k, integrator in enumerate(integrators)}
                out += sorted(together, key=lambda f: (rank[f.name.integrator],
                                                       _RUN_QUANTITIES.get(f.name.quantity, 3)))
        else:
            out += found.figures
    return tuple(out)


def run_case(case: Case, options: RunOptions | None = None) -> CaseResult:
    """Every family's figures of ``case`` run as ``options`` ask, with their budgets, findings and settings.

    ``options.mjcf`` replaces the shipped model and ``options.edit`` modifies the model through MjSpec; the
    reference is built from the model so made. ``options.backend`` runs every simulation of the case, the
    budget's and the convergence ladder's included; :class:`~harness.core.errors.BackendUnavailable` where it
    cannot.
    """
    # a model of one's own: a line every few seconds while it runs, never silent (a shipped case ends in seconds)
    with progress.heartbeat(f"case {case.name}", quiet=case.tree is None):
        return _run_case(case, options or RunOptions())


def _measure(case: Case, options: RunOptions, *, stiff_rtol: float = STIFF_RTOL
             ) -> tuple[Bench, list[tuple[str, Measured]]]:
    bench = Bench(case, options, COMPARISONS, stiff_rtol=stiff_rtol)
    return bench, [(family.NAME, family.measure(bench)) for family in FAMILIES]


def _tightened(case: Case, options: RunOptions) -> tuple[Bench, list[tuple[str, Measured]], str]:
    """The case measured with its reference as tight as its budgets need: a stiff tree's Radau IIA solve is made
    to STIFF_RTOL first and, where its part passes REFERENCE_SHARE of a figure's limit, once more at the rtol that
    the budgets derive (:func:`harness.budget.reference.reference_rtol`); the statement of the reference's tolerance
    and its share ("" where the reference is not a stiff tree's).

    The second time, every family is measured again, on purpose: each compares MuJoCo with the reference or reads
    what is derived from its solution (the states sampled on it, its scales, whose length counts how far the solved
    motion goes, the clamp switches located on it, the reference's own part of every budget), so a figure
    measured against the looser solve is not the figure at the tighter one. What does not depend on the reference
    is not made again: the models (each variant whose edit has a stable identity comes from the compile cache,
    :func:`harness.engine.models.compile_model`) and the derived dynamics (their cache)."""
    bench, measured = _measure(case, options)
    rtol = bench.reference.solution.rtol
    if case.tree is None or bench.reference.solution.method != "Radau IIA":
        return bench, measured, ""
    first = _share(measured)
    tighter = reference_rtol(_budgets_of(measured), rtol=rtol, floor=DEFAULT_RTOL)
    if tighter is None:
        return bench, measured, f"rtol {rtol:g}: its part is {first}, within REFERENCE_SHARE {REFERENCE_SHARE:.0%}"
    progress.stage(f"solving the reference again to rtol {tighter:g}: at rtol {rtol:g} its part is {first}, more "
                   f"than REFERENCE_SHARE {REFERENCE_SHARE:.0%}")
    try:
        again, remeasured = _measure(case, options, stiff_rtol=tighter)
    except (RunTooLong, ModelError) as exc:  # the tighter solve past the bounds: the first one stands, said so
        return bench, measured, (f"rtol {rtol:g}: its part is {first}, more than REFERENCE_SHARE "
                                 f"{REFERENCE_SHARE:.0%}; solving it to rtol {tighter:g} was refused ({exc})")
    return again, remeasured, (f"rtol {again.reference.solution.rtol:g}, derived: at rtol {rtol:g} its part was "
                               f"{first}, more than REFERENCE_SHARE {REFERENCE_SHARE:.0%}; now {_share(remeasured)}")


def _share(measured: Sequence[tuple[str, Measured]]) -> str:
    share, figure = reference_share(_budgets_of(measured))
    return f"at most {share:.1%} of a figure's limit ({figure})" if figure else "in no figure's limit"


def _budgets_of(measured: Sequence[tuple[str, Measured]]) -> dict[str, Budget]:
    return {k: v for _, found in measured for k, v in found.budgets.items()}


def _run_case(case: Case, options: RunOptions) -> CaseResult:
    recorder_notes = len(recording.notes())
    bench, measured, tolerance = _tightened(case, options)
    case, model, ref = bench.case, bench.model, bench.reference
    sims = bench.sims

    diverged = dict(bench.diverged)  # the runs over the horizon: each a verdict of its own, never a number
    unmeasured: dict[str, str] = {}
    budgets: dict[str, Budget] = {}
    defect_budgets: dict[str, Budget] = {}
    orders: dict[str, float] = {}
    findings: list[Finding] = []
    families: dict[str, object] = {}
    for _, found in measured:
        budgets |= found.budgets
        defect_budgets |= found.defect_budgets
        unmeasured |= found.unmeasured
        diverged |= found.diverged
        orders |= found.orders
        findings += found.findings
        families |= found.settings
    if sims:
        diverged |= {f"budget.{name}": why for name, why in bench.run_budgets.failed.items()}
    if bench.stability:  # the explicit integrators against their stability regions, the model's own first
        families["stability"] = {name: s.as_dict() for name, s in bench.stability.items()}

    own = ModelSettings.of(model)
    tested = own.as_dict() | {f"param.{k}": v for k, v in ref.params.items()}
    original = ModelSettings.of(bench.shipped).as_dict() | {
        f"param.{k}": v for k, v in case.params_from_model(bench.shipped).items()}
    changed = changed_settings(original, tested)
    edit = bench.mut.edit
    if changed or bench.path != case.mjcf or edit is not None:  # and every other difference, as the files are written
        try:
            changed |= authored_differences(authored(case.mjcf),
                                            authored(bench.path, timestep=options.timestep, edit=edit))
        except Exception as exc:  # MuJoCo cannot write one of them (to_xml): said, never silent, never fatal
            changed["mjcf"] = {"shipped": str(case.mjcf),
                               "tested": f"{bench.path} (not compared attribute by attribute: "
                                         f"{' '.join(str(exc).split())})"}
    tree = None
    if case.tree is not None:  # what the model's own tree covers, and how its horizon was chosen
        tree = {"not examined": dict(case.tree.uncovered), "horizon": case.tree.horizon_note,
                "switched off for the comparison": bool(case.tree.uncovered),
                "the model as it is": "judged by the work–energy balance (INTEGRATOR.balance)"
                if case.tree.uncovered else "the comparison itself",
                "reference solver": ref.solution.method + (f": {ref.solution.why}" if ref.solution.why else ""),
                **({"reference tolerance": tolerance} if tolerance else {}),
                "seconds": {"horizon": case.tree.horizon_seconds, "reference": bench.timings["reference"]}}
    missing = [n for n in ("discrete",) if unavailable_reason(f"{n}.position")]  # shown, never silently skipped
    engine = bench.engine
    settings = RunSettings(
        model=own, mjcf=str(bench.path), horizon=case.horizon, settle=bench.settle[0],
        params=dict(ref.params), q0=dict(zip(ref.dynamics.coordinates, ref.initial[0], strict=True)),
        qd0=dict(zip(ref.dynamics.coordinates, ref.initial[1], strict=True)), integrators=tuple(sims),
        recorder=recording.recorder(), changed=changed, projected=tuple(ref.projected), tree=tree, families=families,
        # the batch recorder handed some runs to the loop: shown, never silent
        recorder_fallbacks=tuple(dict.fromkeys(recording.notes()[recorder_notes:])),
        compat=(*fallbacks(str(bench.path)), *(unavailable_reason(f"{n}.position") for n in missing)),
        # the C backend's settings stay as they always were (baselines, reports)
        backend=None if engine.name == "c" else {
            "name": engine.name, "precision": engine.precision, "instant": INSTANT_NOTE,
            "skipped": bench.skipped, "adapted": list(engine.adaptations(model))})
    return CaseResult(case=case, figures=_listed(measured, list(sims)), reference=bench.reference_run,
                      simulations=sims, settings=settings, timings=bench.timings, joints=joint_types(model),
                      budgets=budgets, defect_budgets=defect_budgets,
                      orders={k: v for k, v in orders.items() if math.isfinite(v)}, findings=tuple(findings),
                      unmeasured=unmeasured, diverged=diverged, stability=bench.stability)

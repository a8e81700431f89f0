"""The balance family: a model's motion judged as it is, with every force acting, whatever the forces are, by the
work–energy balance.

Where a model the user brings has forces its tree reference does not model (contacts, joint limits, dry
friction, fluid forces, spatial tendons, …: :func:`harness.reference.tree.uncovered`), the comparison with the
reference runs with them switched off; the model as it is is judged here, by a truth that holds regardless of
what the forces are: its energy changes by the work of the forces that are not conservative,

    B(t) = E(t) − E(0) − ∫₀ᵗ P dt ,   P = qvel · (qfrc_passive − qfrc_spring + qfrc_actuator + qfrc_constraint
                                                 + qfrc_applied)

with E MuJoCo's own energy (gravity's and the springs' potential, whose forces are left out of P, plus the
kinetic energy) and P the power of everything else MuJoCo applied: damping, gravity compensation, fluid forces,
actuators, and every constraint row (contacts, limits, dry friction, equalities), all read at each recorded
state. A run's B is its integrator's truncation error, so it is judged as a trajectory figure is: from the runs
at h, h/2 and h/4, Richardson removes the leading term (``integration``) and the residual must lie within the
estimate's own next-order error (measured from h/4) and round-off. Energy that no force accounts for — a force
missing from MuJoCo's accounts, a kick — does not shrink with h and is left unexplained.

A balance that fails says where and by what: the time its unexplained residual peaks, and the force group whose
work that residual follows (:func:`attribute`: the passive forces, the actuators, the constraint rows or the applied
forces, each's work recorded beside it), or that it follows none — energy from nothing MuJoCo reports.

∫ P dt is a fourth-order cumulative quadrature of the samples (the four-point Lagrange rule on each step,
one-sided at the ends): a trapezoid would cap the balance of RK4 at second order.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

import mujoco
import numpy as np

from harness.cases import Case
from harness.core.budget import Budget
from harness.core.checks import Limit
from harness.core.errors import SimulationDiverged, UnmodelledElement
from harness.core.figures import Figure, FigureName
from harness.engine.backends import Backend, Request
from harness.engine.integrators import EXPECTED_ORDER
from harness.engine.models import compile_model
from harness.engine.probe import Probe
from harness.engine.readings import Reading
from harness.engine.recording import steps_in
from harness.engine.variants import compose
from harness.families.bench import Bench, Measured
from harness.reference.tree import TreeEdit

__all__ = ["NAME", "POWER", "POWER_FIELDS", "attribute", "balance_figures", "cumulative_work", "gated", "measure",
           "names", "owns", "theory_limit"]

POWER_FIELDS = ("qfrc_passive", "qfrc_spring", "qfrc_actuator", "qfrc_constraint", "qfrc_applied")


def _power(model: mujoco.MjModel, recorded: Mapping[str, np.ndarray]) -> np.ndarray:
    force = (recorded["qfrc_passive"] - recorded["qfrc_spring"] + recorded["qfrc_actuator"]
             + recorded["qfrc_constraint"] + recorded["qfrc_applied"])
    return np.einsum("ni,ni->n", recorded["qvel"], force)


POWER = Reading(fields=POWER_FIELDS, evaluate=_power,
                description="the power of every force not in MuJoCo's energy (W)")


def _group(*fields: str, minus: str = "") -> Reading:
    def evaluate(model: mujoco.MjModel, recorded: Mapping[str, np.ndarray]) -> np.ndarray:
        force = sum(recorded[f] for f in fields) - (recorded[minus] if minus else 0.0)
        return np.einsum("ni,ni->n", recorded["qvel"], force)
    return Reading(fields=(*fields, *((minus,) if minus else ())), evaluate=evaluate,
                   description=f"the power of {'+'.join(fields)}{' − ' + minus if minus else ''} (W)")


FORCES: Mapping[str, Reading] = {
    "the passive forces (damping, gravity compensation, fluid)": _group("qfrc_passive", minus="qfrc_spring"),
    "the actuators": _group("qfrc_actuator"),
    "the constraint rows (contacts, limits, dry friction, equalities)": _group("qfrc_constraint"),
    "the applied forces": _group("qfrc_applied"),
}
"""The groups of :data:`POWER`'s forces, each's work recorded beside the balance so that energy no force accounts
for can be set against each (:func:`attribute`)."""
ATTRIBUTED = 0.2
"""A group is named when a multiple of its work leaves at most this fraction of the unexplained residual (in the
2-norm over the run): the residual then follows that force's work in time."""
ROUNDOFF_PER_STEP = 64 * np.finfo(float).eps
"""The round-off a step leaves in E and in the work, relative to the energy scale (the float64 allowance of the
trajectory budget, harness/budget/roundoff.py), accumulating as a random walk."""
RESOLVED = 0.5
"""As the trajectory budget's (harness/families/runs.py): a next-order term above half the leading one, on a
balance above :data:`ASYMPTOTIC` of the energy scale, means h, h/2, h/4 are no converging sequence (as on gymnasium's
ant: docs/findings/bases.md, the balance's RESOLVED)."""
ASYMPTOTIC = 0.01
UNRESOLVED_SPREAD = 4.0
"""Where h, h/2, h/4 are no expansion in h, the balance can still be judged from below: an integrator of order ≥ 1
whose error shrinks with h at all leaves at h/4 at most its change from h/2 to h/4 (order 1: exactly that); the
floor is the smallest |B| of the three runs less this factor × the largest change between them, sample by sample,
the factor the margin on that assumption. What stays above it, and above :data:`ASYMPTOTIC` of the energy
scale, is energy that no timestep explains: a failure, never n/a."""
INTEGRATION_UNCERTAINTY = 0.25
"""What Richardson leaves of the correction, relatively, when no run at h/4 measures it (as the trajectory budget)."""


def cumulative_work(power: np.ndarray, h: float) -> np.ndarray:
    """∫₀^{t_k} P dt at every sample k of uniformly sampled ``power``, fourth-order accurate for a smooth P."""
    p = np.asarray(power, dtype=float)
    n = len(p) - 1
    if n < 3:
        steps = 0.5 * h * (p[1:] + p[:-1])
    else:
        steps = np.empty(n)
        steps[1:n - 1] = h / 24 * (-p[:n - 2] + 13 * p[1:n - 1] + 13 * p[2:n] - p[3:n + 1])
        steps[0] = h / 24 * (9 * p[0] + 19 * p[1] - 5 * p[2] + p[3])
        steps[n - 1] = h / 24 * (9 * p[n] + 19 * p[n - 1] - 5 * p[n - 2] + p[n - 3])
    return np.concatenate([[0.0], np.cumsum(steps)])


def balance(energy: np.ndarray, power: np.ndarray, h: float) -> np.ndarray:
    """B(t_k) = E(t_k) − E(0) − ∫ P dt at every sample."""
    energy = np.asarray(energy, dtype=float)
    return energy - energy[0] - cumulative_work(power, h)


def attribute(residual: np.ndarray, works: Mapping[str, np.ndarray]) -> str:
    """Which force's work the unexplained ``residual`` (B with its integration part removed, over the run) follows:
    the group of ``works`` (each ∫ P_k dt at the same samples) whose best multiple c·W_k leaves the least of it, named
    when that is at most :data:`ATTRIBUTED` of it. Energy from nothing (a kick, an integrator's defect) follows no
    force's work, and is said so."""
    r = np.asarray(residual, dtype=float)
    size = float(np.linalg.norm(r))
    if not size > 0:
        return ""
    best, left, factor = "", 1.0, 0.0
    for name, work in works.items():
        w = np.asarray(work, dtype=float)
        ww = float(w @ w)
        if not ww > 0:
            continue
        c = float(r @ w) / ww
        rest = float(np.linalg.norm(r - c * w)) / size
        if rest < left:
            best, left, factor = name, rest, c
    if best and left <= ATTRIBUTED:
        return (f"the unexplained energy follows the work of {best} ({factor:+.3g} × it leaves {left:.0%} of the "
                "residual): that force's work is missing from MuJoCo's accounts or misstated")
    return "the unexplained energy follows no force's work: it comes from no force MuJoCo reports (a kick, a defect)"


def _works(run, h: float, energy_scale: float) -> dict[str, np.ndarray]:
    """Each force group's work over ``run`` (recorded beside the balance), on the energy scale: what
    :func:`attribute` sets an unexplained residual against."""
    return {k: cumulative_work(run.series[f"force {i}"], h) / energy_scale for i, k in enumerate(FORCES)}


def observed_order(levels: Sequence[np.ndarray], documented: float) -> float:
    """The order at which a balance converges over h, h/2, h/4 (``levels``), from its two differences, clamped to
    [1, ``documented``]: a contact's or a limit's onset is not smooth in time, and the balance across it converges
    at its own order, not at the integrator's (on gymnasium's inverted double pendulum RK4's balance halves with h,
    and κ for order 4 left half of it as if unexplained). A part of B that does not change with h — energy no force
    accounts for — cancels in both differences, so the order never absorbs it: it stays in the extrapolation."""
    first = float(np.max(np.abs(levels[0] - levels[1])))
    second = float(np.max(np.abs(levels[1] - levels[2])))
    if not (first > 0 and second > 0):
        return float(documented)
    return float(min(max(np.log2(first / second), 1.0), documented))


def balance_figures(path, edit: Callable[[mujoco.MjSpec], None] | None, binding, *, integrators: Sequence[str],
                    q0: np.ndarray, qd0: np.ndarray, horizon: float, energy_scale: float, orders: Mapping[str, int],
                    not_examined: Sequence[str], engine: Backend, power: Reading = POWER,
                    timestep: float | None = None
                    ) -> tuple[list[Figure], dict[str, Budget], dict[str, str], dict[str, str]]:
    """Each integrator's ``INTEGRATOR.balance`` figure (max |B| over the horizon / ``energy_scale``), its budget, and
    the runs that diverged (by figure name, with why), for the model at ``path`` compiled with ``edit`` (as it is:
    nothing switched off), started from (q0, q̇0) through ``binding``, every run on ``engine``, at ``timestep``
    (h; default: the model's own). ``power``: what counts as the work done
    (:data:`POWER`; the tests leave a force out of it to show the balance sees it)."""
    probe = Probe(binding=binding, points=(), constraints=(),
                  series={"power": power, **{f"force {k}": reading for k, reading in enumerate(FORCES.values())}})
    figures: list[Figure] = []
    budgets: dict[str, Budget] = {}
    diverged: dict[str, str] = {}
    unresolved: dict[str, str] = {}
    forces = ", ".join(not_examined)
    for name in integrators:
        fig = FigureName.trajectory(name, "balance")
        base = compile_model(path, integrator=name, timestep=timestep, edit=edit)
        h = float(base.opt.timestep)
        steps = steps_in(horizon, h)
        requests = [Request(compile_model(path, integrator=name, timestep=h / k, edit=edit), q0, qd0, steps * k)
                    for k in (1, 2, 4)]
        try:
            runs = engine.simulate_many(requests, probe)
        except (SimulationDiverged, UnmodelledElement) as exc:
            diverged[str(fig)] = exc.reason
            continue
        levels = [balance(r.invariants["energy"], r.series["power"], h / k)[::k] / energy_scale
                  for r, k in zip(runs, (1, 2, 4), strict=True)]
        order = observed_order(levels, orders[name])
        kappa = 2.0 ** order / (2.0 ** order - 1.0)
        correction = kappa * (levels[0] - levels[1])
        ideal = levels[0] - correction
        next_order = 2.0 * np.abs(ideal - (levels[1] - kappa * (levels[1] - levels[2])))
        measured = float(np.max(np.abs(levels[0])))
        leading, rest = float(np.max(np.abs(correction))), float(np.max(next_order))
        integration = max(INTEGRATION_UNCERTAINTY * leading, rest)
        roundoff = ROUNDOFF_PER_STEP * math.sqrt(4 * steps)
        if rest > RESOLVED * leading and leading > ASYMPTOTIC:
            spread = np.maximum(np.abs(levels[0] - levels[1]), np.abs(levels[1] - levels[2]))
            floor = np.min(np.abs(levels), axis=0) - UNRESOLVED_SPREAD * spread
            at = int(np.argmax(floor))
            if floor[at] > ASYMPTOTIC:  # energy from nothing that no convergence in h can remove: a failure
                budgets[str(fig)] = Budget(
                    measured=measured, explained={"integration": float(UNRESOLVED_SPREAD * np.max(spread))},
                    unexplained=float(floor[at]), tolerance={"integration": ASYMPTOTIC, "roundoff": roundoff},
                    notes=(f"work–energy balance of the model as it is ({forces} acting), no expansion in h (impacts "
                           f"the timestep does not resolve), yet at h, h/2 and h/4 alike it stays at least "
                           f"{np.min(np.abs(levels), axis=0)[at]:.3g} of the energy scale, {UNRESOLVED_SPREAD:g} × its "
                           f"largest change between them ({spread[at]:.2g}) removed",))
                text = (f"max |E(t) − E(0) − ∫ P dt| / energy scale ({energy_scale:.4g} J) of the model as it is; at "
                        f"every h it stays {floor[at]:.3g} above what any convergence in h explains, at t = "
                        f"{at * h:.3g} s; {attribute(levels[0], _works(runs[0], h, energy_scale))}")
                figures.append(Figure(name=fig, value=measured, unit="1", description=text))
                continue
            unresolved[str(fig)] = (f"not judged: the balance at h, h/2, h/4 is no expansion in h (its next-order term "
                                    f"{rest:.2g} against a leading term {leading:.2g} of the energy scale: impacts the "
                                    f"timestep does not resolve); a smaller --timestep judges the model as it is")
        budgets[str(fig)] = Budget(
            measured=measured, explained={"integration": float(np.max(np.abs(correction)))},
            unexplained=float(np.max(np.abs(ideal))), tolerance={"integration": integration, "roundoff": roundoff},
            notes=(f"work–energy balance of the model as it is ({forces} acting): E(t) − E(0) − ∫ P dt, P the power "
                   "of every force not in MuJoCo's energy; integration from the runs at h, h/2, h/4, at the order they "
                   f"show ({order:.2g})",))
        worst = int(np.argmax(np.abs(ideal)))
        if str(fig) in unresolved:  # no figure: its check is n/a with the reason, not a number without a limit
            continue
        blame = ""
        if not budgets[str(fig)].passed:  # name the force whose work the unexplained energy follows, if one does
            blame = "; " + attribute(ideal, _works(runs[0], h, energy_scale))
        figures.append(Figure(name=fig, value=measured, unit="1",
                              description=f"max |E(t) − E(0) − ∫ P dt| / energy scale ({energy_scale:.4g} J) of the "
                                          f"model as it is; the unexplained residual peaks at t = "
                                          f"{worst * h:.3g} s{blame}"))
    return figures, {k: v for k, v in budgets.items() if k not in unresolved}, diverged, unresolved


# ----------------------------------------------------------------- the family
NAME = "balance"


def owns(name: FigureName) -> bool:
    return name.layer == "trajectory" and name.quantity == "balance"


def names(case: Case, model: mujoco.MjModel) -> set[FigureName]:
    if case.tree is None or not case.tree.uncovered:
        return set()
    return {FigureName.trajectory(integrator, "balance") for integrator in EXPECTED_ORDER}


def gated(name: FigureName, *, constrained: bool) -> bool:
    return True


def theory_limit(name: FigureName) -> Limit | None:
    return None


def measure(bench: Bench) -> Measured:
    """The balance of each integrator's run, where the model has forces its tree reference does not model (they
    were switched off for the comparison): the model as it is, every force acting."""
    case, tree = bench.case, bench.case.tree
    if tree is None or not tree.uncovered:
        return Measured()
    as_is = compose(TreeEdit(isolating=False, ctrl=tree.ctrl), bench.options.edit)
    ref = bench.reference
    found, budgets, diverged, unjudged = bench.timed(NAME, lambda: balance_figures(
        bench.path, as_is, bench.probe.binding, integrators=tuple(bench.sims), q0=ref.q0(), qd0=ref.qd0(),
        horizon=case.horizon, energy_scale=ref.scales.energy, orders=bench.orders,
        not_examined=tuple(dict(tree.uncovered)), engine=bench.engine, timestep=bench.options.timestep))
    return Measured(figures=tuple(found), budgets=budgets, diverged=diverged,
                    unmeasured=unjudged)  # n/a with why: impacts the timestep does not resolve

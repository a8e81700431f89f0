"""The convergence family: the observed convergence order of every MuJoCo integrator vs. its documented order.

Figures ``converge.INTEGRATOR.order_shortfall`` = max(0, documented − observed order), every one gated with a
limit from theory (:data:`ORDER_TOLERANCE`, the fit's floor bias below). This module computes (ladders of runs,
fitted orders, the figures); the same study at more timesteps is a report page (:mod:`harness.studies`).

For each integrator the case is run at a ladder of timesteps h (each a power
of two times the shipped timestep) over one horizon T shared by the ladder;
the error is the largest distance between MuJoCo's and the reference's points
over [0, T] (the reference is solved once and evaluated on each run's grid).
The observed order is the least-squares slope of log(error) against log(h)
over the asymptotic range: points whose error is a small fraction of the
case's length (not saturated) and well above any error floor.

Expected orders are the documented ones (:data:`harness.engine.integrators.EXPECTED_ORDER`, with the
documentation's passages).

Error floors. An error that stops decreasing with h is a floor, not an order:
the two smallest-h points decide (a local slope below ``PLATEAU_SLOPE``);
the floor is then the smallest error, and only points above
``FLOOR_FACTOR`` × floor are fitted, so the floor biases the slope by at most
log2((9·2ᵖ + 1)/10)/p − 1 (0.14 for p = 4, 0.07 for p = 1). Known floors:
the point-mass inertia (diaginertia ~1e-10 of m l²), the reference tolerance
(rtol 1e-12) and, for equality constraints, softness.

Softness. A soft equality (solimp d < 1) sags by r = a_u (1 − d) timeconst²
dampratio² (modeling.rst, "Solver parameters"), and with the refsafe flag
MuJoCo enforces timeconst ≥ 2h, so the sag and the error it causes scale as
h² once 2h exceeds the authored timeconst, and stay constant below. With d at
its maximum 0.9999 (mjMAXIMP) no stiffer setting exists, and that O(h²) term
hides RK4's 4th order on the pendulum at every stable h. The rigid limit
removes it: the deviation caused by softness is linear in ε = 1 − d
(the forcing (1 − d) a_u of the constraint dynamics), so each constrained run
is repeated at 2ε and extrapolated, x₀ = 2 x(ε) − x(2ε) (Richardson in ε). The
verdict of a constrained case judges ``position@rigid``; ``position`` (as
authored), ``softness`` (|x(ε) − x(2ε)|, the softness part) and ``force``
are shown beside it, not gated.

Solver. Where the model's own constraint solver stops short of the solution
(CG or PGS at their iteration cap, a loose tolerance: what
:func:`harness.engine.variants.exact_solver` detects), its error does not
fall with h and would show as a floor, or a lower order, of the integrator.
The ladder then solves the constraints exactly, as the budget's runs do, so
the order measured is the integrator's; what the solver leaves is the
budget's ``solver`` part.
"""

from __future__ import annotations

import itertools
import math
import os
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from harness.budget.extrapolation import RIGID_TAIL
from harness.budget.roundoff import ROUNDOFF_EPS
from harness.cases import Case
from harness.core.checks import Limit
from harness.core.errors import SimulationDiverged
from harness.core.figures import Figure, FigureName
from harness.core.trajectory import Trajectory
from harness.engine import backends
from harness.engine.backends import Backend, Request, simulate
from harness.engine.compat import joint_types, known_defect
from harness.engine.integrators import EXPECTED_ORDER, available_integrators
from harness.engine.models import compile_model
from harness.engine.recording import steps_in
from harness.engine.variants import compose, exact_solver, floors_pair, point_masses, rigid_factor
from harness.families.bench import Bench, Measured
from harness.families.runs import every_nth
from harness.reference import solutions as refmod
from harness.reference.tree import SWITCHED_ORDER, switched_orders, switches

__all__ = ["EXPECTED_ORDER", "NAME", "ORDER_TOLERANCE", "VERDICT_QUANTITY", "ConvergenceStudy", "Series",
           "convergence_study", "explained_floor", "fit_order", "gated", "initial_force_floor", "measure", "names",
           "owns", "reference_grids", "roundoff_floor", "scaled_softness", "theory_limit"]

ORDER_TOLERANCE = 0.3   # pass when observed ≥ expected − 0.3 (floor bias ≤ 0.14, see above)
FLOOR_FACTOR = 10.0     # fit only errors above 10 × the detected floor
PLATEAU_SLOPE = 0.5     # a local slope below this at the smallest h marks a floor
SATURATION = 0.05       # errors above 5 % of the case's length are not asymptotic

# Timestep ladders, as multiples of the case's timestep (largest first). The
# full study goes far into the asymptotic range; the fast subset (run by
# `mjharness check`) is three points where every registered case is asymptotic.
FULL_LADDER: Mapping[int, tuple[float, ...]] = {1: (8, 4, 2, 1, 0.5, 0.25), 4: (32, 16, 8, 4, 2, 1)}
FAST_LADDER: Mapping[int, tuple[float, ...]] = {1: (4, 2, 1), 4: (32, 16, 8)}
FAST_HORIZON = 0.5      # s; the fast subset's horizon (or the case's, if shorter)

VERDICT_QUANTITY = {False: "position", True: "position@rigid"}


# ----------------------------------------------------------------- fitting
@dataclass(frozen=True)
class OrderFit:
    """Slope of log(error) vs log(h) over the asymptotic range.

    Attributes:
        order: fitted slope; nan when fewer than two points are usable.
        floor: detected error floor (the smallest error), or None when the
            errors still fall at the smallest h.
        status: per point, ``used``, ``floor`` (≤ FLOOR_FACTOR × floor),
            ``saturated`` (above the saturation level), ``diverged`` or ``zero``.
        local: slopes between neighbouring finite points, largest h first.
    """

    order: float
    floor: float | None
    status: tuple[str, ...]
    local: tuple[float, ...]

    @property
    def n_used(self) -> int:
        return self.status.count("used")


def fit_order(dts: Sequence[float], errors: Sequence[float], *, saturation: float = math.inf,
              floor_factor: float = FLOOR_FACTOR, plateau_slope: float = PLATEAU_SLOPE,
              known_floors: Sequence[float] | None = None) -> OrderFit:
    """Fit the observed order, detecting a floor first so it is never fitted as an order.

    ``known_floors``, one per point, are floors known apart from the errors (the rigid-limit
    extrapolation's own uncertainty at that step): a point within ``floor_factor`` of its own is a floor
    point too, and the largest such floor is the fit's floor where no plateau was detected."""
    h = np.asarray(dts, dtype=float)
    e = np.asarray(errors, dtype=float)
    if h.shape != e.shape or h.ndim != 1 or h.size < 2:
        raise ValueError(f"dts and errors must be 1-D of one length ≥ 2, got {h.shape} and {e.shape}")
    if not np.all(h > 0) or len(set(h.tolist())) != h.size:
        raise ValueError(f"dts must be positive and distinct, got {h.tolist()}")
    known = np.zeros_like(h) if known_floors is None else np.nan_to_num(np.asarray(known_floors, float), nan=0.0)
    if known.shape != h.shape:
        raise ValueError(f"known_floors must have one value per point, got {known.shape} for {h.shape}")
    finite = np.isfinite(e) & (e > 0)
    by_h = [i for i in np.argsort(h) if finite[i]]  # smallest h first
    floor = None
    if len(by_h) >= 2:
        i0, i1 = by_h[0], by_h[1]
        if math.log(e[i1] / e[i0]) / math.log(h[i1] / h[i0]) < plateau_slope:
            floor = float(np.min(e[finite]))
    status = []
    for i in range(h.size):
        if not np.isfinite(e[i]):
            status.append("diverged")
        elif e[i] <= 0:
            status.append("zero")
        elif e[i] > saturation:
            status.append("saturated")
        elif (floor is not None and e[i] <= floor_factor * floor) or e[i] <= floor_factor * known[i]:
            status.append("floor")
        else:
            status.append("used")
    on_known = [known[i] for i in range(h.size) if status[i] == "floor" and e[i] <= floor_factor * known[i]]
    if floor is None and on_known:
        floor = float(max(on_known))
    used = np.array([s == "used" for s in status])
    order = float(np.polyfit(np.log(h[used]), np.log(e[used]), 1)[0]) if used.sum() >= 2 else math.nan
    desc = by_h[::-1]
    local = tuple(math.log(e[a] / e[b]) / math.log(h[a] / h[b]) for a, b in itertools.pairwise(desc))
    return OrderFit(order=order, floor=floor, status=tuple(status), local=local)


# ----------------------------------------------------------------- results
@dataclass(frozen=True)
class Series:
    """One error-vs-h series of one integrator, with its fit and (if gated) its verdict.

    ``expected`` is None for series shown for information only.
    """

    integrator: str
    quantity: str
    unit: str
    dts: tuple[float, ...]
    errors: tuple[float, ...]
    fit: OrderFit
    expected: float | None = None
    tolerance: float = ORDER_TOLERANCE
    note: str = ""
    predicted_floor: float | None = None
    diverged: str = ""  # the first run of the ladder that diverged ("diverged: WARNING at t = … (h = …)")
    cause: str = ""  # what was measured about a failed verdict's ladder (:func:`pre_asymptotic`), said with it

    @property
    def shortfall(self) -> float | None:
        """max(0, expected − observed); the whole expected order when none was observed."""
        if self.expected is None:
            return None
        if not math.isfinite(self.fit.order):
            return float(self.expected)
        return max(0.0, self.expected - self.fit.order)

    @property
    def passed(self) -> bool | None:
        """False where the ladder diverged anywhere; None for a series shown for information."""
        if self.diverged:
            return False
        return None if self.shortfall is None else self.shortfall <= self.tolerance

    @property
    def verdict(self) -> str:
        if self.diverged:
            return self.diverged
        if self.passed is None:
            return f"n/a: {self.note}" if self.note else "info"
        if self.passed:
            return "pass"
        if self.fit.n_used < 2:
            return "FAIL (no asymptotic range above the floor)" if self.fit.floor else "FAIL (< 2 usable points)"
        return "FAIL"


@dataclass(frozen=True)
class ConvergenceStudy:
    """Every series of one case, and the integrators this MuJoCo lacks (its plot: harness/outputs/studies)."""

    case: str
    horizon: float
    fast: bool
    constrained: bool
    series: tuple[Series, ...]
    unavailable: Mapping[str, str] = field(default_factory=dict)
    mujoco_version: str = mujoco.__version__
    joints: frozenset[int] = frozenset()  # the model's joint types, which known defects match

    @property
    def verdicts(self) -> tuple[Series, ...]:
        """The gated series: those with a documented order, and an exact one whose ladder diverged."""
        gated = VERDICT_QUANTITY[self.constrained]
        return tuple(s for s in self.series if s.expected is not None or (s.diverged and s.quantity == gated))

    def known_defect(self, s: Series) -> str:
        """The documented defect of this MuJoCo that explains a failed verdict ('' if none)."""
        if s.passed is not False or s.diverged:  # a diverged run is no defect's signature
            return ""
        return known_defect(self.joints, FigureName.converge(s.integrator, "order_shortfall"))

    @property
    def passed(self) -> bool:
        """Every verdict passes, or fails for a documented defect of this MuJoCo version."""
        return all(s.passed or self.known_defect(s) for s in self.verdicts)


# ----------------------------------------------------------------- running
def unavailable_integrators() -> dict[str, str]:
    """Documented integrators this MuJoCo lacks, each with the reason (shown, never skipped)."""
    return {name: f"not in MuJoCo {mujoco.__version__} (no mjINT_{name.upper()})"
            for name in EXPECTED_ORDER if name not in available_integrators()}


def double_softness(spec: mujoco.MjSpec) -> None:
    """Double ε = 1 − d of every equality's impedance (solimp d0 and d_width): :func:`scaled_softness` by 2, where
    every 1 − d has room to double."""
    for eq in spec.equalities:
        for k in (0, 1):
            if not 0 < 1.0 - float(eq.solimp[k]) < 0.5:
                raise ValueError(f"equality {eq.name!r}: solimp[{k}] = {float(eq.solimp[k])} leaves no room to "
                                 "double 1 − d; accepted: 0.5 < d < 1")
    scaled_softness(2.0)(spec)


def quadruple_softness(spec: mujoco.MjSpec) -> None:
    """Quadruple ε = 1 − d of every equality's impedance (:func:`double_softness` twice)."""
    double_softness(spec)
    double_softness(spec)


def scaled_softness(factor: float) -> Callable[[mujoco.MjSpec], None]:
    """The edit that multiplies ε = 1 − d of every equality's impedance (solimp d0 and d_width) by ``factor``."""
    def edit(spec: mujoco.MjSpec) -> None:
        for eq in spec.equalities:
            imp = [float(x) for x in eq.solimp]
            eq.solimp = [1.0 - factor * (1.0 - imp[0]), 1.0 - factor * (1.0 - imp[1]), *imp[2:]]
    return edit


def _rigid_limit_resolved(fit: OrderFit, errors: Sequence[float], dts: Sequence[float], ladder: Mapping[float, tuple],
                          quadrupled: Mapping[float, Trajectory | None], saturation: float) -> tuple[OrderFit, str]:
    """A constrained ladder's order that falls short, refitted with the rigid-limit extrapolation's own
    uncertainty at each step as a known floor (:func:`fit_order`), and the n/a note where that leaves
    fewer than two points.

    The rigid limit x₀ = 2x(ε) − x(2ε) drops the O(ε²) part of the softness; with 1 − d large
    (MuJoCo's default solimp: ε = 0.05–0.1, against 1e-4 in the shipped cases) that part can exceed the
    truncation error, and it changes with h where refsafe raises the timeconstant to 2h. Its size is
    estimated by the quadratic extrapolation (8x(ε) − 6x(2ε) + x(4ε))/3: |linear − quadratic|, per step.
    A point whose error lies within FLOOR_FACTOR of it measures the extrapolation, not the integrator.
    Only a failing order is refitted, so a stiff model (the uncertainty 1e-4 of its error) is judged as
    before, and a fault stays a failure wherever its error stands above the extrapolation's."""
    if any(quadrupled[h] is None or ladder[h][0] is None or ladder[h][1] is None for h in dts):
        return fit, ""
    uncertainty = []
    for h in dts:
        sim, soft = ladder[h][:2]
        four = quadrupled[h]
        assert sim is not None and soft is not None and four is not None  # returned above where one is None
        linear = {p: 2 * sim.positions[p] - soft.positions[p] for p in sim.positions}
        quadratic = {p: (8 * sim.positions[p] - 6 * soft.positions[p] + four.positions[p]) / 3
                     for p in sim.positions}
        uncertainty.append(_point_error(linear, quadratic))
    return _with_known_floors(fit, errors, dts, uncertainty, saturation, "|linear − quadratic in 1 − d|")


def _with_known_floors(fit: OrderFit, errors: Sequence[float], dts: Sequence[float], uncertainty: Sequence[float],
                       saturation: float, what: str) -> tuple[OrderFit, str]:
    """``fit`` refitted with the rigid-limit extrapolation's own uncertainty at each step (``what`` it is) as a
    known floor, and the n/a note where that leaves fewer than two points."""
    refit = fit_order(dts, errors, saturation=saturation, known_floors=uncertainty)
    if refit.n_used >= 2:
        return refit, ""
    return refit, (f"not measurable at these settings: the rigid-limit extrapolation's own uncertainty "
                   f"({what}, up to {max(uncertainty):.2e} m) lies within "
                   f"{FLOOR_FACTOR:g}× of the errors, and hides the truncation error (1 − d too large)")


def polynomial_degree(reference: refmod.Reference, horizon: float, *, max_degree: int) -> int | None:
    """Lowest degree ≤ ``max_degree`` of a polynomial in t that every reference point follows
    over [0, horizon] to 1e-9 of the length scale; None if there is none.

    A one-step method of order p integrates linear dynamics whose solution is a
    polynomial of degree ≤ p without truncation error (uniform acceleration:
    Atwood's machine, a ramp), so its order cannot be observed there.
    """
    t = np.linspace(0.0, horizon, 257)
    q, _ = reference.solution.state(t)
    pts = reference.dynamics.points(q).reshape(len(t), -1)
    for degree in range(max_degree + 1):
        coef = np.polynomial.chebyshev.chebfit(t / horizon, pts, degree)
        resid = pts - np.polynomial.chebyshev.chebval(t / horizon, coef).T
        if np.max(np.abs(resid)) <= 1e-9 * reference.scales.length:
            return degree
    return None


def initial_force_floor(model: mujoco.MjModel, reference: refmod.Reference) -> float:
    """Documented force error of the soft equalities at t = 0, / force scale.

    At r = 0, v = 0 the reference acceleration a_r = −b v − k r vanishes, so
    the force is f = (A + R)⁻¹(−a_u) against the ideal f* = A⁻¹(−a_u), i.e.
    f − f* = −(A + R)⁻¹ R f*, with A = J M⁻¹ Jᵀ and R_ii = (1 − d)/d · A_ii
    (computation chapter, "Parameters", eq. impedance_R, taking MuJoCo's
    diagonal approximation as exact, which diagexact makes it). For one row this
    is the familiar (1 − d)|λ(0)|; coupled rows (Atwood's two strings) mix.
    No timestep removes it: it is a floor of the force error.
    """
    dyn = reference.dynamics
    q0 = reference.q0()[None]
    equalities = [c for c in dyn.constraint_names if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_EQUALITY, c) >= 0]
    if not equalities:
        return 0.0
    # every row of each equality's block (a connect has 3), with that equality's impedance
    rows = [k for c in equalities for k in range(dyn.blocks[c].start, dyn.blocks[c].stop)]
    jac = dyn.jacobian(q0)[0][rows]
    lam = reference.solution.multipliers([0.0])[0][rows]
    a = jac @ np.linalg.solve(dyn.mass_matrix(q0)[0], jac.T)
    d = np.array([float(model.eq_solimp[model.equality(c).id, 0]) for c in equalities
                  for _ in range(dyn.blocks[c].stop - dyn.blocks[c].start)])
    r = np.diag((1.0 - d) / d * np.diag(a))
    try:
        shift = np.linalg.solve(a + r, r @ lam)
    except np.linalg.LinAlgError:  # a zero row (a planar loop's out-of-plane one): A_ii = R_ii = 0, no force there
        shift = np.linalg.lstsq(a + r, r @ lam, rcond=None)[0]
    return float(np.max(np.abs(shift))) / reference.scales.force


def refsafe_off(model: mujoco.MjModel) -> bool:
    """Whether ``model`` has soft constraints (equalities, contact pairs) with MuJoCo's refsafe flag off: its
    time constants are then taken as written at any timestep (no floor at 2h; XMLreference.rst, "flag/refsafe"),
    and a step well above them is unstable, so its ladder runs down from its own timestep, as a user's model with
    equalities does (:data:`DOWN_ABOVE`)."""
    off = bool(model.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_REFSAFE))
    return off and bool(model.neq or model.npair)


def _ladder(integrator: str, fast: bool) -> tuple[float, ...]:
    table = FAST_LADDER if fast else FULL_LADDER
    return table[4 if EXPECTED_ORDER[integrator] >= 4 else 1]


DOWN_ABOVE = 1e-7
"""A model the user brings runs its ladder down from its own timestep (h, h/2, h/4) where its error there is at
least this × L: two halvings shrink an order-4 error 256×, which keeps the smallest near 4e-10 L, decades above
the round-off floor; below it the error at h is already near the floor, and the ladder goes up as a shipped case's
does (multiples of h: 32, 16, 8 for RK4; 4, 2, 1 for the first-order integrators). A model with equality
constraints always goes down: above its own step refsafe raises a stiff row's time constant to 2h, so the ladder
would compare different constraints (welded_pendulum's RK4 order on such a ladder: docs/findings/bases.md);
where its errors then sit on the round-off floor the order is not measurable, and says so."""


UP_LIMIT = 1e-6
"""Where a user's model's ladder goes up, its coarsest step's predicted error e_h kᵖ stays at most this × L: an error
that small is the leading term of an expansion in h; a larger one comes from a step near the motion's own time
scale (ω h near 1), where the order observed is not the integrator's (the models it was set on:
docs/findings/bases.md, UP_LIMIT)."""


def _tree_ladder(integrator: str, fast: bool, error_at_h: float) -> tuple[float, ...]:
    """The multiples of a user's model's own timestep its ladder runs: down from h where its error there is at least
    :data:`DOWN_ABOVE` × L, else up, as far as :data:`UP_LIMIT` lets the coarsest step's predicted error go (at least
    to 4 h: below that the ladder would not leave the floor it is above)."""
    base = _ladder(integrator, fast)
    if error_at_h >= DOWN_ABOVE:
        return tuple(k / max(base) for k in base)
    order = EXPECTED_ORDER[integrator]
    scaled = [tuple(k * s for k in base) for s in (1.0, 0.5, 0.25, 0.125) if min(base) * s >= 1.0 or s == 1.0]
    fitting = [ladder for ladder in scaled if error_at_h * max(ladder) ** order <= UP_LIMIT]
    return fitting[0] if fitting else scaled[-1]


def _error_at(path: Path, integrator: str, h: float, edit, case: Case, reference: refmod.Reference,
              span: float, engine: Backend) -> float:
    """The worst point's position error of one run at the model's own timestep over ``span``, / L (inf where it
    diverges: the ladder then goes down)."""
    probe = case.probe(reference.dynamics)
    model = compile_model(path, integrator=integrator, timestep=h, edit=edit)
    try:
        sim = simulate(engine, model, probe, q0=reference.q0(), qd0=reference.qd0(), steps=steps_in(span, h))
    except SimulationDiverged:
        return math.inf
    return _point_error(sim.positions, refmod.trajectory(reference, sim.t).positions) / reference.scales.length


def _point_error(a: Mapping[str, np.ndarray], b: Mapping[str, np.ndarray]) -> float:
    return max(float(np.max(np.linalg.norm(a[p] - b[p], axis=1))) for p in b)


def _force_error(sim: Trajectory, ref: Trajectory) -> float:
    names = [c for c in ref.multipliers if c in sim.multipliers]
    return max(float(np.max(np.abs(sim.multipliers[c] - ref.multipliers[c]))) for c in names)


def roundoff_floor(steps: float, length: float, epsilon: float) -> float:
    """The round-off a run of ``steps`` steps carries in the active backend's arithmetic (m):
    :data:`~harness.budget.roundoff.ROUNDOFF_EPS` machine epsilons a step, a random walk, × the case's
    length. 3e-12 m for 10⁴ float64 steps; 8e-4 m in float32 (MJX, Warp), where an RK4 error below it
    stops decreasing with h: a floor, not an order."""
    return ROUNDOFF_EPS * epsilon * math.sqrt(max(steps, 1.0)) * length


def explained_floor(fit: OrderFit, effects: Mapping[str, float]) -> str:
    """Why an order cannot be measured, where the errors sit on a floor (fewer than two points above
    it) no higher than an effect the model's settings explain — the softness the rigid-limit
    extrapolation removed (|x(ε) − x(2ε)| at some step of the ladder), or a point mass's inertia
    floor (the change doubling it makes): what is left then hides the integrator's truncation error at
    these settings (MuJoCo's default solimp, a floor of 1e-7 m L²), and is not a fault. '' otherwise (a
    floor above every explained effect is a fault the verdict must show)."""
    if fit.n_used >= 2 or fit.floor is None:
        return ""
    finite = {k: v for k, v in effects.items() if math.isfinite(v)}
    name, largest = max(finite.items(), key=lambda kv: kv[1], default=("", 0.0))
    if not fit.floor <= largest:
        return ""
    return (f"not measurable at these settings: the error sits on a floor ({fit.floor:.2e} m) below the "
            f"{name} effect ({largest:.2e} m), which hides the truncation error")


def convergence_study(
    case: Case,
    *,
    fast: bool = False,
    integrators: Sequence[str] | None = None,
    mjcf: Path | str | None = None,
    timestep: float | None = None,
    edit: Callable[[mujoco.MjSpec], None] | None = None,
    reference: refmod.Reference | None = None,
    engine: Backend | None = None,
) -> ConvergenceStudy:
    """Error vs timestep for each integrator of ``case``, with fitted and expected orders.

    ``fast`` runs the three-point subset on a horizon of at most FAST_HORIZON
    (what `mjharness check` gates); ``mjcf``, ``timestep`` and ``edit`` change
    the model as in ``run_case`` (the ladder is the case's: multiples of the
    shipped model's timestep, whatever timestep is tested; ``timestep`` only
    sets the model the reference and softness are read from), while
    the reference is built from the model so made. ``reference`` reuses a solved
    reference whose horizon covers the study's. Every run goes to ``engine`` (default: MuJoCo's C engine).
    """
    engine = engine or backends.get("c")
    available = available_integrators()
    chosen = list(integrators) if integrators is not None else list(available)
    for name in chosen:
        if name not in available:
            raise ValueError(f"unknown integrator {name!r}; this MuJoCo offers {list(available)}")
    path = Path(mjcf) if mjcf is not None else case.mjcf
    base = compile_model(path, timestep=timestep, edit=edit)
    if exact_solver(base) is not None:  # the solver stops short: the ladder solves exactly (module docstring)
        edit = compose(edit, exact_solver(base))
        base = compile_model(path, timestep=timestep, edit=edit)
    h0 = float(compile_model(case.mjcf, edit=case.prepare).opt.timestep)  # the case's, whatever timestep is tested
    span = min(case.horizon, FAST_HORIZON) if fast else case.horizon
    multiples = {n: _ladder(n, fast) for n in chosen}
    if case.tree is not None:  # a model the user brings: the ladder's direction from its error at its own step
        if reference is None or reference.solution.t_end < span - 1e-12:
            reference = case.reference(base, t_end=span)
        if base.neq:  # above the model's own step a stiff equality is another constraint (refsafe: τ raised to 2h)
            multiples = {n: _tree_ladder(n, fast, math.inf) for n in chosen}
        else:
            multiples = {n: _tree_ladder(n, fast, _error_at(path, n, h0, edit, case, reference, span, engine))
                         for n in chosen}
    elif refsafe_off(base):  # no 2h floor on the time constants: above h a stiff row is unstable, not softer
        multiples = {n: tuple(k / max(m) for k in m) for n, m in multiples.items()}
    h_max = h0 * max(max(m) for m in multiples.values())
    horizon = max(1, math.floor(span / h_max + 1e-9)) * h_max  # at least one largest step
    if reference is None or reference.solution.t_end < horizon - 1e-12:
        reference = case.reference(base, t_end=horizon)
    probe = case.probe(reference.dynamics)
    # a clamp's switch within the study's horizon: an integrator of order above SWITCHED_ORDER has no order to fit
    crossed = switches(reference.dynamics, reference.solution.state, horizon)
    orders = switched_orders(EXPECTED_ORDER, crossed)
    constrained = bool(probe.constraints)
    # equalities whose ε is far above the stiffest: their rigid limit from the near-rigid levels fε and 2fε, where
    # the softness is linear (from ε and 2ε at MuJoCo's default solimp it is not, in loops of light links:
    # docs/findings/softness.md); ε and 2ε are still run, for the softness shown
    rigid = rigid_factor(base) if constrained else None
    near = (scaled_softness(rigid), scaled_softness(2.0 * rigid)) if rigid is not None else ()
    scales = reference.scales
    force_floor = initial_force_floor(base, reference) if constrained else None

    diverged: dict[str, str] = {}  # per integrator, the first run of its ladder that diverged

    def run(name: str, h: float, extra: Callable[[mujoco.MjSpec], None] | None) -> Trajectory | None:
        model = compile_model(path, integrator=name, timestep=h, edit=compose(edit, extra))
        try:
            return simulate(engine, model, probe, q0=reference.q0(), qd0=reference.qd0(),
                            steps=steps_in(horizon, h))
        except SimulationDiverged as exc:
            softer = " with 1 − d changed" if extra is not None else ""
            diverged.setdefault(name, f"{exc.reason} (h = {h:g} s{softer})")
            return None

    bodies = point_masses(base, scales.length)

    def floor_effect(name: str, h: float) -> float:
        """How far doubling the point masses' inertia floors moves the run at ``h`` (nan: none)."""
        if not bodies:
            return math.nan
        try:
            runs = [simulate(engine, compile_model(path, integrator=name, timestep=h, edit=compose(edit, extra)),
                             probe,
                             q0=reference.q0(), qd0=reference.qd0(), steps=steps_in(horizon, h))
                    for extra in floors_pair(base, bodies)]
        except SimulationDiverged:
            return math.nan
        return _point_error(runs[0].positions, runs[1].positions)

    def quadruple(name: str, dts: Sequence[float]) -> dict[float, Trajectory | None]:
        """The ladder's runs with 1 − d quadrupled (None where one diverges or 1 − d has no room)."""
        try:
            requests = [Request(compile_model(path, integrator=name, timestep=h,
                                              edit=compose(edit, quadruple_softness)),
                                reference.q0(), reference.qd0(), steps_in(horizon, h)) for h in dts]
            return dict(zip(dts, engine.simulate_many(requests, probe), strict=True))
        except (SimulationDiverged, ValueError):
            return dict.fromkeys(dts)

    extras = (double_softness, *near) if constrained else ()

    def ladder_of(name: str) -> dict[float, tuple]:
        return _ladder_runs(run, name, tuple(h0 * k for k in multiples[name]), extras, probe=probe, path=path,
                            edit=edit, start=(reference.q0(), reference.qd0()), horizon=horizon, engine=engine)

    # every integrator's ladder side by side (their compiles and steps run in C, Python's lock released)
    with ThreadPoolExecutor(max_workers=max(1, min(len(chosen), os.cpu_count() or 1))) as pool:
        ladders = dict(zip(chosen, pool.map(ladder_of, chosen), strict=True))
    grids = reference_grids(reference, [run[0].t for ladder in ladders.values() for run in ladder.values()
                                         if run[0] is not None])
    series: list[Series] = []
    for name in chosen:
        dts = tuple(h0 * k for k in multiples[name])
        errs: dict[str, list[float]] = {"position": [], "position@rigid": [], "softness": [], "force": []}
        tails: list[float] = []  # the near-rigid extrapolation's own uncertainty per step (RIGID_TAIL: all it adds)
        ladder = ladders[name]
        for h in dts:
            sim, soft, *pair = ladder[h]
            if sim is None or (constrained and soft is None) or None in pair:  # the series says why (Series.diverged)
                for v in errs.values():
                    v.append(math.nan)
                continue
            steps = len(sim.t) - 1
            ref = grids[steps]
            errs["position"].append(_point_error(sim.positions, ref.positions))
            if constrained:  # Richardson in ε from ε and 2ε, or from the near-rigid fε and 2fε
                low, high = pair if pair else (sim, soft)
                at_rigid = {p: 2 * low.positions[p] - high.positions[p] for p in ref.positions}
                tails.append(RIGID_TAIL * _point_error(low.positions, high.positions))
                errs["position@rigid"].append(_point_error(at_rigid, ref.positions))
                errs["softness"].append(_point_error(sim.positions, soft.positions))
                errs["force"].append(_force_error(sim, ref) / scales.force)
        sat = SATURATION * scales.length
        gated = VERDICT_QUANTITY[constrained]
        degree = polynomial_degree(reference, horizon, max_degree=orders[name])
        exact = "" if degree is None else (
            f"exact: the reference is a degree-{degree} polynomial in t, which an order-"
            f"{orders[name]} method integrates without truncation error")
        quantities = [("position", "m", sat)]
        if constrained:
            quantities = [("position@rigid", "m", sat), *quantities, ("softness", "m", sat), ("force", "1", SATURATION)]
        for quantity, unit, saturation in quantities:
            values = tuple(errs[quantity])
            fit = fit_order(dts, values, saturation=saturation)
            note = exact or _switched(crossed, name, horizon)
            if (quantity == gated and constrained and not exact and math.isfinite(fit.order)
                    and orders[name] - fit.order > ORDER_TOLERANCE):
                fit, note = _with_known_floors(fit, values, dts, tails, saturation, "the line through the "
                                               "near-rigid levels' whole tail") if near and len(tails) == len(dts) \
                    else _rigid_limit_resolved(fit, values, dts, ladder, quadruple(name, dts), saturation)
            if quantity == gated and not note and fit.n_used < 2 and fit.floor is not None:
                softness = [v for v in errs["softness"] if math.isfinite(v)]
                effects = {"softness": max(softness, default=math.nan), "inertia floor": floor_effect(name, dts[-1])}
                if engine.epsilon > float(np.finfo(np.float64).eps):  # float32 backends: round-off is a floor too
                    effects[f"{engine.precision} round-off"] = roundoff_floor(steps_in(horizon, min(dts)),
                                                                              scales.length, engine.epsilon)
                note = explained_floor(fit, effects)
            cause = pre_asymptotic([ladder[h][2] for h in dts], dts, order=orders[name]) \
                if quantity == gated and near and all(ladder[h][2] is not None for h in dts) else ""
            series.append(Series(
                integrator=name, quantity=quantity, unit=unit, dts=dts, errors=values, fit=fit, cause=cause,
                expected=float(orders[name]) if quantity == gated and not note else None,
                note=note if quantity == gated else "",
                predicted_floor=force_floor if quantity == "force" else None,
                diverged=diverged.get(name, "")))
    unavailable = unavailable_integrators() if integrators is None else {}
    return ConvergenceStudy(case=case.name, horizon=horizon, fast=fast, constrained=constrained,
                            series=tuple(series), unavailable=unavailable, joints=joint_types(base))


def reference_grids(reference: refmod.Reference, grids: Sequence[np.ndarray]) -> dict[int, Trajectory]:
    """The reference on each of ``grids`` (sample times k·h), by number of steps: evaluated once on the finest and
    taken every m-th sample for each grid that is exactly every m-th of its times (the ladder's halvings of h),
    else evaluated on its own. Each sample's constraint forces cost a KKT solve of the tree."""
    by_steps = {len(t) - 1: t for t in grids}
    if not by_steps:
        return {}
    finest = max(by_steps)
    fine = refmod.trajectory(reference, by_steps[finest])
    out = {finest: fine}
    for steps, t in by_steps.items():
        if steps == finest:
            continue
        m = finest // steps
        same = finest % steps == 0 and np.array_equal(fine.t[::m], t)
        out[steps] = every_nth(fine, m) if same else refmod.trajectory(reference, t)
    return out


PRE_ASYMPTOTIC = 0.5
"""The largest next-order rest, relative to the Richardson correction, at which a run's constraint forces are still an
expansion in h (the rule :data:`harness.families.runs.RESOLVED` sets for the budget's runs: for a first-order method,
a shrink per halving of h between 4/3 and 4)."""


def pre_asymptotic(lows: Sequence[Trajectory], dts: Sequence[float], *, order: float) -> str:
    """Where the ladder's near-rigid level fε (``lows``, one run per step of ``dts``, each halving the last) is
    outside the integrator's asymptotic range on its constraint forces ('' where it is inside, or cannot be told):
    the rest twice the distance between the Richardson extrapolations from consecutive pairs above
    :data:`PRE_ASYMPTOTIC` of the correction, where that correction is not below 1e-3 of the forces (round-off).
    Its ``position@rigid`` is then no expansion in h either, and an order fitted there is the pre-asymptotic
    range's, not the method's (Cassie under ``discrete``: docs/findings/softness.md)."""
    if len(lows) < 3 or any(abs(a / b - 2.0) > 1e-9 for a, b in itertools.pairwise(dts)) \
            or not lows[0].multipliers:
        return ""
    kappa = 2.0**order / (2.0**order - 1.0)
    worst = None
    for k in range(len(lows) - 2):
        x, y, z = (np.concatenate([np.reshape(run.multipliers[c][::2**j], (len(run.multipliers[c][::2**j]), -1))
                                   for c in sorted(run.multipliers)], axis=1)
                   for j, run in zip((0, 1, 2), lows[k:k + 3], strict=True))
        n = min(len(x), len(y), len(z))
        x, y, z = x[:n], y[:n], z[:n]
        leading = float(np.max(np.abs(kappa * (x - y))))
        rest = float(np.max(np.abs(2.0 * ((x - kappa * (x - y)) - (y - kappa * (y - z))))))
        if leading > 1e-3 * float(np.max(np.abs(z))) and rest > PRE_ASYMPTOTIC * leading:
            shrink = float(np.max(np.abs(x - y))) / max(float(np.max(np.abs(y - z))), 1e-300)
            worst = (dts[k], shrink)
            break
    if worst is None:
        return ""
    return (f"the near-rigid level fε's constraint forces change {worst[1]:.2f}× per halving of h from h = "
            f"{worst[0] * 1e3:g} ms, not {2.0**order:g}×: these steps are outside the integrator's asymptotic range "
            f"at the near-rigid softness, where the order fitted is not the method's")


def _switched(crossed: Sequence[tuple[str, float]], integrator: str, horizon: float) -> str:
    """Why ``integrator``'s order is not judged over a motion that crosses the clamps' switches ``crossed`` ('' where
    it is): above :data:`~harness.reference.tree.SWITCHED_ORDER`, the step straddling each switch errs O(h³) with a
    coefficient set by where in the step the switch falls, which differs from one rung of the ladder to the next, so
    the error is no expansion in h and a fitted order says nothing (measured on a servo clamped at its joint: RK4's
    error at h/2ᵏ, k = 0…6, fell by ×15, ×1.1, ×4.2, ×38, ×0.6, ×46). The trajectory budget judges those runs, its
    estimate's error measured from h/4."""
    if not crossed or EXPECTED_ORDER[integrator] <= SWITCHED_ORDER:
        return ""
    return (f"not judged: the motion crosses {len(crossed)} clamp switch(es) within {horizon:g} s (first: "
            f"{crossed[0][0]} at t = {crossed[0][1]:.4g} s); the step straddling each errs O(h³) by where in it the "
            "switch falls, so the error over the ladder is no expansion in h")


def _ladder_runs(run: Callable, name: str, dts: Sequence[float], softer: Sequence[Callable], *, probe, path: Path,
                 edit: Callable | None, start: tuple[np.ndarray, np.ndarray], horizon: float,
                 engine: Backend) -> dict[float, tuple]:
    """Every run of one integrator's ladder (each timestep: as it is, then with each edit of ``softer``; (run,
    None) where there is none), as one batched call to ``engine``
    (:meth:`harness.engine.backends.Backend.simulate_many`); where any run diverges the ladder is run one by one,
    so that each diverged run is told apart as before."""
    extras = (None, *softer)
    keys = [(h, extra) for h in dts for extra in extras]

    def request(key: tuple[float, Callable | None]) -> Request:
        h, extra = key
        return Request(compile_model(path, integrator=name, timestep=h, edit=compose(edit, extra)), *start,
                       steps_in(horizon, h))

    try:
        with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:  # compiled side by side (no GIL in C)
            requests = list(pool.map(request, keys))
        trajs = engine.simulate_many(requests, probe)
        done = dict(zip(keys, trajs, strict=True))
    except SimulationDiverged:
        done = {key: run(name, *key) for key in keys}
    return {h: tuple(done[(h, extra)] for extra in extras) if softer else (done[(h, None)], None) for h in dts}


# ----------------------------------------------------------------- outputs
def order_figures(study: ConvergenceStudy) -> list[Figure]:
    """``converge.INTEGRATOR.order_shortfall`` = max(0, expected − observed), gated ≤ tolerance; none for a
    series whose ladder diverged (its verdict is that reason, :attr:`Series.diverged`, never a number)."""
    figs = []
    for s in study.verdicts:
        if s.diverged:
            continue
        shortfall = s.shortfall
        assert shortfall is not None  # a verdict's series that did not diverge has a documented order
        used = [f"{h * 1e3:g}" for h, st in zip(s.dts, s.fit.status, strict=True) if st == "used"]
        floor = f"; floor {s.fit.floor:.2e} {s.unit}" if s.fit.floor is not None else ""
        figs.append(Figure(
            FigureName.converge(s.integrator, "order_shortfall"), float(shortfall), "1",
            f"max(0, documented order {s.expected:g} − observed {s.fit.order:.2f}) of the {s.quantity} error "
            f"over T = {study.horizon:g} s, fitted on h = {', '.join(used) or 'none'} ms{floor}"
            + (f"; {s.cause}" if s.cause and s.passed is False else "")))
    return figs


# ----------------------------------------------------------------- the family
NAME = "convergence"
ORDER_REASON = ("max(0, documented − observed order) ≤ 0.3: a floor at 1/10 of the smallest fitted error biases the "
                "fitted slope by ≤ 0.14 (harness/families/convergence.py)")


def owns(name: FigureName) -> bool:
    return name.layer == "converge"


def names(case: Case, model: mujoco.MjModel) -> set[FigureName]:
    return {FigureName.converge(integrator, "order_shortfall") for integrator in EXPECTED_ORDER}


def gated(name: FigureName, *, constrained: bool) -> bool:
    return True


def theory_limit(name: FigureName) -> Limit | None:
    if name.layer == "converge" and name.quantity == "order_shortfall":
        return Limit("theory", ORDER_TOLERANCE, ORDER_REASON)
    return None


def measure(bench: Bench) -> Measured:
    """The fast subset of the study on the integrators whose run over the horizon did not diverge (one that
    diverged has no ladder: its order's verdict is that run's)."""
    sims = bench.sims
    if not sims:
        return Measured()
    study = bench.timed("converge", lambda: convergence_study(
        bench.case, fast=True, integrators=list(sims), mjcf=bench.path, timestep=bench.options.timestep,
        edit=bench.mut.edit, reference=bench.reference, engine=bench.engine))
    gated_quantity = VERDICT_QUANTITY[study.constrained]
    return Measured(
        figures=tuple(order_figures(study)),
        diverged={f"converge.{s.integrator}": s.diverged for s in study.verdicts if s.diverged},
        orders={s.integrator: s.fit.order for s in study.verdicts},
        unmeasured={str(FigureName.converge(s.integrator, "order_shortfall")): s.note for s in study.series
                    if s.quantity == gated_quantity and s.expected is None and s.note and not s.diverged})

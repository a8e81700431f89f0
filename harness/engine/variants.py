"""The model variants a budget runs: each changes one setting whose effect the budget extrapolates away.

A variant is the model under test with, for every constraint it has (every
equality, every contact pair and colliding geom), three effective settings
set: the timestep h, the time constant τ of its solref spring-damper and its
impedance softness ε = 1 − d (solimp's d0 and d_width). :func:`variant` makes
one with any of them changed, each *as MuJoCo applies it*:

- τ in effect: under the ``refsafe`` flag MuJoCo raises a time constant below
  2h to 2h; under ``discrete`` it instead replaces a contact row the step
  cannot resolve (:func:`effective_timeconst`). A run at h/2 therefore holds
  every τ at the value in effect at h, or halving h would also stiffen the
  constraints and mix softness into the integration estimate;
- ε in effect: every integrator but ``discrete`` uses solimp's d as authored
  (within [mjMINIMP, mjMAXIMP]); ``discrete`` evaluates the spring-damper at
  the end of the step and folds it into the impedance, which divides ε by
  F = 1 + h b + h² k (b = 2/τ, k = 1/(τ ζ)², ζ the damping ratio), and caps d
  at mjMAXIMP, so ε never goes below 1 − mjMAXIMP (:func:`effective_softness`,
  pinned against MuJoCo's forces in tests/test_budget.py). A variant
  sets the authored ε that gives the effective ε it wants.

The variants (the budgets of :mod:`harness.families.runs` and :mod:`harness.families.sampled` combine them):

- ``split``: h/2 (or h/4), with τ and ε held at their effective values at h;
- ``eps_factor``: every effective ε multiplied by :func:`softness_factor`
  (1/2, or 2 at the stiffest). MuJoCo's documented softness (modeling.rst,
  "Solver parameters") is linear in ε near the rigid limit — the sag
  a_u ε τ², the force error −(A + R)⁻¹Rλ at a consistent state, R ∝ ε/(1 − ε)
  — so two runs extrapolate it to ε → 0, where an equality is held exactly
  (its feedback then only corrects integration error);
- ``tc_factor``: every contact's effective τ multiplied by
  :data:`TIMECONST_FACTOR` (equalities keep theirs). A contact's friction rows
  ask J q̈ = −b v without J̇ q̇, so it rolls with a slip v ≈ γ τ/2 that no ε
  removes: linear in τ, extrapolated to 0;
- :func:`heavier_floors`: the rotational inertia of every point mass doubled.
  The analytic systems have point masses; MuJoCo needs some inertia, and a
  body whose rotational inertia is at most :data:`POINT_MASS` × m L² (L the
  case's length scale) is a point mass carrying that floor. A body with more
  is a rigid body the analytic system must model itself: extra inertia on a
  point mass is a fault, not a floor.

Softness in solref's direct format (negative stiffness, damping) is left as it
is, and said so (:func:`softness_notes`).
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import mujoco
import numpy as np

from harness.engine.integrators import integrator_name
from harness.engine.models import compile_model

__all__ = ["CONVERGED_TOLERANCE", "POINT_MASS", "SETTLE_TIMECONSTS", "TIMECONST_FACTOR", "ConvergedSolver",
           "ModelUnderTest", "SpecEdit", "Variants", "compose", "contact_timeconst", "converged_solver",
           "exact_solver", "floors_pair", "point_masses", "represented_model", "rigid_factor", "roundoff_copy",
           "scale_inertia", "softness_factor", "solver_converges", "steps_per_timeconst", "variant", "wider_margins"]

POINT_MASS = 1e-6
"""The largest rotational inertia, relative to m L², a body may carry and still count as a point mass."""

SpecEdit = Callable[[mujoco.MjSpec], None]
Row = Literal["equality", "contact", "friction"]

SOFTEST = 1.0 - float(mujoco.mjMINIMP)
STIFFEST = 1.0 - float(mujoco.mjMAXIMP)
"""The range of ε = 1 − d MuJoCo accepts (solimp's d is clamped to [mjMINIMP, mjMAXIMP])."""


def refsafe(model: mujoco.MjModel) -> bool:
    return not int(model.opt.disableflags) & int(mujoco.mjtDisableBit.mjDSBL_REFSAFE)


def _discrete(model: mujoco.MjModel) -> bool:
    return integrator_name(model) == "discrete"


def effective_timeconst(model: mujoco.MjModel, solref: Sequence[float], *, row: Row) -> float:
    """The time constant MuJoCo uses for a standard-format ``solref`` (timeconst, dampratio) on a row
    of kind ``row`` of ``model`` (its timestep h, integrator and refsafe flag): XMLreference.rst,
    "refsafe", and computation/index.rst, "Discrete-time".

    - every integrator but ``discrete``: max(timeconst, 2h) under refsafe, for every row;
    - ``discrete``: equality and friction rows as authored; a contact row whose spring the step cannot
      resolve (timeconst · dampratio < h) is replaced by "the stiffest zero-restitution row for the
      timestep, keeping the authored damping ratio", taken here as timeconst = h / dampratio (the
      threshold itself).
    """
    tc, ratio = float(solref[0]), float(solref[1])
    h = float(model.opt.timestep)
    if not refsafe(model):
        return tc
    if not _discrete(model):
        return max(tc, 2.0 * h)
    if row == "contact" and tc * ratio < h:
        return h / ratio
    return tc


def fold(timestep: float, timeconst: float, dampratio: float) -> float:
    """F = 1 + h b + h² k: what ``discrete`` divides a row's ε by, with b = 2/τ, k = 1/(τ ζ)²."""
    u = timestep / timeconst
    return 1.0 + 2.0 * u + (u / dampratio) ** 2


def effective_softness(model: mujoco.MjModel, eps: float, solref: Sequence[float], *, row: Row) -> float:
    """The ε = 1 − d in effect for an authored ε on a row with standard-format ``solref``: clamped to
    MuJoCo's range, and under ``discrete`` divided by :func:`fold` and kept ≥ 1 − mjMAXIMP."""
    eps = min(max(eps, STIFFEST), SOFTEST)
    if not _discrete(model):
        return eps
    tc = effective_timeconst(model, solref, row=row)
    return max(eps / fold(float(model.opt.timestep), tc, float(solref[1])), STIFFEST)


def _authored_softness(eps_effective: float, *, discrete: bool, timestep: float, timeconst: float,
                       dampratio: float) -> float:
    """The authored ε that gives ``eps_effective`` (the inverse of :func:`effective_softness`), within
    MuJoCo's range."""
    eps = eps_effective * fold(timestep, timeconst, dampratio) if discrete else eps_effective
    return min(max(eps, STIFFEST), SOFTEST)


def _standard(solref: Sequence[float]) -> bool:
    return float(solref[0]) > 0  # the direct format (−stiffness, −damping) is negative


def _overridden(spec: mujoco.MjSpec) -> bool:
    """Whether every contact uses option's o_solref/o_solimp (the override flag)."""
    return bool(int(spec.option.enableflags) & int(mujoco.mjtEnableBit.mjENBL_OVERRIDE))


def _friction_solref(holder: Any) -> list[float]:
    """A pair's friction solref: its solreffriction, or its solref where that is unset (0 0)."""
    friction = [float(x) for x in holder.solreffriction]
    return friction if any(friction) else [float(x) for x in holder.solref]


def _contact_elements(spec: mujoco.MjSpec) -> Iterator[object]:
    """Every element whose solref/solimp make contacts': pairs and geoms."""
    yield from spec.pairs
    yield from spec.geoms


TIMECONST_FACTOR = 1.5
"""What the ``slower`` variant multiplies every contact's effective τ by. A contact's force and slip
reach their steady values, linear in τ, through a transient f(t/τ) that no extrapolation in τ
follows; 1.5 keeps the variant's transient at (1 + 26.7) e^(−26.7) ≈ 1e-10 of its start after the
model's settle time (:data:`SETTLE_TIMECONSTS` = 40 τ), where 2 would leave 4e-8."""


def _soft_rows(model: mujoco.MjModel) -> Iterator[tuple[list[float], list[float], Row]]:
    """(solref, solimp, row kind) of every constraint the budget softens: equalities, colliding geoms,
    pairs (or option's override)."""
    for i in range(model.neq):
        yield [float(x) for x in model.eq_solref[i]], [float(x) for x in model.eq_solimp[i]], "equality"
    if not has_contacts(model):
        return
    if int(model.opt.enableflags) & int(mujoco.mjtEnableBit.mjENBL_OVERRIDE):
        yield [float(x) for x in model.opt.o_solref], [float(x) for x in model.opt.o_solimp], "contact"
        return
    colliding = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
    for g in np.flatnonzero(colliding):
        yield [float(x) for x in model.geom_solref[g]], [float(x) for x in model.geom_solimp[g]], "contact"
    for i in range(model.npair):
        yield [float(x) for x in model.pair_solref[i]], [float(x) for x in model.pair_solimp[i]], "contact"


def softness_factor(model: mujoco.MjModel) -> float:
    """What the ``softer`` variant multiplies every effective ε by: 1/2 where every constraint's ε is at
    least twice the stiffest MuJoCo allows (halving moves toward the rigid limit, so the linear
    extrapolation spans ε, not 2ε: MuJoCo's softness grows like ε/(1 − ε)², and from ε = 0.1 — its
    default solimp — a step to 0.2 would leave half the effect unexplained, a step to 0.05 a tenth);
    else 2 (at ε = 1e-4, the stiffest, doubling is linear to 1e-4)."""
    return 0.5 if _smallest_softness(model) >= 2.0 * STIFFEST * (1 + 1e-9) else 2.0


def _smallest_softness(model: mujoco.MjModel) -> float:
    """The smallest effective ε of the model's soft rows in solref's standard format (1 where there is none)."""
    return min((effective_softness(model, 1.0 - d, solref, row=row)
                for solref, solimp, row in _soft_rows(model) if _standard(solref) for d in solimp[:2]),
               default=1.0)


def rigid_factor(model: mujoco.MjModel) -> float | None:
    """f, where the softness part is measured down to the near-rigid levels 2fε and fε rather than extrapolated
    from ε, ε/2 and ε/4: the smallest effective ε × f is twice the stiffest MuJoCo allows (both levels stay
    representable under ``discrete``'s folding). Where the smallest ε is at least 8 × the stiffest (f ≤
    :data:`RIGID_LEVELS_BELOW`) and no contact is soft; None elsewhere: near or at the stiffest already (the levels
    are ε, ε/2, ε/4, or ε and 2ε), or with contacts, whose τ part is extrapolated on the levels ε, ε/2, ε/4.
    A closed loop of light links (Cassie's rods, Robotiq's linkage) at MuJoCo's default solimp answers to ε as
    no polynomial through ε, ε/2, ε/4 does (docs/findings/softness.md)."""
    factor = 2.0 * STIFFEST / _smallest_softness(model)
    if factor > RIGID_LEVELS_BELOW or has_contacts(model):
        return None
    return factor


RIGID_LEVELS_BELOW = 0.25
"""The largest f :func:`rigid_factor` gives: nearer the stiffest (ε below 8 × 1e-4) the levels ε, ε/2, ε/4 are near
the rigid limit already, and the integration correction at 2fε, interpolated between fε and ε with the weight
f/(1 − f), would grow without bound as f → 1."""


def variant(model: mujoco.MjModel, *, split: int = 1, eps_factor: float = 1.0, tc_factor: float = 1.0
            ) -> SpecEdit:
    """The spec edit that makes ``model`` (compiled with the integrator the variant runs) into the variant
    with its timestep divided by ``split`` (compile the result at h/split), every effective ε multiplied
    by ``eps_factor`` and every contact's effective τ by ``tc_factor``, everything else in effect held.
    See the module docstring."""
    h = float(model.opt.timestep)
    h_new = h / split
    discrete = _discrete(model)

    def set_element(holder: object, solref_attr: str, solimp_attr: str, row: Row) -> None:
        solref = [float(x) for x in getattr(holder, solref_attr)]
        if not _standard(solref):
            return
        tc = effective_timeconst(model, solref, row=row) * (tc_factor if row == "contact" else 1.0)
        imp = [float(x) for x in getattr(holder, solimp_attr)]
        authored = [1.0 - _authored_softness(eps_factor * effective_softness(model, 1.0 - d, solref, row=row),
                                             discrete=discrete, timestep=h_new, timeconst=tc, dampratio=solref[1])
                    for d in imp[:2]]
        setattr(holder, solref_attr, [tc, solref[1]])
        setattr(holder, solimp_attr, [*authored, imp[2] * eps_factor, *imp[3:]])

    def edit(spec: mujoco.MjSpec) -> None:
        for eq in spec.equalities:
            set_element(eq, "solref", "solimp", "equality")
        for element in _contact_elements(spec):
            if hasattr(element, "solreffriction"):
                friction = _friction_solref(element)
                if _standard(friction):
                    element.solreffriction = [tc_factor * effective_timeconst(model, friction, row="friction"),
                                              friction[1]]
            set_element(element, "solref", "solimp", "contact")
        if _overridden(spec):
            set_element(spec.option, "o_solref", "o_solimp", "contact")
    return edit


CONVERGED_TOLERANCE = 1e-12
"""The Newton solver's tolerance in the converged variant (:func:`converged_solver`): its relative
improvement per iteration; Newton converges quadratically, so the solution is then exact to round-off."""


def solver_converges(model: mujoco.MjModel) -> bool:
    """Whether the model's own constraint solver is Newton at a tolerance at most
    :data:`CONVERGED_TOLERANCE` × 1e4 (quadratic convergence: stopped at 1e-8, its error is ~1e-16): then
    its solution is the exact one to round-off, and no converged variant is needed."""
    newton = int(model.opt.solver) == int(mujoco.mjtSolver.mjSOL_NEWTON)
    return newton and float(model.opt.tolerance) <= 1e4 * CONVERGED_TOLERANCE


def converged_solver(model: mujoco.MjModel) -> SpecEdit:
    """The model with its constraints solved to convergence: Newton at :data:`CONVERGED_TOLERANCE`, with
    at least the model's iterations (100). The constraint problem is strictly convex (soft constraints),
    so any solver converges to the one solution this one finds; what the model's own solver leaves of it
    (CG or PGS stopped by their iteration cap) is the budget's ``solver`` part."""
    return ConvergedSolver(iterations=max(int(model.opt.iterations), 100))


@dataclass(frozen=True)
class ConvergedSolver:
    """:func:`converged_solver`'s edit, a value (compiled once per variant: :func:`compose`)."""

    iterations: int

    def __call__(self, spec: mujoco.MjSpec) -> None:
        spec.option.solver = mujoco.mjtSolver.mjSOL_NEWTON
        spec.option.tolerance = CONVERGED_TOLERANCE
        spec.option.iterations = self.iterations


def exact_solver(model: mujoco.MjModel) -> SpecEdit | None:
    """:func:`converged_solver` where the model's own solver stops short of the solution, else None (the
    model's runs are then exact already): the edit every budget run of the model is made with."""
    return None if solver_converges(model) else converged_solver(model)


def has_contacts(model: mujoco.MjModel) -> bool:
    """Whether the model can make contacts: a pair or a colliding geom, with contacts enabled."""
    colliding = bool(np.any(model.geom_contype) or np.any(model.geom_conaffinity))
    contacts_on = not int(model.opt.disableflags) & int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    return contacts_on and (model.npair > 0 or colliding)


def contact_timeconst(model: mujoco.MjModel) -> float:
    """The slowest response time among the model's contacts (standard-format solref of its colliding
    geoms and pairs, or option's override; normal and friction rows), 0 where it has none. A row's
    spring-damper has natural period tc · dampratio and damping ratio ≈ dampratio (b = 2/tc,
    k = 1/(tc dampratio)²): critically damped or under, it decays with τ = tc · dampratio; overdamped,
    its slow mode with τ ≈ 2 tc dampratio². A contact's force and slip settle over a few τ
    (:data:`SETTLE_TIMECONSTS`)."""
    if not has_contacts(model):
        return 0.0
    rows: list[tuple[list[float], Row]] = []
    if int(model.opt.enableflags) & int(mujoco.mjtEnableBit.mjENBL_OVERRIDE):
        rows.append(([float(x) for x in model.opt.o_solref], "contact"))
    else:
        colliding = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
        rows += [([float(x) for x in r], "contact") for r in model.geom_solref[colliding]]
        for i in range(model.npair):
            rows.append(([float(x) for x in model.pair_solref[i]], "contact"))
            friction = [float(x) for x in model.pair_solreffriction[i]]
            rows.append((friction if any(friction) else rows[-1][0], "friction"))

    def tau(solref: list[float], row: Row) -> float:
        tc, ratio = effective_timeconst(model, solref, row=row), solref[1]
        return tc * ratio if ratio <= 1 else 2.0 * tc * ratio**2

    return max((tau(r, kind) for r, kind in rows if _standard(r)), default=0.0)


SETTLE_TIMECONSTS = 40.0
"""A contact builds its force from slip or penetration as a critically damped response, (1 + t/τ) e^(−t/τ)
of its start; after 40 τ of the model (26.7 τ of the budget's run with τ × :data:`TIMECONST_FACTOR`)
what remains is below 1e-10 of it, and from there on slip and force are the steady ones that are linear
in τ. Force, velocity and MuJoCo-only figures count samples after that long (or the case's ``settle``,
if longer; :func:`harness.families.bench.settle_time`)."""


def steps_per_timeconst(model: mujoco.MjModel) -> float:
    """The largest h/τ among the model's soft constraints (τ in effect, standard format), 0 with none.
    Above 1/2 — possible only under ``discrete``, or with refsafe off — a constraint's own dynamics are
    resolved by fewer than two steps per time constant, past the range where a run at h/2 tells the
    integration error (:func:`harness.families.runs.past_asymptotic`)."""
    h = float(model.opt.timestep)
    return max((h / effective_timeconst(model, solref, row=row) for solref, _, row in _soft_rows(model)
                if _standard(solref)), default=0.0)


def has_soft_constraints(model: mujoco.MjModel) -> bool:
    """Whether softening changes anything the analytic system has: an equality, or a contact."""
    return model.neq > 0 or has_contacts(model)


def softness_notes(model: mujoco.MjModel) -> tuple[str, ...]:
    """What softening cannot extrapolate (solref's direct format)."""
    direct = [model.equality(i).name or str(i) for i in range(model.neq) if model.eq_solref[i, 0] <= 0]
    direct += [model.pair(i).name or str(i) for i in range(model.npair) if model.pair_solref[i, 0] <= 0]
    return (f"softness: solref in the direct format (negative) is not extrapolated for {', '.join(direct)}",) \
        if direct else ()


def point_masses(model: mujoco.MjModel, length: float) -> tuple[str, ...]:
    """The bodies that are point masses carrying a rotational-inertia floor (see :data:`POINT_MASS`)."""
    out = []
    for b in range(1, model.nbody):
        mass = float(model.body_mass[b])
        if mass > 0 and 0 < float(np.max(model.body_inertia[b])) <= POINT_MASS * mass * length**2:
            out.append(model.body(b).name)
    return tuple(out)


def has_fluid(model: mujoco.MjModel) -> bool:
    """Whether MuJoCo applies fluid forces (``density`` or ``viscosity`` on ``<option>``; ``wind`` acts only
    through them). Its default inertia-box model sizes each body's box from the body's rotational inertia,
    so the force changes with a point mass's floor (XMLreference.rst, "fluidshape")."""
    return float(model.opt.density) > 0 or float(model.opt.viscosity) > 0


def without_fluid(spec: mujoco.MjSpec) -> None:
    """No fluid forces (density and viscosity 0): the floors' pair of runs is made so, because the
    inertia-box fluid force scales with the floor it doubles and would be explained as the floor's
    (:func:`floors_pair`)."""
    spec.option.density = 0.0
    spec.option.viscosity = 0.0


def floors_pair(model: mujoco.MjModel, bodies: tuple[str, ...]) -> tuple[SpecEdit | None, SpecEdit]:
    """(base, heavier): the two variants whose difference is the floors' part. A budget part varies only
    what it names: where the model has fluid forces, both runs hold them off, so a force that also changes
    with the inertia (the inertia box's drag and wind) is not explained as the floor; the floor's own
    effect differs from the one with the fluid forces on at second order (floor × fluid). Else the model
    as it is, and the floors doubled."""
    if has_fluid(model):
        return without_fluid, compose(without_fluid, heavier_floors(bodies))
    return None, heavier_floors(bodies)


def wider_margins(model: mujoco.MjModel) -> SpecEdit | None:
    """Double every contact margin (explicit pairs' and geoms'), or None where none is set. A contact is
    active below its margin and pushes towards it: at a state in contact (distance 0) its reference
    acceleration holds k·margin (k = 1/(d_max τ ζ)², computation/index.rst, "Soft constraints"), linear in
    the margin and independent of 1 − d, which the softness part does not remove."""
    if not (np.any(model.pair_margin > 0) or np.any(model.geom_margin > 0)):
        return None

    def edit(spec: mujoco.MjSpec) -> None:
        for pair in spec.pairs:
            pair.margin = 2.0 * float(pair.margin)
        for geom in spec.geoms:
            geom.margin = 2.0 * float(geom.margin)
    return edit


def heavier_floors(bodies: tuple[str, ...]) -> SpecEdit:
    """Double the rotational inertia of ``bodies`` (their explicit <inertial>)."""
    def edit(spec: mujoco.MjSpec) -> None:
        for name in bodies:
            scale_inertia(spec.body(name), 2.0)
    return edit


def scale_inertia(body, factor: float) -> None:
    """Scale a spec body's rotational inertia, given as a full tensor or as principal moments."""
    full = [float(x) for x in body.fullinertia]
    if np.isfinite(full[0]):
        body.fullinertia = [factor * x for x in full]
    else:
        body.inertia = [factor * float(x) for x in body.inertia]


@dataclass(frozen=True)
class Composed:
    """Spec edits applied one after the other: a value (equal parts make an equal edit), so that
    :func:`harness.engine.models.compile_model` compiles each variant once."""

    edits: tuple[SpecEdit, ...]

    def __call__(self, spec: mujoco.MjSpec) -> None:
        for e in self.edits:
            e(spec)


def compose(*edits: SpecEdit | None) -> SpecEdit:
    """``edits`` (None: none) applied in order, as one edit; a single one is itself."""
    parts: list[SpecEdit] = []
    for e in edits:
        if isinstance(e, Composed):
            parts.extend(e.edits)
        elif e is not None:
            parts.append(e)
    return parts[0] if len(parts) == 1 else Composed(tuple(parts))


# ---------------------------------------------------------------- float32 round-off
def roundoff_copy(model: mujoco.MjModel, *, epsilon: float, index: int) -> mujoco.MjModel:
    """Round-off copy number ``index`` (1, 2, …) of ``model``: each body's mass and each of its principal
    inertias × (1 ± ε), an independent sign each, seeded by ``index`` (one ulp in the backend's arithmetic).
    The constants MuJoCo derives from the masses at compile time (``dof_invweight0``, which sizes the
    constraints' regularisers) stay the model's: off by ε too, an ε-sized change of softness. Not
    ``mj_setConst``: it recomputes more than the masses feed, and moved a copy's motion far beyond ε on MuJoCo
    3.3.0 (docs/findings/backends.md); without it the motion moves by O(ε) (pinned in tests/test_budget.py).

    Why: to measure a float32 run's round-off, copies must round differently from the first operation on
    (they then round independently: stochastic arithmetic, :data:`harness.budget.roundoff.PERTURBED_FACTOR`),
    and in every direction an error can take. Independent signs do that: an ill-conditioned step (a stiff
    constraint's solve, a point mass's 1e-10 inertia) turns ε-sized changes of its inputs into changes of
    its result as large as its own round-off (the condition number at work), so the copies' spread sees it.
    One common factor for every mass would not: the motion is invariant under it, and the copies then round
    in step with the run (on the float32 pendulum their spread then fell far below Warp's own error:
    docs/findings/backends.md). The price is a change of the physics by ε relative, far below
    the round-off measured. Not the timestep: a constraint whose time constant sits at MuJoCo's 2 h floor
    (the pendulum's rod) would stiffen by 2ε. Not the initial state: one ulp off it leaves the constraint
    manifold (the pendulum's slide, a quaternion), whose soft response is a transient of its own, far above
    round-off (docs/findings/backends.md); the state's rounding is :func:`represented_model`'s part."""
    rng = np.random.default_rng(index)
    out = copy.deepcopy(model)
    out.body_mass[:] = model.body_mass * (1.0 + epsilon * rng.choice((-1.0, 1.0), size=model.body_mass.shape))
    out.body_inertia[:] = model.body_inertia * (1.0 + epsilon * rng.choice((-1.0, 1.0),
                                                                           size=model.body_inertia.shape))
    return out


_OPTION_CONSTANTS = ("gravity", "timestep", "impratio", "density", "viscosity", "wind", "magnetic")
"""The physical constants of ``mjOption`` a float32 backend stores in its precision (the solver's tolerances,
which only stop an iteration, are left as they are)."""


def represented_model(model: mujoco.MjModel, dtype: type = np.float32) -> mujoco.MjModel:
    """A copy of ``model`` with every real constant (each float64 array of ``MjModel``, and
    :data:`_OPTION_CONSTANTS`) rounded to ``dtype`` and back: the model as a float32 backend holds it, run in
    float64 by the C engine. The difference it makes to a figure is the representation of the model's
    constants, each off by up to ½ε relative: a deterministic shift that no copy of the state moves (the
    forcing (m₁ − m₂)g of an Atwood machine depends on no state), measured here instead of assumed."""
    out = copy.deepcopy(model)
    for name in dir(out):
        if name.startswith("_"):
            continue
        value = getattr(out, name, None)
        if isinstance(value, np.ndarray) and value.dtype == np.float64 and value.size:
            value[...] = value.astype(dtype).astype(np.float64)
    for name in _OPTION_CONSTANTS:
        value = getattr(out.opt, name)
        if isinstance(value, np.ndarray):
            value[...] = value.astype(dtype).astype(np.float64)
        else:
            setattr(out.opt, name, float(dtype(value)))
    return out


@dataclass(frozen=True)
class ModelUnderTest:
    """How the model under test is compiled (its file, the timestep asked for, the edit applied), so
    that each variant is the same model with one more change."""

    path: Path | str
    timestep: float | None = None
    edit: Callable[[mujoco.MjSpec], None] | None = None
    floors: bool = True
    """Whether the reference idealizes point masses (a hand-derived system does: their floor inertia is then a
    budget part); a model's own tree reads that inertia, so it has no floor to budget."""

    def compile(self, *, integrator: str | None = None, timestep: float | None = None,
                variant: SpecEdit | None = None) -> mujoco.MjModel:
        return compile_model(self.path, integrator=integrator, timestep=timestep or self.timestep,
                             edit=compose(self.edit, variant))


@dataclass(frozen=True)
class Variants:
    """Which variants a budget runs of a model, read once per case: softer (soft constraints), with slower
    contacts (contacts), with heavier floors (the point masses), and the solver tolerance every run keeps."""

    soft: bool
    contacts: bool
    point_masses: tuple[str, ...]
    solver_tolerance: float
    notes: tuple[str, ...]

    @classmethod
    def of(cls, model: mujoco.MjModel, length: float, *, floors: bool = True) -> Variants:
        """``model``'s variants; ``length``: the case's length scale (a point mass's floor is relative to it);
        ``floors``: whether its point masses' inertia is a floor to budget (:attr:`ModelUnderTest.floors`)."""
        constrained = model.neq > 0 or has_contacts(model)
        bodies = point_masses(model, length) if floors else ()
        notes = [*softness_notes(model)]
        if bodies:
            notes.append(f"floors: the rotational inertia of the point mass(es) {', '.join(bodies)} "
                         f"(≤ {POINT_MASS:g} m L²), doubled and extrapolated to 0"
                         + (" with the fluid forces off (the inertia box they act on is the floor: they are "
                            "not the floor's to explain)" if has_fluid(model) else ""))
        return cls(soft=has_soft_constraints(model), contacts=has_contacts(model), point_masses=bodies,
                   solver_tolerance=float(model.opt.tolerance) if constrained else 0.0, notes=tuple(notes))

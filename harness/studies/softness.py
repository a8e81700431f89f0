"""Layer 4: how soft MuJoCo's equality constraints are, beside its documented relations.

For every case whose constraints are MJCF equalities, each equality's
``solref`` time constant and ``solimp`` impedance (d = dmin = dmax) is swept
at the shipped integrator and timestep, and three errors are measured against
the reference, each beside what the documentation predicts:

- Violation (MuJoCo's ``efc_pos``). modeling.rst, "Solver parameters": the
  constraint-space dynamics are a_c + d (b v + k r) = (1 − d) a_u with
  b = 2/(d_w timeconst) and k = d(r)/(d_w² timeconst² dampratio²); at rest, with
  d = d0 = d_w, the "penetration depth" is

      r = a_u (1 − d) timeconst² dampratio².

  We evaluate it quasi-statically along the reference, with a_u = −A λ (the
  ideal a_c = a_u + A λ = 0), A = J M⁻¹ Jᵀ, and timeconst → max(timeconst, 2h),
  the refsafe clamp the same section documents. For coupled rows (A not
  diagonal: Atwood's strings) the same derivation from the documented R and
  a_ref gives r_i = −(1 − d) timeconst² dampratio² A_ii λ_i, which is the
  formula above for one row; that general form is the 'doc' column.
- Force error at t = 0, where r = v = 0: −(A + R)⁻¹ R λ(0) with
  R_ii = (1 − d)/d A_ii (computation chapter, "Parameters"); (1 − d)|λ(0)| for
  a single row (see convergence.initial_force_floor).
- Force error once the transient has decayed (t ≥ 10 timeconst): the
  quasi-static relation predicts none (a_c ≈ 0 makes the force the ideal one),
  so what remains is lag of the constraint spring and integrator error.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from harness.cases import Case, all_cases
from harness.core.errors import SimulationDiverged
from harness.engine import backends
from harness.engine.backends import Backend, simulate
from harness.engine.integrators import integrator_name
from harness.engine.models import compile_model
from harness.engine.recording import steps_in
from harness.families.convergence import initial_force_floor
from harness.reference import solutions as refmod

__all__ = ["SETTLE", "SoftnessStudy", "equality_cases", "softness_study"]

TIMECONSTS: tuple[float, ...] = (0.002, 0.005, 0.02, 0.05)   # s; 0.02 is MuJoCo's default solref
IMPEDANCES: tuple[float, ...] = (0.9, 0.99, 0.999, 0.9999)   # 0.9999 = mjMAXIMP, the stiffest
FAST_TIMECONSTS: tuple[float, ...] = (0.002, 0.02)
FAST_IMPEDANCES: tuple[float, ...] = (0.99, 0.9999)
FAST_HORIZON = 0.5
SETTLE = 10.0  # force errors "settled" from SETTLE × effective timeconst on


@dataclass(frozen=True)
class SoftnessRow:
    """One (timeconst, d) setting: measured errors beside the documented ones.

    Forces are |λ_mj − λ_ref| / the case's force scale, worst constraint;
    violations in metres (the rows' own units), worst equality.
    """

    timeconst: float
    effective_timeconst: float
    dampratio: float
    impedance: float
    violation: float
    violation_doc: float
    force_t0: float
    force_t0_doc: float
    force_settled: float
    position: float
    diverged: str = ""  # the setting's run diverged: its reason, and nan for every measured number


@dataclass(frozen=True)
class SoftnessFit:
    """log(violation) = c + a log(1 − d) + b log(timeconst_eff), vs. documented a = 1, b = 2."""

    impedance_exponent: float
    timeconst_exponent: float


@dataclass(frozen=True)
class SoftnessStudy:
    case: str
    integrator: str
    timestep: float
    horizon: float
    constraints: tuple[str, ...]
    rows: tuple[SoftnessRow, ...]
    fit: SoftnessFit | None
    mujoco_version: str = mujoco.__version__


def equality_cases(selected: Sequence[Case]) -> tuple[Case, ...]:
    """The cases whose system has constraints that are MJCF equalities."""
    return tuple(c for c in selected if c.probe(c.dynamics()).constraints)


def set_softness(timeconst: float, impedance: float) -> Callable[[mujoco.MjSpec], None]:
    """MjSpec edit: every equality gets solref (timeconst, its dampratio), solimp d0 = d_w = impedance."""
    if not timeconst > 0:
        raise ValueError(f"timeconst must be positive (the standard solref format), got {timeconst}")
    if not 0 < impedance < 1:
        raise ValueError(f"impedance d must lie in (0, 1), got {impedance}")

    def edit(spec: mujoco.MjSpec) -> None:
        for eq in spec.equalities:
            eq.solref = [timeconst, float(eq.solref[1])]
            eq.solimp = [impedance, impedance, *[float(x) for x in eq.solimp[2:]]]
    return edit


def _documented_violation(reference: refmod.Reference, t: np.ndarray, names: Sequence[str],
                          eps: float, tc: float, dr: float) -> float:
    """max over t and rows of the documented quasi-static violation |(1 − d) tc² dr² A_ii λ_i|.

    From the documented definitions, at a_c = 0, v = 0: A f = −a_u, (A + R) f =
    a_r − a_u, a_r = −k r, so k r = R A⁻¹ a_u, and with R_ii = (1 − d)/d A_ii,
    k = 1/(d tc² dr²): r = (1 − d) tc² dr² diag(A) A⁻¹ a_u = −(1 − d) tc² dr² A_ii λ_i.
    For one row (A = A_ii) this is modeling.rst's r = a_u (1 − d) tc² dr².
    """
    dyn = reference.dynamics
    rows = [k for c in names for k in range(dyn.blocks[c].start, dyn.blocks[c].stop)]  # every row of each block
    q, qd = reference.solution.state(t)
    _, lam = dyn.accelerations(q, qd)
    jac = dyn.jacobian(q)[:, rows]
    a = jac @ np.linalg.solve(dyn.mass_matrix(q), np.swapaxes(jac, -1, -2))
    a_diag = np.diagonal(a, axis1=-2, axis2=-1)
    return float(np.max(np.abs(eps * tc**2 * dr**2 * a_diag * lam[:, rows])))


def softness_study(case: Case, *, fast: bool = False, timeconsts: Sequence[float] | None = None,
                   impedances: Sequence[float] | None = None, engine: Backend | None = None) -> SoftnessStudy:
    """Sweep solref timeconst × solimp d for ``case``'s equalities at its shipped integrator and timestep, every
    run on ``engine`` (default: MuJoCo's C engine)."""
    engine = engine or backends.get("c")
    timeconsts = tuple(timeconsts or (FAST_TIMECONSTS if fast else TIMECONSTS))
    impedances = tuple(impedances or (FAST_IMPEDANCES if fast else IMPEDANCES))
    path = case.mjcf
    shipped = compile_model(path)
    horizon = min(case.horizon, FAST_HORIZON) if fast else case.horizon
    reference = case.reference(shipped, t_end=horizon)
    probe = case.probe(reference.dynamics)
    if not probe.constraints:
        raise ValueError(f"case {case.name!r} has no MJCF equality constraints; the softness study needs "
                         f"some (cases with them: {', '.join(c.name for c in equality_cases(all_cases()))})")
    h = float(shipped.opt.timestep)
    steps = steps_in(horizon, h)
    refsafe = not shipped.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_REFSAFE
    scale = reference.scales.force
    rows, ref_traj = [], None
    for tc in timeconsts:
        for d in impedances:
            model = compile_model(path, edit=set_softness(tc, d))
            tc_eff = max(tc, 2 * h) if refsafe else tc
            dr = float(model.eq_solref[model.equality(probe.constraints[0]).id, 1])
            try:
                sim = simulate(engine, model, probe, q0=reference.q0(), qd0=reference.qd0(), steps=steps)
            except SimulationDiverged as exc:  # a finding of the sweep, never a number
                rows.append(SoftnessRow(timeconst=tc, effective_timeconst=tc_eff, dampratio=dr, impedance=d,
                                        violation=math.nan, violation_doc=math.nan, force_t0=math.nan,
                                        force_t0_doc=math.nan, force_settled=math.nan, position=math.nan,
                                        diverged=exc.reason))
                continue
            if ref_traj is None:
                ref_traj = refmod.trajectory(reference, sim.t)
            # per sample, the worst row of every constraint (a block's multipliers are (N, k))
            force = np.max(np.stack([np.abs(sim.multipliers[c] - ref_traj.multipliers[c]).reshape(len(sim.t), -1)
                                     .max(axis=1) for c in probe.constraints]), axis=0) / scale
            settled = sim.t >= SETTLE * tc_eff
            rows.append(SoftnessRow(
                timeconst=tc, effective_timeconst=tc_eff, dampratio=dr, impedance=d,
                violation=max(float(np.max(np.abs(sim.violations[c]))) for c in probe.constraints),
                violation_doc=_documented_violation(reference, sim.t, probe.constraints, 1 - d, tc_eff, dr),
                force_t0=float(force[0]), force_t0_doc=initial_force_floor(model, reference),
                force_settled=float(np.max(force[settled])) if settled.any() else math.nan,
                position=max(float(np.max(np.linalg.norm(sim.positions[p] - ref_traj.positions[p], axis=1)))
                             for p in ref_traj.positions)))
    return SoftnessStudy(case=case.name, integrator=integrator_name(shipped), timestep=h, horizon=horizon,
                         constraints=tuple(probe.constraints), rows=tuple(rows), fit=_fit(rows))


def _fit(rows: Sequence[SoftnessRow]) -> SoftnessFit | None:
    rows = [r for r in rows if not r.diverged]
    eps = np.log([1 - r.impedance for r in rows])
    tcs = np.log([r.effective_timeconst for r in rows])
    if len(set(eps)) < 2 or len(set(tcs)) < 2:
        return None
    design = np.column_stack([np.ones_like(eps), eps, tcs])
    coef, *_ = np.linalg.lstsq(design, np.log([r.violation for r in rows]), rcond=None)
    return SoftnessFit(impedance_exponent=float(coef[1]), timeconst_exponent=float(coef[2]))

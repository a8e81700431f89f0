"""Numeric checks of the seed documents' claims at MuJoCo's states, and what each number is.

A claim's case is run in MuJoCo at its shipped settings and 40 states are
sampled (every step, for the action claims); q̈ is MuJoCo's ``qacc`` and λ its
``efc_force`` (or contact force). Each kind of check yields an ``error`` (how
far the claim is from MuJoCo, or from our formula at MuJoCo's states where no
MuJoCo reading exists) and a ``floor`` (the same figure for our own derivation,
or MuJoCo's own deviation from the ideal constraint): what MuJoCo's integrator
and soft constraints leave. A claim "agrees" when its error is within
AGREEMENT × floor (plus the neglected order of an approximation it states).
:data:`KINDS` says in words what error and floor are for each kind; every row
of the audit carries that description. Each kind is shown to fail on a wrong
variant of its claim in tests/test_audit.py.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import mujoco
import numpy as np
import sympy as sp

from analytic import systems
from harness import cases
from harness.audit import Claim
from harness.audit.view import T_SYMBOL, DocView, resolve
from harness.engine.bindings import JointBinding
from harness.engine.constraints import equality_block
from harness.engine.models import compile_model
from harness.engine.recording import steps_in

__all__ = ["AGREEMENT", "KINDS", "Numbers", "numeric_check"]

SAMPLES = 40
AGREEMENT = 10.0

# kind -> (what the error is, what the floor is)
KINDS: dict[str, tuple[str, str]] = {
    "reading": ("max |claim − MuJoCo's own reading| / max |reading| at MuJoCo's states (range, for a claim "
                "up to a constant)", "the same for our derivation's formula"),
    "acceleration": ("max |claim − our formula evaluated with MuJoCo's qacc/efc_force| / its scale at MuJoCo's "
                     "states", "our formula with our solved q̈, λ vs with MuJoCo's qacc, efc_force"),
    "formula": ("max |claim − our derivation's formula| / its scale, both at MuJoCo's (q, q̇): our formula, "
                "not a MuJoCo reading", "0: both sides are functions of the same state"),
    "equation": ("max |residual| / max Σ|terms| per equation, with MuJoCo's q, q̇, qacc, efc_force",
                 "the same for our Lagrange equations, plus what MuJoCo's drift off the manifold changes"),
    "rows": ("max |claimed row at MuJoCo's velocities| / (its largest coefficient × the motion's top speed)",
             "MuJoCo's own violation of our constraint rows, same scale"),
    "positions": ("max |claimed f(q)| at MuJoCo's positions (its range, for f = constant) / (max |∇f| × the "
                  "system's length scale)", "MuJoCo's own violation of our holonomic constraints, same scale"),
    "drift": ("(max − min) of the claimed quantity along MuJoCo's run / max |MuJoCo's own reading|",
              "the drift of MuJoCo's own reading"),
    "trajectory": ("max |closed form − MuJoCo's q(t)| / amplitude", "our reference solution vs MuJoCo's q(t)"),
    "action": ("action S = ∫L dt of MuJoCo's path under variations η fixed at the ends: first variation "
               "|δS| / its terms (stationary), or the decrease −δ²S / its kinetic part (minimum)",
               "the same figure at twice the step (the quadrature's error)"),
}


@dataclass(frozen=True)
class Samples:
    """MuJoCo states in our coordinates, with MuJoCo's own readings."""

    case: str
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    lam: np.ndarray
    kinetic: np.ndarray
    potential: np.ndarray
    invariants: dict[str, np.ndarray]
    params: dict[str, float]


@dataclass(frozen=True)
class Numbers:
    """One claim's numeric check: its kind, figures, and what they are (see :data:`KINDS`)."""

    kind: str
    error: float | None
    floor: float | None
    tolerance: float | None
    agrees: bool | None
    error_is: str
    floor_is: str
    states: str

    @staticmethod
    def none(why: str) -> Numbers:
        return Numbers("none", None, None, None, None, why, "", "")


def case_for(claim: Claim) -> cases.Case:
    """The case the claim is measured on: joint-bound, preferring a contact model for constraint claims."""
    pool = [c for c in cases.all_cases() if c.system == claim.frame.system and c.binding is None]
    if not pool:
        raise ValueError(f"no joint-bound case for system {claim.frame.system!r}")
    if claim.measure == "constraint":
        contact = [c for c in pool if c.mujoco_forces]
        pool = contact or pool
    return pool[0]


@functools.cache
def sample(case_name: str, small_motion: float = 1.0, scaled: str = "", *, t_end: float = 0.0) -> Samples:
    """Run the case's model and sample SAMPLES states over its horizon (``t_end``: every step up to
    t_end instead), with MuJoCo's qacc, forces and energies, each read after ``mj_forward``."""
    case = cases.get(case_name)
    model = compile_model(case.mjcf)
    ref = case.reference(model)
    dyn = ref.dynamics
    q0, qd0 = ref.q0(), ref.qd0()
    if scaled:
        k = dyn.coordinates.index(scaled)
        q0[k] *= small_motion
        qd0[k] *= small_motion
    binding = JointBinding(dyn.coordinates)
    data = mujoco.MjData(model)
    binding.set_state(model, data, q0, qd0)
    steps = steps_in(t_end or case.horizon, model.opt.timestep)
    every = 1 if t_end else max(1, steps // SAMPLES)
    dof = binding.dof_matrix(model)
    rows: dict[str, list] = {k: [] for k in ("t", "q", "qd", "qdd", "lam", "kin", "pot")}
    inv: dict[str, list] = {k: [] for k in case.mujoco_invariants}
    for k in range(steps + 1):
        mujoco.mj_forward(model, data)
        if k % every == 0:
            rows["t"].append(data.time)
            rows["q"].append([data.qpos[model.joint(c).qposadr[0]] for c in dyn.coordinates])
            rows["qd"].append(dof.T @ data.qvel)
            rows["qdd"].append(dof.T @ data.qacc)
            # one value per constraint row, in the order of the multiplier symbols (a block: all its rows)
            rows["lam"].append(np.concatenate([[], *(np.atleast_1d(case.mujoco_forces[c](model, data))
                                                    if c in case.mujoco_forces else equality_block(model, data, c)[0]
                                                    for c in dyn.constraint_names)]))
            rows["kin"].append(data.energy[1])
            rows["pot"].append(data.energy[0])
            for name, read in case.mujoco_invariants.items():
                inv[name].append(read(model, data))
        mujoco.mj_step(model, data)
    arr = {k: np.array(v, dtype=float) for k, v in rows.items()}
    return Samples(case=case_name, t=arr["t"], q=arr["q"], qd=arr["qd"], qdd=arr["qdd"],
                   lam=arr["lam"].reshape(len(arr["t"]), -1), kinetic=arr["kin"], potential=arr["pot"],
                   invariants={k: np.array(v) for k, v in inv.items()}, params=dict(ref.params))


# --- evaluating formulas at MuJoCo's states

def _ours_symbols(view: DocView) -> list[sp.Symbol]:
    d = view.derivation
    names = [c.name for c in d.system.q]
    return ([view.ours_q[n] for n in names] + [view.ours_qd[n] for n in names]
            + [view.ours_qdd[n] for n in names] + list(d.multiplier_symbols))


def _evaluate_ours(expr: sp.Expr, view: DocView, s: Samples, *, extra: dict | None = None) -> np.ndarray:
    """An expression in our variables at MuJoCo's sampled states."""
    d = view.derivation
    symbols = _ours_symbols(view)
    values = [*s.q.T, *s.qd.T, *s.qdd.T, *s.lam.T]
    params = {p: s.params[p.name] for p in d.system.params}
    for sym, val in (extra or {}).items():
        symbols.append(sym)
        values.append(val)
    fn = sp.lambdify(symbols, sp.sympify(expr).subs(params), modules="numpy")
    return np.broadcast_to(np.asarray(fn(*values), dtype=float), s.t.shape).copy()


def evaluate(expr: sp.Expr, view: DocView, s: Samples, *, extra: dict | None = None) -> np.ndarray:
    """An expression in the document's variables, evaluated at MuJoCo's sampled states."""
    return _evaluate_ours(sp.sympify(expr).subs(view.to_ours, simultaneous=True), view, s, extra=extra)


def _term_scale(expr: sp.Expr, view: DocView, s: Samples) -> float:
    terms = sp.Add.make_args(sp.expand(expr))
    return float(np.max(sum(np.abs(evaluate(t, view, s)) for t in terms)))


def _components(formula: sp.Expr | sp.Matrix) -> list[sp.Expr]:
    if isinstance(formula, sp.Equality):
        formula = formula.lhs - formula.rhs
    return list(formula) if isinstance(formula, sp.MatrixBase) else [sp.sympify(formula)]


def _claimed(claim: Claim, view: DocView) -> list[sp.Expr]:
    """The claim's formula (its instance, for a general display), aliases replaced, one entry per equation."""
    return [e.subs(claim.aliases, simultaneous=True) for e in _components(resolve(claim.claimed, view))]


def _uses_motion(expr: sp.Expr, view: DocView) -> bool:
    """Whether ``expr`` has q̈ or λ in it: at MuJoCo's states they are MuJoCo's qacc and efc_force."""
    return bool(sp.sympify(expr).free_symbols & {*view.frame.qdd, *view.frame.lam.values()})


def _allowance(exprs: list[sp.Expr], claim: Claim, view: DocView, s: Samples, scales: list[float]) -> float:
    """What MuJoCo's drift off the constraint manifold changes in the claim: |claim − claim on the
    manifold| relative, where the claim names the manifold (``manifold`` or ``projection``)."""
    onto = {**claim.manifold, **claim.projection}
    if not onto:
        return 0.0
    return max(float(np.max(np.abs(evaluate(e, view, s) - evaluate(e.subs(onto, simultaneous=True), view, s))))
               / sc for e, sc in zip(exprs, scales, strict=True) if sc > 0)


# --- the kinds of check

def _states(s: Samples) -> str:
    return f"{len(s.t)} MuJoCo states of case {s.case!r}"


def _numbers(kind: str, err: float, floor: float, tol: float, s: Samples, *, error_is: str = "") -> Numbers:
    what, floor_is = KINDS[kind]
    return Numbers(kind, err, floor, tol, err <= tol, error_is or what, floor_is, _states(s))


def _tolerance(claim: Claim, floor: float, view: DocView, s: Samples) -> float:
    tol = AGREEMENT * floor + 1e-9
    if claim.approx_symbol is not None:
        k = [c.name for c in view.derivation.system.q].index(claim.approx_symbol.name)
        tol += float(np.max(np.abs(s.q[:, k]))) ** 2  # the neglected order, relative
    return tol


_READINGS = {"kinetic": "MuJoCo's kinetic energy (data.energy[1])",
             "potential": "MuJoCo's potential energy (data.energy[0])",
             "lagrangian": "MuJoCo's energy[1] − energy[0]"}


def _reading(claim: Claim, s: Samples) -> tuple[np.ndarray, str]:
    m = claim.measure or ""
    if m in ("kinetic", "potential"):
        return (s.kinetic if m == "kinetic" else s.potential), _READINGS[m]
    if m == "lagrangian":
        return s.kinetic - s.potential, _READINGS[m]
    name = m.split(":", 1)[1]
    return s.invariants[name], f"MuJoCo's {name} (read from its own state)"


def _value(claim: Claim, view: DocView, s: Samples) -> Numbers:
    (claimed,) = _claimed(claim, view)
    truth_expr = claim.truth(view)  # type: ignore[misc]
    truth = evaluate(view.on_motion(truth_expr, claim), view, s)
    if claim.measure:
        kind = "reading"
        measured, source = _reading(claim, s)
    else:
        kind = "acceleration" if _uses_motion(truth_expr, view) else "formula"
        measured, source = evaluate(truth_expr, view, s), "our formula"
    got = evaluate(claimed, view, s)
    scale = max(float(np.max(np.abs(measured))), _term_scale(truth_expr, view, s), _term_scale(claimed, view, s))
    scale = scale or 1.0
    spread = np.ptp if claim.kind == "value_up_to_constant" else (lambda x: np.max(np.abs(x)))
    err = float(spread(got - measured)) / scale
    drift = _allowance([claimed], claim, view, s, [scale])
    floor = float(spread(truth - measured)) / scale + drift
    what = KINDS[kind][0].replace("MuJoCo's own reading", source) if kind == "reading" else ""
    numbers = _numbers(kind, err, floor, _tolerance(claim, floor, view, s), s, error_is=what)
    if drift:
        numbers = dataclasses.replace(numbers, floor_is=f"{numbers.floor_is}, plus {drift:.2e}: what MuJoCo's drift "
                                                        "off the constraint manifold changes in the claim")
    return numbers


def _equation_floor(view: DocView, s: Samples) -> float:
    worst = 0.0
    for eq in view.derivation.equations:
        doc_eq = view.doc(eq)
        scale = _term_scale(doc_eq, view, s)
        if scale > 0:
            worst = max(worst, float(np.max(np.abs(evaluate(doc_eq, view, s)))) / scale)
    return worst


def _equation(claim: Claim, view: DocView, s: Samples) -> Numbers:
    exprs = _claimed(claim, view)
    scales = [_term_scale(e, view, s) for e in exprs]
    err = max(float(np.max(np.abs(evaluate(e, view, s)))) / sc for e, sc in zip(exprs, scales, strict=True)
              if sc > 0)
    floor = _equation_floor(view, s) + _allowance(exprs, claim, view, s, scales)
    return _numbers("equation", err, floor, _tolerance(claim, floor, view, s), s)


def _top_speed(view: DocView, s: Samples) -> float:
    """The largest speed of any named point of the system over the sampled states (m/s)."""
    d = view.derivation
    q, qd = d.system.q, d.system.qd
    top = 0.0
    for pos in d.system.points.values():
        vel = [sum(sp.diff(p, c) * v for c, v in zip(q, qd, strict=True)) for p in pos]
        speed = np.sqrt(sum(_evaluate_ours(v, view, s) ** 2 for v in vel))
        top = max(top, float(np.max(speed)))
    return top


def _coefficient_scale(row: sp.Expr, variables: tuple[sp.Symbol, ...], view: DocView, s: Samples) -> np.ndarray:
    """The largest |∂row/∂v| over ``variables``, at each state (a row's size per unit rate)."""
    coefs = [np.abs(evaluate(sp.diff(row, v), view, s)) for v in variables]
    return np.max(np.vstack(coefs), axis=0)


def _rows(claim: Claim, view: DocView, s: Samples) -> Numbers:
    speed = _top_speed(view, s)
    qd = view.frame.qd

    def relative(row: sp.Expr, reference: sp.Expr) -> float:
        size = float(np.max(_coefficient_scale(reference, qd, view, s))) * speed
        return float(np.max(np.abs(evaluate(row, view, s)))) / size

    claimed = _claimed(claim, view)
    err = max(relative(row, row) for row in claimed)
    # our rows on the scale of the claimed ones: what MuJoCo's soft constraint or contact leaves
    floor = max(relative(ours, row) for ours in view.rows for row in claimed)
    return _numbers("rows", err, floor, _tolerance(claim, floor, view, s), s)


def _positions(claim: Claim, view: DocView, s: Samples) -> Numbers:
    d = view.derivation
    length = systems.load(d.system.name).scales(s.params).length
    known = {*view.frame.q, *d.system.params}

    def relative(f: sp.Expr) -> float:
        constants = {c: 0 for c in f.free_symbols - known}
        size = float(np.max(_coefficient_scale(f, view.frame.q, view, s))) * length
        values = evaluate(f.subs(constants), view, s)
        return float(np.ptp(values) if constants else np.max(np.abs(values))) / size

    err = max(relative(f) for f in _claimed(claim, view))
    holonomic = [view.doc(c.expr) for c in d.system.constraints if c.kind == "holonomic"]
    floor = max(relative(f) for f in holonomic)
    return _numbers("positions", err, floor, _tolerance(claim, floor, view, s), s)


def _drift(claim: Claim, view: DocView, s: Samples) -> Numbers:
    (claimed,) = _claimed(claim, view)
    name = (claim.measure or "").split(":", 1)[1]
    reading = s.kinetic + s.potential if name == "energy" else s.invariants[name]
    scale = float(np.max(np.abs(reading))) or 1.0
    err = float(np.ptp(evaluate(claimed, view, s))) / scale
    floor = float(np.ptp(reading)) / scale
    source = "MuJoCo's energy[0] + energy[1]" if name == "energy" else f"MuJoCo's {name}"
    return _numbers("drift", err, floor, _tolerance(claim, floor, view, s), s,
                    error_is=KINDS["drift"][0].replace("MuJoCo's own reading", source))


def _trajectory(claim: Claim, view: DocView, s: Samples, case: cases.Case) -> Numbers:
    coord = (claim.measure or "").split(":", 1)[1]
    k = [c.name for c in view.derivation.system.q].index(coord)
    q0s, v0s = sp.symbols("q0 v0", real=True)
    (claimed,) = _claimed(claim, view)
    closed = evaluate(claimed, view, s, extra={T_SYMBOL: s.t, q0s: s.q[0, k], v0s: s.qd[0, k]})
    ref = case.reference(compile_model(case.mjcf))
    ref_q = ref.solution.state(s.t)[0][:, k]
    amp = float(np.max(np.abs(s.q[:, k])))
    err = float(np.max(np.abs(closed - s.q[:, k]))) / amp
    floor = float(np.max(np.abs(ref_q - s.q[:, k]))) / amp
    return _numbers("trajectory", err, floor, _tolerance(claim, floor, view, s), s)


def _action_figures(lag: sp.Expr, view: DocView, s: Samples, stride: int) -> tuple[float, float, float, float]:
    """(first variation / its terms, −second variation / its kinetic part) of ∫L dt along MuJoCo's path,
    worst over the variations η = sin(nπt/τ), n = 1..3, each coordinate moved by 0.1 of its range."""
    s = dataclasses.replace(s, t=s.t[::stride], q=s.q[::stride], qd=s.qd[::stride], qdd=s.qdd[::stride],
                            lam=s.lam[::stride], kinetic=s.kinetic[::stride], potential=s.potential[::stride])
    tau = float(s.t[-1] - s.t[0])
    size = np.maximum(np.ptp(s.q, axis=0), 1e-3) * 0.1
    f = view.frame
    first, second = 0.0, 0.0
    for n in (1, 2, 3):
        w = n * np.pi / tau
        eta = np.sin(w * (s.t - s.t[0]))[:, None] * size
        eta_d = w * np.cos(w * (s.t - s.t[0]))[:, None] * size

        def action(e: float, eta=eta, eta_d=eta_d) -> float:
            moved = dataclasses.replace(s, q=s.q + e * eta, qd=s.qd + e * eta_d)
            return float(np.trapezoid(evaluate(lag, view, moved), s.t))

        d1 = (action(1.0) - action(-1.0)) / 2
        d2 = action(1.0) + action(-1.0) - 2 * action(0.0)
        terms = sum(np.abs(evaluate(sp.diff(lag, c), view, s)) * np.abs(eta[:, k])
                    + np.abs(evaluate(sp.diff(lag, v), view, s)) * np.abs(eta_d[:, k])
                    for k, (c, v) in enumerate(zip(f.q, f.qd, strict=True)))
        kinetic = sum(np.abs(evaluate(sp.diff(lag, v, 2), view, s)) * eta_d[:, k] ** 2
                      for k, v in enumerate(f.qd))
        first = max(first, abs(d1) / float(np.trapezoid(terms, s.t)))
        second = max(second, -d2 / float(np.trapezoid(kinetic, s.t)))
    return first, max(second, 0.0), tau, float(s.t[1] - s.t[0])


def _action(claim: Claim, view: DocView, case: cases.Case) -> Numbers:
    s = sample(case.name, t_end=claim.window or case.horizon)
    (lag,) = _claimed(claim, view)
    fine_first, fine_second, tau, step = _action_figures(lag, view, s, 1)
    coarse_first, coarse_second, _, _ = _action_figures(lag, view, s, 2)
    minimum = claim.measure == "action:minimum"
    err = fine_second if minimum else fine_first
    floor = abs(fine_second - coarse_second) if minimum else abs(fine_first - coarse_first)
    what = ("−δ²S[η] / ∫ ∂²L/∂q̇² η̇² dt (0 when S does not decrease)" if minimum
            else "|δS[η]| / ∫ (|∂L/∂q η| + |∂L/∂q̇ η̇|) dt")
    states = f"MuJoCo's path of case {case.name!r} over [0, {tau:g}] s, every {step:g} s"
    tol = _tolerance(claim, floor, view, s)
    return Numbers("action", err, floor, tol, err <= tol, f"{KINDS['action'][0]}: {what}", KINDS["action"][1], states)


def numeric_check(claim: Claim, view: DocView) -> Numbers:
    """The claim checked at MuJoCo's states, with what the figures are."""
    if claim.no_numbers:
        return Numbers.none(claim.no_numbers)
    if claim.kind == "statement" and claim.measure is None:
        return Numbers.none("a statement with no formula a motion could test: symbolic check only")
    try:
        case = case_for(claim)
    except ValueError as exc:
        return Numbers.none(f"no MuJoCo reading: {exc}")
    if claim.measure and claim.measure.startswith("action:"):
        return _action(claim, view, case)
    scaled = claim.approx_symbol.name if claim.approx_symbol is not None else ""
    s = sample(case.name, claim.small_motion, scaled)
    if claim.kind == "equation":
        return _equation(claim, view, s)
    if claim.kind in ("value", "value_up_to_constant"):
        return _value(claim, view, s)
    measure = claim.measure or ""
    if measure == "constraint":
        return _rows(claim, view, s)
    if measure == "position":
        return _positions(claim, view, s)
    if measure.startswith("conserved:"):
        return _drift(claim, view, s)
    if measure.startswith("trajectory:"):
        return _trajectory(claim, view, s, case)
    raise ValueError(f"claim {claim.id!r}: unknown measure {claim.measure!r}")

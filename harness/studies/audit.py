"""Audit of the seed documents' claims: symbolic against our derivation, numeric against MuJoCo.

Each claim (``analytic/claims``) gets one of three verdicts:

- ``confirmed``: it holds symbolically, and MuJoCo's measurements agree with
  it as closely as with our own derivation;
- ``refuted``: it fails symbolically; the row gives the corrected formula and
  the numbers (MuJoCo's measurement vs the claim) that refute it, and says
  whether the cause is a transcription slip (the display is contradicted by
  the document's next line) or an error of physics/derivation;
- ``ambiguous``: it depends on a convention the document leaves open.

Numerics: the claim's case is run in MuJoCo at its shipped settings and 40
states are sampled; q̈ is MuJoCo's ``qacc`` and λ its ``efc_force`` (or
contact force). A claim "agrees" when its error is within 10× the error of
our own derivation on the same states (plus the neglected order for an
approximation), the floor that MuJoCo's integrator and soft constraints set.
"""

from __future__ import annotations

import functools
import html
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
import sympy as sp

from analytic.claims import Claim
from analytic.claims.documents import all_claims
from analytic.claims.view import T_SYMBOL, DocView, symbolic_check
from harness import cases
from harness.engine.bindings import JointBinding
from harness.engine.constraints import equality_block
from harness.engine.models import compile_model
from harness.reference.derivations import derivation

SAMPLES = 40
AGREEMENT = 10.0


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
class AuditRow:
    claim: Claim
    verdict: str  # confirmed | refuted | ambiguous
    cause: str  # "", "transcription slip", "error"
    symbolic: str  # residual or reason
    corrected: str  # the corrected formula (sympy's plain text), or ""
    corrected_latex: str
    numeric_error: float | None  # claim's relative error vs MuJoCo
    numeric_floor: float | None  # our derivation's relative error on the same states
    numeric_agrees: bool | None
    detail: str


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
def sample(case_name: str, small_motion: float = 1.0, scaled: str = "") -> Samples:
    """Run the case's model and sample SAMPLES states, with MuJoCo's qacc, forces and energies."""
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
    steps = round(case.horizon / model.opt.timestep)
    every = max(1, steps // SAMPLES)
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


def _evaluate(expr: sp.Expr, view: DocView, s: Samples, *, extra: dict | None = None) -> np.ndarray:
    """An expression in the document's variables, evaluated at MuJoCo's sampled states."""
    ours = sp.sympify(expr).subs(view.to_ours, simultaneous=True)
    d = view.derivation
    names = [c.name for c in d.system.q]
    symbols = ([view.ours_q[n] for n in names] + [view.ours_qd[n] for n in names]
               + [view.ours_qdd[n] for n in names] + list(d.multiplier_symbols))
    values = [*s.q.T, *s.qd.T, *s.qdd.T, *s.lam.T]
    params = {p: s.params[p.name] for p in d.system.params}
    for sym, val in (extra or {}).items():
        symbols.append(sym)
        values.append(val)
    fn = sp.lambdify(symbols, ours.subs(params), modules="numpy")
    return np.broadcast_to(np.asarray(fn(*values), dtype=float), s.t.shape).copy()


def _term_scale(expr: sp.Expr, view: DocView, s: Samples) -> float:
    terms = sp.Add.make_args(sp.expand(expr))
    return float(np.max(sum(np.abs(_evaluate(t, view, s)) for t in terms)))


def _equation_floor(view: DocView, s: Samples) -> float:
    eqs = list(view.derivation.equations)
    worst = 0.0
    for eq in eqs:
        doc_eq = view.doc(eq)
        scale = _term_scale(doc_eq, view, s)
        if scale > 0:
            worst = max(worst, float(np.max(np.abs(_evaluate(doc_eq, view, s)))) / scale)
    return worst


def _measured(claim: Claim, view: DocView, s: Samples) -> np.ndarray:
    m = claim.measure
    if m == "kinetic":
        return s.kinetic
    if m == "potential":
        return s.potential
    if m == "lagrangian":
        return s.kinetic - s.potential
    if m and m.startswith("invariant:"):
        return s.invariants[m.split(":", 1)[1]]
    return _evaluate(claim.truth(view), view, s)  # type: ignore[misc]


def numeric_check(claim: Claim, view: DocView) -> tuple[float | None, float | None, str]:
    """(claim's relative error, our derivation's, description) at sampled MuJoCo states."""
    if claim.kind == "statement" and claim.measure is None:
        return None, None, "not a formula about motion: symbolic check only"
    try:
        case = case_for(claim)
    except ValueError as exc:
        return None, None, f"no MuJoCo reading: {exc}"
    scaled = claim.approx_symbol.name if claim.approx_symbol is not None else ""
    s = sample(case.name, claim.small_motion, scaled)
    where = f"{len(s.t)} MuJoCo states of case {case.name!r}"
    if claim.kind == "equation":
        scale = _term_scale(claim.claimed, view, s)
        raw = _evaluate(claim.claimed, view, s)
        err = float(np.max(np.abs(raw))) / scale
        floor = _equation_floor(view, s)
        if claim.manifold:  # MuJoCo's soft constraint leaves the manifold slightly: allow for that
            projected = _evaluate(sp.sympify(claim.claimed).subs(claim.manifold), view, s)
            floor += float(np.max(np.abs(raw - projected))) / scale
        return err, floor, f"max |residual| / max Σ|terms| over {where}"
    if claim.kind in ("value", "value_up_to_constant"):
        measured = _measured(claim, view, s)
        claimed = _evaluate(claim.claimed, view, s)
        truth = _evaluate(view.on_motion(claim.truth(view), claim), view, s)  # type: ignore[misc]
        # a quantity that vanishes on motions (d/dt of a conserved momentum) is measured against its terms
        scale = max(float(np.max(np.abs(measured))), _term_scale(claim.truth(view), view, s), 1e-300)  # type: ignore[misc]
        if claim.kind == "value_up_to_constant":
            err = float(np.ptp(claimed - measured)) / scale
            floor = float(np.ptp(truth - measured)) / scale
        else:
            err = float(np.max(np.abs(claimed - measured))) / scale
            floor = float(np.max(np.abs(truth - measured))) / scale
        source = claim.measure or "our formula with MuJoCo's q̈, λ"
        return err, floor, f"max |claim − MuJoCo ({source})| / max |MuJoCo| over {where}"
    if claim.measure == "constraint":
        scale = _term_scale(claim.claimed, view, s)
        err = float(np.max(np.abs(_evaluate(claim.claimed, view, s)))) / max(scale, 1e-300)
        rows = [view.doc(r) for r in view.derivation.constraint_rows]
        floor = max(float(np.max(np.abs(_evaluate(r, view, s)))) / max(_term_scale(r, view, s), 1e-300)
                    for r in rows)
        return err, floor, f"max |claimed row| / max Σ|terms| (slip) over {where}"
    if claim.measure and claim.measure.startswith("conserved:"):
        values = _evaluate(claim.claimed, view, s)
        reading = s.invariants[claim.measure.split(":", 1)[1]]
        scale = float(np.max(np.abs(reading)))
        return (float(np.ptp(values)) / scale, float(np.ptp(reading)) / scale,
                f"drift (max − min) / max of the claimed quantity vs MuJoCo's own reading over {where}")
    if claim.measure and claim.measure.startswith("trajectory:"):
        coord = claim.measure.split(":", 1)[1]
        k = [c.name for c in view.derivation.system.q].index(coord)
        q0s, v0s = sp.symbols("q0 v0", real=True)
        closed = _evaluate(claim.claimed, view, s, extra={T_SYMBOL: s.t, q0s: s.q[0, k], v0s: s.qd[0, k]})
        ref = case.reference(compile_model(case.mjcf))
        ref_q = ref.solution.state(s.t)[0][:, k]
        amp = float(np.max(np.abs(s.q[:, k])))
        return (float(np.max(np.abs(closed - s.q[:, k]))) / amp, float(np.max(np.abs(ref_q - s.q[:, k]))) / amp,
                f"max |closed form − MuJoCo q(t)| / amplitude over {where}")
    return None, None, "no numeric reading"


def _tolerance(claim: Claim, floor: float, view: DocView) -> float:
    tol = AGREEMENT * floor + 1e-9
    if claim.approx_symbol is not None:
        s = sample(case_for(claim).name, claim.small_motion, claim.approx_symbol.name)
        k = [c.name for c in view.derivation.system.q].index(claim.approx_symbol.name)
        tol += float(np.max(np.abs(s.q[:, k]))) ** 2  # the neglected order, relative
    return tol


def audit_claim(claim: Claim, view: DocView | None = None) -> AuditRow:
    """One claim's row; ``view``, the claim's frame read against our derivation, is built here unless
    given (``audit`` builds one per frame: its symbolic solve costs 0.1-0.2 s)."""
    view = view if view is not None else DocView(derivation(claim.frame.system), claim.frame)
    sym = symbolic_check(claim, view)
    err, floor, detail = numeric_check(claim, view)
    agrees = None if err is None else err <= _tolerance(claim, floor or 0.0, view)
    symbolic = sym.reason or ("identically equal" if sym.holds else f"residual {sp.sstr(sym.residual)}")
    cause, corrected, corrected_latex = "", "", ""
    if sym.holds:
        verdict = "ambiguous" if claim.ambiguity else "confirmed"
    elif claim.ambiguity:
        verdict = "ambiguous"
    else:
        verdict = "refuted"
        cause = "transcription slip" if claim.slip else "error"
        fixed = claim.intended
        if fixed is None and claim.truth is not None:
            fixed = sp.simplify(view.on_motion(claim.truth(view), claim))
        if fixed is not None:
            if claim.intended is not None and not symbolic_check(claim, view, claim.intended).holds:
                raise AssertionError(f"intended formula of {claim.id} does not hold either")
            suffix = " = 0" if claim.kind == "equation" else ""
            corrected, corrected_latex = sp.sstr(fixed) + suffix, sp.latex(fixed) + suffix
    why = claim.ambiguity or claim.slip or claim.note
    return AuditRow(claim=claim, verdict=verdict, cause=cause, symbolic=symbolic, corrected=corrected,
                    corrected_latex=corrected_latex,
                    numeric_error=err, numeric_floor=floor, numeric_agrees=agrees,
                    detail=f"{detail}. {why}".strip())


def audit(claims: Sequence[Claim] | None = None) -> list[AuditRow]:
    views: dict[int, DocView] = {}  # one per frame, shared by its claims
    rows = []
    for c in claims if claims is not None else all_claims():
        if id(c.frame) not in views:
            views[id(c.frame)] = DocView(derivation(c.frame.system), c.frame)
        rows.append(audit_claim(c, views[id(c.frame)]))
    return rows


def consistent(row: AuditRow) -> bool:
    """Symbolic and numeric verdicts tell the same story (a disagreement is a harness defect)."""
    if row.numeric_agrees is None:
        return True
    symbolic_holds = row.verdict != "refuted"
    if row.claim.ambiguity and row.verdict == "ambiguous":
        return True
    if row.claim.numeric_blind:
        return True
    return symbolic_holds == row.numeric_agrees


def _num(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.2e}"


def _why(r: AuditRow) -> str:
    if r.claim.slip:
        return r.claim.slip
    if r.claim.ambiguity:
        return r.claim.ambiguity if r.claim.kind != "statement" else f"{r.claim.ambiguity}: {r.symbolic}"
    return r.claim.note or r.symbolic


def format_table(rows: Sequence[AuditRow]) -> str:
    """Aligned text table, one claim a row, then the reason for every non-confirmed one."""
    head = ("claim", "verdict", "cause", "MuJoCo err", "floor", "agrees")
    body = [(r.claim.id, r.verdict, r.cause or "-", _num(r.numeric_error), _num(r.numeric_floor),
             "-" if r.numeric_agrees is None else ("yes" if r.numeric_agrees else "no")) for r in rows]
    widths = [max(len(x[i]) for x in [head, *body]) for i in range(len(head))]
    lines = ["  ".join(v.ljust(w) for v, w in zip(x, widths, strict=True)).rstrip() for x in [head, *body]]
    lines.append("")
    for r in rows:
        if r.verdict != "confirmed":
            lines.append(f"{r.claim.id} ({r.claim.document}, {r.claim.location}): {r.verdict}"
                         + (f", {r.cause}" if r.cause else ""))
            lines.append(f"    printed:   {r.claim.quote}")
            if r.corrected:
                lines.append(f"    corrected: {r.corrected}")
            lines.append(f"    why:       {_why(r)}")
            if r.numeric_error is not None:
                lines.append(f"    numbers:   claim error {_num(r.numeric_error)} vs our derivation's "
                             f"{_num(r.numeric_floor)} ({r.detail.split('. ')[0]})")
    counts = {v: sum(r.verdict == v for r in rows) for v in ("confirmed", "refuted", "ambiguous")}
    lines.append(", ".join(f"{n} {v}" for v, n in counts.items()))
    return "\n".join(lines)


def html_section(rows: Sequence[AuditRow]) -> str:
    """The audit as an HTML section for the report (formulas as LaTeX source, no network assets)."""
    cells = []
    for r in rows:
        cls = {"confirmed": "pass", "refuted": "fail"}.get(r.verdict, "ambiguous")
        why = _why(r)
        cells.append(
            f"<tr class='{cls}'><td>{html.escape(r.claim.id)}<br><small>{html.escape(r.claim.location)}</small></td>"
            f"<td><code>{html.escape(r.claim.quote)}</code></td><td>{r.verdict}"
            f"{'<br><small>' + r.cause + '</small>' if r.cause else ''}</td>"
            f"<td><code>{html.escape(r.corrected_latex)}</code></td>"
            f"<td>{_num(r.numeric_error)} / {_num(r.numeric_floor)}</td><td>{html.escape(why)}</td></tr>")
    return ("<section id='audit'><h2>Audit of the seed documents</h2><p>Each derived result of the two "
            "lecture notes, checked symbolically against our sympy derivation and numerically against MuJoCo "
            "(claim's relative error / our derivation's on the same MuJoCo states).</p><table><tr><th>claim"
            "</th><th>as printed</th><th>verdict</th><th>corrected</th><th>MuJoCo error / floor</th>"
            f"<th>why</th></tr>{''.join(cells)}</table></section>")


def json_rows(rows: Sequence[AuditRow]) -> dict[str, dict[str, object]]:
    """The verdicts by claim id, for report.json and ``mjharness audit --json``."""
    return {r.claim.id: {"verdict": r.verdict, "cause": r.cause, "document": r.claim.document,
                         "location": r.claim.location, "printed": r.claim.quote, "corrected": r.corrected,
                         "numeric_error": r.numeric_error, "numeric_floor": r.numeric_floor,
                         "why": _why(r)} for r in rows}

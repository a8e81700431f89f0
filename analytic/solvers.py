"""Our reference integrators: index-reduced DAE with stabilization, and plain ODE.

A constrained system is integrated as the index-1 form (q̈, λ from the KKT
system at every right-hand-side call) with Baumgarte stabilization
γ ← γ − 2ω(Jq̇ + b) − ω²f(q): on the constraint manifold these terms vanish,
off it they pull drift back with time constant 1/ω instead of letting it grow.
The residuals f(q) and Jq̇ + b are reported at every output time, so the
quality of the reference is a measured figure, not an assumption.

An unconstrained (minimal-coordinate) system goes through the same code with
no constraint rows, which makes it a plain ODE.

Both are integrated by our DOP853 (:mod:`analytic.dop853`, order 8, 7th-order
dense output): one solve serves every timestep, integrator and setting a study
asks for. A stiff motion (a fast decaying mode, e.g. joint damping on a light
link, bounds an explicit method's step by stability, not accuracy) can be
handed to our Radau IIA (:mod:`analytic.radau`, L-stable, order 5) instead:
the same index-1 ODE with the same stabilization, so the constraint residuals
and every figure read from the solution mean the same. Its Newton iteration's
Jacobian (:func:`state_jacobian`) is exact for the tree reference.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from analytic import dop853, dual, radau
from analytic.dynamics import Array, Dynamics, chunk_states

__all__ = ["DEFAULT_RTOL", "STABILITY", "STIFF_RTOL", "Solution", "TooManySteps", "TooSlow", "explicit_steps",
           "project", "solve", "state_jacobian"]

DEFAULT_RTOL = 1e-12
DEFAULT_ATOL = 1e-12
STIFF_RTOL = 1e-8
"""The loosest tolerance a solve handed to Radau IIA is made to (rtol and atol): Radau's steps grow as rtol^(-1/4)
(its error estimate is O(h⁴)), so 1e-12 on a robot's 1 s of motion takes it 5e4 steps. What the trajectory budget
must resolve is MuJoCo's own integration error at the model's step, which the reference's allowance
(harness.budget.reference.REFERENCE × rtol × the size) must stay below: this is the first tolerance, and a check
solves again at the tighter one its budgets derive (``solve(stiff_rtol=…)``, harness.budget.reference.reference_rtol;
docs/findings/bases.md, STIFF_RTOL and REFERENCE_SHARE)."""


@dataclass(frozen=True)
class Solution:
    """A dense reference solution: evaluate anywhere in [0, t_end]."""

    dynamics: Dynamics
    t_end: float
    rtol: float
    nfev: int
    _dense: dop853.Dense | radau.Dense
    method: str = "DOP853"
    why: str = ""
    """``method``: the integrator that solved it (DOP853 or Radau IIA); ``why``: the reason, where Radau IIA
    was chosen."""

    def state(self, t: Array | Sequence[float]) -> tuple[Array, Array]:
        """q and q̇ at times t, shapes (N, n)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if t.min() < -1e-12 or t.max() > self.t_end * (1 + 1e-12) + 1e-12:
            raise ValueError(f"t must lie in [0, {self.t_end}], got [{t.min()}, {t.max()}]")
        y = self._dense(np.clip(t, 0.0, self.t_end))
        n = self.dynamics.n
        return y[:, :n], y[:, n:]

    def multipliers(self, t: Array | Sequence[float]) -> Array:
        """λ at times t, shape (N, m), from the KKT system at the dense state."""
        q, qd = self.state(t)
        return self.dynamics.accelerations(q, qd)[1]

    def residuals(self, t: Array) -> tuple[Array, Array]:
        """Constraint residuals f(q) and Jq̇ + b at times t, each (N, m)."""
        q, qd = self.state(t)
        return self.dynamics.position_residual(q), self.dynamics.velocity_residual(q, qd)


def solve(
    dynamics: Dynamics,
    *,
    q0: Array,
    qd0: Array,
    t_end: float,
    rtol: float = DEFAULT_RTOL,
    atol: float = DEFAULT_ATOL,
    stabilization_rate: float = 10.0,
    max_steps: int = dop853.MAX_STEPS,
    stiff: bool = False,
    reach: bool = False,
    cpu_seconds: float | None = None,
    stiff_rtol: float = STIFF_RTOL,
) -> Solution:
    """Integrate from (q0, q̇0) over [0, t_end] with dense output.

    Raises ValueError if the initial state violates a constraint (a
    reference must start on the manifold MuJoCo starts on), or if an
    argument is out of range; :class:`~analytic.dop853.IntegrationError` where
    the solver cannot go on, and :class:`TooManySteps` at once (after at most
    :data:`TRIAL_STEPS` steps) where the solve would take more than ``max_steps``
    steps, with the estimate.

    ``stiff``: where stability alone would take DOP853 more than :data:`TRIAL_STEPS` steps at the start
    (:func:`explicit_steps`: its step is then set by a fast decaying mode, not by the motion's accuracy; every
    shipped reference takes fewer), or where its first steps estimate more than ``max_steps``, the motion is
    handed to Radau IIA (to ``stiff_rtol``, by default :data:`STIFF_RTOL`, at the loosest), judged by its own
    first steps against the same bound, before it is refused (:class:`TooManySteps` then gives both estimates).

    ``reach``: solve only as far as ``max_steps`` steps go (``Solution.t_end`` the time reached, at most
    ``t_end``), by the solver the start chooses, instead of refusing a longer solve: a span bounded by its cost.
    ``cpu_seconds``: :class:`TooSlow` once the solve has used that much of the process's CPU time, with how far
    it got (a bound on a solve whose first steps cannot tell its cost: a large stiff tree's Jacobians).
    """
    q0 = np.asarray(q0, dtype=float)
    qd0 = np.asarray(qd0, dtype=float)
    if q0.shape != (dynamics.n,) or qd0.shape != (dynamics.n,):
        raise ValueError(f"q0 and qd0 must have shape ({dynamics.n},), got {q0.shape}, {qd0.shape}")
    if not t_end > 0:
        raise ValueError(f"t_end must be positive, got {t_end}")
    if not 0 < rtol <= 1e-6:
        raise ValueError(f"rtol must be in (0, 1e-6], got {rtol}")
    if not 0 < stiff_rtol <= 1e-6:
        raise ValueError(f"stiff_rtol must be in (0, 1e-6], got {stiff_rtol}")
    _check_consistent(dynamics, q0, qd0)

    omega = float(stabilization_rate)
    stab = (2.0 * omega, omega * omega)
    n = dynamics.n

    started, reached = time.process_time(), [0.0]

    def rhs(t: float | Array, y: Array) -> Array:  # also a batch: y of shape (k, 2n)
        if cpu_seconds is not None:
            reached[0] = max(reached[0], float(np.max(t)))
            if time.process_time() - started > cpu_seconds:
                raise TooSlow(cpu_seconds, reached[0], float(t_end))
        qdd, _ = dynamics.accelerations(y[..., :n], y[..., n:], stabilization=stab)
        return np.concatenate([y[..., n:], qdd], axis=-1)

    y0 = np.concatenate([q0, qd0])
    if stiff:  # the criterion: stability alone sets DOP853's step (more than its trial's steps): Radau IIA at once
        steps, radius = explicit_steps(dynamics, rhs, y0, float(t_end), atol_over_rtol=atol / rtol)
        if steps > min(max_steps, TRIAL_STEPS):
            return _solve_stiff(dynamics, rhs, y0, t_end=float(t_end), rtol=max(rtol, stiff_rtol),
                                atol=max(atol, stiff_rtol), max_steps=max_steps, explicit=None, radius=radius,
                                reach=reach)
    if reach:
        result = dop853.integrate(rhs, float(t_end), y0, rtol=rtol, atol=atol, max_steps=max_steps, reach=True)
        return Solution(dynamics=dynamics, t_end=_reached(result.dense, float(t_end)), rtol=rtol, nfev=result.nfev,
                        _dense=result.dense)
    trial = min(TRIAL_STEPS, max_steps)
    clock = time.perf_counter()
    try:
        result = dop853.integrate(rhs, float(t_end), y0, rtol=rtol, atol=atol, max_steps=trial)
    except dop853.StepBudgetExceeded as exc:
        estimate = trial * t_end / max(exc.t, 1e-300)
        too_many = TooManySteps(estimate, max_steps, trial, exc.t, float(t_end), time.perf_counter() - clock)
        if estimate <= max_steps and trial < max_steps:
            result = dop853.integrate(rhs, float(t_end), y0, rtol=rtol, atol=atol, max_steps=max_steps)
        elif stiff:
            return _solve_stiff(dynamics, rhs, y0, t_end=float(t_end), rtol=max(rtol, stiff_rtol),
                                atol=max(atol, stiff_rtol), max_steps=max_steps, explicit=too_many)
        else:
            raise too_many from None
    return Solution(dynamics=dynamics, t_end=float(t_end), rtol=rtol, nfev=result.nfev, _dense=result.dense)


def state_jacobian(dynamics: Dynamics, rhs: dop853.RightHandSide, t: float, y: Array, f: Array, *,
                   atol_over_rtol: float = 1.0, differences: bool = False) -> Array:
    """∂f/∂y of the first-order form f(y) = (q̇, q̈(q, q̇)), every column in one batch.

    Where the dynamics takes dual-number states (:attr:`Dynamics.dual_states`: the tree reference), every column
    is exact to round-off: ``rhs`` (built on the dynamics, as :func:`solve` builds it) runs once on the batch of
    dual numbers y + ε e_j (:mod:`analytic.dual`), and the tangent of its j-th result is column j. ε is a second
    infinitesimal beside the complex step i the tree's equations take their own q-derivatives with (Ṁq̇, ∂L/∂q,
    J̇q̇), which a complex step could not be nested into; the KKT solve is differentiated as a solve
    (:func:`analytic.dynamics.kkt_tangent`, exact where the constraints' rank is locally constant); a clamp
    (an actuator's force range) has the slope of the branch it is on.

    Forward differences are left only where the dynamics cannot take dual numbers (the derived systems, whose code
    is compiled for floats), or with ``differences`` (the former path, a baseline for benchmarks and tests): every
    column (f(y + δe_j) − f(y))/δ, step √ε × max(|y_j|, atol/rtol), except the velocity columns where
    :attr:`Dynamics.velocity_polynomial` (q̈ at fixed q a polynomial of degree ≤ 3 in q̇): the five-point derivative
    (f(−2δ) − 8f(−δ) + 8f(δ) − f(2δ))/12δ, exact for degree ≤ 4 whatever δ, so δ is the velocity's own size."""
    if dynamics.dual_states and not differences:  # the columns in chunks (analytic.dynamics.chunk_states)
        eye, per = np.eye(y.size), chunk_states(dynamics.n)
        on_duals: Callable[[float, Any], Any] = rhs  # dual numbers, where dynamics.dual_states (its type: arrays)
        return np.concatenate([np.asarray(dual.tangent(on_duals(t, dual.seeded(y, eye[j:j + per]))))
                               for j in range(0, y.size, per)]).T.copy()
    n = y.size // 2
    eps = np.finfo(float).eps
    exact = dynamics.velocity_polynomial
    columns = range(n) if exact else range(2 * n)
    delta = np.sqrt(eps) * np.maximum(np.abs(y), atol_over_rtol)
    delta = (y + delta) - y
    states = [y + delta[j] * np.eye(2 * n)[j] for j in columns]
    if exact:
        size = max(float(np.sqrt(np.mean(y[n:] ** 2))), float(np.max(np.abs(y[n:]), initial=0.0)), 1e-3)
        for j in range(n):
            for k in (-2.0, -1.0, 1.0, 2.0):
                states.append(y + k * size * np.eye(2 * n)[n + j])
    values = rhs(t, np.array(states))
    out = np.empty((y.size, y.size))
    for i, j in enumerate(columns):
        out[:, j] = (values[i] - f) / delta[j]
    if exact:
        stencil = values[len(columns):].reshape(n, 4, y.size)
        out[:, n:] = ((stencil[:, 0] - 8.0 * stencil[:, 1] + 8.0 * stencil[:, 2] - stencil[:, 3]) / (12.0 * size)).T
    return out


STABILITY = 6.39
"""DOP853's stability interval on the negative real axis, [−6.39, 0] (|R(z)| ≤ 1 of its stability function, from
its table: tests/test_stiff_reference.py): a mode decaying at rate r bounds its step to 6.39/r, whatever the
tolerance."""


def explicit_steps(dynamics: Dynamics, rhs: dop853.RightHandSide, y0: Array, t_end: float, *,
                   atol_over_rtol: float = 1.0) -> tuple[float, float]:
    """The fewest steps DOP853 can take over ``t_end`` by stability alone, t_end · ρ / :data:`STABILITY` with ρ the
    spectral radius of the linearization at the start (:func:`state_jacobian`), and ρ."""
    jac = state_jacobian(dynamics, rhs, 0.0, y0, rhs(0.0, y0), atol_over_rtol=atol_over_rtol)
    radius = float(np.max(np.abs(np.linalg.eigvals(jac))))
    return t_end * radius / STABILITY, radius


def _solve_stiff(dynamics: Dynamics, rhs: dop853.RightHandSide, y0: Array, *, t_end: float, rtol: float,
                 atol: float, max_steps: int, explicit: TooManySteps | None, radius: float | None = None,
                 reach: bool = False) -> Solution:
    """The solve by Radau IIA, chosen because DOP853 would take more than ``max_steps`` steps: by its first steps
    (``explicit``), or (``explicit`` None) by stability alone at the start's spectral radius ``radius``
    (:func:`explicit_steps`). Its own first :data:`TRIAL_STEPS` steps judge its length against ``max_steps``
    as DOP853's did; ``reach``: as far as ``max_steps`` steps go (:func:`solve`). ``rtol``, ``atol``: Radau's
    own (:func:`solve` raises them to its ``stiff_rtol``)."""

    def jacobian(t: float, y: Array, f: Array) -> Array:
        return state_jacobian(dynamics, rhs, t, y, f, atol_over_rtol=atol / rtol)

    if explicit is None:
        assert radius is not None  # the caller gives the radius where DOP853 took no steps
        why = (f"stiff (rtol {rtol:g}): DOP853 would take at least {t_end * radius / STABILITY:.2g} steps by "
               f"stability alone (the linearization's fastest mode decays at {radius:.2g}/s, which bounds its step "
               f"to {STABILITY:g} over that)")
        explicit = TooManySteps(t_end * radius / STABILITY, max_steps, 0, 0.0, t_end, 0.0)
    else:
        fastest = float(np.max(np.abs(np.linalg.eigvals(jacobian(0.0, y0, rhs(0.0, y0))))))
        why = (f"stiff (rtol {rtol:g}): DOP853 would take about {explicit.estimate:.2g} steps (its stability bounds "
               f"the step: the fastest mode decays at {fastest:.2g}/s)")
    if reach:
        try:
            result, end = radau.integrate(rhs, t_end, y0, rtol=rtol, atol=atol, max_steps=max_steps, jac=jacobian,
                                          vectorized=True), t_end
        except radau.StepsTaken as exc:
            result, end = exc.partial, exc.t
        return Solution(dynamics=dynamics, t_end=end, rtol=rtol, nfev=result.nfev, _dense=result.dense,
                        method="Radau IIA", why=why)
    trial = min(TRIAL_STEPS, max_steps)
    clock = time.perf_counter()
    try:
        result = radau.integrate(rhs, t_end, y0, rtol=rtol, atol=atol, max_steps=trial, jac=jacobian,
                                 vectorized=True)
    except radau.StepsTaken as exc:  # judged by the step it reached: its first steps resolve a transient
        estimate = trial + (t_end - exc.t) / exc.h
        if estimate > max_steps or trial == max_steps:
            raise TooManySteps(estimate, max_steps, trial, exc.t, t_end, time.perf_counter() - clock,
                               solver=f"Radau IIA (after DOP853: {explicit})") from None
        try:  # on from where the trial stopped
            rest = radau.integrate(rhs, t_end, exc.y, rtol=rtol, atol=atol, max_steps=max_steps - trial,
                                   jac=jacobian, vectorized=True, t0=exc.t, first_step=exc.h)
        except dop853.StepBudgetExceeded as over:
            raise TooManySteps(max_steps, max_steps, trial, over.t, t_end, time.perf_counter() - clock,
                               solver=f"Radau IIA (after DOP853: {explicit})") from None
        result = radau.joined(exc.partial, rest)
    return Solution(dynamics=dynamics, t_end=t_end, rtol=rtol, nfev=result.nfev, _dense=result.dense,
                    method="Radau IIA", why=why)


def _reached(dense: dop853.Dense, t_end: float) -> float:
    """Where a solve's steps ended: ``t_end``, or short of it where its step budget ran out first."""
    return min(t_end, float(dense.t_start[-1] + dense.h[-1])) if len(dense.h) else 0.0


TRIAL_STEPS = 500
"""The steps a solve takes before it judges its length: twice those of the longest shipped reference
(docs/findings/bases.md, TRIAL_STEPS), so a shipped case is solved in one go; where they cover only part of the
span, the whole is estimated as proportional to the time they covered."""


class TooSlow(dop853.IntegrationError):
    """A solve stopped once it had used its ``seconds`` of CPU, at ``reached`` of ``t_end``."""

    def __init__(self, seconds: float, reached: float, t_end: float) -> None:
        self.seconds, self.reached, self.t_end = float(seconds), float(reached), float(t_end)
        whole = seconds * t_end / reached if reached > 0 else float("inf")
        super().__init__(f"it used {seconds:.3g} s of CPU to cover {reached:.3g} s of {t_end:g} s (about "
                         f"{whole / 60:.2g} min for the whole span at that rate)")

    def __reduce__(self):  # pickled with its parts (a worker sends it to the parent)
        return (type(self), (self.seconds, self.reached, self.t_end))


class TooManySteps(dop853.IntegrationError):
    """A solve estimated, after its first steps, to need more than its bound: refused before it is made."""

    def __init__(self, estimate: float, bound: int, trial: int, reached: float, t_end: float,
                 seconds: float, solver: str = "") -> None:
        self.estimate, self.bound, self.trial, self.reached, self.t_end, self.seconds, self.solver = (
            float(estimate), int(bound), int(trial), float(reached), float(t_end), float(seconds), solver)
        hours = seconds * estimate / max(trial, 1) / 3600.0
        which = f"the reference's solver, {solver}" if solver else "the reference's solver"
        basis = (f"{trial} steps covered {reached:.3g} s of {t_end:g} s, in {seconds:.2g} s: about {hours:.2g} h in "
                 "all" if trial else "by stability alone, at the start's fastest mode")
        super().__init__(f"it would take about {estimate:.2g} steps of {which} ({basis}), more than the bound of "
                         f"{bound:g}")

    def __reduce__(self):  # pickled with its parts (a worker sends it to the parent)
        return (type(self), (self.estimate, self.bound, self.trial, self.reached, self.t_end, self.seconds,
                             self.solver))


def _check_consistent(dynamics: Dynamics, q0: Array, qd0: Array, tol: float = 1e-9) -> None:
    pos = dynamics.position_residual(q0)
    vel = dynamics.velocity_residual(q0, qd0)
    bad = [(name, p, v) for name, p, v in zip(dynamics.row_labels, pos, vel, strict=True)
           if abs(p) > tol or abs(v) > tol]
    if bad:
        detail = ", ".join(f"{n}: f={p:.3g}, Jq̇+b={v:.3g}" for n, p, v in bad)
        raise ValueError(f"initial state violates constraints ({detail}); give q0, qd0 on the manifold")


def project(dynamics: Dynamics, q0: Array, qd0: Array, *, tol: float = 1e-13, iterations: int = 50,
            polish: bool = False) -> tuple[Array, Array]:
    """The state on the constraint manifold nearest (q0, q̇0): q by Gauss-Newton, each step the
    smallest change Δq with J Δq = −f(q) (so a coordinate the constraints do not involve keeps its
    value: a pendulum's angle stays, its radius becomes the rod's length), then q̇ less its
    smallest change that makes J q̇ + b = 0 (exact in one step: the rows are linear in q̇). A state
    already on the manifold (to ``tol``) is returned unchanged.

    "Smallest" is in the coordinates' own units (the Euclidean norm of Δq), which is what a user who
    wrote the state in those coordinates means by "nearest". ValueError where the constraints cannot
    be met from (q0, q̇0) within ``iterations`` steps. ``polish`` goes on past ``tol`` while the
    residual still falls (to round-off), for states whose every last bit of violation matters.
    """
    q = np.array(q0, dtype=float)
    qd = np.array(qd0, dtype=float)
    if dynamics.rows == 0:
        return q, qd
    for _ in range(iterations):
        residual = dynamics.position_residual(q)
        if np.max(np.abs(residual)) <= tol * max(1.0, float(np.max(np.abs(q)))):
            break
        q = q - np.linalg.lstsq(dynamics.jacobian(q), residual, rcond=None)[0]
    else:
        raise ValueError(f"the initial state cannot be brought onto the constraints (residual "
                         f"{np.max(np.abs(dynamics.position_residual(q))):.3g} after {iterations} steps)")
    for _ in range(4 if polish else 0):
        step = q - np.linalg.lstsq(dynamics.jacobian(q), dynamics.position_residual(q), rcond=None)[0]
        if not np.max(np.abs(dynamics.position_residual(step))) < np.max(np.abs(dynamics.position_residual(q))):
            break
        q = step
    velocity = dynamics.velocity_residual(q, qd)
    if np.max(np.abs(velocity)) > tol * max(1.0, float(np.max(np.abs(qd)))):
        qd = qd - np.linalg.lstsq(dynamics.jacobian(q), velocity, rcond=None)[0]
        if polish:
            qd = qd - np.linalg.lstsq(dynamics.jacobian(q), dynamics.velocity_residual(q, qd), rcond=None)[0]
    return q, qd

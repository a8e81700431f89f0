"""RADAU5: our implicit Runge–Kutta integrator (Radau IIA, order 5) for stiff motions.

An explicit method such as DOP853 needs |h λ| within its stability region for
every eigenvalue λ of the right-hand side's Jacobian, so a fast decaying mode
(joint damping on a light link: c/I far above the motion's own rates) bounds
its step however smooth the motion is. Radau IIA is L-stable: its step is set
by the accuracy of the motion alone. The method follows Hairer & Wanner,
*Solving ODEs II*, §IV.8 and their ``radau5.f`` (as scipy's ``Radau`` does):

- a step solves the three-stage collocation system Z = h (A ⊗ I) F(y + Z) at
  the Radau nodes c = ((4 − √6)/10, (4 + √6)/10, 1) by simplified Newton, with
  A⁻¹ brought to block-diagonal form T⁻¹ A⁻¹ T = diag(γ, [[α, β], [−β, α]]):
  one real system (γ/h − J) and one complex one ((α − iβ)/h − J) per Jacobian
  and step size, reused while the iteration converges fast;
- the Jacobian J as the caller gives it (the tree reference's is exact, by dual
  numbers over its complex steps: :func:`analytic.solvers.state_jacobian`), else
  by forward differences (:func:`fd_jacobian`);
- the error is the embedded third-order estimate filtered through
  (γ/h − J)⁻¹ (so it stays bounded on stiff components), each component scaled
  by atol + rtol·max(|y|, |y_new|); a step is kept when its RMS is below 1;
- the next step follows Gustafsson's predictive controller, damped by how many
  Newton iterations the step took;
- the dense output is the collocation polynomial of each step (degree 3 through
  y at the start and the three stages). Its error is of the order of the
  controlled third-order estimate, i.e. of the tolerance (tests/test_radau.py
  measures it against DOP853).

No scipy at run time: the constants are derived here from the nodes, and the
linear systems are solved by inverting the two iteration matrices once each
(the state has at most a few hundred components).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from analytic.dop853 import IntegrationError, Piecewise, StepBudgetExceeded

__all__ = ["Dense", "StepsTaken", "integrate", "joined"]

Array = np.ndarray

MAX_STEPS = 1_000_000
NEWTON_MAXITER = 6  # Hairer's NIT: a step whose Newton iteration has not converged by then is retried smaller
MIN_FACTOR = 0.2  # a rejected step shrinks at most 5×
MAX_FACTOR = 10.0  # an accepted one grows at most 10×
SAFETY = 0.9
ERROR_EXPONENT = -0.25  # the estimate is O(h⁴)

_S6 = 6.0 ** 0.5
C = np.array([(4.0 - _S6) / 10.0, (4.0 + _S6) / 10.0, 1.0])
"""The Radau IIA nodes: the zeros of the Radau polynomial of degree 3 on [0, 1]."""
E = np.array([-13.0 - 7.0 * _S6, -13.0 + 7.0 * _S6, -1.0]) / 3.0
"""Weights of the embedded error estimate (Hairer & Wanner IV.8, (8.19)), in units of γ₀ = 1/γ."""


def collocation_matrix(c: Array) -> Array:
    """A with A_ij = ∫₀^{c_i} ℓ_j(s) ds, ℓ_j the Lagrange polynomial of node j: the collocation method's
    Butcher matrix."""
    powers = np.arange(len(c))
    lagrange = np.linalg.inv(c[:, None] ** powers)  # ℓ_j(s) = Σ_k lagrange[k, j] s^k
    return (c[:, None] ** (powers + 1) / (powers + 1)) @ lagrange


def _transformation(a: Array) -> tuple[float, complex, Array, Array]:
    """γ, μ = α − iβ and T, T⁻¹ with T⁻¹ A⁻¹ T = diag(γ, [[α, β], [−β, α]]): A⁻¹'s real eigenvalue, the
    conjugate of its complex one, and the eigenvectors (real; real and imaginary parts of the complex one)."""
    values, vectors = np.linalg.eig(np.linalg.inv(a))
    real = int(np.argmin(np.abs(values.imag)))
    pair = int(np.argmax(values.imag))
    t = np.column_stack([vectors[:, real].real, vectors[:, pair].real, vectors[:, pair].imag])
    return float(values[real].real), complex(np.conj(values[pair])), t, np.linalg.inv(t)


A = collocation_matrix(C)
GAMMA, MU, T, TI = _transformation(A)
_TI_REAL = TI[0]
_TI_COMPLEX = TI[1] + 1j * TI[2]
_DENSE = np.linalg.inv(C[:, None] ** np.arange(1, 4))
"""u(θ) = Σ_k q_k θ^k (k = 1..3) through u(c_i) = Z_i: q = _DENSE @ Z."""


@dataclass(frozen=True)
class Dense(Piecewise):
    """The continuous solution: per step the three coefficient vectors of its collocation polynomial;
    called as :class:`analytic.dop853.Dense` is."""

    def __call__(self, t: Array) -> Array:
        """y at times ``t`` (1-d, within [t_start[0], t_end]), shape (len(t), n): with θ = (t − t_i)/h_i in
        step i, y = y_i + θ(q₁ + θ(q₂ + θ q₃))."""
        step, theta = self._steps(t)
        q = self.coeffs[step]
        return self.y_start[step] + theta * (q[:, 0] + theta * (q[:, 1] + theta * q[:, 2]))


@dataclass(frozen=True)
class Result:
    dense: Dense
    nfev: int
    njev: int
    steps: int
    rejected: int


RightHandSide = Callable[[float, Array], Array]
Jacobian = Callable[[float, Array, Array], Array]


def _rms(x: Array) -> float:
    return float(np.sqrt(np.mean(x * x)))


def fd_jacobian(fun: RightHandSide, t: float, y: Array, f: Array, *, atol_over_rtol: float = 1.0) -> Array:
    """∂f/∂y by forward differences, column by column, each step √ε × max(|y_j|, atol/rtol) rounded to
    a representable one. ``fun`` is called once per column."""
    delta = np.sqrt(np.finfo(float).eps) * np.maximum(np.abs(y), atol_over_rtol)
    delta = (y + delta) - y
    out = np.empty((y.size, y.size))
    for j in range(y.size):
        moved = y.copy()
        moved[j] += delta[j]
        out[:, j] = (np.asarray(fun(t, moved)) - f) / delta[j]
    return out


def _initial_step(fun: RightHandSide, y: Array, f: Array, t_end: float, rtol: float, atol: float) -> float:
    """Hairer's starting step (Solving ODEs I, §II.4) for an error of order h⁴."""
    scale = atol + np.abs(y) * rtol
    d0, d1 = _rms(y / scale), _rms(f / scale)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, t_end)
    d2 = _rms((np.asarray(fun(h0, y + h0 * f)) - f) / scale) / h0
    h1 = max(1e-6, h0 * 1e-3) if max(d1, d2) <= 1e-15 else (0.01 / max(d1, d2)) ** 0.25
    return min(100.0 * h0, h1, t_end)


@dataclass(frozen=True)
class _Newton:
    converged: bool
    iterations: int
    z: Array
    rate: float


def _newton(stages: Callable[[Array, Array], Array], t: float, y: Array, h: float, z0: Array, scale: Array,
            tol: float, inv_real: Array, inv_complex: Array) -> _Newton:
    """The collocation system solved by simplified Newton in the transformed variables W = T⁻¹ Z, stopped
    when the predicted remaining error rate/(1 − rate)·‖ΔW‖ is below ``tol``, abandoned when it diverges or
    would not get there within :data:`NEWTON_MAXITER` iterations."""
    w = TI @ z0
    z = z0
    m_real, m_complex = GAMMA / h, MU / h
    rate, previous = 1.0, None
    for k in range(NEWTON_MAXITER):
        f = stages(t + C * h, y + z)
        if not np.all(np.isfinite(f)):
            return _Newton(False, k + 1, z, rate)
        dw_real = inv_real @ (_TI_REAL @ f - m_real * w[0])
        dw_complex = inv_complex @ (_TI_COMPLEX @ f - m_complex * (w[1] + 1j * w[2]))
        dw = np.stack([dw_real, dw_complex.real, dw_complex.imag])
        norm = _rms(dw / scale)
        if previous is not None:
            rate = norm / previous
            if rate >= 1.0 or rate ** (NEWTON_MAXITER - k) / (1.0 - rate) * norm > tol:
                return _Newton(False, k + 1, z, rate)
        w = w + dw
        z = T @ w
        if norm == 0.0 or (previous is not None and rate / (1.0 - rate) * norm < tol):
            return _Newton(True, k + 1, z, rate)
        previous = norm
    return _Newton(False, NEWTON_MAXITER, z, rate)


def _factor(h: float, h_old: float | None, err: float, err_old: float | None) -> float:
    """Gustafsson's predictive step factor (Hairer & Wanner IV.8, (8.25)), before safety and bounds."""
    if err == 0.0:
        return MAX_FACTOR
    multiplier = 1.0 if h_old is None or err_old is None else h / h_old * (err_old / err) ** 0.25
    return min(1.0, multiplier) * err ** ERROR_EXPONENT


def integrate(fun: RightHandSide, t_end: float, y0: Array, *, rtol: float, atol: float,
              max_steps: int = MAX_STEPS, jac: Jacobian | None = None, vectorized: bool = False,
              first_step: float | None = None, t0: float = 0.0) -> Result:
    """Integrate y' = fun(t, y) from y(t0) = y0 to t_end > t0 with dense output.

    ``jac(t, y, f)``: ∂f/∂y at (t, y) (default: :func:`fd_jacobian`). ``vectorized``: ``fun`` also takes
    times of shape (k,) with states (k, n) and returns (k, n), so the three stages are one call.
    ``first_step``: the first step to try (default: Hairer's estimate from the start's derivatives).
    Raises IntegrationError (naming the time) when the step size falls below ten units in the last place
    of t, and :class:`StepsTaken` (a :class:`~analytic.dop853.StepBudgetExceeded`, with the solution so far)
    after ``max_steps`` steps.
    """
    if not t_end > t0:
        raise ValueError(f"t_end must be positive, got {t_end}" if t0 == 0 else f"t_end must exceed t0 = {t0}")
    if not (rtol > 0 and atol > 0):
        raise ValueError(f"rtol and atol must be positive, got {rtol}, {atol}")
    y = np.array(y0, dtype=float)
    n = y.size
    count = {"f": 0, "j": 0}

    def one(t: float, state: Array) -> Array:
        count["f"] += 1
        return np.asarray(fun(t, state), dtype=float)

    def stages(times: Array, states: Array) -> Array:
        count["f"] += len(times)
        if vectorized:
            every: Callable[..., Array] = fun  # it takes every stage's time at once (its type names one time)
            return np.asarray(every(times, states), dtype=float)
        return np.array([fun(float(s), states[i]) for i, s in enumerate(times)], dtype=float)

    def jacobian(t: float, state: Array, f: Array) -> Array:
        count["j"] += 1
        if jac is not None:
            return np.asarray(jac(t, state, f), dtype=float)
        return fd_jacobian(one, t, state, f, atol_over_rtol=atol / rtol)

    t = float(t0)
    f = one(t, y)
    if not np.all(np.isfinite(f)):
        raise IntegrationError(f"the right-hand side is not finite at t = {t:g}")
    span = t_end - t
    h = _initial_step(one, y, f, span, rtol, atol) if first_step is None else min(float(first_step), span)
    newton_tol = max(10.0 * np.finfo(float).eps / rtol, min(0.03, rtol ** 0.5))
    eye = np.eye(n)
    jmat = jacobian(t, y, f)
    current = True
    inv_real = inv_complex = None
    h_old = err_old = None
    previous: tuple[float, float, Array] | None = None  # the last step's (t, h, coefficients), to predict Z
    rejected = 0
    t_starts: list[float]
    hs: list[float]
    y_starts: list[Array]
    coeffs: list[Array]
    t_starts, hs, y_starts, coeffs = [], [], [], []
    def solved() -> Result:
        dense = Dense(t_start=np.array(t_starts), h=np.array(hs), y_start=np.array(y_starts),
                      coeffs=np.array(coeffs))
        return Result(dense=dense, nfev=count["f"], njev=count["j"], steps=len(hs), rejected=rejected)

    while t < t_end:
        if len(hs) >= max_steps:
            raise StepsTaken(max_steps, t, t_end, y=y, h=h, partial=solved())
        min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
        failed = False
        while True:
            if h < min_step:
                raise IntegrationError(f"step size fell below {min_step:.3g} at t = {t:.6g}")
            t_new = t + h
            if t_new >= t_end or t_end - t_new < min_step:
                t_new = t_end
            h = t_new - t
            if previous is None:
                z0 = np.zeros((3, n))
            else:
                t_p, h_p, q_p = previous
                theta = (t + C * h - t_p) / h_p
                z0 = (theta[:, None] * (q_p[0] + theta[:, None] * (q_p[1] + theta[:, None] * q_p[2]))
                      + y_starts[-1] - y)
            scale = atol + np.abs(y) * rtol
            while True:
                if inv_real is None or inv_complex is None:  # both set, or both cleared, together
                    inv_real = np.linalg.inv(GAMMA / h * eye - jmat)
                    inv_complex = np.linalg.inv(MU / h * eye - jmat)
                result = _newton(stages, t, y, h, z0, scale, newton_tol, inv_real, inv_complex)
                if result.converged or current:
                    break
                jmat, current = jacobian(t, y, f), True
                inv_real = inv_complex = None
            if not result.converged:
                h *= 0.5
                inv_real = inv_complex = None
                continue
            z = result.z
            y_new = y + z[-1]
            ze = (E @ z) / h
            error = inv_real @ (f + ze)
            scale = atol + rtol * np.maximum(np.abs(y), np.abs(y_new))
            err = _rms(error / scale)
            safety = SAFETY * (2 * NEWTON_MAXITER + 1) / (2 * NEWTON_MAXITER + result.iterations)
            if failed and err >= 1.0:  # Hairer's second estimate after a rejection: one more filtering pass
                err = _rms(inv_real @ (one(t, y + error) + ze) / scale)
            if err < 1.0:  # False for a NaN: a non-finite step is rejected and shrinks
                break
            failed = True
            rejected += 1
            factor = _factor(h, h_old, err, err_old) if np.isfinite(err) else MIN_FACTOR
            h *= max(MIN_FACTOR, safety * factor)
            inv_real = inv_complex = None
        recompute = result.iterations > 2 and result.rate > 1e-3
        factor = min(MAX_FACTOR, safety * _factor(h, h_old, err, err_old))
        if not recompute and factor < 1.2:
            factor = 1.0
        else:
            inv_real = inv_complex = None
        q = _DENSE @ z
        t_starts.append(t)
        hs.append(h)
        y_starts.append(y)
        coeffs.append(q)
        previous = (t, h, q)
        f_new = one(t_new, y_new)
        if recompute:
            jmat, current = jacobian(t_new, y_new, f_new), True
        else:
            current = False
        h_old, err_old = h, err
        t, y, f = t_new, y_new, f_new
        h *= factor
    return solved()


class StepsTaken(StepBudgetExceeded):
    """The step budget ran out at ``t``: the solution so far (``partial``), the state ``y`` there and the step
    ``h`` it would try next, so that a solve judged long enough goes on from there (:func:`joined`)."""

    def __init__(self, steps: int, t: float, t_end: float, *, y: Array, h: float, partial: Result) -> None:
        super().__init__(steps, t, t_end)
        self.y, self.h, self.partial = y, float(h), partial

    def __reduce__(self):  # pickled as the plain budget error (a worker sends it to the parent)
        return (StepBudgetExceeded, (self.steps, self.t, self.t_end))


def joined(first: Result, then: Result) -> Result:
    """One solution of two consecutive ones (``then`` starting where ``first`` ends)."""
    dense = Dense(*(np.concatenate([getattr(first.dense, k), getattr(then.dense, k)])
                    for k in ("t_start", "h", "y_start", "coeffs")))
    return Result(dense=dense, nfev=first.nfev + then.nfev, njev=first.njev + then.njev,
                  steps=first.steps + then.steps, rejected=first.rejected + then.rejected)

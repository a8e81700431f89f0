"""DOP853: our explicit Runge–Kutta integrator of order 8 with step-size control and dense output.

Every reference is solved by this one method (Hairer, Nørsett & Wanner, *Solving
ODEs I*, §II.5–II.6; coefficients in :mod:`analytic.dop853_table`):

- a step is 12 stages of the 8th-order formula, the 13th evaluation (f at the new
  point) doubling as the next step's first (FSAL);
- its error is estimated from the embedded 5th- and 3rd-order formulas combined as
  in Hairer's ``dop853.f``, err = |h| ‖e₅‖² / √((‖e₅‖² + 0.01 ‖e₃‖²) n), each
  component scaled by atol + rtol·max(|y|, |y_new|); a step is kept when err < 1;
- the next step is h·min(10, 0.9 err^(−1/8)) (at least h/5 after a rejection, and
  no growth in the step that follows one);
- three more stages per accepted step give a continuous extension of order 7, so
  one solve is evaluated at any time (every integrator's and every timestep's
  samples) to the accuracy of the step itself.

Why our own rather than ``scipy.integrate.solve_ivp``: the reference is part of
what this tool certifies, and loading scipy.integrate is a cost every process
that solves one pays — more than a warm run's whole solve in some cases
(docs/findings/speed.md), and each worker of a parallel ``check`` pays it on
its own. The step control follows scipy's DOP853 (the same published
algorithm), and tests/test_dop853.py checks this integrator against it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from analytic import dop853_table as table

__all__ = ["MAX_STEPS", "Dense", "IntegrationError", "Piecewise", "RightHandSide", "StepBudgetExceeded", "integrate"]

Array = np.ndarray

SAFETY = 0.9  # aim a little below the tolerance, so the next step is rarely rejected
MIN_FACTOR = 0.2  # a rejected step shrinks at most 5×
MAX_FACTOR = 10.0  # an accepted one grows at most 10×
ERROR_EXPONENT = -1.0 / 8.0  # the controlled error is O(h⁸)
MAX_STEPS = 1_000_000

_A = [np.array(row) for row in table.A]
_B = np.array(table.B)
_C = np.array(table.C)
_E5 = np.array(table.E5)
_E3 = np.array(table.E3)
_D = np.array(table.D)
_ORDER = 7  # of the dense output: seven coefficient vectors per step


@dataclass(frozen=True)
class Piecewise:
    """A continuous solution stored step by step: each step's start time, length, start state and the
    coefficient vectors of its polynomial in θ = (t − t_i)/h_i, which a solver's ``Dense`` evaluates.
    Plain arrays, so it pickles small."""

    t_start: Array  # (S,)
    h: Array  # (S,)
    y_start: Array  # (S, n)
    coeffs: Array  # (S, K, n)

    @property
    def t_end(self) -> float:
        return float(self.t_start[-1] + self.h[-1])

    def _steps(self, t: Array) -> tuple[Array, Array]:
        """The step of each time ``t`` (1-d, within [t_start[0], t_end]) and its θ, a column (len(t), 1)."""
        t = np.asarray(t, dtype=float)
        step = np.clip(np.searchsorted(self.t_start, t, side="right") - 1, 0, len(self.h) - 1)
        return step, ((t - self.t_start[step]) / self.h[step])[:, None]


@dataclass(frozen=True)
class Dense(Piecewise):
    """The continuous solution: per step the seven coefficient vectors of its 7th-order interpolant."""

    def __call__(self, t: Array) -> Array:
        """y at times ``t`` (1-d, within [t_start[0], t_end]), shape (len(t), n), all in one pass.

        With θ = (t − t_i)/h_i in step i: y = y_i + θ(F₀ + (1−θ)(F₁ + θ(F₂ + (1−θ)(F₃ + θ(F₄ + (1−θ)(F₅ + θF₆)))))),
        Hairer's ``contd8``.
        """
        step, theta = self._steps(t)
        coeffs = self.coeffs[step]
        y = coeffs[:, _ORDER - 1].copy()
        for k in range(_ORDER - 1, 0, -1):
            y *= theta if k % 2 == 0 else 1.0 - theta
            y += coeffs[:, k - 1]
        y *= theta
        y += self.y_start[step]
        return y


@dataclass(frozen=True)
class Result:
    dense: Dense
    nfev: int
    steps: int
    rejected: int


def _rms(x: Array) -> float:
    return float(np.sqrt(np.mean(x * x)))


def _initial_step(fun: Callable[[float, Array], Array], y: Array, f: Array, t_end: float, rtol: float,
                  atol: float) -> float:
    """Hairer's starting step (§II.4): one Euler step of a hundredth of the state's scale, then the
    step at which an 8th-order error would meet the tolerance given the estimated second derivative."""
    scale = atol + np.abs(y) * rtol
    d0, d1 = _rms(y / scale), _rms(f / scale)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, t_end)
    d2 = _rms((fun(h0, y + h0 * f) - f) / scale) / h0
    h1 = max(1e-6, h0 * 1e-3) if max(d1, d2) <= 1e-15 else (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    return min(100.0 * h0, h1, t_end)


def _error_norm(K: Array, h: float, scale: Array) -> float:
    e5 = (_E5 @ K) / scale
    e3 = (_E3 @ K) / scale
    n5, n3 = float(e5 @ e5), float(e3 @ e3)
    if n5 == 0.0 and n3 == 0.0:
        return 0.0
    return abs(h) * n5 / np.sqrt((n5 + 0.01 * n3) * len(scale))


class IntegrationError(RuntimeError):
    """The integration could not go on: the step size collapsed (a singularity, a non-finite
    right-hand side, a tolerance the arithmetic cannot meet) or the step budget ran out."""


class StepBudgetExceeded(IntegrationError):
    """The step budget ran out: ``steps`` steps reached ``t`` of ``t_end``."""

    def __init__(self, steps: int, t: float, t_end: float) -> None:
        super().__init__(f"more than {steps} steps before t = {t_end} (reached t = {t:.6g})")
        self.steps, self.t, self.t_end = int(steps), float(t), float(t_end)

    def __reduce__(self):  # pickled with its parts (a worker sends it to the parent)
        return (type(self), (self.steps, self.t, self.t_end))


RightHandSide = Callable[[float, Array], Array]


def _stages(fun: RightHandSide, t: float, y: Array, h: float, K: Array, first: int, last: int) -> None:
    """K[s] = f(t + c_s h, y + h Σ_j a_sj K[j]) for stages first..last-1, in place."""
    for s in range(first, last):
        K[s] = fun(t + _C[s] * h, y + h * (_A[s] @ K[:s]))


def _step(fun: RightHandSide, t: float, y: Array, f: Array, h: float, t_end: float, K: Array,
          rtol: float, atol: float) -> tuple[float, float, Array, float, int]:
    """One accepted step from (t, y) with f = f(t, y), trying h first and shrinking it on each
    rejection: (t_new, h taken, y_new, factor for the next step, rejections). K holds its stages."""
    rejected = 0
    min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
    h = max(h, min_step)
    while True:
        if h < min_step:
            raise IntegrationError(f"step size fell below {min_step:.3g} at t = {t:.6g}")
        t_new = min(t + h, t_end)
        h = t_new - t
        K[0] = f
        _stages(fun, t, y, h, K, 1, table.N_STAGES)
        y_new = y + h * (_B @ K[:table.N_STAGES])
        K[table.N_STAGES] = fun(t_new, y_new)
        scale = atol + rtol * np.maximum(np.abs(y), np.abs(y_new))
        err = _error_norm(K[:table.N_STAGES + 1], h, scale)
        if err < 1.0:  # False for a NaN: a non-finite step is rejected and shrinks
            factor = MAX_FACTOR if err == 0.0 else min(MAX_FACTOR, SAFETY * err ** ERROR_EXPONENT)
            return t_new, h, y_new, (min(1.0, factor) if rejected else factor), rejected
        rejected += 1
        h *= MIN_FACTOR if not np.isfinite(err) else max(MIN_FACTOR, SAFETY * err ** ERROR_EXPONENT)


def _dense_coefficients(fun: RightHandSide, t: float, y: Array, y_new: Array, h: float, K: Array) -> Array:
    """The seven coefficient vectors of the step's interpolant (Hairer's ``contd8``), after the three
    extra stages (K[0] = f at the start, K[12] = f at the end)."""
    _stages(fun, t, y, h, K, table.N_STAGES + 1, len(table.C))
    dy = y_new - y
    F = np.empty((_ORDER, y.size))
    F[0] = dy
    F[1] = h * K[0] - dy
    F[2] = 2.0 * dy - h * (K[table.N_STAGES] + K[0])
    F[3:] = h * (_D @ K)
    return F


def integrate(fun: RightHandSide, t_end: float, y0: Array, *, rtol: float, atol: float,
              max_steps: int = MAX_STEPS, reach: bool = False) -> Result:
    """Integrate y' = fun(t, y) from y(0) = y0 to t_end > 0 with dense output.

    Raises IntegrationError (naming the time) when the step size falls below ten
    units in the last place of t — a singularity, a non-finite right-hand side
    or a tolerance the arithmetic cannot meet — or after ``max_steps`` steps
    (``reach``: returns the solution as far as those steps went instead).
    """
    if not t_end > 0:
        raise ValueError(f"t_end must be positive, got {t_end}")
    y = np.array(y0, dtype=float)
    t = 0.0
    f = np.asarray(fun(t, y), dtype=float)
    if not np.all(np.isfinite(f)):
        raise IntegrationError("the right-hand side is not finite at t = 0")
    h = _initial_step(fun, y, f, t_end, rtol, atol)
    nfev, rejected = 2, 0
    K = np.empty((len(table.C), y.size))
    hs: list[float]
    t_starts, hs, y_starts, coeffs = [], [], [], []
    while t < t_end:
        if len(hs) >= max_steps:
            if reach:
                break
            raise StepBudgetExceeded(max_steps, t, t_end)
        t_new, h, y_new, factor, rejections = _step(fun, t, y, f, h, t_end, K, rtol, atol)
        coeffs.append(_dense_coefficients(fun, t, y, y_new, h, K))
        nfev += (rejections + 1) * table.N_STAGES + len(table.C) - table.N_STAGES - 1
        rejected += rejections
        t_starts.append(t)
        hs.append(h)
        y_starts.append(y)
        t, y, f = t_new, y_new, K[table.N_STAGES].copy()
        h *= factor
    dense = Dense(t_start=np.array(t_starts), h=np.array(hs), y_start=np.array(y_starts), coeffs=np.array(coeffs))
    return Result(dense=dense, nfev=nfev, steps=len(hs), rejected=rejected)

"""Whether MuJoCo's explicit integrators are stable at the model's step, from the reference's linearization.

An explicit method run at a step h where h·λ lies outside its stability region, for an eigenvalue λ of the
linearized dynamics, amplifies that mode every step: the run diverges whatever the engine does right. That is a
property of the method and the model, not a defect of MuJoCo, so such a run is reported as beyond its stability
limit (its figures n/a with the statement) rather than failed. A run that diverges at a step inside the limit
stays a failure.

The linearization is the reference's, never the engine's: ẏ = A y with y = (q, q̇) and A = [[0, I], [K, C]],
K = ∂q̈/∂q and C = ∂q̈/∂q̇ of the reference's own q̈(q, q̇) (the tree's M, F and constraint rows, exact to round-off
by complex step; the KKT solve for a constrained model, whose directions off the manifold add only zero
eigenvalues), by central differences of that q̈: exact in q̇ for everything at most quadratic in q̇ (Coriolis
terms, linear damping, actuators), O(δ²) ≈ 1e-10 relative in q. It is taken at :data:`STATES` states of the
reference over the run's horizon, the states the run should pass through (fewer for a large model,
:func:`states_for`). Forces the reference does not model (contacts, limits, tendons it switches off) are not in it.

The stability regions, each the method's own, as MuJoCo applies it (doc/computation/index.rst, "Numerical
integration"):

- ``RK4``: the one-step map of y' = λy is R(z) = 1 + z + z²/2 + z³/6 + z⁴/24 (z = hλ), and on a linear system
  R(hA) has the eigenvalues R(hλ): stable iff |R(hλ)| ≤ 1 for every λ. Along the ray of each λ the region ends at
  the first r with |R(r e^{iθ})| = 1 (:func:`rk4_boundary`): 2.7853 on the negative real axis, 2√2 on the
  imaginary axis (|R(iy)|² = 1 − y⁶/72 + y⁸/576). The step limit is min over λ of r(arg λ)/|λ|.
- ``Euler``: semi-implicit Euler with the joints' damping D implicit (``eulerdamp``, on by default; without
  damping or with the flag off D = 0): v' = v + h (M + hD)⁻¹ M a, q' = q + h v'. Its map is partitioned, not a
  function of each λ alone, so it is applied as it is: on the linearization, with P = (I + h M⁻¹D)⁻¹,

      G(h) = [[I + h² P K, h (I + h P C)], [h P K, I + h P C]],

  stable iff its spectral radius ρ(G) ≤ 1. For one undamped mode ω (K = −ω², C = D = 0): h ω ≤ 2; with damping c
  that Euler makes implicit (C = −c, D = c): h²ω² ≤ 4 + 2hc. The step limit is found by bisection on ρ(G(h)).
  Velocity coupling whose eigenvalues are imaginary (gyroscopic terms) makes ρ slightly above 1 at any h; over the
  run's horizon T the step counts as beyond the limit only where ρ^(T/h) > :data:`GROWTH`.

A mode that grows in the motion itself (Re λ > 0: an inverted pendulum, a tumbling body) is no numerical
instability: RK4 leaves it out, and Euler's ρ(G) is allowed that growth (|e^{hλ}|, plus the method's own
(h|λ|)² error on it). The implicit integrators (``implicit``, ``implicitfast``, ``discrete``) are not assessed:
their update treats velocity (and, for ``discrete``, position) terms implicitly and is judged as run.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import overload

import numpy as np

__all__ = ["ASSESSED", "Stability", "assess", "states_for"]

Array = np.ndarray

ASSESSED = ("Euler", "RK4")
"""The integrators whose stability region is applied (the explicit ones)."""

STATES = 8
"""The reference's states, evenly over the horizon, at which the dynamics are linearized (at most: see
:func:`states_for`)."""

EVALUATIONS = 1024
"""The reference's evaluations the linearization may take (4n per state): a large model is linearized at fewer
states (dm_control's dog, 85 dof: 3; its stiffest modes, damping on light links, change little with the pose)."""


def states_for(n: int) -> int:
    """How many states a model of ``n`` coordinates is linearized at: :data:`STATES`, fewer where 4n of them each
    would exceed :data:`EVALUATIONS`, never fewer than 2 (the start and the end of the horizon)."""
    return max(2, min(STATES, EVALUATIONS // max(4 * n, 1)))

GROWING = 1e-6
"""A mode counts as growing in the motion itself where Re λ > GROWING · |λ| (below it, as neutral: the central
differences leave Re λ ~ 1e-10 |λ| on an undamped oscillation)."""

GROWTH = 10.0
"""Over a horizon, how much Euler may amplify a mode the motion does not grow before its step counts as beyond the
limit: ρ(G)^(T/h) ≤ GROWTH. Semi-implicit Euler amplifies a gyroscopic mode (velocity coupling whose eigenvalues
are ±iω) by about 1 + h²ω²/2 at every step whatever h: over a horizon that is a drift its budget judges, not a
divergence. Past the sharp limits (h ω = 2 for a spring) ρ jumps by 2√δ at h ω = 2 + δ, so on a horizon of N
steps this moves the limit by about (1.2/N)² relative. Small on purpose: a run it leaves to be judged is judged
(and fails where its error shows), never hidden."""

SLACK = 1e-4
"""What Euler's ρ(G) may exceed its allowance by without counting as unstable: the eigenvalue solver's error on
the Jordan blocks a free or constrained coordinate gives G (~ √(ε‖G‖)). Past the limit ρ grows like 1 + 2√(δ) at
h ω = 2 + δ, so this moves the limit by ~1e-9 relative."""


CHUNK = 64
"""States evaluated per batched call of the reference (a tree's evaluation holds n + 2 complex configurations
each: its memory grows with the batch)."""


@overload
def rk4_amplification(z: Array) -> Array: ...
@overload
def rk4_amplification(z: complex) -> complex: ...
def rk4_amplification(z: Array | complex) -> Array | complex:
    """RK4's one-step factor R(z) on y' = λy, z = hλ."""
    return 1.0 + z * (1.0 + z * (0.5 + z * (1.0 / 6.0 + z / 24.0)))


def rk4_boundary(theta: float) -> float:
    """Where RK4's stability region ends along the ray arg z = θ (θ in [π/2, π], the left half-plane): the
    first r > 0 with |R(r e^{iθ})| > 1, by a scan of r ∈ (0, 4] refined by bisection to round-off."""
    if not math.pi / 2 - 1e-12 <= theta <= math.pi + 1e-12:
        raise ValueError(f"theta must be in [pi/2, pi] (the left half-plane), got {theta!r}")
    ray = complex(math.cos(theta), math.sin(theta))
    grid = np.linspace(1e-3, 4.0, 4000)
    outside = np.abs(rk4_amplification(grid * ray)) > 1.0
    first = int(np.argmax(outside))
    lo, hi = (grid[first - 1] if first else 0.0), grid[first]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if abs(rk4_amplification(mid * ray)) <= 1.0 else (lo, mid)
    return float(lo)


RK4_REAL = rk4_boundary(math.pi)
"""RK4's limit on the negative real axis, h|λ| ≈ 2.7853."""


@dataclass(frozen=True)
class Linearization:
    """The reference's dynamics linearized at some states: q̈ ≈ K δq + C δq̇, each (S, n, n); ``damping``: the
    joints' own damping D (S, n, n) in the same coordinates and ``mass`` M (S, n, n) (what Euler makes
    implicit), or None where the reference cannot separate it."""

    stiffness: Array
    velocity: Array
    mass: Array
    damping: Array | None

    @property
    def matrices(self) -> Array:
        """A = [[0, I], [K, C]], (S, 2n, 2n)."""
        s, n, _ = self.stiffness.shape
        a = np.zeros((s, 2 * n, 2 * n))
        a[:, :n, n:] = np.eye(n)
        a[:, n:, :n] = self.stiffness
        a[:, n:, n:] = self.velocity
        return a

    @property
    def eigenvalues(self) -> Array:
        """The eigenvalues of A at each state, (S, 2n) complex."""
        return np.linalg.eigvals(self.matrices)


def linearize(dynamics, q: Array, qd: Array) -> Linearization:
    """K = ∂q̈/∂q and C = ∂q̈/∂q̇ of ``dynamics``'s q̈ (:meth:`~analytic.dynamics.Dynamics.accelerations`, no
    stabilization) at the states (q, q̇), each (S, n), by central differences in one batched evaluation (the
    module docstring gives their accuracy)."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    qd = np.atleast_2d(np.asarray(qd, dtype=float))
    s, n = q.shape
    dq = 1e-5 * np.maximum(1.0, np.abs(q))  # (S, n)
    dv = 1e-3 * np.maximum(1.0, np.max(np.abs(qd), axis=1, keepdims=True)) * np.ones((s, n))
    eye = np.eye(n)
    qs = np.concatenate([q[:, None, :] + dq[:, :, None] * eye, q[:, None, :] - dq[:, :, None] * eye,
                         np.repeat(q[:, None, :], 2 * n, axis=1)], axis=1)  # (S, 4n, n)
    vs = np.concatenate([np.repeat(qd[:, None, :], 2 * n, axis=1),
                         qd[:, None, :] + dv[:, :, None] * eye, qd[:, None, :] - dv[:, :, None] * eye], axis=1)
    flat_q, flat_v = qs.reshape(-1, n), vs.reshape(-1, n)
    acc = np.concatenate([dynamics.accelerations(flat_q[i:i + CHUNK], flat_v[i:i + CHUNK])[0]
                          for i in range(0, len(flat_q), CHUNK)]).reshape(s, 4 * n, n)
    k = ((acc[:, :n] - acc[:, n:2 * n]) / (2.0 * dq[:, :, None])).transpose(0, 2, 1)
    c = ((acc[:, 2 * n:3 * n] - acc[:, 3 * n:]) / (2.0 * dv[:, :, None])).transpose(0, 2, 1)
    mass = dynamics.mass_matrix(q)
    damping_matrix: Callable[[Array, Array], Array] | None = getattr(dynamics, "damping_matrix", None)
    damping = damping_matrix(q, qd) if damping_matrix is not None else None
    return Linearization(stiffness=k, velocity=c, mass=mass, damping=damping)


def euler_map(lin: Linearization, h: float, *, implicit_damping: bool) -> Array:
    """G(h) of semi-implicit Euler as MuJoCo applies it (the module docstring), (S, 2n, 2n); with
    ``implicit_damping`` the joints' damping is solved implicitly (``eulerdamp``)."""
    k, c = lin.stiffness, lin.velocity
    s, n, _ = k.shape
    eye = np.eye(n)
    if implicit_damping:
        assert lin.damping is not None  # asked only where the reference separates the damping (assess)
        p = np.linalg.inv(eye + h * np.linalg.solve(lin.mass, lin.damping))
    else:
        p = np.broadcast_to(eye, (s, n, n))
    pk, pc = p @ k, eye + h * (p @ c)
    g = np.empty((s, 2 * n, 2 * n))
    g[:, :n, :n] = eye + h * h * pk
    g[:, :n, n:] = h * pc
    g[:, n:, :n] = h * pk
    g[:, n:, n:] = pc
    return g


@dataclass(frozen=True)
class Stability:
    """One integrator's stability at the model's step.

    Attributes:
        integrator: the integrator.
        timestep: the step h it runs at, s.
        h_lambda: h · the largest |λ| of the modes that do not grow in the motion, over the states.
        limit: the largest stable step, s (inf where no mode bounds it): RK4's region along each eigenvalue's ray,
            Euler's ρ(G(h)) ≤ 1.
        region: the region's extent, in h|λ|, along the ray of the eigenvalue that sets the limit (RK4), or the
            spectral radius of Euler's one-step map at h.
        states: how many states of the reference were linearized.
    """

    integrator: str
    timestep: float
    h_lambda: float
    limit: float
    region: float
    states: int

    @property
    def beyond(self) -> bool:
        """Whether the step is beyond the limit: every figure of this integrator's runs is then n/a."""
        return self.timestep > self.limit

    def as_dict(self) -> dict[str, object]:
        """What report.json's settings keep of it (``limit`` None where no mode bounds the step)."""
        return {"beyond": self.beyond, "timestep": self.timestep, "h_lambda_max": self.h_lambda,
                "limit": self.limit if math.isfinite(self.limit) else None, "statement": self.statement()}

    def statement(self) -> str:
        """One line: where the step stands against the limit, with the figures and where they come from."""
        h = self.timestep
        where = (f"h·|λ|max = {self.h_lambda:.3g}, λ from the linearization at the run's states (the reference's, "
                 f"at {self.states} instants over the horizon)")
        if self.integrator == "RK4":
            region = f"RK4's region ends at h·|λ| = {self.region:.3g} along the limiting eigenvalue's ray"
        else:
            region = (f"the spectral radius of semi-implicit Euler's one-step map (as MuJoCo applies it) is "
                      f"{self.region:.3g} at h")
        if self.beyond:
            return (f"{self.integrator} at h={h:g} s is beyond its stability limit ({where}; {region}); "
                    f"stable below h ≈ {self.limit:.3g} s")
        limit = f"h ≈ {self.limit:.3g} s" if math.isfinite(self.limit) else "any step (no mode bounds it)"
        return f"{self.integrator} at h={h:g} s is within its stability limit ({where}); stable below {limit}"


def _split(eigenvalues: Array) -> tuple[Array, Array]:
    """The eigenvalues that do not grow in the motion (|Re λ| ≤ GROWING |λ| counted as neutral), and the largest
    rate |λ| of those that do (0 if none)."""
    lam = eigenvalues.ravel()
    size = np.abs(lam)
    growing = lam.real > GROWING * size
    return lam[~growing & (size > 0)], lam[growing]


def rk4_limit(eigenvalues: Array) -> tuple[float, float]:
    """The largest stable RK4 step for these eigenvalues, and the region's extent h|λ| along the ray of the
    eigenvalue that sets it (inf, nan where none bounds the step)."""
    stable, _ = _split(eigenvalues)
    if not stable.size:
        return math.inf, math.nan
    theta = np.clip(np.abs(np.angle(stable)), math.pi / 2, math.pi)  # the conjugate's ray: the region is symmetric
    boundary = {t: rk4_boundary(float(t)) for t in np.unique(np.round(theta, 12))}
    extent = np.array([boundary[t] for t in np.round(theta, 12)])
    steps = extent / np.abs(stable)
    k = int(np.argmin(steps))
    return float(steps[k]), float(extent[k])


def _euler_unstable(lin: Linearization, eigenvalues: Array, h: float, *, implicit_damping: bool,
                    horizon: float | None) -> Array:
    """Per state: ρ(G(h)) beyond what the motion's own growth allows (the module docstring), and over ``horizon``
    (None: any) more than :data:`GROWTH`."""
    rho = np.max(np.abs(np.linalg.eigvals(euler_map(lin, h, implicit_damping=implicit_damping))), axis=-1)
    allowed = np.ones(len(rho))
    for s, lam in enumerate(eigenvalues):
        _, growing = _split(lam)
        if growing.size:
            with np.errstate(over="ignore"):  # a huge trial step: the motion's own growth is unbounded (inf)
                allowed[s] = float(np.max(np.abs(np.exp(h * growing)))) + (h * float(np.max(np.abs(growing)))) ** 2
    if horizon:
        with np.errstate(over="ignore"):
            allowed = allowed * GROWTH ** min(h / horizon, 1.0)
    return rho > allowed + SLACK


def euler_limit(lin: Linearization, eigenvalues: Array, *, implicit_damping: bool, near: float,
                horizon: float | None = None) -> float:
    """The largest step at which semi-implicit Euler is stable at every state (over ``horizon``: :data:`GROWTH`):
    doubled or halved from ``near`` until the verdict changes (at most 2⁴⁰), then bisected to 1e-6 relative (inf
    where no step up to 2⁴⁰ · near, or up to the horizon, is unstable)."""
    def unstable(h: float) -> bool:
        return bool(np.any(_euler_unstable(lin, eigenvalues, h, implicit_damping=implicit_damping,
                                           horizon=horizon)))

    lo = hi = near
    if unstable(near):
        for _ in range(40):
            lo /= 2.0
            if not unstable(lo):
                break
        else:
            return 0.0
    else:
        for _ in range(40):
            hi *= 2.0
            if horizon and hi > horizon:  # a step longer than the run: no mode bounds any step it can take
                return math.inf
            if unstable(hi):
                break
        else:
            return math.inf
        lo = hi / 2.0
    while hi - lo > 1e-6 * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if not unstable(mid) else (lo, mid)
    return lo


def assess(dynamics, q: Array, qd: Array, *, timestep: float, integrators: Sequence[str],
           implicit_damping: bool = True, horizon: float | None = None) -> dict[str, Stability]:
    """Each of ``integrators`` that is assessed (:data:`ASSESSED`) against its stability region at ``timestep``,
    the reference ``dynamics`` linearized at the states (q, q̇) (S, n); ``implicit_damping``: whether MuJoCo's Euler
    solves joint damping implicitly (``eulerdamp`` on and some joint damped); ``horizon``: the run's, over which
    Euler may amplify a mode the motion does not grow by :data:`GROWTH` (None: not at all, beyond round-off).
    Euler is left out where that damping cannot be separated from the reference (a hand-derived system's
    dynamics)."""
    wanted = [name for name in integrators if name in ASSESSED]
    if not wanted or not getattr(dynamics, "n", 0):
        return {}
    lin = linearize(dynamics, q, qd)
    eigenvalues = lin.eigenvalues
    stable, _ = _split(eigenvalues)
    h_lambda = timestep * float(np.max(np.abs(stable))) if stable.size else 0.0
    states = len(eigenvalues)
    out: dict[str, Stability] = {}
    for name in wanted:
        if name == "RK4":
            limit, region = rk4_limit(eigenvalues)
        else:
            if implicit_damping and lin.damping is None:
                continue  # the reference cannot separate the damping Euler makes implicit: not assessed
            damped = implicit_damping and bool(np.any(lin.damping))
            limit = euler_limit(lin, eigenvalues, implicit_damping=damped, near=timestep, horizon=horizon)
            region = float(np.max(np.abs(np.linalg.eigvals(euler_map(lin, timestep, implicit_damping=damped)))))
        out[name] = Stability(integrator=name, timestep=float(timestep), h_lambda=h_lambda, limit=limit,
                              region=region, states=states)
    return out

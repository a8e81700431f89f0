"""Build and solve the analytic reference of a case, and express it as a Trajectory.

Derivations are cached on disk (harness/cache.py), keyed by the source of the
system module and of analytic/lagrangian.py, so a run derives only what was
edited since the last one; within a process each is loaded once. So are the
numeric functions made from them at a model's parameter values
(:class:`analytic.dynamics.Compiled`, keyed also by analytic/dynamics.py and
the values): a run that finds them cached needs no derivation and never
imports sympy.

A case's reference is solved once per process over the case's horizon (or a
longer one asked for) and reused, through its dense output, by every
integrator, timestep, setting and study that asks for that horizon or a
shorter one. The solve is keyed by everything it depends on (system,
parameters, initial state, tolerance, horizon), never by call order, so a
result does not depend on which case or study ran first. Solutions solved in a
worker process can be handed to the parent (:func:`export_solutions`,
:func:`import_solutions`), so that a run's studies reuse its cases' solves.
"""

from __future__ import annotations

import functools
import importlib.util
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from analytic.dynamics import Compiled, Dynamics
from analytic.solvers import DEFAULT_RTOL, Solution, solve
from analytic.systems import Scales, load
from harness import cache
from harness.cases import Case
from harness.trajectory import Trajectory

if TYPE_CHECKING:
    from analytic.lagrangian import Derivation, LagrangianSystem

# Derivation's lazily computed results, all evaluated before a derivation is cached on disk
SYMBOLIC = ("mass_matrix", "forcing", "constraint_rows", "jacobian", "gamma", "holonomic_residual", "energy",
            "momenta", "cyclic", "equations", "multiplier_symbols")


def _module_file(module: str) -> Path:
    """Where ``module``'s source is, found without importing it (analytic.lagrangian loads sympy)."""
    spec = importlib.util.find_spec(module)
    if spec is None or spec.origin is None:
        raise ImportError(f"cannot find the source of {module}")
    return Path(spec.origin)


def _sources(system: str) -> list[Path]:
    """The files a derivation of ``system`` depends on (the package's ``parameters`` makes its symbols)."""
    return [Path(str(load(system).__file__)), _module_file("analytic.systems"), _module_file("analytic.lagrangian")]


def _derived(system_of: LagrangianSystem) -> Derivation:
    result = system_of.derive()
    for name in SYMBOLIC:
        getattr(result, name)
    return result


@functools.cache
def derivation(system: str) -> Derivation:
    """The derivation of ``system`` with every symbolic result evaluated (cached on disk and per process)."""
    from analytic.lagrangian import Derivation

    digest = cache.source_key(_sources(system))
    return cache.cached("derivation", system, digest, lambda: _derived(load(system).build()), Derivation)


def derivation_stored(system: str) -> bool:
    """Whether the on-disk cache holds ``system``'s derivation for its current source (no loading)."""
    return cache.has("derivation", system, cache.source_key(_sources(system)))


@functools.cache
def minimal_derivation(system: str) -> Derivation | None:
    """The derivation of the system's minimal-coordinate form (``minimal()``), or None if it has none."""
    from analytic.lagrangian import Derivation

    module = load(system)
    if not hasattr(module, "minimal"):
        return None
    digest = cache.source_key(_sources(system))
    return cache.cached("minimal", system, digest, lambda: _derived(module.minimal()), Derivation)


def _compiled(kind: str, system: str, params: tuple[tuple[str, float], ...],
              deriving: Callable[[str], Derivation | None]) -> Dynamics:
    """Dynamics from the on-disk entry for (system, params), made from ``deriving(system)`` if absent
    or if its code does not run here (e.g. a numpy that lacks a function it names)."""
    digest = cache.key(cache.source_key([*_sources(system), _module_file("analytic.dynamics")]), repr(params))
    return cache.cached(kind, system, digest, lambda: Compiled.of(deriving(system), dict(params)), Compiled,
                        lambda compiled: Dynamics.load(compiled).checked())


@functools.cache
def _minimal_dynamics(system: str, params: tuple[tuple[str, float], ...]) -> Dynamics | None:
    if not hasattr(load(system), "minimal"):
        return None
    return _compiled("minimal-dynamics", system, params, minimal_derivation)


def minimal_dynamics(system: str, params: Mapping[str, float]) -> Dynamics | None:
    """Numeric dynamics of the minimal-coordinate form at ``params`` (cached), or None."""
    return _minimal_dynamics(system, tuple(sorted(params.items())))


@functools.cache
def _dynamics(system: str, params: tuple[tuple[str, float], ...]) -> Dynamics:
    return _compiled("dynamics", system, params, derivation)


def dynamics(system: str, params: Mapping[str, float]) -> Dynamics:
    """Numeric dynamics of ``system`` at ``params`` (cached on disk and per process)."""
    return _dynamics(system, tuple(sorted(params.items())))


@dataclass(frozen=True)
class Reference:
    """A case's reference: parameters, scales and the dense solution."""

    case: Case
    params: Mapping[str, float]
    scales: Scales
    solution: Solution

    @property
    def dynamics(self) -> Dynamics:
        return self.solution.dynamics

    def q0(self) -> np.ndarray:
        return _ordered(self.case.q0, self.dynamics.coordinates, "q0")

    def qd0(self) -> np.ndarray:
        return _ordered(self.case.qd0, self.dynamics.coordinates, "qd0")


def _ordered(values: Mapping[str, float], order: tuple[str, ...], label: str) -> np.ndarray:
    if set(values) != set(order):
        raise ValueError(f"{label} must give exactly the coordinates {order}, got {tuple(values)}")
    return np.array([values[k] for k in order], dtype=float)


# solutions by (system, params, q0, qd0, rtol, horizon); seeds (exported by another process) wait
# there without their dynamics until asked for
_solutions: dict[tuple, Solution] = {}
_seeds: dict[tuple, tuple[float, float, int, object]] = {}
_exported: set[tuple] = set()


def build_reference(case: Case, model: mujoco.MjModel, *, rtol: float = DEFAULT_RTOL,
                    t_end: float | None = None) -> Reference:
    """The case's system solved with the parameters read from ``model``, over at least ``t_end``
    (default: the case's horizon).

    One solve over max(t_end, horizon) serves every request up to it: a shorter
    ``t_end`` gets the case's solution, whose dense output covers it.
    """
    module = load(case.system)
    params = module.params_from_model(model)
    dyn = dynamics(case.system, params)
    q0 = _ordered(case.q0, dyn.coordinates, "q0")
    qd0 = _ordered(case.qd0, dyn.coordinates, "qd0")
    span = max(float(t_end or case.horizon), float(case.horizon))
    key = (case.system, tuple(sorted(params.items())), tuple(q0.tolist()), tuple(qd0.tolist()),
           float(rtol), span)
    sol = _solutions.get(key)
    if sol is None and key in _seeds:
        end, tol, nfev, dense = _seeds.pop(key)
        sol = Solution(dynamics=dyn, t_end=end, rtol=tol, nfev=nfev, _dense=dense)
    if sol is None:
        sol = solve(dyn, q0=q0, qd0=qd0, t_end=span, rtol=rtol, atol=rtol)
    _solutions[key] = sol
    return Reference(case=case, params=params, scales=module.scales(params), solution=sol)


def export_solutions() -> dict[tuple, tuple[float, float, int, object]]:
    """The solutions of this process not exported before, in a picklable form (no dynamics)."""
    out = {k: (s.t_end, s.rtol, s.nfev, s._dense) for k, s in _solutions.items() if k not in _exported}
    _exported.update(out)
    return out


def import_solutions(seeds: Mapping[tuple, tuple[float, float, int, object]]) -> None:
    """Solutions exported by another process: :func:`build_reference` uses them instead of solving."""
    for key, seed in seeds.items():
        if key not in _solutions:
            _seeds[key] = seed


def clear_caches() -> None:
    """Forget this process's solutions (derivations stay: they depend on source code only)."""
    _solutions.clear()
    _seeds.clear()
    _exported.clear()


def trajectory(ref: Reference, t: np.ndarray) -> Trajectory:
    """The reference sampled at times t, in the common schema."""
    dyn = ref.dynamics
    q, qd = ref.solution.state(t)
    _, lam = dyn.accelerations(q, qd)
    pts = dyn.points(q)
    vels = dyn.point_velocities(q, qd)
    jac = dyn.jacobian(q)
    gen = np.einsum("nmk,nm->nk", jac, lam)
    pos_res = dyn.position_residual(q)
    invariants = {"energy": dyn.energy(q, qd)}
    momenta = dyn.momenta(q, qd)
    for k, name in enumerate(dyn.coordinates):
        if name in dyn.cyclic:
            invariants[f"p_{name}"] = momenta[:, k]
    return Trajectory(
        t=np.asarray(t, dtype=float),
        positions={p: pts[:, i] for i, p in enumerate(dyn.point_names)},
        velocities={p: vels[:, i] for i, p in enumerate(dyn.point_names)},
        multipliers={c: lam[:, j] for j, c in enumerate(dyn.constraint_names)},
        generalized_force=gen,
        invariants=invariants,
        violations={c: pos_res[:, j] for j, c in enumerate(dyn.constraint_names)},
        source="reference",
    )

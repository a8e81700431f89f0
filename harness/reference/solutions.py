"""Solved references: a system's motion integrated once per process and sampled as a Trajectory.

A reference is solved once per machine over the motion's horizon (or a
longer one asked for): kept on disk in the user cache (:mod:`harness.core.cache`,
kind ``solution``), keyed by the solve's own key and the source of everything
it runs (``analytic/``, the tree reader) and numpy's version, so a warm run
loads the very bits a fresh solve makes, and in the process, reused through its dense output, by every
integrator, timestep, setting and study that asks for that horizon or a
shorter one. The solve is keyed by everything it depends on (system,
parameters, initial state, tolerance, horizon), never by call order, so a
result does not depend on which case or study ran first. Solutions solved in a
worker process can be handed to the parent (:func:`export_solutions`,
:func:`import_solutions`), so that a run's studies reuse its cases' solves.
"""

from __future__ import annotations

import dataclasses
import functools
import platform
import re
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import mujoco
import numpy as np

import analytic
from analytic import systems
from analytic.dynamics import Dynamics
from analytic.solvers import DEFAULT_RTOL, STIFF_RTOL, Solution, TooManySteps, TooSlow, project, solve
from analytic.systems import Scales
from analytic.tree import TreeDynamics
from harness.core import bounds, cache
from harness.core.errors import ModelError
from harness.core.trajectory import Trajectory
from harness.reference.derivations import dynamics, params_of
from harness.reference.tree import TreeSystem, tree_scales

__all__ = ["TREE_MAX_STEPS", "Reference", "bounded_solve", "build_reference", "clear_caches", "export_solutions",
           "import_solutions", "trajectory"]


@dataclass(frozen=True)
class Reference:
    """A solved motion of ``system``: its parameters, scales and dense solution from (q0, qd0).

    ``initial`` is the state solved from: the one asked for, brought onto the constraints of these
    parameters where it was not on them (``projected`` says which coordinates moved, and how).
    """

    system: str
    params: Mapping[str, float]
    scales: Scales
    solution: Solution
    initial: tuple[tuple[float, ...], tuple[float, ...]]
    projected: tuple[str, ...] = ()

    @property
    def dynamics(self) -> Dynamics:
        return self.solution.dynamics

    def q0(self) -> np.ndarray:
        return np.array(self.initial[0], dtype=float)

    def qd0(self) -> np.ndarray:
        return np.array(self.initial[1], dtype=float)


def ordered(values: Mapping[str, float], order: tuple[str, ...], label: str) -> np.ndarray:
    """``values`` by coordinate name, in the dynamics' coordinate order; ValueError unless they name
    exactly those coordinates."""
    if set(values) != set(order):
        raise ValueError(f"{label} must give exactly the coordinates {order}, got {tuple(values)}")
    return np.array([values[k] for k in order], dtype=float)


TREE_MAX_STEPS = 20_000
"""The most steps a tree reference's solve may take, well above what dm_control's humanoid with every joint set
moving takes (docs/findings/bases.md, TREE_MAX_STEPS): past it the model is refused in one line, after the solver's
first 500 steps, never left to run for hours."""

# solutions by (system, params, q0, qd0, rtol, horizon); seeds (exported by another process) wait
# there without their dynamics until asked for
_solutions: dict[tuple, Solution] = {}
# a solution's (t_end, rtol, nfev, dense output, method, why): Solution's fields, the dense output as unpickled
_seeds: dict[tuple, tuple[float, float, int, Any, str, str]] = {}
_exported: set[tuple] = set()


def _usable(scale: object) -> bool:
    """A scale a relative figure can divide by: a positive, finite real (a reversed gravity makes √(g l) complex)."""
    return isinstance(scale, (int, float, np.floating)) and bool(np.isfinite(scale)) and bool(scale > 0)


def build_reference(system: str, model: mujoco.MjModel, *, q0: Mapping[str, float], qd0: Mapping[str, float],
                    horizon: float, rtol: float = DEFAULT_RTOL, t_end: float | None = None,
                    tree: TreeSystem | None = None, reach: int | None = None,
                    stiff_rtol: float = STIFF_RTOL) -> Reference:
    """``system`` solved from (q0, qd0) with the parameters read from ``model``, over at least
    ``t_end`` (default: ``horizon``).

    The state is first brought onto the constraints at these parameters
    (:func:`analytic.solvers.project`): a motion written for the shipped model
    (a pendulum's r = 1) starts a model of other dimensions on its own
    constraints (r = 2), and the changes are listed in ``Reference.projected``.

    One solve over max(t_end, horizon) serves every request up to it: a shorter
    ``t_end`` gets the horizon's solution, whose dense output covers it.

    ``tree``: the system is ``model``'s own kinematic tree (:mod:`harness.reference.tree`), read in
    those charts, rather than a hand-derived module.

    ``reach``: solve only as far as that many solver steps go (at most the span): a span bounded by the
    reference's cost, which the returned solution's ``t_end`` states (the chaos horizon's cap on a model whose
    motion is costly to solve). Later requests up to that span reuse it.

    ``stiff_rtol``: the tolerance a stiff tree's Radau IIA solve is made to (:func:`analytic.solvers.solve`),
    tighter than :data:`~analytic.solvers.STIFF_RTOL` where the budget needs it (:func:`harness.budget.reference.
    reference_rtol`).
    """
    dyn: Dynamics
    if tree is not None:
        dyn = own = tree.dynamics(model)
        params, scales, identity = dict(own.params), tree_scales(own.tree), own.tree.digest()
    else:
        module = systems.load(system)
        params = params_of(system, model)
        dyn = dynamics(system, params)
        scales, identity = module.scales(params), ""
    vanished = [f.name for f in dataclasses.fields(scales) if not _usable(getattr(scales, f.name))]
    if vanished:  # every relative figure divides by them: such a model is not this case's system
        if tree is not None:  # a tree keeps its scales where gravity is off; only an overflowing one loses them
            raise ModelError(f"the model's {' or '.join(vanished)} scale is not finite (gravity or a mass beyond "
                             "floating point?); accepted: a model whose masses, sizes and gravity are finite")
        raise ModelError(f"case {system!r} has no positive, finite {' or '.join(vanished)} scale at the model's "
                         f"parameters ({', '.join(f'{k} = {v:g}' for k, v in params.items())}): its figures have "
                         "nothing to be relative to (gravity off or reversed?); accepted: a model with the case's "
                         "scales, or the model alone with no case (--mjcf FILE), judged against its own tree")
    asked_q = ordered(q0, dyn.coordinates, "q0")
    asked_qd = ordered(qd0, dyn.coordinates, "qd0")
    q, qd = project(dyn, asked_q, asked_qd)
    projected = tuple(f"{label} {name}: {a:.10g} → {b:.10g}" for label, asked, got in
                      (("q0", asked_q, q), ("qd0", asked_qd, qd))
                      for name, a, b in zip(dyn.coordinates, asked, got, strict=True)
                      if abs(b - a) > 1e-12 * max(1.0, abs(a)))
    span = max(float(t_end or horizon), float(horizon))
    tolerance = float(rtol) if stiff_rtol == STIFF_RTOL else (float(rtol), float(stiff_rtol))
    key = (system, identity, tuple(sorted(params.items())), tuple(q.tolist()), tuple(qd.tolist()), tolerance, span)
    if reach is not None:
        return _reach(system, dyn, key, int(reach), rtol, params, scales, q, qd, projected, tree, stiff_rtol)
    sol = _solutions.get(key)
    if sol is None:  # a solve over a longer span from the same start covers this one: its dense output, cut to span
        longer = next((found for k, found in _solutions.items() if k[:-1] == key[:-1] and k[-1] >= span), None)
        if longer is not None:  # (what samples the motion, e.g. the instant layer's states, reads t_end)
            sol = dataclasses.replace(longer, dynamics=dyn, t_end=span)
    if sol is None and key in _seeds:
        end, tol, nfev, dense, method, why = _seeds.pop(key)
        sol = Solution(dynamics=dyn, t_end=end, rtol=tol, nfev=nfev, _dense=dense, method=method, why=why)
    # the solver's step bound: past it a solve is refused, and below it a stiff motion goes to Radau IIA
    bound = min(TREE_MAX_STEPS, bounds.max_reference_steps()) if tree is not None else bounds.max_reference_steps()
    if sol is None:
        sol = _stored(key, bound, dyn)
    if sol is None:
        clock = time.perf_counter()
        try:
            sol = bounded_solve(dyn, q0=q, qd0=qd, t_end=span, rtol=rtol, max_steps=bound, tree=tree is not None,
                                stiff_rtol=stiff_rtol)
        except TooManySteps as exc:
            if tree is not None:  # a model the user brings: its motion, not the run asked for, is what is too long
                raise ModelError(f"the model's tree reference cannot be solved to rtol {rtol:g} over {span:g} s: "
                                 f"{exc}; its motion is too stiff or its mass matrix too ill-conditioned for the "
                                 "reference (accepted: a model whose tree solves within the bound, or a shorter "
                                 "--horizon)") from None
            raise bounds.reference_too_long(str(exc)) from None
        if tree is not None and sol.why:  # a tree's dynamics (tree given)
            sol = dataclasses.replace(sol, why=stiffness_cause(cast(TreeDynamics, dyn), q, sol.why))
        _store(key, bound, sol, time.perf_counter() - clock)
    _solutions[key] = sol
    return _reference(system, params, scales, sol, dyn, q, qd, projected, span, tree)


def bounded_solve(dyn: Dynamics, *, q0: np.ndarray, qd0: np.ndarray, t_end: float, rtol: float, max_steps: int,
                  tree: bool, reach: bool = False, stiff_rtol: float = STIFF_RTOL) -> Solution:
    """:func:`analytic.solvers.solve` to ``rtol`` (and atol) within ``max_steps``; a tree reference (``tree``: a
    model the user brings) also stiff-capable and within :func:`harness.core.bounds.max_solve_seconds` of CPU,
    refused (RunTooLong, with how far it got) past them."""
    try:
        return solve(dyn, q0=q0, qd0=qd0, t_end=t_end, rtol=rtol, atol=rtol, max_steps=max_steps, stiff=tree,
                     reach=reach, cpu_seconds=bounds.max_solve_seconds() if tree else None, stiff_rtol=stiff_rtol)
    except TooSlow as exc:
        raise bounds.solve_too_slow(str(exc), nv=dyn.n) from None


def _reach(system: str, dyn: Dynamics, key: tuple, steps: int, rtol: float, params: dict[str, float],
           scales: Scales, q: np.ndarray, qd: np.ndarray, projected: tuple[str, ...],
           tree: TreeSystem | None, stiff_rtol: float) -> Reference:
    """:func:`build_reference` over as much of the span as ``steps`` solver steps cover, kept (in the process and
    on disk) under its own key and, in the process, under the span it reached."""
    within = (*key, f"within {steps} steps")
    sol = _solutions.get(within)
    if sol is None and within in _seeds:
        end, tol, nfev, dense, method, why = _seeds.pop(within)
        sol = Solution(dynamics=dyn, t_end=end, rtol=tol, nfev=nfev, _dense=dense, method=method, why=why)
    if sol is None:
        sol = _stored(within, steps, dyn)
    if sol is None:
        clock = time.perf_counter()
        sol = bounded_solve(dyn, q0=q, qd0=qd, t_end=key[-1], rtol=rtol, max_steps=steps, tree=tree is not None,
                            reach=True, stiff_rtol=stiff_rtol)
        if tree is not None and sol.why:  # a tree's dynamics (tree given)
            sol = dataclasses.replace(sol, why=stiffness_cause(cast(TreeDynamics, dyn), q, sol.why))
        _store(within, steps, sol, time.perf_counter() - clock)
    _solutions[within] = sol
    _solutions.setdefault((*key[:-1], sol.t_end), sol)
    return _reference(system, params, scales, sol, dyn, q, qd, projected, sol.t_end, tree)


def _reference(system: str, params: dict[str, float], scales: Scales, sol: Solution, dyn: Dynamics,
               q: np.ndarray, qd: np.ndarray, projected: tuple[str, ...], span: float,
               tree: TreeSystem | None) -> Reference:
    if tree is not None:  # a model of one's own: its length is at least how far its motion goes
        points = dyn.points(sol.state(np.linspace(0.0, span, 65))[0]) if dyn.point_names else np.zeros((1, 1, 3))
        excursion = float(np.max(np.linalg.norm(points - points[:1], axis=-1)))
        scales = tree_scales(cast(TreeDynamics, dyn).tree, excursion=excursion)  # a tree's dynamics (tree given)
    return Reference(system=system, params=params, scales=scales, solution=sol,
                     initial=(tuple(q.tolist()), tuple(qd.tolist())), projected=projected)


def code_files() -> list[Path]:
    """The files every solve depends on besides its own key: ``analytic/`` (dynamics, solvers, the tree)
    and the readers that make dynamics from a system or a model's tree."""
    roots = [Path(analytic.__file__).parent, Path(__file__).with_name("tree.py"),
             Path(__file__).with_name("derivations.py")]
    return sorted(f for r in roots for f in ([r] if r.is_file() else r.rglob("*.py")))


@functools.cache
def _code_key() -> str:
    return cache.key(cache.source_key(code_files()), np.__version__, platform.machine())


def _digest(key: tuple, bound: int) -> str:
    return cache.key(_code_key(), repr(key), str(bound))


def _entry_name(key: tuple) -> str:
    """The system's name as a file name (a tree's may hold any character)."""
    return re.sub(r"[^A-Za-z0-9_.-]", "_", str(key[0]))[:64] or "system"


def _stored(key: tuple, bound: int, dyn: Dynamics) -> Solution | None:
    """The solution of ``key`` within ``bound`` steps stored on disk by an earlier run, given these dynamics;
    None if there is none that loads."""
    seed = cache.load("solution", _entry_name(key), _digest(key, bound), tuple)
    if not isinstance(seed, tuple) or len(seed) != 6:  # (load gives a tuple or None)
        return None
    end, tol, nfev, dense, method, why = seed
    return Solution(dynamics=dyn, t_end=end, rtol=tol, nfev=nfev, _dense=dense, method=method, why=why)


def _store(key: tuple, bound: int, sol: Solution, seconds: float) -> None:
    cache.store("solution", _entry_name(key), _digest(key, bound),
                (sol.t_end, sol.rtol, sol.nfev, sol._dense, sol.method, sol.why), seconds=seconds)


def stiffness_cause(dyn: TreeDynamics, q: np.ndarray, why: str) -> str:
    """``why`` (a stiff solve's reason) with its cause named where the joints' damping explains it: the
    fastest decay rate of M⁻¹D at the start within a factor 2 of the fastest mode's."""
    fastest = float(dyn.damping_modes(q)[0][0])
    stated = re.search(r"decays at ([0-9.e+]+)/s", why)
    if stated is None or not fastest >= 0.5 * float(stated.group(1)):
        return why
    return f"{why}; joint damping on light links (M⁻¹D up to {fastest:.2g}/s)"


def export_solutions() -> dict[tuple, tuple[float, float, int, Any, str, str]]:
    """The solutions of this process not exported before, in a picklable form (no dynamics)."""
    out = {k: (s.t_end, s.rtol, s.nfev, s._dense, s.method, s.why) for k, s in _solutions.items()
           if k not in _exported}
    _exported.update(out)
    return out


def import_solutions(seeds: Mapping[tuple, tuple[float, float, int, object, str, str]]) -> None:
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
    # λ: the multipliers (none without constraints, where M and F at every sample would be computed for nothing)
    lam = dyn.accelerations(q, qd)[1] if dyn.rows else np.zeros((len(q), 0))
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
    invariants |= dyn.extra_invariants(q, qd)
    return Trajectory(
        t=np.asarray(t, dtype=float),
        positions={p: pts[:, i] for i, p in enumerate(dyn.point_names)},
        velocities={p: vels[:, i] for i, p in enumerate(dyn.point_names)},
        multipliers=dyn.by_constraint(lam),
        generalized_force=gen,
        invariants=invariants,
        violations=dyn.by_constraint(pos_res),
        source="reference",
    )

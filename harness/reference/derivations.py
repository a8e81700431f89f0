"""Derivations and the numeric dynamics made from them, cached on disk and per process.

Derivations are cached on disk (:mod:`harness.core.cache`), keyed by the source
of the system module and of ``analytic/lagrangian.py``, so a run derives only
what was edited since the last one; within a process each is loaded once. So
are the numeric functions made from them at a model's parameter values
(:class:`analytic.dynamics.Compiled`, keyed also by ``analytic/dynamics.py`` and
the values): a run that finds them cached needs no derivation and never
imports sympy. Those of the default cases ship with the package
(:mod:`.prebuilt`), so a fresh install's first run finds them too.
"""

from __future__ import annotations

import functools
import importlib.util
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from analytic import systems
from analytic.dynamics import Compiled, Dynamics
from harness.core import cache
from harness.core.errors import ModelMismatch
from harness.reference import prebuilt
from harness.reference.tree import TREE

if TYPE_CHECKING:
    from analytic.lagrangian import Derivation, LagrangianSystem

__all__ = ["clear_caches", "derivation", "derivation_cost", "derivation_stored", "dynamics", "dynamics_of",
           "minimal_derivation", "minimal_dynamics", "numeric_sources", "params_of"]

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
    """The files a derivation of ``system`` depends on (the package's ``symbols`` makes its symbols)."""
    return [Path(str(systems.load(system).__file__)), _module_file("analytic.systems"),
            _module_file("analytic.lagrangian")]


def _derived(system_of: LagrangianSystem) -> Derivation:
    result = system_of.derive()
    for name in SYMBOLIC:
        getattr(result, name)
    return result


def _stored_derivation(kind: str, system: str, minimal: bool) -> Derivation:
    """The derivation from its on-disk entry (its symbolic results as data, :mod:`harness.core.stored`, set
    on a fresh derivation of the system), else derived and stored for next time."""
    digest = cache.source_key(_sources(system))
    results = cache.load(kind, system, digest, dict)
    if isinstance(results, dict) and set(results) == set(SYMBOLIC):  # (load gives a dict or None)
        found = systems.build(system, minimal=minimal).derive()
        found.__dict__.update(results)  # the cached_property values, as derive() would compute them
        return found
    start = time.perf_counter()
    derived = _derived(systems.build(system, minimal=minimal))
    cache.store(kind, system, digest, {name: getattr(derived, name) for name in SYMBOLIC},
                seconds=time.perf_counter() - start)
    return derived


@functools.cache
def derivation(system: str) -> Derivation:
    """The derivation of ``system`` with every symbolic result evaluated (cached on disk and per process)."""
    return _stored_derivation("derivation", system, minimal=False)


def derivation_stored(system: str) -> bool:
    """Whether the on-disk cache holds ``system``'s derivation for its current source, or the package ships
    its numeric dynamics, so that its shipped cases need no derivation (no loading: a hint)."""
    return (cache.has("derivation", system, cache.source_key(_sources(system)))
            or prebuilt.covers("dynamics", system, numeric_sources(system)))


def derivation_cost(system: str) -> float | None:
    """Seconds the last cold derivation of ``system`` at its current source took (None if never
    measured): recorded by the cache when it computed the entry."""
    return cache.cost("derivation", system, cache.source_key(_sources(system)))


@functools.cache
def minimal_derivation(system: str) -> Derivation | None:
    """The derivation of the system's minimal-coordinate form (``minimal()``), or None if it has none."""
    if not systems.has_minimal(system):
        return None
    return _stored_derivation("minimal", system, minimal=True)


def numeric_sources(system: str) -> list[Path]:
    """The files numeric dynamics of ``system`` depend on."""
    return [*_sources(system), _module_file("analytic.dynamics")]


def _opened(compiled: Compiled) -> Dynamics:
    return Dynamics.load(compiled).checked()


def _compiled(kind: str, system: str, params: tuple[tuple[str, float], ...],
              deriving: Callable[[str], Derivation | None]) -> Dynamics:
    """Dynamics from the on-disk entry for (system, params), else from the package's prebuilt one, else made
    from ``deriving(system)``; an entry whose code does not run here (e.g. a numpy that lacks a function it
    names) counts as absent."""
    sources = numeric_sources(system)
    digest = cache.key(cache.source_key(sources), repr(params))

    def compute() -> Compiled:
        shipped = prebuilt.load(kind, system, sources, params)
        if shipped is not None:
            try:
                _opened(shipped)
                return shipped
            except Exception:  # unusable here: derived below like an absent one
                pass
        derived = deriving(system)
        assert derived is not None  # asked only of a system that has this form (minimal_dynamics checks)
        return Compiled.of(derived, dict(params))

    return cache.cached(kind, system, digest, compute, Compiled, _opened)


@functools.cache
def _minimal_dynamics(system: str, params: tuple[tuple[str, float], ...]) -> Dynamics | None:
    if not systems.has_minimal(system):
        return None
    return _compiled("minimal-dynamics", system, params, minimal_derivation)


def minimal_dynamics(system: str, params: Mapping[str, float]) -> Dynamics | None:
    """Numeric dynamics of the minimal-coordinate form at ``params`` (cached), or None (always for a model's
    own tree, which has one form)."""
    if system == TREE:
        return None
    return _minimal_dynamics(system, tuple(sorted(params.items())))


@functools.cache
def _dynamics(system: str, params: tuple[tuple[str, float], ...]) -> Dynamics:
    return _compiled("dynamics", system, params, derivation)


def dynamics(system: str, params: Mapping[str, float]) -> Dynamics:
    """Numeric dynamics of ``system`` at ``params`` (cached on disk and per process)."""
    return _dynamics(system, tuple(sorted(params.items())))


def clear_caches() -> None:
    """Forget this process's derivations and dynamics (a system's name now names another module: a user's
    systems directory changed, :mod:`harness.cases.sources`); the on-disk cache, keyed by source, stays."""
    for cached in (derivation, minimal_derivation, _dynamics, _minimal_dynamics):
        cached.cache_clear()


def params_of(system: str, model) -> dict[str, float]:
    """``system``'s parameters read from the compiled ``model`` (its ``params_from_model``); ModelMismatch
    in one line where the model lacks an element it reads them from (MuJoCo's KeyError for a name)."""
    try:
        return systems.load(system).params_from_model(model)
    except KeyError as exc:
        why = exc.args[0] if exc.args else exc
        raise ModelMismatch(f"the model is not a {system} system: it lacks an element the system reads its "
                            f"parameters from (MuJoCo: {why})") from None


def dynamics_of(system: str, model) -> Dynamics:
    """Numeric dynamics of ``system`` at the parameters read from the compiled ``model``."""
    return dynamics(system, params_of(system, model))

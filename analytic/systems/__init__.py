"""One module per mechanical system; the module name is the system's name everywhere.

A system is discovered, not listed: every module in this package (names not
starting with ``_``) is one. Each defines

- ``PARAMETERS``: its physical parameters, space-separated (``"m g l"``);
- optionally ``SIGNED_PARAMETERS``: those of them that may be negative or zero (a
  centre of mass's coordinates, a product of inertia), space-separated: real
  sympy symbols instead of positive ones, so that no simplification assumes a
  sign they do not have;
- ``build(p) -> LagrangianSystem``: T, V, coordinates, constraints and named
  points, with ``p.m``, ``p.g`` … the parameters as positive (or, if signed,
  real) sympy symbols (:func:`symbols`); the module docstring states axes, angle origins and
  multiplier signs, with a sketch;
- optionally ``minimal(p) -> LagrangianSystem``: the same system in minimal
  coordinates, the independent ODE path the DAE result is checked against;
- ``params_from_model(model) -> dict``: the parameters, read from the compiled
  MJCF (the one source of truth for every constant);
- ``scales(params) -> Scales``: the length, force, energy and momentum a
  figure is measured against (e.g. m·g for a tension);
- ``MOTION``: the :class:`Motion` its case runs (initial state, horizon).

sympy is imported inside ``build``/``minimal`` only: the numeric half of a
system (``params_from_model``, ``scales``, ``MOTION``) is all a run with cached
derivations needs, and it then never loads sympy.
"""

from __future__ import annotations

import functools
import importlib
import pkgutil
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import ModuleType, SimpleNamespace
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import sympy as sp

    from analytic.lagrangian import LagrangianSystem

__all__ = ["REQUIRED", "Motion", "Parameters", "Scales", "build", "has_minimal", "load", "names", "symbols"]

REQUIRED = ("PARAMETERS", "MOTION", "build", "params_from_model", "scales")

Parameters = SimpleNamespace
"""What ``build(p)`` and ``minimal(p)`` receive: the system's parameters as sympy symbols, by name
(positive, or real where ``SIGNED_PARAMETERS`` names them)."""


@dataclass(frozen=True)
class Scales:
    """Characteristic magnitudes used to make errors dimensionless."""

    length: float
    force: float
    energy: float
    momentum: float = 1.0

    @classmethod
    def gravity(cls, *, mass: float, g: float, length: float) -> Scales:
        """The scales of a mass moving over a length under gravity: force m g, energy m g L,
        (angular) momentum m √(g L) L."""
        force = mass * g
        return cls(length=length, force=force, energy=force * length, momentum=mass * (g * length) ** 0.5 * length)


@dataclass(frozen=True)
class Motion:
    """What a system's case runs: the initial state in the system's coordinates, and for how long.

    ``q0``/``qd0`` name every coordinate; the state must satisfy the
    constraints (the reference refuses otherwise). ``tags`` select cases
    (``fast``, ``ci``, ``constrained``, ``contact``).
    """

    description: str
    q0: Mapping[str, float]
    qd0: Mapping[str, float]
    horizon: float
    tags: frozenset[str] = field(default_factory=lambda: frozenset({"fast", "ci"}))

    def __post_init__(self) -> None:
        object.__setattr__(self, "tags", frozenset(self.tags))
        if set(self.q0) != set(self.qd0):
            raise ValueError(f"q0 and qd0 must name the same coordinates, got {sorted(self.q0)} and "
                             f"{sorted(self.qd0)}")
        if not self.horizon > 0:
            raise ValueError(f"horizon must be positive, got {self.horizon}")


def names() -> tuple[str, ...]:
    """Every system in this package, sorted."""
    return tuple(sorted(m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_")))


@functools.cache
def load(name: str) -> ModuleType:
    """The system module ``analytic.systems.NAME``; ValueError naming the known systems otherwise,
    or naming what a module lacks of the protocol above."""
    if name not in names():
        raise ValueError(f"unknown system {name!r}; known systems: {', '.join(names())}")
    module = importlib.import_module(f"{__name__}.{name}")
    missing = [attr for attr in REQUIRED if not hasattr(module, attr)]
    if missing:
        raise ValueError(f"system module {module.__name__} lacks {', '.join(missing)} "
                         f"(a system defines {', '.join(REQUIRED)}; see analytic/systems/__init__.py)")
    return module


def parameter_names(system: str) -> tuple[str, ...]:
    return tuple(load(system).PARAMETERS.split())


def signed_parameter_names(system: str) -> tuple[str, ...]:
    """The parameters of ``system`` that may take any sign (``SIGNED_PARAMETERS``; none by default);
    ValueError naming any that is not one of its ``PARAMETERS``."""
    signed = tuple(getattr(load(system), "SIGNED_PARAMETERS", "").split())
    stray = sorted(set(signed) - set(parameter_names(system)))
    if stray:
        raise ValueError(f"SIGNED_PARAMETERS of system {system!r} names {', '.join(stray)}, not among its "
                         f"PARAMETERS ({load(system).PARAMETERS})")
    return signed


def symbols(system: str) -> Parameters:
    """The parameters of ``system`` as sympy symbols, by name (``symbols("pendulum").m``): positive,
    except the signed ones (:func:`signed_parameter_names`), which are real. Symbols are equal by
    name and assumptions, so every call gives the same ones."""
    import sympy as sp  # lazy: sympy, only where a derivation is made

    signed = set(signed_parameter_names(system))
    return SimpleNamespace(**{name: sp.Symbol(name, real=True) if name in signed else sp.Symbol(name, positive=True)
                              for name in parameter_names(system)})


def has_minimal(system: str) -> bool:
    """Whether ``system`` gives a minimal-coordinate form."""
    return hasattr(load(system), "minimal")


def build(system: str, *, minimal: bool = False) -> LagrangianSystem:
    """The system's Lagrangian (``minimal``: its minimal-coordinate form), with its parameter symbols."""
    module = load(system)
    made = (module.minimal if minimal else module.build)(symbols(system))
    expected = f"{system}_minimal" if minimal else system
    if made.name != expected:
        raise ValueError(f"{module.__name__}.{'minimal' if minimal else 'build'} names its system "
                         f"{made.name!r}; it must be {expected!r}")
    return made


def parameter(system: str, name: str) -> sp.Symbol:
    """One parameter's symbol (``parameter("pendulum", "l")``)."""
    return getattr(symbols(system), name)

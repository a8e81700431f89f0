"""One module per mechanical system; the module name is the system's name everywhere.

Each module defines:

- ``build() -> LagrangianSystem``: T, V, coordinates, constraints, named points;
  the docstring states axes, angle origins and multiplier signs.
- ``params_from_model(model) -> dict``: the physical parameters, read from the
  compiled MJCF (the one source of truth for every constant).
- ``scales(params) -> Scales``: the length, force and energy a figure is
  measured against (e.g. m·g for a tension).
- optionally ``minimal() -> LagrangianSystem``: the same system in minimal
  coordinates, the independent ODE path the DAE result is checked against.
- ``PARAMETERS``: the names of its physical parameters; ``system.m`` etc. are
  their (positive) sympy symbols, made on first use by the module's
  ``__getattr__``.

sympy is imported inside ``build``/``minimal`` only: the numeric half of a
system (``params_from_model``, ``scales``) is all a run with cached
derivations needs, and it then never loads sympy (0.15 s a process).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from types import ModuleType
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import sympy as sp


@dataclass(frozen=True)
class Scales:
    """Characteristic magnitudes used to make errors dimensionless."""

    length: float
    force: float
    energy: float
    momentum: float = 1.0


def parameters(names: str) -> tuple[sp.Symbol, ...]:
    """The parameters ``names`` (space-separated) as positive sympy symbols. Symbols are equal by name
    and assumptions, so every call gives the same parameters."""
    import sympy as sp

    return sp.symbols(names, positive=True, seq=True)


def parameter(module: str, names: str, attr: str) -> sp.Symbol:
    """A system module's ``__getattr__``: the symbol of parameter ``attr``, or AttributeError."""
    listed = names.split()
    if attr in listed:
        return parameters(names)[listed.index(attr)]
    raise AttributeError(f"module {module!r} has no attribute {attr!r}")


def load(name: str) -> ModuleType:
    """The system module ``analytic.systems.NAME``."""
    return importlib.import_module(f"analytic.systems.{name}")

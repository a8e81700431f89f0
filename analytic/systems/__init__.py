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
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from types import ModuleType


@dataclass(frozen=True)
class Scales:
    """Characteristic magnitudes used to make errors dimensionless."""

    length: float
    force: float
    energy: float
    momentum: float = 1.0


def load(name: str) -> ModuleType:
    """The system module ``analytic.systems.NAME``."""
    return importlib.import_module(f"analytic.systems.{name}")

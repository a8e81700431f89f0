"""mjharness: MuJoCo checked against analytical mechanics.

The Python API, for your own scripts and test suites (the ``mjharness`` command
and the pytest fixture ``mjharness`` call the same functions)::

    import harness

    result = harness.validate("pendulum", mjcf="my_pendulum.xml")
    print(result.summary())
    result.raise_for_failures()          # AssertionError listing each failed check

See README, "Python API", and ``harness.api``. The names below are imported on
first use, so that ``import harness`` (which the ``mjharness`` command does
before it imports MuJoCo without OpenGL) loads nothing heavy.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from harness.core import VERSION

if TYPE_CHECKING:
    from analytic.lagrangian import Constraint, LagrangianSystem, coordinates
    from analytic.rigid import RigidBody, point_mass
    from analytic.systems import Motion, Parameters, Scales
    from harness.api import Advice, Validation, ValidationFailed, advise, case_names, validate
    from harness.cases import Case, Wiring
    from harness.core.budget import Budget
    from harness.core.checks import Check
    from harness.core.figures import Figure, FigureName
    from harness.core.findings import Finding
    from harness.pipeline.require import Fitness, Requirement
    from harness.pipeline.settings import RunSettings
    from harness.pytest_plugin import Harness
    from harness.studies.advice import Curve, Verification

__version__ = VERSION
# The public API, and all of it: what a user's script, test suite or system may use (docs/design.md, "The public API
# and the private boundary", lists the same names by what they are for; tests/test_exports.py holds the two
# together). Everything else is internal, whatever its name; each module's own __all__ is its boundary within the
# package.
__all__ = ["Advice", "Budget", "Case", "Check", "Constraint", "Curve", "Figure", "FigureName", "Finding", "Fitness",
           "Harness", "LagrangianSystem", "Motion", "Parameters", "Requirement", "RigidBody", "RunSettings", "Scales",
           "Validation", "ValidationFailed", "Verification", "Wiring", "__version__", "advise", "case_names",
           "coordinates", "point_mass", "validate"]

_EXPORTS = {"advise": "harness.api", "case_names": "harness.api", "validate": "harness.api",
            "Advice": "harness.api", "Validation": "harness.api", "ValidationFailed": "harness.api",
            "Budget": "harness.core.budget", "Case": "harness.cases", "Check": "harness.core.checks",
            "Curve": "harness.studies.advice", "Figure": "harness.core.figures", "FigureName": "harness.core.figures",
            "Finding": "harness.core.findings", "Fitness": "harness.pipeline.require",
            "Requirement": "harness.pipeline.require", "RunSettings": "harness.pipeline.settings",
            "Verification": "harness.studies.advice", "Harness": "harness.pytest_plugin",
            "Constraint": "analytic.lagrangian", "LagrangianSystem": "analytic.lagrangian",
            "coordinates": "analytic.lagrangian", "RigidBody": "analytic.rigid", "point_mass": "analytic.rigid",
            "Motion": "analytic.systems", "Parameters": "analytic.systems", "Scales": "analytic.systems",
            "Wiring": "harness.cases"}


def __getattr__(name: str) -> object:
    if name in _EXPORTS:
        return getattr(importlib.import_module(_EXPORTS[name]), name)  # lazy: keeps `import harness` light
    raise AttributeError(f"module 'harness' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)

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
    from harness.api import Advice, Validation, ValidationFailed, advise, case_names, validate
    from harness.cases import Case
    from harness.core.checks import Check
    from harness.core.figures import Figure, FigureName

__version__ = VERSION
__all__ = ["Advice", "Case", "Check", "Figure", "FigureName", "Validation", "ValidationFailed", "__version__", "advise",
           "case_names", "validate"]

_EXPORTS = {"advise": "harness.api", "Advice": "harness.api",
            "validate": "harness.api", "Validation": "harness.api", "ValidationFailed": "harness.api",
            "case_names": "harness.api", "Case": "harness.cases", "Check": "harness.core.checks",
            "Figure": "harness.core.figures", "FigureName": "harness.core.figures"}


def __getattr__(name: str) -> object:
    if name in _EXPORTS:
        return getattr(importlib.import_module(_EXPORTS[name]), name)  # lazy: keeps `import harness` light
    raise AttributeError(f"module 'harness' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)

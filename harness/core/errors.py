"""The errors the harness raises for what a user gave it, each meant to be shown as one line.

Every input error is a ``ValueError`` (the CLI turns any ``ValueError`` into
one line on stderr and exit 2); a simulation that blows up is a
``RuntimeError`` of its own, because it is a finding about the model rather
than a mistake in the input.
"""

from __future__ import annotations


class ConfigError(ValueError):
    """A config or limits file that is missing, unreadable or malformed."""


class ModelError(ValueError):
    """An MJCF file that cannot be read or compiled."""


class ModelMismatch(ValueError):
    """The MJCF does not fit the case (missing joints, equalities or bodies)."""


class SimulationDiverged(RuntimeError):
    """MuJoCo produced non-finite values or raised warnings (instability)."""

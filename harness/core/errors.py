"""The errors the harness raises for what a user gave it, each meant to be shown as one line.

Every input error is a ``ValueError`` (the CLI turns any ``ValueError`` into
one line on stderr and exit 2); a simulation that blows up is a
``RuntimeError`` of its own, because it is a finding about the model rather
than a mistake in the input.
"""

from __future__ import annotations

__all__ = ["BackendUnavailable", "ConfigError", "ModelError", "ModelMismatch", "RunTooLong", "SimulationDiverged",
           "UnmodelledElement"]


class ConfigError(ValueError):
    """A config or limits file that is missing, unreadable or malformed."""


class ModelError(ValueError):
    """An MJCF file that cannot be read or compiled."""


class ModelMismatch(ValueError):
    """The MJCF does not fit the case (missing joints, equalities or bodies)."""


class RunTooLong(ValueError):
    """A run whose steps (MuJoCo's, or the reference solver's) would pass a bound (:mod:`harness.core.bounds`):
    refused before it starts, with the estimate and how to raise the bound."""


class SimulationDiverged(RuntimeError):
    """MuJoCo produced non-finite values or raised warnings (instability): ``what`` (the warnings' names,
    e.g. ``mjWARN_BADQACC``) at time ``t``. A finding, never a number: :attr:`reason` is the verdict a
    run that raised it gets ("diverged: mjWARN_BADQACC at t = 0.25 s")."""

    def __init__(self, what: str, t: float) -> None:
        super().__init__(f"{what} at t = {t:.6g} s")
        self.what, self.t = what, float(t)

    def __reduce__(self):  # pickled with its parts (a worker sends it to the parent)
        return (type(self), (self.what, self.t))

    @property
    def reason(self) -> str:
        return f"diverged: {self}"


class UnmodelledElement(RuntimeError):
    """The model has an element its analytic system lacks where a reading must tell it apart (a limit or
    friction loss on the slide a contact force is read along): a finding about the model, like a
    divergence — its figures fail with :attr:`reason` — not a mistake in the input."""

    @property
    def reason(self) -> str:
        return f"not measurable: {self}"


class BackendUnavailable(ValueError):
    """A backend that cannot run here: not installed, or the model uses a feature it lacks. The message
    is one line naming the backend, what is missing and the fix (the CLI prints it and exits 2)."""

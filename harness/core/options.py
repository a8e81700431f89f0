"""How a case runs: the one options object the CLI's flags and the API's keywords become, and the run reads.

Everything a user may change about a run is here and nowhere else: the command line builds a
:class:`RunOptions` from its flags, :func:`harness.validate` from its keywords, and
:func:`harness.pipeline.run.run_case` takes it whole, down to the bench every family measures on
(:class:`harness.families.bench.Bench`). Workers receive it pickled, so it holds data only (``edit``, a
function, is for runs in the caller's own process).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import mujoco

__all__ = ["RunOptions"]


@dataclass(frozen=True)
class RunOptions:
    """What a user may change of how a case runs; all defaults: the case as shipped.

    Attributes:
        mjcf: a model file run instead of the case's (the reference is built from it).
        timestep: run at this timestep instead of the model's.
        integrators: run only these (None: every integrator this MuJoCo has).
        horizon: simulate this long instead of the case's horizon (s).
        q0, qd0: initial coordinates and velocities by name (a case's motion gives the rest).
        perturb: move the whole initial state at round-off level (:func:`harness.families.bench.perturbed`).
        edit: a function changing the model through ``mujoco.MjSpec`` before it is compiled.
        backend: the engine every run of the case goes to (:data:`harness.engine.backends.BACKENDS`).
    """

    mjcf: Path | str | None = None
    timestep: float | None = None
    integrators: tuple[str, ...] | None = None
    horizon: float | None = None
    q0: Mapping[str, float] | None = None
    qd0: Mapping[str, float] | None = None
    perturb: float | None = None
    edit: Callable[[mujoco.MjSpec], None] | None = None
    backend: str = "c"

    def __post_init__(self) -> None:  # a path given as text, integrators as a list: held as Path and tuple
        if self.mjcf is not None and not isinstance(self.mjcf, Path):
            object.__setattr__(self, "mjcf", Path(self.mjcf))
        if self.integrators is not None and not isinstance(self.integrators, tuple):
            object.__setattr__(self, "integrators", tuple(self.integrators))

    @property
    def shipped(self) -> bool:
        """Whether the case runs exactly as shipped (what its measured cost is recorded for)."""
        return self == RunOptions()

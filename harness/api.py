"""The Python API: validate one case, or your own MJCF variant of it, and get a frozen result.

In the style of ``mujoco.rollout``: one function, keyword-only options, a
result you can inspect or turn into a failing assertion::

    from harness import validate

    result = validate("pendulum", mjcf="my_pendulum.xml", integrators=["RK4"])
    result.passed                 # every check within its limit
    result.failures               # the checks that are not
    result.figure("RK4.position") # any measured figure, gated or not
    result.raise_for_failures()   # ValidationFailed (an AssertionError) listing the failures

It runs exactly what ``mjharness check --case CASE --mjcf FILE`` runs (every
layer of :func:`harness.pipeline.run.run_case`, judged by the case's limits,
overridden by ``config`` and ``limits``), in this process.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import mujoco

from harness import cases
from harness.cases import Case
from harness.core.checks import Check
from harness.core.figures import Figure, FigureName
from harness.engine.integrators import DOCUMENTED_INTEGRATORS
from harness.outputs.jsondoc import json_doc
from harness.outputs.table import checks_table
from harness.pipeline.limits import load_limits
from harness.pipeline.run import CaseResult, run_case
from harness.pipeline.verdict import judge
from harness.pipeline.vocabulary import check_config

__all__ = ["Validation", "ValidationFailed", "case_names", "validate"]


class ValidationFailed(AssertionError):
    """Raised by :meth:`Validation.raise_for_failures`; the message lists every failed check, and
    ``validation`` is the whole result."""

    def __init__(self, validation: Validation) -> None:
        self.validation = validation
        lines = [f"{c.name}: {c.diverged}" if c.diverged else f"{c.name} = {c.value:.3e} {c.unit} > limit "
                 f"{c.threshold:.3e}" for c in validation.failures]
        super().__init__(f"case {validation.case!r} ({validation.mjcf}): {len(lines)} of "
                         f"{len(validation.checks)} checks failed\n  " + "\n  ".join(lines))


@dataclass(frozen=True)
class Validation:
    """What one validation found: every check, every figure measured, and the settings it ran with.

    Attributes:
        case: the case's name.
        mjcf: the model file that ran (the shipped model, or yours).
        checks: each gated figure beside its limit.
        figures: every figure measured, gated or not.
        settings: timestep, integrator, solver, softness, parameters, … as the report lists them.
        limits: where the limits came from.
    """

    case: str
    mjcf: str
    checks: tuple[Check, ...]
    figures: tuple[Figure, ...]
    settings: Mapping[str, object] = field(default_factory=dict)
    limits: str = ""
    result: CaseResult | None = field(default=None, repr=False, compare=False)

    @property
    def passed(self) -> bool:
        """Every check within its limit (an n/a check or a documented defect of this MuJoCo counts)."""
        return all(c.passed for c in self.checks)

    @property
    def failures(self) -> tuple[Check, ...]:
        return tuple(c for c in self.checks if not c.passed)

    def figure(self, name: str) -> Figure:
        """The measured figure called ``name``; KeyError listing the measured ones otherwise."""
        for f in self.figures:
            if f.name == name:
                return f
        raise KeyError(f"no figure {name!r}; measured: {', '.join(f.name for f in self.figures)}")

    def check(self, name: str) -> Check:
        """The check of the figure called ``name``; KeyError listing the gated ones otherwise."""
        for c in self.checks:
            if c.name == name:
                return c
        raise KeyError(f"no check {name!r}; gated: {', '.join(c.name for c in self.checks)}")

    def summary(self) -> str:
        """Every check as the ``mjharness check`` table prints it, ending with the counts."""
        return checks_table({self.case: list(self.checks)})

    def to_json(self) -> dict:
        """This case in the report.json schema (docs/report-json.md)."""
        if self.result is None:
            raise ValueError("this Validation carries no run to write (it was built by hand)")
        return json_doc([self.result], {self.case: list(self.checks)})

    def raise_for_failures(self) -> None:
        """Raise :class:`ValidationFailed`, listing every failed check, unless all passed."""
        if not self.passed:
            raise ValidationFailed(self)


def case_names() -> tuple[str, ...]:
    """Every case this harness knows, as :func:`validate` accepts them."""
    return cases.names()


def _restricted(limits: Mapping[str, float], integrators: Sequence[str] | None) -> dict[str, float]:
    """The limits of the figures a run of ``integrators`` measures (all when None)."""
    if integrators is None:
        return dict(limits)
    chosen = set(integrators)
    return {name: value for name, value in limits.items()
            if FigureName(name).integrator not in DOCUMENTED_INTEGRATORS or FigureName(name).integrator in chosen}


def validate(
    case: str | Case,
    *,
    mjcf: str | Path | None = None,
    integrators: Sequence[str] | None = None,
    timestep: float | None = None,
    config: str | Path | None = None,
    limits: Mapping[str, float] | None = None,
    edit: Callable[[mujoco.MjSpec], None] | None = None,
) -> Validation:
    """Run ``case`` (a name, or a :class:`~harness.cases.Case`) through every layer and judge it.

    Args:
        case: which case; ValueError listing the known ones for an unknown name.
        mjcf: your model file to run instead of the shipped one (it must fit the case: the same joint,
            body and equality names); the reference keeps the shipped model's parameters.
        integrators: run only these (default: every integrator this MuJoCo has); the limits of the
            others are not applied.
        timestep: run at this timestep instead of the model's.
        config: a TOML file overriding limits (``[thresholds.CASE] "FIGURE" = LIMIT``), as ``--config``.
        limits: limits by figure name, overriding the shipped ones and ``config``'s.
        edit: a function changing the model through ``mujoco.MjSpec`` before it is compiled.
    """
    chosen = cases.get(case) if isinstance(case, str) else case
    if not isinstance(chosen, Case):
        raise ValueError(f"case must be a case name or a harness.cases.Case, got {type(case).__name__}")
    if integrators is not None and not list(integrators):
        raise ValueError("integrators must name at least one integrator (None: every one)")
    shipped = load_limits(config)
    check_config(shipped.overrides, cases.all_cases(), source=repr(str(config)))  # every case it names
    merged = shipped.for_case(chosen.name) | {str(FigureName(k)): float(v) for k, v in (limits or {}).items()}
    result = run_case(chosen, mjcf=mjcf, integrators=integrators, timestep=timestep, edit=edit)
    checks = judge(result, _restricted(merged, integrators))
    source = shipped.source + (" + limits given to validate()" if limits else "")
    return Validation(case=chosen.name, mjcf=str(result.settings.get("mjcf", chosen.mjcf)), checks=tuple(checks),
                      figures=result.figures, settings=dict(result.settings), limits=source, result=result)

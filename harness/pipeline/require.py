"""Fitness for purpose: does a model, at its own settings, meet the accuracy a user needs?

A separate question from "is MuJoCo right" (the verdict): a model can be
simulated exactly as its settings say — every figure explained by its
budget — and still be too coarse for its use (2 mm of position error where
1 mm is needed). A requirement names a figure's measure and the largest value
acceptable, ``position=1e-3``; it is judged on the model's own integrator
(the one its file sets, which is what the user runs), on the figure as
measured, in the figure's unit (m for position, m/s for velocity, relative for
drifts and forces). A measure may name a group: ``force`` is every
``force.*`` figure, ``drift`` every drift, ``violation`` and ``series`` alike.

On the command line ``--require position=1e-3`` (repeatable); in a config file::

    [require]
    position = 1e-3
    "drift.energy" = 1e-4
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

from harness.core.errors import ConfigError
from harness.core.figures import FigureName
from harness.pipeline.run import CaseResult

__all__ = ["Fitness", "Requirement", "check_known", "check_possible", "from_config", "judge_fitness", "parse",
           "requirement"]

GROUPS = ("force", "drift", "violation", "series")


@dataclass(frozen=True)
class Requirement:
    """The largest acceptable value of a measure (``position``) or group (``force``)."""

    measure: str
    value: float

    def covers(self, name: FigureName) -> bool:
        return name.measure == self.measure or (self.measure in GROUPS and name.quantity == self.measure)


@dataclass(frozen=True)
class Fitness:
    """One figure of the model's own integrator beside a requirement."""

    case: str
    requirement: Requirement
    figure: FigureName
    value: float
    unit: str

    @property
    def met(self) -> bool:
        return math.isfinite(self.value) and self.value <= self.requirement.value

    def as_dict(self) -> dict[str, object]:
        return {"figure": str(self.figure), "value": self.value, "unit": self.unit,
                "required": self.requirement.value, "met": self.met}


def parse(items: Iterable[str], *, source: str = "--require") -> tuple[Requirement, ...]:
    """``MEASURE=VALUE`` strings as requirements, several in one string separated by commas
    (``position=1e-3,force=1e-2``); ConfigError naming what is wrong and what is accepted."""
    out = []
    for item in (piece for given in items for piece in given.split(",")):
        measure, sep, text = item.partition("=")
        measure = measure.strip()
        if not sep or not measure:
            raise ConfigError(f"{source} {item!r}: expected MEASURE=VALUE, e.g. position=1e-3")
        try:
            value = float(text)
        except ValueError:
            raise ConfigError(f"{source} {item!r}: {text.strip()!r} is not a number") from None
        out.append(requirement(measure, value, source=source))
    return tuple(out)


def requirement(measure: str, value: object, *, source: str) -> Requirement:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) or value <= 0:
        raise ConfigError(f"{source}: {measure} must be a positive number, got {value!r}")
    return Requirement(measure, float(value))


def from_config(table: object, *, source: str) -> tuple[Requirement, ...]:
    """The ``[require]`` table of a config file."""
    if not isinstance(table, Mapping):
        raise ConfigError(f"{source}: 'require' must be a table of MEASURE = VALUE")
    return tuple(requirement(str(k), v, source=f"{source}: require") for k, v in table.items())


def judge_fitness(result: CaseResult, requirements: Sequence[Requirement]) -> list[Fitness]:
    """Every figure of the model's own integrator a requirement covers, beside it."""
    own = result.settings.integrator
    out = []
    for req in requirements:
        for f in result.figures:
            if f.name.layer == "trajectory" and f.name.integrator == own and req.covers(f.name):
                out.append(Fitness(result.case.name, req, f.name, f.value, f.unit))
    return out


def check_possible(requirements: Sequence[Requirement], names: Iterable[str]) -> None:
    """ConfigError, before any run, for a requirement no trajectory figure of ``names`` (every figure the cases
    can give: :func:`harness.families.figure_names`) answers, naming the measures there are; what the runs
    then measure on the models' own integrators is :func:`check_known`'s."""
    if not requirements:
        return
    trajectory = [n for n in map(FigureName, names) if n.layer == "trajectory"]
    for req in requirements:
        if not any(req.covers(n) for n in trajectory):
            raise ConfigError(f"requirement {req.measure!r} matches no figure these cases measure; accepted: "
                              f"{', '.join(sorted({n.measure for n in trajectory}))} or a group "
                              f"({', '.join(GROUPS)})")


def check_known(requirements: Sequence[Requirement], results: Sequence[CaseResult]) -> None:
    """ConfigError for a requirement no figure of any case's own integrator answers (a typo, or a
    measure these cases do not have), naming the measures they have."""
    if not requirements:
        return
    measures = sorted({f.name.measure for r in results for f in r.figures
                       if f.name.layer == "trajectory" and f.name.integrator == r.settings.integrator})
    for req in requirements:
        if not any(judge_fitness(r, [req]) for r in results):
            raise ConfigError(f"requirement {req.measure!r} matches no figure of the models' own integrator; "
                              f"accepted: {', '.join(measures)} or a group ({', '.join(GROUPS)})")

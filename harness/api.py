"""The Python API: validate one case, or your own MJCF variant of it, and get a frozen result.

In the style of ``mujoco.rollout``: one function, keyword-only options, a
result you can inspect or turn into a failing assertion::

    from harness import validate

    result = validate("pendulum", mjcf="my_pendulum.xml", integrators=["RK4"], timestep=0.002)
    result.passed                 # every check's unexplained error within its budget's limit
    result.failures               # the checks that are not
    result.check("RK4.position").budget   # measured, explained (integration, softness, …), unexplained
    result.figure("RK4.position") # any measured figure, gated or not
    result.fit                    # the requirements met (require={"position": 1e-3})
    result.raise_for_failures()   # ValidationFailed (an AssertionError) listing the failures

It runs exactly what ``mjharness check --case CASE --mjcf FILE`` runs (every
layer of :func:`harness.pipeline.run.run_case` and every figure's error
budget, judged by the case's limits, overridden by ``config`` and
``limits``), in this process.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from numbers import Real
from pathlib import Path
from typing import TypeGuard

import mujoco
import numpy as np

from harness import cases
from harness.cases import Case, sources
from harness.core.checks import Check, Limit, gate
from harness.core.figures import Figure, FigureName
from harness.core.findings import Finding
from harness.core.options import RunOptions
from harness.engine import messages
from harness.families import figure_names
from harness.outputs.jsondoc import json_doc
from harness.outputs.table import checks_table, ratio, ratio_text, verdict_line
from harness.pipeline.entry import Judging, evaluate, own_case
from harness.pipeline.outcome import Outcome
from harness.pipeline.require import Fitness, check_possible, judge_fitness
from harness.pipeline.require import requirement as requirement_of
from harness.pipeline.run import CaseResult
from harness.pipeline.settings import RunSettings
from harness.studies import advice
from harness.studies.advice import Advice

__all__ = ["Advice", "Validation", "ValidationFailed", "advise", "case_names", "validate"]


def _amount(value: float, unit: str) -> str:
    """A number to 3 significant digits, with its unit unless it has none ("1")."""
    return f"{value:.3g}" + (f" {unit}" if unit not in ("", "1") else "")


def _failure(c: Check) -> str:
    """One failed check on one line: case, check, what was measured, what is unexplained beside its limit,
    and by how much it is over; for a run that could not be measured, why."""
    head = f"{c.case} {c.name}: "
    if c.diverged:
        reason = c.diverged
        return head + (reason if reason.startswith(("diverged", "not measurable")) else f"not measurable: {reason}")
    text = f"measured {_amount(c.value, c.unit)}"
    if c.budget is not None:
        text += f", unexplained {_amount(c.budget.unexplained, c.unit)}"
    over = ratio(c)
    text += (f" vs limit {_amount(c.threshold, c.unit)} "
             + (f"({ratio_text(over)})" if math.isfinite(over) else "(not finite)"))
    return head + text + (f"; known defect: {c.known}" if c.known else "")


def _unmet(f: Fitness) -> str:
    return (f"{f.case} {f.figure}: measured {_amount(f.value, f.unit)} vs required {f.requirement.value:g} "
            f"(requirement {f.requirement.measure} not met)")


class ValidationFailed(AssertionError):
    """Raised by :meth:`Validation.raise_for_failures`; ``validation`` is the whole result.

    The message is short, to read in a test's failure: the verdict line (naming the model), then one line
    per failed check (case, check, measured, unexplained vs limit and how far over, or why it could not be
    measured) and per unmet requirement.
    """

    def __init__(self, validation: Validation) -> None:
        self.validation = validation
        verdict = verdict_line(validation.outcome)
        if validation.unmet:
            verdict += f"; {len(validation.unmet)} requirement(s) not met"
        lines = [_failure(c) for c in validation.failures] + [_unmet(f) for f in validation.unmet]
        super().__init__(f"{verdict}; model {validation.mjcf}" + "".join(f"\n  {line}" for line in lines))


@dataclass(frozen=True)
class Validation:
    """What one validation found: every check, every figure measured, and the settings it ran with.

    Attributes:
        case: the case's name.
        mjcf: the model file that ran (the shipped model, or yours).
        checks: each gated figure beside its limit.
        figures: every figure measured, gated or not.
        settings: the settings it ran with (:class:`~harness.pipeline.settings.RunSettings`: timestep, integrator,
            solver, softness, parameters, …; what differs from the shipped model in ``changed``).
        limits: where the limits came from.
        fitness: each figure of the model's own integrator a requirement judged.
        findings: engine functions found to disagree while measuring.
        accept_known_defects: whether a failure with a documented defect's signature passes the gate.
    """

    case: str
    mjcf: str
    checks: tuple[Check, ...]
    figures: tuple[Figure, ...]
    settings: RunSettings | None = None
    limits: str = ""
    fitness: tuple[Fitness, ...] = ()
    findings: tuple[Finding, ...] = ()
    accept_known_defects: bool = False
    result: CaseResult | None = field(default=None, repr=False, compare=False)

    @property
    def passed(self) -> bool:
        """The gate: every check passes (an n/a check counts), or — with ``accept_known_defects`` — fails
        only as a documented defect of this MuJoCo."""
        return gate(self.checks, accept_known_defects=self.accept_known_defects)

    @property
    def failures(self) -> tuple[Check, ...]:
        return tuple(c for c in self.checks if not c.passed)

    @property
    def unmet(self) -> tuple[Fitness, ...]:
        return tuple(f for f in self.fitness if not f.met)

    @property
    def fit(self) -> bool:
        """Every requirement given to :func:`validate` met (true where none was)."""
        return not self.unmet

    def __repr__(self) -> str:
        """One line (the dataclass's repr spelled out every check and figure): the case, the model, the
        verdict."""
        failed = len(self.failures)
        verdict = f"{failed} of {len(self.checks)} checks failed" if failed else f"passed, {len(self.checks)} checks"
        return (f"<Validation {self.case!r} ({Path(self.mjcf).name}): {verdict}"
                + (f", {len(self.unmet)} requirement(s) not met" if self.unmet else "") + ">")

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
        return json_doc([self.result], self.outcome)

    @property
    def outcome(self) -> Outcome:
        return Outcome(checks={self.case: list(self.checks)}, fitness={self.case: list(self.fitness)},
                       findings={self.case: list(self.findings)} if self.findings else {},
                       requirements=tuple(dict.fromkeys(f.requirement for f in self.fitness)),
                       accept_known_defects=self.accept_known_defects)

    def raise_for_failures(self) -> None:
        """Raise :class:`ValidationFailed`, listing every failed check and unmet requirement, unless the
        gate passed and every requirement is met."""
        __tracebackhide__ = True  # pytest: the failure shows in the test's own line, not here with self's repr
        if not self.passed or not self.fit:
            raise ValidationFailed(self)


def _number(value: object) -> TypeGuard[Real]:
    """A real number (int or float, numpy's included), not a bool or a string."""
    return isinstance(value, Real) and not isinstance(value, bool)


def _seconds(name: str, value: object) -> None:
    """TypeError unless ``value`` is None or a number; ValueError unless it is finite and positive."""
    if value is None:
        return
    if not _number(value):
        raise TypeError(f"{name} must be a number of seconds (a float such as 0.001), got {value!r} "
                        f"({type(value).__name__})")
    if not (math.isfinite(float(value)) and float(value) > 0):
        raise ValueError(f"{name} must be a finite number of seconds > 0, got {value!r}")


def _numbers_by_name(name: str, value: object, example: str) -> None:
    """TypeError unless ``value`` is None or a mapping of names (str) to numbers."""
    if value is None:
        return
    if not isinstance(value, Mapping):
        raise TypeError(f"{name} must be a mapping of names to numbers, e.g. {example}, got {value!r} "
                        f"({type(value).__name__})")
    bad = [f"{k!r}: {v!r}" for k, v in value.items() if not isinstance(k, str) or not _number(v)]
    if bad:
        raise TypeError(f"{name} must map names (str) to numbers, e.g. {example}; not {', '.join(bad)}")


def _check_arguments(*, integrators: object, timestep: object, horizon: object, q0: object, qd0: object,
                     limits: object, require: object, accept_known_defects: object, edit: object,
                     keyframe: object = None, ctrl: object = None) -> None:
    """Each argument of :func:`validate` of the type it must have, before any work: TypeError (or
    ValueError for a value out of range) naming the argument and what it accepts, never an error from deep
    inside the run or a value silently read as something else (``"no"`` as true, ``"RK4"`` letter by
    letter)."""
    if integrators is not None and (isinstance(integrators, str) or not isinstance(integrators, Iterable)
                                    or not all(isinstance(n, str) for n in integrators)):
        raise TypeError(f"integrators must be a list of integrator names, e.g. ['RK4'], got {integrators!r}")
    _seconds("timestep", timestep)
    _seconds("horizon", horizon)
    _numbers_by_name("q0", q0, "{'theta': 0.3}")
    _numbers_by_name("qd0", qd0, "{'theta': 0.0}")
    _numbers_by_name("limits", limits, "{'RK4.position': 1e-6}")
    _numbers_by_name("require", require, "{'position': 1e-3}")
    if not isinstance(accept_known_defects, bool | np.bool_):
        raise TypeError(f"accept_known_defects must be True or False, got {accept_known_defects!r}")
    if edit is not None and not callable(edit):
        raise TypeError(f"edit must be a function of a mujoco.MjSpec (or None), got {edit!r}")
    if keyframe is not None and not isinstance(keyframe, str):
        raise TypeError(f"keyframe must be a keyframe's name (a string), e.g. 'home', got {keyframe!r}")
    _numbers_by_name("ctrl", ctrl, "{'shoulder': 0.5}")


def _in_place(edit: Callable[[mujoco.MjSpec], object]) -> Callable[[mujoco.MjSpec], None]:
    """``edit``, refusing a result: an edit changes the spec it is given and returns None, so a function
    that returns something (a new spec, a model) would otherwise be run for nothing, silently."""
    def checked(spec: mujoco.MjSpec) -> None:
        returned = edit(spec)
        if returned is not None:
            raise TypeError(f"edit must change the mujoco.MjSpec it is given in place and return None; it "
                            f"returned {type(returned).__name__} (what it returns is not used)")
    return checked


def _directories(systems: object) -> tuple[str | os.PathLike, ...]:
    """``systems`` as a tuple of directories; TypeError for anything but a list of paths (a bare path too:
    a string would be read letter by letter)."""
    if systems is None:
        return ()
    if isinstance(systems, str | os.PathLike) or not isinstance(systems, Iterable):
        raise TypeError(f"systems must be a list of directories, e.g. ['my_systems'], got {systems!r}")
    chosen = tuple(systems)
    bad = [d for d in chosen if not isinstance(d, str | os.PathLike)]
    if bad:
        raise TypeError(f"systems must be a list of directories (str or Path), e.g. ['my_systems']; not "
                        f"{', '.join(repr(d) for d in bad)}")
    return chosen


def case_names(*, systems: Iterable[str | os.PathLike] | None = None) -> tuple[str, ...]:
    """Every case this harness knows, as :func:`validate` accepts them: the shipped ones, the installed
    packages' and those of the ``systems`` directories (:mod:`harness.cases.sources`)."""
    with sources.using(_directories(systems)):
        return cases.names()


def validate(
    case: str | Case | None = None,
    *,
    mjcf: str | Path | None = None,
    keyframe: str | None = None,
    ctrl: Mapping[str, float] | None = None,
    integrators: Sequence[str] | None = None,
    timestep: float | None = None,
    horizon: float | None = None,
    q0: Mapping[str, float] | None = None,
    qd0: Mapping[str, float] | None = None,
    config: str | Path | None = None,
    limits: Mapping[str, float] | None = None,
    require: Mapping[str, float] | None = None,
    accept_known_defects: bool = False,
    edit: Callable[[mujoco.MjSpec], None] | None = None,
    backend: str = "c",
    systems: Iterable[str | os.PathLike] | None = None,
) -> Validation:
    """Run ``case`` (a name, or a :class:`~harness.cases.Case`), or any model ``mjcf``, through every layer
    and judge it.

    Args:
        case: which case; ValueError listing the known ones for an unknown name. None with ``mjcf``: the
            model is judged against its own kinematic tree (:func:`harness.cases.own.from_mjcf`).
        mjcf: with a case, your model file to run instead of the shipped one (it must fit the case: the same
            joint, body and equality names; the reference is built from its parameters); without one, any
            model, its reference derived from its own tree.
        keyframe, ctrl: for a model judged against its own tree, the keyframe it starts from (default: qpos0
            at rest) and actuator controls by name (default: the keyframe's, else 0).
        integrators: run only these (default: every integrator this MuJoCo has); the checks of the
            others are not judged.
        timestep: run at this timestep instead of the model's.
        horizon: simulate this long instead of the case's horizon (s).
        q0, qd0: initial coordinates and velocities by name (the others as the case has them); the state
            is brought onto the model's constraints.
        config: a TOML file as ``--config``: limits (``[thresholds.CASE] "FIGURE" = LIMIT``),
            requirements (``[require]``), ``accept_known_defects``.
        limits: fixed limits by figure name, overriding the shipped ones and ``config``'s.
        require: the accuracy you need by measure (``{"position": 1e-3}``), judged on the model's own
            integrator: :attr:`Validation.fit`.
        accept_known_defects: let a failure with a documented defect's signature pass the gate (True or
            False).
        edit: a function changing the model through ``mujoco.MjSpec`` before it is compiled, in place (it
            returns None).
        backend: the engine every run goes to: ``c`` (MuJoCo's C engine), ``mjx`` (float32), or ``mjx-f64``
            (:data:`harness.engine.backends.BACKENDS`); a backend not installed, or a model feature
            it lacks, raises :class:`~harness.core.errors.BackendUnavailable` naming the fix.
        systems: directories of your own systems, each holding ``NAME.py`` (the analytic system), ``NAME.xml``
            (its MJCF) and ``NAME.limits.toml``, whose cases are discovered for this call as well as the shipped
            and installed ones (:mod:`harness.cases.sources`); ValueError in one line for a directory that is
            missing, a module that does not import or a name another source has.

    An argument of the wrong type raises TypeError naming it and what it accepts, before any work.
    """
    _check_arguments(integrators=integrators, timestep=timestep, horizon=horizon, q0=q0, qd0=qd0, limits=limits,
                     require=require, accept_known_defects=accept_known_defects, edit=edit, keyframe=keyframe,
                     ctrl=ctrl)
    options = RunOptions(mjcf=mjcf, integrators=tuple(integrators) if integrators is not None else None,
                         timestep=timestep, horizon=horizon, q0=q0, qd0=qd0,
                         edit=_in_place(edit) if edit is not None else None, backend=backend)
    judging = _Judging(config=config, limits=limits or {}, require=require or {},
                       accept_known_defects=accept_known_defects)
    with sources.using(_directories(systems)), messages.kept_within():  # MuJoCo's warnings: in the result only
        return _validate(case, options, judging, keyframe=keyframe, ctrl=ctrl)


@dataclass(frozen=True)
class _Judging:
    """How :func:`validate` judges what it ran: its ``config``, ``limits``, ``require`` and
    ``accept_known_defects``, checked."""

    config: str | Path | None
    limits: Mapping[str, float]
    require: Mapping[str, float]
    accept_known_defects: bool


def _validate(case: str | Case | None, options: RunOptions, judging: _Judging, *, keyframe: str | None,
              ctrl: Mapping[str, float] | None) -> Validation:
    """:func:`validate` with its arguments checked and the user's systems in use."""
    if case is None and options.mjcf is None:
        raise ValueError("validate needs a case name (or Case) or an mjcf path; known cases: "
                         + ", ".join(cases.names()))
    if case is None:  # any model, judged against its own tree: the model is the case's, not a variant of it
        assert options.mjcf is not None  # (checked above)
        chosen = own_case(options.mjcf, keyframe=keyframe, ctrl=ctrl, horizon=options.horizon)
        options = dataclasses.replace(options, mjcf=None)
    else:
        chosen = cases.get(case) if isinstance(case, str) else case
    if not isinstance(chosen, Case):
        raise ValueError(f"case must be a case name or a harness.cases.Case, got {type(case).__name__}")
    if chosen.tree is None and (keyframe is not None or ctrl):
        raise ValueError("keyframe and ctrl apply to a model judged against its own tree (mjcf= without a case)")
    if options.integrators is not None and not options.integrators:
        raise ValueError("integrators must name at least one integrator (None: every one)")
    given = {str(FigureName(k)): Limit("user", float(v), "given to validate()") for k, v in judging.limits.items()}
    required = tuple(requirement_of(str(k), v, source="validate(require=...)") for k, v in judging.require.items())
    done = evaluate(chosen, options=options, judging=Judging(config=judging.config, limits=given, require=required,
                                                             accept_known_defects=judging.accept_known_defects),
                    jobs=1, bar=False, record_costs=False)
    result, checks = done.results[0], done.checks[chosen.name]
    source = done.limits.source + (" + limits given to validate()" if judging.limits else "")
    return Validation(case=chosen.name, mjcf=result.settings.mjcf, checks=tuple(checks),
                      figures=result.figures, settings=result.settings, limits=source,
                      fitness=tuple(judge_fitness(result, done.outcome.requirements)), findings=tuple(result.findings),
                      accept_known_defects=done.outcome.accept_known_defects, result=result)


def advise(
    case: str | Case | None = None,
    *,
    require: Mapping[str, float],
    mjcf: str | Path | None = None,
    keyframe: str | None = None,
    ctrl: Mapping[str, float] | None = None,
    integrators: Sequence[str] | None = None,
    horizon: float | None = None,
    systems: Iterable[str | os.PathLike] | None = None,
) -> Advice:
    """Which integrator and timestep meet ``require`` for ``case`` (a name or a :class:`~harness.cases.Case`) or
    any model ``mjcf`` (against its own tree): every integrator's error against the reference over a ladder of
    timesteps with error bars, its stability limit (confirmed by runs) and its measured cost, and the cheapest
    setting meeting every requirement, verified by checking the model there (:mod:`harness.studies.advice`).

    Args:
        case, mjcf, keyframe, ctrl, horizon, systems: as for :func:`validate` (one model: a case, or ``mjcf``).
        require: the accuracy needed by measure, e.g. ``{"position": 1e-3, "force": 1e-2}`` (at least one).
        integrators: consider only these (default: every integrator this MuJoCo has).

    :attr:`Advice.recommended` is None where no setting meets the requirements, and :attr:`Advice.why_none` says
    why. An argument of the wrong type raises TypeError naming it, before any work.
    """
    _check_arguments(integrators=integrators, timestep=None, horizon=horizon, q0=None, qd0=None, limits=None,
                     require=require, accept_known_defects=False, edit=None, keyframe=keyframe, ctrl=ctrl)
    if not require:
        raise ValueError("advise needs at least one requirement, e.g. require={'position': 1e-3}")
    if (case is None) == (mjcf is None):
        raise ValueError("advise needs one model: a case (name or Case), or mjcf= (not both); known cases: "
                         + ", ".join(cases.names()))
    requirements = tuple(requirement_of(str(k), v, source="advise(require=...)") for k, v in require.items())
    with sources.using(_directories(systems)), messages.kept_within():
        if mjcf is not None:
            chosen: object = own_case(mjcf, keyframe=keyframe, ctrl=ctrl, horizon=horizon)
        else:
            if keyframe is not None or ctrl:
                raise ValueError("keyframe and ctrl apply to a model judged against its own tree (mjcf=, no case)")
            chosen = cases.get(case) if isinstance(case, str) else case
        if not isinstance(chosen, Case):
            raise ValueError(f"case must be a case name or a harness.cases.Case, got {type(case).__name__}")
        check_possible(requirements, figure_names(chosen))
        options = RunOptions(horizon=horizon if mjcf is None else None)
        return advice.advise(chosen, requirements, options=options,
                             integrators=tuple(integrators) if integrators is not None else None)

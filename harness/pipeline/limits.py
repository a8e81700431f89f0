"""Limits: which figures of a case are gated, and how each is judged, with its basis.

A case's limits are data shipped with its model, ``mjcf/NAME.limits.toml``
(package data, so editable, regular and ``--user`` installs all find them)::

    notes = ["what holds for the whole case: why a figure is gated or not"]

    [limits]
    "RK4.position" = { basis = "budget" }
    "converge.RK4.order_shortfall" = { value = 0.3, basis = "theory", reason = "..." }

Every limit carries its basis:

- ``budget``: the figure is judged by its error budget (:mod:`harness.budget`, each family's):
  what the model's own settings explain — integration error, softness, the
  point masses' inertia floors — is removed, and the unexplained residual must
  lie within the limit the estimates' own accuracy sets, computed for each run
  from the model under test. No number is stored: a user's timestep, softness
  or parameters change the budget, not the verdict;
- ``theory``: a fixed bound derived without the model's settings (the
  ``reason`` gives the formula and its margin): a convergence order's
  shortfall, the reference's own accuracy at its tolerance;
- ``user``: a value from a user's ``--config`` (below), on the figure as measured.

``mjharness limits --write [CASE ...]`` writes the file of a case that has none,
by the default rule (each family's: :func:`harness.families.gated`). Nothing is measured into a limit:
what the shipped settings give is the regression baseline's business
(``reports/baseline``), a separate question.

A user's ``--config FILE`` overrides limits key by key with fixed values on
the measured figures; its schema is::

    [thresholds.CASE]          # or [tool.mjharness.thresholds.CASE] in a pyproject.toml
    "FIGURE" = LIMIT

    [require]                  # fitness for purpose, judged on each model's own integrator
    position = 1e-3            # (see harness.pipeline.require)

    accept_known_defects = true   # a failure with a documented defect's signature does not fail the gate

    [accept_inertia]           # a body whose inertial the inertia audit finds unphysical (harness.inertia),
    link2 = "REASON"           # accepted: the reason is printed with the finding, which no longer fails
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from harness import families
from harness.cases import Case, all_cases, did_you_mean
from harness.core import inputs
from harness.core.checks import BASES, Limit
from harness.core.errors import ConfigError
from harness.core.figures import FigureName
from harness.families import peers as peers_family
from harness.pipeline.require import Requirement, from_config

__all__ = ["SHIPPED_SOURCE", "Limit", "Limits", "case_limits", "check_config", "load_limits"]

CONFIG_KEYS = {"thresholds", "require", "accept_known_defects", "accept_inertia"}


@dataclass(frozen=True)
class CaseLimits:
    """A case's limits by figure, in file order, and the notes that hold for the whole case."""

    case: str
    limits: Mapping[str, Limit]
    notes: tuple[str, ...] = ()


def limits_path(model: Path) -> Path:
    """Where the limits of the case whose model is ``model`` (``mjcf/NAME.xml``) live."""
    return model.with_name(f"{model.stem}.limits.toml")


def _read_toml(path: Path, what: str) -> dict:
    try:
        return tomllib.loads(inputs.read_text(path, what=what))
    except OSError as exc:
        raise ConfigError(f"cannot read {what} {str(path)!r}: {exc.strerror}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{what} {str(path)!r} is not valid TOML: {' '.join(str(exc).split())}") from None


def read_case_limits(case: str, path: Path) -> CaseLimits:
    """A case's limits file (ConfigError naming the file and the entry for anything malformed)."""
    data = _read_toml(path, "limits file")
    table = data.get("limits")
    if not isinstance(table, dict):
        raise ConfigError(f"{str(path)!r} has no [limits] table")
    limits = {}
    for name, entry in table.items():
        where = f"{str(path)!r}: limits.{name!r}"
        try:
            FigureName(name)
        except ValueError as exc:
            raise ConfigError(f"{where}: {exc}") from None
        if not isinstance(entry, dict) or entry.get("basis") not in BASES:
            raise ConfigError(f"{where} must be a table with basis {' or '.join(BASES)}")
        unknown = set(entry) - {"value", "basis", "reason"}
        if unknown:
            raise ConfigError(f"{where}: unknown key(s) {sorted(unknown)}; accepted: basis, value, reason")
        try:
            limits[name] = Limit(**entry)
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"{where}: {exc}") from None
    notes = data.get("notes", [])
    if not isinstance(notes, list) or not all(isinstance(n, str) for n in notes):
        raise ConfigError(f"{str(path)!r}: notes must be a list of strings")
    return CaseLimits(case=case, limits=limits, notes=tuple(notes))


def _toml_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _toml_number(value: float) -> str:
    text = repr(float(value))
    return text if re.search(r"[.eE]|inf|nan", text) else text + ".0"


def format_case_limits(limits: CaseLimits) -> str:
    """The TOML text of a limits file (what :func:`read_case_limits` reads back)."""
    lines = [f"# The {limits.case} case's gated figures, each with its basis: \"budget\" (judged by its error",
             "# budget, computed for each run from the model under test) or \"theory\" (a fixed bound; the",
             "# reason gives it). See harness/pipeline/limits.py.",
             "", "notes = ["]
    lines += [f"    {_toml_string(n)}," for n in limits.notes]
    lines += ["]", "", "[limits]"]
    for name, lim in limits.limits.items():
        parts = [] if lim.value is None else [f"value = {_toml_number(lim.value)}"]
        parts.append(f"basis = {_toml_string(lim.basis)}")
        if lim.reason:
            parts.append(f"reason = {_toml_string(lim.reason)}")
        lines.append(f"{_toml_string(name)} = {{ {', '.join(parts)} }}")
    return "\n".join(lines) + "\n"


def default_limits(case: str, figures: Iterable[str], *, constrained: bool) -> CaseLimits:
    """The limits a case without a file gets: every figure its family gates by default
    (:func:`harness.families.gated`) with its family's limit from theory where it has one, else its budget."""
    limits = {}
    for name in figures:
        figure = FigureName(name)
        if families.gated(figure, constrained=constrained):
            limits[str(figure)] = families.theory_limit(figure) or Limit("budget")
    return CaseLimits(case=case, limits=limits)


@dataclass(frozen=True)
class Limits:
    """The limits every case is judged by: each case's shipped limits, overridden key by key by a
    user's config (``source`` says which files)."""

    cases: Mapping[str, CaseLimits]
    source: str
    overrides: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    requirements: tuple[Requirement, ...] = ()
    accept_known_defects: bool = False
    accept_inertia: Mapping[str, str] = field(default_factory=dict)

    def for_case(self, case: str) -> dict[str, Limit]:
        """The limits of ``case`` by figure name (what a verdict uses): the shipped ones, a user's
        override as basis ``user``."""
        shipped = self.cases.get(case)
        limits = dict(shipped.limits) if shipped else {}
        for name, value in self.overrides.get(case, {}).items():
            limits[name] = Limit("user", value, f"set by {self.source}")
        return limits

    def limit(self, case: str, figure: str) -> Limit | None:
        """The limit of one figure with its basis (a user override is basis ``user``)."""
        return self.for_case(case).get(figure)


def case_limits(limits: Limits, case: Case, figures: Iterable[str]) -> dict[str, Limit]:
    """The limits ``case`` is judged by: the second opinions' theory limit on each ``instant.peer.*`` figure it
    measured (:mod:`harness.opinions.threeway`), and its limits file's (with a user's overrides), or for a case without
    one (a model the user brings, judged against its own tree; a user's system whose limits are not written
    yet) the default rule's over the ``figures`` it measured or could not (give both: one it could not is then
    n/a with its reason, never absent), so that every figure the rule gates is judged, never none."""
    figures = list(figures)
    peers = {f: limit for f in figures if peers_family.owns(FigureName(f))
             and (limit := peers_family.theory_limit(FigureName(f))) is not None}
    if case.tree is None and case.name in limits.cases:
        return peers | limits.for_case(case.name)
    names = [FigureName(f) for f in figures if f not in peers]
    constrained = any(f.quantity in ("force", "violation") for f in names)
    out = dict(default_limits(case.name, [str(f) for f in names], constrained=constrained).limits)
    out |= peers
    for name, value in limits.overrides.get(case.name, {}).items():
        out[name] = Limit("user", value, f"set by {limits.source}")
    return out


def _config_section(path: Path) -> dict:
    data: Any = _read_toml(path, "config")  # TOML's tables, checked below
    if "tool" in data:
        tool = data["tool"]
        data = tool.get("mjharness") if isinstance(tool, dict) else None
        if data is None:
            raise ConfigError(f"config {str(path)!r} has no [tool.mjharness] table")
    if not isinstance(data, dict):
        raise ConfigError(f"config {str(path)!r}: [tool.mjharness] must be a table")
    unknown = set(data) - CONFIG_KEYS
    if unknown:
        raise ConfigError(f"config {str(path)!r}: unknown key(s) {sorted(unknown)}; "
                          f"accepted: {sorted(CONFIG_KEYS)}")
    return data


def _overrides(raw: object, path: Path, known_cases: set[str]) -> dict[str, dict[str, float]]:
    if not isinstance(raw, dict):
        raise ConfigError(f"config {str(path)!r}: 'thresholds' must be a table of cases")
    out: dict[str, dict[str, float]] = {}
    for case, table in raw.items():
        if case not in known_cases:
            raise ConfigError(f"config {str(path)!r}: unknown case {case!r} in thresholds; "
                              f"{did_you_mean(case, sorted(known_cases))}known cases: {', '.join(sorted(known_cases))}")
        if not isinstance(table, dict):
            raise ConfigError(f"config {str(path)!r}: thresholds.{case} must be a table")
        for fig, value in table.items():
            if isinstance(value, dict):  # RK4.position = 1 unquoted: TOML nests a table "RK4"
                inner = next(iter(value), "QUANTITY")
                raise ConfigError(f"config {str(path)!r}: thresholds.{case}.{fig} is a table; quote dotted "
                                  f"figure names, e.g. \"{fig}.{inner}\" = LIMIT")
            if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) \
                    or value <= 0:
                raise ConfigError(f"config {str(path)!r}: thresholds.{case}.{fig!r} must be a "
                                  f"positive number, got {value!r}")
        out[case] = {k: float(v) for k, v in table.items()}
    return out


SHIPPED_SOURCE = "the shipped limits (mjcf/CASE.limits.toml)"
"""Where the limits come from where no config is given."""


def load_limits(config: Path | str | None = None) -> Limits:
    """Every case's shipped limits (a case without a limits file has none), overridden key by key by
    ``config``."""
    models = {c.name: c.mjcf for c in all_cases()}
    cases = {}
    for case, model in models.items():
        path = limits_path(Path(model))
        if path.is_file():
            cases[case] = read_case_limits(case, path)
    source = SHIPPED_SOURCE
    overrides: dict[str, dict[str, float]] = {}
    requirements: tuple[Requirement, ...] = ()
    accept = False
    if config is not None:
        config = Path(config)
        section = _config_section(config)
        overrides = _overrides(section.get("thresholds", {}), config, set(models))
        requirements = from_config(section.get("require", {}), source=f"config {str(config)!r}")
        accept = section.get("accept_known_defects", False)
        if not isinstance(accept, bool):
            raise ConfigError(f"config {str(config)!r}: accept_known_defects must be true or false, got {accept!r}")
        source = f"{source} + {config}"
        inertia = _accept_inertia(section.get("accept_inertia", {}), config)
    return Limits(cases=cases, source=source, overrides=overrides, requirements=requirements,
                  accept_known_defects=accept, accept_inertia=inertia if config is not None else {})


def _accept_inertia(raw: object, path: Path) -> dict[str, str]:
    """The ``[accept_inertia]`` table: body name → the reason its inertia finding is accepted (a non-empty
    string: an acceptance without a reason is refused)."""
    if not isinstance(raw, dict) or not all(isinstance(v, str) and v.strip() for v in raw.values()):
        raise ConfigError(f"config {str(path)!r}: accept_inertia must be a table of body = \"reason\" (a "
                          "non-empty string saying why the body's inertial is accepted)")
    return {str(k): v.strip() for k, v in raw.items()}


def check_config(overrides: Mapping[str, Mapping[str, float]], cases: Iterable[Case], *, source: str) -> None:
    """ConfigError naming the first figure of ``overrides`` (limits by case) that its case cannot have, before any
    case runs. A case that runs is judged against what it measured (:mod:`harness.pipeline.verdict`: a limit naming
    an unmeasured figure is a config error); a case a config names but the command does not run measured nothing,
    and a typo there ("RK4.positon") would pass silently: it is checked against every name its families can give it
    (:func:`harness.families.figure_names`, a superset; tests/test_bad_input.py pins that every figure a shipped
    case measures is in it)."""
    by_name = {c.name: c for c in cases}
    for case, limits in overrides.items():
        if case not in by_name:
            continue
        known = families.figure_names(by_name[case])
        unknown = sorted(set(limits) - known)
        if unknown:
            raise ConfigError(f"config {source}: thresholds for case {case!r} name unmeasured figure(s) {unknown}, "
                              f"which it does not have; its figures: {', '.join(sorted(known))}")

"""Limits: the largest value each gated figure of a case may take, each with its basis.

A case's limits are data shipped with its model, ``mjcf/NAME.limits.toml``
(package data, so editable, regular and ``--user`` installs all find them)::

    notes = ["what holds for the whole case: parameters, scales, floors"]

    [limits]
    "instant.mass_matrix" = { value = 2e-10, basis = "theory", reason = "point-mass floor ... = 1e-10; ×2" }
    "Euler.position" = { value = 4e-3, basis = "measured", measured = 2.0e-3, margin = 2.0, reason = "..." }

Every limit carries its basis:

- ``theory``: a bound derived from the model (the ``reason`` gives the
  formula and the margin applied), or a round-off floor;
- ``measured``: the figure measured at the shipped settings (``measured``)
  times a stated ``margin``; ``value`` ≥ measured × margin, rounded up.

``mjharness limits --write [CASE ...]`` rewrites the measured limits from a
fresh run (theory limits are kept), and writes a case that has no file yet
with the default gating rule (:data:`DEFAULT_GATED`, margin
:data:`DEFAULT_MARGIN`). A figure passes when its value is finite and ≤ its
limit.

A user's ``--config FILE`` overrides limits key by key; its schema is::

    [thresholds.CASE]          # or [tool.mjharness.thresholds.CASE] in a pyproject.toml
    "FIGURE" = LIMIT
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from harness.cases import all_cases
from harness.core.errors import ConfigError
from harness.core.figures import Figure, FigureName
from harness.layers.orders import ORDER_TOLERANCE

Basis = Literal["theory", "measured", "user"]
BASES = ("theory", "measured")
CONFIG_KEYS = {"thresholds"}

DEFAULT_MARGIN = 3.0
"""Margin of a limit set from a measurement at the shipped settings, for a case that has none yet:
the top of the 2–3× the shipped cases use. Runs are bit-identical on one machine; across platforms
round-off and solver jitter move trajectory figures by percents, a real change by factors."""

ROUNDOFF_FLOOR = 1e-13
"""No measured limit is set below this (in the figure's unit, relative or SI at the case's O(1)
scale): a figure at double-precision round-off (1e-16 a step, ~1e-14 accumulated over thousands of
steps) may grow by an order of magnitude across platforms and libraries without meaning anything.
The lowest measured limit the shipped cases set by hand was 2e-13."""


def _default_gated(name: FigureName, constrained: bool) -> bool:
    """Which measured figures a new case gates: every instantaneous figure; the reference's quality
    (its residual only where it has constraints); per integrator the position, the drifts, forces,
    violations and MuJoCo-only series, and each conserved momentum against the reference; every
    convergence order. Not gated: position at the horizon, velocity, energy against the reference
    (the drift is gated) and the generalized force (its rows are gated as forces)."""
    if name.layer in ("instant", "converge"):
        return True
    if name.layer == "reference":
        return name.quantity != "residual" or constrained
    return name.quantity in ("position", "drift", "force", "violation", "series") or name.quantity.startswith("p_")


DEFAULT_GATED = _default_gated


@dataclass(frozen=True)
class Limit:
    """One figure's limit and its basis (see the module docstring)."""

    value: float
    basis: Basis
    reason: str = ""
    measured: float | None = None
    margin: float | None = None

    def __post_init__(self) -> None:
        if isinstance(self.value, bool) or not isinstance(self.value, int | float) or not math.isfinite(self.value) \
                or self.value <= 0:
            raise ValueError(f"a limit must be a positive number, got {self.value!r}")
        if self.basis == "measured":
            if self.measured is None or self.margin is None:
                raise ValueError("a measured limit needs the measured value and the margin")
            if not self.margin >= 1 or self.value < self.measured * self.margin * (1 - 1e-9):
                raise ValueError(f"a measured limit must be ≥ measured × margin with margin ≥ 1, got "
                                 f"{self.value:g} for {self.measured:g} × {self.margin:g}")

    def describe(self) -> str:
        """One line: the basis and its reason."""
        if self.basis == "measured":
            measured = f"measured {self.measured:.3g} × margin {self.margin:g}"
            return f"{measured}; {self.reason}" if self.reason else measured
        return f"{self.basis}: {self.reason}" if self.reason else self.basis


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
        return tomllib.loads(path.read_text(encoding="utf-8"))
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
        unknown = set(entry) - {"value", "basis", "reason", "measured", "margin"}
        if unknown:
            raise ConfigError(f"{where}: unknown key(s) {sorted(unknown)}")
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
    lines = [f"# Limits of the {limits.case} case's gated figures, each with its basis: \"theory\" (the reason",
             "# gives the bound) or \"measured\" (the figure at the shipped settings × margin). Measured ones are",
             f"# rewritten from a fresh run by `mjharness limits --write {limits.case}`; see",
             "# harness/pipeline/limits.py.",
             "", "notes = ["]
    lines += [f"    {_toml_string(n)}," for n in limits.notes]
    lines += ["]", "", "[limits]"]
    for name, lim in limits.limits.items():
        parts = [f"value = {_toml_number(lim.value)}", f"basis = {_toml_string(lim.basis)}"]
        if lim.measured is not None:
            parts.append(f"measured = {_toml_number(lim.measured)}")
        if lim.margin is not None:
            parts.append(f"margin = {_toml_number(lim.margin)}")
        if lim.reason:
            parts.append(f"reason = {_toml_string(lim.reason)}")
        lines.append(f"{_toml_string(name)} = {{ {', '.join(parts)} }}")
    return "\n".join(lines) + "\n"


def round_up(value: float, digits: int = 2) -> float:
    """``value`` rounded up to ``digits`` significant digits (a limit never ends below its product)."""
    if value <= 0:
        return value
    exponent = math.floor(math.log10(value)) - digits + 1
    mantissa = math.ceil(value / 10.0**exponent - 1e-9)  # 1e-9 of a 2-digit mantissa: float noise only
    return float(f"{mantissa}e{exponent}")


def measured_limit(measured: float, margin: float, reason: str = "") -> Limit:
    """A limit set from a measurement: round_up(measured × margin), never below the round-off floor."""
    value = round_up(measured * margin)
    if not value >= ROUNDOFF_FLOOR:
        floor = f"round-off floor {ROUNDOFF_FLOOR:g} (measured × margin = {measured * margin:.2g})"
        return Limit(value=ROUNDOFF_FLOOR, basis="measured", measured=measured, margin=margin,
                     reason=f"{reason}; {floor}" if reason else floor)
    return Limit(value=value, basis="measured", measured=measured, margin=margin, reason=reason)


ORDER_REASON = ("max(0, documented − observed order) ≤ 0.3: a floor at 1/10 of the smallest fitted error biases the "
                "fitted slope by ≤ 0.14 (harness/layers/orders.py)")


def theory_limit(name: FigureName) -> Limit | None:
    """The limit theory sets for a figure whatever the case (None where only a measurement can): a
    convergence order's shortfall, which the fit's floor bias bounds."""
    if name.layer == "converge" and name.quantity == "order_shortfall":
        return Limit(value=ORDER_TOLERANCE, basis="theory", reason=ORDER_REASON)
    return None


def remeasured(case: str, old: CaseLimits | None, figures: Iterable[Figure], *, constrained: bool,
               skip: Iterable[str] = ()) -> CaseLimits:
    """New limits from freshly measured ``figures``: each measured limit of ``old`` set again from its
    figure with its own margin, theory limits kept as they are; with no ``old``, a limit for every
    figure :data:`DEFAULT_GATED` picks: its theory limit where one applies to any case
    (:func:`theory_limit`), else the measurement at :data:`DEFAULT_MARGIN`. Figures in ``skip``
    (integrators this MuJoCo lacks) keep their old limits."""
    measured = {f.name: f.value for f in figures}
    skip = set(skip)
    if old is None:
        limits = {name: theory_limit(FigureName(name)) or measured_limit(value, DEFAULT_MARGIN, "default rule")
                  for name, value in measured.items() if DEFAULT_GATED(FigureName(name), constrained)}
        return CaseLimits(case=case, limits=limits)
    out = {}
    for name, lim in old.limits.items():
        if lim.basis != "measured" or name in skip:
            out[name] = lim
            continue
        if name not in measured or not math.isfinite(measured[name]):
            raise ValueError(f"case {case!r}: figure {name!r} was not measured (or is not finite); "
                             "cannot rewrite its limit")
        out[name] = measured_limit(measured[name], float(lim.margin), lim.reason)  # type: ignore[arg-type]
    return CaseLimits(case=case, limits=out, notes=old.notes)


@dataclass(frozen=True)
class Limits:
    """The limits every case is judged by: each case's shipped limits, overridden key by key by a
    user's config (``source`` says which files)."""

    cases: Mapping[str, CaseLimits]
    source: str
    overrides: Mapping[str, Mapping[str, float]] = field(default_factory=dict)

    def for_case(self, case: str) -> dict[str, float]:
        """The limit values of ``case`` by figure name (what a verdict uses)."""
        shipped = self.cases.get(case)
        values = {name: lim.value for name, lim in shipped.limits.items()} if shipped else {}
        return values | dict(self.overrides.get(case, {}))

    def limit(self, case: str, figure: str) -> Limit | None:
        """The limit of one figure with its basis (a user override is basis ``user``)."""
        if figure in self.overrides.get(case, {}):
            return Limit(value=self.overrides[case][figure], basis="user", reason=f"set by {self.source}")
        shipped = self.cases.get(case)
        return shipped.limits.get(figure) if shipped else None


def _config_section(path: Path) -> dict:
    data = _read_toml(path, "config")
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
                              f"known cases: {', '.join(sorted(known_cases))}")
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


def load_limits(config: Path | str | None = None) -> Limits:
    """Every case's shipped limits (a case without a limits file has none), overridden key by key by
    ``config``."""
    models = {c.name: c.mjcf for c in all_cases()}
    cases = {}
    for case, model in models.items():
        path = limits_path(Path(model))
        if path.is_file():
            cases[case] = read_case_limits(case, path)
    source = "the shipped limits (mjcf/CASE.limits.toml)"
    overrides: dict[str, dict[str, float]] = {}
    if config is not None:
        config = Path(config)
        overrides = _overrides(_config_section(config).get("thresholds", {}), config, set(models))
        source = f"{source} + {config}"
    return Limits(cases=cases, source=source, overrides=overrides)

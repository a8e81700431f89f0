"""Thresholds: ``[tool.mjharness]`` in pyproject.toml, overridable by ``--config FILE``.

Schema::

    [tool.mjharness.thresholds.CASE]
    "FIGURE" = LIMIT      # comment: measured value and margin

A figure passes when its value is finite and ≤ LIMIT. The default config is
the project's own pyproject.toml: beside the packages in a source checkout or
editable install, under ``<prefix>/share/mjharness`` in a regular install.
"""

from __future__ import annotations

import math
import sys
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

KNOWN_KEYS = {"thresholds"}


class ConfigError(ValueError):
    """A config file that is missing, unreadable or malformed."""


@dataclass(frozen=True)
class Config:
    thresholds: Mapping[str, Mapping[str, float]]
    source: str

    def for_case(self, case: str) -> Mapping[str, float]:
        return self.thresholds.get(case, {})


def default_path() -> Path:
    here = Path(__file__).resolve().parent.parent / "pyproject.toml"
    installed = Path(sys.prefix) / "share" / "mjharness" / "pyproject.toml"
    for path in (here, installed):
        if path.is_file() and "mjharness" in _read(path).get("tool", {}):
            return path
    raise ConfigError(f"no [tool.mjharness] config found (looked in {here} and {installed}); "
                      "pass --config FILE")


def _read(path: Path) -> dict:
    try:
        return tomllib.loads(path.read_text())
    except OSError as exc:
        raise ConfigError(f"cannot read config {str(path)!r}: {exc.strerror}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ConfigError(f"config {str(path)!r} is not valid TOML: {exc}") from None


def _section(path: Path) -> dict:
    data = _read(path)
    if "tool" in data:
        tool = data["tool"]
        data = tool.get("mjharness") if isinstance(tool, dict) else None
        if data is None:
            raise ConfigError(f"config {str(path)!r} has no [tool.mjharness] table")
    if not isinstance(data, dict):
        raise ConfigError(f"config {str(path)!r}: [tool.mjharness] must be a table")
    unknown = set(data) - KNOWN_KEYS
    if unknown:
        raise ConfigError(f"config {str(path)!r}: unknown key(s) {sorted(unknown)}; "
                          f"accepted: {sorted(KNOWN_KEYS)}")
    return data


def _thresholds(raw: object, path: Path, known_cases: set[str]) -> dict[str, dict[str, float]]:
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


def load_config(path: Path | str | None = None) -> Config:
    """Defaults from the project config, overridden key by key by ``path``."""
    from harness.cases import names

    known = set(names())
    base_path = default_path()
    merged = _thresholds(_section(base_path).get("thresholds", {}), base_path, known)
    source = str(base_path)
    if path is not None:
        path = Path(path)
        extra = _thresholds(_section(path).get("thresholds", {}), path, known)
        for case, table in extra.items():
            merged[case] = {**merged.get(case, {}), **table}
        source = f"{base_path} + {path}"
    return Config(thresholds=merged, source=source)

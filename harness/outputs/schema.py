"""A run's JSON as a reader checks it: report.json, ``check --json`` output and baselines (docs/report-json.md).

``mjharness diff`` and ``baseline --compare`` read documents someone else
wrote, or edited by hand. Each is checked against the documented schema before
a number is read from it, so that a figure entry that is a string or null, or
a document of a schema this version does not know, is one line naming the
entry and what is accepted, never a traceback (nor the exit 1 of a
regression). Only what the readers use is required; other keys (the studies,
the audit, a baseline's rule) may be there.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from harness.core.figures import FigureName

__all__ = ["SchemaError", "check_run"]

SCHEMAS = (1, 2)  # the schema numbers this version reads (harness.outputs.jsondoc.SCHEMA writes the last)
NON_FINITE = ("nan", "inf", "-inf")  # how strict JSON holds a non-finite number


class SchemaError(ValueError):
    """A run document that does not fit docs/report-json.md."""


def check_run(doc: object, source: str) -> dict:
    """``doc`` if it is a run document of a known schema; :class:`SchemaError` naming the first entry that
    is not, and what is accepted."""
    if not isinstance(doc, dict) or not isinstance(doc.get("cases"), dict):
        raise SchemaError(f"{source} is not an mjharness run (expected report.json, the output of "
                          "`mjharness check --json` or a baseline: an object with 'schema' and 'cases')")
    for case, entry in doc["cases"].items():
        if not isinstance(entry, dict) or not isinstance(entry.get("figures"), dict):
            raise SchemaError(f"{source} is not an mjharness run: cases.{case} must be an object with "
                              "'figures' (an object by figure name)")
    schema = doc.get("schema")
    if isinstance(schema, bool) or schema not in SCHEMAS:
        found = "no schema number" if "schema" not in doc else f"schema {schema!r}"
        raise SchemaError(f"{source} has {found}; this mjharness reads schema "
                          f"{' or '.join(map(str, SCHEMAS))} (docs/report-json.md)")
    versions = doc.get("versions", {})
    if not isinstance(versions, dict) or not all(isinstance(v, str) for v in versions.values()):
        raise SchemaError(f"{source}: 'versions' must be an object of version strings")
    for case, entry in doc["cases"].items():
        _check_case(entry, f"{source}: cases.{case}")
    return doc


def _check_case(entry: dict, where: str) -> None:
    for name, figure in entry["figures"].items():
        _name(name, f"{where}.figures")
        if not isinstance(figure, dict) or not _number(figure.get("value")):
            raise SchemaError(f"{where}.figures[{name!r}] must be an object with a numeric 'value' "
                              f"(a number or {', '.join(map(repr, NON_FINITE))}), got {_kind(figure)}")
    checks = entry.get("checks", {})
    if not isinstance(checks, dict):
        raise SchemaError(f"{where}.checks must be an object by figure name, got {_kind(checks)}")
    for name, check in checks.items():
        _name(name, f"{where}.checks")
        if not (isinstance(check, dict) and isinstance(check.get("passed"), bool)
                and _number(check.get("threshold")) and _number(check.get("value"))):
            raise SchemaError(f"{where}.checks[{name!r}] must be an object with numeric 'value' and "
                              f"'threshold' and a boolean 'passed', got {_kind(check)}")


def _name(name: str, where: str) -> None:
    try:
        FigureName(name)
    except ValueError as exc:
        raise SchemaError(f"{where}: {exc}") from None


def _number(value: object) -> bool:
    if isinstance(value, bool):
        return False
    if isinstance(value, int | float):
        return math.isfinite(value)  # strict JSON holds no NaN; a parser that let one through is not ours
    return value in NON_FINITE


def _kind(value: object) -> str:
    """What a JSON value is, in a message."""
    if value is None:
        return "null"
    if isinstance(value, Mapping):
        return "an object without those"
    names = {bool: "a boolean", str: "a string", list: "an array", int: "a number", float: "a number"}
    shown = repr(value) if isinstance(value, str | int | float) and len(repr(value)) < 40 else ""
    return f"{names.get(type(value), type(value).__name__)}{' ' + shown if shown else ''}"

"""The run as one JSON document (report.json, ``check --json``, baselines): every figure, check and setting.

The schema is documented in docs/report-json.md; :data:`SCHEMA` is bumped when
a consumer (``mjharness diff``) must change.
"""

from __future__ import annotations

import json
import platform
from collections.abc import Mapping, Sequence
from importlib.metadata import version

import mujoco
import numpy as np

from harness.core import VERSION as __version__
from harness.core.checks import Check
from harness.pipeline.outcome import Outcome
from harness.pipeline.run import CaseResult

__all__ = ["dumps", "json_doc", "render_json", "versions"]

SCHEMA = 2


def versions() -> dict[str, str]:
    """The versions a run's figures depend on (sympy's read from its metadata: no import)."""
    return {"mjharness": __version__, "mujoco": mujoco.__version__, "numpy": np.__version__,
            "sympy": version("sympy"), "matplotlib": version("matplotlib"), "python": platform.python_version()}


def _check_entry(c: Check) -> dict:
    entry: dict = {"value": c.value, "threshold": c.threshold, "unit": c.unit, "passed": c.passed,
                   "status": c.status, "basis": "budget" if c.budget is not None else "limit"}
    if c.budget is not None:
        entry["budget"] = c.budget.as_dict()
    if c.note:
        entry["note"] = c.note
    if c.known:
        entry["known_defect"] = c.known
    if c.diverged:
        entry["diverged"] = c.diverged
    return entry


def json_doc(results: Sequence[CaseResult], outcome: Outcome | Mapping[str, Sequence[Check]], *,
             appendix: Mapping[str, object] | None = None) -> dict:
    """Every figure, every check (with its budget) and the settings, per case, the verdict of the run and
    of the requirements (the schema ``mjharness diff`` reads); ``appendix`` adds further top-level entries
    (the studies, the seed audit)."""
    if not isinstance(outcome, Outcome):
        outcome = Outcome(checks=outcome)
    doc: dict = {"schema": SCHEMA, "versions": versions(), "passed": outcome.passed,
                 "gate": {"passed": outcome.gate_passed, "accept_known_defects": outcome.accept_known_defects,
                          "known_defects": len(outcome.known_defects), "exit_code": outcome.exit_code},
                 "cases": {}, **(appendix or {})}
    if outcome.requirements:
        doc["requirements"] = {"stated": {r.measure: r.value for r in outcome.requirements}, "met": outcome.fit}
    for r in results:
        cs = outcome.checks[r.case.name]
        entry = {
            "passed": all(c.passed for c in cs),
            "figures": {f.name: f.as_dict() for f in r.figures},
            "checks": {c.name: _check_entry(c) for c in cs},
            "settings": r.settings.as_dict(),
        }
        if r.findings:
            entry["findings"] = [f.as_dict() for f in r.findings]
        if outcome.requirements:
            entry["fitness"] = [f.as_dict() for f in outcome.fitness.get(r.case.name, ())]
        doc["cases"][r.case.name] = entry
    return doc


def _jsonable(value: object) -> object:
    """Plain JSON: numpy scalars and arrays unwrapped, non-finite floats as the strings
    "nan", "inf", "-inf" (strict JSON has no NaN; ``float()`` reads them back)."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float):
        return value if np.isfinite(value) else str(value)
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if value is None or isinstance(value, bool | int | str):
        return value
    return str(value)


def dumps(doc: object) -> str:
    """JSON text for report documents: strict JSON, stable key order."""
    return json.dumps(_jsonable(doc), indent=1, sort_keys=True, allow_nan=False) + "\n"


def render_json(results: Sequence[CaseResult], outcome: Outcome | Mapping[str, Sequence[Check]], *,
                appendix: Mapping[str, object] | None = None) -> str:
    return dumps(json_doc(results, outcome, appendix=appendix))

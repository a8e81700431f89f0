"""Regression baseline: every gated figure at the shipped settings, committed as reports/baseline/.

The baseline is a directory with one file per case (``reports/baseline/NAME.json``,
each in the report.json schema), so a new case adds its own file and edits no
other; a single ``.json`` file holding every case works too.

The verdict asks whether MuJoCo is right: a figure passes while its error
budget explains it, however large the explained parts grow. The baseline asks
a separate question, what changed since it was recorded: a gated figure
regresses when

    new > FACTOR × max(old, FLOOR × limit)      (or new is not finite)

with ``limit`` the check's limit in this run (its budget's, or its fixed one).

FACTOR = 2. Runs are bit-identical on one machine and MuJoCo version, so any
change comes from code, MuJoCo or the platform. Roundoff and solver jitter
across platforms move trajectory figures by percents; a real change in
behaviour moves them by factors (halving the accuracy of a first-order method
is 2×, of RK4 16×). 2× is the smallest factor that such a change trips while
staying far above jitter.

FLOOR = 0.01: a figure at roundoff level (1e-16 against a 1e-12 limit)
may double across platforms without meaning anything; only growth beyond 2%
of the limit (FACTOR × FLOOR) counts there.

Refresh deliberately, after checking that the change is wanted, with
``mjharness baseline --write reports/baseline`` (all cases) or naming
cases to update only those entries.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco

from harness.core.checks import Check
from harness.core.figures import Figure
from harness.engine.compat import unavailable_reason
from harness.outputs.files import prepare_output, write_atomic
from harness.outputs.jsondoc import dumps, json_doc

__all__: list[str] = []

FACTOR = 2.0
FLOOR = 0.01
DEFAULT_PATH = "reports/baseline"
REFRESH = f"mjharness baseline --write {DEFAULT_PATH}"


@dataclass(frozen=True)
class Finding:
    """A problem with one case against the baseline: a regression or a missing entry."""

    case: str
    figure: str | None
    message: str


def baseline_doc(results: Sequence, checks: Mapping[str, Sequence]) -> dict:
    """The gated figures of ``results`` (CaseResult) with their checks and settings, in the
    report.json schema (so ``mjharness diff`` reads it), machine paths removed."""
    doc = json_doc(results, checks)
    for entry in doc["cases"].values():
        entry["figures"] = {k: v for k, v in entry["figures"].items() if k in entry["checks"]}
        settings = dict(entry["settings"])
        if "mjcf" in settings:
            settings["mjcf"] = Path(str(settings["mjcf"])).name
        entry["settings"] = settings
    doc["kind"] = "baseline"
    doc["regression_rule"] = {"factor": FACTOR, "floor_fraction_of_threshold": FLOOR, "refresh": REFRESH}
    return doc


def merge(old: Mapping | None, new: Mapping) -> dict:
    """``new`` with the cases of ``old`` it does not have (a partial refresh keeps the rest).
    Both must come from one MuJoCo version (a baseline is per version)."""
    if old is None:
        return dict(new)
    versions = [doc.get("versions", {}).get("mujoco") for doc in (old, new)]
    if None not in versions and versions[0] != versions[1]:
        raise ValueError(f"the baseline was recorded with MuJoCo {versions[0]}, this run is MuJoCo {versions[1]}: "
                         "a partial refresh would mix versions; write all cases to a baseline of its own")
    out = dict(new)
    out["cases"] = {**old.get("cases", {}), **new["cases"]}
    out["cases"] = dict(sorted(out["cases"].items()))
    return out


def _is_file(path: Path) -> bool:
    return Path(path).suffix == ".json"


def output_dir(path: Path) -> Path:
    """The directory a baseline at ``path`` is written into."""
    return Path(path).parent if _is_file(path) else Path(path)


def exists(path: Path) -> bool:
    return Path(path).is_file() if _is_file(path) else Path(path).is_dir() and any(Path(path).glob("*.json"))


def write(path: Path, new: Mapping, old: Mapping | None = None) -> dict:
    """Write the baseline ``new`` (one run's cases) to ``path`` and return what ``path`` then holds.

    A directory gets one file per case of ``new``, each a whole baseline document with that case
    alone; the other cases' files are left as they are. A single file gets ``new`` merged with
    ``old`` (its previous content: a partial refresh keeps the other cases). Either way the two must
    come from one MuJoCo version (:func:`merge` refuses otherwise)."""
    path = Path(path)
    merged = merge(old, new)
    prepare_output(output_dir(path))
    if _is_file(path):
        write_atomic({path: dumps(merged)})
    else:
        write_atomic({path / f"{case}.json": dumps({**new, "passed": entry["passed"], "cases": {case: entry}})
                      for case, entry in new["cases"].items()})
    return merged


def limit(old: float, threshold: float) -> float:
    """The largest value a figure may take before it counts as a regression (``threshold``: the check's
    limit in this run; nan where it has none, when the floor does not apply)."""
    return FACTOR * max(old, FLOOR * threshold) if math.isfinite(threshold) else FACTOR * old


def version_mismatch(baseline: Mapping, *, source: str = DEFAULT_PATH) -> str:
    """Why ``baseline`` cannot judge this run ('' if it can): it was recorded with another MuJoCo.

    A baseline is per MuJoCo version: the same model on another version moves figures by
    factors where the version changed an algorithm (or has a documented defect), which
    is what ``mjharness diff`` shows, not a regression. A baseline that records no
    MuJoCo version is compared as before.
    """
    recorded = baseline.get("versions", {}).get("mujoco")
    if recorded is None or recorded == mujoco.__version__:
        return ""
    return (f"{source} was recorded with MuJoCo {recorded}, this is MuJoCo {mujoco.__version__}: a baseline "
            f"is per MuJoCo version (compare the versions with `mjharness diff`)")


def compare(baseline: Mapping, case: str, figures: Iterable[Figure],
            checks: Sequence[Check] | Mapping[str, float], *, source: str = DEFAULT_PATH) -> list[Finding]:
    """Findings for one case: missing from the baseline, a gated figure missing, or regressed. ``checks``:
    the case's checks in this run (or its limits by figure), whose limits set the floor."""
    thresholds = checks if isinstance(checks, Mapping) else {c.name: c.threshold for c in checks}
    refresh = f"mjharness baseline --write {source}"
    entry = baseline.get("cases", {}).get(case)
    if entry is None:
        return [Finding(case, None, f"case {case!r} is not in the baseline {source}; after checking its "
                                    f"figures, add it deliberately with `{refresh}`")]
    measured: dict[str, float] = {f.name: f.value for f in figures}
    stored = entry.get("figures", {})
    missing = [name for name in thresholds if name not in stored and not unavailable_reason(name)]
    found = []
    if missing:
        found.append(Finding(case, None, f"{case}: {len(missing)} gated figure(s) not in the baseline {source} "
                                         f"({', '.join(missing)}); refresh it deliberately with `{refresh}`"))
    for name, threshold in thresholds.items():
        if name in missing:
            continue
        if name not in measured and unavailable_reason(name):
            continue  # an integrator this MuJoCo lacks: n/a in the verdict, nothing to compare
        old = float(stored[name]["value"])
        new = measured.get(name, math.nan)
        if not (math.isfinite(new) and new <= limit(old, threshold)):
            found.append(Finding(case, name, f"{case} {name} regressed: {new:.3e} against baseline {old:.3e} "
                                             f"(allowed up to {limit(old, threshold):.3e} = {FACTOR:g}× "
                                             f"max(baseline, {FLOOR:g}×limit)); if intended, refresh "
                                             f"with `{refresh}`"))
    return found

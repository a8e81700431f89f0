"""How long each case takes, measured on every run and kept beside the cache: only to order work.

A process pool runs the costliest work first so that the cheapest fills the
end; that order never changes a result. Costs are measured, never typed: a
case's warm cost is recorded after each run that computed it
(:func:`record`), a system's cold derivation cost by the cache when it
derived it (``harness.core.cache.cost``). A case never measured on this
machine counts :data:`UNKNOWN` seconds.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path

from harness.core import cache

__all__ = ["UNKNOWN", "case_costs", "record"]

UNKNOWN = 0.5  # seconds: a typical case, and a typical derivation


def _file() -> Path | None:
    root = cache.cache_dir()
    return None if root is None else root / "costs" / "cases.json"


def _read(path: Path) -> dict[str, float]:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    if not isinstance(data, dict):
        return {}
    return {str(k): float(v) for k, v in data.items() if isinstance(v, int | float) and v > 0}


def case_costs() -> dict[str, float]:
    """Seconds each case's last measured run took with its derivation cached, by case name."""
    path = _file()
    return {} if path is None else _read(path)


def record(seconds: Mapping[str, float]) -> None:
    """Keep the measured warm cost of these cases (merged with the others'); silently skipped where the
    cache cannot be written."""
    path = _file()
    if path is None or not seconds:
        return
    merged = _read(path) | {k: round(float(v), 4) for k, v in seconds.items() if v > 0}
    cache.write_atomic(path, json.dumps(dict(sorted(merged.items())), indent=1).encode())

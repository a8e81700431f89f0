"""What ``mjharness sweep`` writes: sweep.md (per model a row per backend, a column per release, each cell's
verdict, and where the row first changed) and sweep.json (every cell with every figure and check status).

Two sweeps of the same models, releases and backends are the same sweep when :func:`comparable` of their
JSON documents are equal: everything but what the run cost and where it ran (:data:`COST_KEYS`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from harness.core.escape import markdown_cell
from harness.versions.sweep import ERROR, NA, REFUSED, FirstChange, Sweep, first_changes

__all__ = ["comparable", "differences", "json_doc", "markdown", "text"]

SCHEMA = 1
COST_KEYS = ("seconds", "env_seconds", "host", "executor", "command")
"""The keys of sweep.json that say what a run cost and where it ran, not what it found."""
FIGURE_CHANGE = ("a figure changed at a release when its value differs bit for bit from the release before it "
                 "that ran (a figure that appeared or vanished counts); no noise runs are made, so a change at "
                 "round-off level counts too: `mjharness versions` tells those apart")
VERDICT_CHANGE = ("the verdict changed at a release when it differs from that of the release before it that had "
                  "a verdict (pass, fail or refused; n/a and error cells are stepped over)")


def _change(f: FirstChange) -> tuple[str, str]:
    verdict = f"{f.verdict} ({f.was} → {f.now})" if f.verdict else "—"
    if not f.figure:
        return verdict, "—"
    size = "∞" if math.isinf(f.largest) else f"{f.largest:.2g}"
    parts = [f"{f.changed} of {f.compared} figures changed"] if f.changed else []
    if f.changed:
        parts.append(f"largest relative change {size} on {f.largest_figure}")
    if f.appeared:
        parts.append(f"{f.appeared} appeared or vanished")
    return verdict, f"{f.figure} ({'; '.join(parts)})"


def markdown(sweep: Sweep) -> str:
    """sweep.md: the verdict table with each row's first changes, then every cell that has a reason."""
    head = ["model", "backend", *sweep.releases, "first verdict change", "first figure change"]
    lines = [f"# MuJoCo sweep: {len(sweep.models)} models × {len(sweep.releases)} releases × "
             f"{len(sweep.backends)} backends", ""]
    if sweep.command:
        lines += [f"`{sweep.command}` ({sweep.executor} executor, {sweep.seconds:.0f} s)", ""]
    lines += [f"Each cell is `check --mjcf FILE --backend B` (or `--case NAME`) run in that MuJoCo release's own "
              f"environment. {VERDICT_CHANGE[0].upper()}{VERDICT_CHANGE[1:]}; {FIGURE_CHANGE}.", "",
              "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    changes = {(f.model, f.backend): f for f in first_changes(sweep)}
    for model in sweep.models:
        for backend in sweep.backends:
            row = {c.release: c.verdict for c in sweep.row(model, backend)}
            verdict, figure = _change(changes[(model, backend)])
            lines.append("| " + " | ".join(markdown_cell(c) for c in [model, backend, *(row.get(r, "—") for r in
                                                                                 sweep.releases), verdict, figure])
                         + " |")
    for title, kinds in (("Cells that could not be run", (ERROR,)), ("Refused and n/a cells", (REFUSED, NA))):
        listed = [c for c in sweep.cells if c.verdict in kinds]
        if listed:
            lines += ["", f"## {title}", "", *(f"- {markdown_cell(c.line())}" for c in listed)]
    return "\n".join(lines) + "\n"


def text(sweep: Sweep) -> str:
    """The terminal's summary: the counts of each verdict and every cell that could not be run."""
    counts = {v: sum(c.verdict == v for c in sweep.cells) for v in ("pass", "fail", "refused", "n/a", "error")}
    lines = [f"{len(sweep.cells)} cells ({len(sweep.models)} models × {len(sweep.releases)} releases × "
             f"{len(sweep.backends)} backends) in {sweep.seconds:.0f} s: "
             + ", ".join(f"{n} {v}" for v, n in counts.items() if n)]
    lines += [f"error: {c.line()}" for c in sweep.errors]
    for f in first_changes(sweep):
        verdict, figure = _change(f)
        lines.append(f"{f.model} ({f.backend}): first verdict change {verdict}; first figure change {figure}")
    return "\n".join(lines) + "\n"


def json_doc(sweep: Sweep) -> dict[str, Any]:
    """sweep.json: the sweep's axes, every cell, and each row's first changes, with how changes are found."""
    return {"schema": SCHEMA, "command": sweep.command, "executor": sweep.executor, "seconds": sweep.seconds,
            "models": list(sweep.models), "releases": list(sweep.releases), "backends": list(sweep.backends),
            "method": {"verdict change": VERDICT_CHANGE, "figure change": FIGURE_CHANGE},
            "cells": [{"model": c.model, "release": c.release, "backend": c.backend, "verdict": c.verdict,
                       "reason": c.reason, "mujoco": c.mujoco, "figures": dict(c.figures),
                       "statuses": dict(c.statuses), "seconds": c.seconds, "env_seconds": c.env_seconds,
                       "host": c.host} for c in sweep.cells],
            "first_changes": [{"model": f.model, "backend": f.backend, "verdict": f.verdict or None,
                               "was": f.was or None, "now": f.now or None, "figure": f.figure or None,
                               "changed": f.changed, "appeared": f.appeared, "compared": f.compared,
                               "largest": f.largest,
                               "largest_figure": f.largest_figure or None} for f in first_changes(sweep)]}


def comparable(doc: Any) -> Any:
    """``doc`` (a parsed sweep.json) without :data:`COST_KEYS`, at every level."""
    if isinstance(doc, Mapping):
        return {k: comparable(v) for k, v in doc.items() if k not in COST_KEYS}
    if isinstance(doc, list):
        return [comparable(v) for v in doc]
    return doc


def differences(a: Any, b: Any, where: str = "") -> list[str]:
    """Where two comparable sweep.json documents differ, one line each (empty: identical, every figure's
    value bit for bit: JSON writes a float's shortest repr, which reads back to the same bits)."""
    if isinstance(a, Mapping) and isinstance(b, Mapping):
        out = [f"{where}/{k}: only in {'the first' if k in a else 'the second'}" for k in sorted(set(a) ^ set(b))]
        return out + [d for k in sorted(set(a) & set(b)) for d in differences(a[k], b[k], f"{where}/{k}")]
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{where}: {len(a)} entries vs {len(b)}"]
        return [d for i, (x, y) in enumerate(zip(a, b, strict=True)) for d in differences(x, y, f"{where}[{i}]")]
    return [] if type(a) is type(b) and a == b else [f"{where}: {a!r} vs {b!r}"]

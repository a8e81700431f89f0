"""What changed between two runs: figure by figure (old, new, new/old), verdict flips first.

Reads the JSON that ``mjharness run`` (report.json), ``mjharness check --json``
and ``mjharness baseline --write`` produce: ``{"cases": {CASE: {"figures":
{NAME: {"value": V, ...}}, "checks": {NAME: {"passed": B, "threshold": T}}}}}``.
Informational: it never judges; the flipped verdicts are what to look at.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from harness.outputs.schema import check_run


@dataclass(frozen=True)
class Row:
    """One figure in either run. ``old``/``new`` are None where the run lacks it; ``passed_*``
    are None where the figure is not gated in that run."""

    case: str
    figure: str
    old: float | None
    new: float | None
    passed_old: bool | None
    passed_new: bool | None

    @property
    def ratio(self) -> float | None:
        if self.old is None or self.new is None:
            return None
        if self.old == self.new:
            return 1.0
        return self.new / self.old if self.old != 0 else math.inf

    @property
    def flipped(self) -> bool:
        return self.passed_old is not None and self.passed_new is not None and self.passed_old != self.passed_new

    @property
    def changed(self) -> bool:
        """Present in both runs, with another value or verdict."""
        return self.old is not None and self.new is not None and (
            self.ratio != 1.0 or self.passed_old != self.passed_new)

    @property
    def one_sided(self) -> bool:
        return self.old is None or self.new is None

    @property
    def gated(self) -> bool:
        return self.passed_old is not None or self.passed_new is not None


@dataclass(frozen=True)
class Diff:
    rows: tuple[Row, ...]
    versions: tuple[tuple[str, str, str], ...]  # (package, old, new) where they differ

    @property
    def flipped(self) -> tuple[Row, ...]:
        return tuple(r for r in self.rows if r.flipped)

    @property
    def identical(self) -> bool:
        """Both runs have the same figures, each with the same value and verdict."""
        return all(not r.changed and not r.one_sided for r in self.rows)


def load_run(path: Path | str) -> dict:
    """A run's JSON document; ValueError (one line) if missing, unreadable or not of the documented schema
    (:func:`harness.outputs.schema.check_run`). A directory (a baseline with one file per case) is read as
    one document holding every case."""
    path = Path(path)
    if path.is_dir():
        return _merged(path)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ValueError(f"cannot read {str(path)!r}: {exc.strerror}") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"{str(path)!r} is not JSON: {exc}") from None
    return check_run(doc, repr(str(path)))  # the documented schema: one line naming what does not fit


def _value(entry: object) -> float:
    raw = entry.get("value") if isinstance(entry, dict) else entry
    try:
        return float(raw)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return math.nan


def _verdicts(case_doc: Mapping) -> dict[str, bool]:
    checks = case_doc.get("checks", {})
    return {k: bool(v.get("passed")) for k, v in checks.items() if isinstance(v, dict)} \
        if isinstance(checks, dict) else {}


def diff_runs(old: Mapping, new: Mapping) -> Diff:
    """Every figure of either run, by case, in the old run's order (new cases and figures after)."""
    rows = []
    old_cases, new_cases = old["cases"], new["cases"]
    for case in [*old_cases, *(c for c in new_cases if c not in old_cases)]:
        o, n = old_cases.get(case, {"figures": {}}), new_cases.get(case, {"figures": {}})
        vo, vn = _verdicts(o), _verdicts(n)
        names = [*o["figures"], *(f for f in n["figures"] if f not in o["figures"])]
        for name in names:
            rows.append(Row(case, name,
                            _value(o["figures"][name]) if name in o["figures"] else None,
                            _value(n["figures"][name]) if name in n["figures"] else None,
                            vo.get(name), vn.get(name)))
    ov, nv = old.get("versions", {}), new.get("versions", {})
    versions = tuple((k, str(ov.get(k, "?")), str(nv.get(k, "?")))
                     for k in sorted(set(ov) | set(nv)) if ov.get(k) != nv.get(k))
    return Diff(rows=tuple(rows), versions=versions)


def _num(v: float | None) -> str:
    return "—" if v is None else f"{v:.3e}"


def _verdict(p: bool | None) -> str:
    return "" if p is None else ("pass" if p else "FAIL")


def format_diff(diff: Diff, *, show_all: bool = False) -> str:
    """Aligned text: flipped verdicts marked ``<< FLIPPED``; unchanged figures only with ``show_all``."""
    lines = [f"{pkg}: {a} -> {b}" for pkg, a, b in diff.versions]
    for r in diff.flipped:
        lines.append(f"FLIPPED {r.case} {r.figure}: {_verdict(r.passed_old)} -> {_verdict(r.passed_new)} "
                     f"({_num(r.old)} -> {_num(r.new)})")
    shown = [r for r in diff.rows if show_all or r.changed or (r.one_sided and r.gated)]
    header = ("case", "figure", "old", "new", "new/old", "verdict", "")
    table = [header]
    for r in shown:
        ratio = "—" if r.ratio is None else ("inf" if math.isinf(r.ratio) else f"{r.ratio:.3g}")
        verdict = (f"{_verdict(r.passed_old) or '-'} -> {_verdict(r.passed_new) or '-'}"
                   if r.passed_old is not None or r.passed_new is not None else "")
        table.append((r.case, r.figure, _num(r.old), _num(r.new), ratio, verdict,
                      "<< FLIPPED" if r.flipped else ""))
    if len(table) > 1:
        widths = [max(len(row[i]) for row in table) for i in range(len(header))]
        lines += ["  ".join(v.ljust(w) for v, w in zip(row, widths, strict=True)).rstrip() for row in table]
    both = [r for r in diff.rows if not r.one_sided]
    unchanged = sum(not r.changed for r in both)
    only_old = sum(r.new is None for r in diff.rows)
    only_new = sum(r.old is None for r in diff.rows)
    worse = [r for r in diff.flipped if r.passed_old]
    hidden = unchanged + sum(r.one_sided and not r.gated for r in diff.rows)
    lines.append(f"{len(both)} figures in both runs: {len(both) - unchanged} changed, {unchanged} identical; "
                 f"{only_old} only in OLD, {only_new} only in NEW"
                 f"{'' if show_all or not hidden else ' (--all lists every figure)'}; "
                 f"{len(diff.flipped)} verdict(s) flipped ({len(worse)} pass -> FAIL, "
                 f"{len(diff.flipped) - len(worse)} FAIL -> pass)")
    return "\n".join(lines) + "\n"


def _merged(directory: Path) -> dict:
    """The run documents ``directory/*.json`` as one: every case, and every package version any of them
    records (ValueError where two record different versions of one package)."""
    docs = [load_run(p) for p in sorted(directory.glob("*.json"))]
    if not docs:
        raise ValueError(f"{str(directory)!r} holds no run documents (*.json)")
    merged = dict(docs[0])
    merged["cases"], merged["versions"] = {}, {}
    for path, doc in zip(sorted(directory.glob("*.json")), docs, strict=True):
        versions = doc.get("versions", {})
        clash = sorted(k for k, v in versions.items() if merged["versions"].get(k, v) != v)
        if clash:
            raise ValueError(f"{str(path)!r} was recorded with other versions of {', '.join(clash)} than the "
                             f"other documents in {str(directory)!r}")
        merged["versions"].update(versions)
        merged["cases"].update(doc["cases"])
    merged["passed"] = all(bool(c.get("passed", True)) for c in merged["cases"].values())
    return merged

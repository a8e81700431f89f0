"""What changed between two runs: figure by figure (old, new, new/old), verdict flips first, then the
figures by the size of their change.

Reads the JSON that ``mjharness run`` (report.json), ``mjharness check --json``
and ``mjharness baseline --write`` produce: ``{"cases": {CASE: {"figures":
{NAME: {"value": V, ...}}, "checks": {NAME: {"passed": B, "status": S, "threshold": T}}}}}``.
Informational: it never judges; the flipped verdicts are what to look at. A verdict flips when a
check's status changes between ``pass``, ``FAIL`` and ``FAIL (known defect)`` (a known defect is a
failure: a release that fixes it flips it to pass).

By default the table hides what tells nothing: figures identical in both runs and figures whose
new/old is 1 at the three digits it is printed with (:data:`PRINTED_PRECISION`: MuJoCo releases and
platforms move figures at round-off); ``--all`` lists every figure. Two runs of one machine and
version are bit-identical, so ``diff`` has no measure of a figure's noise; ``mjharness versions``
measures it.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from fnmatch import fnmatchcase
from pathlib import Path

from harness.core import inputs
from harness.outputs.schema import check_run

__all__ = ["JUDGED", "FigureChange", "diff_runs", "figure_value", "format_diff", "load_run", "select",
           "status_flipped"]

PRINTED_PRECISION = 5e-4
"""A ratio within this of 1 prints as 1 at three significant digits: the row shows no change."""
JUDGED = ("pass", "FAIL", "FAIL (known defect)")
"""The statuses a verdict flips between (not n/a: a check n/a on one side has appeared or vanished)."""


def ratio(old: float | None, new: float | None) -> float | None:
    """new/old of a figure between two runs: None where either is missing, 1 where they are equal
    (0 → 0 included), infinite from 0 to anything else."""
    if old is None or new is None:
        return None
    if old == new:
        return 1.0
    return new / old if old != 0 else math.inf


def status_flipped(old: str | None, new: str | None) -> bool:
    """A check's status changed from one of :data:`JUDGED` to another."""
    return old in JUDGED and new in JUDGED and old != new


@dataclass(frozen=True)
class FigureChange:
    """One figure of one case in two runs, old and new: its values (None where a run lacks it) and its check's
    statuses (None where it has no check there). What a row of ``diff`` and a change between two releases
    (:class:`harness.versions.changes.Change`) share."""

    case: str
    figure: str
    old: float | None
    new: float | None
    status_old: str | None
    status_new: str | None

    @property
    def ratio(self) -> float | None:
        return ratio(self.old, self.new)

    @property
    def decades(self) -> float | None:
        """The change as decades, ``|log10(new/old)|``: 0 where the value is the same, infinite from or to
        zero or a non-finite value; None where a run lacks the figure."""
        old, new = self.old, self.new
        if old is None or new is None:
            return None
        if old == new:
            return 0.0
        if not (math.isfinite(old) and math.isfinite(new)) or old == 0 or new == 0:
            return math.inf
        return abs(math.log10(abs(new) / abs(old)))


@dataclass(frozen=True)
class Row(FigureChange):
    """One figure in either run; ``passed_*`` are None where the figure is not gated in that run."""

    passed_old: bool | None
    passed_new: bool | None

    @property
    def flipped(self) -> bool:
        """The verdict changed: passed against failed, or between FAIL and FAIL (known defect)."""
        if self.passed_old is None or self.passed_new is None:
            return False
        return self.passed_old != self.passed_new or status_flipped(self.status_old, self.status_new)

    @property
    def size(self) -> float:
        """:attr:`decades`, 0 where one run lacks the figure."""
        decades = self.decades
        return 0.0 if decades is None else decades

    @property
    def negligible(self) -> bool:
        """Changed, but new/old prints as 1 (:data:`PRINTED_PRECISION`), and the verdict did not flip."""
        r = self.ratio
        return (self.changed and not self.flipped and r is not None and math.isfinite(r)
                and abs(r - 1.0) < PRINTED_PRECISION)

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
        doc = json.loads(inputs.read_text(path, what="run document", limit=inputs.DOCUMENT_LIMIT))
    except OSError as exc:
        raise ValueError(f"cannot read {str(path)!r}: {exc.strerror}") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"{str(path)!r} is not JSON: {exc}") from None
    return check_run(doc, repr(str(path)))  # the documented schema: one line naming what does not fit


def figure_value(entry: object) -> float:
    """A figure entry's number (``"nan"``/``"inf"`` strings read back; anything else nan)."""
    raw = entry.get("value") if isinstance(entry, Mapping) else entry
    try:
        return float(raw)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return math.nan


def _verdicts(case_doc: Mapping) -> dict[str, bool]:
    checks = case_doc.get("checks", {})
    return {k: bool(v.get("passed")) for k, v in checks.items() if isinstance(v, dict)} \
        if isinstance(checks, dict) else {}


def _statuses(case_doc: Mapping) -> dict[str, str]:
    """Each check's status (schema 2; absent in schema 1)."""
    checks = case_doc.get("checks", {})
    return {k: v["status"] for k, v in checks.items() if isinstance(v, dict) and isinstance(v.get("status"), str)} \
        if isinstance(checks, dict) else {}


def diff_runs(old: Mapping, new: Mapping) -> Diff:
    """Every figure of either run, by case, in the old run's order (new cases and figures after)."""
    rows = []
    old_cases, new_cases = old["cases"], new["cases"]
    for case in [*old_cases, *(c for c in new_cases if c not in old_cases)]:
        o, n = old_cases.get(case, {"figures": {}}), new_cases.get(case, {"figures": {}})
        vo, vn = _verdicts(o), _verdicts(n)
        so, sn = _statuses(o), _statuses(n)
        names = [*o["figures"], *(f for f in n["figures"] if f not in o["figures"])]
        for name in names:
            rows.append(Row(case=case, figure=name,
                            old=figure_value(o["figures"][name]) if name in o["figures"] else None,
                            new=figure_value(n["figures"][name]) if name in n["figures"] else None,
                            status_old=so.get(name), status_new=sn.get(name),
                            passed_old=vo.get(name), passed_new=vn.get(name)))
    ov, nv = old.get("versions", {}), new.get("versions", {})
    versions = tuple((k, str(ov.get(k, "?")), str(nv.get(k, "?")))
                     for k in sorted(set(ov) | set(nv)) if ov.get(k) != nv.get(k))
    return Diff(rows=tuple(rows), versions=versions)


def select(diff: Diff, *, cases: Sequence[str] = (), figures: Sequence[str] = ()) -> Diff:
    """The rows of the cases named and of the figures matching one of the glob patterns (``RK4.*``); all
    where none is given. ValueError (one line) for a case neither run has or a pattern no figure matches."""
    rows = diff.rows
    if cases:
        present = list(dict.fromkeys(r.case for r in rows))
        unknown = [c for c in cases if c not in present]
        if unknown:
            raise ValueError(f"--case {', '.join(unknown)}: not in either run; the runs have {', '.join(present)}")
        rows = tuple(r for r in rows if r.case in cases)
    if figures:
        idle = [p for p in figures if not any(fnmatchcase(r.figure, p) for r in rows)]
        if idle:
            raise ValueError(f"--figure {', '.join(idle)}: matches no figure of the runs (a name such as "
                             "RK4.position, or a pattern such as 'RK4.*' or '*.force.*')")
        rows = tuple(r for r in rows if any(fnmatchcase(r.figure, p) for p in figures))
    return replace(diff, rows=rows)


def _order(r: Row) -> tuple:
    """Flipped verdicts first, then the largest change first (by decades), figures only in one run last."""
    return (not r.flipped, r.one_sided, -r.size)


def _num(v: float | None) -> str:
    return "—" if v is None else f"{v:.3e}"


def _verdict(p: bool | None) -> str:
    return "" if p is None else ("pass" if p else "FAIL")


def _status(r: Row, *, old: bool) -> str:
    """The check's status where the run records one that agrees with its ``passed`` (``FAIL (known
    defect)``), else pass/FAIL from ``passed``."""
    status, passed = (r.status_old, r.passed_old) if old else (r.status_new, r.passed_new)
    if status is not None and passed is not None and (status in ("pass", "n/a")) == passed:
        return status
    return _verdict(passed)


def format_diff(diff: Diff, *, show_all: bool = False) -> str:
    """Aligned text, sorted by the size of the change: flipped verdicts marked ``<< FLIPPED`` (and listed
    first); figures unchanged, or changed below what new/old prints, only with ``show_all``."""
    lines = [f"{pkg}: {a} -> {b}" for pkg, a, b in diff.versions]
    for r in diff.flipped:
        lines.append(f"FLIPPED {r.case} {r.figure}: {_status(r, old=True)} -> {_status(r, old=False)} "
                     f"({_num(r.old)} -> {_num(r.new)})")
    shown = sorted((r for r in diff.rows if show_all or (r.changed and not r.negligible) or (r.one_sided and r.gated)),
                   key=_order)
    header = ("case", "figure", "old", "new", "new/old", "verdict", "")
    table = [header]
    for r in shown:
        ratio = "—" if r.ratio is None else ("inf" if math.isinf(r.ratio) else f"{r.ratio:.3g}")
        verdict = (f"{_status(r, old=True) or '-'} -> {_status(r, old=False) or '-'}"
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
    negligible = sum(r.negligible for r in diff.rows)
    hidden = unchanged + negligible + sum(r.one_sided and not r.gated for r in diff.rows)
    lines.append(f"{len(both)} figures in both runs: {len(both) - unchanged} changed ({negligible} of them by less "
                 f"than new/old shows, hidden), {unchanged} identical; "
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

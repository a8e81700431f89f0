"""What changed from release to release: verdict flips, figures that moved beyond their noise, figures that
appeared or vanished, each at the release where it happened, sorted by the size of the change.

**Noise.** A figure's noise at a release is the most it moved in that release's perturbed runs
(:mod:`harness.versions.runs`: the initial state moved ±1e-15 relative), and at least
:data:`ULP_FLOOR` × its size (a change of a few units in the last place of the number itself is its
representation, not a result). Between two releases the noise is the larger of the two.

**Moved.** A figure moved from release A to release B when ``|F_B − F_A| > NOISE_FACTOR × noise``.
:data:`NOISE_FACTOR` = 10 has a measured basis: over the release steps of MuJoCo 3.3.0 → 4.0.0 on every
default case, the figures that changed at round-off moved by a few times their noise and those a documented
change moves by far more, none in between, and 10 sits in that gap (docs/findings/versions.md, "Round-off
against change"; tests/test_versions.py pins both sides of the rule on fake runs).

**Flips.** A check's status (``pass``, ``FAIL``, ``FAIL (known defect)``) differs between two releases:
a known defect counts as what it is, a failure, so MuJoCo 4.0.0 fixing RK4 on ball joints flips
``converge.RK4.order_shortfall`` from ``FAIL (known defect)`` to ``pass``. A check that is ``n/a`` on one
side (an integrator the older MuJoCo lacks) has appeared or vanished rather than flipped.

**Size.** A change's size is the factor it moved the figure by, ``|log10(new/old)|`` (infinite from or to
zero, or where either side is not a finite number); flips first, then moved figures by size, then
figures that appeared or vanished.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from harness.outputs.diff import FigureChange, figure_value, status_flipped
from harness.versions.releases import Release

__all__ = ["NOISE_FACTOR", "ULP_FLOOR", "Change", "History", "Key", "Snapshot", "changes", "compare", "figures",
           "history", "moved", "noise", "snapshot", "statuses"]

NOISE_FACTOR = 10.0
ULP_FLOOR = 4 * float(np.finfo(float).eps)

Key = tuple[str, str]  # (case, figure)


def status(check: Mapping) -> str:
    """A check's status (schema 2), or pass/FAIL from ``passed`` (schema 1)."""
    found = check.get("status")
    if isinstance(found, str):
        return found
    return "pass" if check.get("passed") else "FAIL"


def figures(doc: Mapping) -> dict[Key, float]:
    """Every figure of a run document, by (case, figure)."""
    return {(case, name): figure_value(entry)
            for case, c in doc["cases"].items() for name, entry in c["figures"].items()}


def statuses(doc: Mapping) -> dict[Key, str]:
    """Every check's status of a run document, by (case, figure)."""
    return {(case, name): status(check) for case, c in doc["cases"].items()
            for name, check in (c.get("checks") or {}).items() if isinstance(check, Mapping)}


def noise(doc: Mapping, perturbed: Sequence[Mapping]) -> dict[Key, float]:
    """Each figure's noise in one release: the most it moved in the perturbed runs, at least
    :data:`ULP_FLOOR` × its size; infinite where a perturbed run lacks it or it is not finite there."""
    base = figures(doc)
    moved = [figures(p) for p in perturbed]
    out = {}
    for key, v in base.items():
        spread = 0.0
        for other in moved:
            w = other.get(key, math.nan)
            spread = max(spread, abs(w - v)) if math.isfinite(w) and math.isfinite(v) else math.inf
        out[key] = max(spread, ULP_FLOOR * abs(v)) if math.isfinite(v) else math.inf
    return out


@dataclass(frozen=True)
class Point:
    """One release's figure: its value, noise and check status (None where it has no check)."""

    release: Release
    value: float | None
    noise: float | None
    status: str | None


@dataclass(frozen=True)
class History:
    """A figure over the releases run, oldest first (``value`` None where that release lacks it)."""

    case: str
    figure: str
    points: tuple[Point, ...]


@dataclass(frozen=True)
class Change(FigureChange):
    """One change of one figure between two releases run one after the other: ``release`` is the first
    that shows it, ``since`` the one before it (on the index's list or not: the releases in between were
    not run)."""

    kind: str  # "flip", "moved", "appeared", "vanished"
    since: Release
    release: Release
    noise: float | None

    @property
    def size(self) -> float:
        """:attr:`decades`, infinite where one release lacks the figure and the other has it, 0 where
        neither has it (0 too where the value did not change: a flip alone)."""
        decades = self.decades
        if decades is None:
            return math.inf if self.old != self.new else 0.0
        return decades

    @property
    def in_noise(self) -> float | None:
        """|new − old| in units of the noise (None where undefined)."""
        if self.old is None or self.new is None or not self.noise or not math.isfinite(self.noise):
            return None
        return abs(self.new - self.old) / self.noise

    def as_dict(self) -> dict[str, object]:
        return {"kind": self.kind, "case": self.case, "figure": self.figure, "since": str(self.since),
                "release": str(self.release), "old": self.old, "new": self.new, "noise": self.noise,
                "ratio": self.ratio, "size_decades": self.size, "change_in_noise": self.in_noise,
                "status_old": self.status_old, "status_new": self.status_new}


ORDER = {"flip": 0, "moved": 1, "appeared": 2, "vanished": 2}


def sort_key(change: Change) -> tuple:
    return (ORDER[change.kind], -change.size, -(change.in_noise or 0.0), change.release, change.case, change.figure)


def moved(old: float, new: float, noise_old: float, noise_new: float, *, factor: float = NOISE_FACTOR) -> bool:
    """Whether a figure moved beyond its noise between two releases (see the module's docstring)."""
    if not (math.isfinite(old) and math.isfinite(new)):
        return not (old == new or (math.isnan(old) and math.isnan(new)))
    return abs(new - old) > factor * max(noise_old, noise_new)


@dataclass(frozen=True)
class Snapshot:
    """One release's data as the comparison needs it."""

    release: Release
    figures: Mapping[Key, float]
    noise: Mapping[Key, float]
    statuses: Mapping[Key, str]


def snapshot(release: Release, doc: Mapping, perturbed: Sequence[Mapping]) -> Snapshot:
    return Snapshot(release, figures(doc), noise(doc, perturbed), statuses(doc))


def _available(data: Snapshot, key: Key) -> bool:
    """The figure was measured: present, and its check (if any) not n/a."""
    return key in data.figures and data.statuses.get(key) != "n/a"


def compare(a: Snapshot, b: Snapshot, *, factor: float = NOISE_FACTOR) -> list[Change]:
    """Every change from release ``a`` to release ``b`` (unsorted)."""
    out: list[Change] = []
    keys = list(dict.fromkeys([*a.figures, *a.statuses, *b.figures, *b.statuses]))
    for key in keys:
        case, name = key
        old, new = a.figures.get(key), b.figures.get(key)
        n_old, n_new = a.noise.get(key, math.inf), b.noise.get(key, math.inf)
        s_old, s_new = a.statuses.get(key), b.statuses.get(key)
        here_a, here_b = _available(a, key), _available(b, key)
        noise = max(n_old, n_new) if here_a and here_b else (n_new if here_b else n_old)
        common: dict[str, Any] = {"case": case, "figure": name, "since": a.release, "release": b.release, "old": old,
                                  "new": new, "noise": noise, "status_old": s_old, "status_new": s_new}
        if here_a != here_b:
            out.append(Change(kind="appeared" if here_b else "vanished", **common))
        elif status_flipped(s_old, s_new):
            out.append(Change(kind="flip", **common))
        elif old is not None and new is not None and moved(old, new, n_old, n_new, factor=factor):
            out.append(Change(kind="moved", **common))
    return out


def changes(data: Sequence[Snapshot], *, factor: float = NOISE_FACTOR) -> list[Change]:
    """Every change between consecutive releases of ``data`` (oldest first), sorted: flips, then figures
    that moved, by the size of the change, then those that appeared or vanished."""
    found = [c for a, b in itertools.pairwise(data) for c in compare(a, b, factor=factor)]
    return sorted(found, key=sort_key)


def history(data: Sequence[Snapshot], key: Key) -> History:
    """One figure over every release of ``data``."""
    return History(key[0], key[1], tuple(Point(d.release, d.figures.get(key), d.noise.get(key),
                                               d.statuses.get(key)) for d in data))

"""The first release at which a figure (or any verdict) changed, running only the releases it needs.

Given the releases of a range, oldest first, the two ends are run; if the target differs between them,
the release halfway is run and compared with the oldest, and the half that holds the change is kept,
until two neighbours on the list remain: the newer is the first release that shows the change. A range
of n releases costs 2 + ⌈log2(n − 1)⌉ environments instead of n.

The target is a figure (``CASE:FIGURE``), which has changed at a release when it moved beyond its noise
from the oldest release's value (:func:`harness.versions.changes.moved`), or ``verdicts``: any check's
status differs from the oldest release's. Bisection assumes the change happened once: a figure that
changed and changed back between two releases run is not seen.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from harness.outputs.diff import JUDGED
from harness.versions.changes import NOISE_FACTOR, Key, Snapshot, moved
from harness.versions.releases import Release

__all__ = ["Bisection", "Target", "bisect", "differs", "parse_target"]

VERDICTS = "verdicts"


@dataclass(frozen=True)
class Target:
    """What to bisect: one figure of one case, or (``figure`` None) every verdict."""

    case: str | None = None
    figure: str | None = None

    @property
    def key(self) -> Key | None:
        return None if self.figure is None else (self.case or "", self.figure)

    def describe(self) -> str:
        return "any verdict" if self.figure is None else f"{self.case} {self.figure}"


def parse_target(text: str) -> Target:
    """``verdicts``, or ``CASE:FIGURE``; ValueError (one line) otherwise."""
    if text == VERDICTS:
        return Target()
    case, sep, figure = text.partition(":")
    if not sep or not case or not figure:
        raise ValueError(f"--bisect takes CASE:FIGURE (e.g. spherical_pendulum_ball:RK4.position) or "
                         f"'{VERDICTS}', got {text!r}")
    return Target(case, figure)


def differs(target: Target, base: Snapshot, other: Snapshot, *, factor: float = NOISE_FACTOR) -> list[str]:
    """How ``other`` differs from ``base`` in ``target``: one line per difference (empty: no change)."""
    if target.key is None:
        keys = sorted(set(base.statuses) | set(other.statuses))
        return [f"{c} {f}: {base.statuses.get((c, f), 'absent')} -> {other.statuses.get((c, f), 'absent')}"
                for c, f in keys if base.statuses.get((c, f)) != other.statuses.get((c, f))
                and (base.statuses.get((c, f)) in JUDGED or other.statuses.get((c, f)) in JUDGED)]
    key = target.key
    old, new = base.figures.get(key), other.figures.get(key)
    if old is None and new is None:
        return []
    if old is None or new is None:
        return [f"{target.describe()}: {'absent' if old is None else f'{old:.4g}'} -> "
                f"{'absent' if new is None else f'{new:.4g}'}"]
    noise = max(base.noise.get(key, math.inf), other.noise.get(key, math.inf))
    if moved(old, new, base.noise.get(key, math.inf), other.noise.get(key, math.inf), factor=factor):
        return [f"{target.describe()}: {old:.6g} -> {new:.6g} (change {abs(new - old):.3g}, noise {noise:.3g})"]
    return []


@dataclass(frozen=True)
class Bisection:
    """The outcome: ``first`` the first release that differs from ``releases[0]`` (None: the newest does
    not), ``before`` the last that does not, ``visited`` the releases run (in the order run), ``evidence``
    how ``first`` differs, ``errors`` releases that could not be run."""

    target: Target
    releases: tuple[Release, ...]
    first: Release | None
    before: Release | None
    visited: tuple[Release, ...]
    evidence: tuple[str, ...]
    errors: tuple[tuple[Release, str], ...] = ()

    def text(self) -> str:
        lo, hi = self.releases[0], self.releases[-1]
        runs = (f"{len(self.visited)} of {len(self.releases)} releases run: "
                f"{', '.join(str(r) for r in sorted(self.visited))}")
        if self.errors:
            failed = "; ".join(f"{r}: {e}" for r, e in self.errors)
            return (f"bisect {self.target.describe()} over {lo}..{hi}: stopped, a release could not be run "
                    f"({failed})\n{runs}\n")
        if self.first is None:
            return f"bisect {self.target.describe()}: no change between {lo} and {hi} beyond noise\n{runs}\n"
        lines = [f"bisect {self.target.describe()}: first changed at MuJoCo {self.first} (after {self.before})",
                 *(f"  {e}" for e in self.evidence), runs]
        return "\n".join(lines) + "\n"

    def as_dict(self) -> dict[str, object]:
        return {"target": self.target.describe(), "releases": [str(r) for r in self.releases],
                "first": None if self.first is None else str(self.first),
                "before": None if self.before is None else str(self.before),
                "visited": [str(r) for r in self.visited], "evidence": list(self.evidence),
                "errors": [{"release": str(r), "error": e} for r, e in self.errors]}


def bisect(target: Target, releases: Sequence[Release], run: Callable[[Release], Snapshot | str], *,
           factor: float = NOISE_FACTOR) -> Bisection:
    """Bisect ``releases`` (oldest first, at least two) for ``target``; ``run(release)`` gives the
    release's :class:`Snapshot` or a one-line error."""
    releases = tuple(releases)
    visited: list[Release] = []
    seen: dict[Release, Snapshot] = {}

    def at(i: int) -> Snapshot | str:
        r = releases[i]
        if r not in seen:
            visited.append(r)
            got = run(r)
            if isinstance(got, str):
                return got
            seen[r] = got
        return seen[r]

    def stopped(release: Release, error: str) -> Bisection:
        return Bisection(target, releases, None, None, tuple(visited), (), ((release, error),))

    base = at(0)
    if isinstance(base, str):
        return stopped(releases[0], base)
    newest = at(len(releases) - 1)
    if isinstance(newest, str):
        return stopped(releases[-1], newest)
    if not differs(target, base, newest, factor=factor):
        return Bisection(target, releases, None, None, tuple(visited), ())
    lo, hi = 0, len(releases) - 1  # lo: like the oldest; hi: differs
    while hi - lo > 1:
        mid = (lo + hi) // 2
        got = at(mid)
        if isinstance(got, str):
            return stopped(releases[mid], got)
        if differs(target, base, got, factor=factor):
            hi = mid
        else:
            lo = mid
    evidence = differs(target, seen[releases[lo]], seen[releases[hi]], factor=factor) or \
        differs(target, base, seen[releases[hi]], factor=factor)
    return Bisection(target, releases, releases[hi], releases[lo], tuple(visited), tuple(evidence))

"""MuJoCo releases: version numbers, and the list the package index holds.

The range form of ``mjharness versions LO..HI`` covers every release the index offers between LO and HI,
asked of the index each time (``pip index versions mujoco``, pip being the ordinary client of the index
the user has configured), never a list typed here. Releases older than :data:`OLDEST` are refused: the
harness supports MuJoCo 3.3 and later (pyproject: ``mujoco>=3.3``).
"""

from __future__ import annotations

import re
import subprocess
import sys
from collections.abc import Callable, Sequence
from functools import total_ordering

__all__ = ["Release", "parse_selection", "pip_index_versions", "releases_between"]

PACKAGE = "mujoco"
OLDEST = "3.3.0"

_RELEASE = re.compile(r"^(\d+)\.(\d+)\.(\d+)$")


@total_ordering
class Release:
    """A final release's version, ``MAJOR.MINOR.PATCH`` (no pre- or post-release suffix), ordered by number."""

    __slots__ = ("numbers", "text")

    def __init__(self, text: str) -> None:
        match = _RELEASE.match(text.strip())
        if match is None:
            raise ValueError(f"{text!r} is not a MuJoCo release number (expected MAJOR.MINOR.PATCH, e.g. 3.3.0)")
        self.text = text.strip()
        self.numbers = tuple(int(g) for g in match.groups())

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Release) and self.numbers == other.numbers

    def __lt__(self, other: Release) -> bool:
        return self.numbers < other.numbers

    def __hash__(self) -> int:
        return hash(self.numbers)

    def __repr__(self) -> str:
        return f"Release({self.text!r})"

    def __str__(self) -> str:
        return self.text


def release(text: str) -> Release:
    """``text`` as a :class:`Release`, refused (ValueError, one line) below :data:`OLDEST`."""
    found = Release(text)
    if found < Release(OLDEST):
        raise ValueError(f"MuJoCo {found} is older than the oldest the harness supports ({OLDEST})")
    return found


def pip_index_versions(package: str = PACKAGE) -> list[str]:
    """The versions of ``package`` the package index offers, newest first, as ``pip index versions``
    lists them (pip of this interpreter, with the user's pip configuration). ValueError (one line) where
    the index cannot be reached or does not know the package."""
    try:
        done = subprocess.run([sys.executable, "-m", "pip", "index", "versions", package,
                               "--disable-pip-version-check"], capture_output=True, text=True, timeout=120, check=False)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise ValueError(f"cannot ask the package index for {package}'s releases: {exc}") from None
    for line in done.stdout.splitlines():
        if line.strip().startswith("Available versions:"):
            return [v.strip() for v in line.split(":", 1)[1].split(",") if v.strip()]
    reason = (done.stderr.strip().splitlines() or ["no 'Available versions' in pip's answer"])[-1]
    raise ValueError(f"cannot ask the package index for {package}'s releases: {reason}")


def releases_between(low: str, high: str, *, index: Callable[[], Sequence[str]] | None = None) -> list[Release]:
    """Every final release the index offers from ``low`` to ``high`` (both included, oldest first).
    ``index`` gives the index's list (default: :func:`pip_index_versions`; tests pass a fake).
    ValueError where the range is reversed or names a release the index does not offer."""
    lo, hi = release(low), release(high)
    if hi < lo:
        raise ValueError(f"the range {lo}..{hi} runs backwards; give the older release first")
    listed = index() if index is not None else pip_index_versions()
    offered = sorted({Release(v) for v in listed if _RELEASE.match(v.strip())})
    missing = [str(r) for r in (lo, hi) if r not in offered]
    if missing:
        raise ValueError(f"the package index offers no MuJoCo {', '.join(missing)}; it offers "
                         f"{', '.join(str(r) for r in offered if r >= Release(OLDEST))}")
    return [r for r in offered if lo <= r <= hi]


def parse_selection(tokens: Sequence[str], *, index: Callable[[], Sequence[str]] | None = None) -> list[Release]:
    """The releases ``tokens`` name, oldest first, each once: a release (``3.17.0``) or a range
    (``3.3.0..4.0.0``: every release the index offers between the two). At least two are needed."""
    chosen: set[Release] = set()
    for token in tokens:
        low, sep, high = token.partition("..")
        chosen.update(releases_between(low, high, index=index) if sep else [release(token)])
    if len(chosen) < 2:
        raise ValueError(f"name at least two MuJoCo releases to compare (got {', '.join(tokens) or 'none'}); "
                         "e.g. 3.17.0 4.0.0, or a range 3.3.0..4.0.0")
    return sorted(chosen)

"""Numeric dynamics shipped with the package, so that a fresh install's first ``check`` runs no sympy.

Deriving the systems and lambdifying their equations was most of a cold ``check`` (docs/findings/speed.md).
The numeric code a run needs at each default case's parameter values (:class:`analytic.dynamics.Compiled`,
lambdify's Python source) is written into ``prebuilt/`` beside this module by
``python -m harness.cases.prebuilt`` and installed as package data; :mod:`.derivations` reads an entry
from here where the user's cache has none, and stores it there.

An entry is used only where it is the one this source would make. Its key is a hash of the text of the
files it came from (the system module, ``analytic/systems/__init__.py``, ``analytic/lagrangian.py``,
``analytic/dynamics.py``) and of the parameter values; its header repeats the key with the SHA-256 of its
bytes (the user cache's entry format, :mod:`harness.core.cache`: data, never a pickle; the code in it runs
only once checked to be arithmetic, ``analytic.dynamics``), so an entry whose sources were edited since, or
whose bytes changed, is passed over and the code derived as before. Unlike the user
cache's key, this one leaves out the Python and sympy versions: the entry is plain numpy source, so any
install loads the code the package was tested with (tests/test_prebuilt.py: the entries are current, and
are what sympy derives from these sources).

``MJHARNESS_NO_PREBUILT=1`` (or ``MJHARNESS_NO_CACHE=1``) leaves the entries unused.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Sequence
from pathlib import Path

from analytic.dynamics import Compiled
from harness.core import cache

__all__ = ["DIRECTORY", "SUFFIX", "covers", "load", "write"]

DIRECTORY = Path(__file__).resolve().parent / "prebuilt"
SUFFIX = ".entry"


def enabled() -> bool:
    """Whether shipped entries are read (not with MJHARNESS_NO_PREBUILT or MJHARNESS_NO_CACHE set)."""
    return all(os.environ.get(v, "").strip() in ("", "0") for v in ("MJHARNESS_NO_PREBUILT", "MJHARNESS_NO_CACHE"))


def source_digest(sources: Sequence[Path]) -> str:
    """The hash of the sources an entry came from (their names and text; no versions)."""
    return cache.source_key(sources, versions=False)


def entry_key(sources: Sequence[Path], params: tuple[tuple[str, float], ...]) -> str:
    """An entry's key: its sources' digest and the parameter values."""
    return cache.key(source_digest(sources), repr(params), versions=False)


def _params_digest(params: tuple[tuple[str, float], ...]) -> str:
    return hashlib.sha256(repr(params).encode()).hexdigest()


def path(kind: str, system: str, sources: Sequence[Path], params: tuple[tuple[str, float], ...]) -> Path:
    """Where the entry of (kind, system, sources, params) is shipped: the sources' digest in its name, so
    that every entry of one system's current source is found without reading any."""
    return DIRECTORY / f"{kind}-{system}-{source_digest(sources)[:16]}-{_params_digest(params)[:16]}{SUFFIX}"


def load(kind: str, system: str, sources: Sequence[Path], params: tuple[tuple[str, float], ...]) -> Compiled | None:
    """The shipped entry of (kind, system) at ``params`` if there is one made from ``sources`` as they are
    now, unaltered; else None."""
    if not enabled():
        return None
    found = cache.load_file(path(kind, system, sources, params), kind, system, entry_key(sources, params), Compiled)
    return found if isinstance(found, Compiled) else None


def covers(kind: str, system: str, sources: Sequence[Path]) -> bool:
    """Whether an entry of (kind, system) made from ``sources`` as they are now is shipped, at any
    parameter values (a hint for scheduling: the entry may still turn out unusable)."""
    return enabled() and any(DIRECTORY.glob(f"{kind}-{system}-{source_digest(sources)[:16]}-*{SUFFIX}"))


def write(kind: str, system: str, sources: Sequence[Path], params: tuple[tuple[str, float], ...],
          compiled: Compiled) -> Path:
    """Write the entry of (kind, system) at ``params``, made from ``sources``; its path."""
    data = cache.entry_bytes(kind, system, entry_key(sources, params), compiled)
    if data is None:
        raise ValueError(f"the {kind} of {system!r} is not plain data")
    target = path(kind, system, sources, params)
    if not cache.write_atomic(target, data):
        raise OSError(f"cannot write {target}")
    return target

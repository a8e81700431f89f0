"""The numeric dynamics every case needs at its shipped parameters, written into the package
(:mod:`harness.reference.prebuilt`) so that a fresh install's first run derives nothing.

After editing a system, ``analytic/lagrangian.py``, ``analytic/dynamics.py`` or a case's model, write
them anew (tests/test_prebuilt.py fails until then)::

    python -m harness.cases.prebuilt

Every entry is derived afresh with sympy (the user's cache is neither read nor written), and the entries
of sources or parameters no case has any more are removed.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator

from analytic import systems
from analytic.dynamics import Compiled
from harness import cases
from harness.engine.models import compile_model
from harness.reference import derivations, prebuilt

__all__: list[str] = []


def needed() -> Iterator[tuple[str, str, tuple[tuple[str, float], ...]]]:
    """(kind, system, params) of every numeric dynamics a shipped case's run loads, once each (a user's
    systems, :mod:`harness.cases.sources`, are derived where they run)."""
    seen = set()
    for case in (c for c in cases.all_cases() if not c.origin):
        params = tuple(sorted(systems.load(case.system).params_from_model(compile_model(case.mjcf)).items()))
        kinds = ("dynamics", "minimal-dynamics") if systems.has_minimal(case.system) else ("dynamics",)
        for kind in kinds:
            if (kind, case.system, params) not in seen:
                seen.add((kind, case.system, params))
                yield kind, case.system, params


def missing() -> list[str]:
    """Each needed entry the package does not ship for the sources as they are now, as 'kind system'."""
    return [f"{kind} {system}" for kind, system, params in needed()
            if prebuilt.load(kind, system, derivations.numeric_sources(system), params) is None]


def write_all() -> list[str]:
    """Derive and write every needed entry, removing the others; the files written."""
    os.environ["MJHARNESS_NO_CACHE"] = "1"  # derived here and now, from these sources: no cache read
    entries = list(needed())
    written = []
    for kind, system, params in entries:
        deriving = derivations.derivation if kind == "dynamics" else derivations.minimal_derivation
        derived = deriving(system)
        assert derived is not None  # needed() names the minimal form only of a system that has one
        compiled = Compiled.of(derived, dict(params))
        written.append(prebuilt.write(kind, system, derivations.numeric_sources(system), params, compiled))
    for old in prebuilt.DIRECTORY.glob(f"*{prebuilt.SUFFIX}"):
        if old not in written:
            old.unlink()
    return [p.name for p in written]


def main() -> int:
    for name in write_all():
        print(f"wrote {prebuilt.DIRECTORY.name}/{name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

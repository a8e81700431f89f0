"""The numeric dynamics shipped with the package (harness/reference/prebuilt.py) are current, are what sympy
derives from these sources, are used only while they are, and spare a fresh install every derivation
without changing any verdict or figure."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

from analytic.dynamics import Compiled
from harness import cases
from harness.cases import prebuilt as shipped
from harness.engine.compat import version as mujoco_version
from harness.pipeline import matrix as runner
from harness.reference import derivations, prebuilt

FAST = ("pendulum", "atwood")  # one system without and one with a minimal form, a few seconds of sympy


def _clear() -> None:
    for fn in (derivations.derivation, derivations.minimal_derivation, derivations._dynamics,
               derivations._minimal_dynamics):
        fn.cache_clear()


@pytest.fixture
def fresh(monkeypatch):
    """No derivation or dynamics kept by this process; the package's entries read."""
    monkeypatch.delenv("MJHARNESS_NO_CACHE", raising=False)
    monkeypatch.delenv("MJHARNESS_NO_PREBUILT", raising=False)
    _clear()
    yield
    _clear()


def test_every_cases_dynamics_ship_for_the_sources_as_they_are(fresh):
    stale = [f"{k} {s}" for k, s, _ in shipped.needed() if not prebuilt.covers(k, s, derivations.numeric_sources(s))]
    assert stale == [], ("the package's prebuilt dynamics are stale or missing: "
                         "run `python -m harness.cases.prebuilt` and commit harness/reference/prebuilt/")
    if mujoco_version() < (4, 0, 0):  # written on MuJoCo 4: 3.3's compiler rounds physical_pendulum's inertia
        return  # otherwise, so there that one system derives (its entry's sources are current all the same)
    assert shipped.missing() == [], "run `python -m harness.cases.prebuilt` (on MuJoCo 4) and commit its entries"
    names = {p.name for p in prebuilt.DIRECTORY.glob(f"*{prebuilt.SUFFIX}")}
    wanted = {prebuilt.path(k, s, derivations.numeric_sources(s), p).name for k, s, p in shipped.needed()}
    assert names == wanted  # nothing stale left beside them


def _is_what_sympy_derives(systems_: tuple[str, ...], monkeypatch) -> None:
    """Each shipped entry of ``systems_`` equals, source text and all, what sympy derives now with no cache."""
    entries = [(k, s, p) for k, s, p in shipped.needed() if s in systems_]
    assert {s for _, s, _ in entries} == set(systems_)
    loaded = {(k, s): prebuilt.load(k, s, derivations.numeric_sources(s), p) for k, s, p in entries}
    monkeypatch.setenv("MJHARNESS_NO_CACHE", "1")  # derived here and now
    for kind, system, params in entries:
        deriving = derivations.derivation if kind == "dynamics" else derivations.minimal_derivation
        assert loaded[kind, system] == Compiled.of(deriving(system), dict(params)), (kind, system)


def test_shipped_dynamics_are_what_sympy_derives(fresh, monkeypatch):
    _is_what_sympy_derives(FAST, monkeypatch)


@pytest.mark.slow
def test_every_shipped_entry_is_what_sympy_derives(fresh, monkeypatch):
    _is_what_sympy_derives(tuple(dict.fromkeys(s for _, s, _ in shipped.needed())), monkeypatch)


@pytest.fixture
def package_copy(tmp_path, monkeypatch):
    """The shipped entries copied to a folder of the test's own, which the package reads instead."""
    folder = tmp_path / "prebuilt"
    shutil.copytree(prebuilt.DIRECTORY, folder)
    monkeypatch.setattr(prebuilt, "DIRECTORY", folder)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    monkeypatch.delenv("MJHARNESS_NO_CACHE", raising=False)
    monkeypatch.delenv("MJHARNESS_NO_PREBUILT", raising=False)
    _clear()
    yield folder
    _clear()


def _pendulum():
    (kind, system, params), *_ = [e for e in shipped.needed() if e[:2] == ("dynamics", "pendulum")]
    return kind, system, params


def test_an_altered_entry_is_passed_over(package_copy):
    kind, system, params = _pendulum()
    sources = derivations.numeric_sources(system)
    entry = prebuilt.path(kind, system, sources, params)
    assert prebuilt.load(kind, system, sources, params) is not None
    entry.write_bytes(entry.read_bytes().replace(b"9.81", b"9.82"))  # gravity altered in the stored code
    assert b"9.82" in entry.read_bytes()
    assert prebuilt.load(kind, system, sources, params) is None


def test_an_entry_of_other_sources_or_parameters_is_passed_over(package_copy, tmp_path):
    kind, system, params = _pendulum()
    sources = derivations.numeric_sources(system)
    edited = tmp_path / sources[0].name
    edited.write_text(sources[0].read_text() + "\n# edited\n")
    assert prebuilt.load(kind, system, [edited, *sources[1:]], params) is None
    other = tuple((name, value * 2) for name, value in params)
    assert prebuilt.load(kind, system, sources, other) is None
    # another system's entry in this one's place
    atwood = next(e for e in shipped.needed() if e[:2] == ("dynamics", "atwood"))
    shutil.copy(prebuilt.path(*atwood[:2], derivations.numeric_sources("atwood"), atwood[2]),
                prebuilt.path(kind, system, sources, params))
    assert prebuilt.load(kind, system, sources, params) is None


def test_unusable_shipped_entries_are_derived_instead(package_copy, monkeypatch):
    """An entry passed over (here every one, altered) costs a derivation, never a wrong reference."""
    kind, system, params = _pendulum()
    sources = derivations.numeric_sources(system)
    entry = prebuilt.path(kind, system, sources, params)
    entry.write_bytes(entry.read_bytes().replace(b"9.81", b"9.82"))
    dynamics = derivations.dynamics(system, dict(params))
    assert dynamics.params == dict(params) and dynamics.params["g"] == 9.81
    monkeypatch.setenv("MJHARNESS_NO_CACHE", "1")
    _clear()
    fresh = derivations.dynamics(system, dict(params))
    q, qd = np.array([0.3, 1.0]), np.array([0.2, -0.1])
    assert np.array_equal(dynamics.forcing(q, qd), fresh.forcing(q, qd))


def test_they_can_be_turned_off(package_copy, monkeypatch):
    kind, system, params = _pendulum()
    sources = derivations.numeric_sources(system)
    assert prebuilt.load(kind, system, sources, params) is not None and derivations.derivation_stored(system)
    monkeypatch.setenv("MJHARNESS_NO_PREBUILT", "1")
    assert prebuilt.load(kind, system, sources, params) is None and not derivations.derivation_stored(system)


def test_a_fresh_install_derives_nothing(tmp_path):
    """With an empty cache, check finds every case's numeric dynamics in the package: it never imports sympy
    and stores no derivation, only the shipped entries (so the next run reads its own cache)."""
    code = ("import sys; from harness.cli import commands as cli; "
            "code = cli.main(['check', 'spring', 'atwood', '--jobs', '1', '--quiet']); "
            "print('sympy' in sys.modules, code)")
    env = {k: v for k, v in os.environ.items() if k not in ("MJHARNESS_NO_CACHE", "MJHARNESS_NO_PREBUILT")}
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                          env=env | {"XDG_CACHE_HOME": str(tmp_path)})
    assert proc.stdout.strip().splitlines()[-1] == "False 0", proc.stdout + proc.stderr
    stored = sorted(p.parent.name for p in (tmp_path / "mjharness").glob("*/*.entry"))
    # spring's; atwood's and its minimal form; and the two references solved (harness/reference/solutions.py)
    assert stored == ["dynamics", "dynamics", "minimal-dynamics", "solution", "solution"]


def _verdicts(selected) -> dict:
    results, checks, _ = runner.run_all(selected, None, figures_only=True)
    return {name: [(c.name, c.status, repr(c.judged)) for c in found] for name, found in checks.items()} | {
        r.case.name + " figures": [(f.name, repr(f.value)) for f in r.figures] for r in results}


@pytest.mark.slow
def test_no_verdict_or_figure_changes_with_the_shipped_dynamics(package_copy, monkeypatch):
    """Every default case's every check (status and the figure it judged) and every figure, the same
    with the package's dynamics as with dynamics derived here and now."""
    selected = cases.select([])
    with_shipped = _verdicts(selected)
    monkeypatch.setenv("MJHARNESS_NO_CACHE", "1")
    _clear()
    from harness.reference import solutions

    solutions.clear_caches()
    assert _verdicts(selected) == with_shipped

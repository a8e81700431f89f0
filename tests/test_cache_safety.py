"""Nothing executable is read from the cache (issue 45, point 2).

- A cache entry is data (:mod:`harness.core.stored`): a pickle put in an entry's place, with a header
  recomputed to match it, is never unpickled; the value is recomputed and stored over.
- Numeric code in an entry (lambdify's source) runs only once checked to be arithmetic on numpy's
  functions: an entry whose code would call ``os.system`` is refused and made anew, never run.
- The native recorder's library is loaded only from a private folder, only if its SHA-256 is the one
  recorded when this install built it: a replaced library (one whose constructor would write a marker
  file) and a corrupted one are rebuilt, never loaded.

Each payload would create a marker file if it ran; the tests assert the marker is absent.
"""

from __future__ import annotations

import hashlib
import json
import os
import pickle
import shutil
import stat
import subprocess

import numpy as np
import pytest

from analytic import systems
from analytic.dynamics import Compiled, _checked_source
from harness.core import cache, stored
from harness.engine.models import compile_model, mjcf_path
from harness.reference import derivations

SYSTEM = "pendulum"


class _Payload:
    """Unpickling this runs ``os.system`` (what an attacker's pickle does)."""

    def __init__(self, marker: str) -> None:
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


@pytest.fixture
def cache_home(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    monkeypatch.setenv("MJHARNESS_NO_PREBUILT", "1")
    monkeypatch.delenv("MJHARNESS_NO_CACHE", raising=False)
    derivations.clear_caches()
    yield tmp_path / "xdg" / "mjharness"
    derivations.clear_caches()


def _params() -> dict[str, float]:
    return systems.load(SYSTEM).params_from_model(compile_model(mjcf_path(SYSTEM)))


def _forged(entry, payload: bytes) -> None:
    """Put ``payload`` in ``entry``'s place with a header that matches it (what a writer of the cache can do)."""
    header = cache.read_header(entry)
    header["sha256"] = hashlib.sha256(payload).hexdigest()
    entry.write_bytes(json.dumps(header, sort_keys=True).encode() + b"\n" + payload)


def test_a_pickle_with_a_matching_header_is_never_unpickled(cache_home, tmp_path):
    marker = tmp_path / "pwned-pickle"
    params = _params()
    good = derivations.dynamics(SYSTEM, params).mass_matrix(np.array([0.3, 1.0]))
    (entry,) = (cache_home / "dynamics").glob(f"{SYSTEM}-*{cache.SUFFIX}")
    _forged(entry, pickle.dumps(_Payload(str(marker))))
    derivations.clear_caches()
    again = derivations.dynamics(SYSTEM, params).mass_matrix(np.array([0.3, 1.0]))
    assert not marker.exists()
    assert np.array_equal(again, good)
    assert b"os.system" not in entry.read_bytes() and b"posix" not in entry.read_bytes()  # stored over


def test_stored_code_that_would_run_a_command_is_refused_and_made_anew(cache_home, tmp_path):
    marker = tmp_path / "pwned-code"
    params = _params()
    good = derivations.dynamics(SYSTEM, params).mass_matrix(np.array([0.3, 1.0]))
    (entry,) = (cache_home / "dynamics").glob(f"{SYSTEM}-*{cache.SUFFIX}")
    compiled = cache.load("dynamics", SYSTEM, cache.read_header(entry)["key"], Compiled)
    hostile = "def _lambdifygenerated(*a):\n    return [__import__('os').system('touch " + str(marker) + "')]\n"
    functions = tuple((n, hostile if src else src, r, c) for n, src, r, c in compiled.functions)
    _forged(entry, stored.dumps(Compiled(**{**vars(compiled), "functions": functions})))
    derivations.clear_caches()
    again = derivations.dynamics(SYSTEM, params).mass_matrix(np.array([0.3, 1.0]))
    assert not marker.exists()
    assert np.array_equal(again, good)
    assert b"__import__" not in entry.read_bytes()


@pytest.mark.parametrize("code", [
    "import os",
    "def _lambdifygenerated(x):\n    return [x.__class__]",
    "def _lambdifygenerated(x):\n    return [numpy.load(x)]",
    "def _lambdifygenerated(x):\n    return [open('f')]",
    "def _lambdifygenerated(x):\n    return [(lambda: 1)()]",
    "def _lambdifygenerated(x):\n    return [10**10**10]",
    "def _lambdifygenerated(x):\n    return ['text']",
    "@numpy.sin\ndef _lambdifygenerated(x):\n    return [x]",
])
def test_only_lambdify_shaped_arithmetic_is_compiled(code):
    with pytest.raises(ValueError):
        _checked_source(code)


def test_lambdify_shaped_arithmetic_is_compiled():
    _checked_source("def _lambdifygenerated(a, b):\n    x0 = numpy.sin(a)\n    return [x0**2 + b**(-1/2), 0]\n")


@pytest.mark.parametrize("tree", [
    {"$": "obj", "type": "subprocess.Popen", "v": {}},
    {"$": "sympy", "v": ["apply", "Function", []]},
    {"$": "sympy", "v": ["apply", "__import__", [["integer", "1"]]]},
    {"$": "array", "dtype": "object", "shape": [1], "data": ""},
    {"$": "pickle", "v": ""},
])
def test_stored_values_outside_the_vocabulary_are_refused(tree):
    with pytest.raises(ValueError):
        stored.loads(json.dumps(tree).encode())


def test_values_round_trip_as_data():
    value = (1, 2.5, float("nan"), "x", None, True, [np.arange(6.0).reshape(2, 3)], {"k": np.float64(3.0)})
    back = stored.loads(stored.dumps(value))
    assert back[:2] == value[:2] and np.isnan(back[2]) and back[3:6] == value[3:6]
    assert np.array_equal(back[6][0], value[6][0]) and back[7] == {"k": 3.0} and isinstance(back[7]["k"], np.float64)


# the native recorder's library ------------------------------------------------------------------------------

needs_compiler = pytest.mark.skipif(not (os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")),
                                    reason="no C compiler")


@pytest.fixture
def native(cache_home, monkeypatch):
    from harness.engine.recording import native as module

    monkeypatch.delenv("MJHARNESS_NATIVE", raising=False)
    module.library.cache_clear()
    yield module
    module.library.cache_clear()


def _library(folder):
    (found,) = folder.glob("record-*.so")
    return found


@needs_compiler
def test_a_replaced_recorder_is_rebuilt_never_loaded(native, cache_home, tmp_path):
    assert native.library() is not None, native.why_not()
    built = _library(cache_home / "native")
    assert stat.S_IMODE((cache_home / "native").stat().st_mode) == 0o700
    marker = tmp_path / "pwned-so"
    source = tmp_path / "evil.c"
    source.write_text('#include <stdlib.h>\n__attribute__((constructor)) static void run(void) '
                      f'{{ system("touch {marker}"); }}\nint mjh_abi(void) {{ return {native.ABI}; }}\n')
    evil = tmp_path / "evil.so"
    subprocess.run([os.environ.get("CC") or shutil.which("cc") or "gcc", "-shared", "-fPIC", str(source), "-o",
                    str(evil)], check=True)
    os.chmod(evil, 0o700)
    os.replace(evil, built)  # a new file in its place (this process maps the old one: never write into it)
    native.library.cache_clear()
    assert native.library() is not None, native.why_not()
    assert not marker.exists()
    record = built.with_name(built.name + native.HASH_SUFFIX).read_text().strip()
    assert hashlib.sha256(built.read_bytes()).hexdigest() == record  # rebuilt over


@needs_compiler
def test_a_corrupted_recorder_is_rebuilt(native, cache_home):
    assert native.library() is not None, native.why_not()
    built = _library(cache_home / "native")
    good = built.read_bytes()
    half = built.with_name("half")
    half.write_bytes(good[: len(good) // 2])
    os.replace(half, built)  # (this process maps the old file: never write into it)
    native.library.cache_clear()
    assert native.library() is not None, native.why_not()
    assert built.read_bytes() == good


def test_a_recorder_folder_that_is_a_link_is_not_used(native, tmp_path):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir(mode=0o700)
    link = tmp_path / "native"
    link.symlink_to(elsewhere)
    assert native._private_folder(link) is None
    own = tmp_path / "own"
    own.mkdir(mode=0o755)
    assert native._private_folder(own) == own and stat.S_IMODE(own.stat().st_mode) == 0o700

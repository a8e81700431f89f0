"""The native recorder's build: where it cannot be built the batch recorder (or the loop) runs and says why,
in one line; where it is built it shares the one MuJoCo library Python loaded."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import mujoco
import pytest

from harness.engine import recording
from harness.engine.models import compile_model, mjcf_path
from harness.engine.recording import native

from .test_recording import PROBE, Q0, QD0, _arrays


def _fresh(monkeypatch, tmp_path, **env: str) -> None:
    """A process state in which the recorder is looked for anew, with a cache of its own."""
    native.library.cache_clear()
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.delenv("MJHARNESS_NO_CACHE", raising=False)
    for name, value in env.items():
        monkeypatch.setenv(name, value)


@pytest.fixture(autouse=True)
def _forget():
    yield
    native.library.cache_clear()  # the next test finds the user's own build again


@pytest.mark.parametrize("env, says", [({"MJHARNESS_NATIVE": "0"}, "turned off (MJHARNESS_NATIVE=0)"),
                                       ({"CC": "/nonexistent/cc"}, "cc could not build it")])
def test_without_the_native_recorder_another_records_the_same_numbers_and_says_why(monkeypatch, tmp_path, env, says):
    model = compile_model(mjcf_path("pendulum"), integrator="Euler")
    loop = _arrays(recording.record(model, PROBE, q0=Q0, qd0=QD0, steps=60, method="loop"))
    _fresh(monkeypatch, tmp_path, **env)
    assert native.library() is None and says in native.why_not() and "\n" not in native.why_not()
    assert f"no native recorder: {native.why_not()}" in recording.recorder()
    got = _arrays(recording.record(model, PROBE, q0=Q0, qd0=QD0, steps=60))
    assert [k for k in loop if not (loop[k] == got[k]).all()] == []
    with pytest.raises(ValueError, match=r"^method 'native' is not available here: .*; accepted here: 'auto'"):
        recording.record(model, PROBE, q0=Q0, qd0=QD0, steps=60, method="native")


def test_a_build_is_kept_in_the_cache_and_found_again(monkeypatch, tmp_path):
    _fresh(monkeypatch, tmp_path)
    if native.library() is None:
        pytest.skip(f"no native recorder here: {native.why_not()}")
    built = list((tmp_path / "cache" / "mjharness" / "native").glob("record-*.so"))
    assert len(built) == 1 and not list(built[0].parent.glob("*.partial"))
    stamp = built[0].stat().st_mtime_ns
    native.library.cache_clear()
    assert native.library() is not None and built[0].stat().st_mtime_ns == stamp  # loaded, not rebuilt


def test_the_native_recorder_uses_the_mujoco_python_loaded():
    """One libmujoco in the process: the recorder runs on the very library whose plugins and callbacks the
    bindings registered (a second copy would have its own)."""
    if native.library() is None or not Path("/proc/self/maps").exists():
        pytest.skip("no native recorder here, or no /proc to list the process's libraries")
    code = ("import mujoco\nfrom harness.engine.recording import native\nassert native.library() is not None\n"
            "maps = open('/proc/self/maps').read().splitlines()\n"
            "print(sorted({l.split()[-1] for l in maps if 'libmujoco' in l}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    libraries = ast.literal_eval(out)
    assert len(libraries) == 1 and Path(libraries[0]).parent == Path(mujoco.__file__).parent

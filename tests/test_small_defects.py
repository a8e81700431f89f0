"""The smaller defects of issue 45 (point 6), each held by a test that failed before its fix.

- ``versions --with`` values starting with ``-`` reached ``uv pip install`` as options;
- ``MJHARNESS_MAX_STEPS=1e400`` was an internal error and ``=1.5`` silently 1;
- a malformed ``--require`` was judged only after the whole run (a dangling ``--out`` link: test_out_folder.py);
- a relative ``XDG_CACHE_HOME`` was used (the XDG spec says it is invalid and ignored);
- a full disk was reported as "cannot write ''";
- in the API, ``ctrl="a=1"`` and ``keyframe=5`` raised raw errors, MuJoCo's warnings reached stderr and
  ``MUJOCO_LOG.TXT`` appeared in the working folder.
"""

from __future__ import annotations

import errno
import os
from pathlib import Path

import pytest

import harness
from harness import cases
from harness.cli import commands as cli
from harness.core import bounds, cache
from harness.core.options import RunOptions
from harness.outputs import files
from harness.pipeline import entry
from harness.pipeline.run import run_case
from harness.versions.envs import EnvSpec
from tests.conftest import judged
from tests.helpers import damping


@pytest.mark.parametrize("extra", ["--index-url=http://example.invalid/simple", "-e.", " -r requirements.txt"])
def test_an_extra_package_that_is_an_option_is_refused(extra, capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["versions", "3.3.0", f"--with={extra}"])
    assert exc.value.code == 2 and "not a package requirement" in capsys.readouterr().err
    spec = EnvSpec(release="3.3.0", extras=(extra,))
    with pytest.raises(ValueError, match="not a package requirement"):
        spec.requirements()


@pytest.mark.parametrize("text", ["1e400", "1.5", "inf", "nan", "0", "-3", "many"])
def test_a_step_bound_that_is_no_positive_whole_number_is_refused(monkeypatch, text):
    monkeypatch.setenv(bounds.MAX_STEPS_VARIABLE, text)
    with pytest.raises(ValueError, match="a positive whole number of steps"):
        bounds.max_steps()


def test_a_whole_step_bound_written_as_a_float_is_read(monkeypatch):
    monkeypatch.setenv(bounds.MAX_STEPS_VARIABLE, "2e6")
    assert bounds.max_steps() == 2_000_000


@pytest.fixture
def no_run(monkeypatch):
    def refused(*args, **kwargs):
        raise AssertionError("the run started before its arguments were judged")

    monkeypatch.setattr(entry, "run_all", refused)  # every command runs its cases through the one entry


@pytest.mark.parametrize("given", ["position", "nosuch=1e-3"])
@pytest.mark.parametrize("command", ["run", "check"])
def test_a_malformed_or_unknown_requirement_is_refused_before_the_run(command, given, tmp_path, no_run, capsys):
    args = [command, "pendulum", "--require", given] + (["--out", str(tmp_path / "R")] if command == "run" else [])
    assert cli.main(args) == 2
    assert given.split("=")[0] in capsys.readouterr().err


def test_a_max_steps_bound_is_judged_before_the_run(monkeypatch, no_run, capsys):
    monkeypatch.setenv(bounds.MAX_STEPS_VARIABLE, "1e400")
    assert cli.main(["check", "pendulum"]) == 2
    assert "positive whole number" in capsys.readouterr().err


def test_a_relative_cache_home_is_ignored(monkeypatch, tmp_path):
    monkeypatch.delenv("MJHARNESS_NO_CACHE", raising=False)
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/cache")
    assert cache.cache_dir() == tmp_path / ".cache" / "mjharness"
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "abs"))
    assert cache.cache_dir() == tmp_path / "abs" / "mjharness"


def test_a_full_disk_names_the_file_being_written(tmp_path, monkeypatch):
    real = os.fdopen

    class Full:
        def __init__(self, fh):
            self.fh = fh

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.fh.close()

        def write(self, text):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))  # as a full disk raises it: no file name

    monkeypatch.setattr(files.os, "fdopen", lambda fd, *a, **k: Full(real(fd, *a, **k)))
    target = tmp_path / "R" / "report.html"
    with pytest.raises(ValueError) as exc:
        files.write_atomic({target: "x"})
    assert str(target) in str(exc.value) and "No space left" in str(exc.value)
    assert not target.exists()


@pytest.mark.parametrize(("given", "named"), [({"ctrl": "a=1"}, "ctrl must be a mapping"),
                                              ({"keyframe": 5}, "keyframe must be a keyframe's name")])
def test_api_arguments_of_the_wrong_type_are_named(given, named):
    with pytest.raises(TypeError, match=named):
        harness.validate(mjcf=str(Path("mjcf/pendulum.xml").resolve()), **given)


def test_api_keeps_mujocos_warnings_off_stderr_and_the_working_folder(tmp_path, monkeypatch, capfd):
    monkeypatch.chdir(tmp_path)
    result = harness.validate("pendulum", qd0={"theta": 1e12}, horizon=0.01, integrators=["RK4"])
    assert result is not None
    assert "WARNING" not in capfd.readouterr().err
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()


def test_terminal_escapes_in_a_model_name_never_reach_the_terminal(tmp_path, capsys):
    """Every line ``check`` prints (its case line, the trees' summary, the verdict) shows an ESC or BEL in the
    file's name as ``\\x1b``/``\\x07``."""
    model = tmp_path / "e\x1b[31mred\x07.xml"
    model.write_bytes(Path("mjcf/pendulum.xml").read_bytes())
    assert cli.main(["check", "--mjcf", str(model), "--horizon", "0.05", "--integrators", "RK4"]) in (0, 1)
    said = capsys.readouterr()
    assert "\x1b" not in said.out + said.err and "\x07" not in said.out + said.err
    assert "e\\x1b[31mred\\x07" in said.out + said.err


def test_a_run_whose_error_grows_past_the_motion_without_a_warning_is_diverged_not_a_number():
    """An energy-pumping fault (negative damping on MuJoCo's side only) grows the spring's energy by orders of
    magnitude over its horizon with no MuJoCo warning: each integrator's figures are "diverged", with the growth
    named, not an "unresolved" or a number. A milder fault of the same kind stays a number (a FAIL, not a
    divergence): the bound (harness.families.runs.GROWN) says diverged only past 1000 times the motion's size."""
    case = cases.get("spring")
    pumped = judged(run_case(case, RunOptions(edit=damping("x", -2.0), integrators=("RK4",))))
    rk4 = {name: c for name, c in pumped.items() if name.startswith("RK4.")}
    assert rk4 and all("left the reference by" in c.diverged and "without a MuJoCo warning" in c.diverged
                       for c in rk4.values()), {name: c.diverged for name, c in rk4.items()}
    mild = judged(run_case(case, RunOptions(edit=damping("x", -0.1), integrators=("RK4",))))
    position = mild["RK4.position"]
    assert not position.diverged and not position.passed and position.value > 0

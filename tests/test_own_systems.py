"""Users' own hand-written systems, discovered from outside the package (harness/cases/sources.py).

The example package examples/own_system (a cart-pole: system, MJCF, limits, entry point) is copied
to a temporary directory and used from there, as a user would: with ``--systems DIR``, through the
API's ``systems=``, the pytest fixture, and installed (its real entry-point metadata, written by its
own build backend from its pyproject.toml). A fault in its model fails the gate; bad input is one
line and exit 2.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import harness
from harness import cases
from harness.cli.commands import main
from tests.conftest import without_progress

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "own_system"
PACKAGE = "mjharness_cartpole"
CASE = "cartpole"


@pytest.fixture
def example(tmp_path: Path) -> Path:
    """A copy of the example, outside the repository; its systems directory is ``own_system/mjharness_cartpole``."""
    shutil.copytree(EXAMPLE, tmp_path / "own_system", ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    return tmp_path / "own_system"


@pytest.fixture
def restored():
    """In-process CLI calls set the directories in use for the process: none again after the test."""
    yield
    from harness.cases import sources

    sources.use(())


def _cli(*args: str, cwd: Path, path: tuple[Path, ...] = ()) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(str(p) for p in (ROOT, *path)))
    return subprocess.run([sys.executable, "-m", "harness.cli", *args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=300)


def _passed(out: subprocess.CompletedProcess) -> None:
    assert out.returncode == 0, (out.stdout, out.stderr)
    verdict = out.stdout.strip().splitlines()[-1]
    assert verdict.startswith("PASS") and " 0 checks" not in verdict, verdict


def _installed(example: Path, site: Path) -> None:
    """The example installed into ``site`` as a wheel would put it: its package, and the metadata its build
    backend (setuptools) writes from its pyproject.toml, entry points included (offline: no wheel built)."""
    site.mkdir()
    subprocess.run([sys.executable, "-W", "ignore", "-c", "import setuptools; setuptools.setup()", "-q",
                    "egg_info", "--egg-base", str(site)], cwd=example, check=True, capture_output=True)
    shutil.copytree(example / PACKAGE, site / PACKAGE)


# ------------------------------------------------------------------ the CLI
@pytest.mark.slow  # a whole check or pytest run from outside the repository; the gate's both directions stay fast
def test_list_and_check_find_a_users_system_in_its_directory(example):
    listed = _cli("list", "--systems", "own_system/mjharness_cartpole", cwd=example.parent)
    assert listed.returncode == 0 and CASE in listed.stdout.split(), listed
    assert CASE not in _cli("list", cwd=example.parent).stdout.split()  # not without --systems
    _passed(_cli("check", "--systems", "own_system/mjharness_cartpole", "--case", CASE, "-j", "1",
                 cwd=example.parent))


def test_a_fault_in_a_users_model_fails_the_gate(example):
    """A damper the system does not have fails; a heavier bob is another cart-pole, whose reference is read
    from the model, and passes."""
    model = example / PACKAGE / f"{CASE}.xml"
    text = model.read_text()
    hinge, bob = 'axis="0 -1 0" damping="0"', 'mass="0.5"'
    assert text.count(hinge) == 1 and text.count(bob) == 1
    model.write_text(text.replace(hinge, 'axis="0 -1 0" damping="0.002"'))
    damped = _cli("check", "--systems", str(example / PACKAGE), "--case", CASE, "-j", "1", "-q", cwd=example)
    assert damped.returncode == 1 and damped.stdout.strip().splitlines()[-1].startswith("FAIL"), damped
    assert "RK4.position" in damped.stdout
    model.write_text(text.replace(bob, 'mass="0.6"'))
    _passed(_cli("check", "--systems", str(example / PACKAGE), "--case", CASE, "-j", "1", "-q", cwd=example))


@pytest.mark.slow  # a whole check or pytest run from outside the repository; the gate's both directions stay fast
def test_an_installed_package_is_found_through_its_entry_point(example, tmp_path):
    site = tmp_path / "site"
    _installed(example, site)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    listed = _cli("list", cwd=elsewhere, path=(site,))
    assert listed.returncode == 0 and CASE in listed.stdout.split(), listed
    _passed(_cli("check", "--case", CASE, "-j", "1", cwd=elsewhere, path=(site,)))
    # the same directory given as --systems too is one source, not a collision with itself
    twice = _cli("list", "--systems", str(site / PACKAGE), cwd=elsewhere, path=(site,))
    assert twice.returncode == 0 and twice.stdout.split().count(CASE) == 1, twice


# ------------------------------------------------------------ the API, pytest
def test_the_api_validates_a_users_system_for_that_call(example):
    result = harness.validate(CASE, systems=[example / PACKAGE], integrators=["RK4"])
    assert result.passed and result.check("RK4.position").passed, result.summary()
    assert result.mjcf == str((example / PACKAGE / f"{CASE}.xml").resolve())
    assert CASE in harness.case_names(systems=[str(example / PACKAGE)])
    assert CASE not in cases.names()  # for that call only
    with pytest.raises(ValueError, match="unknown case 'cartpole'"):
        harness.validate(CASE, integrators=["RK4"])
    with pytest.raises(TypeError, match="systems must be a list of directories"):
        harness.validate(CASE, systems=str(example / PACKAGE))


def test_a_users_case_without_a_limits_file_is_judged_by_the_default_rule(example):
    """Never by nothing: the figures ``mjharness limits --write`` would gate."""
    (example / PACKAGE / f"{CASE}.limits.toml").unlink()
    result = harness.validate(CASE, systems=[example / PACKAGE], integrators=["RK4"])
    judged = {str(c.name) for c in result.checks}
    assert {"instant.qacc", "RK4.position", "RK4.drift.energy"} <= judged and result.passed, judged


@pytest.mark.slow  # a whole check or pytest run from outside the repository; the gate's both directions stay fast
def test_the_pytest_fixture_finds_systems_from_its_ini_option_and_the_test_file(example):
    """A user's own suite: the ini option's directory (relative to the ini file), and ``systems=`` relative to
    the test file."""
    suite = example.parent
    (suite / "pytest.ini").write_text("[pytest]\nmjharness_systems = own_system/mjharness_cartpole\n")
    (suite / "tests").mkdir()
    (suite / "tests" / "test_mine.py").write_text(
        "def test_from_ini(mjharness):\n"
        "    mjharness.assert_valid('cartpole', integrators=['RK4'])\n\n"
        "def test_relative_to_this_file(mjharness):\n"
        "    mjharness.assert_valid('cartpole', systems=['../own_system/mjharness_cartpole'], "
        "integrators=['Euler'])\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    env.pop("MJHARNESS_SYSTEMS", None)
    out = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "tests"], cwd=suite,
                         env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0 and "2 passed" in out.stdout, (out.stdout, out.stderr)


def test_the_fixture_reads_the_systems_variable_relative_to_the_working_directory(pytestconfig, monkeypatch,
                                                                                   tmp_path):
    from harness.pytest_plugin import configured_systems

    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MJHARNESS_SYSTEMS", os.pathsep.join(["a", str(tmp_path / "b")]))
    assert configured_systems(pytestconfig)[-2:] == (tmp_path / "a", tmp_path / "b")


# ---------------------------------------------------------------- bad input
def _exit_code(argv: list[str]) -> int:
    """``mjharness ARGV`` in this process: its exit code, argparse's own (a bad option's value) included."""
    try:
        return main(argv)
    except SystemExit as stop:
        return int(stop.code)


def _one_line(capsys, *needles: str) -> None:
    err = without_progress(capsys.readouterr().err)
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    for needle in needles:
        assert needle in err, err


def _broken_import(directory: Path) -> Path:
    with (directory / f"{CASE}.py").open("a") as f:
        f.write("\nimport no_such_module_of_yours\n")
    return directory


def _renamed(directory: Path, name: str) -> Path:
    for path in list(directory.iterdir()):
        if path.name.startswith(f"{CASE}."):
            path.rename(directory / path.name.replace(CASE, name, 1))
    return directory


@pytest.mark.parametrize("make, needles", [
    (lambda d: d / "nowhere", ("no such directory", "accepted: a directory holding NAME.py")),
    (lambda d: d / "pyproject.toml", ("is not a directory", "accepted:")),
    (lambda d: d, ("holds no model (NAME.xml)", "accepted:")),
    (lambda d: _broken_import(d / PACKAGE), (f"cannot import {{dir}}/{CASE}.py",
                                            "ModuleNotFoundError: No module named 'no_such_module_of_yours'")),
    (lambda d: _renamed(d / PACKAGE, "pendulum"), ("the name 'pendulum'",
                                                   "already the shipped case mjcf/pendulum.xml")),
], ids=["missing", "not-a-directory", "no-model", "import-fails", "shipped-name"])
def test_a_bad_systems_directory_is_one_line_and_exit_2_with_nothing_written(example, capsys, restored, make,
                                                                             needles):
    directory = make(example)
    junit = example / "junit.xml"
    code = _exit_code(["check", "--systems", str(directory), "--case", CASE, "--junit", str(junit)])
    assert code == 2 and not junit.exists()
    _one_line(capsys, *(n.replace("{dir}", str(directory.resolve())) for n in needles))


def test_a_name_two_directories_define_names_both(example, tmp_path, capsys, restored):
    other = tmp_path / "other"
    shutil.copytree(example / PACKAGE, other)
    assert _exit_code(["list", "--systems", str(example / PACKAGE), "--systems", str(other)]) == 2
    _one_line(capsys, "the name 'cartpole'", str(other.resolve()), str((example / PACKAGE).resolve()))


def test_an_entry_point_that_cannot_be_loaded_is_one_line_and_exit_2(tmp_path):
    site = tmp_path / "site"
    (site / "broken_systems-0.1.egg-info").mkdir(parents=True)
    (site / "broken_systems-0.1.egg-info" / "PKG-INFO").write_text("Metadata-Version: 2.1\nName: broken-systems\n"
                                                                   "Version: 0.1\n")
    (site / "broken_systems-0.1.egg-info" / "entry_points.txt").write_text(
        "[mjharness.systems]\nbroken = no_such_package_of_yours\n")
    out = _cli("list", cwd=tmp_path, path=(site,))
    assert out.returncode == 2 and out.stdout == "", out
    assert "Traceback" not in out.stderr and len(out.stderr.strip().splitlines()) == 1, out.stderr
    assert "entry point broken = no_such_package_of_yours (mjharness.systems, package broken-systems) cannot be " \
           "loaded: ModuleNotFoundError" in out.stderr, out.stderr

"""The pytest plugin ``mjharness`` (entry point ``pytest11``): validate your own model inside your tests.

Installed with the package, it gives every test suite a fixture ``mjharness``::

    def test_my_robot(mjharness):                     # any model, against its own kinematic tree
        mjharness.assert_valid(mjcf="models/my_robot.xml")

    def test_my_pendulum(mjharness):                  # a variant of a shipped case, against its reference
        result = mjharness.assert_valid("pendulum", mjcf="models/my_pendulum.xml")
        assert result.figure("RK4.position").value < 1e-6     # your own requirement, on top

Your own systems (:mod:`harness.cases.sources`: ``NAME.py``, ``NAME.xml``,
``NAME.limits.toml`` in a directory) are found from the ini option
``mjharness_systems`` (directories, relative to the ini file), the variable
``MJHARNESS_SYSTEMS`` (directories separated by ``os.pathsep``, relative to the
working directory) and a test's own ``systems=[...]`` (relative to the test
file); installed packages' through their entry points, as everywhere::

    def test_my_cartpole(mjharness):
        mjharness.assert_valid("cartpole", systems=["systems"])

``mjharness.validate(...)`` returns the :class:`harness.api.Validation` without
judging it; ``mjharness.assert_valid(...)`` fails the test with a short list:
the verdict line, then one line per failed check (case, check, measured,
unexplained vs limit and how far over, or why it could not be measured). Both
take :func:`harness.api.validate`'s options; a relative ``mjcf=`` or
``config=`` path is found next to the test file that uses the fixture, not in
pytest's working directory, and a case name is checked first (an unknown one
suggests the closest). The header of the test session names the mjharness and
MuJoCo versions.

The plugin loads in every pytest session of an environment where mjharness
is installed, so it imports nothing of the harness until a test asks for the
fixture.
"""

from __future__ import annotations

import os
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

if TYPE_CHECKING:
    from harness.api import Validation

__all__ = ["Harness", "configured_systems", "mjharness", "pytest_addoption", "pytest_report_header"]

PATHS = {"mjcf": "MJCF", "config": "config"}  # the options naming a file, found relative to the test file
INI = "mjharness_systems"
VARIABLE = "MJHARNESS_SYSTEMS"


class Harness:
    """The ``mjharness`` fixture's value: :func:`harness.api.validate` for the test file ``test_file``."""

    def __init__(self, test_file: Path | None = None, systems: tuple[Path, ...] = ()) -> None:
        self.test_file = test_file
        self.systems = systems

    def __repr__(self) -> str:
        return f"<mjharness fixture of {self.test_file.name if self.test_file else 'no test file'}>"

    def path(self, option: str, given: object) -> object:
        """``given`` (a relative path) joined to the test file's folder; absolute, or no path, unchanged.
        ModelError (or ConfigError, both ValueErrors) in one line naming the path given and where it was looked
        for, if nothing is there."""
        __tracebackhide__ = True
        if self.test_file is None or not isinstance(given, str | os.PathLike):
            return given
        path = Path(given)
        if path.is_absolute():
            return given
        where = self.test_file.parent / path
        if not where.exists():
            from harness.core.errors import ConfigError, ModelError  # lazy: only for a missing file

            error = ModelError if option == "mjcf" else ConfigError
            raise error(f"cannot read {PATHS[option]} {str(given)!r}: no such file; looked for it at {where} "
                        f"(relative to the test file {self.test_file.name}, not the working directory)")
        return where

    def validate(self, case: str | None = None, **options: Any) -> Validation:
        """:func:`harness.api.validate`, unjudged (no case: ``mjcf=`` judged against its own tree)."""
        __tracebackhide__ = True  # pytest: a failure shows at the test's own line
        from harness import cases  # lazy: MuJoCo and the harness load only when a test uses them
        from harness.api import validate  # lazy: as above
        from harness.cases import sources  # lazy: as above

        for option in PATHS.keys() & options.keys():
            options[option] = self.path(option, options[option])
        given = options.pop("systems", None)
        if isinstance(given, str | os.PathLike):
            raise TypeError(f"systems must be a list of directories, e.g. ['my_systems'], got {given!r}")
        systems = [*self.systems, *(self.directory(d) for d in (given or ()))]
        if isinstance(case, str):
            with sources.using(systems):
                try:
                    cases.get(case)
                except ValueError as err:  # an unknown case: the one line (with the closest name), no traceback
                    raise ValueError(str(err)) from None
        return validate(case, systems=systems, **options)

    def directory(self, given: str | os.PathLike) -> str | os.PathLike:
        """A ``systems=`` directory: relative to the test file's folder (absolute: as given)."""
        path = Path(given)
        return given if self.test_file is None or path.is_absolute() else self.test_file.parent / path

    def assert_valid(self, case: str | None = None, **options: Any) -> Validation:
        """:func:`harness.api.validate`, failing the test (:class:`~harness.api.ValidationFailed`, an
        AssertionError) with the verdict line and one line per failed check."""
        __tracebackhide__ = True
        result = self.validate(case, **options)
        result.raise_for_failures()
        return result


@pytest.fixture
def mjharness(request: pytest.FixtureRequest) -> Harness:
    """Validate cases, or your MJCF variants of them, against the analytic reference and the limits; a
    relative model path is found next to the test file."""
    return Harness(Path(request.path), systems=configured_systems(request.config))


def configured_systems(config: pytest.Config) -> tuple[Path, ...]:
    """The systems directories of the ini option (relative to the ini file) and of the variable (relative to
    the working directory), in that order."""
    from_ini = tuple(Path(p) for p in config.getini(INI))
    from_env = tuple(Path(p).absolute() for p in os.environ.get(VARIABLE, "").split(os.pathsep) if p.strip())
    return (*from_ini, *from_env)


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addini(INI, type="paths", default=[],
                  help="directories of your own mjharness systems (NAME.py, NAME.xml, NAME.limits.toml), for the "
                       "mjharness fixture; relative to the ini file")


def pytest_report_header(config: pytest.Config) -> str:
    def installed(name: str) -> str:
        try:
            return version(name)
        except PackageNotFoundError:
            return "not installed"

    return f"mjharness {installed('mjharness')}, MuJoCo {installed('mujoco')}"

"""The pytest plugin ``mjharness`` (entry point ``pytest11``): validate your own model inside your tests.

Installed with the package, it gives every test suite a session fixture
``mjharness``::

    def test_my_robot(mjharness):                     # any model, against its own kinematic tree
        mjharness.assert_valid(mjcf="models/my_robot.xml")

    def test_my_pendulum(mjharness):                  # a variant of a shipped case, against its reference
        result = mjharness.assert_valid("pendulum", mjcf="models/my_pendulum.xml")
        assert result.figure("RK4.position").value < 1e-6     # your own requirement, on top

``mjharness.validate(...)`` returns the :class:`harness.api.Validation` without
judging it; ``mjharness.assert_valid(...)`` fails the test with every failed
check listed. Both take :func:`harness.api.validate`'s options. The header of
the test session names the mjharness and MuJoCo versions.

The plugin loads in every pytest session of an environment where mjharness
is installed, so it imports nothing of the harness until a test asks for the
fixture.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version
from typing import TYPE_CHECKING, Any

import pytest

if TYPE_CHECKING:
    from harness.api import Validation


class Harness:
    """The ``mjharness`` fixture's value."""

    def validate(self, case: str | None = None, **options: Any) -> Validation:
        """:func:`harness.api.validate`, unjudged (no case: ``mjcf=`` judged against its own tree)."""
        from harness.api import validate  # lazy: MuJoCo and the harness load only when a test uses them

        return validate(case, **options)

    def assert_valid(self, case: str | None = None, **options: Any) -> Validation:
        """:func:`harness.api.validate`, failing the test (AssertionError) with each failed check listed."""
        result = self.validate(case, **options)
        result.raise_for_failures()
        return result


@pytest.fixture(scope="session")
def mjharness() -> Harness:
    """Validate cases, or your MJCF variants of them, against the analytic reference and the limits."""
    return Harness()


def pytest_report_header(config: pytest.Config) -> str:
    def installed(name: str) -> str:
        try:
            return version(name)
        except PackageNotFoundError:
            return "not installed"

    return f"mjharness {installed('mjharness')}, MuJoCo {installed('mujoco')}"

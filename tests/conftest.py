"""Shared fixtures: one run per case (and per breakage) for the whole session."""

from __future__ import annotations

import functools
import re

import pytest

from harness import cases
from harness.core.checks import Check
from harness.core.options import RunOptions
from harness.engine.compat import joint_types, known_defect, unavailable_reason
from harness.engine.models import compile_model
from harness.opinions import pinocchio as peer
from harness.opinions import threeway
from harness.pipeline.limits import load_limits
from harness.pipeline.run import CaseResult, run_case
from harness.pipeline.verdict import judge

pytest_plugins = ["pytester"]

PEER_CHECKS = len(threeway.QUANTITIES) if peer.available() else 0
"""The checks the second opinions add to each case run on the C engine (``instant.peer.*``, judged beside the
case's limits file): none where Pinocchio is not installed."""


@functools.cache
def shipped_run(name: str) -> CaseResult:
    """run_case at the shipped settings, computed once per session."""
    return run_case(cases.get(name))


@pytest.fixture(scope="session")
def config():
    """Every case's shipped limits."""
    return load_limits()


def judged(result: CaseResult) -> dict[str, Check]:
    """Every gated figure's check, by name (the gates of integrators the run left out are not judged; those
    of a diverged or unmeasurable run are failures)."""
    return {c.name: c for c in judge(result, load_limits().for_case(result.case.name))}


def failing(result: CaseResult) -> set[str]:
    """Gated figures that fail."""
    return {name for name, check in judged(result).items() if not check.passed}


def breakable(case: str, names) -> set[str]:
    """The check names of ``case`` this MuJoCo can fail: without those of integrators it lacks (n/a)
    and those a documented defect of this version already fails on the case's model (known defects).
    For tests that expect a broken variant to fail a set of gates."""
    joints = joint_types(compile_model(cases.get(case).mjcf))
    return {n for n in names if not unavailable_reason(n) and not known_defect(joints, n)}


# --- the budget's two directions, for the per-system tables of faults and legitimate settings -------------

def assert_trips(case: cases.Case, run: dict, gates: set[str], label: str) -> None:
    """A fault (``run``: :class:`~harness.core.options.RunOptions`' fields) fails every gate of ``gates`` this
    MuJoCo can fail (:func:`breakable`: not those of an integrator it lacks or of a documented defect of it)."""
    must_fail = breakable(case.name, gates)
    failed = failing(run_case(case, RunOptions(**run)))
    assert must_fail <= failed, f"{label}: did not fail {sorted(must_fail - failed)}"


def assert_passes(case: cases.Case, run: dict, label: str) -> None:
    """A legitimate setting (``run``: :class:`~harness.core.options.RunOptions`' fields) fails no gate, but those
    a documented defect of this MuJoCo fails on the case's model whatever the setting."""
    failed = failing(run_case(case, RunOptions(**run)))
    assert breakable(case.name, failed) == set(), f"{label}: failed {sorted(failed)}"


def assert_faults_cover(case: str, faults: dict, generic: tuple[str, ...] = ("converge", "reference")) -> None:
    """The gates of ``case``'s limits are covered by the faults (label -> (run, gates)), but for the
    families ``generic`` (converge.*: the generic faults of tests/test_gates.py and tests/test_convergence.py;
    reference.*: a broken reference, also there)."""
    covered = set().union(*(gates for _, gates in faults.values()))
    gated = {k for k in load_limits().for_case(case) if k.split(".")[0] not in generic}
    assert gated <= covered, sorted(gated - covered)


# the line run and check print as each case finishes (harness/outputs/table.py case_line): on stdout, or with
# --quiet or --json on stderr where it is not a terminal; and the heartbeat of a long phase (harness/core/progress.py)
PROGRESS_LINE = re.compile(r"case [^:]+: +\d+ checks, +\d+ fail, [^()]+ \(\d+\.\d s\)"
                           r"|mjharness: .+, \d+(\.\d)? (s|min) so far|mjharness: .+: \d+(\.\d)? (s|min) so far")


def without_progress(err: str) -> str:
    """``err`` without the per-case progress lines, each of which must be one exactly (bytes or str alike)."""
    lines = err.splitlines(keepends=True)
    kept = [line for line in lines if not PROGRESS_LINE.fullmatch(line.rstrip("\n"))]
    return "".join(kept)


def pivot_frame_pendulum(path):
    """The shipped pendulum written with its bob's body frame at the pivot (hinge, rod and sensors' sites at its
    origin, the point mass 1 m below): the same system written differently, at ``path``."""
    text = cases.get("pendulum").mjcf.read_text()
    for old, new in [('<body name="bob" pos="0 0 -1">', '<body name="bob" pos="0 0 0">'),
                     ('type="hinge" pos="0 0 1"', 'type="hinge" pos="0 0 0"'),
                     ('<inertial pos="0 0 0" mass="1"', '<inertial pos="0 0 -1" mass="1"'),
                     ('<geom name="bob" type="sphere" size="0.05"', '<geom name="bob" type="sphere" pos="0 0 -1" '
                                                                    'size="0.05"'),
                     ('<site name="rod_end" pos="0 0 1"', '<site name="rod_end" pos="0 0 0"'),
                     ('fromto="0 0 0 0 0 1"', 'fromto="0 0 -1 0 0 0"')]:
        assert old in text
        text = text.replace(old, new)
    path.write_text(text)
    return path


def case_ids() -> list[str]:
    return list(cases.names())


@pytest.fixture
def cached_runs(monkeypatch):
    """A shipped case run as shipped returns the session's cached run (variants still run for real)."""
    use_cached_runs(monkeypatch)


def use_cached_runs(monkeypatch) -> None:
    """:func:`cached_runs` with ``monkeypatch`` (a fixture of a wider scope uses ``pytest.MonkeyPatch.context()``)."""
    from harness.pipeline import matrix

    real = matrix.run_case

    def run(case, options=None):
        return shipped_run(case.name) if options is None or options.shipped else real(case, options)

    monkeypatch.setattr(matrix, "run_case", run)



# ----------------------------------------------------------------- the fast suite
# `pytest` runs the fast suite (pyproject: -m 'not slow'); `pytest -m slow` the rest, which CI runs too. Beside the
# tests marked slow where they are written, these are marked here (seconds each on this project's 2-core machine at
# 82fbb63 under load, about twice a quiet machine's). Each repeats, at more cost, what a fast test exercises.
SLOW_TESTS: dict[str, str] = {
    "tests/test_cli.py::test_run_writes_complete_deterministic_report":
        "60 s: `run` twice with the studies; `run` itself is exercised by test_run_user_variant_against_the_case",
    "tests/test_blocks.py::test_the_instant_layer_compares_a_block_per_row_and_as_a_generalized_force":
        "42 s: a derived test system; the shipped connect and weld blocks go through the instant layer in test_cases",
    "tests/test_speed_paths.py::test_a_check_with_its_derivations_cached_never_imports_sympy":
        "24 s: derives two systems; test_prebuilt's fresh install shows a check without sympy",
    "tests/test_symmetric_top.py::test_lagrangian_is_lagranges_top":
        "15 s of sympy; layer 1 (derivations) stays in the fast suite through the other systems",
    "tests/test_symmetric_top.py::test_theta_equation_at_rest_in_theta_is_the_steady_precession_quadratic":
        "13 s of sympy, as above",
    "tests/test_double_pendulum.py::test_equations_are_the_textbook_ones_in_absolute_angles": "11 s of sympy, as above",
    "tests/test_rigid.py::test_world_angular_velocity_is_the_rotated_body_one": "10 s of sympy, as above",
    "tests/test_bad_input.py::test_every_figure_a_shipped_case_measures_is_among_its_names":
        "10 s from a fresh clone: runs every shipped case; test_families checks the same on four cases",
    "tests/test_versions.py::test_versions_builds_the_harness_from_a_regular_install":
        "7 s: pip installs the harness into a venv and uv builds a wheel of it; versions' own logic is tested fast "
        "with a fake uv",
}
# The budget's two directions (a legitimate change passes every gate, a fault trips its gates): the fast suite keeps
# the first of each per system's module, the others are slow (tests/test_budget_matrix.py chooses its own share).
BOTH_DIRECTIONS = ("test_a_legitimate_", "test_a_fault", "test_a_contact_fault", "test_a_wrong_")
OWN_SHARE = ("tests/test_budget_matrix.py",)


def pytest_collection_modifyitems(config, items):
    seen: set[tuple[str, str]] = set()
    for item in items:
        function = item.nodeid.split("::")[-1].split("[")[0]
        if item.nodeid.split("[")[0] in SLOW_TESTS:
            item.add_marker(pytest.mark.slow)
        elif (function.startswith(BOTH_DIRECTIONS) and "[" in item.nodeid and item.get_closest_marker("slow") is None
              and not item.nodeid.startswith(OWN_SHARE)):
            group = (item.nodeid.split("::")[0], function)
            if group in seen:
                item.add_marker(pytest.mark.slow)
            seen.add(group)


@pytest.fixture(scope="session")
def ray_address():
    """A Ray cluster on loopback (2 CPUs) for the session, stopped after it, with this process set to join it
    (tests/raycluster.py); skipped where Ray is not installed."""
    pytest.importorskip("ray")
    from tests.raycluster import AUTH, loopback_cluster

    with pytest.MonkeyPatch.context() as mp, loopback_cluster() as address:
        for name, value in AUTH.items():
            mp.setenv(name, value)
        yield address

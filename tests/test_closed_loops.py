"""Closed loops, redundant constraints and stiff robots judged, never refused (issue 43): the IFToMM A02 N-four-bar
(examples/four_bar_a02.xml) both ways — a fault on MuJoCo's side alone fails, another timestep passes — and the
real robots of ../shared/models/menagerie get a verdict (exit 0 or 1), not exit 2 or 4."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import harness
from harness.cases.own import from_mjcf
from harness.engine.compat import set_damping

ROOT = Path(__file__).resolve().parents[1]
FOUR_BAR = ROOT / "examples" / "four_bar_a02.xml"
MENAGERIE = ROOT.parent / "shared" / "models" / "menagerie"
BEFORE_SINGULAR = 0.4  # s: the cranks reach the horizontal at about 0.71 s (tests/test_kkt.py)


def _failed(v) -> set[str]:
    return {c.name for c in v.checks if not c.passed and not c.known}


def _damped(joint: str, extra: float):
    def edit(spec):
        for j in spec.joints:
            if j.name == joint:
                set_damping(j, float(np.atleast_1d(j.damping)[0]) + extra)
    return edit


@pytest.mark.slow
def test_the_four_bar_passes_and_its_redundant_multipliers_are_na():
    """Before its singular pose the four-bar passes; the out-of-plane rows make its per-connect force figures n/a
    (not unique), and the total generalized constraint force is compared and passes."""
    v = harness.validate(from_mjcf(FOUR_BAR, keyframe="start", horizon=BEFORE_SINGULAR), integrators=["RK4"])
    assert not _failed(v), [(c.name, c.value, c.threshold) for c in v.checks if not c.passed]
    by_name = {c.name: c for c in v.checks}
    assert by_name["instant.generalized_force"].passed
    for name in ("instant.force.loop0", "RK4.force.loop1"):
        assert by_name[name].status == "n/a" and "not unique" in by_name[name].reason


@pytest.mark.slow
def test_damping_added_to_mujocos_four_bar_alone_fails():
    case = from_mjcf(FOUR_BAR, keyframe="start", horizon=BEFORE_SINGULAR, reference=FOUR_BAR)
    failed = _failed(harness.validate(case, integrators=["RK4"], edit=_damped("A1", 0.05)))
    assert "RK4.position" in failed and {"instant.forcing", "instant.qacc"} & failed


@pytest.mark.slow
def test_the_four_bar_at_another_timestep_passes():
    v = harness.validate(from_mjcf(FOUR_BAR, keyframe="start", horizon=BEFORE_SINGULAR), integrators=["RK4"],
                         timestep=0.0005)
    assert not _failed(v), [(c.name, c.value, c.threshold) for c in v.checks if not c.passed]


@pytest.mark.slow
def test_the_four_bar_through_its_singular_pose_gets_a_verdict():
    """Through the collinear pose (its own chaos horizon): a verdict with figures, whatever it is; the reference
    is solved through the pose (tests/test_kkt.py)."""
    v = harness.validate(from_mjcf(FOUR_BAR, keyframe="start"), integrators=["RK4"])
    assert v.checks and all(np.isfinite(c.value) or c.status == "n/a" for c in v.checks)


ROBOTS = ["robotiq_2f85/scene.xml", "kuka_iiwa_14/scene.xml", "wonik_allegro/scene_right.xml",
          "agility_cassie/scene.xml"]
"""Cassie's horizon is cut to what 1500 steps of its reference cover (its lightly damped 60 Hz spring modes cost
thousands of Radau steps a second: harness.cases.own.HORIZON_STEPS)."""

LOOPS = {"robotiq_2f85/2f85.xml": (0.2, "right_coupler"), "agility_cassie/cassie.xml": (0.1, "left-achilles-rod")}
"""Closed loops of light links at MuJoCo's default solimp, each with a horizon and a link of its loop."""


def _robot(name: str) -> Path:
    path = MENAGERIE / name
    if not path.exists():
        pytest.skip(f"{MENAGERIE} is absent (the shared Menagerie robots)")
    return path


def _heavier(body: str, factor: float):
    def edit(spec):
        for b in spec.bodies:
            if b.name == body:
                b.mass, b.inertia = b.mass * factor, [x * factor for x in b.inertia]
    return edit


@pytest.mark.slow
@pytest.mark.parametrize("robot", LOOPS)
def test_a_closed_loop_at_mujocos_default_softness_passes(robot):
    """Robotiq's linkage and Cassie's achilles loops at their shipped solimp (0.9, 0.95): their connects' softness
    is measured down to the near-rigid levels (harness.engine.variants.rigid_factor), where the levels ε, ε/2, ε/4
    failed them by 1.2-13× (the extrapolation, not MuJoCo: at the stiffest ε both pass; docs/findings/softness.md)."""
    horizon, _ = LOOPS[robot]
    v = harness.validate(from_mjcf(_robot(robot), horizon=horizon), integrators=["RK4"])
    assert not _failed(v), [(c.name, c.value, c.threshold) for c in v.checks if not c.passed]
    assert any(c.name.startswith("RK4.violation.") and c.passed for c in v.checks)


@pytest.mark.slow
@pytest.mark.parametrize("robot", LOOPS)
def test_a_link_of_the_loop_one_percent_heavier_on_mujocos_side_alone_fails(robot):
    horizon, body = LOOPS[robot]
    path = _robot(robot)
    failed = _failed(harness.validate(from_mjcf(path, horizon=horizon, reference=path), integrators=["RK4"],
                                      edit=_heavier(body, 1.01)))
    assert {"instant.mass_matrix", "instant.forcing"} <= failed, failed


@pytest.mark.slow
@pytest.mark.parametrize("robot", ROBOTS)
def test_a_real_robot_gets_a_verdict(robot):
    """Robotiq 2F-85 (a closed loop with redundant connect rows), KUKA iiwa 14 (stiff position servos), Allegro
    (damping on light finger links): exit 0 or 1 with figures."""
    path = MENAGERIE / robot
    if not path.exists():
        pytest.skip(f"{MENAGERIE} is absent (the shared Menagerie robots)")
    done = subprocess.run([sys.executable, "-m", "harness.cli", "check", "--mjcf", str(path)], capture_output=True,
                          text=True, timeout=900, cwd=ROOT)
    assert done.returncode in (0, 1), done.stderr[-2000:]
    assert "checks" in done.stdout


def test_cassies_light_rods_are_no_longer_refused():
    """Cassie's achilles rods spin about their axis with 3.8e-6 kg m² against 34 (1.1e-7 of it): above SPIN_FLOOR
    (ε / STIFF_RTOL = 2.2e-8), so the model is read, no longer refused ("turns a body with next to no rotational
    inertia"); a point mass on a ball joint (1e-12) still is (tests/test_own_model.py)."""
    from harness.cases.own import SPIN_FLOOR

    path = MENAGERIE / "agility_cassie" / "scene.xml"
    if not path.exists():
        pytest.skip(f"{MENAGERIE} is absent (the shared Menagerie robots)")
    assert SPIN_FLOOR < 3.8e-6 / 34.4
    case = from_mjcf(path, horizon=0.01)
    assert case.tree is not None and len(case.qd0) == 32


CASSIE = "agility_cassie/cassie.xml"


@pytest.mark.slow
@pytest.mark.skipif("discrete" not in __import__("harness.engine.integrators", fromlist=["x"]).available_integrators(),
                    reason="no discrete integrator in this MuJoCo")
def test_cassie_under_discrete_passes_its_trajectory_figures_and_a_heavier_rod_still_fails():
    """Under ``discrete`` Cassie's near-rigid softness levels are outside the asymptotic range at h, h/2 and h/4
    (their runs' differences shrink 1.1-1.5x per halving): their correction is taken from deeper runs
    (harness.families.runs.rigid_resolved) and the trajectory figures that failed by 2.4-12.9x pass
    (docs/findings/softness.md, "discrete"). The discrete order shortfall is left open (said there). A link of the
    loop 1 % heavier on MuJoCo's side alone still fails."""
    horizon, body = LOOPS[CASSIE]
    path = _robot(CASSIE)
    v = harness.validate(from_mjcf(path, horizon=horizon), integrators=["discrete"])
    trajectory = [(c.name, c.value, c.threshold) for c in v.checks if c.name.startswith("discrete.") and not c.passed
                  and c.status != "n/a"]
    assert not trajectory, trajectory
    assert any("near-rigid levels" in note for c in v.checks if c.name == "discrete.position"
               for note in (c.budget.notes if c.budget else ()))
    failed = _failed(harness.validate(from_mjcf(path, horizon=horizon, reference=path), integrators=["discrete"],
                                      edit=_heavier(body, 1.01)))
    assert {"instant.mass_matrix", "instant.forcing"} <= failed, failed

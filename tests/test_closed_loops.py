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
from harness.engine.compat import full_mass_matrix, set_damping

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


@pytest.mark.slow
def test_the_iiwas_reference_is_tightened_to_what_its_budgets_resolve():
    """KUKA iiwa 14 settles onto its servos' targets, so MuJoCo's end positions match the reference far below the
    stiff reference's first tolerance: at STIFF_RTOL 1e-8 its part is ~99 % of discrete.position_final's limit.
    The check solves it again at the derived rtol (harness.budget.reference.reference_rtol), says so, and then no
    figure's limit is more than REFERENCE_SHARE the reference's."""
    from harness.budget.reference import REFERENCE_SHARE
    from harness.core.options import RunOptions
    from harness.pipeline.run import run_case

    result = run_case(from_mjcf(_robot("kuka_iiwa_14/iiwa14.xml")), RunOptions())
    said = result.settings.tree["reference tolerance"]
    assert ", derived: at rtol 1e-08" in said, said
    shares = [b.tolerance["reference"] / b.limit for b in result.budgets.values() if b.tolerance.get("reference")]
    assert shares and max(shares) <= REFERENCE_SHARE, max(shares)


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


def _four_bar_near_singular(theta_deg: float, eps: float):
    """A planar four-bar (crank 0.1 m, 1 kg; a light coupler 0.3 m, 0.05 kg; a rocker to ground 0.35 m away), at rest,
    its crank at ``theta_deg`` and coupler bent back by as much (the rocker closing it wherever that puts the coupler's
    end), closed by a connect at solimp d = 1 − ``eps``: near theta = 0 every link is nearly collinear, A02's singular
    pose, and A = J M⁻¹ Jᵀ has an in-plane eigenvalue near 0 (its out-of-plane one is 0: the rows are redundant)."""
    a, b, d, th = 0.1, 0.3, 0.35, np.radians(theta_deg)
    tip = a * np.array([np.cos(th), np.sin(th)]) + b * np.array([1.0, 0.0])
    c, psi = np.linalg.norm(tip - [d, 0.0]), np.degrees(np.arctan2(tip[1], tip[0] - d))
    xml = f"""<mujoco><option gravity="0 -9.81 0"><flag contact="disable"/></option>
      <default><joint type="hinge" axis="0 0 1"/><geom type="capsule" size="0.005"/></default>
      <worldbody>
        <body name="crank" euler="0 0 {theta_deg}"><joint/>
          <inertial pos="{a / 2} 0 0" mass="1" diaginertia="1e-4 {a * a / 12} {a * a / 12}"/>
          <body name="coupler" pos="{a} 0 0" euler="0 0 {-theta_deg}"><joint/>
            <inertial pos="{b / 2} 0 0" mass="0.05" diaginertia="1e-6 {0.05 * b * b / 12} {0.05 * b * b / 12}"/>
          </body></body>
        <body name="rocker" pos="{d} 0 0" euler="0 0 {psi}"><joint/>
          <inertial pos="{c / 2} 0 0" mass="0.5" diaginertia="1e-5 {0.5 * c * c / 12} {0.5 * c * c / 12}"/></body>
      </worldbody>
      <equality><connect body1="coupler" body2="rocker" anchor="{b} 0 0" solimp="{1 - eps} {1 - eps} 0.001 0.5 2"
                         solref="0.02 1"/></equality></mujoco>"""
    import mujoco

    model = mujoco.MjModel.from_xml_string(xml)
    model.opt.jacobian = mujoco.mjtJacobian.mjJAC_DENSE
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def _generalized_force_error(theta_deg: float, eps: float) -> float:
    """|MuJoCo's Jᵀλ − the rigid one| / |the rigid one| at the four-bar's rest pose. The rigid one is an independent
    check computed here from the KKT system of MuJoCo's own M and J at rest (J q̈ = 0; the pseudo-inverse, the rows
    being redundant; Jᵀλ is unique): this pins MuJoCo's softness law, it judges no dynamics."""

    model, data = _four_bar_near_singular(theta_deg, eps)
    mass = full_mass_matrix(model, data)
    jac = data.efc_J.reshape(data.nefc, model.nv)
    a = jac @ np.linalg.solve(mass, jac.T)
    rigid = -jac.T @ (np.linalg.pinv(a, rcond=1e-12) @ (jac @ np.linalg.solve(mass, data.qfrc_smooth)))
    return float(np.max(np.abs(data.qfrc_constraint - rigid)) / np.max(np.abs(rigid)))


def test_near_a_singular_pose_mujocos_soft_connect_force_saturates_below_its_stiffest_softness():
    """MuJoCo's force error −(A + R)⁻¹Rλ, R ∝ ε, is r/(a + r) along an eigenvalue a of A: linear in ε only while
    r ≪ a. Far from the singular pose the generalized constraint force's error halves with ε down to MuJoCo's
    stiffest (1e-4); 0.5° from it (a = 8.6e-5 of A's mean diagonal) it shrinks 1.2× from 4e-4 → 2e-4 → 1e-4, and
    at 1e-4 it is still 18 % of the force: no solimp MuJoCo accepts resolves it (Cassie's plantar loops, ε* ≈ 3e-4:
    docs/findings/softness.md, "generalized force"). The sampled budget's note says so (linearity_note)."""
    from harness.budget.extrapolation import linearity_note
    from harness.core.deviation import Deviation
    from harness.core.figures import FigureName

    for theta, shrinks in ((60.0, (1.95, 2.05)), (0.5, (1.1, 1.3))):
        errors = [_generalized_force_error(theta, eps) for eps in (4e-4, 2e-4, 1e-4)]
        shrink = (errors[0] - errors[1]) / (errors[1] - errors[2])
        assert shrinks[0] < shrink < shrinks[1], (theta, errors)
        dev = Deviation(FigureName("instant.generalized_force"), np.zeros(1), "scalar", "1", "")
        said = linearity_note(dev.magnitude, *(np.array([e]) for e in errors))
        assert bool(said) == (theta < 1.0), said
    assert _generalized_force_error(0.5, 1e-4) > 0.15  # at MuJoCo's stiffest ε
    assert _generalized_force_error(60.0, 1e-4) < 1e-3

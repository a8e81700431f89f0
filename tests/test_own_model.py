"""A model the user brings, judged against its own kinematic tree: the CLI, the API and the fixture with no case,
both directions of the verdict (faults made on the engine's side alone fail; legitimate settings pass), the
shipped double pendulum judged either way, and what is refused.

The models here are written for these tests (nobody's robot); dm_control's and Gymnasium's run in tests/test_zoo.py.
"""

from __future__ import annotations

import dataclasses
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import harness
from harness.cases import own
from harness.cases.own import from_mjcf
from harness.core.errors import ModelError
from harness.engine.compat import set_damping
from harness.engine.models import compile_model
from tests.conftest import pivot_frame_pendulum

ROOT = Path(__file__).resolve().parent.parent

# A three-link arm in 3D: capsules (full inertia from geoms), hinge axes not aligned, damping, armature, a position
# servo holding the elbow, a keyframe away from rest, and a floor it never reaches (contacts listed, switched off).
ARM = """
<mujoco model="arm">
  <option timestep="0.002"/>
  <default><joint damping="0.02" armature="0.001"/><geom type="capsule" size="0.04" density="800"/></default>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 .1" pos="0 0 -1"/>
    <body name="shoulder" pos="0 0 1">
      <joint name="yaw" axis="0 0 1"/>
      <geom fromto="0 0 0 0 0 0.1"/>
      <body name="upper" pos="0 0 0.1">
        <joint name="pitch" axis="0 1 0.1"/>
        <geom fromto="0 0 0 0.4 0 0"/>
        <body name="fore" pos="0.4 0 0">
          <joint name="elbow" axis="0.1 1 0" ref="0.2"/>
          <geom fromto="0 0 0 0.3 0 0"/>
          <site name="tip" pos="0.3 0 0"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator><position name="elbow_servo" joint="elbow" kp="2" kv="0.1"/></actuator>
  <keyframe><key name="reach" qpos="0.3 -0.5 0.6" qvel="0.5 0 -1"/></keyframe>
</mujoco>
"""

FREE_TOP = """
<mujoco model="tumbler">
  <option gravity="0 0 0"/>
  <worldbody>
    <body name="hull" pos="0 0 1" quat="0.9 0.2 0.3 0.1">
      <freejoint name="root"/>
      <geom type="box" size="0.2 0.1 0.05" density="500"/>
      <body name="flap" pos="0.2 0 0">
        <joint name="flap" type="ball" pos="0.02 0 0" damping="0.001"/>
        <geom type="capsule" fromto="0 0 0 0.15 0.05 0" size="0.02" density="500"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

# A whip: a 0.4 m link and a 1 g tip on a heavily damped hinge, its damping decaying at ~1e6/s (a time constant of
# ~1 µs, far below the 2 ms step MuJoCo takes with its damping implicit): a stiff motion, beyond DOP853's bound.
WHIP = """
<mujoco model="whip">
  <option timestep="0.002"/>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="shoulder" axis="0 1 0" damping="0.01"/>
      <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.03" density="800"/>
      <body name="tip" pos="0.4 0 0">
        <joint name="flick" axis="0 1 0" damping="0.5"/>
        <geom type="sphere" pos="0.02 0 0" size="0.008" mass="0.001"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.fixture(scope="module")
def whip(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("own") / "whip.xml"
    path.write_text(WHIP)
    return path


@pytest.fixture(scope="module")
def arm(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("own") / "arm.xml"
    path.write_text(ARM)
    return path


@pytest.fixture(scope="module")
def tumbler(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("own") / "tumbler.xml"
    path.write_text(FREE_TOP)
    return path


def _cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "harness.cli", *args], capture_output=True, text=True,
                          timeout=600, cwd=cwd)


def _failed(v) -> set[str]:
    """The failing checks, but for those that fail with a documented defect's signature of this MuJoCo (3.3's RK4 on
    ball and free joints): those are labelled as such, and are no verdict on the model."""
    return {c.name for c in v.checks if not c.passed and not c.known}


# ------------------------------------------------------------------ the entry
def test_check_judges_any_model_against_its_own_tree(arm, tmp_path):
    done = _cli("check", "--mjcf", str(arm), "--integrators", "RK4,implicitfast", cwd=tmp_path)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "PASS" in done.stdout and "arm" in done.stdout
    assert not list(tmp_path.iterdir())  # check writes nothing


def test_run_writes_a_report_that_says_what_was_examined(arm, tmp_path):
    out = tmp_path / "out"
    done = _cli("run", "--mjcf", str(arm), "--out", str(out), "--integrators", "RK4", "--no-studies", cwd=tmp_path)
    assert done.returncode == 0, done.stdout + done.stderr
    page = (out / "cases" / "arm.html").read_text()  # the model's own page, linked from the overview
    assert "href='cases/arm.html'" in (out / "report.html").read_text()
    assert "What was examined" in page and "<b>contacts</b>" in page and "RK4.<wbr>balance" in page
    assert "model image unavailable" not in page


def test_the_case_says_what_it_did_not_examine_and_how_it_chose_its_horizon(arm):
    case = from_mjcf(arm, keyframe="reach")
    notes = dict(case.tree.uncovered)
    assert "contacts" in notes  # the floor: listed, and switched off for the comparison
    assert "horizon" in case.tree.horizon_note and case.horizon <= 1.0
    assert case.qd0["yaw"] == 0.5 and case.q0["elbow"] == 0.6  # the keyframe's state, as given


def test_a_costly_reference_cuts_the_horizon_to_what_its_steps_cover_and_says_so(arm, monkeypatch):
    """The chaos horizon's reference takes at most own.HORIZON_STEPS solver steps (Cassie's costly rods): its span is
    cut to what they cover, rounded down, and the note says why; a fault still fails within the cut horizon."""
    full = from_mjcf(arm, keyframe="reach")
    monkeypatch.setattr(own, "HORIZON_STEPS", 25)
    cut = from_mjcf(arm, keyframe="reach")
    assert cut.horizon < full.horizon and "the reference's cost: 25 steps of its DOP853 solve cover" in \
        cut.tree.horizon_note, cut.tree.horizon_note
    reached = float(re.search(r"cover ([0-9.e-]+) s", cut.tree.horizon_note).group(1))
    assert 0.9 * reached <= cut.horizon <= reached  # two figures, rounded down
    v = harness.validate(dataclasses.replace(cut, tree=dataclasses.replace(cut.tree, source=str(arm))),
                         integrators=["RK4"], edit=_heavier("fore", 1.01))
    assert "RK4.position" in _failed(v)


def test_a_model_at_rest_is_set_moving_rather_than_judged_motionless(arm):
    case = from_mjcf(arm)
    assert any(abs(v) > 0.1 for v in case.qd0.values())
    assert "set moving" in case.description


# ------------------------------------------------------------------ both directions
def _heavier(body: str, factor: float):
    def edit(spec):
        for b in spec.bodies:
            if b.name == body:
                for g in b.geoms:
                    g.density *= factor
    return edit


def _damped(joint: str, extra: float):
    def edit(spec):
        for j in spec.joints:
            if j.name == joint:
                set_damping(j, float(np.atleast_1d(j.damping)[0]) + extra)
    return edit


def _tilted(joint: str, angle: float):
    def edit(spec):
        import numpy as np

        for j in spec.joints:
            if j.name == joint:
                axis = np.asarray(j.axis, dtype=float) / np.linalg.norm(j.axis)
                normal = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
                j.axis = np.cos(angle) * axis + np.sin(angle) * normal / np.linalg.norm(normal)
    return edit


@pytest.mark.parametrize(("fault", "edit"), [
    ("the forearm 1 % heavier", _heavier("fore", 1.01)),
    pytest.param("0.01 N m s more damping at the elbow", _damped("elbow", 0.01), marks=pytest.mark.slow),
    pytest.param("the pitch axis tilted by 1e-3 rad", _tilted("pitch", 1e-3), marks=pytest.mark.slow),
])
def test_a_fault_on_the_engines_side_alone_fails(arm, fault, edit):
    case = from_mjcf(arm, keyframe="reach", reference=arm)
    v = harness.validate(case, integrators=["RK4"], edit=edit)
    assert "RK4.position" in _failed(v), fault
    assert {"instant.mass_matrix", "instant.forcing", "instant.qacc"} & _failed(v), fault


def test_the_same_model_unfaulted_passes(arm):
    case = from_mjcf(arm, keyframe="reach", reference=arm)
    v = harness.validate(case, integrators=["RK4"])
    assert not _failed(v)


@pytest.mark.parametrize("setting", [
    pytest.param({"timestep": 0.001}, id="half the timestep"),
    pytest.param({"edit": lambda s: setattr(s.option, "solver", 1)}, id="CG solver", marks=pytest.mark.slow),
    pytest.param({"edit": lambda s: setattr(s.option, "integrator", 1)}, id="RK4 as its own integrator",
                 marks=pytest.mark.slow),
])
def test_legitimate_settings_pass(arm, setting):
    case = from_mjcf(arm, keyframe="reach")
    v = harness.validate(case, integrators=["RK4", "implicitfast"], **setting)
    assert not _failed(v), [(c.name, c.value, c.threshold) for c in v.checks if not c.passed]


@pytest.mark.slow
@pytest.mark.parametrize("variant", ["MuJoCo's default softness", "body frame at the pivot"])
def test_a_legitimate_rewrite_of_a_model_passes_with_no_case(tmp_path, variant):
    """Both directions case-free: the welded pendulum with its weld at MuJoCo's default solref and solimp (its order
    checks n/a, the error on the softness's floor, saying so) and the pendulum with its body frame moved to the pivot
    each pass against their own trees, as the shipped files do; the gate fails on a fault
    (test_a_fault_on_the_engines_side_alone_fails)."""
    if variant == "MuJoCo's default softness":
        text = (ROOT / "mjcf" / "welded_pendulum.xml").read_text()
        path = tmp_path / "welded_default.xml"
        path.write_text(text.replace(' solref="0.002 1"', "").replace(' solimp="0.9999 0.9999 0.001 0.5 2"', ""))
        assert compile_model(path).eq_solimp[0, 0] == pytest.approx(0.9)
    else:
        path = pivot_frame_pendulum(tmp_path / "pivot.xml")
    v = harness.validate(mjcf=path)
    assert not _failed(v), [(c.name, c.value, c.threshold) for c in v.checks if not c.passed]
    assert sum(c.passed for c in v.checks) >= 30


@pytest.mark.slow
def test_a_floating_body_with_a_ball_joint_passes_and_a_heavier_flap_fails(tumbler):
    """Without gravity the tumbler's linear and angular momentum are conserved, and checked: MuJoCo's own drift and
    against the reference. A flap 1 % heavier on the engine's side alone: MuJoCo still conserves its own momentum,
    which is no longer the reference's."""
    case = from_mjcf(tumbler, reference=tumbler)
    good = harness.validate(case, integrators=["RK4"])
    assert not _failed(good)
    names = {c.name for c in good.checks}
    assert {"RK4.p_lin_x", "RK4.p_ang_z", "RK4.drift.p_lin_y", "RK4.drift.p_ang_x"} <= names
    bad = _failed(harness.validate(case, integrators=["RK4"], edit=_heavier("flap", 1.01)))
    assert "RK4.position" in bad and {"RK4.p_lin_x", "RK4.p_ang_x"} & bad
    assert not {n for n in bad if n.startswith("RK4.drift.p_")}


# ------------------------------------------------------------------ our own double pendulum, either way
@pytest.mark.slow
def test_the_shipped_double_pendulum_passes_with_and_without_its_case():
    mjcf = ROOT / "mjcf" / "double_pendulum.xml"
    with_case = harness.validate("double_pendulum", integrators=["RK4", "Euler"])
    without = harness.validate(mjcf=mjcf, integrators=["RK4", "Euler"])
    assert not _failed(with_case) and not _failed(without)
    assert {c.name for c in without.checks} >= {c.name for c in with_case.checks if c.name.startswith("instant.")}


# ------------------------------------------------------------------ the fixture
def test_the_fixture_takes_a_model_with_no_case(pytester, arm):
    pytester.makepyfile(test_user=f"""
        def test_my_arm(mjharness):
            mjharness.assert_valid(mjcf={str(arm)!r}, keyframe="reach", integrators=["RK4"])
    """)
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider", "-q")
    result.assert_outcomes(passed=1)


# ------------------------------------------------------------------ what is refused
@pytest.mark.parametrize(("xml", "needle"), [
    ("<mujoco><worldbody><body><geom size='.1'/></body></worldbody></mujoco>", "no degrees of freedom"),
    ("<mujoco><worldbody><body><joint type='hinge'/><geom size='.1'/></body><flexcomp name='rope' type='grid' "
     "count='3 1 1' spacing='.1 .1 .1' dim='1' mass='0.1'/></worldbody></mujoco>", "flex elements"),
    ("<mujoco><worldbody><body><joint type='hinge' damping='nan'/><geom size='.1'/></body></worldbody></mujoco>",
     "not finite"),
    ("<mujoco><extension><plugin plugin='mujoco.pid'><instance name='pid'><config key='kp' value='4'/></instance>"
     "</plugin></extension><worldbody><body><joint name='j'/><geom size='.1' mass='1'/></body></worldbody>"
     "<actuator><plugin joint='j' plugin='mujoco.pid' instance='pid'/></actuator></mujoco>", "engine plugins"),
])
def test_a_model_it_cannot_judge_is_one_line_exit_2_nothing_written(tmp_path, xml, needle):
    path = tmp_path / "model.xml"
    path.write_text(textwrap.dedent(xml))
    out = tmp_path / "out"
    done = _cli("run", "--mjcf", str(path), "--out", str(out), "--no-studies", cwd=tmp_path)
    assert done.returncode == 2, done.stdout + done.stderr
    assert done.stderr.count("\n") == 1 and needle in done.stderr and "Traceback" not in done.stderr
    assert not out.exists()


def test_an_unknown_keyframe_or_actuator_is_named(arm):
    with pytest.raises(ModelError, match="keyframe 'nope' is not in the model; accepted: reach"):
        from_mjcf(arm, keyframe="nope")
    with pytest.raises(ModelError, match="accepted: elbow_servo"):
        from_mjcf(arm, ctrl={"shoulder_motor": 1.0})


def test_keyframe_without_a_model_of_ones_own_is_refused(tmp_path):
    done = _cli("check", "pendulum", "--keyframe", "home", cwd=tmp_path)
    assert done.returncode == 2 and "--keyframe and --ctrl apply to a model judged against its own tree" in done.stderr


@pytest.mark.slow
def test_a_control_is_baked_into_the_model_both_sides_read(arm):
    """ctrl 0.5 on the elbow servo (kp 2) becomes the bias b₀ = kp · 0.5 of the model every run compiles (the engine's
    ctrl stays 0), so the reference and the engine see the same servo: the model passes; the servo's stiffness changed
    on the engine's side alone (kp 2 → 2.02, after the control is baked in) fails."""
    moved = from_mjcf(arm, keyframe="reach", ctrl={"elbow_servo": 0.5}, reference=arm)
    model = compile_model(arm, edit=moved.prepare)
    assert model.actuator_biasprm[0, 0] == pytest.approx(2 * 0.5) and model.actuator_biasprm[0, 1] == -2
    assert not _failed(harness.validate(moved, integrators=["RK4"]))

    def stiffer(spec):
        params = list(spec.actuators[0].biasprm)
        params[1] = -2.02
        spec.actuators[0].biasprm = params

    assert "RK4.position" in _failed(harness.validate(moved, integrators=["RK4"], edit=stiffer))


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # DOP853's trial steps past its stability diverge, rejected
def test_a_stiff_model_is_solved_by_radau_iia_rather_than_refused(whip):
    """DOP853's first steps estimate ~4e4 over 0.2 s (the refusal of issue 29); Radau IIA solves it, the solution says
    so and why, the kick spared the damped mode (it would be gone within a step), and the constraint-free reference
    keeps the work–energy balance of its damping: E(t) − E(0) = −∫ q̇ᵀ D q̇ dt to the tolerance's order."""
    case = from_mjcf(whip, horizon=0.2)
    assert abs(case.qd0["flick"]) < 1e-3 * abs(case.qd0["shoulder"])
    model = compile_model(whip, edit=case.prepare)
    ref = case.reference(model)
    assert ref.solution.method == "Radau IIA"
    assert ref.solution.why.startswith("stiff (rtol 1e-08): DOP853 would take")
    assert "joint damping on light links" in ref.solution.why
    t = np.linspace(0.0, 0.2, 4001)
    q, qd = ref.solution.state(t)
    energy = ref.dynamics.energy(q, qd)
    power = -(0.01 * qd[:, 0] ** 2 + 0.5 * qd[:, 1] ** 2)
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(t))])  # trapezoid: O(dt²)
    assert np.max(np.abs(energy - energy[0] - work)) < 1e-6 * abs(energy[0])


@pytest.mark.slow
def test_a_stiff_model_reaches_a_verdict(whip, tmp_path):
    """The whole check of the whip (its reference by Radau IIA, the horizon chosen by its own chaos): RK4 cannot run
    at the model's step (its damping decays at ~1e6/s, h λ ~ 1e3, far past explicit RK4's stability bound of 2.8):
    its figures are n/a with the stability statement (the method's limit, not MuJoCo's defect:
    harness/families/stability.py), and every other check passes. The settings name the solver and why."""
    v = harness.validate(mjcf=whip)
    assert [c for c in v.checks if not c.passed] == []
    rk4 = [c for c in v.checks if c.name.startswith(("RK4.", "converge.RK4."))]
    assert rk4 and all(c.status == "n/a" and "beyond its stability limit" in c.note for c in rk4), rk4
    assert v.settings.tree["reference solver"].startswith("Radau IIA: stiff")


SPRING = """
<mujoco model="stiff_spring">
  <option timestep="0.01"/>
  <worldbody>
    <body name="rotor">
      <joint name="twist" type="hinge" axis="0 0 1" stiffness="1e3"/>
      <geom type="cylinder" size="0.1 0.05" mass="1"/>
    </body>
  </worldbody>
</mujoco>
"""


def test_an_integrator_whose_run_diverges_fails_rather_than_vanishing(tmp_path):
    """A model judged against its own tree gets its limits from the figures it measured, so a diverged integrator's
    checks vanished with its figures and the gate passed on the instantaneous checks alone; each is now judged.

    A spring of ω ≈ 450 rad/s at h = 10 ms (ω h ≈ 4.5, past RK4's 2√2 and semi-implicit Euler's 2): both runs
    diverge, beyond the methods' stability limits, so each check is there, n/a with that statement (the method's
    limit, harness/families/stability.py). The same spring made 4× stiffer on the engine's side alone, at a step
    the reference calls stable for semi-implicit Euler (3 ms: ω h ≈ 1.3 for the reference, 2.7 for the engine,
    past its 2), fails where its run diverged: the limit comes from the reference, so no fault can move it."""
    path = tmp_path / "spring.xml"
    path.write_text(SPRING)
    v = harness.validate(mjcf=path, integrators=["RK4", "Euler"], horizon=0.2)
    assert v.passed
    for integrator in ("RK4", "Euler"):
        for name in (f"{integrator}.position", f"{integrator}.drift.energy", f"converge.{integrator}.order_shortfall"):
            check = v.check(name)
            assert check.status == "n/a" and "is beyond its stability limit" in check.note, check
            assert "its run diverged: mjWARN_BADQACC" in check.note, check
    faulty = tmp_path / "faulty.xml"
    faulty.write_text(SPRING.replace('stiffness="1e3"', 'stiffness="4e3"'))
    v = harness.validate(from_mjcf(faulty, reference=path, horizon=0.2), integrators=["Euler"], timestep=0.003)
    assert not v.passed
    for name in ("Euler.position", "Euler.drift.energy", "converge.Euler.order_shortfall"):
        check = v.check(name)
        assert not check.passed and check.diverged.startswith("diverged: mjWARN_BADQACC"), check


def test_a_point_mass_on_a_ball_joint_is_refused_rather_than_solved_for_hours():
    with pytest.raises(ModelError, match="joint 'ball' turns a body with next to no rotational inertia"):
        from_mjcf(ROOT / "mjcf" / "spherical_pendulum_ball.xml")


def test_the_check_output_says_what_the_tree_covered_and_what_only_the_balance_judged():
    from harness.outputs.table import coverage_block

    text = coverage_block({"arm": {"contacts": "…", "joint limits": "…"}, "bare": {}, "pendulum": None}, 100)
    assert "arm: the reference derived from its own tree covers every force but contacts, joint limits" in \
        " ".join(text.split())
    assert "work–energy balance" in " ".join(text.split())
    assert "bare: every force MuJoCo applies is in the reference derived from its own tree" in text
    assert "pendulum" not in text  # a hand-derived case has no tree to speak of
    assert all(len(line) <= 100 for line in text.splitlines())
    assert coverage_block({"pendulum": None}, 100) == ""


SYRUP = """
<mujoco model="syrup">
  <option timestep="0.01" viscosity="10"/>
  <worldbody>
    <body name="arm">
      <joint name="swing" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.02" mass="1"/>
      <body name="bead" pos="0.5 0 0">
        <joint name="spin" type="hinge" axis="0 0 1"/>
        <geom type="sphere" size="0.05" mass="0.001"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_a_balance_run_that_diverges_fails_rather_than_vanishing(tmp_path):
    """A 1 g bead in a viscous fluid at h = 10 ms: the drag's rate (6πμr/m ≈ 9e3/s) is far past explicit stability, so
    the model as it is (fluid acting) diverges, while the comparison with the tree (fluid off) runs. The balance's own
    run diverging left no figure and, a tree case's limits coming from its figures, no check: the gate passed."""
    path = tmp_path / "syrup.xml"
    path.write_text(SYRUP)
    v = harness.validate(mjcf=path, integrators=["RK4"], horizon=0.2)
    assert "fluid forces" in v.settings.tree["not examined"]
    check = v.check("RK4.balance")
    assert not check.passed and check.diverged.startswith("diverged: mjWARN_BADQACC"), check
    assert not v.passed

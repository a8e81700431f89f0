"""The Python API (harness.validate) and the pytest plugin, used as a user's own code and test suite would."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys

import pytest

import harness
from harness.cases import get
from harness.engine.compat import set_damping
from harness.outputs.jsondoc import dumps
from harness.studies.faults import by_name

RK4 = ["RK4"]  # one integrator keeps these runs short; the others are judged by the generic tests


@pytest.fixture(scope="module")
def shipped():
    return harness.validate("pendulum", integrators=RK4)


@pytest.fixture(scope="module")
def damped():
    return harness.validate("pendulum", integrators=RK4, edit=lambda spec: set_damping(spec.joint("theta"), 0.01))


def test_import_harness_loads_nothing_heavy():
    """`import harness` must stay light: the mjharness command imports it before MuJoCo (without GL)."""
    code = "import sys, harness; print(sorted({'mujoco', 'numpy', 'sympy'} & set(sys.modules)), harness.__version__)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["[]", harness.__version__]
    assert set(harness.__all__) <= set(dir(harness))
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        harness.nope  # noqa: B018


def test_a_shipped_case_validates(shipped):
    assert isinstance(shipped, harness.Validation) and shipped.passed and shipped.failures == ()
    assert shipped.case == "pendulum" and shipped.mjcf.endswith("pendulum.xml")
    # the other integrators' limits are left, but for one this MuJoCo lacks, which is shown as n/a
    assert {c.name.integrator for c in shipped.checks if not c.note} <= {"", "RK4"}
    assert shipped.check("RK4.position").value == shipped.figure("RK4.position").value
    na = sum(bool(c.note) for c in shipped.checks)
    assert shipped.summary().splitlines()[-1].startswith(f"{len(shipped.checks) - na} passed, 0 failed")
    shipped.raise_for_failures()  # nothing to raise
    with pytest.raises(KeyError, match="measured: "):
        shipped.figure("RK4.nothing")
    with pytest.raises(dataclasses.FrozenInstanceError):
        shipped.case = "other"  # type: ignore[misc]


def test_a_fault_fails_with_every_failure_listed(damped):
    assert not damped.passed and damped.failures
    with pytest.raises(harness.ValidationFailed) as err:
        damped.raise_for_failures()
    assert isinstance(err.value, AssertionError) and err.value.validation is damped
    message = str(err.value)
    assert f"{len(damped.failures)} of {len(damped.checks)} checks failed" in message
    assert all(c.name in message for c in damped.failures) and "RK4.position" in message


def test_the_json_is_the_report_schema(shipped):
    doc = json.loads(dumps(shipped.to_json()))
    assert doc["schema"] == 2 and list(doc["cases"]) == ["pendulum"]  # docs/report-json.md
    assert doc["gate"] == {"passed": True, "accept_known_defects": False, "known_defects": 0, "exit_code": 0}
    assert "requirements" not in doc  # none stated
    entry = doc["cases"]["pendulum"]
    found = {"findings"} if shipped.findings else set()  # mj_jacDot before MuJoCo 3.3.1
    assert set(entry) == {"passed", "figures", "checks", "settings", *found} and entry["passed"] is True
    check = entry["checks"]["RK4.position"]
    assert check["threshold"] == shipped.check("RK4.position").threshold == check["budget"]["limit"]
    assert (check["basis"], check["status"]) == ("budget", "pass")


def test_a_legitimate_setting_passes_and_says_what_differs():
    """Twice the masses (the catalog's setting): another, consistent pendulum; its reference is built with
    its own mass, so nothing is unexplained, and the run says what differs from the shipped model."""
    case = get("pendulum")
    heavier = harness.validate(case, integrators=RK4, edit=by_name("masses×2").edit(case))
    assert heavier.passed and heavier.settings["params"]["m"] == 2.0
    assert heavier.settings["changed"]["param.m"] == {"shipped": 1.0, "tested": 2.0}


def test_what_differs_lists_every_change_of_the_model(tmp_path):
    """The issue's run listed the mass and the timestep, not the joint damping that made it fail: every
    attribute the model under test is written with differently is listed, however it was changed."""
    text = get("pendulum").mjcf.read_text()
    path = tmp_path / "damped.xml"
    path.write_text(text.replace('axis="0 -1 0" damping="0"', 'axis="0 -1 0" damping="0.001"')
                    .replace('<inertial pos="0 0 0" mass="1"', '<inertial pos="0 0 0" mass="1.02"'))
    result = harness.validate("pendulum", mjcf=path, integrators=RK4, timestep=0.002)
    changed = result.settings["changed"]
    assert changed["mjcf: joint 'theta' damping"] == {"shipped": "default", "tested": "0.001"}
    assert changed["param.m"] == {"shipped": 1.0, "tested": 1.02}
    assert changed["timestep"] == {"shipped": 0.001, "tested": 0.002}
    assert changed["mjcf: body 'bob'/inertial mass"] == {"shipped": "1", "tested": "1.02"}
    assert not any("timestep" in k for k in changed if k.startswith("mjcf:"))  # listed once, as the setting
    edited = harness.validate("pendulum", integrators=RK4, edit=lambda spec: setattr(spec.geom("bob"), "margin", 0.1))
    assert edited.settings["changed"] == {"mjcf: geom 'bob' margin": {"shipped": "default", "tested": "0.1"}}


def test_a_model_mujoco_cannot_write_is_said_not_compared(monkeypatch):
    from harness.pipeline import run as pipeline

    def unwritable(*_a, **_k):
        raise RuntimeError("to_xml: plugin cannot be written")

    monkeypatch.setattr(pipeline, "authored", unwritable)
    edited = harness.validate("pendulum", integrators=RK4, edit=lambda spec: setattr(spec.geom("bob"), "margin", 0.1))
    assert "not compared attribute by attribute: to_xml: plugin cannot be written" in \
        edited.settings["changed"]["mjcf"]["tested"]


def test_a_requirement_is_a_second_verdict_on_the_models_own_integrator(shipped):
    """The pendulum's own integrator is RK4: its position error (about 1e-7 m over 5 s, mostly the rod's softness) is
    within 1 mm and not within 1e-15 m. Unmet, the run still passes its checks, and raise_for_failures
    names the requirement."""
    fit = harness.validate("pendulum", integrators=RK4, require={"position": 1e-3})
    assert fit.passed and fit.fit and [str(f.figure) for f in fit.fitness] == ["RK4.position"]
    assert fit.outcome.exit_code == 0
    unfit = harness.validate("pendulum", integrators=RK4, require={"position": 1e-15})
    assert unfit.passed and not unfit.fit and [str(f.figure) for f in unfit.unmet] == ["RK4.position"]
    assert unfit.outcome.exit_code == 3
    with pytest.raises(harness.ValidationFailed, match=r"0 of \d+ checks failed, 1 requirement\(s\) not met"):
        unfit.raise_for_failures()
    with pytest.raises(ValueError, match="matches no figure"):
        harness.validate("pendulum", integrators=RK4, require={"posture": 1e-3})


def test_the_motion_can_be_given():
    """Another initial angle and horizon: the reference starts where the run does (r on its constraint)."""
    other = harness.validate("pendulum", integrators=RK4, q0={"theta": 0.3}, qd0={"theta": 0.0}, horizon=1.0)
    assert other.passed
    assert other.settings["q0"] == {"theta": 0.3, "r": 1.0} and other.settings["qd0"] == {"theta": 0.0, "r": 0.0}
    assert other.settings["horizon"] == 1.0


def test_limits_and_cases_can_be_given(shipped):
    tight = harness.validate(get("pendulum"), integrators=RK4,
                             limits={"RK4.position": shipped.figure("RK4.position").value / 2})
    assert [c.name for c in tight.failures] == ["RK4.position"] and "validate()" in tight.limits
    assert "pendulum" in harness.case_names()


@pytest.mark.parametrize("kwargs, needle", [
    ({"case": "pendulumm"}, "known cases: atwood"),
    ({"case": "pendulm"}, r"unknown case 'pendulm'; did you mean 'pendulum'\? known cases: atwood"),
    ({"case": 3}, "case must be a case name"),
    ({"case": "pendulum", "integrators": []}, "at least one integrator"),
    ({"case": "pendulum", "integrators": ["Verlet"]}, "unknown integrator 'Verlet'"),
])
def test_bad_arguments_are_one_line_value_errors(kwargs, needle):
    with pytest.raises(ValueError, match=needle) as err:
        harness.validate(**kwargs)
    assert "\n" not in str(err.value)


def _returns_a_spec(spec):
    spec.option.timestep = 0.002
    return spec


@pytest.mark.parametrize("kwargs, error, needle", [
    ({"accept_known_defects": "no"}, TypeError, "accept_known_defects must be True or False, got 'no'"),
    ({"integrators": "RK4"}, TypeError, r"integrators must be a list of integrator names, e.g. \['RK4'\], got 'RK4'"),
    ({"timestep": "0.001"}, TypeError, r"timestep must be a number of seconds .* got '0.001' \(str\)"),
    ({"timestep": -0.001}, ValueError, "timestep must be a finite number of seconds > 0, got -0.001"),
    ({"horizon": float("nan")}, ValueError, "horizon must be a finite number of seconds > 0, got nan"),
    ({"limits": [1]}, TypeError, r"limits must be a mapping of names to numbers, e.g. .* got \[1\] \(list\)"),
    ({"limits": {"RK4.position": "1e-6"}}, TypeError, "limits must map names .* not 'RK4.position': '1e-6'"),
    ({"require": {"position": None}}, TypeError, "require must map names"),
    ({"q0": {"theta": "0.3"}}, TypeError, "q0 must map names"),
    ({"edit": "timestep=0.002"}, TypeError, "edit must be a function of a mujoco.MjSpec"),
    ({"edit": _returns_a_spec}, TypeError, "edit must change the mujoco.MjSpec it is given in place and return "
                                           "None; it returned MjSpec"),
])
def test_arguments_of_the_wrong_type_are_refused_naming_them(kwargs, error, needle):
    """The issue's inputs: each refused naming the argument and what it accepts, never read as something
    else ("no" as true, "RK4" letter by letter), a raw error from inside, or an edit's result ignored."""
    with pytest.raises(error, match=needle) as err:
        harness.validate("pendulum", **kwargs)
    assert "\n" not in str(err.value)


USER_TESTS = '''
from pathlib import Path

MODEL = Path(__file__).parent / "my_pendulum.xml"
BROKEN = Path(__file__).parent / "my_damped_pendulum.xml"


def test_my_pendulum_is_valid(mjharness):
    result = mjharness.assert_valid("pendulum", mjcf=MODEL, integrators=["RK4"])
    assert result.figure("RK4.position").value < 1e-6


def test_my_damped_pendulum(mjharness):
    mjharness.assert_valid("pendulum", mjcf=BROKEN, integrators=["RK4"])
'''


def test_the_plugin_validates_a_users_variant_in_their_own_suite(pytester):
    """An outside test file, run by pytest in a fresh process with only the installed plugin: the fixture
    passes the user's faithful copy of the model and fails their damped one, naming the failed checks."""
    shipped = get("pendulum").mjcf.read_text()
    assert 'damping="0"' in shipped
    pytester.makefile(".xml", my_pendulum=shipped,
                      my_damped_pendulum=shipped.replace('damping="0"', 'damping="0.01"', 1))
    pytester.makepyfile(test_user=USER_TESTS)
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider", "-v")
    result.assert_outcomes(passed=1, failed=1)
    result.stdout.fnmatch_lines(["*mjharness 0.1.0, MuJoCo *", "*test_my_pendulum_is_valid PASSED*",
                                 "*ValidationFailed: case 'pendulum' (*my_damped_pendulum.xml): * checks failed*",
                                 "*RK4.position: measured * m, unexplained * > limit *"])

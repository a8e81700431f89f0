"""The Python API (harness.validate) and the pytest plugin, used as a user's own code and test suite would."""

from __future__ import annotations

import dataclasses
import json
import math
import re
import subprocess
import sys
from pathlib import Path

import pytest

import harness
from harness.cases import get
from harness.core.budget import Budget
from harness.core.checks import Check
from harness.engine.compat import set_damping
from harness.outputs.jsondoc import dumps
from harness.outputs.table import verdict_line
from harness.studies.faults import by_name

RK4 = ["RK4"]  # one integrator keeps these runs short; the others are judged by the generic tests


@pytest.fixture(scope="module")
def shipped():
    return harness.validate("pendulum", integrators=RK4)


_PLAIN_RUNS: dict = {}


@pytest.fixture
def plain_runs(monkeypatch):
    """validate()'s run of a shipped case, unedited and from its own file, made once for the module: the tests
    that take this vary what is judged of the same run (limits, requirements); any other run is made as asked."""
    from harness.pipeline import matrix  # validate runs its case through the pipeline's entry, which runs it here

    real = matrix.run_case

    def run(case, options):
        if options.edit is not None or options.mjcf is not None:
            return real(case, options)
        key = (case.name, repr(options))
        if key not in _PLAIN_RUNS:
            _PLAIN_RUNS[key] = real(case, options)
        return _PLAIN_RUNS[key]

    monkeypatch.setattr(matrix, "run_case", run)


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
    verdict, *lines = message.splitlines()
    assert verdict.startswith(f"FAIL — {len(damped.failures)} of {len(damped.checks)} checks fail, in 1 of 1 case(s)")
    assert verdict.endswith(f"; model {damped.mjcf}")
    assert [line.split(":")[0] for line in lines] == [f"  pendulum {c.name}" for c in damped.failures]
    position = next(line for line in lines if " RK4.position: " in line)
    check = damped.check("RK4.position")
    assert position == (f"  pendulum RK4.position: measured {check.value:.3g} m, unexplained "
                        f"{check.budget.unexplained:.3g} m vs limit {check.threshold:.3g} m "
                        f"({check.budget.unexplained / check.threshold:.3g}× over)")
    assert "Validation(" not in message and "Check(" not in message
    assert repr(damped) == (f"<Validation 'pendulum' ({Path(damped.mjcf).name}): {len(damped.failures)} of "
                            f"{len(damped.checks)} checks failed>")


def test_the_failure_message_has_one_line_per_kind_of_failure():
    """A budget's, a fixed limit's (a dimensionless figure: no unit), a run that diverged, a figure with no
    budget, a known defect and a figure that is not finite: each on its line, after the verdict."""
    budget = Budget(measured=3e-4, explained={"integration": 1e-4}, unexplained=2e-4, tolerance={"floors": 1e-5})
    diverged = "diverged: mjWARN_BADQACC at t = 0.25 s"
    known = "RK4 order 1 on a ball joint; observed order 1.0"
    checks = (Check("pendulum", "RK4.position", 3e-4, 1e-5, "m", budget=budget),
              Check("pendulum", "converge.RK4.order_shortfall", 0.55, 0.3, "1"),
              Check("pendulum", "Euler.position", math.nan, math.nan, "", diverged=diverged),
              Check("pendulum", "implicit.position", 1.0, math.nan, "m", diverged="no budget was computed"),
              Check("pendulum", "RK4.force.rod", 2.0, 1.0, "N", known=known),
              Check("pendulum", "RK4.drift.energy", math.inf, 1e-9, "1"),
              Check("pendulum", "RK4.velocity", 1e-9, 1e-6, "m/s"),  # passes: not listed
              Check("pendulum", "Euler.velocity", math.nan, math.nan, "", note="not in this MuJoCo"))  # n/a: not listed
    result = harness.Validation(case="pendulum", mjcf="/models/mine.xml", checks=checks, figures=())
    assert repr(result) == "<Validation 'pendulum' (mine.xml): 6 of 8 checks failed>"
    assert str(harness.ValidationFailed(result)).splitlines() == [
        "FAIL — 6 of 8 checks fail, in 1 of 1 case(s): pendulum (6); 1 of them known defects of this MuJoCo "
        "(RK4 order 1 on a ball joint); 1 n/a; model /models/mine.xml",
        "  pendulum RK4.position: measured 0.0003 m, unexplained 0.0002 m vs limit 1e-05 m (20× over)",
        "  pendulum converge.RK4.order_shortfall: measured 0.55 vs limit 0.3 (1.83× over)",
        "  pendulum Euler.position: diverged: mjWARN_BADQACC at t = 0.25 s",
        "  pendulum implicit.position: not measurable: no budget was computed",
        "  pendulum RK4.force.rod: measured 2 N vs limit 1 N (2× over); known defect: RK4 order 1 on a ball joint; "
        "observed order 1.0",
        "  pendulum RK4.drift.energy: measured inf vs limit 1e-09 (not finite)",
    ]


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
    assert heavier.passed and heavier.settings.params["m"] == 2.0
    assert heavier.settings.changed["param.m"] == {"shipped": 1.0, "tested": 2.0}


def test_what_differs_lists_every_change_of_the_model(tmp_path):
    """The issue's run listed the mass and the timestep, not the joint damping that made it fail: every
    attribute the model under test is written with differently is listed, however it was changed."""
    text = get("pendulum").mjcf.read_text()
    path = tmp_path / "damped.xml"
    path.write_text(text.replace('axis="0 -1 0" damping="0"', 'axis="0 -1 0" damping="0.001"')
                    .replace('<inertial pos="0 0 0" mass="1"', '<inertial pos="0 0 0" mass="1.02"'))
    result = harness.validate("pendulum", mjcf=path, integrators=RK4, timestep=0.002)
    changed = result.settings.changed
    assert changed["mjcf: joint 'theta' damping"] == {"shipped": "default", "tested": "0.001"}
    assert changed["param.m"] == {"shipped": 1.0, "tested": 1.02}
    assert changed["timestep"] == {"shipped": 0.001, "tested": 0.002}
    assert changed["mjcf: body 'bob'/inertial mass"] == {"shipped": "1", "tested": "1.02"}
    assert not any("timestep" in k for k in changed if k.startswith("mjcf:"))  # listed once, as the setting
    edited = harness.validate("pendulum", integrators=RK4, edit=lambda spec: setattr(spec.geom("bob"), "margin", 0.1))
    assert edited.settings.changed == {"mjcf: geom 'bob' margin": {"shipped": "default", "tested": "0.1"}}


def test_a_model_mujoco_cannot_write_is_said_not_compared(monkeypatch):
    from harness.pipeline import run as pipeline

    def unwritable(*_a, **_k):
        raise RuntimeError("to_xml: plugin cannot be written")

    monkeypatch.setattr(pipeline, "authored", unwritable)
    edited = harness.validate("pendulum", integrators=RK4, edit=lambda spec: setattr(spec.geom("bob"), "margin", 0.1))
    assert "not compared attribute by attribute: to_xml: plugin cannot be written" in \
        edited.settings.changed["mjcf"]["tested"]


def test_a_requirement_is_a_second_verdict_on_the_models_own_integrator(shipped, plain_runs):
    """The pendulum's own integrator is RK4: its position error (about 1e-7 m over 5 s, mostly the rod's softness) is
    within 1 mm and not within 1e-15 m. Unmet, the run still passes its checks, and raise_for_failures
    names the requirement."""
    fit = harness.validate("pendulum", integrators=RK4, require={"position": 1e-3})
    assert fit.passed and fit.fit and [str(f.figure) for f in fit.fitness] == ["RK4.position"]
    assert fit.outcome.exit_code == 0
    unfit = harness.validate("pendulum", integrators=RK4, require={"position": 1e-15})
    assert unfit.passed and not unfit.fit and [str(f.figure) for f in unfit.unmet] == ["RK4.position"]
    assert unfit.outcome.exit_code == 3
    with pytest.raises(harness.ValidationFailed) as err:
        unfit.raise_for_failures()
    (position,) = unfit.unmet
    assert verdict_line(unfit.outcome).startswith("PASS — ")
    assert str(err.value).splitlines() == [
        f"{verdict_line(unfit.outcome)}; 1 requirement(s) not met; model {unfit.mjcf}",
        f"  pendulum RK4.position: measured {position.value:.3g} m vs required 1e-15 (requirement position not met)"]
    with pytest.raises(ValueError, match="matches no figure"):
        harness.validate("pendulum", integrators=RK4, require={"posture": 1e-3})


def test_the_motion_can_be_given():
    """Another initial angle and horizon: the reference starts where the run does (r on its constraint)."""
    other = harness.validate("pendulum", integrators=RK4, q0={"theta": 0.3}, qd0={"theta": 0.0}, horizon=1.0)
    assert other.passed
    assert other.settings.q0 == {"theta": 0.3, "r": 1.0} and other.settings.qd0 == {"theta": 0.0, "r": 0.0}
    assert other.settings.horizon == 1.0


def test_limits_and_cases_can_be_given(shipped, plain_runs):
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

MODEL = Path(__file__).parent / "models" / "my_pendulum.xml"


def test_my_pendulum_is_valid(mjharness):  # an absolute path: unchanged
    result = mjharness.assert_valid("pendulum", mjcf=MODEL, integrators=["RK4"])
    assert result.figure("RK4.position").value < 1e-6


def test_my_damped_pendulum(mjharness):  # relative to this file, not to pytest's working directory
    mjharness.assert_valid("pendulum", mjcf="models/my_damped_pendulum.xml", integrators=["RK4"])


def test_a_missing_model(mjharness):
    mjharness.assert_valid("pendulum", mjcf="models/my_pendulm.xml", integrators=["RK4"])


def test_a_mistyped_case(mjharness):
    mjharness.assert_valid("pendulm", mjcf=MODEL, integrators=["RK4"])
'''


def _section(stdout: str, test: str) -> list[str]:
    """The lines pytest shows for one failed test (between its ``___ test ___`` header and the next)."""
    lines = stdout.splitlines()
    start = next(i for i, line in enumerate(lines) if re.fullmatch(rf"_+ {test} _+", line))
    end = next((i for i, line in enumerate(lines[start + 1:], start + 1) if re.match(r"^(_{3,} |=+ )", line)),
               len(lines))
    return lines[start + 1:end]


def test_the_plugin_validates_a_users_variant_in_their_own_suite(pytester, monkeypatch):
    """An outside suite, run by pytest in a fresh process with only the installed plugin, from the folder above
    its test file: the fixture passes the user's faithful copy of the model and fails their damped one (damping on
    the hinge theta) with a short list, the verdict and one line per failed check, at the test's own line (no
    frame of the plugin, no Validation repr); a model path is found next to the test file, and a missing one or
    a mistyped case is one line."""
    monkeypatch.setenv("PYTHONPATH", str(Path(harness.__file__).parents[1]))  # this checkout's harness and plugin
    shipped = get("pendulum").mjcf.read_text()
    assert 'axis="0 -1 0" damping="0"' in shipped  # the hinge theta's
    models = pytester.mkdir("tests") / "models"
    models.mkdir()
    (models / "my_pendulum.xml").write_text(shipped)
    (models / "my_damped_pendulum.xml").write_text(shipped.replace('axis="0 -1 0" damping="0"',
                                                                   'axis="0 -1 0" damping="0.01"', 1))
    (pytester.path / "tests" / "test_user.py").write_text(USER_TESTS)
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider", "-v", "tests")
    result.assert_outcomes(passed=1, failed=3)
    out = result.stdout.str()
    assert "Validation(" not in out and "Check(" not in out and "pytest_plugin.py" not in out, out
    result.stdout.fnmatch_lines(["*mjharness 0.1.0, MuJoCo *", "*test_my_pendulum_is_valid PASSED*"])

    damped = [line for line in _section(out, "test_my_damped_pendulum") if line.startswith("E ")]
    verdict, *failures = damped
    assert re.fullmatch(r"E +harness\.api\.ValidationFailed: FAIL — (\d+) of \d+ checks fail, in 1 of 1 case\(s\): "
                        r"pendulum \(\1\)(; [^;]+)*; model .*/tests/models/my_damped_pendulum\.xml", verdict), verdict
    # (an older MuJoCo adds "; 5 n/a; engine finding: …" before the model: the verdict line as the CLI prints it)
    assert len(failures) == int(re.search(r"FAIL — (\d+)", verdict)[1])
    assert all(re.fullmatch(r"E +pendulum \S+: measured .* vs limit \S+( \w+)? \(\S+× over\)", line)
               for line in failures), failures
    assert any(re.fullmatch(r"E +pendulum RK4\.position: measured \S+ m, unexplained \S+ m vs limit \S+ m "
                            r"\(\S+× over\)", line) for line in failures), failures

    missing = [line for line in _section(out, "test_a_missing_model") if line.startswith("E ")]
    looked = pytester.path / "tests" / "models" / "my_pendulm.xml"
    assert missing == [f"E       harness.core.errors.ModelError: cannot read MJCF 'models/my_pendulm.xml': no such "
                       f"file; looked for it at {looked} (relative to the test file test_user.py, not the working "
                       f"directory)"]
    typo = [line for line in _section(out, "test_a_mistyped_case") if line.startswith("E ")]
    assert len(typo) == 1 and typo[0].startswith("E       ValueError: unknown case 'pendulm'; did you mean "
                                                 "'pendulum'? known cases: atwood, "), typo

"""`mjharness advise`: the recommended (integrator, timestep) meets the requirement and twice its step does not, by
errors known in closed form; explicit integrators only below their stability limit; a requirement nothing meets is
said so; the limit's confirmation fails on a wrong limit; bad input is one line.

The closed form: the spring (mjcf/spring.xml: m = 0.5 kg, k = 20 N/m, x(0) = 0.2 m, ẋ(0) = 1 m/s) is linear, so each
of MuJoCo's explicit integrators is a fixed matrix per step, and its error at every sample is that matrix's power
against the exact cos/sin solution, computed here from the documented update rules (doc/computation, "Numerical
integration"), not by the harness.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from harness import cases
from harness.core.options import RunOptions
from harness.pipeline.require import parse
from harness.studies import advice as A

ROOT = Path(__file__).resolve().parent.parent
MENAGERIE = ROOT.parent / "shared" / "models" / "menagerie"
M, K, X0, V0, HORIZON = 0.5, 20.0, 0.2, 1.0, 5.0


def _step_matrix(integrator: str, h: float) -> np.ndarray:
    """One step of ``integrator`` on ẍ = −ω²x, state (x, ẋ)."""
    w2 = K / M
    if integrator == "Euler":  # semi-implicit: v ← v + h a(x), then x ← x + h v
        return np.array([[1.0 - h * h * w2, h], [-h * w2, 1.0]])
    a = np.array([[0.0, 1.0], [-w2, 0.0]]) * h  # RK4 on a linear system: its 4th-order Taylor polynomial of hA
    return np.eye(2) + a + a @ a / 2 + a @ a @ a / 6 + a @ a @ a @ a / 24


def closed_form_error(integrator: str, h: float) -> float:
    """The largest |x_k − x(k h)| over the samples of a run of ``integrator`` at ``h`` over the horizon."""
    w = math.sqrt(K / M)
    n = math.floor(HORIZON / h + 1e-9)
    step = _step_matrix(integrator, h)
    y = np.array([X0, V0])
    worst = 0.0
    for k in range(1, n + 1):
        y = step @ y
        exact = X0 * math.cos(w * k * h) + V0 / w * math.sin(w * k * h)
        worst = max(worst, abs(y[0] - exact))
    return worst


def test_the_closed_form_is_the_spring_case():  # the constants above are the shipped case's
    case = cases.get("spring")
    assert case.motion.q0 == {"x": X0} and case.motion.qd0 == {"x": V0} and case.horizon == HORIZON


@pytest.mark.parametrize(("integrator", "required"), [("Euler", 3e-2), ("RK4", 1e-4), ("RK4", 1e-7)])
def test_the_recommended_step_meets_the_requirement_and_twice_it_does_not(integrator, required):
    advice = A.advise(cases.get("spring"), parse([f"position={required}"]), integrators=(integrator,))
    v = advice.recommended
    assert v is not None, advice.why_none
    assert v.integrator == integrator and v.met and not v.failures
    h = v.timestep
    assert closed_form_error(integrator, h) <= required < closed_form_error(integrator, 2 * h)
    # the printed figure is the measured one, and the measurement is the closed form's
    assert v.measured["position"] == pytest.approx(closed_form_error(integrator, h), rel=1e-6, abs=1e-11)
    assert v.margin == pytest.approx(required / v.measured["position"])


def test_the_cheapest_integrator_is_recommended_and_its_cost_is_measured():
    advice = A.advise(cases.get("spring"), parse(["position=1e-4"]), integrators=("Euler", "RK4"))
    v = advice.recommended
    # RK4 meets 1e-4 at a step ~100× Euler's, at 4 evaluations a step: the cheaper by far
    assert v is not None and v.integrator == "RK4"
    euler = A.candidate(advice.curve("Euler"), advice.requirements)[0]
    assert euler < v.timestep / 10
    assert v.cost > 0 and all(p.cost > 0 for c in advice.curves for p in c.measured())


def test_requirements_come_comma_separated_or_repeated():
    assert parse(["position=1e-3,force=1e-2"]) == parse(["position=1e-3", "force=1e-2"])
    with pytest.raises(ValueError, match="expected MEASURE=VALUE"):
        parse(["position=1e-3,"])


def test_a_requirement_no_integrator_meets_is_said_so():
    advice = A.advise(cases.get("spring"), parse(["position=1e-14"]), integrators=("Euler", "RK4"))
    assert advice.recommended is None
    assert advice.why_none.startswith("no integrator meets the requirements")
    assert "Euler" in advice.why_none and "RK4" in advice.why_none


def _curve(limit: float, confirmed: bool) -> A.Curve:
    """A first-order curve whose errors are e(h) = h (m), runs from 1 s down to 1/16 s."""
    points = tuple(A.Point(timestep=h, values={"position": h}, bars={"position": 0.0}, units={"position": "m"},
                           cost=1.0 / h) for h in (1.0, 0.5, 0.25, 0.125, 0.0625))
    return A.Curve(integrator="RK4", order=1.0, points=points,
                   limit=A.Limit(limit, "test", confirmed=confirmed), ordered={"position": (0.0625, 1.0)})


def test_an_explicit_candidate_stays_below_its_stability_limit():
    requirement = parse(["position=0.9"])  # met up to h = 0.6 by the errors alone
    h, _ = A.candidate(_curve(math.inf, False), requirement)
    assert h == pytest.approx(0.6)
    h, _ = A.candidate(_curve(0.5, True), requirement)  # a confirmed limit: at most BELOW × it
    assert h == pytest.approx(A.BELOW * 0.5)
    h, _ = A.candidate(_curve(0.3, True), requirement)  # the largest run within it, never one above
    assert h == pytest.approx(0.25)
    assert A.candidate(_curve(0.3, False), requirement)[0] <= 0.3


def test_the_stability_confirmation_fails_on_a_wrong_limit():
    """A limit half the true one: the run 'above' it does not grow, and the limit is not confirmed."""
    from harness.families import COMPARISONS
    from harness.families.bench import Bench

    bench = Bench(cases.get("spring"), RunOptions(integrators=("RK4",)), COMPARISONS)
    true = bench.stability["RK4"].limit
    assert true == pytest.approx(2 * math.sqrt(2) / math.sqrt(K / M), rel=1e-3)  # RK4's imaginary-axis extent / ω
    assert A._confirm(bench, "RK4", true)[2] is True
    _, above, confirmed = A._confirm(bench, "RK4", 0.5 * true)
    assert confirmed is False and "diverged" not in above


def _menagerie(name: str) -> Path:
    path = MENAGERIE / name
    if not path.exists():
        pytest.skip(f"{MENAGERIE} is absent: the shared robots are not here")
    return path


@pytest.mark.slow
@pytest.mark.parametrize("robot", ["kuka_iiwa_14/iiwa14.xml", "wonik_allegro/right_hand.xml"])
def test_on_a_stiff_robot_explicit_integrators_are_recommended_only_below_their_limit(robot):
    """Stiff servos (iiwa) and damped light links (Allegro): RK4's limit is far below the model's own step."""
    from harness.cases.own import from_mjcf

    case = from_mjcf(_menagerie(robot))
    advice = A.advise(case, parse(["position=1e-3"]), integrators=("Euler", "RK4"))
    v = advice.recommended
    assert v is not None, advice.why_none
    limit = advice.curve(v.integrator).limit  # at most BELOW × a confirmed limit, never above one that is not
    assert v.timestep <= (A.BELOW if limit.confirmed else 1.0) * limit.timestep
    assert advice.curve("RK4").limit.timestep < 1e-4  # stiff: RK4's limit far below the model's own 2 ms
    for curve in advice.curves:  # no ladder run above the limit
        assert all(p.timestep <= curve.limit.timestep for p in curve.measured())
    # the forces the reference lacks (joint limits, contacts): what only self-convergence checked, said
    assert advice.uncovered and "position" in v.as_is


def _cli(*args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "harness", "advise", *args], capture_output=True, text=True,
                          cwd=cwd, timeout=300)


@pytest.mark.parametrize(("args", "says"), [
    (("spring",), "--require"),
    (("spring", "--mjcf", "mjcf/spring.xml", "--require", "position=1"), "not both"),
    (("spring", "--require", "positon=1e-3"), "accepted"),
    (("spring", "--require", "position=-1"), "positive"),
    (("nosuchcase", "--require", "position=1e-3"), "unknown case"),
])
def test_bad_input_is_one_line(args, says):
    done = _cli(*args)
    assert done.returncode == 2
    assert says in done.stderr and "Traceback" not in done.stderr
    assert done.stdout == ""


def test_the_command_writes_the_plot_and_the_page_and_escapes_names(tmp_path):
    model = tmp_path / "my<b>robot.xml"  # the model's name comes from its own XML: a name with markup in it
    model.write_text((ROOT / "mjcf" / "spring.xml").read_text().replace('model="spring"', 'model="my&lt;b&gt;robot"'))
    done = _cli("--mjcf", str(model), "--require", "position=1e-3", "--integrators", "RK4", "--png",
                str(tmp_path / "out" / "a.png"), "--html", str(tmp_path / "out" / "a.html"))
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "out" / "a.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    page = (tmp_path / "out" / "a.html").read_text()
    assert "my&lt;b&gt;robot" in page and "my<b>robot" not in page
    assert "\\x0a" not in page and "\nRecommended: RK4" in page  # the text's lines as lines
    assert "Recommended: RK4" in done.stdout


def test_nothing_met_exits_3():
    done = _cli("spring", "--require", "position=1e-14", "--integrators", "RK4")
    assert done.returncode == 3
    assert "No recommendation: no integrator meets" in done.stdout


def test_the_api_is_the_command_and_the_json_document_is_the_advice():
    import harness

    advice = harness.advise("spring", require={"position": 1e-4}, integrators=["RK4"])
    assert isinstance(advice, harness.Advice) and advice.recommended is not None
    done = _cli("spring", "--require", "position=1e-4", "--integrators", "RK4", "--json")
    assert done.returncode == 0, done.stderr
    doc = json.loads(done.stdout)
    rec = doc["recommended"]
    assert rec["integrator"] == "RK4" and rec["met"] and rec["measured"]["position"] <= 1e-4
    assert rec["timestep"] == advice.recommended.timestep and rec["measured"] == dict(advice.recommended.measured)
    assert doc["integrators"]["RK4"]["limit"]["confirmed"] is True


@pytest.mark.parametrize(("kwargs", "error"), [
    ({"require": {}}, ValueError), ({"require": {"position": "x"}}, TypeError),
    ({"require": {"position": 1e-3}, "mjcf": "mjcf/spring.xml"}, ValueError),
    ({"require": {"position": 1e-3}, "integrators": "RK4"}, TypeError),
])
def test_the_api_refuses_bad_arguments_before_any_work(kwargs, error):
    import harness

    with pytest.raises(error):
        harness.advise("spring", **kwargs)


def test_the_model_as_it_is_is_held_to_the_requirement_where_the_reference_lacks_its_forces(tmp_path):
    """The spring with a joint limit its motion hits (amplitude 0.25 m, range ±0.1 m): the tree reference leaves
    the limit out, the comparison switches it off, and only the model as it is, by self-convergence, shows the
    impacts' error. The recommendation must meet the requirement there too, or be refused."""
    from harness.cases.own import from_mjcf

    model = tmp_path / "limited_spring.xml"
    model.write_text((ROOT / "mjcf" / "spring.xml").read_text().replace(
        'stiffness="20"', 'stiffness="20" limited="true" range="-0.1 0.1"'))
    case = from_mjcf(model)
    assert "joint limits" in dict(case.tree.uncovered)
    advice = A.advise(case, parse(["position=1e-3"]), integrators=("RK4",))
    v = advice.recommended
    assert v is not None, advice.why_none
    assert v.as_is["position"][1].startswith("self-convergence") and v.as_is["position"][0] <= 1e-3
    # the tree comparison alone would have taken a coarser step: the model as it is decided
    assert v.timestep < A.candidate(advice.curve("RK4"), advice.requirements)[0]
    # and where the impacts would need a step below the ladder, no recommendation, saying why
    strict = A.advise(case, parse(["position=1e-5"]), integrators=("RK4",))
    assert strict.recommended is None and "the model as it is" in strict.why_none


@pytest.mark.slow
def test_an_implicit_integrators_limit_is_found_by_runs_and_is_the_closed_forms(tmp_path):
    """MuJoCo's implicit integrator solves velocity terms implicitly, not a spring's stiffness: on an undamped
    spring it is semi-implicit Euler, stable iff h ω ≤ 2. A spring with ω = 2/(1.5 ms) puts that limit between two
    ladder steps (1 and 2 ms); the runs' bisection must bracket it."""
    from harness.cases.own import from_mjcf

    omega = 2.0 / 1.5e-3
    model = tmp_path / "stiff_spring.xml"
    model.write_text((ROOT / "mjcf" / "spring.xml").read_text().replace('stiffness="20"',
                                                                         f'stiffness="{M * omega ** 2:.6g}"'))
    advice = A.advise(from_mjcf(model), parse(["position=1"]), integrators=("implicit",))
    limit = advice.curve("implicit").limit
    assert limit.confirmed and limit.basis.startswith("runs:")
    grew_at = float(limit.basis.split("grew at ")[1].split(" s")[0])
    assert limit.timestep <= 2 / omega <= grew_at * 1.001
    assert grew_at / limit.timestep < 1.05


@pytest.mark.parametrize(("failing", "recommended"), [("instant.qacc", True), ("RK4.position", False),
                                                     ("converge.RK4.order_shortfall", False)])
def test_only_the_integrators_own_checks_decide_a_verification(monkeypatch, failing, recommended):
    """A check failing at the sampled states is about the model, whatever the setting: said beside the
    recommendation (a finding), never a reason to refuse it; one of the integrator's runs is such a reason."""
    from harness.core.checks import Check

    real = A.judge

    def judged(result, limits):
        return [*real(result, limits), Check(case="spring", name=failing, value=1.0, threshold=0.5, unit="1")]

    monkeypatch.setattr(A, "judge", judged)
    advice = A.advise(cases.get("spring"), parse(["position=1e-4"]), integrators=("RK4",))
    first = advice.tried[0]
    if recommended:
        assert advice.recommended is first and first.findings == (failing,) and not first.failures
    else:
        assert advice.recommended is None and failing in first.failures and failing in advice.why_none


def test_a_prediction_the_measurement_contradicts_is_never_printed(monkeypatch):
    """The ladder's prediction made wrong on purpose (4× the step it found): the verification measures the miss,
    halves the step once, misses again (RK4: 16× the requirement at 2×), and nothing is recommended."""
    real = A.candidate

    def optimistic(curve, requirements):
        h, why = real(curve, requirements)
        return 4 * h, why

    monkeypatch.setattr(A, "candidate", optimistic)
    advice = A.advise(cases.get("spring"), parse(["position=1e-4"]), integrators=("RK4",))
    assert advice.recommended is None
    assert len(advice.tried) == 2 and not any(v.met for v in advice.tried)
    assert advice.tried[1].timestep == pytest.approx(advice.tried[0].timestep / 2, rel=0.05)
    assert all(v.measured["position"] > 1e-4 for v in advice.tried)
    assert "beyond the requirement" in advice.why_none

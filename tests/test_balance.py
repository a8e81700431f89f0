"""The work–energy balance (harness/families/balance.py): its quadrature's order, a model with forces the tree does not
model passing as it is, and energy that no force accounts for failing."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from harness.cases.own import from_mjcf
from harness.engine import backends
from harness.engine.compat import set_damping
from harness.engine.integrators import EXPECTED_ORDER
from harness.engine.models import compile_model
from harness.engine.readings import Reading
from harness.families.balance import POWER, POWER_FIELDS, attribute, balance_figures, cumulative_work
from harness.reference.tree import TreeEdit

# A damped, actuated double pendulum whose lower link reaches a joint limit and a wall: limits, contacts and
# dry friction act (none of them in the tree reference), with damping and a servo doing work besides.
WALLED = """
<mujoco model="walled">
  <option timestep="0.002"/>
  <worldbody>
    <geom name="wall" type="box" size="0.05 0.5 0.5" pos="0.55 0 0.4"/>
    <body name="upper" pos="0 0 1">
      <joint name="shoulder" axis="0 1 0" damping="0.05" frictionloss="0.01"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.04"/>
      <body name="lower" pos="0 0 -0.4">
        <joint name="elbow" axis="0 1 0" limited="true" range="-1.2 1.2" damping="0.02"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.04"/>
      </body>
    </body>
  </worldbody>
  <actuator><position name="servo" joint="shoulder" kp="3" kv="0.2"/></actuator>
</mujoco>
"""


def test_the_quadrature_is_fourth_order():
    t = np.linspace(0, 1, 33)
    errors = []
    for k in (1, 2):
        tk = t[::k]
        errors.append(abs(cumulative_work(np.cos(3 * tk), tk[1] - tk[0])[-1] - np.sin(3.0) / 3))
    assert errors[1] / errors[0] > 12  # 16 for order 4; a trapezoid gives 4


@pytest.fixture(scope="module")
def walled(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("balance") / "walled.xml"
    path.write_text(WALLED)
    return path


def _balance(path: Path, power: Reading = POWER, integrators=("RK4", "Euler")):
    case = from_mjcf(path, horizon=1.0)
    ref = case.reference(compile_model(path, edit=case.prepare))
    as_is = TreeEdit(isolating=False, ctrl=case.tree.ctrl)
    return balance_figures(path, as_is, case.probe(ref.dynamics).binding, integrators=integrators, q0=ref.q0(),
                           qd0=ref.qd0(), horizon=case.horizon, energy_scale=ref.scales.energy,
                           orders=EXPECTED_ORDER, not_examined=[k for k, _ in case.tree.uncovered], power=power,
                           engine=backends.get("c"))


def test_forces_the_tree_does_not_model_are_examined_by_the_balance(walled):
    case = from_mjcf(walled, horizon=1.0)
    assert {"contacts", "joint limits", "dry friction"} <= {k for k, _ in case.tree.uncovered}
    figures, budgets, diverged, unjudged = _balance(walled)
    assert not diverged and {str(f.name) for f in figures} == set(budgets)  # a figure where judged, else n/a with why
    assert set(budgets) | set(unjudged) == {"RK4.balance", "Euler.balance"} and "Euler.balance" in budgets
    for name, budget in budgets.items():
        assert budget.passed, (name, budget)
    for why in unjudged.values():  # the wall's and the limit's impacts, unresolved at h: n/a with why, never a pass
        assert why.startswith("not judged: the balance at h, h/2, h/4 is no expansion in h")


@pytest.mark.parametrize("left_out", ["qfrc_constraint", "qfrc_actuator"])
def test_energy_no_force_accounts_for_fails(walled, left_out):
    """The same runs with one force's work left out of the accounts (the wall's, limit's and friction's rows; the
    servo): the energy it moved is then unaccounted for, and no timestep explains it."""

    def partial(model, recorded):
        return POWER.evaluate(model, {**recorded, left_out: np.zeros_like(recorded[left_out])})

    leaky = Reading(fields=POWER_FIELDS, evaluate=partial, description=f"without {left_out}")
    figures, budgets, _, _ = _balance(walled, power=leaky)
    assert budgets and all(not b.passed for b in budgets.values()), budgets
    # and the failure names the force whose work went missing
    named = {"qfrc_constraint": "the constraint rows", "qfrc_actuator": "the actuators"}[left_out]
    for figure in figures:
        assert f"the unexplained energy follows the work of {named}" in figure.description, figure.description


def test_energy_from_nothing_is_attributed_to_no_force():
    """attribute() sets the unexplained residual against each force's work: a residual that is a multiple of one
    force's work names it; a steady gain no work follows (a kick every step) names none, and says so."""
    t = np.linspace(0.0, 1.0, 1001)
    works = {"the actuators": np.sin(7 * t), "the constraint rows": 1 - np.cos(3 * t)}
    assert "follows the work of the constraint rows (+0.02" in attribute(0.02 * works["the constraint rows"], works)
    assert "follows the work of the actuators" in attribute(-0.5 * works["the actuators"] + 1e-3 * t, works)
    assert attribute(1e-3 * t**3, works).startswith("the unexplained energy follows no force's work")
    assert attribute(np.zeros_like(t), works) == ""


def test_run_case_reports_the_balance_for_a_model_with_uncovered_forces(walled):
    import harness

    v = harness.validate(mjcf=walled, integrators=["RK4"])
    assert "RK4.balance" in {c.name for c in v.checks}
    assert v.settings.tree["the model as it is"].startswith("judged by the work–energy balance")


def test_the_smallest_energy_injection_the_balance_catches_is_measured(walled):
    """An engine-side force feeding energy in (a negative damper on the shoulder) whose work the accounts leave out
    is energy from nothing to the balance: caught, with contacts, a limit and dry friction acting, at a size whose
    energy over the horizon is a small share of the motion's (the prototype of issue 29 saw 1–2 % of the peak kinetic
    energy at h on a walking model); the same force in the accounts is no finding."""
    from harness.outputs.studies.injection import cell
    from harness.studies.injection import INJECTED, injector, smallest_injection, unaccounted

    found = smallest_injection(walled, horizon=1.0)
    assert found.joint == "shoulder" and found.deciding.endswith(".balance") and not found.note, found
    assert found.size <= 1e-2 and 0 < found.of_kinetic <= 0.05, found
    assert "of the peak kinetic energy" in cell(found)

    case = from_mjcf(walled, horizon=1.0)
    ref = case.reference(compile_model(walled, edit=case.prepare))
    strong = 2 * found.rate
    edit = lambda spec: (TreeEdit(isolating=False, ctrl=case.tree.ctrl)(spec), injector("shoulder", strong)(spec))  # noqa: E731
    common = dict(integrators=("RK4", "Euler"), q0=ref.q0(), qd0=ref.qd0(), horizon=case.horizon,
                  energy_scale=ref.scales.energy, orders=EXPECTED_ORDER, not_examined=[], engine=backends.get("c"))
    binding = case.probe(ref.dynamics).binding
    _, hidden, _, _ = balance_figures(walled, edit, binding, power=unaccounted(), **common)
    _, accounted, _, _ = balance_figures(walled, edit, binding, power=POWER, **common)
    assert hidden and not any(b.passed for b in hidden.values()), hidden
    assert accounted and all(b.passed for b in accounted.values()), accounted
    assert INJECTED.fields == ("actuator_force", "actuator_velocity")


def test_energy_from_nothing_fails_where_impacts_leave_the_balance_no_expansion_in_h(walled):
    """An injection of several m g L: its impacts differ at h, h/2 and h/4, so the balance is no expansion in h, yet
    it stays far above every change between the three runs; that is energy no timestep explains, a failure, where it
    was n/a (a silent pass of the gate) before."""
    from harness.studies.injection import injector, unaccounted

    case = from_mjcf(walled, horizon=1.0)
    ref = case.reference(compile_model(walled, edit=case.prepare))
    edit = lambda spec: (TreeEdit(isolating=False, ctrl=case.tree.ctrl)(spec), injector("shoulder", 4.0)(spec))  # noqa: E731
    figures, budgets, diverged, unjudged = balance_figures(
        walled, edit, case.probe(ref.dynamics).binding, integrators=("RK4", "Euler"), q0=ref.q0(), qd0=ref.qd0(),
        horizon=case.horizon, energy_scale=ref.scales.energy, orders=EXPECTED_ORDER, not_examined=[],
        power=unaccounted(), engine=backends.get("c"))
    assert not unjudged and not diverged and set(budgets) == {"RK4.balance", "Euler.balance"}
    for name, budget in budgets.items():
        assert not budget.passed and budget.unexplained > 1.0, (name, budget)
        assert "no expansion in h" in budget.notes[0]
    for figure in figures:
        assert "above what any convergence in h explains" in figure.description


# MuJoCo's model/car/car.xml reduced (its feature, not its file): a free body on a floor, two wheels whose joints are
# damped and whose summed actuator torque is clamped (actuatorfrcrange), driven through fixed tendons
CAR = """
<mujoco model="damped wheels">
  <compiler autolimits="true"/>
  <default><joint damping=".03" actuatorfrcrange="-0.5 0.5"/></default>
  <worldbody>
    <geom type="plane" size="3 3 .01"/>
    <body name="car" pos="0 0 .03">
      <freejoint/>
      <geom name="chassis" type="box" size=".1 .05 .01" mass="0.5"/>
      <body name="left wheel" pos="-.07 .06 0" zaxis="0 1 0">
        <joint name="left"/>
        <geom type="cylinder" size=".03 .01" mass="0.05"/>
      </body>
      <body name="right wheel" pos="-.07 -.06 0" zaxis="0 1 0">
        <joint name="right"/>
        <geom type="cylinder" size=".03 .01" mass="0.05"/>
      </body>
    </body>
  </worldbody>
  <tendon>
    <fixed name="forward"><joint joint="left" coef=".5"/><joint joint="right" coef=".5"/></fixed>
    <fixed name="turn"><joint joint="left" coef="-.5"/><joint joint="right" coef=".5"/></fixed>
  </tendon>
  <actuator>
    <motor name="forward" tendon="forward" ctrlrange="-1 1"/>
    <motor name="turn" tendon="turn" ctrlrange="-1 1"/>
  </actuator>
</mujoco>
"""


@pytest.fixture(scope="module")
def car(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("car") / "car.xml"
    path.write_text(CAR)
    return path


def _damped_wheels(spec) -> None:
    for name in ("left", "right"):
        set_damping(spec.joint(name), 0.06)


@pytest.mark.slow
def test_the_wheels_damping_loss_is_accounted_for_and_extra_damping_on_the_engines_side_fails(car):
    """MuJoCo's car FAILed RK4.drift.energy (5.35e-7 against 3.8e-8): its wheels' damping loss, below a fixed 1e-6
    of the energy scale, was taken for drift. The reference's own change is now subtracted wherever it exceeds its
    tolerance, so the model passes (before: RK4.drift.energy 4.13e-7 against 7.6e-8 on this model); twice the damping on
    the engine's side alone fails the drift."""
    import harness

    case = from_mjcf(car, reference=car, horizon=1.0)
    good = harness.validate(case, integrators=["RK4"])
    failed = {c.name for c in good.checks if not c.passed and not c.known}
    assert not failed, [(c.name, c.value, c.threshold) for c in good.checks if not c.passed]
    bad = harness.validate(case, integrators=["RK4"], edit=_damped_wheels)
    assert "RK4.drift.energy" in {c.name for c in bad.checks if not c.passed}


def test_the_timestep_asked_for_reaches_the_balances_runs(walled):
    """ur5e's balance rows were byte-identical with and without --timestep (compiled at the model's own step): now the
    balance runs at the step asked for, so its figure moves with it — semi-implicit Euler's balance, its first-order
    truncation error, halves with h — and its budget still passes."""
    case = from_mjcf(walled, horizon=0.3)
    ref = case.reference(compile_model(walled, edit=case.prepare))
    as_is = TreeEdit(isolating=False, ctrl=case.tree.ctrl)

    def at(timestep):
        figures, budgets, _, _ = balance_figures(
            walled, as_is, case.probe(ref.dynamics).binding, integrators=("Euler",), q0=ref.q0(), qd0=ref.qd0(),
            horizon=case.horizon, energy_scale=ref.scales.energy, orders=EXPECTED_ORDER,
            not_examined=[k for k, _ in case.tree.uncovered], engine=backends.get("c"), timestep=timestep)
        return {str(f.name): f.value for f in figures}, budgets

    own, _ = at(None)
    half, budgets = at(0.001)  # the model's own step is 0.002
    assert own.keys() == half.keys() == {"Euler.balance"}
    assert 0.4 < half["Euler.balance"] / own["Euler.balance"] < 0.6
    assert budgets and all(b.passed for b in budgets.values())

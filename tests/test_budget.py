"""The error budget's parts: extrapolation arithmetic, the variants as MuJoCo applies them, and a budget
that passes a model whose error its settings explain and fails one whose error they do not."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from harness import cases
from harness.budget.extrapolation import (
    LINEAR_SHRINK,
    RIGID_GAIN,
    from_rigid,
    gain,
    linearity_note,
    richardson,
    to_zero,
)
from harness.cli.commands import main
from harness.core.deviation import Deviation
from harness.core.figures import FigureName
from harness.core.options import RunOptions
from harness.engine import variants as V
from harness.engine.integrators import available_integrators
from harness.engine.models import compile_model
from harness.families import convergence as orders
from harness.families.runs import RIGID_SPLITS, Runs, budgets, noise_gain, rigid_resolved, unresolved
from harness.outputs.studies.sensitivity import trials_table
from harness.pipeline.limits import load_limits
from harness.pipeline.run import run_case
from harness.pipeline.verdict import judge
from harness.studies import faults, sensitivity
from tests.conftest import shipped_run

NAME = FigureName("Euler.position")


def _dev(values, name: FigureName = NAME) -> list[Deviation]:
    return [Deviation(name, np.asarray(values, dtype=float), "scalar", "m", "", size=1.0)]


# ---------------------------------------------------------------- arithmetic
@pytest.mark.parametrize("order, kappa", [(1, 2.0), (2, 4 / 3), (4, 16 / 15)])
def test_richardson_factor(order, kappa):
    assert richardson(order) == pytest.approx(kappa)


@pytest.mark.parametrize("s", [2.0, 0.5])
def test_two_levels_extrapolate_a_line_exactly_and_three_a_parabola(s):
    eps = 0.1
    line = lambda e: 3.0 + 7.0 * e  # noqa: E731
    parabola = lambda e: 3.0 + 7.0 * e - 40.0 * e * e  # noqa: E731
    value, uncertainty = to_zero([np.array([line(eps)]), np.array([line(s * eps)])], s)
    assert value[0] == pytest.approx(3.0) and uncertainty is None
    levels = [np.array([parabola(eps * s**k)]) for k in range(3)]
    value, uncertainty = to_zero(levels, s)
    assert value[0] == pytest.approx(3.0)
    # the uncertainty is the last level's correction: quadratic minus the line through the two nearest 0
    near = (parabola(s * s * eps) - s * parabola(s * eps)) / (1 - s)
    assert uncertainty[0] == pytest.approx(3.0 - near)


def test_noise_gain_is_the_sum_of_the_weights_magnitudes():
    assert gain(2, 2.0) == pytest.approx(3.0) and gain(3, 0.5) == pytest.approx(1 / 3 + 2 + 8 / 3)
    d = _dev([0.0])
    assert noise_gain(Runs(d, d), order=1) == pytest.approx(3.0)  # 2κ − 1
    assert noise_gain(Runs(d, d), order=4) == pytest.approx(2 * 16 / 15 - 1)


# ---------------------------------------------------------------- budgets on known series
def _runs(model, *, h: float, eps: float, s: float = 2.0, fault: float = 0.0) -> Runs:
    """The runs of a figure whose value is ``model(h, eps) + fault`` at every sample."""
    t = np.linspace(0.0, 1.0, 11)

    def run(hh: float, ee: float) -> list[Deviation]:
        return _dev(model(hh, ee) * (1 + t) + fault)

    return Runs(as_is=run(h, eps), half_step=run(h / 2, eps), softness=(run(h, s * eps),),
                softness_half_step=run(h / 2, s * eps), eps_factor=s)


def test_a_budget_explains_integration_and_softness_and_their_interaction():
    bilinear = lambda h, e: 0.3 * h + 0.02 * e + 5.0 * h * e  # noqa: E731  (first order in h)
    budget = budgets(_runs(bilinear, h=1e-3, eps=1e-4), order=1, steps=1000, rtol=1e-12, solver_tolerance=0)[NAME]
    assert budget.unexplained < 1e-15 and budget.passed
    assert budget.explained["integration"] == pytest.approx(2 * (0.3 * 1e-3 + 5.0 * 1e-3 * 1e-4))
    assert budget.measured == pytest.approx(bilinear(1e-3, 1e-4) * 2)


def test_a_budget_fails_what_no_setting_explains():
    bilinear = lambda h, e: 0.3 * h + 0.02 * e  # noqa: E731
    budget = budgets(_runs(bilinear, h=1e-3, eps=1e-4, fault=1e-3), order=1, steps=1000, rtol=1e-12,
                     solver_tolerance=0)[NAME]
    assert budget.unexplained == pytest.approx(1e-3) and not budget.passed
    # below the estimates' own accuracy (1/4 of the integration part here) a fault hides: its sensitivity
    hidden = budgets(_runs(bilinear, h=1e-3, eps=1e-4, fault=1e-4), order=1, steps=1000, rtol=1e-12,
                     solver_tolerance=0)[NAME]
    assert hidden.unexplained == pytest.approx(1e-4) and hidden.passed


def _rigid_runs(model, *, h: float, eps: float, f: float, fault: float = 0.0) -> Runs:
    """The runs of a figure ``model(h, eps) + fault`` whose softness is measured down to the near-rigid 2fε, fε."""
    t = np.linspace(0.0, 1.0, 11)

    def run(hh: float, ee: float) -> list[Deviation]:
        return _dev(model(hh, ee) * (1 + t) + fault)

    return Runs(as_is=run(h, eps), half_step=run(h / 2, eps), softness=(run(h, 2 * f * eps), run(h, f * eps)),
                softness_half_step=run(h / 2, f * eps), eps_factor=0.5, rigid=f)


def test_near_rigid_levels_measure_a_softness_no_polynomial_in_eps_follows():
    """An effect linear near the rigid limit that saturates by the model's ε (a closed loop of light links at
    MuJoCo's default solimp: docs/findings/softness.md): the levels ε, ε/2, ε/4 extrapolate it to the wrong
    value and fail the model; measured down to 2fε and fε it is explained, and a fault still fails."""
    saturating = lambda h, e: 0.003 * h + 0.02 * e / (1.0 + e / 1e-2) + 0.05 * h * e  # noqa: E731
    h, eps = 1e-3, 0.1
    f = 2.0 * V.STIFFEST / eps
    three = _runs(saturating, h=h, eps=eps, s=0.5)
    three = Runs(as_is=three.as_is, half_step=three.half_step,
                 softness=(three.softness[0], _dev(saturating(h, eps / 4) * (1 + np.linspace(0.0, 1.0, 11)))),
                 softness_half_step=three.softness_half_step, eps_factor=0.5)
    assert not budgets(three, order=1, steps=1000, rtol=1e-12, solver_tolerance=0)[NAME].passed
    rigid = budgets(_rigid_runs(saturating, h=h, eps=eps, f=f), order=1, steps=1000, rtol=1e-12,
                    solver_tolerance=0)[NAME]
    assert rigid.passed and rigid.unexplained < 1e-3 * rigid.explained["softness"]
    faulty = budgets(_rigid_runs(saturating, h=h, eps=eps, f=f, fault=1e-4), order=1, steps=1000, rtol=1e-12,
                     solver_tolerance=0)[NAME]
    assert not faulty.passed and faulty.unexplained == pytest.approx(1e-4, rel=0.05)


def _slow_near_rigid(h: float, e: float) -> float:
    """A figure whose integration error at the near-rigid ε saturates in h: 0.2 h/(h + τ*(ε)), τ*(ε) = ε/8 (at the
    model's ε = 0.1 it is linear in h over h = 1e-3 … h/256; at fε = 2e-4, τ* = 2.5e-5, h/τ* runs from 40 at h to
    0.16 at h/256). Cassie's loops under ``discrete`` do so (docs/findings/softness.md, "discrete")."""
    return 0.003 * h + 0.02 * e / (1.0 + e / 1e-2) + 0.2 * h / (h + e / 8)


def _deepened_runs(model, *, h: float, eps: float, f: float, fault: float = 0.0) -> Runs:
    """As :func:`harness.families.runs._rigid_ladder` makes them: the near-rigid levels at the first h/s, h/2s,
    h/4s of RIGID_SPLITS inside the asymptotic range."""
    t = np.linspace(0.0, 1.0, 11)

    def run(hh: float, ee: float) -> list[Deviation]:
        return _dev(model(hh, ee) * (1 + t) + fault)

    base = _rigid_runs(model, h=h, eps=eps, f=f, fault=fault)
    for s in RIGID_SPLITS:
        level = tuple(run(h / k, f * eps) for k in (s, 2 * s, 4 * s))
        if rigid_resolved(level, order=1):
            break
    assert s > 1
    twice = tuple(run(h / k, 2 * f * eps) for k in (s, 2 * s, 4 * s))
    return Runs(as_is=base.as_is, half_step=base.half_step, softness=base.softness,
                softness_half_step=base.softness_half_step, eps_factor=0.5, rigid=f, rigid_ladder=(twice, level),
                rigid_split=s)


def test_near_rigid_levels_outside_the_asymptotic_range_are_taken_to_h_zero_from_deeper_runs():
    """Where the near-rigid levels' error saturates in h (outside the integrator's asymptotic range at h, h/2, h/4,
    as discrete's is on Cassie's loops), their correction from h and h/2 leaves most of it, and a legitimate model
    fails; taken from the first h/s, h/2s, h/4s inside the range, it passes, and a fault still fails."""
    h, eps = 1e-3, 0.1
    f = 2.0 * V.STIFFEST / eps
    t = np.linspace(0.0, 1.0, 11)
    at_h = tuple(_dev(_slow_near_rigid(h / k, f * eps) * (1 + t)) for k in (1, 2, 4))
    assert not rigid_resolved(at_h, order=1)
    old = budgets(_rigid_runs(_slow_near_rigid, h=h, eps=eps, f=f), order=1, steps=1000, rtol=1e-12,
                  solver_tolerance=0)[NAME]
    assert not old.passed  # what the budget did before: the false alarm
    deep = budgets(_deepened_runs(_slow_near_rigid, h=h, eps=eps, f=f), order=1, steps=1000, rtol=1e-12,
                   solver_tolerance=0)[NAME]
    assert deep.passed, (deep.unexplained, deep.limit)
    assert any("near-rigid levels" in n for n in deep.notes)
    faulty = budgets(_deepened_runs(_slow_near_rigid, h=h, eps=eps, f=f, fault=0.2), order=1, steps=1000,
                     rtol=1e-12, solver_tolerance=0)[NAME]
    assert not faulty.passed and faulty.unexplained == pytest.approx(0.2 + deep.unexplained, rel=1e-6)


def test_from_rigid_is_the_line_through_the_near_rigid_levels_and_its_whole_tail():
    line = lambda e: 3.0 + 7.0 * e  # noqa: E731
    value, uncertainty = from_rigid([np.array([50.0]), np.array([line(2e-4)]), np.array([line(1e-4)])])
    assert value[0] == pytest.approx(3.0) and uncertainty[0] == pytest.approx(7e-4)
    assert RIGID_GAIN == 3.0  # |2| + |−1|, exactly


def test_the_near_rigid_factor_brings_the_smallest_eps_to_twice_the_stiffest():
    def soft(spec: mujoco.MjSpec) -> None:
        for eq in spec.equalities:
            eq.solimp = [0.9, 0.95, 0.001, 0.5, 2.0]
    assert V.rigid_factor(_pendulum()) is None  # at the stiffest already: the levels ε and 2ε
    assert V.rigid_factor(_pendulum(soft)) == pytest.approx(2.0 * V.STIFFEST / 0.05)

    def nearly(spec: mujoco.MjSpec) -> None:  # ε 5e-4: f would be 0.4, the levels ε/2, ε/4 near rigid already
        for eq in spec.equalities:
            eq.solimp = [0.9995, 0.9995, 0.001, 0.5, 2.0]
    assert V.softness_factor(_pendulum(nearly)) == 0.5 and V.rigid_factor(_pendulum(nearly)) is None


def test_an_integrator_of_lower_order_than_documented_is_not_explained():
    second = lambda h, e: 50.0 * h * h  # noqa: E731  (a "fourth-order" method that is second order)
    budget = budgets(_runs(second, h=1e-2, eps=1e-4), order=4, steps=100, rtol=1e-12, solver_tolerance=0)[NAME]
    assert budget.unexplained == pytest.approx(0.2 * budget.measured, rel=1e-6)  # 1 − κ·3/4 of it is left
    as_documented = budgets(_runs(second, h=1e-2, eps=1e-4), order=2, steps=100, rtol=1e-12,
                            solver_tolerance=0)[NAME]
    assert as_documented.unexplained < 1e-15


# ---------------------------------------------------------------- variants as MuJoCo applies them
def _pendulum(edit=None, **kw) -> mujoco.MjModel:
    return compile_model(cases.get("pendulum").mjcf, edit=edit, **kw)


def test_refsafe_raises_a_time_constant_to_twice_the_timestep():
    model = _pendulum(timestep=0.004)
    assert V.effective_timeconst(model, [0.002, 1.0], row="equality") == pytest.approx(0.008)
    off = _pendulum(timestep=0.004, edit=lambda s: setattr(s.option, "disableflags",
                                                            int(mujoco.mjtDisableBit.mjDSBL_REFSAFE)))
    assert V.effective_timeconst(off, [0.002, 1.0], row="equality") == pytest.approx(0.002)


@pytest.mark.skipif("discrete" not in __import__("harness.engine.integrators", fromlist=["x"]).available_integrators(),
                    reason="no discrete integrator in this MuJoCo")
@pytest.mark.parametrize("timeconst, dampratio, timestep, d", [
    (0.002, 1.0, 0.001, 0.999), (0.002, 0.5, 0.001, 0.999), (0.004, 2.0, 0.001, 0.99), (0.01, 0.7, 0.002, 0.9),
    (0.002, 1.0, 0.001, 0.9999),  # capped: ε/F < 1 − mjMAXIMP
])
def test_discrete_folds_the_spring_damper_into_the_impedance_as_the_budget_assumes(timeconst, dampratio, timestep,
                                                                                    d):
    """Under ``discrete`` a row's ε is ε / (1 + 2h/τ + (h/(τζ))²), at least 1 − mjMAXIMP: measured as the
    relative force error −(A + R)⁻¹Rλ = ε at a consistent state (the exact diagonal makes R/(A + R) = ε)."""
    case = cases.get("pendulum")
    ref = case.reference(_pendulum())
    probe = case.probe(ref.dynamics)
    lam = ref.solution.multipliers([0.0])[0][0]

    def edit(spec: mujoco.MjSpec) -> None:
        for eq in spec.equalities:
            eq.solimp, eq.solref = [d, d, 0.001, 0.5, 2.0], [timeconst, dampratio]

    model = _pendulum(edit, integrator="discrete", timestep=timestep)
    data = mujoco.MjData(model)
    probe.binding.set_state(model, data, ref.q0(), ref.qd0())
    mujoco.mj_forward(model, data)
    measured = -(data.efc_force[0] - lam) / lam
    assert measured == pytest.approx(V.effective_softness(model, 1 - d, [timeconst, dampratio], row="equality"),
                                     rel=1e-6)


def test_a_variant_holds_what_it_does_not_change():
    model = _pendulum(timestep=0.004)  # τ in effect 8 ms (refsafe), ε 1e-4
    half = _pendulum(timestep=0.002, edit=V.variant(model, split=2))
    assert half.eq_solref[0][0] == pytest.approx(0.008) and 1 - half.eq_solimp[0][0] == pytest.approx(1e-4)
    softer = _pendulum(timestep=0.004, edit=V.variant(model, eps_factor=2.0))
    assert 1 - softer.eq_solimp[0][0] == pytest.approx(2e-4) and softer.eq_solimp[0][2] == pytest.approx(0.002)


def test_the_softness_factor_halves_where_it_can_and_doubles_at_the_stiffest():
    assert V.softness_factor(_pendulum()) == 2.0  # shipped: ε = 1e-4, the stiffest MuJoCo allows

    def soft(spec: mujoco.MjSpec) -> None:
        for eq in spec.equalities:
            eq.solimp = [0.9, 0.95, 0.001, 0.5, 2.0]
    assert V.softness_factor(_pendulum(soft)) == 0.5


def test_point_masses_are_bodies_whose_inertia_is_a_floor():
    assert V.point_masses(_pendulum(), 1.0) == ("bob",)
    heavier = _pendulum(lambda s: setattr(s.body("bob"), "inertia", [1e-3, 1e-3, 1e-3]))
    assert V.point_masses(heavier, 1.0) == ()


def test_the_floors_pair_holds_the_fluid_forces_off():
    """A budget part varies only what it names. MuJoCo's inertia-box fluid force is sized by the body's
    rotational inertia, which the floors' variant doubles: with a fluid, both runs of the pair have none."""
    def water(spec: mujoco.MjSpec) -> None:
        spec.option.density, spec.option.wind = 1000.0, [20.0, 0.0, 0.0]

    assert not V.has_fluid(_pendulum()) and V.has_fluid(_pendulum(water))
    base, heavier = V.floors_pair(_pendulum(), ("bob",))
    assert base is None and _pendulum(heavier).body_inertia[1].tolist() == [2e-10] * 3
    base, heavier = V.floors_pair(_pendulum(water), ("bob",))
    lighter, doubled = _pendulum(V.compose(water, base)), _pendulum(V.compose(water, heavier))
    assert lighter.opt.density == doubled.opt.density == lighter.opt.viscosity == doubled.opt.viscosity == 0.0
    assert lighter.body_inertia[1].tolist() == [1e-10] * 3 and doubled.body_inertia[1].tolist() == [2e-10] * 3


@pytest.mark.parametrize("option, integrators", [
    ('density="1000" wind="20 0 0"', None),  # the probe: exit 0, the floors "explained" the wind
    ('density="1000"', "all but RK4"),  # passed without RK4's order check
])
def test_a_fluid_force_is_not_explained_as_the_point_masss_floor(tmp_path, capsys, option, integrators):
    path = tmp_path / "fluid.xml"
    text = cases.get("pendulum").mjcf.read_text()
    path.write_text(text.replace('tolerance="1e-12">', f'tolerance="1e-12" {option}>'))
    assert option in path.read_text()
    if integrators == "all but RK4":  # those this MuJoCo offers (3.3 has no discrete)
        integrators = ",".join(name for name in available_integrators() if name != "RK4")
    args = ["check", "pendulum", "--mjcf", str(path), "-q"] + (["--integrators", integrators] if integrators else [])
    assert main(args) == 1
    assert capsys.readouterr().out.splitlines()[-1].startswith("FAIL — ")


@pytest.mark.parametrize("fault", ["drag", "viscosity", "wind"])
def test_a_fluid_fails_on_a_point_mass_at_the_size_the_catalog_claims(fault):
    """The catalog's fluids (harness/studies/faults.py; every case in tests/test_budget_matrix.py, slow) on the
    pendulum, whose bob's inertia box is the floor the budget doubles: each fails at its claimed size."""
    change = faults.by_name(fault)
    assert change.kind == "fault" and change in faults.FAULTS
    trial = sensitivity.trial(cases.get("pendulum"), change)
    assert trial.verdict == "FAIL" and trial.as_expected, trial


def _bit(kind, name: str) -> int:
    """A flag's bit, 0 where this MuJoCo lacks the flag."""
    return int(getattr(kind, name, 0))


@pytest.mark.parametrize("name, read", [
    ("noslip=10", lambda m: m.opt.noslip_iterations == 10),
    ("warmstart-off", lambda m: bool(int(m.opt.disableflags) & int(mujoco.mjtDisableBit.mjDSBL_WARMSTART))),
    ("iterations=1000", lambda m: m.opt.iterations == 1000),
    ("impratio×10", lambda m: m.opt.impratio == 100.0),
    ("other-cone", lambda m: int(m.opt.cone) == int(mujoco.mjtCone.mjCONE_PYRAMIDAL)),
    ("refsafe-off", lambda m: bool(int(m.opt.disableflags) & int(mujoco.mjtDisableBit.mjDSBL_REFSAFE))),
    ("other-jacobian", lambda m: bool(mujoco.mj_isSparse(m))),
    ("ls_tolerance=1e-3", lambda m: m.opt.ls_tolerance == 1e-3),
    ("solreffriction", lambda m: m.pair_solreffriction.tolist() == [[0.004, 1.0]]),
    ("island-toggled", lambda m: bool(int(m.opt.disableflags) & _bit(mujoco.mjtDisableBit, "mjDSBL_ISLAND"))
     or bool(int(m.opt.enableflags) & _bit(mujoco.mjtEnableBit, "mjENBL_ISLAND"))),
    ("eulerdamp-off", lambda m: bool(int(m.opt.disableflags) & int(mujoco.mjtDisableBit.mjDSBL_EULERDAMP))),
    pytest.param("diagexact-toggled",
                 lambda m: not int(m.opt.enableflags) & _bit(mujoco.mjtEnableBit, "mjENBL_DIAGEXACT"),
                 marks=pytest.mark.skipif(not hasattr(mujoco.mjtEnableBit, "mjENBL_DIAGEXACT"),
                                          reason="no diagexact flag in this MuJoCo")),
])
def test_the_solver_settings_of_the_catalog_change_what_they_name(name, read):
    """The settings MuJoCo documents as changing how constraints are solved (issue 30's item 3; every case
    passes each: tests/test_budget_matrix.py, slow) are in the catalog, each setting what it names."""
    change = faults.by_name(name)
    case = cases.get("hoop_ramp_contact" if name in ("impratio×10", "other-cone", "solreffriction") else "hoop_plane")
    assert change.kind == "setting" and not read(compile_model(case.mjcf))
    assert read(compile_model(case.mjcf, edit=change.edit(case)))


def test_impratio_times_ten_passes_on_the_contact_case():
    """Issue 30: impratio 100 on hoop_ramp_contact failed its reaction sensors at 2.4× their limit. The friction
    rows' regularizer is impratio× smaller, and the contact's solve amplifies round-off by that conditioning
    (its float64 round-off copies spread 4.5e-11 of the force, against 4.5e-12 at the shipped impratio 10):
    measured by the copies, the round-off part explains it."""
    trial = sensitivity.trial(cases.get("hoop_ramp_contact"), faults.by_name("impratio×10"))
    assert trial.verdict == "pass" and trial.as_expected, trial


def test_the_pyramidal_cone_passes_on_the_contact_case_its_margin_explained():
    """Issue 30: hoop_ramp_contact with the pyramidal cone failed qacc, the hub's acceleration and the point
    acceleration at 2.0–2.3× their limits. The pair's margin (1e-10 m: the contact active at distance 0) holds a
    reference acceleration k·margin in the contact, k = 1/(d τ ζ)² = 2.5e5 s⁻²: 2.5e-5 m/s², independent of 1 − d,
    which the softness part (linear in 1 − d) left over; the elliptic cone passed only because its softness part
    was large enough to hide it. The margin part (every margin doubled, the difference) names it."""
    trial = sensitivity.trial(cases.get("hoop_ramp_contact"), faults.by_name("other-cone"))
    assert trial.verdict == "pass" and trial.as_expected, trial
    result = shipped_run("hoop_ramp_contact")  # the case as shipped: the session's run
    qacc = result.budgets["instant.qacc"]
    # 2.5e-6 of qacc's scale against 9.5e-10 (MuJoCo 4.0.0), 3.8e-9 (3.3.0): without the part, all of it was left
    assert qacc.explained["margin"] > 100 * qacc.unexplained
    assert V.wider_margins(compile_model(cases.get("pendulum").mjcf)) is None  # no margin: no part, no run


def test_refsafe_off_passes_its_ladder_run_down_from_the_models_step():
    """refsafe off on the pendulum failed 4 order checks, 3 of them diverged (mjWARN_BADQACC at h = 4 ms):
    the ladder ran above the model's step, where the rod's 2 ms time constant, no longer raised to 2h, is
    unstable. Its ladder now runs down from h, as a user's model with equalities does; the orders pass (RK4's
    is n/a, its error on the softness's floor, saying so)."""
    case = cases.get("pendulum")
    change = faults.by_name("refsafe-off")
    model = compile_model(case.mjcf, edit=change.edit(case))
    assert orders.refsafe_off(model) and not orders.refsafe_off(compile_model(case.mjcf))
    trial = sensitivity.trial(case, change)
    assert trial.verdict == "pass" and trial.as_expected, trial
    study = orders.convergence_study(case, fast=True, edit=change.edit(case))
    assert all(max(s.dts) <= model.opt.timestep * (1 + 1e-12) for s in study.series)
    assert study.verdicts and all(s.passed for s in study.verdicts) and not any(s.diverged for s in study.series)


@pytest.mark.parametrize("name, contacts, copies", [("hoop_ramp_contact", True, 4), ("pendulum", False, 4),
                                                     ("double_pendulum", False, 0)])
def test_float64_round_off_is_measured_where_constraints_are_and_only_there(name, contacts, copies):
    """The C backend's round-off copies run on a model with constraints (a contact pair, an equality), so its
    limits hold at least their spread × PERTURBED_FACTOR; a model without keeps the assumed ROUNDOFF alone, bit for
    bit (slider_crank's redundant rows: its wrist pin's force spreads 1.8e-11 over the copies, 8× ROUNDOFF, and 1.4e-10
    with diagexact toggled, which failed its crank pin torque at 1.18× before the copies measured it)."""
    from harness.engine.backends import get
    from harness.families import COMPARISONS
    from harness.families.sampled import at_states, has_contacts

    case = cases.get(name)
    model = compile_model(case.mjcf)
    ref = case.reference(model)
    assert has_contacts(model) is contacts
    got = at_states(model, case.probe(ref.dynamics), ref, get("c"), COMPARISONS.at_states, perturbed=True)
    assert len(got.perturbed) == copies


def test_diagexact_toggled_passes_on_the_slider_crank():
    """diagexact off on slider_crank (shipped with it on) failed instant.sensor.crank_pin_torque at 1.18× its limit:
    round-off of its redundant rows' solve, 64× the assumed ROUNDOFF; measured by the copies, it passes."""
    if "slider_crank" not in cases.names() or faults.by_name("diagexact-toggled").reason_not(cases.get("slider_crank")):
        pytest.skip("no slider_crank or no diagexact flag in this MuJoCo")
    trial = sensitivity.trial(cases.get("slider_crank"), faults.by_name("diagexact-toggled"))
    assert trial.verdict == "pass" and trial.as_expected, trial


def test_contacts_settle_over_forty_response_times():
    model = compile_model(cases.get("hoop_plane").mjcf)
    assert V.contact_timeconst(model) == pytest.approx(0.002)
    assert V.SETTLE_TIMECONSTS * V.contact_timeconst(model) == pytest.approx(0.08)
    assert (1 + 40 / V.TIMECONST_FACTOR) * math.exp(-40 / V.TIMECONST_FACTOR) < 1e-10


@pytest.mark.parametrize("threshold, expected", [(3e-4, 5e-4), (1e-4, 1e-4), (1.5e-7, 2e-7), (2.0, math.nan)])
def test_the_sensitivity_search_finds_the_smallest_detected_size(threshold, expected):
    smallest_detected = sensitivity.smallest_detected

    calls = []

    def detects(size: float) -> str:
        calls.append(size)
        return "RK4.position" if size >= threshold else ""

    size, deciding = smallest_detected(detects)
    assert (math.isnan(size) and math.isnan(expected)) or size == pytest.approx(expected)
    assert deciding == ("" if math.isnan(expected) else "RK4.position")
    assert len(calls) <= 6


def test_a_catalog_trial_names_the_check_that_decided_and_its_budget():
    """A fault fails with the check furthest over its limit, and nothing of it is explained (damping is
    no setting); a legitimate setting passes, the deciding check being the one closest to its limit."""
    spring = cases.get("spring")
    damping = sensitivity.trial(spring, faults.by_name("damping"))
    assert damping.verdict == "FAIL" and damping.as_expected and damping.size == 1e-3
    assert damping.deciding is not None and not damping.deciding.passed and damping.deciding.ratio > 1e3
    heavier = sensitivity.trial(spring, faults.by_name("masses×2"))
    assert heavier.verdict == "pass" and heavier.as_expected and heavier.deciding.ratio <= 1
    assert sensitivity.trial(spring, faults.by_name("low-friction")).verdict == "n/a"
    assert "damping" in trials_table([damping, heavier])


def test_sensitivity_refuses_a_setting_named_as_a_fault(capsys):
    assert main(["sensitivity", "spring", "--faults", "masses×2"]) == 2
    assert "names settings, not faults: masses×2" in capsys.readouterr().err


def _position_runs(error, h: float) -> Runs:
    """Runs of a position figure whose value at step h is ``error(h)``, with the run at h/4."""
    t = np.linspace(0.0, 1.0, 11)
    name = FigureName("RK4.position")

    def run(hh: float) -> list[Deviation]:
        return _dev(error(hh) * (1 + t), name)

    return Runs(as_is=run(h), half_step=run(h / 2), quarter_step=run(h / 4))


def test_a_timestep_outside_the_asymptotic_range_cannot_be_budgeted():
    """Richardson needs the error to be its leading term plus a smaller rest. A series whose h, h/2, h/4
    values do not fall as h⁴ (a step a sizeable part of the period, where terms of every order are alike)
    is refused, naming why; one in the asymptotic range (a small h⁵ rest) is budgeted."""
    coarse = lambda h: 0.5 * h  # noqa: E731  (halving h halves the error: nothing like h⁴)
    why = unresolved(_position_runs(coarse, 1.0), order=4, integrator="RK4")
    assert why.startswith("unresolved: the timestep is outside RK4's asymptotic range")
    fine = lambda h: 0.3 * h**4 + 1.0 * h**5  # noqa: E731
    assert unresolved(_position_runs(fine, 0.01), order=4, integrator="RK4") == ""


def test_a_pendulum_stepped_by_a_fifth_of_its_horizon_fails_as_unresolved():
    """At h = 1 s (the period is 2 s) no integrator's error is an expansion in h: its figures fail with the
    reason, instead of passing inside a limit as large as the figure. RK4 and semi-implicit Euler are past their
    stability limits there (h ω ≈ 3 > 2√2, 2): n/a with that statement (harness/families/stability.py); the
    implicit integrators, not assessed, fail as unresolved."""
    checks = {c.name: c for c in judge(run_case(cases.get("pendulum"), RunOptions(timestep=1.0)),
                                       load_limits().for_case("pendulum"))}
    for integrator in ("RK4", "Euler"):
        check = checks[f"{integrator}.position"]
        assert check.status == "n/a" and "is beyond its stability limit" in check.reason, check
    assert not checks["implicit.position"].passed and checks["implicit.position"].reason.startswith("unresolved")


def test_a_timestep_longer_than_the_horizon_is_refused(capsys):
    assert main(["check", "pendulum", "--timestep", "9"]) == 2
    assert "the timestep 9 s is longer than the horizon 5 s" in capsys.readouterr().err


@pytest.mark.parametrize("name", ["pendulum", "atwood", "welded_pendulum", "hoop_ramp_contact", "spring"])
def test_a_roundoff_copy_moves_each_mass_by_one_ulp_and_the_motion_by_no_more_than_that(name):
    """The float32 round-off copies (harness.engine.variants.roundoff_copy, harness.budget.roundoff.PERTURBED_RUNS):
    each body's mass and each principal inertia × (1 ± ε), independent seeded signs (both drawn, the same for
    the same index, different between copies); the motion then moves by O(ε) only — the copies measure round-off,
    not another physics. Checked on the C engine in float64 at the case's initial state and a state moved off
    it (0.3 in every coordinate and velocity: constraints violated, the contact pressed), with float32's ε:
    |Δqacc| ≤ 8 ε × max|qacc| (measured at most 1.0 ε on MuJoCo 4.0.0 and 3.3.0)."""
    from harness.budget.roundoff import PERTURBED_RUNS

    if name in cases.unavailable():  # an older MuJoCo: the case is n/a there, with its measured reason
        pytest.skip(cases.unavailable()[name])
    case = cases.get(name)
    model = compile_model(case.mjcf)
    eps = float(np.finfo(np.float32).eps)
    ref = case.reference(model)
    binding = case.probe(ref.dynamics).binding
    data = mujoco.MjData(model)
    copies = [V.roundoff_copy(model, epsilon=eps, index=i) for i in range(1, PERTURBED_RUNS + 1)]
    again = V.roundoff_copy(model, epsilon=eps, index=1)
    assert np.array_equal(again.body_mass, copies[0].body_mass)
    assert len({tuple(c.body_mass) + tuple(c.body_inertia.ravel()) for c in copies}) == PERTURBED_RUNS
    for other in copies:
        massive, inertial = model.body_mass > 0, model.body_inertia > 0
        ratio = np.concatenate([other.body_mass[massive] / model.body_mass[massive],
                                other.body_inertia[inertial] / model.body_inertia[inertial]])
        assert np.allclose(np.abs(ratio - 1), eps, rtol=1e-6, atol=0)
        twin = mujoco.MjData(other)
        for shift in (0.0, 0.3):
            for d, m in ((data, model), (twin, other)):
                mujoco.mj_resetData(m, d)
                binding.set_state(m, d, np.asarray(ref.q0()) + shift, np.asarray(ref.qd0()) + shift)
                mujoco.mj_forward(m, d)
            size = float(np.max(np.abs(data.qacc))) or 1.0
            assert np.max(np.abs(twin.qacc - data.qacc)) <= 8 * eps * size, (name, shift)
    signs = np.concatenate([np.sign(c.body_mass[model.body_mass > 0] - model.body_mass[model.body_mass > 0])
                            for c in copies])
    assert (signs > 0).any() and (signs < 0).any()


def test_the_represented_model_holds_every_real_constant_in_float32():
    """harness.engine.variants.represented_model: each float64 array of the model and the physical options
    rounded to float32 and back (so the C engine in float64 runs the model a float32 backend holds); integer
    arrays untouched. The Atwood machine's 1.2 kg mass and 0.4 kg pulley are not float32 numbers."""

    model = compile_model(cases.get("atwood").mjcf)
    rounded = V.represented_model(model)
    assert np.array_equal(rounded.body_mass, model.body_mass.astype(np.float32).astype(float))
    assert not np.array_equal(rounded.body_mass, model.body_mass)
    assert rounded.opt.timestep == float(np.float32(model.opt.timestep))
    assert np.array_equal(rounded.jnt_type, model.jnt_type)


def _shares(made: dict, scale: float) -> list[float]:
    """Each budget's reference share once its reference part is × ``scale`` (the part is linear in rtol)."""
    out = []
    for b in made.values():
        own = b.tolerance["reference"] * scale
        out.append(own / (b.limit - b.tolerance["reference"] + own))
    return out


def test_the_reference_is_solved_again_only_where_its_part_passes_half_a_limit():
    """harness.budget.reference.reference_rtol: a budget whose reference part is a third of its limit needs nothing; one
    whose part is 98 % of it gets the power of ten at or below what brings it to REFERENCE_SHARE (1e-8 × 1e-4 /
    5e-3 = 2e-10 → 1e-10, where it is a third); a limit that is the reference's alone goes to the floor; a
    reference at the floor already cannot be tightened."""
    from harness.budget.reference import REFERENCE_SHARE, reference_rtol, reference_share
    from harness.core.budget import Budget

    within = {"a": Budget(measured=1.0, tolerance={"integration": 1e-3, "reference": 5e-4})}
    assert reference_rtol(within, rtol=1e-8, floor=1e-12) is None
    assert reference_share(within) == (pytest.approx(1 / 3), "a")
    over = within | {"b": Budget(measured=1.0, tolerance={"integration": 1e-4, "reference": 5e-3, "roundoff": 0.0})}
    assert reference_rtol(over, rtol=1e-8, floor=1e-12) == 1e-10
    assert max(_shares(over, 1e-10 / 1e-8)) <= REFERENCE_SHARE < max(_shares(over, 1.0))
    assert reference_share(over)[1] == "b"
    alone = {"c": Budget(measured=1.0, tolerance={"roundoff": 1e-15, "reference": 5e-3})}
    assert reference_rtol(alone, rtol=1e-8, floor=1e-12) == 1e-12
    assert reference_rtol(alone, rtol=1e-12, floor=1e-12) is None
    assert reference_share({}) == (0.0, "")


def test_a_stiff_references_tolerance_is_derived_from_its_budgets_and_stated(tmp_path, monkeypatch):
    """The whip's Radau IIA reference (tests/test_own_model.py) at STIFF_RTOL takes at most 0.1 % of any figure's
    limit: within REFERENCE_SHARE, said so. With the share asked for set to 1e-5 the same check solves the reference
    again at the derived rtol, says so, and then every budget is within the share or the reference at 1e-12; a
    tighter solve that is refused leaves the first one standing, said so."""
    import harness
    from harness.budget import reference as B
    from harness.cases.own import from_mjcf
    from harness.core.errors import RunTooLong
    from harness.pipeline import run as R
    from tests.test_own_model import WHIP

    whip = tmp_path / "whip.xml"
    whip.write_text(WHIP)
    said = harness.validate(mjcf=whip).settings.tree["reference tolerance"]
    assert said.startswith("rtol 1e-08: its part is at most") and "within REFERENCE_SHARE 50%" in said
    monkeypatch.setattr(B, "REFERENCE_SHARE", 1e-5)
    v = run_case(from_mjcf(whip), RunOptions())
    said = v.settings.tree["reference tolerance"]
    assert ", derived: at rtol 1e-08 its part was at most" in said, said
    rtol = float(said.split(",")[0].removeprefix("rtol "))
    assert 1e-12 <= rtol < 1e-8
    shares = [b.tolerance["reference"] / b.limit for b in v.budgets.values() if b.tolerance.get("reference")]
    assert shares and (max(shares) <= 1e-5 or rtol == 1e-12)
    first = R._measure

    def refused(case, options, *, stiff_rtol=R.STIFF_RTOL):
        if stiff_rtol != R.STIFF_RTOL:
            raise RunTooLong("planted: past the bounds")
        return first(case, options)

    monkeypatch.setattr(R, "_measure", refused)
    said = harness.validate(mjcf=whip).settings.tree["reference tolerance"]
    assert said.startswith("rtol 1e-08: its part is at most") and "was refused (planted: past the bounds)" in said


def test_a_softness_that_saturates_below_the_near_rigid_levels_is_said_so():
    """MuJoCo's soft force error along a direction of J M⁻¹ Jᵀ with a small eigenvalue a is r/(a + r), r ∝ ε: once ε
    is near ε* = a/Â it no longer halves with ε (Cassie's plantar loops: ε* ≈ 3e-4, above MuJoCo's stiffest 1e-4).
    The sampled budget says so where its differences 2fε→fε→fε/2 shrink less than LINEAR_SHRINK; a linear effect
    gets no note."""
    def x(e: float, star: float) -> np.ndarray:
        return np.array([0.05 * e / (e + star)])

    dev = _dev([0.0])[0]
    said = linearity_note(dev.magnitude, x(4e-4, 3e-4), x(2e-4, 3e-4), x(1e-4, 3e-4))
    assert "not linear" in said and "1.14×" in said  # (4/7 − 2/5)/(2/5 − 1/4) for ε* = 3e-4
    assert linearity_note(dev.magnitude, x(4e-4, 1.0), x(2e-4, 1.0), x(1e-4, 1.0)) == ""  # ε ≪ ε*: linear, shrink 2
    assert 1.0 < LINEAR_SHRINK < 2.0


def test_a_runs_budget_says_where_its_softness_saturates_and_only_from_runs_inside_the_asymptotic_range():
    """The runs' budget: the level fε/2 at h beside 2fε and fε. A softness saturating below them (ε* = 3e-4) gets the
    note; a linear one none; nor one whose levels had to be taken from deeper runs (at h their differences are the
    integrator's as much as the softness's)."""
    h, eps = 1e-3, 0.1
    f = 2.0 * V.STIFFEST / eps
    t = np.linspace(0.0, 1.0, 11)
    for star, noted in ((3e-4, True), (1.0, False)):
        figure = lambda hh, e, s=star: 0.003 * hh + 0.05 * e / (e + s)  # noqa: E731
        runs = _rigid_runs(figure, h=h, eps=eps, f=f)
        runs = Runs(**{**runs.__dict__, "stiffest": _dev(figure(h, f * eps / 2) * (1 + t))})
        said = budgets(runs, order=1, steps=1000, rtol=1e-12, solver_tolerance=0)[NAME].notes
        assert any("not linear" in n for n in said) == noted, said
        ladder = _deepened_runs(_slow_near_rigid, h=h, eps=eps, f=f).rigid_ladder
        deep = Runs(**{**runs.__dict__, "rigid_ladder": ladder, "rigid_split": 16})
        assert not any("not linear" in n for n in budgets(deep, order=1, steps=1000, rtol=1e-12,
                                                           solver_tolerance=0)[NAME].notes)

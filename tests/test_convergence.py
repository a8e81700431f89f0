"""Convergence study: the order fit, floor detection, verdicts that can fail, and the CLI."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from harness import cases
from harness.cli.commands import main
from harness.engine.models import compile_model, mjcf_path
from harness.families import convergence as orders
from harness.outputs.studies import convergence as cv
from harness.outputs.studies import draw, html_section, text
from harness.studies import run_studies
from harness.studies.faults import by_name
from tests.conftest import case_ids

H = np.array([32, 16, 8, 4, 2, 1, 0.5]) * 1e-3


def _series(errors, expected, dts=H) -> orders.Series:
    return orders.Series(integrator="RK4", quantity="position", unit="m", dts=tuple(dts), errors=tuple(errors),
                     fit=orders.fit_order(dts, errors), expected=expected)


# ------------------------------------------------------------- fitting
@pytest.mark.parametrize("order", [1, 2, 4])
def test_a_pure_power_law_gives_its_order(order):
    fit = orders.fit_order(H, 3.0 * H**order)
    assert fit.order == pytest.approx(order, abs=1e-9)
    assert fit.floor is None and fit.n_used == len(H)


def test_a_floor_is_detected_and_not_fitted_as_an_order():
    floor = 1e-9
    errors = 50.0 * H**4 + floor  # 50·h⁴ reaches the floor near h = 2 ms
    fit = orders.fit_order(H, errors)
    assert fit.floor == pytest.approx(floor, rel=0.1)
    assert all(st == "floor" for e, st in zip(errors, fit.status, strict=True) if e <= 10 * fit.floor)
    assert fit.order == pytest.approx(4, abs=orders.ORDER_TOLERANCE)
    # the same data fitted without the floor cut would read as a lower order
    naive = np.polyfit(np.log(H), np.log(errors), 1)[0]
    assert naive < 4 - orders.ORDER_TOLERANCE


def test_an_order_one_sequence_fails_against_expected_four():
    s = _series(0.1 * H, expected=4)
    assert s.fit.order == pytest.approx(1)
    assert s.shortfall == pytest.approx(3)
    assert s.passed is False and s.verdict == "FAIL"


def test_a_floor_dominated_series_fails_with_the_whole_expected_order():
    s = _series(np.full(len(H), 6.5e-8) * (1 + 1e-3 * H), expected=4)
    assert s.fit.floor is not None and s.fit.n_used == 0
    assert math.isnan(s.fit.order)
    assert s.shortfall == 4 and s.passed is False
    assert "no asymptotic range" in s.verdict


def test_saturated_and_diverged_points_are_left_out():
    errors = 0.01 * H
    errors[0], errors[1] = math.nan, 0.5  # diverged, saturated
    fit = orders.fit_order(H, errors, saturation=0.05)
    assert fit.status[:2] == ("diverged", "saturated")
    assert fit.order == pytest.approx(1)


@pytest.mark.parametrize("dts, errors, needle", [
    ([1e-3], [1.0], "length ≥ 2"),
    ([1e-3, 1e-3], [1.0, 2.0], "distinct"),
    ([1e-3, -1e-3], [1.0, 2.0], "positive"),
    ([1e-3, 2e-3], [1.0], "one length"),
])
def test_bad_fit_input_is_a_one_line_value_error(dts, errors, needle):
    with pytest.raises(ValueError, match=needle):
        orders.fit_order(dts, errors)


# -------------------------------------------------------- on the models
@pytest.fixture(scope="module")
def pendulum_fast() -> orders.ConvergenceStudy:
    return orders.convergence_study(cases.get("pendulum"), fast=True)


def test_expected_orders_are_the_documented_ones():
    assert orders.EXPECTED_ORDER == {"Euler": 1, "implicit": 1, "implicitfast": 1, "RK4": 4, "discrete": 1}


def test_pendulum_orders_pass_on_the_rigid_limit(pendulum_fast):
    assert pendulum_fast.constrained
    assert {s.quantity for s in pendulum_fast.verdicts} == {"position@rigid"}
    assert pendulum_fast.passed


def test_rk4_claimed_on_the_soft_pendulum_as_authored_fails(pendulum_fast):
    """The as-authored position error is dominated by the softness (refsafe: timeconst ≥ 2h, so the
    sag is O(h²)); judged against RK4's 4 it must fail — a floor is not an order."""
    raw = next(s for s in pendulum_fast.series if s.integrator == "RK4" and s.quantity == "position")
    judged = orders.Series(integrator="RK4", quantity="position", unit="m", dts=raw.dts, errors=raw.errors,
                       fit=raw.fit, expected=4.0)
    assert judged.fit.order == pytest.approx(2, abs=0.3)
    assert judged.passed is False
    soft = next(s for s in pendulum_fast.series if s.integrator == "RK4" and s.quantity == "softness")
    assert soft.fit.order == pytest.approx(2, abs=0.3)  # the part the rigid limit removes is O(h²)


def test_the_force_floor_is_the_documented_one(pendulum_fast):
    force = next(s for s in pendulum_fast.series if s.integrator == "RK4" and s.quantity == "force")
    assert force.fit.floor == pytest.approx(force.predicted_floor, rel=0.02)


def test_a_broken_model_fails_every_order_verdict():
    """Joint damping (a fault: the reference has no dissipation) leaves an error that does not shrink with
    the timestep, so no integrator converges at its order. 0.1 N m s: its effect over the ladder's 0.5 s
    exceeds even Euler's error at 4 ms (the catalog's sizes, 1e-3 and 1e-2, hide under it; RK4 alone,
    far more accurate, catches those)."""
    case = cases.get("pendulum")
    study = orders.convergence_study(case, fast=True, edit=by_name("damping").edit(case, 0.1))
    assert all(s.passed is False for s in study.verdicts)
    figs = orders.order_figures(study)
    assert all(f.value > orders.ORDER_TOLERANCE for f in figs)


def test_a_legitimate_setting_keeps_every_order():
    """Gravity 9.0 instead of 9.81 is another pendulum, and its reference is built with it: every integrator
    still converges at its documented order (a 2 % gravity error failed them all while the reference was
    the shipped model's)."""
    case = cases.get("pendulum")
    study = orders.convergence_study(case, fast=True, edit=by_name("gravity=9.0").edit(case))
    assert study.verdicts and all(s.passed for s in study.verdicts)


def _default_solimp(spec: mujoco.MjSpec) -> None:
    """MuJoCo's default solimp (0.9 0.95 0.001 0.5 2) on every equality: 1 − d = 0.05–0.1, not 1e-4."""
    for eq in spec.equalities:
        eq.solimp = [0.9, 0.95, 0.001, 0.5, 2.0]


def test_default_softness_measures_the_rk4_order_from_the_near_rigid_levels():
    """Issue 30: the pendulum's rod at MuJoCo's default solimp failed converge.RK4.order_shortfall (observed
    0.28): the rigid-limit extrapolation from ε and 2ε left its O(ε²) remainder, not RK4, to set the error, and
    the order was n/a. From the near-rigid levels fε and 2fε (issue 43: variants.rigid_factor), where the
    softness is linear, that remainder is gone: RK4's fourth order is measured, as every other integrator's."""
    case = cases.get("pendulum")
    study = orders.convergence_study(case, fast=True, edit=_default_solimp)
    rk4 = next(s for s in study.series if s.integrator == "RK4" and s.quantity == "position@rigid")
    assert rk4 in study.verdicts and rk4.passed and rk4.fit.order > 3.7, (rk4.fit, rk4.verdict)
    assert "used" in rk4.fit.status
    assert all(s.passed for s in study.verdicts) and study.passed


def test_a_fault_under_default_softness_still_fails_every_order_verdict():
    """The same soft rod with joint damping 0.1 N m s (test_a_broken_model_fails_every_order_verdict's fault):
    its error stands above the extrapolation's uncertainty, so the refit still measures a short order."""
    case = cases.get("pendulum")
    damping = by_name("damping").edit(case, 0.1)

    def edit(spec: mujoco.MjSpec) -> None:
        _default_solimp(spec)
        damping(spec)

    study = orders.convergence_study(case, fast=True, edit=edit)
    assert study.verdicts and all(s.passed is False for s in study.verdicts)


def test_points_within_their_known_floor_are_not_fitted():
    """fit_order's known floors (the extrapolation's uncertainty per step): a point within 10× of its own is
    a floor point; the others are fitted, so a short order above the floors still shows."""
    errors = 3.0 * H**2
    low = orders.fit_order(H, errors, known_floors=errors / 1e4)
    assert low.n_used == len(H) and low.order == pytest.approx(2)
    high = orders.fit_order(H, errors, known_floors=errors / 5)
    assert high.n_used == 0 and set(high.status) == {"floor"} and high.floor == pytest.approx(max(errors / 5))
    part = orders.fit_order(H, errors, known_floors=np.where(H < 4e-3, errors, 0.0))
    assert part.status.count("floor") == 3 and part.order == pytest.approx(2)
    with pytest.raises(ValueError, match="one value per point"):
        orders.fit_order(H, errors, known_floors=[1.0])


def test_double_softness_doubles_one_minus_d():
    spec = mujoco.MjSpec.from_file(str(mjcf_path("pendulum")))
    before = [1 - float(e.solimp[0]) for e in spec.equalities]
    orders.double_softness(spec)
    assert [1 - float(e.solimp[0]) for e in spec.equalities] == pytest.approx([2 * b for b in before])


def test_a_missing_integrator_is_shown_not_skipped(monkeypatch):
    present = tuple(k for k in orders.EXPECTED_ORDER if k != "discrete")
    monkeypatch.setattr(orders, "available_integrators", lambda: present)
    study = orders.convergence_study(cases.get("spring"), fast=True)
    assert "discrete" in study.unavailable and "discrete" not in {s.integrator for s in study.series}
    shown = [r for r in cv.rows(study) if r[1] == "discrete"]
    assert shown and shown[0][-1].startswith("n/a: not in MuJoCo")
    assert "discrete" in cv.text(study)


def test_uniform_acceleration_makes_rk4_exact_not_failed():
    if "atwood" not in cases.names():
        pytest.skip("atwood is not registered")
    case = cases.get("atwood")
    ref = case.reference(compile_model(case.mjcf), t_end=0.5)
    assert orders.polynomial_degree(ref, 0.5, max_degree=4) == 2
    pend = cases.get("pendulum")
    ref = pend.reference(compile_model(pend.mjcf), t_end=0.5)
    assert orders.polynomial_degree(ref, 0.5, max_degree=4) is None


def test_outputs_plot_table_html_and_figures(pendulum_fast):
    assert cv.plot(pendulum_fast).startswith(b"\x89PNG")
    studies = run_studies([cases.get("spring")], fast=True, with_softness=False, with_solvers=False)
    page = html_section(studies, draw(studies))
    assert "data:image/png;base64," in page and "<table>" in page
    figs = orders.order_figures(pendulum_fast)
    assert {f.name for f in figs} == {f"converge.{s.integrator}.order_shortfall" for s in pendulum_fast.verdicts}
    assert all(np.isfinite(f.value) for f in figs)


def test_gates_use_the_stated_tolerance(config):
    limits = {(v.basis, v.value) for name in case_ids() for k, v in config.for_case(name).items()
              if k.startswith("converge.")}
    assert limits == {("theory", orders.ORDER_TOLERANCE)}


def test_cli_converge_prints_the_table_and_exits_0(capsys):
    assert main(["converge", "spring", "--fast"]) == 0
    out = capsys.readouterr().out
    assert "order" in out and "expected" in out and "RK4" in out and "0 failed" in out


def test_cli_converge_unknown_case_exits_2(capsys):
    assert main(["converge", "nosuchcase"]) == 2
    assert "known cases" in capsys.readouterr().err


# ------------------------------------------------------------------ slow
@pytest.mark.slow
@pytest.mark.parametrize("name", case_ids())
def test_full_study_confirms_every_gated_order(name, config):
    """Every order the fast subset gates holds over the full ladder (down to h/4)."""
    study = orders.convergence_study(cases.get(name))
    gated = {k.split(".")[1] for k in config.for_case(name) if k.startswith("converge.")}
    for s in study.verdicts:
        if s.integrator in gated:
            assert s.passed, (s.integrator, s.fit.order, s.errors)
    assert name in text(run_studies([cases.get(name)], fast=True, with_softness=False, with_solvers=False))


def _force_ladder(force, dts):
    """Runs whose one connect force over t ∈ [0, 0.1] is ``force(h, t)``, each at its own step h of ``dts``."""
    from harness.core.trajectory import Trajectory

    out = []
    for h in dts:
        t = np.arange(round(0.1 / h) + 1) * h
        out.append(Trajectory(t=t, positions={}, velocities={}, multipliers={"loop": force(h, t)}))
    return out


def test_a_failed_order_says_where_the_near_rigid_level_is_outside_the_asymptotic_range():
    """Cassie's loops under ``discrete``: at the near-rigid ε the connect forces change 1.1–1.3× per halving of h at
    the ladder's steps, not 2× (docs/findings/softness.md); a first-order error c h does not get that cause."""
    dts = (1e-3, 5e-4, 2.5e-4)
    first_order = _force_ladder(lambda h, t: 10.0 + 50.0 * h * np.sin(20 * t), dts)
    assert orders.pre_asymptotic(first_order, dts, order=1) == ""
    g = lambda h: 0.5 * h / (h + 1e-3)  # noqa: E731  (an error saturating in h: h/τ from 1 to 1/4)
    saturating = _force_ladder(lambda h, t: 10.0 + g(h) * np.sin(20 * t), dts)
    said = orders.pre_asymptotic(saturating, dts, order=1)
    shrink = (g(dts[0]) - g(dts[1])) / (g(dts[1]) - g(dts[2]))
    assert "outside the integrator's asymptotic range" in said and f"{shrink:.2f}×" in said, said
    assert 1.0 < shrink < 4.0 / 3.0  # a shrink the asymptotic range of a first-order method excludes


def test_the_ladders_reference_is_evaluated_once_on_the_finest_grid_and_taken_every_mth_sample(monkeypatch):
    """The reference on each rung's grid (constraint forces: a KKT solve per sample) is the finest grid's every
    m-th sample where the grids nest, the same values as evaluated on its own (to round-off); a grid that does
    not nest is evaluated on its own."""
    from harness.reference import solutions as refmod

    case = cases.get("pendulum")  # its rod's multiplier: a KKT solve per sample (on every MuJoCo this supports)
    model = compile_model(case.mjcf)
    ref = case.reference(model)
    h = float(model.opt.timestep)
    grids = [np.arange(k * 50 + 1) * (h / k) for k in (1, 2, 4)] + [np.arange(31) * (1.5 * h)]
    evaluated = []
    real = refmod.trajectory
    monkeypatch.setattr(refmod, "trajectory", lambda r, t: evaluated.append(len(t)) or real(r, t))
    got = orders.reference_grids(ref, grids)
    assert sorted(evaluated) == [31, 201]
    for t in grids:
        alone = real(ref, t)
        mine = got[len(t) - 1]
        assert np.array_equal(mine.t, t)
        for name, values in alone.multipliers.items():
            assert np.allclose(mine.multipliers[name], values, rtol=0, atol=1e-12 * np.abs(values).max())
        for name, values in alone.positions.items():
            assert np.allclose(mine.positions[name], values, rtol=0, atol=1e-12 * np.abs(values).max())

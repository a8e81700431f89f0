"""Hoop rolling down an incline, two ways (cases ``hoop_ramp``: joint equalities;
``hoop_ramp_contact``: a real frictional contact): closed forms against the sympy
derivation, the reference and MuJoCo; the sign and frame conventions; the contact
study behind the shipped settings; the faults that trip the gates and the
legitimate settings that pass them.

Closed forms (by hand, independently of the sympy path). Rolling, with F the
friction along d on the hoop and N the normal force:

    m ẍ = m g sin α + F,   m a² φ̈ = −a F,   ẍ = a φ̈,   0 = −m g cos α + N
    ⇒  ẍ = g sin α / 2,   F = −m g sin α / 2 (uphill),   N = m g cos α.

Rolling needs |F| ≤ μ N, i.e. μ ≥ tan α / 2. Below it the hoop slides with
F = −μ N: ẍ = g (sin α − μ cos α), a φ̈ = μ g cos α, so the slip ẋ − a φ̇
grows at g (sin α − 2 μ cos α).
"""

from __future__ import annotations

import math
import re

import mujoco
import numpy as np
import pytest
import sympy as sp

from analytic import systems
from analytic.systems import hoop_ramp
from harness import cases
from harness.core.errors import UnmodelledElement
from harness.core.options import RunOptions
from harness.engine.bindings import JointBinding
from harness.engine.constraints import equality_force
from harness.engine.models import compile_model, mjcf_path
from harness.engine.readings.contact import analytic_residual, contact_force, slide_force
from harness.outputs.studies.contact import plot
from harness.pipeline import run as pipeline
from harness.studies.contact import contact_study
from tests.conftest import assert_passes, failing, shipped_run
from tests.helpers import default_pair_softness, forward_at, friction, rim_radius

P = systems.symbols("hoop_ramp")  # the parameters as sympy symbols

MODELS = ("hoop_ramp", "hoop_ramp_contact")
COORDS = ("x", "s", "phi")


def closed_forms(m, g, alpha):
    """(ẍ, λ_roll, λ_normal), typed by hand; sympy symbols or floats."""
    sin, cos = (sp.sin, sp.cos) if isinstance(alpha, sp.Basic) else (math.sin, math.cos)
    return g * sin(alpha) / 2, -m * g * sin(alpha) / 2, m * g * cos(alpha)


def rolling_state(model: mujoco.MjModel, *, x: float = 0.3, xdot: float = 0.8) -> mujoco.MjData:
    """MuJoCo data at a state on both constraints (s = a, x = a φ, ẋ = a φ̇), after mj_forward."""
    a = hoop_ramp.params_from_model(model)["a"]
    return forward_at(model, JointBinding(COORDS), [x, a, x / a], [xdot, 0.0, xdot / a])


# --- layer 1: derivation ---------------------------------------------------------------

@pytest.mark.parametrize("form", ["holonomic", "pfaffian"])
def test_sympy_derivation_gives_the_closed_forms(form) -> None:
    der = hoop_ramp.build(P, form=form).derive()
    assert [c.name for c in der.system.constraints] == ["normal", "roll"]
    assert der.jacobian == sp.Matrix([[0, 1, 0], [1, 0, -P.a]])
    qdd = [sp.Symbol(f"{c.name}_ddot", real=True) for c in der.system.q]
    lam = list(der.multiplier_symbols)
    sol = sp.solve([*der.equations, *(der.jacobian * sp.Matrix(qdd) - der.gamma)], [*qdd, *lam], dict=True)
    assert len(sol) == 1
    xdd, roll, normal = closed_forms(P.m, P.g, P.alpha)
    expected = {qdd[0]: xdd, qdd[1]: 0, qdd[2]: xdd / P.a, lam[0]: normal, lam[1]: roll}
    for symbol, value in expected.items():
        assert sp.simplify(sol[0][symbol] - value) == 0, symbol


def test_pfaffian_roll_is_the_same_system_as_the_integrated_one() -> None:
    """The seed: dx = a dφ integrates to x = aφ + x0; both forms give the same J, γ, M, F."""
    hol, pfaff = systems.build("hoop_ramp").derive(), hoop_ramp.build(P, form="pfaffian").derive()
    assert pfaff.system.constraints[1].kind == "pfaffian"
    for attr in ("jacobian", "gamma", "mass_matrix", "forcing", "constraint_rows"):
        assert sp.simplify(getattr(hol, attr) - getattr(pfaff, attr)) == sp.zeros(*getattr(hol, attr).shape)
    assert hol.holonomic_residual[1] != 0 and pfaff.holonomic_residual[1] == 0
    with pytest.raises(ValueError, match="form must be"):
        hoop_ramp.build(P, form="rolling")


def test_minimal_system_is_twice_the_mass() -> None:
    der = systems.build("hoop_ramp", minimal=True).derive()
    xdd = sp.Symbol("x_ddot", real=True)
    m, g, alpha = P.m, P.g, P.alpha
    assert sp.simplify(der.equations[0] - (2 * m * xdd - m * g * sp.sin(alpha))) == 0


# --- conventions: the two MJCFs agree with the module's docstring -------------------------

@pytest.mark.parametrize("name", MODELS)
def test_mjcf_constants_agree_with_the_parameters(name) -> None:
    model = compile_model(mjcf_path(name))
    p = hoop_ramp.params_from_model(model)
    assert (p["m"], p["a"], p["g"]) == (1.0, 0.25, 9.81)
    assert p["alpha"] == pytest.approx(math.radians(30), abs=1e-15)
    hoop = model.body("hoop")
    assert hoop.inertia == pytest.approx([p["m"] * p["a"] ** 2 / 2, p["m"] * p["a"] ** 2, p["m"] * p["a"] ** 2 / 2],
                                         rel=1e-12)  # thin hoop, axle +y
    assert model.geom("hoop").size[0] == p["a"]
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    normal = [math.sin(p["alpha"]), 0.0, math.cos(p["alpha"])]
    np.testing.assert_allclose(data.geom_xmat[model.geom("slope").id].reshape(3, 3)[:, 2], normal, atol=1e-15)
    np.testing.assert_allclose(data.xaxis[model.joint("s").id], normal, atol=1e-15)
    np.testing.assert_allclose(data.xaxis[model.joint("phi").id], [0, 1, 0], atol=1e-15)
    if name == "hoop_ramp":
        assert model.equality("roll").data[1] == p["a"]  # polycoef: x = a φ
    else:
        assert model.geom("rim").size[0] == p["a"]
        assert model.pair("rolling").friction[0] >= math.tan(p["alpha"]) / 2


@pytest.mark.parametrize("name", MODELS)
def test_positive_phi_rolls_downhill(name) -> None:
    """At ẋ = a φ̇ > 0 the hoop's material point at the contact is at rest, and the
    centre moves along d (downhill): φ̇ > 0 is the rolling sense the docstring states."""
    model = compile_model(mjcf_path(name))
    p = hoop_ramp.params_from_model(model)
    data = rolling_state(model)
    hoop = model.body("hoop").id
    normal = np.array([math.sin(p["alpha"]), 0.0, math.cos(p["alpha"])])
    jacp = np.zeros((3, model.nv))
    mujoco.mj_jac(model, data, jacp, None, data.xpos[hoop] - p["a"] * normal, hoop)
    assert np.max(np.abs(jacp @ data.qvel)) < 1e-15
    mujoco.mj_jac(model, data, jacp, None, data.xpos[hoop], hoop)
    assert (jacp @ data.qvel)[2] < 0  # going down


def test_equality_forces_are_friction_and_normal_with_their_signs() -> None:
    """efc_force of "roll" is the friction along d (negative: uphill), of "normal" the
    normal force (positive), each within the softness 1 − d of the closed form."""
    model = compile_model(mjcf_path("hoop_ramp"))
    p = hoop_ramp.params_from_model(model)
    _, roll, normal = closed_forms(p["m"], p["g"], p["alpha"])
    data = rolling_state(model)
    soft = 1 - float(model.eq_solimp[model.equality("roll").id][0])
    assert equality_force(model, data, "roll")[0] == pytest.approx(roll, rel=1.5 * soft)
    assert equality_force(model, data, "normal")[0] == pytest.approx(normal, rel=1.5 * soft)
    assert roll < 0 < normal


def test_contact_force_reader_is_the_generalized_contact_force() -> None:
    """slide_force along x and s (qfrc_constraint on those slides) equals the contact force from
    mj_contactForce along the slides' world axes (the contact is the only constraint): the frame
    is transposed and the force is the one on geom2 (the rim; MuJoCo orders a plane first). The
    plane feels the opposite force, and the hinge carries −a times the friction (its moment about
    the axle)."""
    model = compile_model(mjcf_path("hoop_ramp_contact"))
    p = hoop_ramp.params_from_model(model)
    data = rolling_state(model)
    assert data.ncon == 1 and model.geom(data.contact[0].geom2).name == "rim"
    np.testing.assert_array_equal(contact_force(model, data, "slope"), -contact_force(model, data, "rim"))
    roll = slide_force(geom="rim", joint="x")(model, data)
    normal = slide_force(geom="rim", joint="s")(model, data)
    world = contact_force(model, data, "rim")
    assert roll == pytest.approx(world @ data.xaxis[model.joint("x").id], abs=1e-12)
    assert normal == pytest.approx(world @ data.xaxis[model.joint("s").id], abs=1e-12)
    dof = {n: model.joint(n).dofadr[0] for n in COORDS}
    assert data.qfrc_constraint[dof["phi"]] == pytest.approx(-p["a"] * roll, abs=1e-12)
    _, roll_cf, normal_cf = closed_forms(p["m"], p["g"], p["alpha"])
    assert roll == pytest.approx(roll_cf, rel=1e-3) and normal == pytest.approx(normal_cf, rel=1e-3)
    with pytest.raises(ValueError, match="must be a slide"):
        slide_force(geom="rim", joint="phi")(model, data)


@pytest.mark.parametrize(("edit", "named", "s_reads"), [
    (lambda spec: setattr(spec.joint("x"), "range", [-1.0, 10.0]) or setattr(spec.joint("x"), "limited", 1),
     "a limit on slide 'x'", True),
    (lambda spec: setattr(spec.joint("x"), "frictionloss", 0.1), "friction loss on slide 'x'", True),
    (lambda spec: setattr(spec.geom("hoop"), "contype", 1), "colliding geom 'hoop'", False),
])
def test_contact_force_reader_refuses_a_model_where_more_than_the_contact_pushes(edit, named, s_reads) -> None:
    """qfrc_constraint on a slide is the contact force only if nothing else acts along it: a limit,
    friction loss or a second colliding geom on the hoop makes the reading refuse, naming it (an
    UnmodelledElement: a finding about the model, which fails its figures as not measurable, not a bad
    input); a limit or friction loss on x alone leaves the reading along s valid."""
    model = compile_model(mjcf_path("hoop_ramp_contact"), edit=edit)
    data = rolling_state(model)
    with pytest.raises(UnmodelledElement, match=re.escape(named)):
        slide_force(geom="rim", joint="x")(model, data)
    if s_reads:
        assert slide_force(geom="rim", joint="s")(model, data) > 0
    else:
        with pytest.raises(UnmodelledElement, match=re.escape(named)):
            slide_force(geom="rim", joint="s")(model, data)


def test_slip_reading_is_the_rolling_residual() -> None:
    model = compile_model(mjcf_path("hoop_ramp_contact"))
    data = mujoco.MjData(model)
    JointBinding(COORDS).set_state(model, data, [0.5, 0.24, 1.0], [1.0, 0.0, 3.0])
    slip = analytic_residual(system="hoop_ramp", constraints=("roll",), level="velocity")
    creep = analytic_residual(system="hoop_ramp", constraints=("roll",), level="position")
    depth = analytic_residual(system="hoop_ramp", constraints=("normal",), level="position")
    assert slip(model, data) == pytest.approx(abs(1.0 - 0.25 * 3.0), abs=1e-15)
    assert creep(model, data) == pytest.approx(abs(0.5 - 0.25 * 1.0), abs=1e-15)
    assert depth(model, data) == pytest.approx(0.01, abs=1e-15)
    with pytest.raises(ValueError, match="no constraint"):
        analytic_residual(system="hoop_ramp", constraints=("rod",), level="velocity")(model, data)
    with pytest.raises(ValueError, match="level must be"):
        analytic_residual(system="hoop_ramp", constraints=("roll",), level="acceleration")


# --- reference and MuJoCo against the closed forms ----------------------------------------

def test_reference_matches_closed_forms() -> None:
    case = cases.get("hoop_ramp")
    model = compile_model(mjcf_path("hoop_ramp"))
    p = hoop_ramp.params_from_model(model)
    xdd, roll, normal = closed_forms(p["m"], p["g"], p["alpha"])
    ref = case.reference(model)
    t = np.linspace(0.0, case.horizon, 201)
    q, qd = ref.solution.state(t)
    assert np.max(np.abs(q[:, 0] - (case.qd0["x"] * t + xdd * t**2 / 2))) < 1e-10
    assert np.max(np.abs(qd[:, 0] - (case.qd0["x"] + xdd * t))) < 1e-10
    np.testing.assert_allclose(ref.solution.multipliers(t), np.tile([normal, roll], (len(t), 1)), atol=1e-10)


@pytest.mark.parametrize("name", MODELS)
def test_mujoco_matches_closed_forms(name) -> None:
    """RK4 at the shipped settings: the path x(t) and both forces over the horizon."""
    result = shipped_run(name)
    p = result.settings.params
    xdd, roll, normal = closed_forms(p["m"], p["g"], p["alpha"])
    sim, t = result.simulations["RK4"], result.simulations["RK4"].t
    downhill = np.array([math.cos(p["alpha"]), 0.0, -math.sin(p["alpha"])])
    x = (sim.positions["hoop"] - sim.positions["hoop"][0]) @ downhill
    assert np.max(np.abs(x - (result.case.qd0["x"] * t + xdd * t**2 / 2))) < 5e-8
    assert np.max(np.abs(sim.multipliers["roll"] - roll)) < 1e-4 * p["m"] * p["g"]
    assert np.max(np.abs(sim.multipliers["normal"] - normal)) < 1e-4 * p["m"] * p["g"]


# --- the contact study behind the shipped settings -----------------------------------------

def test_study_row_at_shipped_settings_is_run_case() -> None:
    """A one-row study reproduces run_case's RK4 simulation and figures exactly (the same run; the force
    figures counted from the same settle time)."""
    shipped = compile_model(mjcf_path("hoop_ramp_contact")).opt
    result = contact_study("hoop_ramp_contact", cones=("elliptic",), impratios=(shipped.impratio,),
                           noslip_iterations=(shipped.noslip_iterations,), softness=("shipped",))
    row = result.shipped_row()
    run = shipped_run("hoop_ramp_contact")
    figs = {f.name: f.value for f in run.figures}
    assert row["slip_max"] == np.max(np.abs(run.simulations["RK4"].series["slip"]))
    assert row["penetration"] == figs["RK4.series.penetration"]
    assert row["force.roll"] == figs["RK4.force.roll"] and row["force.normal"] == figs["RK4.force.normal"]
    assert plot(result).startswith(b"\x89PNG")
    with pytest.raises(ValueError, match="cones must be among"):
        contact_study("hoop_ramp_contact", cones=("conical",))
    with pytest.raises(ValueError, match="no contact pair"):
        contact_study("hoop_ramp")


@pytest.mark.slow
def test_study_supports_the_shipped_contact_settings() -> None:
    """Elliptic, impratio 10, no NoSlip: the least steady slip among elliptic settings
    (impratio 1 → 10 cuts it > 10×), a friction error no worse once the contact has settled (it is
    counted from 40 response times on, as run_case counts it: 1.65e-9 m g at both impratios), and the
    MuJoCo-default softness 1e3× worse whatever the cone, impratio or NoSlip."""
    study = contact_study("hoop_ramp_contact")
    shipped = study.shipped_row()
    assert (shipped["cone"], shipped["impratio"], shipped["noslip_iterations"]) == ("elliptic", 10.0, 0)
    elliptic = [r for r in study.rows if r["softness"] == "shipped" and r["cone"] == "elliptic"]
    assert shipped["slip_late"] <= min(r["slip_late"] for r in elliptic) * 1.0001
    plain = next(r for r in elliptic if r["impratio"] == 1.0 and r["noslip_iterations"] == 0)
    assert shipped["slip_late"] < plain["slip_late"] / 10
    assert shipped["force.roll"] <= plain["force.roll"] * 1.001
    soft = [r for r in study.rows if r["softness"] == "mujoco_default"]
    assert min(r["slip_late"] for r in soft) > 1e3 * shipped["slip_late"]


# --- faults and legitimate settings -----------------------------------------------------------------------------


def test_too_little_friction_slides_with_the_coulomb_closed_form() -> None:
    mu = 0.2  # below tan α / 2 = 0.289
    result = pipeline.run_case(cases.get("hoop_ramp_contact"), RunOptions(integrators=["RK4"], edit=friction(mu)))
    p = result.settings.params
    slip = result.simulations["RK4"].series["slip"]
    growth = p["g"] * (math.sin(p["alpha"]) - 2 * mu * math.cos(p["alpha"]))
    assert slip[-1] == pytest.approx(growth * result.case.horizon, rel=0.03)
    assert {"RK4.series.slip", "RK4.force.roll", "RK4.position", "RK4.velocity"} <= failing(result)


def test_a_rim_of_another_radius_trips_its_gates() -> None:
    """The rim 10 % smaller than the hoop the analytic system rolls: the hoop sinks by 0.1 a until the rim
    touches, then rolls faster for its smaller radius. Every integrator's penetration and slip fail, and
    the motion; the normal force does not (m g cos α once settled, whatever the radius)."""
    result = pipeline.run_case(cases.get("hoop_ramp_contact"), RunOptions(edit=rim_radius(0.9)))
    expected = {f"{i}.{g}" for i in result.simulations for g in ("series.penetration", "series.slip", "position")}
    assert expected <= failing(result)


@pytest.mark.parametrize(("label", "kwargs"), [
    ("MuJoCo's default contact softness", {"edit": default_pair_softness}),
    ("timestep 10 ms", {"timestep": 0.01}),
])
def test_a_legitimate_contact_setting_passes_every_gate(label, kwargs) -> None:
    """Softer contact and a coarser step simulate the same rolling hoop less accurately: the budget's
    softness and integration parts explain it."""
    assert_passes(cases.get("hoop_ramp_contact"), kwargs, label)


def test_wrong_radius_in_the_rolling_equality_trips_its_gates() -> None:
    def polycoef(spec: mujoco.MjSpec) -> None:
        spec.equality("roll").data[1] *= 0.9

    result = pipeline.run_case(cases.get("hoop_ramp"), RunOptions(integrators=["RK4"], edit=polycoef))
    assert {"instant.force.roll", "instant.qacc", "RK4.force.roll", "RK4.position",
            "RK4.violation.roll"} <= failing(result)

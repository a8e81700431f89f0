"""Vertical hoop rolling on a plane (case ``hoop_plane``): Pfaffian rolling rows, closed
forms against the sympy derivation and the reference, the circular path, MuJoCo's contact
forces and slip, the slip theory behind the gates, the faults that trip them and the
legitimate settings that pass them.

Closed forms (by hand). With the contact force (Fx, Fy, N) on the hoop and the rolling
rows ẋ = a φ̇ cos θ, ẏ = a φ̇ sin θ:

    m ẍ = Fx,  m ÿ = Fy,  m z̈ = −m g + N,  (m a²/2) θ̈ = 0,
    m a² φ̈ = −a (Fx cos θ + Fy sin θ)

⇒ θ̈ = 0, φ̈ = 0, N = m g and (Fx, Fy) = m a φ̇ θ̇ (−sin θ, cos θ): a purely lateral force
m v θ̇ towards the centre of a circle of radius R = a φ̇ / θ̇ about C₀ + R (−sin θ₀, cos θ₀).

MuJoCo's friction rows ask J q̈ = −b J q̇ (b = 2 / timeconst at dampratio 1, no position
term) and omit J̇ q̇, so at zero slip the contact gives no lateral force at all; it comes
from a steady lateral slip v_s with b v_s = v θ̇: v_s = v θ̇ · timeconst / 2.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
import sympy as sp

from analytic import systems
from analytic.systems import hoop_plane
from harness import cases
from harness.core.options import RunOptions
from harness.engine.bindings import JointBinding
from harness.engine.models import compile_model, mjcf_path
from harness.engine.readings.contact import contact_force, fit_circle, slide_force
from harness.pipeline import run as pipeline
from harness.studies.contact import contact_study
from tests.conftest import assert_passes, assert_trips, failing, shipped_run
from tests.helpers import default_pair_softness, forward_at, friction, rim_radius

P = systems.symbols("hoop_plane")  # the parameters as sympy symbols

CASE = cases.get("hoop_plane")
COORDS = ("x", "y", "z", "theta", "phi")


def lateral_force(m, a, phi_d, theta_d, theta):
    """(Fx, Fy), typed by hand; sympy or numpy."""
    sin, cos = (sp.sin, sp.cos) if isinstance(theta, sp.Basic) else (np.sin, np.cos)
    return -m * a * phi_d * theta_d * sin(theta), m * a * phi_d * theta_d * cos(theta)


def circle(case: cases.Case, a: float) -> tuple[np.ndarray, float]:
    """Centre and radius of the analytic path, by hand from the initial state."""
    radius = a * case.qd0["phi"] / case.qd0["theta"]
    theta0 = case.q0["theta"]
    return np.array([case.q0["x"] - radius * math.sin(theta0), case.q0["y"] + radius * math.cos(theta0)]), radius


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return compile_model(mjcf_path("hoop_plane"))


# --- layer 1: derivation ---------------------------------------------------------------

def test_rows_are_the_seed_pfaffian_constraints() -> None:
    der = systems.build("hoop_plane").derive()
    theta, (xd, yd, _, _, phid) = der.system.q[3], der.system.qd
    a = P.a
    assert [(c.name, c.kind) for c in der.system.constraints] == \
        [("normal", "holonomic"), ("roll_x", "pfaffian"), ("roll_y", "pfaffian")]
    assert sp.simplify(der.constraint_rows[1:, 0] - sp.Matrix([xd - a * phid * sp.cos(theta),
                                                               yd - a * phid * sp.sin(theta)])) == sp.zeros(2, 1)
    assert der.cyclic == (theta,)  # absent from L and from every row's coefficients of q̇_θ
    assert sp.simplify(der.momenta[3] - P.m * a**2 / 2 * der.system.qd[3]) == 0


def test_sympy_derivation_gives_the_closed_forms() -> None:
    der = systems.build("hoop_plane").derive()
    qdd = [sp.Symbol(f"{c.name}_ddot", real=True) for c in der.system.q]
    lam = list(der.multiplier_symbols)
    sol = sp.solve([*der.equations, *(der.jacobian * sp.Matrix(qdd) - der.gamma)], [*qdd, *lam], dict=True)
    assert len(sol) == 1
    theta, (theta_d, phi_d) = der.system.q[3], der.system.qd[3:]
    m, g, a = P.m, P.g, P.a
    fx, fy = lateral_force(m, a, phi_d, theta_d, theta)
    expected = {qdd[0]: fx / m, qdd[1]: fy / m, qdd[2]: 0, qdd[3]: 0, qdd[4]: 0,
                lam[0]: m * g, lam[1]: fx, lam[2]: fy}
    for symbol, value in expected.items():
        assert sp.simplify(sol[0][symbol] - value) == 0, symbol


def test_pfaffian_rows_cannot_be_eliminated() -> None:
    """The seed: x and y depend on the history of θ and φ, so no embedding q = φ(s) holds."""
    full = systems.build("hoop_plane")
    x, y, z, theta, phi = full.q
    (th, ph), (th_d, ph_d) = (sp.symbols("th ph", real=True), sp.symbols("th_dot ph_dot", real=True))
    with pytest.raises(ValueError, match="does not vanish"):
        full.reduce(q=(th, ph), qd=(th_d, ph_d),
                    embedding={x: P.a * ph * sp.cos(th), y: P.a * ph * sp.sin(th),
                               z: P.a, theta: th, phi: ph})


def test_reference_runs_round_the_closed_form_circle(model) -> None:
    p = hoop_plane.params_from_model(model)
    ref = CASE.reference(model)
    t = np.linspace(0.0, CASE.horizon, 401)
    q, qd = ref.solution.state(t)
    centre, radius = circle(CASE, p["a"])
    assert np.max(np.abs(np.linalg.norm(q[:, :2] - centre, axis=1) - radius)) < 1e-10
    fit_centre, fit_radius = fit_circle(q[:, :2])
    assert np.max(np.abs(fit_centre - centre)) < 1e-10 and abs(fit_radius - radius) < 1e-10
    np.testing.assert_allclose(qd[:, 3:], np.tile([CASE.qd0["theta"], CASE.qd0["phi"]], (len(t), 1)), atol=1e-10)
    fx, fy = lateral_force(p["m"], p["a"], qd[:, 4], qd[:, 3], q[:, 3])
    lam = ref.solution.multipliers(t)
    np.testing.assert_allclose(lam, np.column_stack([np.full(len(t), p["m"] * p["g"]), fx, fy]), atol=1e-9)


# --- conventions ----------------------------------------------------------------------------

def test_mjcf_constants_agree_with_the_parameters(model) -> None:
    p = hoop_plane.params_from_model(model)
    assert (p["m"], p["a"], p["g"]) == (1.0, 0.5, 9.81)
    a, m = p["a"], p["m"]
    assert model.geom("rim").size[0] == a and model.geom("hoop").size[0] == a
    assert model.body("hoop").pos[2] == a
    assert model.body("hoop").inertia == pytest.approx([m * a**2 / 2, m * a**2, m * a**2 / 2], rel=1e-12)
    assert model.pair("rolling").friction[0] >= CASE.qd0["x"] * CASE.qd0["theta"] / p["g"]


def test_positive_phi_rolls_along_the_heading(model) -> None:
    """At ẋ = a φ̇ cos θ, ẏ = a φ̇ sin θ (θ = 0.7, φ̇ > 0) the hoop's material point at the
    contact is at rest: the hinge's sense and axle are those of the docstring."""
    a, theta, phi_d = 0.5, 0.7, 3.0
    data = forward_at(model, JointBinding(COORDS), [0.2, -0.1, a, theta, 1.1],
                      [a * phi_d * math.cos(theta), a * phi_d * math.sin(theta), 0.0, 0.4, phi_d])
    hoop = model.body("hoop").id
    jacp = np.zeros((3, model.nv))
    mujoco.mj_jac(model, data, jacp, None, data.xpos[hoop] - [0.0, 0.0, a], hoop)
    assert np.max(np.abs(jacp @ data.qvel)) < 1e-15
    np.testing.assert_allclose(data.xaxis[model.joint("phi").id], [-math.sin(theta), math.cos(theta), 0.0],
                               atol=1e-15)


def test_contact_readings_are_world_force_components(model) -> None:
    """roll_x, roll_y, normal = the contact force on the rim along world x, y, z = the
    generalized contact force on the three slides."""
    data = forward_at(model, JointBinding(COORDS), [0.0, 0.0, 0.5 - 1e-4, 0.3, 0.0], [0.2, -0.1, -0.05, 0.0, 0.0])
    world = contact_force(model, data, "rim")  # from mj_contactForce, contact by contact
    for axis, joint in enumerate(("x", "y", "z")):
        assert slide_force(geom="rim", joint=joint)(model, data) == pytest.approx(world[axis], abs=1e-12)
    assert slide_force(geom="rim", joint="z")(model, data) > 0


# --- MuJoCo against the closed forms -----------------------------------------------------------

def test_mujoco_forces_are_the_lateral_closed_form_after_settling() -> None:
    """RK4: after ``settle`` the contact force is m v θ̇ towards the circle's centre and m g up."""
    result = shipped_run("hoop_plane")
    p = result.settings.params
    sim, ref = result.simulations["RK4"], result.reference
    late = sim.t >= CASE.settle
    theta = CASE.q0["theta"] + CASE.qd0["theta"] * sim.t[late]
    fx, fy = lateral_force(p["m"], p["a"], CASE.qd0["phi"], CASE.qd0["theta"], theta)
    mg = p["m"] * p["g"]
    assert np.max(np.abs(sim.multipliers["roll_x"][late] - fx)) < 5e-4 * mg
    assert np.max(np.abs(sim.multipliers["roll_y"][late] - fy)) < 5e-4 * mg
    assert np.max(np.abs(sim.multipliers["normal"][late] - mg)) < 1e-6 * mg
    np.testing.assert_allclose(ref.multipliers["roll_y"], lateral_force(
        p["m"], p["a"], CASE.qd0["phi"], CASE.qd0["theta"], CASE.qd0["theta"] * sim.t)[1], atol=1e-9)


def test_mujoco_path_is_the_circle_within_the_slip_drift() -> None:
    """The fitted circle of MuJoCo's path: the slip v_s drifts it outward by about v_s T."""
    result = shipped_run("hoop_plane")
    centre, radius = circle(CASE, result.settings.params["a"])
    drift = 1e-3 * CASE.horizon  # v_s T, see test_slip_is_the_missing_jdot_term
    for name, sim in result.simulations.items():
        fit_centre, fit_radius = fit_circle(sim.positions["hoop"][:, :2])
        assert np.linalg.norm(fit_centre - centre) < 2 * drift, name
        assert abs(fit_radius - radius) < 2 * drift, name


def test_slip_is_the_missing_jdot_term(model) -> None:
    """MuJoCo's steady slip is v θ̇ · timeconst / 2 (dampratio 1): 1e-3 m/s at 2 ms, twice
    that at 4 ms, for every continuous-time integrator; and at a state of ideal rolling
    MuJoCo's qacc lacks the whole centripetal part (instant.qacc = 1)."""
    v, theta_d = CASE.qd0["x"], CASE.qd0["theta"]
    timeconst = float(model.pair_solref[0][0])
    result = shipped_run("hoop_plane")
    figs = {f.name: f.value for f in result.figures}
    for integrator in ("Euler", "implicit", "implicitfast", "RK4"):
        assert figs[f"{integrator}.series.slip"] == pytest.approx(v * theta_d * timeconst / 2, rel=2e-3)
    assert figs["instant.qacc"] == pytest.approx(1.0, abs=1e-3)
    assert figs["instant.point_acceleration"] == pytest.approx(1.0, abs=1e-3)

    def slower(spec: mujoco.MjSpec) -> None:
        spec.pairs[0].solref = [2 * timeconst, 1.0]

    twice = pipeline.run_case(CASE, RunOptions(integrators=["RK4"], edit=slower))
    assert twice.figure("RK4.series.slip").value == pytest.approx(v * theta_d * timeconst, rel=2e-3)


def test_p_theta_is_conserved_by_both() -> None:
    result = shipped_run("hoop_plane")
    p = result.settings.params
    expected = p["m"] * p["a"] ** 2 / 2 * CASE.qd0["theta"]
    np.testing.assert_allclose(result.reference.invariants["p_theta"], expected, rtol=1e-12)
    for sim in result.simulations.values():
        np.testing.assert_allclose(sim.invariants["p_theta"], expected, rtol=1e-12)


# --- the study, faults and legitimate settings --------------------------------------------------------------

@pytest.mark.slow
def test_study_finds_slip_independent_of_cone_impratio_noslip() -> None:
    """At the shipped softness every setting slips at v θ̇ timeconst / 2 (±1 %): the slip is
    the omitted J̇ q̇, which none of the three options adds back; MuJoCo's default (10× softer)
    solref slips ≈ 10× more."""
    study = contact_study("hoop_plane")
    shipped = [r for r in study.rows if r["softness"] == "shipped"]
    theory = CASE.qd0["x"] * CASE.qd0["theta"] * shipped[0]["solref"][0] / 2
    assert all(r["slip_late"] == pytest.approx(theory, rel=1e-2) for r in shipped)
    soft = [r for r in study.rows if r["softness"] == "mujoco_default"]
    assert all(r["slip_late"] > 8 * theory for r in soft)
    assert study.shipped_row()["cone"] == "elliptic"


# faults of the contact: too little friction to roll (the analytic system rolls without slipping) and a
# rim of another radius than the hoop's (the analytic one): slip, penetration, forces, motion
@pytest.mark.parametrize(("label", "kwargs", "expected"), [
    ("μ = 0.05 < v θ̇ / g: skids", {"edit": friction(0.05)},
     {"RK4.series.slip", "RK4.force.roll_x", "RK4.force.roll_y", "RK4.position", "RK4.velocity"}),
    ("rim radius 0.9 a", {"edit": rim_radius(0.9)},
     {"RK4.series.slip", "RK4.series.penetration", "RK4.position", "RK4.drift.energy"}),
])
def test_a_contact_fault_trips_its_gates(label, kwargs, expected) -> None:
    assert_trips(CASE, {"integrators": ["RK4"], **kwargs}, expected, label)


# legitimate settings of the contact: MuJoCo's default softness and a 10 ms step simulate the same rolling
# hoop less accurately; the budget's softness and integration parts explain it, and every gate passes
@pytest.mark.parametrize(("label", "kwargs"), [
    ("MuJoCo's default contact softness", {"edit": default_pair_softness}),
    ("timestep 10 ms", {"timestep": 0.01}),
])
def test_a_legitimate_contact_setting_passes_every_gate(label, kwargs) -> None:
    assert_passes(CASE, kwargs, label)


def test_p_theta_gates_fail_when_the_heading_is_damped() -> None:
    """A tiny damping on the heading hinge θ (1e-8 N m s) breaks the conservation of p_θ and nothing
    else the gates see: every integrator's p_θ and its drift fail, while its trajectory, contact
    forces and slip still pass."""
    from harness.engine.compat import set_damping

    result = pipeline.run_case(CASE, RunOptions(edit=lambda spec: set_damping(spec.joint("theta"), 1e-8)))
    ran = list(result.simulations)
    bad = failing(result)
    assert {f"{i}.{g}" for i in ran for g in ("p_theta", "drift.p_theta")} <= bad
    assert not {f"{i}.{g}" for i in ran for g in ("position", "force.roll_x", "force.normal", "series.slip")} & bad


def test_p_theta_reading_equals_mj_subtree_vel(model) -> None:
    """The hoop's vertical angular momentum about its centre, read from cinert and cvel over the
    subtree (the hoop spins and turns: its own inertia matters), equals mj_subtreeVel's at random
    states."""
    read = cases.get("hoop_plane").mujoco_invariants["p_theta"]
    rng = np.random.default_rng(3)
    bid = model.body("hoop").id
    for _ in range(10):
        data = forward_at(model, JointBinding(COORDS), rng.normal(size=5), rng.normal(size=5))
        mujoco.mj_subtreeVel(model, data)
        lever = data.subtree_com[bid] - data.site_xpos[model.site("centre").id]
        expected = data.subtree_angmom[bid] + model.body_subtreemass[bid] * np.cross(lever, data.subtree_linvel[bid])
        assert read(model, data) == pytest.approx(expected[2], rel=1e-13, abs=1e-15)
        assert abs(expected[2]) > 1e-3


# --- reaction sensors (harness/families/reactions.py): what holds the hoop upright ----------------------------

def _torque_against_newton_euler(model, data, dyn):
    """(MuJoCo's torque sensor at the centre, Newton–Euler's) in the world: the analytic side at MuJoCo's
    state projected onto the constraints, less the declared contact loads (its multipliers along the
    slides, at MuJoCo's contact point)."""
    from analytic.reactions import Load as AnalyticLoad
    from analytic.reactions import subtree_wrench
    from analytic.solvers import project
    from harness.engine import sensors

    q = np.array([data.qpos[model.joint(c).qposadr[0]] for c in COORDS])
    qd = np.array([data.qvel[model.joint(c).dofadr[0]] for c in COORDS])
    q, qd = project(dyn, q, qd, tol=1e-14, polish=True)
    qdd, lam = dyn.accelerations(q[None], qd[None])
    at = sensors.contact_point(model, data, "rim")[None]
    loads = [AnalyticLoad(force=lam[:, dyn.blocks[ld.constraint].start, None]
                          * data.xaxis[model.joint(ld.slide).id], at=at) for ld in CASE.wiring.loads]
    _, torque = subtree_wrench(dyn, ["hoop"], q[None], qd[None], qdd, gravity=model.opt.gravity,
                               about=data.site_xpos[model.site("centre").id][None], loads=loads)
    (sensor,) = [s for s in sensors.sensors(model) if s.name == "hoop_torque"]
    return sensors.world_reading(model, data, sensor), torque[0], qd


def test_the_upright_moment_misses_the_lateral_friction_until_the_slip_settles(model) -> None:
    """Why hoop_torque (and interaction.hoop, hoop_accel) are measured but not gated at layer 2: at a
    state of ideal rolling MuJoCo's contact has no lateral force (its friction rows omit J̇ q̇), so the
    moment holding the hoop upright lacks that force's moment about the centre, a m v θ̇ along the
    heading (by hand: the force m v θ̇ along the axle w at −a ẑ); once MuJoCo has run past ``settle``
    and slips at v θ̇ τ / 2, the sensor is Newton–Euler's with the declared contact loads (measured
    1.2e-8 m g a; bound 1e-6, the slip's own size relative to v being 1e-3)."""
    dyn = CASE.reference(model).dynamics
    data = forward_at(model, JointBinding(COORDS), [CASE.q0[c] for c in COORDS], [CASE.qd0[c] for c in COORDS])
    p = hoop_plane.params_from_model(model)
    mga = p["m"] * p["g"] * p["a"]
    got, expected, _ = _torque_against_newton_euler(model, data, dyn)
    theta = CASE.q0["theta"]
    heading = np.array([math.cos(theta), math.sin(theta), 0.0])
    v = p["a"] * CASE.qd0["phi"]
    np.testing.assert_allclose(got - expected, p["a"] * p["m"] * v * CASE.qd0["theta"] * heading, atol=1e-12)
    while data.time < 0.05:
        mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    got, expected, _ = _torque_against_newton_euler(model, data, dyn)
    assert np.linalg.norm(got - expected) < 1e-6 * mga
    assert np.linalg.norm(expected) > 0.1 * mga  # a real moment: the hoop is held upright

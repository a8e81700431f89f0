"""Spherical pendulum: derivation vs the seed, conventions of both MJCF models, the ball
binding, the MuJoCo-side p_phi, agreement of the two models, and gates that can fail."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
import sympy as sp

from analytic import systems
from analytic.systems import spherical_pendulum as sph
from harness import cases
from harness.core.errors import ModelMismatch
from harness.core.options import RunOptions
from harness.engine import compat
from harness.engine.bindings import JointBinding, velocity_map
from harness.engine.integrators import available_integrators
from harness.engine.models import compile_model, mjcf_path
from harness.engine.recording import point_state
from harness.families.sampled import point_acceleration, pull_back, sample_states
from harness.pipeline.run import run_case
from harness.reference import derivations
from mjcf.spherical_pendulum_ball import BallBinding
from tests.conftest import assert_passes, assert_trips, failing, shipped_run
from tests.helpers import armature, damping, forward_at, gravity, integrate_pos_gap, random_states

HINGE, BALL = "spherical_pendulum", "spherical_pendulum_ball"
SYM = systems.symbols("spherical_pendulum")  # the parameters as sympy symbols
COORDS = ("theta", "phi")


def _rk4_accuracy(name: str, figure: str = "RK4.position"):
    """``name`` as a test parameter; expected to fail (strictly) where a documented defect of
    this MuJoCo makes its RK4 inaccurate (harness.engine.compat.KNOWN_DEFECTS: ball joints before 4.0)."""
    why = compat.known_defect(compat.joint_types(compile_model(mjcf_path(name))), figure)
    return pytest.param(name, marks=pytest.mark.xfail(bool(why), reason=why, strict=True))


def _models() -> dict[str, tuple[mujoco.MjModel, object]]:
    return {HINGE: (compile_model(mjcf_path(HINGE)), JointBinding(COORDS)),
            BALL: (compile_model(mjcf_path(BALL)), BallBinding(COORDS))}


def _random_states(count: int, seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """(θ, φ) off the poles, rates of the case's size."""
    return random_states(count, seed, [(0.2, 2.9, 1), (-3.0, 3.0, 1)], (-3.0, 3.0))


# --- layer 1: derivation --------------------------------------------------------------


def test_equations_match_the_seed_with_theta_from_the_downward_vertical():
    d = systems.build("spherical_pendulum").derive()
    m, g, l = SYM.m, SYM.g, SYM.l
    (th, ph), (thd, phd) = d.system.q, d.system.qd
    thdd, phdd = sp.symbols("theta_ddot phi_ddot", real=True)
    # hand-typed: T = ½ m l² (θ̇² + sin²θ φ̇²); V = −m g l cos θ = seed's m g l cos θ_up with θ_up = π − θ
    assert sp.simplify(d.system.kinetic - m * l**2 * (thd**2 + sp.sin(th) ** 2 * phd**2) / 2) == 0
    assert sp.simplify(d.system.potential - (m * g * l * sp.cos(sp.pi - th))) == 0
    seed_theta_eq = (m * l**2 * thdd - m * l**2 * phd**2 * sp.sin(th) * sp.cos(th) - m * g * l * sp.sin(th))
    up = {th: sp.pi - th, thd: -thd, thdd: -thdd}  # the seed's equation with θ_up = π − θ
    assert sp.simplify(d.equations[0] + seed_theta_eq.subs(up, simultaneous=True)) == 0
    # the seed's φ equation has −2 m l² θ̇ φ̇ sinθ cosθ: a sign slip; d/dt sin²θ = +2 sinθ cosθ θ̇
    phi_eq = m * l**2 * sp.sin(th) ** 2 * phdd + 2 * m * l**2 * thd * phd * sp.sin(th) * sp.cos(th)
    assert sp.simplify(d.equations[1] - phi_eq) == 0
    assert d.cyclic == (ph,)
    assert sp.simplify(d.momenta[1] - m * l**2 * sp.sin(th) ** 2 * phd) == 0


def test_phi_equation_is_the_time_derivative_of_p_phi():
    d = systems.build("spherical_pendulum").derive()
    s = d.system
    qdd = [sp.Symbol(f"{c.name}_ddot", real=True) for c in s.q]
    p_phi = d.momenta[1]
    rate = sum(sp.diff(p_phi, c) * v + sp.diff(p_phi, v) * a for c, v, a in zip(s.q, s.qd, qdd, strict=True))
    assert sp.simplify(d.equations[1] - rate) == 0


def test_bob_acceleration_minus_gravity_points_along_the_rod():
    """Only gravity and the rod act: ẍ − g ∥ x (checks the EOM and Dynamics.point_accelerations)."""
    dyn = derivations.dynamics("spherical_pendulum", {"m": 1.3, "g": 9.81, "l": 0.7})
    q, qd = _random_states(40)
    qdd, _ = dyn.accelerations(q, qd)
    acc = dyn.point_accelerations(q, qd, qdd)[:, 0]
    x = dyn.points(q)[:, 0]
    cross = np.cross(acc - np.array([0.0, 0.0, -9.81]), x)
    assert np.max(np.linalg.norm(cross, axis=1)) < 1e-12
    # and the radial part is the centripetal one: (ẍ − g)·x = −|ẋ|² ... + gravity term cancels
    vel = dyn.point_velocities(q, qd)[:, 0]
    np.testing.assert_allclose(np.einsum("ni,ni->n", acc, x), -np.einsum("ni,ni->n", vel, vel), atol=1e-12)


# --- conventions: analytic ↔ both MJCF models -----------------------------------------


def test_params_are_read_from_each_model_and_agree():
    params = [sph.params_from_model(model) for model, _ in _models().values()]
    assert params[0] == params[1] == {"m": 1.0, "l": 1.0, "g": 9.81}


def test_bob_position_and_frame_match_the_convention_in_both_models():
    models = _models()
    dyn = derivations.dynamics(HINGE, sph.params_from_model(models[HINGE][0]))
    q, qd = _random_states(20)
    for qi, qdi in zip(q, qd, strict=True):
        (theta, phi), l = qi, dyn.params["l"]
        expected = l * np.array([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), -np.cos(theta)])
        frames = []
        for model, binding in models.values():
            data = forward_at(model, binding, qi, qdi)
            bid = model.body("bob").id
            np.testing.assert_allclose(data.xipos[bid], expected, atol=1e-15)
            np.testing.assert_allclose(data.site_xpos[model.site("pivot").id], 0.0, atol=0)
            frames.append(data.xquat[bid].copy())
        np.testing.assert_allclose(dyn.points(qi)[0], expected, atol=1e-15)
        np.testing.assert_allclose(frames[0], frames[1], atol=1e-15)


def test_ball_qvel_is_the_angular_velocity_in_the_local_frame():
    """mj_integratePos(qpos, qvel, h) reaches the orientation at (θ + h θ̇, φ + h φ̇), to O(h²),
    and the body moves exactly as in the two-hinge model (same 6D velocity)."""
    models = _models()
    model, binding = models[BALL]
    h = 1e-7
    for qi, qdi in zip(*_random_states(10), strict=True):
        gap, data, _ = integrate_pos_gap(model, binding, qi, qdi, h)
        assert gap < 1e-12
        hinge_model, hinge_binding = models[HINGE]
        hinge = forward_at(hinge_model, hinge_binding, qi, qdi)
        vel = [np.zeros(6), np.zeros(6)]
        mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_BODY, 1, vel[0], 0)
        mujoco.mj_objectVelocity(hinge_model, hinge, mujoco.mjtObj.mjOBJ_BODY, 1, vel[1], 0)
        np.testing.assert_allclose(vel[0], vel[1], atol=1e-13)


def test_ball_binding_round_trips():
    model, _ = _models()[BALL]
    for order in (COORDS, COORDS[::-1]):
        binding = BallBinding(order)
        for qi, qdi in zip(*_random_states(30, seed=7), strict=True):
            q_in, qd_in = qi if order == COORDS else qi[::-1], qdi if order == COORDS else qdi[::-1]
            data = forward_at(model, binding, q_in, qd_in)
            q_out, qd_out = binding.read_state(model, data)
            np.testing.assert_allclose(q_out, q_in, atol=1e-13)
            np.testing.assert_allclose(qd_out, qd_in, atol=1e-12)


def test_ball_velocity_map_is_what_set_state_writes_and_its_rate_is_exact():
    """qvel = B(q) q̇ as set_state writes it (both coordinate orders), and the complex-step Ḃ q̇
    against a central difference of B along q̇ (to the difference's O(h²))."""
    model, _ = _models()[BALL]
    for order in (COORDS, COORDS[::-1]):
        binding = BallBinding(order)
        for qi, qdi in zip(*_random_states(20, seed=11), strict=True):
            q_in, qd_in = (qi, qdi) if order == COORDS else (qi[::-1], qdi[::-1])
            data = forward_at(model, binding, q_in, qd_in)
            mat, rate = velocity_map(binding, model, q_in, qd_in)
            np.testing.assert_allclose(mat @ qd_in, data.qvel, rtol=0, atol=1e-15)
            h = 1e-6
            central = (binding.velocity_map(model, q_in + h * qd_in)
                       - binding.velocity_map(model, q_in - h * qd_in)) / (2 * h) @ qd_in
            np.testing.assert_allclose(rate, central, rtol=0, atol=1e-8)


def test_the_balls_qacc_is_pulled_back_by_the_kinetic_energy():
    """nv = 3 > n = 2: the twist about the rod is MuJoCo's alone (inertia ε), and its acceleration
    (ω̇ · rod = 0, no torque about the rod) is not the one the (θ, φ) frame would need. The
    kinetic-energy-weighted pull-back leaves it out (q̈ to the floor's 1e-12); qacc compared whole,
    or pulled back by unweighted least squares, is off by O(|q̈|) — why the layer weights it."""
    case = cases.get(BALL)
    model = compile_model(case.mjcf)
    ref = case.reference(model)
    binding = case.probe(ref.dynamics).binding
    q, qd = sample_states(ref)
    qdd, _ = ref.dynamics.accelerations(q, qd)
    weighted, plain, whole = [], [], []
    for qi, qdi, qddi in zip(q, qd, qdd, strict=True):
        data = forward_at(model, binding, qi, qdi)
        mat, rate = velocity_map(binding, model, qi, qdi)
        weighted.append(pull_back(mat, compat.full_mass_matrix(model, data), data.qacc - rate) - qddi)
        plain.append(np.linalg.lstsq(mat, data.qacc - rate, rcond=None)[0] - qddi)
        whole.append(data.qacc - rate - mat @ qddi)
    size = np.max(np.abs(qdd))
    assert np.max(np.abs(weighted)) / size < 1e-11
    assert np.max(np.abs(plain)) / size > 0.1 and np.max(np.abs(whole)) / size > 0.1


def test_ball_binding_rejects_what_it_cannot_bind():
    with pytest.raises(ValueError, match="theta"):
        BallBinding(("theta", "r"))
    binding = BallBinding(COORDS)
    with pytest.raises(ModelMismatch, match="no joint 'ball'"):
        binding.validate(_models()[HINGE][0])
    with pytest.raises(ModelMismatch, match="must be a ball joint"):
        BallBinding(COORDS, joint="phi").validate(_models()[HINGE][0])
    assert binding.dof_matrix(_models()[BALL][0]) is None


def test_point_acceleration_agrees_with_mujocos_accelerometer_convention():
    """J qacc + J̇ qvel = mj_objectAcceleration (after mj_rnePostConstraint), which reads a − g."""
    for model, binding in _models().values():
        for qi, qdi in zip(*_random_states(5), strict=True):
            data = forward_at(model, binding, qi, qdi)
            mujoco.mj_rnePostConstraint(model, data)
            acc6 = np.zeros(6)
            mujoco.mj_objectAcceleration(model, data, mujoco.mjtObj.mjOBJ_BODY, model.body("bob").id, acc6, 0)
            np.testing.assert_allclose(point_acceleration(model, data, "bob"), acc6[3:] + model.opt.gravity,
                                       atol=1e-12)


def test_mujoco_p_phi_is_the_bobs_vertical_angular_momentum():
    """The reading = m (x × v)_z of the bob plus its tiny spin ε ω_z;
    and = m l² sin²θ φ̇ at the state set through either binding."""
    read = cases.get(HINGE).mujoco_invariants["p_phi"]
    assert cases.get(BALL).mujoco_invariants["p_phi"] is not None
    for model, binding in _models().values():
        for qi, qdi in zip(*_random_states(10), strict=True):
            data = forward_at(model, binding, qi, qdi)
            x, v = point_state(model, data, "bob")
            orbital = model.body("bob").mass[0] * np.cross(x, v)[2]
            eps = model.body("bob").inertia[2]  # the point-mass floor: its spin adds ε φ̇
            assert abs(read(model, data) - orbital - eps * qdi[1]) < 1e-15
            assert abs(orbital - np.sin(qi[0]) ** 2 * qdi[1]) < 1e-13


# --- trajectories ---------------------------------------------------------------------


def test_orbit_precesses_away_from_the_poles():
    """θ ∈ [0.47, 1] rad (away from the two-hinge singularity at θ = 0), φ̇ > 0, not conical."""
    result = shipped_run(HINGE)
    pos = result.reference.positions["bob"]
    theta = np.arccos(-pos[:, 2] / result.settings.params["l"])
    assert 0.45 < theta.min() < 0.5 and abs(theta.max() - 1.0) < 1e-9
    phi = np.unwrap(np.arctan2(pos[:, 1], pos[:, 0]))
    assert np.all(np.diff(phi) > 0) and phi[-1] > 5 * np.pi


def test_p_phi_is_conserved_on_both_sides():
    for name in (HINGE, BALL):
        result = shipped_run(name)
        params = result.settings.params
        scale = sph.scales(params).momentum
        ref = result.reference.invariants["p_phi"]
        assert np.ptp(ref) / scale < 1e-10
        case = cases.get(name)  # p_phi(0) = m l² sin²θ0 φ̇0
        expected = params["m"] * params["l"] ** 2 * np.sin(case.q0["theta"]) ** 2 * case.qd0["phi"]
        assert abs(ref[0] - expected) < 1e-12
    # the ball has no dof matrix, so no generalized force is recorded for it
    assert shipped_run(BALL).simulations["RK4"].generalized_force is None
    assert shipped_run(HINGE).simulations["RK4"].generalized_force is not None


@pytest.mark.parametrize("name", [_rk4_accuracy(HINGE), _rk4_accuracy(BALL)])
def test_mujoco_rk4_conserves_p_phi_and_follows_the_reference(name):
    result = shipped_run(name)
    scale = sph.scales(result.settings.params).momentum
    assert np.ptp(result.simulations["RK4"].invariants["p_phi"]) / scale < 1e-10
    assert result.figure("RK4.position").value < 3e-10


@pytest.mark.parametrize("name", [_rk4_accuracy(BALL)])  # the ball's RK4 against the hinges'
def test_the_two_models_agree_under_rk4(name):
    hinge, ball = shipped_run(HINGE), shipped_run(name)
    for integrator in ("RK4",):
        a, b = hinge.simulations[integrator], ball.simulations[integrator]
        assert np.max(np.linalg.norm(a.positions["bob"] - b.positions["bob"], axis=1)) < 3e-10
        # J: the two-hinge model's own RK4 energy drift is 1.5e-10 J
        assert np.max(np.abs(a.invariants["energy"] - b.invariants["energy"])) < 5e-10


def test_the_two_models_agree_at_the_same_state():
    # instantaneous: same state in both models → same bob acceleration and kinetic energy, up to
    # the point-mass floor: the hinges tie the bob's spin (inertia ε) to φ̇, the ball leaves
    # it free, a relative difference ε/(m l² sin²θ)
    models = _models()
    eps = models[BALL][0].body("bob").inertia[0]
    for qi, qdi in zip(*_random_states(10), strict=True):
        got = []
        for model, binding in models.values():
            data = forward_at(model, binding, qi, qdi)
            got.append((point_acceleration(model, data, "bob"), data.energy[1]))
        floor = eps / np.sin(qi[0]) ** 2
        assert np.linalg.norm(got[0][0] - got[1][0]) <= 2 * floor * np.linalg.norm(got[1][0])
        assert abs(got[0][1] - got[1][1]) <= 1e-14 + 2 * floor * got[1][1]


def test_ball_case_has_the_coordinate_figures_through_its_velocity_map():
    """The ball's binding has no constant D but a velocity map B(q): the mass matrix, forcing and q̈
    figures come through it, and at the shipped model they are at the floor's level (ε = 1e-12 relative)
    and pass their budgets."""
    result = shipped_run(BALL)
    figures = {f.name: f.value for f in result.figures}
    coordinate = {"instant.mass_matrix", "instant.forcing", "instant.qacc"}
    assert {"instant.kinematics", "instant.kinetic_energy", "instant.point_acceleration"} | coordinate <= set(figures)
    assert all(figures[n] < 1e-10 for n in coordinate), {n: figures[n] for n in coordinate}
    assert not failing(result) & coordinate
    assert coordinate <= {f.name for f in shipped_run(HINGE).figures}


# --- faults fail their gates, legitimate changes pass ----------------------------------------------------


def _mass(spec: mujoco.MjSpec) -> None:
    spec.body("bob").mass = spec.body("bob").mass * 1.01


def _rod(spec: mujoco.MjSpec) -> None:
    spec.body("bob").ipos = [0.0, 0.0, -0.01]  # centre of mass 1 cm further from the pivot: l = 1.01 m


def _off_the_rod(spec: mujoco.MjSpec) -> None:
    spec.body("bob").ipos = [0.01, 0.0, 0.0]  # centre of mass 1 cm beside the rod's line


EULER_FAMILY = ["Euler", "implicit", "implicitfast", "discrete"]
RK4 = ["RK4"]
# Faults: (kwargs for run_case per case, gates that must fail). Damping the azimuth drains energy and
# p_φ. A centre of mass beside the rod's line is a bob the analytic pendulum does not have (it hangs
# on the rod): the points it moves on are elsewhere (kinematics), and so is its motion.
FAULTS = {
    # linear damping (the only kind MuJoCo 3.3 has). The ball's is capped by the spin about the rod
    # (inertia ε = 1e-12): at t = 0 its qacc is c ω_spin/ε = 1.08e12 c, and mj_step resets a simulation
    # whose |qacc| passes mjMAXVAL = 1e10, so c < 9.2e-3; and only integrators that treat damping
    # implicitly carry it (test_ball_damping_is_too_stiff_for_explicit_rk4).
    "azimuth_damping": ({HINGE: dict(edit=damping("phi", 3e-2)),
                         BALL: dict(edit=damping("ball", 8e-3),
                                    integrators=[i for i in EULER_FAMILY if i in available_integrators()])},
                        {"Euler.position", "Euler.drift.energy", "Euler.drift.p_phi", "Euler.p_phi",
                         "discrete.drift.p_phi", "implicit.p_phi", "instant.forcing", "instant.qacc"}),
    # armature: rotor inertia on the joint's dofs, which a point mass on a massless rod does not have
    # (on the ball, through B(q): Bᵀ(a·1)B adds a to M_θθ and a to M_φφ)
    "armature": ({HINGE: dict(edit=armature("phi", 1e-3), integrators=RK4),
                  BALL: dict(edit=armature("ball", 1e-3), integrators=RK4)},
                 {"instant.mass_matrix", "instant.kinetic_energy", "instant.qacc", "RK4.position"}),
    "centre_of_mass_off_the_rod": ({c: dict(edit=_off_the_rod, integrators=RK4) for c in (HINGE, BALL)},
                                   {"instant.kinematics", "RK4.position"}),
}

# Legitimate changes: another mass, gravity or rod length is another pendulum, read from the model (l is
# the pivot-to-centre-of-mass distance); a 4 ms step is explained by RK4's order. Every gate passes.
SETTINGS = {
    "mass +1%": dict(edit=_mass, integrators=RK4),
    "gravity 9.9": dict(edit=gravity([0.0, 0.0, -9.9]), integrators=RK4),
    "rod 1 cm longer": dict(edit=_rod, integrators=RK4),
    "timestep 4 ms": dict(timestep=0.004, integrators=RK4),
}


@pytest.mark.parametrize("fault", list(FAULTS))
@pytest.mark.parametrize("name", [HINGE, BALL])
def test_a_fault_trips_its_gates(name, fault):
    assert_trips(cases.get(name), FAULTS[fault][0][name], FAULTS[fault][1], fault)


@pytest.mark.parametrize("setting", list(SETTINGS))
@pytest.mark.parametrize("name", [HINGE, BALL])
def test_a_legitimate_change_passes_every_gate(name, setting):
    assert_passes(cases.get(name), SETTINGS[setting], setting)


@pytest.mark.parametrize("name", [HINGE, BALL])
def test_gravity_off_the_vertical_is_refused_naming_it(name):
    """The analytic pendulum hangs under gravity along −z (its θ is from the downward vertical): a model
    with a horizontal component is another system, refused with what is accepted, not judged."""
    with pytest.raises(ValueError, match="gravity must point along −z"):
        run_case(cases.get(name), RunOptions(edit=gravity([0.05, 0.0, -9.81]), integrators=RK4))


def test_ball_damping_is_too_stiff_for_explicit_rk4():
    """Damping on the ball acts on the spin about the rod too, whose inertia is the point-mass
    floor ε: rate c/ε = 3e9 /s, far past RK4's stability at 1 ms (why the damping variant of the
    ball case runs only the integrators that treat damping implicitly)."""
    result = run_case(cases.get(BALL), RunOptions(edit=damping("ball", 3e-3), integrators=RK4))
    assert result.diverged["RK4"].startswith("diverged: mjWARN_") and not result.simulations


def _subtree_vel_momentum(model, data, body: str, site: str) -> float:
    """The vertical angular momentum as mj_subtreeVel assembles it: about the subtree's centre of mass
    plus the transport term (an independent path to the reading's quantity)."""
    bid = model.body(body).id
    mujoco.mj_subtreeVel(model, data)
    transport = model.body_subtreemass[bid] * np.cross(data.subtree_com[bid] - data.site_xpos[model.site(site).id],
                                                       data.subtree_linvel[bid])
    return float((data.subtree_angmom[bid] + transport)[2])


def test_p_phi_reading_equals_mj_subtree_vel():
    """The reading, from cvel, ximat and body_inertia over the subtree, equals mj_subtreeVel's angular
    momentum at random states of both models, to rounding."""
    read = cases.get(HINGE).mujoco_invariants["p_phi"]
    for model, binding in _models().values():
        for qi, qdi in zip(*_random_states(10), strict=True):
            data = forward_at(model, binding, qi, qdi)
            assert read(model, data) == pytest.approx(_subtree_vel_momentum(model, data, "bob", "pivot"),
                                                      rel=1e-13, abs=1e-15)

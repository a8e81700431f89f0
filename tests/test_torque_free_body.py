"""The torque-free asymmetric rigid body on a free joint (issue 18, system 3): conventions, the free
joint's state, Euler's equations from the Lagrangian, the flip period in closed form against the
reference and MuJoCo, the conserved momenta read from MuJoCo, faults and legitimate settings."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest
import sympy as sp

from analytic.rigid import body_angular_velocity, euler_zxz
from analytic.systems import torque_free_body as tfb
from harness import cases
from harness.core.errors import ModelMismatch
from harness.core.options import RunOptions
from harness.engine import compat
from harness.engine.models import compile_model, mjcf_path
from harness.pipeline.run import run_case
from harness.reference import derivations
from harness.reference.solutions import build_reference
from mjcf.torque_free_body import FreeBinding, euler_angles, orientation
from tests.conftest import assert_passes, assert_trips, breakable, failing, judged, shipped_run
from tests.helpers import armature, damping, forward_at, integrate_pos_gap, random_states

NAME = "torque_free_body"
COORDS = tfb.COORDINATES
INERTIA = np.array(tfb.SHIPPED_INERTIA)


def _rk4_accuracy(figure: str = "RK4.position"):
    """The case as a test parameter; expected to fail (strictly) where a documented defect of this MuJoCo
    makes its RK4 inaccurate (harness.engine.compat.KNOWN_DEFECTS: free joints before 4.0)."""
    why = compat.known_defect(compat.joint_types(compile_model(mjcf_path(NAME))), figure)
    return pytest.param(NAME, marks=pytest.mark.xfail(bool(why), reason=why, strict=True))


def _model() -> mujoco.MjModel:
    return compile_model(mjcf_path(NAME))


def _random_states(count: int, seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """States in COORDS order with 0.2 < θ < π − 0.2 (off the ZXZ singularity)."""
    return random_states(count, seed, [(-1, 1, 3), (-3, 3, 1), (0.2, 2.9, 1), (-3, 3, 1)], (-5.0, 5.0))


def _rotation(q) -> np.ndarray:
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, orientation(q[3], q[4], q[5]))
    return mat.reshape(3, 3)


def _crossings(t: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Times where f changes sign, each from the cubic through the four samples around it."""
    out = []
    for k in np.flatnonzero(np.sign(f[1:]) != np.sign(f[:-1])):
        window = slice(max(k - 1, 0), min(k + 3, len(t)))
        roots = np.roots(np.polyfit(t[window] - t[k], f[window], 3))
        real = [r.real + t[k] for r in roots if abs(r.imag) < 1e-12 and 0 <= r.real <= t[k + 1] - t[k]]
        out.append(real[0])
    return np.array(out)


# --- conventions and the analytic side ----------------------------------------------------------------


def test_euler_rate_matrix_is_the_derived_body_angular_velocity():
    """The hand-typed A(θ, ψ) of the numeric side equals ω_b from Rᵀ Ṙ (analytic.rigid), derived by sympy."""
    phi, theta, psi, a, b, c = sp.symbols("phi theta psi a b c")
    omega = body_angular_velocity(euler_zxz(phi, theta, psi), (phi, theta, psi), (a, b, c))
    derived = sp.lambdify((phi, theta, psi, a, b, c), omega, "numpy")
    for qi, qdi in zip(*_random_states(10), strict=True):
        expected = np.asarray(derived(*qi[3:], *qdi[3:]), dtype=float).ravel()
        np.testing.assert_allclose(tfb.euler_rate_matrix(qi[4], qi[5]) @ qdi[3:], expected, atol=1e-14)


def test_orientation_is_r_z_r_x_r_z_and_the_angles_come_back():
    """The binding's quaternion is R = R_z(φ) R_x(θ) R_z(ψ) of analytic.rigid.euler_zxz, and
    euler_angles inverts it for 0 < θ < π."""
    phi, theta, psi = sp.symbols("phi theta psi")
    rot = sp.lambdify((phi, theta, psi), euler_zxz(phi, theta, psi), "numpy")
    for qi in _random_states(10)[0]:
        np.testing.assert_allclose(_rotation(qi), np.asarray(rot(*qi[3:]), dtype=float), atol=1e-15)
        np.testing.assert_allclose(euler_angles(orientation(*qi[3:])), qi[3:], atol=1e-13)


def test_lagrangian_gives_eulers_equations_and_a_uniform_com():
    """q̈ from the derived Lagrangian: c̈ = 0 and I ω̇_b + ω_b × I ω_b = 0 (Euler's equations) at random
    states, ω̇_b = A q̈ + Ȧ q̇ (Ȧ q̇ by complex step, exact to rounding)."""
    dyn = derivations.dynamics_of(NAME, _model())
    q, qd = _random_states(20)
    qdd, _ = dyn.accelerations(q, qd)
    h = 1e-30
    for qi, qdi, qddi in zip(q, qd, qdd, strict=True):
        rates = tfb.euler_rate_matrix(qi[4], qi[5])
        bumped = tfb.euler_rate_matrix(qi[4] + 1j * h * qdi[4], qi[5] + 1j * h * qdi[5])
        omega = rates @ qdi[3:]
        omega_dot = rates @ qddi[3:] + (bumped.imag / h) @ qdi[3:]
        np.testing.assert_allclose(qddi[:3], 0.0, atol=1e-12)
        residual = INERTIA * omega_dot + np.cross(omega, INERTIA * omega)
        assert np.max(np.abs(residual)) < 1e-12 * max(1.0, np.max(np.abs(INERTIA * omega_dot)))


def test_shipped_motion_has_its_angular_momentum_along_world_z():
    """The initial Euler state is solved so that L = R I ω_b = |L| ẑ; p_φ (the reference's) is |L|."""
    q = np.array([tfb.MOTION.q0[c] for c in COORDS])
    qd = np.array([tfb.MOTION.qd0[c] for c in COORDS])
    omega = tfb.euler_rate_matrix(q[4], q[5]) @ qd[3:]
    np.testing.assert_allclose(omega, tfb.OMEGA_BODY, atol=1e-14)
    momentum = _rotation(q) @ (INERTIA * omega)
    np.testing.assert_allclose(momentum[:2], 0.0, atol=1e-15)
    dyn = derivations.dynamics_of(NAME, _model())
    p_phi = dyn.momenta(q[None], qd[None])[0, COORDS.index("phi")]
    assert p_phi == pytest.approx(np.linalg.norm(INERTIA * omega), rel=1e-14) == pytest.approx(momentum[2], rel=1e-14)
    assert "phi" in dyn.cyclic and {"x", "y", "z"} <= set(dyn.cyclic) and "psi" not in dyn.cyclic


def _reference(omega_body, horizon: float):
    angles, rates = tfb.euler_state(tfb.SHIPPED_INERTIA, omega_body)
    q0 = dict(zip(COORDS, (0.0, 0.0, 0.0, *angles), strict=True))
    qd0 = dict(zip(COORDS, (0.0, 0.0, 0.0, *rates), strict=True))
    return build_reference(NAME, _model(), q0=q0, qd0=qd0, horizon=horizon, rtol=1e-12)


@pytest.mark.parametrize("omega_body", [tfb.OMEGA_BODY, (1.0, 10.0, 0.3)],
                         ids=["circling e3 (shipped, L^2 > 2EI2)", "circling e1 (L^2 < 2EI2)"])
def test_flip_period_closed_form_matches_the_reference(omega_body):
    """Landau–Lifshitz §37: ê₂·ẑ = sin θ cos ψ changes sign every T/2, T = 4K(k)√(I₁I₂I₃/((I₃−I₂)(L²−2EI₁)))
    (I₁ ↔ I₃ for L² < 2EI₂). The reference (rtol 1e-12) over two periods: every half period equals T/2 to
    1e-10 relative (measured: 3e-13 to 1.1e-12 s on the shipped orbit; the crossings from cubics through
    1 ms samples)."""
    period = tfb.flip_period(tfb.SHIPPED_INERTIA, omega_body)
    ref = _reference(omega_body, 2 * period)
    t = np.arange(0.0, 2 * period, 1e-3)
    q, _ = ref.solution.state(t)
    crossings = _crossings(t, np.sin(q[:, 4]) * np.cos(q[:, 5]))
    assert len(crossings) >= 3
    np.testing.assert_allclose(np.diff(crossings), period / 2, rtol=1e-10)


def test_flip_period_closed_form_in_numbers():
    """The shipped orbit: T = 3.6274 s (so ê₂ turns over every 1.8137 s); near the separatrix T grows
    like ln(1/|L² − 2EI₂|)."""
    assert tfb.flip_period(tfb.SHIPPED_INERTIA, tfb.OMEGA_BODY) == pytest.approx(3.6274202606, rel=1e-9)
    closer = tfb.flip_period(tfb.SHIPPED_INERTIA, (0.03, 10.0, 0.1))
    assert closer > 1.5 * tfb.flip_period(tfb.SHIPPED_INERTIA, tfb.OMEGA_BODY)
    with pytest.raises(ValueError, match="I1 < I2 < I3"):
        tfb.flip_period((0.03, 0.02, 0.04), tfb.OMEGA_BODY)


def test_euler_angles_stay_off_their_singularity():
    """cos θ = L₃/|L|: its max over the orbit is the closed form (L²/I₁ − 2E)/(L²(1/I₁ − 1/I₃)), 0.672
    here, → a/(a+b) = 2/3 on the separatrix; so sin θ ≥ 0.57 and the ZXZ angles are never singular."""
    period = tfb.flip_period(tfb.SHIPPED_INERTIA, tfb.OMEGA_BODY)
    ref = _reference(tfb.OMEGA_BODY, period)
    q, _ = ref.solution.state(np.linspace(0.0, period, 20001))
    bound = tfb.max_cos2_theta(tfb.SHIPPED_INERTIA, tfb.OMEGA_BODY)
    assert np.max(np.cos(q[:, 4]) ** 2) == pytest.approx(bound, abs=1e-7)
    assert bound == pytest.approx(0.67222489, abs=1e-8) and np.min(np.sin(q[:, 4])) > 0.57
    i1, i2, i3 = tfb.SHIPPED_INERTIA
    a, b = 1 / i1 - 1 / i2, 1 / i2 - 1 / i3
    assert tfb.max_cos2_theta(tfb.SHIPPED_INERTIA, (1e-6, 10.0, 1e-6)) == pytest.approx(a / (a + b), rel=1e-9)


def test_params_are_read_from_the_model():
    assert tfb.params_from_model(_model()) == {"m": 1.0, "I1": 0.02, "I2": 0.03, "I3": 0.04, "d": 0.3}


@pytest.mark.parametrize(("edit", "message"), [
    (lambda s: setattr(s.option, "gravity", [0.0, 0.0, -9.81]), "gravity must be 0"),
    (lambda s: setattr(s.body("body"), "ipos", [0.01, 0.0, 0.0]), "centre of mass must be at the body origin"),
    (lambda s: setattr(s.body("body"), "iquat", [np.cos(0.1), 0.0, 0.0, np.sin(0.1)]), "principal axes"),
    (lambda s: setattr(s.body("body"), "inertia", [0.03, 0.02, 0.04]), "must increase"),
    (lambda s: setattr(s.site("tip2"), "pos", [0.0, 0.25, 0.0]), "site 'tip2'"),
], ids=["gravity", "com offset", "turned principal axes", "moments out of order", "tip off its axis"])
def test_a_model_the_coordinates_do_not_fit_is_refused_naming_it(edit, message):
    with pytest.raises(ValueError, match=message):
        run_case(cases.get(NAME), RunOptions(edit=edit, integrators=["RK4"]))


# --- MuJoCo's free joint ----------------------------------------------------------------------------------


def test_free_joint_qvel_is_world_linear_and_local_angular_velocity():
    """mj_integratePos(qpos, qvel, h) reaches the state at q + h q̇ to O(h²): qvel's first three are the
    world velocity of the body origin, its last three the angular velocity in the body's LOCAL frame.
    The alternative reading (angular velocity in the world frame) misses by O(h |ω|)."""
    model = _model()
    binding = FreeBinding(COORDS)
    h = 1e-7
    for qi, qdi in zip(*_random_states(10), strict=True):
        gap, data, later = integrate_pos_gap(model, binding, qi, qdi, h)
        assert gap < 1e-12
        world = data.qvel.copy()
        world[3:] = _rotation(qi) @ data.qvel[3:]  # ω_world: would be qvel if it were the world frame
        wrong = data.qpos.copy()
        mujoco.mj_integratePos(model, wrong, world, h)
        assert np.max(np.abs(wrong - later.qpos)) > 1e3 * gap + 1e-10
        # the tips move as the analytic points do
        dyn = derivations.dynamics_of(NAME, model)
        velocities = dyn.point_velocities(qi[None], qdi[None])[0]
        for k, point in enumerate(dyn.point_names):
            jac = np.zeros((3, model.nv))
            if point in tfb.TIPS:
                mujoco.mj_jacSite(model, data, jac, None, model.site(point).id)
            else:
                mujoco.mj_jacBodyCom(model, data, jac, None, model.body(point).id)
            np.testing.assert_allclose(jac @ data.qvel, velocities[k], atol=1e-13)


def test_binding_round_trips_in_any_coordinate_order():
    model = _model()
    for order in (COORDS, COORDS[::-1]):
        binding = FreeBinding(order)
        for qi, qdi in zip(*_random_states(20, seed=7), strict=True):
            q_in = np.array([dict(zip(COORDS, qi, strict=True))[c] for c in order])
            qd_in = np.array([dict(zip(COORDS, qdi, strict=True))[c] for c in order])
            data = forward_at(model, binding, q_in, qd_in)
            q_out, qd_out = binding.read_state(model, data)
            np.testing.assert_allclose(q_out, q_in, atol=1e-12)
            np.testing.assert_allclose(qd_out, qd_in, atol=1e-11)


def test_velocity_map_gives_qvel_and_its_complex_step_rate():
    """qvel = B(q) q̇, and Im B(q + i h q̇)/h equals the central difference of B along q̇ (the Ḃ q̇ the
    instant layer takes)."""
    model = _model()
    binding = FreeBinding(COORDS)
    for qi, qdi in zip(*_random_states(10), strict=True):
        data = forward_at(model, binding, qi, qdi)
        np.testing.assert_allclose(binding.velocity_map(model, qi) @ qdi, data.qvel, atol=1e-15)
        complex_step = binding.velocity_map(model, qi + 1e-30j * qdi).imag / 1e-30
        delta = 1e-6
        central = (binding.velocity_map(model, qi + delta * qdi) - binding.velocity_map(model, qi - delta * qdi)) / (
            2 * delta)
        np.testing.assert_allclose(complex_step, central, atol=1e-8)


def test_binding_rejects_what_it_cannot_bind():
    with pytest.raises(ValueError, match="FreeBinding binds"):
        FreeBinding(("x", "y", "z", "theta", "phi", "r"))
    spec = mujoco.MjSpec.from_file(str(mjcf_path(NAME)))
    spec.joint("free").type = mujoco.mjtJoint.mjJNT_BALL
    with pytest.raises(ModelMismatch, match="must be a free joint"):
        FreeBinding(COORDS).validate(spec.compile())
    with pytest.raises(ModelMismatch, match="no joint 'hinge'"):
        FreeBinding(COORDS, joint="hinge").validate(_model())


def _subtree_momenta(model, data) -> tuple[np.ndarray, np.ndarray]:
    """(L about the world origin, P) as mj_subtreeVel assembles them: an independent path to the readings."""
    bid = model.body(tfb.BODY).id
    mujoco.mj_subtreeVel(model, data)
    linear = model.body_subtreemass[bid] * data.subtree_linvel[bid]
    return data.subtree_angmom[bid] + np.cross(data.subtree_com[bid], linear), linear


def test_momentum_readings_equal_mj_subtree_vel():
    model = _model()
    binding = FreeBinding(COORDS)
    read = cases.get(NAME).mujoco_invariants
    for qi, qdi in zip(*_random_states(10), strict=True):
        data = forward_at(model, binding, qi, qdi)
        angular, linear = _subtree_momenta(model, data)
        got_angular = [read[k](model, data) for k in ("L_x", "L_y", "p_phi")]
        got_linear = [read[k](model, data) for k in ("p_x", "p_y", "p_z")]
        np.testing.assert_allclose(np.ravel(got_angular), angular, rtol=1e-13, atol=1e-15)
        np.testing.assert_allclose(np.ravel(got_linear), linear, rtol=1e-13, atol=1e-15)


def test_mujoco_energy_is_the_kinetic_energy_and_no_potential():
    """flag energy: MuJoCo's (potential, kinetic) = (0, ½ m|ċ|² + ½ ω_bᵀ I ω_b) with gravity 0."""
    model = _model()
    binding = FreeBinding(COORDS)
    for qi, qdi in zip(*_random_states(5), strict=True):
        data = forward_at(model, binding, qi, qdi)
        omega = tfb.euler_rate_matrix(qi[4], qi[5]) @ qdi[3:]
        expected = 0.5 * (qdi[:3] @ qdi[:3] + omega @ (INERTIA * omega))
        assert data.energy[0] == 0.0
        assert data.energy[1] == pytest.approx(expected, rel=1e-14)


# --- the shipped run ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", [_rk4_accuracy()])
def test_mujoco_rk4_conserves_the_momenta_and_follows_the_reference(name):
    """At 1 ms RK4 (4.0: fourth order for free-joint orientations) the world L, P and the energy are held to
    1e-10 of their scales and the tips follow the reference to 1e-10 m over the flip."""
    result = shipped_run(name)
    scales = tfb.scales(result.settings.params)
    sim = result.simulations["RK4"]
    for key in ("L_x", "L_y", "p_phi"):
        assert np.ptp(sim.invariants[key]) / scales.momentum < 1e-10
    for key in ("p_x", "p_y", "p_z"):
        assert np.ptp(sim.invariants[key]) < 1e-12
    assert np.ptp(sim.invariants["energy"]) / scales.energy < 1e-10
    assert result.figure("RK4.position").value < 1e-10


def test_rk4_order_is_a_pass_on_4_0_and_the_known_defect_before():
    """Layer 4 on the free joint: RK4's observed order is 4 on MuJoCo ≥ 4.0 (measured 4.03) and 2 before
    (measured 2.00 on 3.3.0: the stages' angular velocities combined without the Runge-Kutta-Munthe-Kaas
    correction), where its failed gate carries that known defect's label and nothing else fails."""
    check = judged(shipped_run(NAME))["converge.RK4.order_shortfall"]
    if compat.version() >= (4, 0, 0):
        assert check.passed and check.value < 0.3
    else:
        assert not check.passed and "Runge-Kutta-Munthe-Kaas" in check.known
        assert check.value == pytest.approx(2.0, abs=0.1)
    assert set(failing(shipped_run(NAME))) <= {"converge.RK4.order_shortfall"}


def test_mujoco_flips_at_the_closed_form_half_period():
    """MuJoCo's own flip, seen through world positions only: ê₂·L̂ ∝ (tip2 − com)·L̂, with L̂ MuJoCo's own
    angular momentum's direction (ẑ, to 1e-10), changes sign at
    t ≈ 0.97 s and 2.78 s; the interval equals the closed-form T/2 (1.8137 s) to 1e-9 s under RK4 on
    4.0 (measured 8.6e-13 s; on 3.3.0, with its 2nd-order orientation defect, 6.2e-8 s: 1e-6 s allowed), and under
    Euler to 1e-3 s (first order at 1 ms: measured 3.9e-4 s, a 2.5× margin)."""
    result = shipped_run(NAME)
    half = tfb.flip_period(tfb.SHIPPED_INERTIA, tfb.OMEGA_BODY) / 2
    rk4_ok = not compat.known_defect(compat.joint_types(_model()), "RK4.position")
    for integrator, tolerance in (("RK4", 1e-9 if rk4_ok else 1e-6), ("Euler", 1e-3)):
        sim = result.simulations[integrator]
        momentum = np.column_stack([sim.invariants[k] for k in ("L_x", "L_y", "p_phi")])  # MuJoCo's own L
        along = momentum / np.linalg.norm(momentum, axis=1, keepdims=True)
        axis = np.sum((sim.positions["tip2"] - sim.positions[tfb.BODY]) * along, axis=1)
        crossings = _crossings(sim.t, axis)
        assert len(crossings) == 2 and 0.9 < crossings[0] < 1.0
        assert abs(np.diff(crossings)[0] - half) < tolerance


def test_com_moves_uniformly_in_mujoco():
    result = shipped_run(NAME)
    sim = result.simulations["RK4"]
    expected = np.outer(sim.t, tfb.COM_VELOCITY)
    assert np.max(np.abs(sim.positions[tfb.BODY] - expected)) < 1e-13


# --- faults fail their gates, legitimate changes pass ----------------------------------------------------


def _hidden_mass(spec: mujoco.MjSpec) -> None:
    """A welded 10 g point at (0.1, 0.1, 0) of the body frame: another body's inertia, which the analytic
    body (read from body ``body`` alone) lacks."""
    child = spec.body("body").add_body(name="hidden", pos=[0.1, 0.1, 0.0])
    child.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.01, 0, 0], mass=0.01, contype=0, conaffinity=0)


def _inertia(spec: mujoco.MjSpec) -> None:
    spec.body("body").inertia = [0.021, 0.03, 0.04]


def _mass(spec: mujoco.MjSpec) -> None:
    spec.body("body").mass = 2.0


def _tips(spec: mujoco.MjSpec) -> None:
    for k, tip in enumerate(tfb.TIPS):
        pos = [0.0, 0.0, 0.0]
        pos[k] = 0.25
        spec.site(tip).pos = pos


def _cg(spec: mujoco.MjSpec) -> None:
    spec.option.solver = mujoco.mjtSolver.mjSOL_CG


RK4 = ["RK4"]
# Faults: (kwargs for run_case, gates that must fail). Damping on the free joint is an external force
# and torque (−c qvel): the energy, L and P drain, and the forcing carries −c qvel. Armature adds c to
# the diagonal of M in the joint's dofs (a mass and an isotropic inertia in the body frame that no body
# has): the mass matrix is another, and as MuJoCo's bias forces come from the bodies alone (no
# gyroscopic term for the armature) its own L is no longer conserved either (drift.L_x fails). A hidden
# welded mass makes another rigid body: still torque-free (its drift gates pass,
# test_hidden_mass_leaves_the_body_torque_free), but not the one the reference reads.
FAULTS = {
    "free_joint_damping": (dict(edit=damping("free", 1e-3), integrators=RK4),
                           {"instant.forcing", "instant.qacc", "RK4.position", "RK4.drift.energy", "RK4.drift.p_phi",
                            "RK4.p_phi", "RK4.drift.L_x", "RK4.drift.p_x", "RK4.p_x"}),
    "armature": (dict(edit=armature("free", 1e-3), integrators=RK4),
                 {"instant.mass_matrix", "instant.kinetic_energy", "RK4.position", "RK4.p_phi", "RK4.drift.L_x"}),
    "hidden_mass": (dict(edit=_hidden_mass, integrators=RK4),
                    {"instant.mass_matrix", "instant.forcing", "instant.kinetic_energy", "instant.point_acceleration",
                     "RK4.position", "RK4.p_phi", "RK4.p_x"}),
}

# Legitimate changes: another inertia, mass or tip distance is another body, read from the model; a 4 ms
# step is explained by RK4's order, 0.5 ms Euler by Euler's; the CG solver has no constraint to solve.
SETTINGS = {  # the first is the one the fast suite keeps (conftest): one that sympy need not derive anew
    "timestep 4 ms": dict(timestep=0.004, integrators=RK4),
    "I1 0.021": dict(edit=_inertia, integrators=RK4),
    "mass 2 kg": dict(edit=_mass, integrators=RK4),
    "tips at 0.25 m": dict(edit=_tips, integrators=RK4),
    "Euler at 0.5 ms": dict(timestep=0.0005, integrators=["Euler"]),
    "CG solver": dict(edit=_cg, integrators=RK4),
}


@pytest.mark.parametrize("fault", list(FAULTS))
def test_a_fault_trips_its_gates(fault):
    assert_trips(cases.get(NAME), *FAULTS[fault], fault)


@pytest.mark.parametrize("setting", list(SETTINGS))
def test_a_legitimate_change_passes_every_gate(setting):
    assert_passes(cases.get(NAME), SETTINGS[setting], setting)


def test_hidden_mass_leaves_the_body_torque_free():
    """The physics of the hidden-mass fault: MuJoCo's composite body still conserves its L and P (its
    drift gates pass), only its motion is another body's."""
    failed = failing(run_case(cases.get(NAME), RunOptions(**FAULTS["hidden_mass"][0])))
    assert not failed & breakable(NAME, {"RK4.drift.L_x", "RK4.drift.L_y", "RK4.drift.p_phi", "RK4.drift.energy"})


@dataclasses.dataclass(frozen=True)
class _SwappedBinding(FreeBinding):
    """A wiring fault no model edit can make (every kinematic edit of the model is refused by
    params_from_model): the Euler rotations composed in the wrong order, R_z(ψ) R_x(θ) R_z(φ)."""

    def set_state(self, model, data, q, qd) -> None:
        super().set_state(model, data, q, qd)
        named = dict(zip(self.coordinates, q, strict=True))
        qpos = int(model.joint(self.joint).qposadr[0])
        data.qpos[qpos + 3:qpos + 7] = orientation(named["psi"], named["theta"], named["phi"])


def test_a_binding_in_the_wrong_euler_order_fails_kinematics():
    """The tips sit elsewhere for the same (φ, θ, ψ): instant.kinematics fails (tests/test_gates.py's
    OWN_FAULTS counts on this for the gate no catalog fault reaches), and the motion with it."""
    case = cases.get(NAME)
    broken = dataclasses.replace(case, wiring=dataclasses.replace(case.wiring, binding=_SwappedBinding))
    assert {"instant.kinematics", "RK4.position"} <= failing(run_case(broken, RunOptions(integrators=RK4)))

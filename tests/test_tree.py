"""The tree reference (analytic/tree, harness/reference/tree.py): its conventions, its derivatives, and its
agreement with three independent things — Kane's form of the same equations typed by hand, the hand-derived
systems, and MuJoCo (the engine it judges, as the thing being checked).

Tolerances: the tree's M and F are sums of O(nbodies · n) products of order-1 numbers, each exact to a few
ε; MuJoCo's likewise. 1e-12 relative is 4500 ε, a margin of ~100 over the 1e-14 measured on every model here.
The hand-derived systems agree to the issue's 1e-9 (measured: ≤ 1e-13 for M and F).
"""

from __future__ import annotations

import copy
import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from analytic.solvers import solve
from analytic.tree import Spring, TreeDynamics
from analytic.tree.kinematics import forward, point_jacobians, points_on
from analytic.tree.rotations import exp_map, mat_to_quat, right_jacobian
from harness import cases
from harness.engine import variants
from harness.engine.bindings import TreeBinding, velocity_map
from harness.engine.compat import full_mass_matrix
from harness.engine.models import compile_model
from harness.families.sampled import sample_states
from harness.reference.tree import charts, prepare, read_tree, refusal, start_state, uncovered
from tests.helpers import needs_polynomial_springs

MJCF = Path(__file__).resolve().parent.parent / "mjcf"
AGREE = 1e-12

# A small tree with every joint kind, both anchors and refs off zero, a full inertia, springs, damping,
# armature, gravity compensation and an affine actuator: nobody's model, written to exercise each term.
EVERY_KIND = """
<mujoco>
  <option gravity="0.3 -0.2 -9.81"><flag energy="enable"/></option>
  <worldbody>
    <body name="base" pos="0.1 0.2 1.0" quat="0.9 0.1 0.3 0.2">
      <joint name="slide" type="slide" axis="0.3 0.4 0.866" ref="0.05" stiffness="3" springref="0.1" damping="0.2"/>
      <geom type="box" size="0.1 0.05 0.03" mass="2"/>
      <body name="arm" pos="0.2 0 0" quat="0.8 0.6 0 0">
        <joint name="hinge" type="hinge" axis="0.2 0.9 0.1" pos="0.01 0.02 -0.03" ref="0.3" armature="0.01"
               stiffness="0.5" damping="0.05"/>
        <inertial pos="0.15 0.01 0.02" quat="0.7 0.1 0.5 0.3" mass="0.7" diaginertia="0.01 0.02 0.025"/>
        <site name="arm_tip" pos="0.3 0.01 0"/>
        <body name="ball" pos="0.3 0 0">
          <joint name="ball" type="ball" pos="0.02 0 0.01" damping="0.01" armature="0.002"/>
          <inertial pos="0.05 0.02 -0.1" mass="0.4" fullinertia="0.004 0.005 0.003 0.0005 -0.0002 0.0001"/>
          <site name="ball_tip" pos="0.1 0.05 -0.2"/>
        </body>
      </body>
    </body>
    <body name="free" pos="1 0 2" quat="0.6 0 0.8 0" gravcomp="0.3">
      <joint name="free" type="free"/>
      <inertial pos="0.01 0.02 0.03" quat="0.5 0.5 0.5 0.5" mass="1.3" diaginertia="0.02 0.03 0.04"/>
      <site name="free_corner" pos="0.1 -0.1 0.05"/>
    </body>
  </worldbody>
  <actuator>
    <position name="servo" joint="hinge" kp="4" kv="0.3"/>
    <motor name="push" joint="slide" gear="2"/>
  </actuator>
</mujoco>
"""

# Polynomial springs (MuJoCo ≥ 3.7's stiffness="a b c": the force −(a x + b x² + c x³), x = q − springref) on a hinge, a
# slide and a second hinge with no linear part (MuJoCo applies the polynomial though a = 0), under gravity.
POLY = """
<mujoco>
  <compiler angle="radian"/>
  <option gravity="0.2 0 -9.81"><flag energy="enable" contact="disable"/></option>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="hinge" type="hinge" axis="0 1 0" stiffness="0.5 -1.5 4" springref="0.3" damping="0.1"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.04"/>
      <body name="tip" pos="0.3 0 0">
        <joint name="slide" type="slide" axis="1 0 0.2" stiffness="2 -6 30" springref="-0.1"/>
        <geom size="0.03" mass="0.2"/>
        <body name="hand" pos="0.05 0 0">
          <joint name="cubic" type="hinge" axis="0 0 1" stiffness="0 0 7" springref="-0.2"/>
          <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02"/>
          <site name="hand_tip" pos="0.2 0 0"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
POLY_X = (-2.5, -0.7, 0.05, 0.9, 2.5)
"""The displacements x = q − springref each joint is set at: the largest where the cubic term is ≥ 5× the others."""


def _compiled(xml: str) -> mujoco.MjModel:
    spec = mujoco.MjSpec.from_string(xml)
    prepare(spec)
    return spec.compile()


def _random_states(model: mujoco.MjModel, count: int, seed: int = 0) -> list[tuple[np.ndarray, np.ndarray]]:
    """MuJoCo states (qpos, qvel) with every joint away from its reference: normalized random quaternions."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        qpos = model.qpos0 + rng.normal(scale=0.4, size=model.nq)
        for j in range(model.njnt):
            adr = int(model.jnt_qposadr[j])
            k = {int(mujoco.mjtJoint.mjJNT_BALL): adr, int(mujoco.mjtJoint.mjJNT_FREE): adr + 3}.get(
                int(model.jnt_type[j]))
            if k is not None:
                qpos[k:k + 4] /= np.linalg.norm(qpos[k:k + 4])
        out.append((qpos, rng.normal(size=model.nv)))
    return out


def _at(model: mujoco.MjModel, qpos: np.ndarray, qvel: np.ndarray, ctrl=None) -> tuple[TreeDynamics, np.ndarray,
                                                                                         np.ndarray]:
    """The tree's dynamics in charts centred at ``qpos`` and its state there (θ = 0: q̇ is MuJoCo's qvel)."""
    dyn = TreeDynamics.of(read_tree(model, chart=charts(model, qpos), ctrl=ctrl))
    q0, qd0 = start_state(model, qpos, qvel)
    return dyn, np.array([q0[c] for c in dyn.coordinates]), np.array([qd0[c] for c in dyn.coordinates])


def _mujoco(model: mujoco.MjModel, qpos, qvel, ctrl=None) -> tuple[np.ndarray, np.ndarray, mujoco.MjData]:
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = qpos, qvel
    if ctrl is not None:
        data.ctrl[:] = ctrl
    mujoco.mj_forward(model, data)
    force = data.qfrc_passive + data.qfrc_actuator - data.qfrc_bias
    return full_mass_matrix(model, data), force, data


# ------------------------------------------------------------------ conventions
def test_quaternions_are_wxyz_and_a_ball_rotates_by_its_rotation_vector():
    """R₀ Exp(θ) written into a ball joint's qpos (w, x, y, z) is the body's orientation MuJoCo computes."""
    model = _compiled(EVERY_KIND)
    theta = np.array([0.3, -0.2, 0.5])
    binding = TreeBinding(tuple(f"c{i}" for i in range(model.nv)), ((2, (1.0, 0.0, 0.0, 0.0)),))
    data = mujoco.MjData(model)
    q = np.zeros(model.nv)
    q[2:5] = theta
    binding.set_state(model, data, q, np.zeros(model.nv))
    adr = int(model.jnt_qposadr[2])
    assert np.allclose(data.qpos[adr:adr + 4], mat_to_quat(exp_map(theta)), atol=1e-15)
    w, x, y, z = data.qpos[adr:adr + 4]
    angle = 2 * math.atan2(math.sqrt(x * x + y * y + z * z), w)  # w first: the scalar part
    assert angle == pytest.approx(np.linalg.norm(theta), rel=1e-14)


def test_free_joint_velocity_is_world_linear_at_the_origin_and_body_angular():
    """MuJoCo's free qvel: the world velocity of the body's origin, then its angular velocity in its own frame;
    the tree's free coordinates are exactly those at θ = 0 (a ball's angular velocity is J_r(θ) θ̇)."""
    model = _compiled(EVERY_KIND)
    qpos, qvel = _random_states(model, 1, seed=3)[0]
    _, _, data = _mujoco(model, qpos, qvel)
    bid = model.body("free").id
    dof = int(model.jnt_dofadr[model.joint("free").id])
    vel = np.zeros(6)
    mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_XBODY, bid, vel, 0)  # world frame, at xpos
    assert np.allclose(vel[3:], qvel[dof:dof + 3], atol=1e-14)
    assert np.allclose(data.xmat[bid].reshape(3, 3).T @ vel[:3], qvel[dof + 3:dof + 6], atol=1e-14)
    theta = np.array([0.4, 0.1, -0.3])
    assert np.allclose(TreeBinding(("x",) * model.nv).velocity_map(model, np.r_[np.zeros(8), theta])[8:, 8:],
                       right_jacobian(theta), atol=0)


def test_right_jacobian_is_the_body_angular_velocity_of_the_exponential_map():
    """ω_body = J_r(θ) θ̇ for R(t) = Exp(θ(t)): checked by complex step of Rᵀ Ṙ, and J_r(0) = I."""
    theta, rate = np.array([0.7, -1.1, 0.4]), np.array([0.3, 0.2, -0.5])
    r = exp_map(theta)
    r_dot = exp_map(theta + 1e-30j * rate).imag / 1e-30
    omega = r.T @ r_dot
    assert np.allclose(omega, -omega.T, atol=1e-15)
    assert np.allclose([omega[2, 1], omega[0, 2], omega[1, 0]], right_jacobian(theta) @ rate, atol=1e-15)
    assert np.array_equal(right_jacobian(np.zeros(3)), np.eye(3))


# ------------------------------------------------------------------ derivatives
def test_jacobians_are_the_derivatives_of_the_poses():
    """Every body-fixed point's linear Jacobian column and every body's angular one equal the complex-step
    derivative of forward kinematics along that coordinate."""
    model = _compiled(EVERY_KIND)
    qpos, qvel = _random_states(model, 1, seed=1)[0]
    dyn, _, _ = _at(model, qpos, qvel)
    q = np.random.default_rng(2).normal(scale=0.3, size=dyn.n)
    bodies = np.arange(len(dyn.tree.bodies))
    offsets = np.array([[0.1, -0.2, 0.05]] * len(bodies))
    pose = forward(dyn.tree, dyn.layout, q)
    lin, ang = point_jacobians(pose, dyn.layout, bodies, points_on(pose, bodies, offsets))
    for k in range(dyn.n):
        moved = forward(dyn.tree, dyn.layout, q + 1e-30j * np.eye(dyn.n)[k])
        dx = points_on(moved, bodies, offsets).imag / 1e-30
        dr = moved.rotation.imag / 1e-30
        w = np.einsum("bij,bkj->bik", dr, pose.rotation)  # Ṙ Rᵀ = [ω]× in the world
        assert np.allclose(lin[..., k], dx, atol=1e-14)
        assert np.allclose(ang[..., k], np.stack([w[:, 2, 1], w[:, 0, 2], w[:, 1, 0]], -1), atol=1e-14)


@pytest.mark.parametrize("xml", [EVERY_KIND, pytest.param(POLY, marks=needs_polynomial_springs)],
                         ids=["every joint kind", "polynomial springs"])
def test_lagrange_by_complex_step_equals_kane_typed_by_hand(xml):
    """F from Lagrange's equations (complex step on T and V) against Kane's form of the same equations, typed
    here as an independent check: Σ Jᵀ(m g − m J̇q̇) − J_ωᵀ(I α_v + ω × I ω) + Q, per body."""
    model = _compiled(xml)
    for qpos, qvel in _random_states(model, 3, seed=4):
        dyn, q, qd = _at(model, qpos, qvel)
        q = q + np.random.default_rng(5).normal(scale=0.2, size=dyn.n)  # off the chart's centre: B ≠ I
        pose = forward(dyn.tree, dyn.layout, q)
        _, lin, ang, inertia = dyn._com_jacobians(pose)
        _, lin_c, ang_c, _ = dyn._com_jacobians(forward(dyn.tree, dyn.layout, q + 1e-30j * qd))
        m = dyn._bodies["mass"]
        acc_v = np.einsum("bij,j->bi", lin_c.imag, qd) / 1e-30
        alpha_v = np.einsum("bij,j->bi", ang_c.imag, qd) / 1e-30
        omega = np.einsum("bij,j->bi", ang, qd)
        iw = np.einsum("bij,bj->bi", inertia, omega)
        kane = (np.einsum("bik,bi->k", lin, m[:, None] * (dyn.tree.gravity - acc_v))
                - np.einsum("bik,bi->k", ang, np.einsum("bij,bj->bi", inertia, alpha_v) + np.cross(omega, iw)))
        b = TreeBinding(dyn.coordinates).velocity_map(model, q)
        b_dot = TreeBinding(dyn.coordinates).velocity_map(model, q + 1e-30j * qd).imag / 1e-30
        arm = dyn._armature
        kane -= b.T @ (arm * (b_dot @ qd))  # the armature's own velocity-product term
        for j, joint in enumerate(dyn.tree.joints):
            for term in joint.terms:  # a hinge or slide's spring, typed here by hand: −(k x + Σ pᵢ x^(i+2))
                assert isinstance(term, Spring), term
                k = dyn.layout.first[j]
                x = q[k] - term.springref
                kane[k] -= term.stiffness * x + sum(p * x ** (i + 2) for i, p in enumerate(term.poly))
        kane += dyn._applied(q, qd, lin)
        got = dyn.forcing(q, qd)
        assert np.allclose(got, kane, rtol=0, atol=AGREE * max(1.0, np.abs(kane).max()))


def test_constraint_jacobian_and_gamma_are_the_derivatives_of_the_residual():
    """J = ∂f/∂q and γ = −J̇ q̇ for connect, weld and joint equalities, by complex step on f itself."""
    xml = EVERY_KIND.replace("</worldbody>", """</worldbody>
  <equality>
    <connect name="c" body1="ball" body2="free" anchor="0.1 0 0"/>
    <weld name="w" body1="arm" body2="free" relpose="0.2 0.1 0 0.9 0.1 0.3 0.2" anchor="0.05 0 0"/>
    <joint name="j" joint1="hinge" joint2="slide" polycoef="0.1 0.5 0.2 0 0"/>
  </equality>""")
    model = _compiled(xml)
    qpos, qvel = _random_states(model, 1, seed=6)[0]
    dyn, q, qd = _at(model, qpos, qvel)
    q = q + 0.1
    jac = dyn.jacobian(q)
    assert jac.shape == (10, dyn.n)
    for k in range(dyn.n):
        dk = dyn._rows(q + 1e-30j * np.eye(dyn.n)[k])[0].imag / 1e-30
        assert np.allclose(jac[:, k], dk, atol=1e-13)
    # γ: d²f/dt² at q̈ = 0 is J̇ q̇; central difference of J along q̇ as an independent (approximate) check
    step = 1e-6
    jdot = (dyn.jacobian(q + step * qd) - dyn.jacobian(q - step * qd)) / (2 * step)
    assert np.allclose(dyn.gamma(q, qd), -jdot @ qd, atol=1e-7)


# ------------------------------------------------------------------ MuJoCo, the thing judged
def _against_mujoco(model: mujoco.MjModel, states, ctrl=None) -> dict[str, float]:
    worst = {"mass_matrix": 0.0, "forcing": 0.0, "energy": 0.0}
    for qpos, qvel in states:
        dyn, q, qd = _at(model, qpos, qvel, ctrl=ctrl)
        mass, force, data = _mujoco(model, qpos, qvel, ctrl)
        worst["mass_matrix"] = max(worst["mass_matrix"], np.abs(dyn.mass_matrix(q) - mass).max() / np.abs(mass).max())
        worst["forcing"] = max(worst["forcing"], np.abs(dyn.forcing(q, qd) - force).max() / max(1, np.abs(force).max()))
        energy = float(np.sum(data.energy))
        worst["energy"] = max(worst["energy"], abs(dyn.energy(q, qd) - energy) / max(1.0, abs(energy)))
    return worst


def test_every_joint_kind_agrees_with_mujoco():
    model = _compiled(EVERY_KIND)
    ctrl = np.array([0.2, -0.7])
    worst = _against_mujoco(model, _random_states(model, 6), ctrl=ctrl)
    assert max(worst.values()) < AGREE, worst


def _poly_states(model: mujoco.MjModel) -> list[tuple[np.ndarray, np.ndarray]]:
    """Every joint of POLY at each displacement of POLY_X from its springref (the others' staggered), moving."""
    rng = np.random.default_rng(7)
    spring = np.array([model.qpos_spring[model.jnt_qposadr[j]] for j in range(model.njnt)])
    return [(spring + np.roll(POLY_X, -i)[:model.njnt], rng.normal(size=model.nv)) for i in range(len(POLY_X))]


@needs_polynomial_springs
def test_polynomial_springs_agree_with_mujoco_where_the_cubic_dominates(monkeypatch):
    """Hinge and slide polynomial springs are read and not listed as uncovered; the tree's forces and energy (its
    V the polynomial's integral, differentiated exactly) are MuJoCo's qfrc_passive and energy, up to displacements
    where c x³ is ≥ 5× a x + b x²; with the polynomial dropped, the same comparison fails by far."""
    import harness.reference.tree as tree_reference

    model = _compiled(POLY)
    assert not uncovered(model)
    poly = np.asarray(model.jnt_stiffnesspoly)
    x = max(POLY_X, key=abs)
    assert np.all(np.abs(poly[:, 1] * x ** 3) >= 5 * np.abs(model.jnt_stiffness * x + poly[:, 0] * x ** 2))
    states = _poly_states(model)
    worst = _against_mujoco(model, states)
    assert max(worst.values()) < AGREE, worst
    monkeypatch.setattr(tree_reference, "_stiffness_poly", lambda model, j: ())  # the polynomial term dropped
    dropped = _against_mujoco(model, states)
    assert dropped["forcing"] > 0.1 and dropped["energy"] > 0.1, dropped


@needs_polynomial_springs
@pytest.mark.parametrize(("engine", "passes"), [
    (POLY, True),  # as written
    (POLY.replace("0.5 -1.5 4", "0.5 -1.5 8"), False),  # the hinge's cubic coefficient doubled
    (POLY.replace("0.5 -1.5 4", "0.5").replace("2 -6 30", "2").replace("0 0 7", "0"), False),  # polynomials dropped
], ids=["as written", "cubic doubled", "polynomials dropped"])
def test_a_polynomial_spring_model_passes_as_written_and_fails_where_the_engine_runs_another(tmp_path, engine,
                                                                                              passes):
    """Both directions through the whole pipeline (check --mjcf's judging): the model judged against its own tree
    passes; the same tree as reference with a spring changed on the engine's side alone fails."""
    from harness import validate
    from harness.cases.own import from_mjcf

    reference, judged = tmp_path / "poly.xml", tmp_path / "engine.xml"
    reference.write_text(POLY)
    judged.write_text(engine)
    verdict = validate(from_mjcf(judged, reference=reference, horizon=0.5), integrators=["RK4", "implicitfast"])
    assert verdict.passed is passes
    if not passes:  # failed for its forces, not for anything else
        assert not verdict.check("instant.forcing").passed


TREE_CASES = ("pendulum", "physical_pendulum", "double_pendulum", "spherical_pendulum", "spherical_pendulum_ball",
              "symmetric_top", "torque_free_body", "slider_crank", "welded_pendulum")
"""The shipped cases that are trees the reference expresses whole (spring and atwood hang on spatial tendons, the
hoops on contacts: not covered, so not compared here)."""


@pytest.mark.parametrize("name", [n for n in TREE_CASES if n in cases.names()])
def test_shipped_tree_models_agree_with_mujoco(name):
    model = compile_model(cases.get(name).mjcf, edit=prepare)
    assert not refusal(model) and not uncovered(model)
    worst = _against_mujoco(model, _random_states(model, 4))
    assert max(worst.values()) < AGREE, worst


# ------------------------------------------------------------------ the hand-derived systems
def _idealized(case, model: mujoco.MjModel) -> mujoco.MjModel:
    """``model`` with its point masses' floor inertia set to 0: the idealization the hand-derived system makes
    (its budget's floors part is that inertia's effect)."""
    ideal = copy.copy(model)
    for body in variants.point_masses(model, case.reference(model).scales.length):
        ideal.body_inertia[model.body(body).id] = 0.0
    return ideal


@pytest.mark.parametrize("name", [n for n in TREE_CASES if n in cases.names()])
def test_the_tree_agrees_with_the_hand_derived_system(name):
    """At the hand-derived reference's sampled states, mapped to MuJoCo's coordinates by the case's binding:
    Bᵀ M_tree B = M, Bᵀ (F_tree − M_tree Ḃ q̇) = F, and the constraint forces Bᵀ J_treeᵀ λ_tree = Jᵀ λ, to 1e-9."""
    case = cases.get(name)
    model = _idealized(case, compile_model(case.mjcf, edit=prepare))
    ref = case.reference(model)
    derived = ref.dynamics
    binding = case.probe(derived).binding
    data = mujoco.MjData(model)
    for q, qd in zip(*sample_states(ref, count=8), strict=True):
        binding.set_state(model, data, q, qd)
        b, bdot_qd = velocity_map(binding, model, q, qd)
        bdot_qd = np.zeros(model.nv) if bdot_qd is None else bdot_qd
        dyn, qt, qdt = _at(model, data.qpos.copy(), data.qvel.copy())
        mass_t = dyn.mass_matrix(qt)
        mass = derived.mass_matrix(q)
        force = derived.forcing(q, qd)
        assert np.abs(b.T @ mass_t @ b - mass).max() <= 1e-9 * np.abs(mass).max()
        scale = max(np.abs(force).max(), np.abs(mass).max() * 9.81)
        assert np.abs(b.T @ (dyn.forcing(qt, qdt) - mass_t @ bdot_qd) - force).max() <= 1e-9 * scale
        if derived.rows:
            _, lam = derived.accelerations(q, qd)
            _, lam_t = dyn.accelerations(qt, qdt)
            gen = derived.jacobian(q).T @ lam
            gen_t = b.T @ dyn.jacobian(qt).T @ lam_t
            assert np.abs(gen_t - gen).max() <= 1e-9 * scale


@pytest.mark.parametrize("name", [pytest.param(n, marks=() if n == "double_pendulum" else pytest.mark.slow)
                                  for n in ("double_pendulum", "physical_pendulum", "torque_free_body", "slider_crank")
                                  if n in cases.names()])
def test_the_tree_trajectory_agrees_with_the_hand_derived_one(name):
    """The two references solved from the same state over the case's horizon: every named point to 1e-9 L."""
    case = cases.get(name)
    model = _idealized(case, compile_model(case.mjcf, edit=prepare))
    ref = case.reference(model)
    binding = case.probe(ref.dynamics).binding
    data = mujoco.MjData(model)
    binding.set_state(model, data, ref.q0(), ref.qd0())
    dyn, q0, qd0 = _at(model, data.qpos.copy(), data.qvel.copy())
    sol = solve(dyn, q0=q0, qd0=qd0, t_end=case.horizon, rtol=1e-12, atol=1e-12)
    t = np.linspace(0, case.horizon, 41)
    names = [p for p in ref.dynamics.point_names if p in dyn.point_names]
    assert names
    got = dyn.points(sol.state(t)[0])[:, [dyn.point_names.index(p) for p in names]]
    want = ref.dynamics.points(ref.solution.state(t)[0])[:, [ref.dynamics.point_names.index(p) for p in names]]
    assert np.abs(got - want).max() <= 1e-9 * ref.scales.length


# ------------------------------------------------------------------ what it refuses, what it does not cover
@pytest.mark.parametrize(("xml", "needle"), [
    ("<mujoco><worldbody><body><geom size='.1'/></body></worldbody></mujoco>", "no degrees of freedom"),
    ("<mujoco><worldbody><body><joint type='hinge'/><geom size='.1'/></body><flexcomp name='rope' type='grid' "
     "count='3 1 1' spacing='.1 .1 .1' dim='1' mass='0.1'/></worldbody></mujoco>", "flex elements"),
])
def test_what_the_tree_cannot_read_is_refused_in_one_line(xml, needle):
    assert needle in refusal(_compiled(xml))


def test_forces_it_does_not_model_are_listed():
    xml = EVERY_KIND.replace('<option gravity="0.3 -0.2 -9.81">', '<option density="1.2" wind="1 0 0">')
    xml = xml.replace('type="slide" axis', 'type="slide" limited="true" range="-1 1" frictionloss="0.1" axis')
    assert "contacts" not in uncovered(_compiled(xml))  # one geom: nothing to touch
    xml = xml.replace("<worldbody>", "<worldbody><geom type='plane' size='5 5 .1'/>")
    gaps = uncovered(_compiled(xml))
    assert {"fluid forces", "joint limits", "dry friction", "contacts"} <= set(gaps)


@pytest.mark.parametrize("chunk", [1, 13 * 7, 10**9])
def test_a_batch_is_each_states_evaluation_however_it_is_chunked(monkeypatch, chunk):
    """A long batch of states is evaluated in chunks (analytic.dynamics.CHUNK_CONFIGURATIONS: its arrays stay in
    the caches); every state's M, F and the Radau Jacobian's columns are its own evaluation's, to round-off,
    whether the batch is one chunk, several uneven ones, or a state at a time."""
    import analytic.dynamics
    from analytic.solvers import state_jacobian

    monkeypatch.setattr(analytic.dynamics, "CHUNK_CONFIGURATIONS", chunk)
    model = _compiled(EVERY_KIND)
    qpos, qvel = _random_states(model, 1, seed=3)[0]
    dyn, q, qd = _at(model, qpos, qvel)
    rng = np.random.default_rng(5)
    qs, qds = q + 0.1 * rng.normal(size=(40, dyn.n)), qd + rng.normal(size=(40, dyn.n))
    mass, force = dyn.mass_and_forcing(qs, qds)
    kkt = dyn.kkt_terms(qs.reshape(5, 8, dyn.n), qds.reshape(5, 8, dyn.n))
    for i in (0, 7, 8, 39):
        m_i, f_i = dyn.mass_and_forcing(qs[i], qds[i])
        assert np.allclose(mass[i], m_i, rtol=0, atol=AGREE * np.abs(m_i).max())
        assert np.allclose(force[i], f_i, rtol=0, atol=AGREE * np.abs(f_i).max())
        assert np.allclose(kkt[1].reshape(40, dyn.n)[i], f_i, rtol=0, atol=AGREE * np.abs(f_i).max())

    def rhs(t, y):
        return np.concatenate([y[..., dyn.n:], dyn.accelerations(y[..., :dyn.n], y[..., dyn.n:])[0]], axis=-1)

    y = np.concatenate([q, qd])
    jac = state_jacobian(dyn, rhs, 0.0, y, rhs(0.0, y))
    monkeypatch.setattr(analytic.dynamics, "CHUNK_CONFIGURATIONS", 10**9)
    whole = state_jacobian(dyn, rhs, 0.0, y, rhs(0.0, y))
    assert np.allclose(jac, whole, rtol=0, atol=AGREE * np.abs(whole).max())

"""Actuation as robots have it, in the tree reference: position and velocity servos with a force range, gear, a
joint's ``actuatorfrcrange`` on the summed force, ``actuatorgravcomp`` routed into that sum, controls clamped to
``ctrlrange`` — each checked against MuJoCo (the thing judged), never switched off; the clamps' switching instants
located and the budget's order lowered across them; both directions of the verdict on a model written for these
tests (faults on the engine's side alone fail; legitimate settings pass).

The Unitree G1 false alarm (instant.forcing 2.66e-2 against a limit of 2.2e-12: the joints' actuatorfrcrange
ignored by the reference) is reproduced by :data:`CLAMPED` (G1 itself is not in ../shared/models).
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

import harness
from analytic.tree import TreeDynamics
from harness.cases.own import from_mjcf
from harness.reference.tree import SWITCHED_ORDER, prepare, read_tree, switched_orders, switches, uncovered

# A three-link arm under gravity: position servos with a force range that binds, a velocity servo, a motor with a
# gear, a servo whose ctrlrange excludes 0 (MuJoCo clamps the zero control), a joint's actuatorfrcrange on the sum of
# two actuators, and gravity compensation routed through the actuators on one joint.
SERVOS = """
<mujoco model="servo arm">
  <compiler autolimits="true"/>
  <option timestep="0.001"/>
  <default><geom type="capsule" size="0.03" density="800" contype="0" conaffinity="0"/></default>
  <worldbody>
    <body name="upper" pos="0 0 1">
      <joint name="shoulder" axis="0 1 0" actuatorfrcrange="-1.5 1.5"/>
      <geom fromto="0 0 0 0.3 0 0"/>
      <body name="fore" pos="0.3 0 0" gravcomp="0.5">
        <joint name="elbow" axis="0 1 0.1" actuatorgravcomp="true"/>
        <geom fromto="0 0 0 0.25 0 0"/>
        <body name="hand" pos="0.25 0 0">
          <joint name="wrist" axis="1 0 0" damping="0.05"/>
          <geom fromto="0 0 0 0.1 0 0"/>
          <site name="tip" pos="0.1 0 0"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position name="shoulder_servo" joint="shoulder" kp="40" kv="2" forcerange="-3 3"/>
    <velocity name="shoulder_damper" joint="shoulder" kv="0.5"/>
    <position name="elbow_servo" joint="elbow" kp="20" kv="1" forcerange="-5 5" ctrlrange="0.2 1"/>
    <motor name="wrist_motor" joint="wrist" gear="2" ctrlrange="-1 1"/>
  </actuator>
  <keyframe><key name="swing" qpos="0.6 -0.9 0.4" qvel="2 -3 4" ctrl="0 0 0.5 0.01"/></keyframe>
</mujoco>
"""

# G1's case reduced: position servos far stronger than their joints' actuatorfrcrange, which clamps the summed torque
CLAMPED = """
<mujoco model="clamped legs">
  <compiler autolimits="true"/>
  <option timestep="0.002"/>
  <default>
    <joint axis="0 1 0" actuatorfrcrange="-2 2" armature="0.01"/>
    <geom type="capsule" size="0.03" density="800" contype="0" conaffinity="0"/>
    <position kp="500" kv="10"/>
  </default>
  <worldbody>
    <body name="thigh" pos="0 0 1">
      <joint name="hip"/>
      <geom fromto="0 0 0 0 0 -0.3"/>
      <body name="shin" pos="0 0 -0.3">
        <joint name="knee"/>
        <geom fromto="0 0 0 0 0 -0.3"/>
        <site name="foot" pos="0 0 -0.3"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position name="hip_servo" joint="hip"/>
    <position name="knee_servo" joint="knee"/>
  </actuator>
  <keyframe><key name="crouch" qpos="0.5 -0.8" qvel="1 -1" ctrl="0.1 -0.2"/></keyframe>
</mujoco>
"""


# Two wheels driven through fixed tendons (MuJoCo's car's transmission) by two motors each, every tendon's summed
# actuator force clamped by its actuatorfrcrange (each actuator's force scaled by the end over the sum), one motor with
# a forcerange of its own besides
TENDONS = """
<mujoco model="tendon drive">
  <compiler autolimits="true"/>
  <default><geom type="cylinder" size=".03 .01" mass="0.05" contype="0" conaffinity="0"/></default>
  <worldbody>
    <body name="left wheel" pos="0 .06 0" zaxis="0 1 0"><joint name="left" damping="0.01"/><geom/></body>
    <body name="right wheel" pos="0 -.06 0" zaxis="0 1 0"><joint name="right" damping="0.01"/><geom/></body>
  </worldbody>
  <tendon>
    <fixed name="forward" actuatorfrcrange="-0.4 0.3"><joint joint="left" coef=".5"/><joint joint="right" coef=".5"/>
    </fixed>
    <fixed name="turn" actuatorfrcrange="-0.2 0.2"><joint joint="left" coef="-.5"/><joint joint="right" coef=".5"/>
    </fixed>
  </tendon>
  <actuator>
    <motor name="forward" tendon="forward" gear="2"/>
    <velocity name="forward_damper" tendon="forward" kv="0.05" forcerange="-0.05 0.05"/>
    <motor name="turn" tendon="turn"/>
    <position name="turn_servo" tendon="turn" kp="0.3"/>
  </actuator>
  <keyframe><key name="roll" qvel="3 -2" ctrl="0.2 1 -0.1 0.5"/></keyframe>
</mujoco>
"""


def _model(text: str) -> mujoco.MjModel:
    spec = mujoco.MjSpec.from_string(text)
    prepare(spec)
    return spec.compile()


def _actuation(dyn: TreeDynamics, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """The reference's generalized actuator force: its forcing less that of the same tree without actuators (the
    gravity compensation routed to the actuators goes with them, as in MuJoCo's qfrc_actuator)."""
    bare = TreeDynamics.of(dataclasses.replace(dyn.tree, actuators=(), limits=()))
    return dyn.forcing(q, qd) - bare.forcing(q, qd)


# a tendon's actuatorfrcrange is newer than the oldest supported MuJoCo (3.3.0), which has none to check
TENDON_CLAMPS = hasattr(mujoco.MjModel, "tendon_actfrclimited")
needs_tendon_clamps = pytest.mark.skipif(not TENDON_CLAMPS, reason=f"MuJoCo {mujoco.__version__} has no tendon "
                                         "actuatorfrcrange")


@pytest.mark.parametrize("text", [SERVOS, CLAMPED, pytest.param(TENDONS, marks=needs_tendon_clamps)],
                         ids=["servos", "clamped", "tendons"])
def test_the_reference_applies_every_clamp_as_mujoco_does_at_states_where_they_bind(text):
    """At 40 random states (a clamp binding at a quarter of them at least), the reference's actuator force
    agrees with MuJoCo's qfrc_actuator to round-off; and nothing of the actuation is listed as uncovered."""
    model = _model(text)
    assert not [k for k in uncovered(model) if k.startswith("actuator")]
    data = mujoco.MjData(model)
    rng = np.random.default_rng(7)
    key = model.key(0).id
    worst, bound = 0.0, 0
    for _ in range(40):
        mujoco.mj_resetDataKeyframe(model, data, key)
        data.qpos[:] = rng.uniform(-1.5, 1.5, model.nq)
        data.qvel[:] = rng.uniform(-5, 5, model.nv)
        data.ctrl[:] = rng.uniform(-2, 2, model.nu)  # beyond the ctrlranges too
        mujoco.mj_forward(model, data)
        dyn = TreeDynamics.of(read_tree(model, ctrl=data.ctrl))
        worst = max(worst, float(np.max(np.abs(_actuation(dyn, data.qpos, data.qvel) - data.qfrc_actuator))))
        args = dyn.clamp_arguments(data.qpos, data.qvel)
        bound += bool(np.any([not lo <= a <= hi for a, (_, lo, hi) in zip(args, dyn.clamp_ranges, strict=True)]))
    assert worst < 1e-12, worst
    assert bound >= 10, bound  # the clamps bind at a quarter of the states at least


@pytest.mark.parametrize(("what", "edit"), [
    ("no forcerange", lambda s: setattr(s.actuator("shoulder_servo"), "forcelimited", 0)),
    ("no joint actuatorfrcrange", lambda s: setattr(s.joint("shoulder"), "actfrclimited", 0)),
    ("gear 2.02", lambda s: setattr(s.actuator("wrist_motor"), "gear", [2.02, 0, 0, 0, 0, 0])),
    ("no ctrl clamp", lambda s: setattr(s.actuator("elbow_servo"), "ctrllimited", 0)),
    ("gravcomp not routed to the actuators", lambda s: setattr(s.joint("elbow"), "actgravcomp", 0)),
])
def test_a_missing_clamp_or_a_wrong_gear_on_the_engines_side_is_seen_by_the_reference(what, edit):
    """Each fault moves MuJoCo's qfrc_actuator away from the reference's (read from the unfaulted model) at the
    same states by far more than round-off: the reference would fail it (the end-to-end runs: below)."""
    good = _model(SERVOS)
    spec = mujoco.MjSpec.from_string(SERVOS)
    prepare(spec)
    edit(spec)
    bad = spec.compile()
    data = mujoco.MjData(bad)
    rng = np.random.default_rng(3)
    worst = 0.0
    for _ in range(20):
        mujoco.mj_resetDataKeyframe(bad, data, 0)
        data.qpos[:] = rng.uniform(-1.5, 1.5, bad.nq)
        data.qvel[:] = rng.uniform(-5, 5, bad.nv)
        data.ctrl[:] = rng.uniform(-2, 2, bad.nu)  # beyond the ctrlranges too
        mujoco.mj_forward(bad, data)
        dyn = TreeDynamics.of(read_tree(good, ctrl=data.ctrl))
        worst = max(worst, float(np.max(np.abs(_actuation(dyn, data.qpos, data.qvel) - data.qfrc_actuator))))
    assert worst > 1e-3, (what, worst)


def test_switching_instants_are_located_and_lower_the_order_only_where_crossed():
    """The hip's summed servo torque −kp q − kv q̇, clipped at ±2 by its joint's actuatorfrcrange, along q(t) = A sin t
    (the knee at rest) switches where A √(kp² + kv²) |sin(t + φ)| = 2, φ = atan2(kv, kp): both instants located to
    round-off on the dense state; only then is RK4's order lowered to 3 (Euler's stays 1)."""
    model = _model(CLAMPED)
    dyn = TreeDynamics.of(read_tree(model))  # ctrl 0
    amplitude, kp, kv = 0.01, 500.0, 10.0

    def state(t):
        t = np.atleast_1d(t)
        return (np.stack([amplitude * np.sin(t), np.zeros_like(t)], axis=-1),
                np.stack([amplitude * np.cos(t), np.zeros_like(t)], axis=-1))

    found = switches(dyn, state, 3.0)
    phase, reach = np.arctan2(kv, kp), np.arcsin(2.0 / (amplitude * np.hypot(kp, kv)))
    assert [name for name, _ in found] == ["joint hip actuatorfrcrange"] * 2
    assert np.allclose([t for _, t in found], [reach - phase, np.pi - reach - phase], rtol=0, atol=1e-12), found
    assert switched_orders({"RK4": 4, "Euler": 1}, found) == {"RK4": SWITCHED_ORDER, "Euler": 1}
    assert switches(dyn, state, 0.9 * (reach - phase)) == ()
    assert switched_orders({"RK4": 4}, ()) == {"RK4": 4}


def _failed(v) -> set[str]:
    return {c.name for c in v.checks if not c.passed and not c.known}


def _unclamped_joints(spec: mujoco.MjSpec) -> None:
    for joint in spec.joints:
        joint.actfrclimited = 0


def _both(*edits):
    def edit(spec: mujoco.MjSpec) -> None:
        for one in edits:
            one(spec)
    return edit


def _kp(name: str, kp: float):
    """A position servo's kp, in its gain and its bias alike (a servo of another stiffness)."""
    def edit(spec: mujoco.MjSpec) -> None:
        actuator = spec.actuator(name)
        actuator.gainprm = [kp, *actuator.gainprm[1:]]
        actuator.biasprm = [0.0, -kp, *actuator.biasprm[2:]]
    return edit


@pytest.fixture
def clamped(tmp_path):
    path = tmp_path / "clamped_legs.xml"
    path.write_text(CLAMPED)
    return path


@pytest.fixture
def servos(tmp_path):
    path = tmp_path / "servo_arm.xml"
    path.write_text(SERVOS)
    return path


def test_the_g1_false_alarm_is_gone_and_a_missing_joint_clamp_fails(clamped):
    """G1's case reduced: servos far stronger than their joints' actuatorfrcrange. Judged with its actuation on, the
    model passes (it failed instant.forcing by ~1e10× its limit while the reference ignored the clamp); the clamp
    removed on the engine's side alone fails instant.forcing."""
    case = from_mjcf(clamped, keyframe="crouch", reference=clamped, horizon=0.2)
    good = harness.validate(case, integrators=["RK4"])
    assert not _failed(good), [(c.name, c.value, c.threshold) for c in good.checks if not c.passed]
    forcing = next(c for c in good.checks if c.name == "instant.forcing")
    bad = harness.validate(case, integrators=["RK4"], edit=_unclamped_joints)
    assert {"instant.forcing", "RK4.position"} <= _failed(bad)
    worse = next(c for c in bad.checks if c.name == "instant.forcing")
    assert worse.value > 1e6 * forcing.threshold, (worse.value, forcing.threshold)


@pytest.mark.slow
@pytest.mark.parametrize(("fault", "edit"), [
    ("kp 1 % higher", _kp("elbow_servo", 20.2)),
    ("forcerange missing", lambda s: setattr(s.actuator("shoulder_servo"), "forcelimited", 0)),
    ("gear 1 % off", lambda s: setattr(s.actuator("wrist_motor"), "gear", [2.02, 0, 0, 0, 0, 0])),
])
def test_an_actuation_fault_on_the_engines_side_alone_fails(servos, fault, edit):
    """Each fails at the sampled states (instant.forcing). A servo's kp is seen only where its force is not clipped
    (a servo saturated at every state has no kp to judge: the elbow's binds at some states only)."""
    case = from_mjcf(servos, keyframe="swing", reference=servos, horizon=0.3)
    v = harness.validate(case, integrators=["RK4"], edit=edit)
    assert "instant.forcing" in _failed(v), (fault, _failed(v))


@pytest.mark.slow
@pytest.mark.parametrize("setting", [
    pytest.param({"timestep": 0.0005}, id="half the timestep"),
    pytest.param({"edit": _both(lambda s: setattr(s.actuator("wrist_motor"), "gear", [4.0, 0, 0, 0, 0, 0]),
                                lambda s: setattr(s.actuator("wrist_motor"), "gainprm",
                                                  [0.5, *s.actuator("wrist_motor").gainprm[1:]]))},
                 id="gear 4 with half the gain"),
    pytest.param({"edit": lambda s: setattr(s.actuator("shoulder_servo"), "forcerange", [-1e6, 1e6])},
                 id="a forcerange that never binds"),
])
def test_legitimate_actuation_settings_pass(servos, setting):
    """Settings that change nothing of the physics, or change it on both sides alike (the edit reaches the model the
    reference reads too: no ``reference=``), pass; the first crosses the clamps' switches at other phases of its
    steps (the budget's order lowered there)."""
    case = from_mjcf(servos, keyframe="swing", horizon=0.3)
    v = harness.validate(case, integrators=["RK4", "implicitfast"], **setting)
    assert not _failed(v), [(c.name, c.value, c.threshold) for c in v.checks if not c.passed]


@pytest.mark.slow
def test_the_reference_stepping_through_a_switch_agrees_with_one_restarted_at_each_located_instant():
    """The reference steps through a clamp's switch under its error control (the embedded estimate sees the kink and
    shrinks the step). Restarted at every located switching instant instead (no step straddles one: 11 switches over
    0.4 s), it ends at the same state within its tolerance (measured: 2.4e-12 rad, 3.8e-11 rad/s at rtol 1e-12): the
    basis for not restarting it."""
    from analytic.solvers import solve

    model = _model(CLAMPED)
    key = model.key(0).id
    dyn = TreeDynamics.of(read_tree(model, ctrl=model.key_ctrl[key]))
    q0, qd0, t_end = np.array(model.key_qpos[key]), np.array(model.key_qvel[key]), 0.4
    through = solve(dyn, q0=q0, qd0=qd0, t_end=t_end, rtol=1e-12, atol=1e-12, stiff=True)
    crossed = switches(dyn, through.state, t_end)
    assert len(crossed) >= 2, crossed
    q, qd, t = q0, qd0, 0.0
    for instant in [s for _, s in crossed] + [t_end]:
        piece = solve(dyn, q0=q, qd0=qd, t_end=instant - t, rtol=1e-12, atol=1e-12, stiff=True)
        (q,), (qd,) = piece.state(np.array([instant - t]))
        t = instant
    (end_q,), (end_qd,) = through.state(np.array([t_end]))
    assert np.max(np.abs(end_q - q)) < 1e-10 and np.max(np.abs(end_qd - qd)) < 1e-9


@needs_tendon_clamps
def test_a_tendons_actuatorfrcrange_is_applied_and_missing_it_is_seen():
    """The tendons' clamps bind at the states of the agreement test above; a reference without them (as before: the
    actuators on such a tendon were switched off) misses MuJoCo's force by far more than round-off."""
    model = _model(TENDONS)
    assert not [k for k in uncovered(model) if k.startswith("actuator")]
    data = mujoco.MjData(model)
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(20):
        data.qpos[:] = rng.uniform(-1.5, 1.5, model.nq)
        data.qvel[:] = rng.uniform(-5, 5, model.nv)
        data.ctrl[:] = rng.uniform(-2, 2, model.nu)
        mujoco.mj_forward(model, data)
        tree = read_tree(model, ctrl=data.ctrl)
        assert len(tree.tendon_limits) == 2
        dyn = TreeDynamics.of(dataclasses.replace(tree, tendon_limits=()))
        worst = max(worst, float(np.max(np.abs(_actuation(dyn, data.qpos, data.qvel) - data.qfrc_actuator))))
    assert worst > 1e-2, worst

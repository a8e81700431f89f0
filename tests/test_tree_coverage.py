"""The tree reference's one table of MuJoCo features (harness.reference.tree.FEATURES): every entry that leaves a
feature out detects it on a small model built here, and its switch-off removes exactly its force — the isolated
model's accelerations are those of the same model written without the feature; what an entry says is read names
fields the reference's types have."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

import analytic.tree as tree_types
from harness.reference.tree import FEATURES, isolate, prepare, uncovered
from tests.helpers import needs_polynomial_springs

# a hinge arm over the world with a slide on its end; each slot takes a feature's MJCF
BASE = """<mujoco>
  <option {option}/>
  <worldbody>
    {world}
    <site name="s0" pos="0 0 1"/>
    <body name="arm" pos="0 0 0.05">
      <joint name="hinge" type="hinge" axis="0 1 0" {joint}/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.04" {geom}/>
      <site name="s1" pos="0.3 0 0"/>
      <body name="tip" pos="0.3 0 0">
        <joint name="slide" type="slide" axis="1 0 0"/>
        <geom size="0.03" mass="0.2"/>
      </body>
    </body>
    {bodies}
  </worldbody>
  {tendon}
  {actuator}
</mujoco>"""
SLOTS = ("option", "world", "joint", "geom", "bodies", "tendon", "actuator")
BALL = "<body name='bob' pos='0 0 -0.5'><joint name='ball' type='ball' {}/><geom size='0.05' pos='0 0 -0.2'/></body>"

# (feature, the uncovered key it makes, the slots that give it, the same slots without it)
CASES = [
    ("contacts", "contacts", {"world": "<geom type='plane' size='1 1 .1' pos='0 0 0.03'/>"}, {}),
    ("joint limits", "joint limits", {"joint": "limited='true' range='-0.1 0.1'"}, {}),
    ("dry friction", "dry friction", {"joint": "frictionloss='0.5'"}, {}),
    ("fluid forces", "fluid forces", {"option": "density='1000'"}, {}),
    ("fluid forces", "fluid forces", {"option": "viscosity='2'"}, {}),
    ("fluid forces", "fluid forces", {"option": "density='1000' wind='3 0 1'"}, {"option": "density='0'"}),
    ("fluid forces", "fluid forces", {"option": "density='1000'", "geom": "fluidshape='ellipsoid'"}, {}),
    ("tendons", "tendon string", {"tendon": "<tendon><spatial name='string' stiffness='100' springlength='0.5'>"
                                            "<site site='s0'/><site site='s1'/></spatial></tendon>"}, {}),
    ("tendons", "tendon coupling", {"tendon": "<tendon><fixed name='coupling' damping='3'>"
                                              "<joint joint='hinge' coef='1'/></fixed></tendon>"}, {}),
    ("tendons", "tendon coupling", {"tendon": "<tendon><fixed name='coupling' frictionloss='0.4' limited='true' "
                                              "range='-0.05 0.05'><joint joint='hinge' coef='1'/>"
                                              "<joint joint='slide' coef='2'/></fixed></tendon>"}, {}),
    ("actuators", "actuator filtered", {"actuator": "<actuator><general name='filtered' joint='hinge' "
                                                    "dyntype='filter' gainprm='5'/></actuator>"}, {}),
    ("actuators", "actuator pushing", {"actuator": "<actuator><general name='pushing' site='s1' "
                                                   "gear='0 0 1 0 0 0'/></actuator>"}, {}),
    # unnamed: found by index, not by a name (before the table, isolate matched names and left these acting)
    ("tendons", "tendon tendon0", {"tendon": "<tendon><spatial stiffness='100' springlength='0.5'>"
                                             "<site site='s0'/><site site='s1'/></spatial></tendon>"}, {}),
    ("actuators", "actuator 0", {"actuator": "<actuator><general joint='hinge' dyntype='integrator' "
                                             "gainprm='5'/></actuator>"}, {}),
    ("joint springs", "joint ball spring", {"bodies": BALL.format("stiffness='40'")}, {"bodies": BALL.format("")}),
]


def _spec(slots: dict[str, str]) -> mujoco.MjSpec:
    spec = mujoco.MjSpec.from_string(BASE.format(**{k: slots.get(k, "") for k in SLOTS}))
    prepare(spec)
    return spec


def _qacc(model: mujoco.MjModel) -> np.ndarray:
    """The accelerations at a state where every feature above acts: the hinge past its limits and into the
    plane, the ball turned off its spring's rest, every joint moving, every control and activation 1."""
    data = mujoco.MjData(model)
    data.qpos[model.jnt_qposadr[model.joint("hinge").id]] = 0.3
    data.qpos[model.jnt_qposadr[model.joint("slide").id]] = 0.1
    if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "ball") >= 0:  # turned 0.4 rad about x
        adr = model.jnt_qposadr[model.joint("ball").id]
        data.qpos[adr:adr + 4] = [np.cos(0.2), np.sin(0.2), 0.0, 0.0]
    data.qvel[:] = 1.0
    data.ctrl[:] = 1.0
    data.act[:] = 1.0
    mujoco.mj_forward(model, data)
    return data.qacc.copy()


def _feature(name: str):
    return next(f for f in FEATURES if f.name.split(":")[0] == name)


@pytest.mark.parametrize(("name", "key", "having", "without"), CASES,
                         ids=[f"{c[0]}-{i}" for i, c in enumerate(CASES)])
def test_each_feature_left_out_is_detected_and_switched_off(name, key, having, without):
    """The feature is listed (and not on the model without it); where its entry has a switch-off, the isolated
    model moves as the model without the feature does, though the feature acted (the accelerations differ before);
    where it has none, the force is left acting."""
    feature = _feature(name)
    with_model = _spec(having).compile()
    bare = _spec(without).compile()
    assert key in uncovered(with_model) and key in {k for k, _, _ in feature.gaps(with_model)}
    assert key not in uncovered(bare)
    spec = _spec(having)
    isolate(spec)
    want, before, after = _qacc(bare), _qacc(with_model), _qacc(spec.compile())
    scale = float(np.max(np.abs(want)))
    assert np.max(np.abs(before - want)) > 1e-3 * scale  # the feature acts at this state
    if feature.switch_off is None:
        assert np.max(np.abs(after - want)) > 1e-3 * scale
    else:
        assert np.allclose(after, want, rtol=1e-10, atol=1e-10 * scale)


@needs_polynomial_springs
def test_a_balls_polynomial_spring_is_listed_and_left_acting():
    """A ball's polynomial spring with no linear part (a hinge or slide's is read: tests/test_tree.py), as the
    table's cases above are."""
    test_each_feature_left_out_is_detected_and_switched_off(
        "joint springs", "joint ball spring", {"bodies": BALL.format("stiffness='0 20 40'")},
        {"bodies": BALL.format("")})


def test_every_feature_left_out_has_a_case_here():
    """Adding an entry that leaves a feature out means adding its case above."""
    tested = {name for name, *_ in CASES}
    assert {f.name.split(":")[0] for f in FEATURES if f.gaps} == tested


def test_what_the_table_says_is_read_are_fields_of_the_references_types():
    for feature in FEATURES:
        for where in feature.read:
            kind, field = where.split(".")
            assert field in {f.name for f in dataclasses.fields(getattr(tree_types, kind))}, (feature.name, where)
    assert all(f.read or f.gaps for f in FEATURES)


def test_a_model_with_nothing_left_out_is_isolated_to_its_flags_alone():
    """isolate on a model none of whose features it switches off changes its dynamics in nothing."""
    spec = _spec({})
    bare = spec.compile()
    assert not uncovered(bare)
    isolate(spec)
    assert np.array_equal(_qacc(spec.compile()), _qacc(bare))

"""Second opinions: Pinocchio built from the compiled model, and the three-way comparison with MuJoCo and the
tree reference (harness/opinions/).

The conventions between MuJoCo and Pinocchio are pinned on a model that has every joint kind, a hinge and a
slide with ``ref``, several joints on one body, a welded body, armature and gravity off; the attribution is
pinned by planting an error in one side at a time, so each test would fail were the side not named, or the
gated figure not over its limit.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from harness import validate
from harness.engine.compat import full_mass_matrix
from harness.opinions import pinocchio as peer
from harness.opinions import threeway

pytest.importorskip("pinocchio")

EVERYTHING = """
<mujoco>
  <option gravity="0.3 -0.2 -9.81"/>
  <worldbody>
    <body name="floating" pos="0.1 0.2 1.3" quat="0.9 0.1 0.3 0.2">
      <freejoint/>
      <inertial pos="0.05 -0.02 0.01" quat="0.8 0.2 0.1 0.5" mass="2" diaginertia="0.03 0.02 0.01"/>
      <body name="two_joints" pos="0.3 0 0" quat="0.7 0.7 0 0">
        <joint name="hinge_ref" type="hinge" axis="0.3 1 0.2" pos="0 0.05 0" ref="0.4" armature="0.01"/>
        <joint name="slide_ref" type="slide" axis="1 0 0.5" ref="-0.2" armature="0.02"/>
        <inertial pos="0.1 0.02 0" mass="0.7" diaginertia="0.004 0.003 0.002"/>
        <body name="welded" pos="0 0 -0.2" euler="0.3 0.2 0.1">
          <inertial pos="0.02 0.01 -0.05" quat="0.6 0.1 0.7 0.2" mass="0.3" diaginertia="0.002 0.001 0.0015"/>
          <body name="ball" pos="0.1 0 -0.1">
            <joint name="ball" type="ball" pos="0 0 0.05" armature="0.005"/>
            <inertial pos="0 0.03 -0.1" mass="0.5" diaginertia="0.003 0.002 0.001"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _everything(*, gravity: bool = True) -> mujoco.MjModel:
    text = EVERYTHING if gravity else EVERYTHING.replace("<worldbody>", '<option><flag gravity="disable"/></option>'
                                                                       "<worldbody>")
    return mujoco.MjModel.from_xml_string(text)


def _state(model: mujoco.MjModel, seed: int = 3) -> tuple[mujoco.MjData, np.ndarray, np.ndarray]:
    qpos, qvel = threeway._states(model, 1, seed)
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = qpos[0], qvel[0]
    mujoco.mj_forward(model, data)
    return data, qpos[0], qvel[0]


def test_pinocchio_places_every_body_where_mujoco_does():
    """Quaternion order, hinge and slide measured from qpos0 (``ref``), anchors, several joints on one body and a
    welded body: each body's frame from Pinocchio's kinematics is MuJoCo's xpos/xmat."""
    import pinocchio as pin

    model = _everything()
    data, qpos, _ = _state(model)
    built = peer.build(model)
    pdata = built.model.createData()
    pin.forwardKinematics(built.model, pdata, built.q(qpos))
    # the body "ball" carries the last joint: its frame is that joint's frame moved back by the anchor
    ball = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "ball")
    placement = pdata.oMi[built.model.njoints - 1] * pin.SE3(np.eye(3), -np.array(model.jnt_pos[-1]))
    np.testing.assert_allclose(placement.translation, data.xpos[ball], atol=1e-14)
    np.testing.assert_allclose(placement.rotation, data.xmat[ball].reshape(3, 3), atol=1e-14)


@pytest.mark.parametrize("gravity", [True, False], ids=["gravity", "gravity-disabled"])
def test_pinocchio_of_the_compiled_model_agrees_with_mujoco(gravity):
    """M, bias forces, forward and inverse dynamics in MuJoCo's dofs, to round-off, at a moving state; with the
    gravity flag off Pinocchio's gravity is off too (built with the model's gravity vector, the bias forces of
    dm_control's finger and fish differed by gravity's whole size)."""
    model = peer.rigid(_everything(gravity=gravity))
    data, qpos, qvel = _state(model)
    built = peer.build(model)
    mass = full_mass_matrix(model, data)
    np.testing.assert_allclose(built.mass_matrix(qpos), mass, rtol=0, atol=1e-13 * np.abs(mass).max())
    force_scale = np.abs(data.qfrc_bias).max()
    np.testing.assert_allclose(built.bias(qpos, qvel), data.qfrc_bias, rtol=0, atol=1e-12 * force_scale)
    force = np.linspace(-1.0, 1.0, model.nv)
    data.qfrc_applied[:] = force
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(built.forward(qpos, qvel, force), data.qacc, rtol=0,
                               atol=1e-11 * np.abs(data.qacc).max())


def test_a_free_joints_velocity_frame_is_mapped():
    """MuJoCo's free-joint linear velocity is world-frame, Pinocchio's body-frame: taken as the same numbers,
    the bias forces differ by far more than round-off; mapped, they agree."""
    import pinocchio as pin

    model = peer.rigid(_everything())
    data, qpos, qvel = _state(model)
    built = peer.build(model)
    naive = np.array(pin.rnea(built.model, built.model.createData(), built.q(qpos), qvel, np.zeros(model.nv)))
    scale = np.abs(data.qfrc_bias).max()
    assert np.abs(naive - data.qfrc_bias).max() > 1e-3 * scale
    assert np.abs(built.bias(qpos, qvel) - data.qfrc_bias).max() < 1e-12 * scale


def _arm() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path("examples/arm.xml")


def test_all_three_agree_on_shipped_and_foreign_models():
    for model in (_everything(), _everything(gravity=False), _arm()):
        result = threeway.three_way(model)
        assert not result.skipped
        assert [a.off for a in result.agreements] == ["", "", "", ""], result.lines()
        assert all(a.mujoco <= threeway.LIMIT for a in result.agreements)


PLANTED = 1e-9  # relative: far below anything physical, far above 64 ε cond(M) on the arm (cond(M) ≈ 20)


@pytest.mark.parametrize("side", ["MuJoCo", "tree", "Pinocchio"])
def test_the_side_that_is_off_is_named(side, monkeypatch):
    """An error planted in one side's mass matrix (and so in what it solves with it) is attributed to that side;
    MuJoCo's gated figure goes over its limit only where MuJoCo is the one off."""
    if side == "MuJoCo":
        original = threeway.full_mass_matrix
        monkeypatch.setattr(threeway, "full_mass_matrix",
                            lambda m, d: original(m, d) * (1 + PLANTED))
    elif side == "tree":
        original_tree = threeway._tree_side
        monkeypatch.setattr(threeway, "_tree_side",
                            lambda m, qpos, qvel: (lambda mb: (mb[0] * (1 + PLANTED), mb[1]))(
                                original_tree(m, qpos, qvel)))
    else:
        original_pin = peer.PinocchioModel.mass_matrix
        monkeypatch.setattr(peer.PinocchioModel, "mass_matrix",
                            lambda self, qpos: original_pin(self, qpos) * (1 + PLANTED))
    result = threeway.three_way(_arm())
    mass = result.agreements[0]
    assert mass.quantity == "mass_matrix" and mass.off == side, result.lines()
    assert (mass.mujoco > threeway.LIMIT) == (side == "MuJoCo")


def test_a_check_fails_where_mujoco_is_off(monkeypatch):
    """The gate: MuJoCo's planted error fails its instant.peer check, and only that figure's among the peers."""
    original = threeway.full_mass_matrix
    monkeypatch.setattr(threeway, "full_mass_matrix", lambda m, d: original(m, d) * (1 + PLANTED))
    result = validate(mjcf="examples/arm.xml", integrators=["RK4"])
    failed = [str(c.name) for c in result.failures]
    assert "instant.peer.mass_matrix" in failed
    assert not [f for f in failed if f.startswith("instant.peer.") and f != "instant.peer.mass_matrix"]


def test_without_pinocchio_one_line_says_what_is_skipped(monkeypatch):
    monkeypatch.setattr(peer, "available", lambda: False)
    result = threeway.three_way(_arm())
    assert result.skipped == threeway.SKIPPED and result.figures() == []
    assert threeway.summary({"a": result.as_dict(), "b": result.as_dict()}) == [threeway.SKIPPED]
    assert "pip install 'mjharness[pin]'" in threeway.SKIPPED

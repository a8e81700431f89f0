"""Points at sites: an analytic point named like a site is that body-fixed point, everywhere.

The recorders and the instantaneous layer read a named point through
``harness.engine.points``: a site's world position, velocity and acceleration as
a point fixed in its body, else a body's centre of mass. Pinned here against
MuJoCo's own independent answers (``mj_objectVelocity`` at the site, a finite
difference of the velocity along the motion) and, for the batch recorder,
against the loop bit for bit, on a hinge chain and on a ball joint (where the
site's offset from the rotation axis makes the body's orientation visible).
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from harness.core.errors import ModelMismatch
from harness.engine import recording
from harness.engine.bindings import JointBinding, velocity_map
from harness.engine.integrators import available_integrators
from harness.engine.models import load_spec, mjcf_path
from harness.engine.points import point_source
from harness.engine.probe import Probe
from harness.engine.recording import batch, native, point_state, record
from harness.families.sampled import point_acceleration
from mjcf.spherical_pendulum_ball import BallBinding

# the recorders in C this MuJoCo has (the native one where it could be built, the batch one where mujoco.batch is)
IN_C = [m for m, here in (("native", native.library() is not None), ("batch", batch.mujoco_batch is not None)) if here]
OFFSETS = {"tip1": ("bob1", [0.12, 0.05, -0.2]), "tip2": ("bob2", [-0.07, 0.3, 0.1])}


def _with_sites(name: str, sites: dict[str, tuple[str, list[float]]], integrator: str = "RK4") -> mujoco.MjModel:
    spec = load_spec(mjcf_path(name))
    for site, (body, pos) in sites.items():
        spec.body(body).add_site(name=site, pos=pos)
    spec.option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
    return spec.compile()


def _chain(integrator: str = "RK4") -> tuple[mujoco.MjModel, Probe, list[float], list[float]]:
    model = _with_sites("double_pendulum", OFFSETS, integrator)
    probe = Probe(binding=JointBinding(("theta1", "theta2")), points=("tip1", "bob2", "tip2"), constraints=())
    return model, probe, [0.9, -0.4], [0.3, 1.7]


def _ball(integrator: str = "RK4") -> tuple[mujoco.MjModel, Probe, list[float], list[float]]:
    model = _with_sites("spherical_pendulum_ball", {"rim": ("bob", [0.1, 0.2, 0.05])}, integrator)
    probe = Probe(binding=BallBinding(("theta", "phi")), points=("rim", "bob"), constraints=())
    return model, probe, [0.8, 0.3], [0.5, 2.0]


def test_a_site_is_read_before_a_body_and_a_missing_point_is_named():
    model, _, _, _ = _chain()
    assert point_source(model, "tip1").kind == "site" and point_source(model, "bob2").kind == "body"
    assert point_source(model, "tip1").body == model.body("bob1").id
    with pytest.raises(ModelMismatch, match="no site or body 'nowhere'"):
        point_source(model, "nowhere")


@pytest.mark.parametrize("make", [_chain, _ball])
def test_a_site_moves_with_its_body(make):
    """Position: the body's frame applied to the site's offset; velocity: mj_objectVelocity at the
    site (world orientation), an independent MuJoCo routine."""
    model, probe, q0, qd0 = make()
    data = mujoco.MjData(model)
    probe.binding.set_state(model, data, q0, qd0)
    mujoco.mj_forward(model, data)
    for site in [p for p in probe.points if point_source(model, p).kind == "site"]:
        sid = model.site(site).id
        body = model.site_bodyid[sid]
        x, v = point_state(model, data, site)
        np.testing.assert_allclose(x, data.xpos[body] + data.xmat[body].reshape(3, 3) @ model.site_pos[sid],
                                   rtol=0, atol=1e-15)
        six = np.zeros(6)
        mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_SITE, sid, six, 0)
        np.testing.assert_allclose(v, six[3:], rtol=0, atol=1e-14)
        assert np.linalg.norm(v) > 0.1


@pytest.mark.parametrize("make", [_chain, _ball])
def test_a_site_acceleration_is_the_rate_of_its_velocity(make):
    """J qacc + J̇ qvel at a site against a central difference of the site's velocity along
    (q + t qvel + ½t² qacc, qvel + t qacc): agreement to the difference's O(t²)."""
    model, probe, q0, qd0 = make()
    data = mujoco.MjData(model)
    probe.binding.set_state(model, data, q0, qd0)
    mujoco.mj_forward(model, data)
    qpos, qvel, qacc = data.qpos.copy(), data.qvel.copy(), data.qacc.copy()
    acc = {p: point_acceleration(model, data, p) for p in probe.points}
    dt = 1e-5
    moved = mujoco.MjData(model)

    def velocity(t: float, point: str) -> np.ndarray:
        moved.qpos[:] = qpos
        mujoco.mj_integratePos(model, moved.qpos, qvel * t + 0.5 * qacc * t * t, 1.0)
        moved.qvel[:] = qvel + qacc * t
        mujoco.mj_kinematics(model, moved)
        mujoco.mj_comPos(model, moved)
        return point_state(model, moved, point)[1]

    for p in probe.points:
        rate = (velocity(dt, p) - velocity(-dt, p)) / (2 * dt)
        np.testing.assert_allclose(acc[p], rate, rtol=0, atol=1e-6 * max(1.0, np.linalg.norm(rate)))


@pytest.mark.parametrize("method", IN_C)
@pytest.mark.parametrize("make", [_chain, _ball])
def test_the_recorders_in_c_read_sites_as_the_loop_does(make, method):
    """Sites and bodies side by side, every integrator: the native and batch recorders' positions and
    velocities (site_xpos, J assembled from cdof at the site) equal the loop's, bit for bit, without falling
    back."""
    for integrator in available_integrators():
        model, probe, q0, qd0 = make(integrator)
        assert "site_xpos" in recording.recorded_fields(model, probe)
        notes = len(recording.notes())
        got = record(model, probe, q0=q0, qd0=qd0, steps=120, method=method)
        loop = record(model, probe, q0=q0, qd0=qd0, steps=120, method="loop")
        assert recording.notes()[notes:] == (), f"the {method} recorder fell back to the loop"
        for p in probe.points:
            assert np.array_equal(got.positions[p], loop.positions[p]), (integrator, p)
            assert np.array_equal(got.velocities[p], loop.velocities[p]), (integrator, p)


def test_bodies_alone_record_no_site_field():
    model = _chain()[0]
    probe = Probe(binding=JointBinding(("theta1", "theta2")), points=("bob1", "bob2"), constraints=())
    assert "site_xpos" not in recording.recorded_fields(model, probe)
    assert "xipos" in recording.recorded_fields(model, probe)


def test_velocity_map_takes_a_bindings_map_else_its_constant_dof_matrix():
    """bindings.velocity_map: a constant D with Ḃ q̇ None (exactly zero) for joint bindings, the
    binding's own B(q) where it has one (shape checked, naming what it expected), None with neither."""
    model, probe, q0, qd0 = _chain()
    mat, rate = velocity_map(probe.binding, model, np.array(q0), np.array(qd0))
    assert rate is None and np.array_equal(mat, probe.binding.dof_matrix(model))

    class Wrong(JointBinding):
        def velocity_map(self, model, q):
            return np.zeros((model.nv + 1, len(q)))

    with pytest.raises(ValueError, match=r"shape \(nv, n\) = \(2, 2\), got \(3, 2\)"):
        velocity_map(Wrong(("theta1", "theta2")), model, np.array(q0), np.array(qd0))

    class Neither(JointBinding):
        def dof_matrix(self, model):
            return None

    assert velocity_map(Neither(("theta1", "theta2")), model, np.array(q0), np.array(qd0)) is None

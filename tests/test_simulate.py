"""The MuJoCo recorder: same steps as mj_step, and every sample belongs to its state."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from harness.binding import JointBinding, ModelMismatch
from harness.models import ModelError, compile_model, mjcf_path
from harness.simulate import (
    Probe,
    SimulationDiverged,
    available_integrators,
    equality_force,
    simulate,
)

PROBE = Probe(binding=JointBinding(("theta", "r")), points=("bob",), constraints=("rod",))
Q0, QD0 = [1.0, 1.0], [0.5, 0.0]


@pytest.mark.parametrize("integrator", available_integrators())
def test_recording_is_bit_identical_to_mj_step(integrator):
    model = compile_model(mjcf_path("pendulum"), integrator=integrator)
    traj = simulate(model, PROBE, q0=Q0, qd0=QD0, steps=300)
    data = mujoco.MjData(model)
    PROBE.binding.set_state(model, data, Q0, QD0)
    for _ in range(300):
        mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    assert np.array_equal(traj.positions["bob"][-1], data.xipos[model.body("bob").id])


@pytest.mark.parametrize("integrator", available_integrators())
def test_recorded_fields_belong_to_the_recorded_state(integrator):
    """efc_force, energy, violation at sample k equal a fresh mj_forward at state k (RK4 included)."""
    model = compile_model(mjcf_path("pendulum"), integrator=integrator)
    steps = 50
    traj = simulate(model, PROBE, q0=Q0, qd0=QD0, steps=steps)
    data = mujoco.MjData(model)
    PROBE.binding.set_state(model, data, Q0, QD0)
    fresh = mujoco.MjData(model)
    for k in range(steps + 1):
        # the warm start is part of MuJoCo's integration state: copy it too
        fresh.qpos[:], fresh.qvel[:] = data.qpos, data.qvel
        fresh.qacc_warmstart[:] = data.qacc_warmstart
        mujoco.mj_forward(model, fresh)
        force, viol = equality_force(model, fresh, "rod")
        assert traj.multipliers["rod"][k] == force
        assert traj.violations["rod"][k] == viol
        assert traj.invariants["energy"][k] == fresh.energy[0] + fresh.energy[1]
        mujoco.mj_step(model, data)


@pytest.mark.parametrize("integrator", available_integrators())
def test_mj_step_fields_would_not_belong_to_the_new_state(integrator):
    """Why the recorder exists: after mj_step, efc_force and energy describe another state
    (the previous one, or RK4's last stage)."""
    model = compile_model(mjcf_path("pendulum"), integrator=integrator)
    data = mujoco.MjData(model)
    PROBE.binding.set_state(model, data, Q0, QD0)
    for _ in range(20):
        mujoco.mj_step(model, data)
    stale_force, stale_energy = equality_force(model, data, "rod")[0], data.energy.copy()
    mujoco.mj_forward(model, data)
    assert stale_force != equality_force(model, data, "rod")[0]
    assert not np.array_equal(stale_energy, data.energy)


def test_divergence_is_reported_not_returned():
    def explode(spec):
        spec.option.gravity = [0, 0, -1e12]

    model = compile_model(mjcf_path("pendulum"), integrator="Euler", timestep=0.05, edit=explode)
    with pytest.raises(SimulationDiverged):
        simulate(model, PROBE, q0=Q0, qd0=QD0, steps=2000)


def test_model_mismatch_names_what_is_missing():
    model = compile_model(mjcf_path("pendulum"))
    with pytest.raises(ModelMismatch, match="no equality 'string'"):
        simulate(model, Probe(binding=PROBE.binding, points=("bob",), constraints=("string",)),
                 q0=Q0, qd0=QD0, steps=2)
    with pytest.raises(ModelMismatch, match="no joint 'phi'"):
        simulate(model, Probe(binding=JointBinding(("phi", "r")), points=(), constraints=()),
                 q0=Q0, qd0=QD0, steps=2)


def test_invalid_mjcf_is_one_line_error(tmp_path):
    bad = tmp_path / "bad.xml"
    bad.write_text("<mujoco><worldbody><body><joint type='nope'/></body></worldbody></mujoco>")
    with pytest.raises(ModelError, match="invalid MJCF") as info:
        compile_model(bad)
    assert "\n" not in str(info.value)
    with pytest.raises(ModelError, match="no such file"):
        compile_model(tmp_path / "missing.xml")


def test_shipped_models_resolve_from_package_not_cwd(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert mjcf_path("pendulum").is_file()

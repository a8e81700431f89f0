"""The MuJoCo recorders: same steps as mj_step, and every sample belongs to its state.

The three recorders (the native one, built from C on first use where a
compiler is found; the batch recorder, in C, where ``mujoco.batch`` exists;
and the Python loop) are pinned to the same guarantees, and to each other bit
for bit on every registered case and integrator.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from harness import cases
from harness.core.errors import ModelError, ModelMismatch, SimulationDiverged
from harness.engine import recording
from harness.engine.bindings import JointBinding
from harness.engine.constraints import equality_block, equality_force
from harness.engine.integrators import available_integrators
from harness.engine.models import compile_model, mjcf_path
from harness.engine.probe import Probe
from harness.engine.readings import momentum
from harness.engine.recording import assemble, batch, equalities, native, point_state, record

PROBE = Probe(binding=JointBinding(("theta", "r")), points=("bob",), constraints=("rod",))
Q0, QD0 = [1.0, 1.0], [0.5, 0.0]
HAS_BATCH = batch.mujoco_batch is not None
HAS_NATIVE = native.library() is not None
# the recorders that write into reused scratch arrays: each must equal the loop
IN_C = [m for m, here in (("native", HAS_NATIVE), ("batch", HAS_BATCH)) if here]
METHODS = ["auto", "loop", *IN_C]


def _case_probe(name: str):
    case = cases.get(name)
    ref = case.reference(compile_model(case.mjcf))
    return case, case.probe(ref.dynamics), ref.q0(), ref.qd0()


def _arrays(traj) -> dict[str, np.ndarray]:
    out = {"t": traj.t}
    for group in ("positions", "velocities", "multipliers", "invariants", "violations", "series"):
        out |= {f"{group}.{k}": v for k, v in getattr(traj, group).items()}
    if traj.generalized_force is not None:
        out["generalized_force"] = traj.generalized_force
    return out


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("integrator", available_integrators())
def test_recording_is_bit_identical_to_mj_step(integrator, method):
    model = compile_model(mjcf_path("pendulum"), integrator=integrator)
    traj = record(model, PROBE, q0=Q0, qd0=QD0, steps=300, method=method)
    data = mujoco.MjData(model)
    PROBE.binding.set_state(model, data, Q0, QD0)
    for _ in range(300):
        mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    assert np.array_equal(traj.positions["bob"][-1], data.xipos[model.body("bob").id])


# two damped links with armature, held by position servos (kp, kv): what the discrete integrator folds into
# its step map (M + hD + h²K)
DAMPED_SERVOS = """<mujoco><option timestep="0.002"><flag energy="enable"/></option>
  <default><joint type="hinge" axis="0 1 0" damping="0.5" armature="0.05"/><position kp="20" kv="1"/></default>
  <worldbody><body name="a" pos="0 0 0.3"><joint name="j1"/><geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.04"/>
    <body name="b" pos="0 0 0.3"><joint name="j2"/><geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.04"/>
  </body></body></worldbody>
  <actuator><position joint="j1"/><position joint="j2"/></actuator></mujoco>"""


@pytest.mark.parametrize("integrator", available_integrators())
def test_every_recorder_steps_as_mj_step_on_damped_servos(integrator):
    """Damping with servos: under ``discrete`` mj_step's Euler update leaves out mj_Euler's implicit damping
    (already in the step map), so the loop's integration stage must too (with mj_Euler it was 1e-4 rad/s off
    at the first step); the recorders in C step with mj_step or as the loop."""
    from harness.engine.integrators import STEP_FUNCTIONS, integrator_enum

    model = mujoco.MjModel.from_xml_string(DAMPED_SERVOS)
    model.opt.integrator = integrator_enum(integrator)
    data, loop = mujoco.MjData(model), mujoco.MjData(model)
    for d in (data, loop):
        d.qvel[:] = [0.3, -0.3]
    for _ in range(50):
        mujoco.mj_step(model, data)
        mujoco.mj_forward(model, loop)
        STEP_FUNCTIONS[integrator](model, loop)
    assert np.array_equal(data.qvel, loop.qvel) and np.array_equal(data.qpos, loop.qpos)
    probe = Probe(binding=JointBinding(("j1", "j2")), points=("b",), constraints=())
    runs = {m: _arrays(record(model, probe, q0=[0.0, 0.0], qd0=[0.3, -0.3], steps=50, method=m)) for m in METHODS}
    mujoco.mj_forward(model, data)
    for m, run in runs.items():
        assert np.array_equal(run["positions.b"][-1], data.xipos[model.body("b").id]), m
        assert [k for k in run if not np.array_equal(run[k], runs["loop"][k])] == [], m


def test_a_run_of_many_steps_ends_at_the_horizon_its_reference_covers():
    """250 000 steps of 2e-5 s (the issue's ``--timestep 2e-5``): MuJoCo's clock reads 5.000000000015821 s
    at the end, past the reference's 5 s by its round-off. The samples are at k h, so the last is the
    horizon and the reference is sampled there (it refused 5.000000000015821 before)."""
    from harness.reference import solutions

    case, probe, q0, qd0 = _case_probe("pendulum")
    model = compile_model(case.mjcf, integrator="Euler", timestep=2e-5)
    steps = recording.steps_in(case.horizon, model.opt.timestep)
    traj = record(model, probe, q0=q0, qd0=qd0, steps=steps)
    assert steps == 250_000 and traj.t[-1] == case.horizon and np.array_equal(traj.t, np.arange(steps + 1) * 2e-5)
    reference = solutions.trajectory(case.reference(model), traj.t)
    assert reference.t[-1] == case.horizon


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("integrator", available_integrators())
def test_recorded_fields_belong_to_the_recorded_state(integrator, method):
    """efc_force, energy, violation at sample k equal a fresh mj_forward at state k (RK4 included)."""
    model = compile_model(mjcf_path("pendulum"), integrator=integrator)
    steps = 50
    traj = record(model, PROBE, q0=Q0, qd0=QD0, steps=steps, method=method)
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


# atwood_tendon (a tendon equality), slider_crank (connects), welded_pendulum (a weld): equalities read after
# mj_forward at every recorded state (cases this MuJoCo offers: the last three need MuJoCo >= 3.7)
RECORDED = ("atwood", "hoop_ramp", "hoop_plane", "spherical_pendulum_ball", "atwood_tendon", "slider_crank",
            "welded_pendulum")


@pytest.mark.parametrize("name", [n for n in RECORDED if n in cases.names()])
@pytest.mark.parametrize("integrator", ["Euler", "RK4"])
def test_every_recorded_quantity_belongs_to_its_state(name, integrator):
    """Positions, velocities, multipliers (two-joint equalities, contact readings), violations,
    energy, generalized force and Python readings at sample k equal a fresh mj_forward at the
    state mj_step reaches after k steps, bit for bit."""
    case, probe, q0, qd0 = _case_probe(name)
    model = compile_model(case.mjcf, integrator=integrator)
    steps = 40
    traj = record(model, probe, q0=q0, qd0=qd0, steps=steps)
    data, fresh = mujoco.MjData(model), mujoco.MjData(model)
    probe.binding.set_state(model, data, q0, qd0)
    spec = mujoco.mjtState.mjSTATE_INTEGRATION
    state = np.zeros(mujoco.mj_stateSize(model, spec))
    dof = probe.binding.dof_matrix(model)
    for k in range(steps + 1):
        mujoco.mj_getState(model, data, state, spec)
        mujoco.mj_setState(model, fresh, state, spec)
        mujoco.mj_forward(model, fresh)
        assert traj.t[k] == k * model.opt.timestep  # the state's time; MuJoCo's clock only rounds it
        assert abs(traj.t[k] - fresh.time) <= 4 * k * np.finfo(float).eps * max(fresh.time, model.opt.timestep)
        for p in probe.points:
            x, v = point_state(model, fresh, p)
            assert np.array_equal(traj.positions[p][k], x) and np.array_equal(traj.velocities[p][k], v)
        for c in probe.constraints:
            force, pos = equality_block(model, fresh, c)
            sign = probe.sign(c)
            assert np.array_equal(traj.multipliers[c][k], sign * force if force.size > 1 else sign * force[0])
            assert np.array_equal(traj.violations[c][k], sign * pos if pos.size > 1 else sign * pos[0])
        assert traj.invariants["energy"][k] == fresh.energy[0] + fresh.energy[1]
        if dof is not None:
            assert np.array_equal(traj.generalized_force[k], fresh.qfrc_constraint @ dof)
        for c, read in probe.forces.items():
            assert traj.multipliers[c][k] == read(model, fresh)
        for group in ("invariants", "series"):
            for key, read in getattr(probe, group).items():
                assert getattr(traj, group)[key][k] == read(model, fresh)
        mujoco.mj_step(model, data)


@pytest.mark.skipif(not IN_C, reason="neither the native recorder nor mujoco.batch here: the loop records everything")
@pytest.mark.parametrize("name", cases.names())
def test_recorders_in_c_equal_the_loop_bit_for_bit(name):
    """Every registered case, every integrator: the native and batch recorders give the loop's arrays, bit for
    bit."""
    case, probe, q0, qd0 = _case_probe(name)
    for integrator in available_integrators():
        model = compile_model(case.mjcf, integrator=integrator)
        loop = _arrays(record(model, probe, q0=q0, qd0=qd0, steps=120, method="loop"))
        for method in IN_C:
            notes = len(recording.notes())
            got = _arrays(record(model, probe, q0=q0, qd0=qd0, steps=120, method=method))
            assert got.keys() == loop.keys()
            assert [k for k in got if not np.array_equal(got[k], loop[k])] == [], (method, integrator)
            assert recording.notes()[notes:] == (), f"the {method} recorder fell back to the loop"


@pytest.mark.parametrize("method", IN_C)
def test_a_result_that_differs_from_mj_forward_is_not_used(monkeypatch, method):
    """The spot check against a fresh mj_forward: wrong velocities send the run to the loop, and a
    wrong recovered equality is read per sample instead; each says so in recording.notes()."""
    model = compile_model(mjcf_path("pendulum"), integrator="Euler")
    loop = _arrays(record(model, PROBE, q0=Q0, qd0=QD0, steps=60, method="loop"))
    if method == "native":  # its velocities come from C: spoil them as they come out
        real_record = native.mjh_record

        def spoiled(*args, velocity, **kwargs):
            out = real_record(*args, velocity=velocity, **kwargs)
            velocity *= 1 + 1e-15
            return out

        monkeypatch.setattr(native, "mjh_record", spoiled)
    else:
        real = assemble.point_velocity
        monkeypatch.setattr(assemble, "point_velocity", lambda *a: real(*a) * (1 + 1e-15))
    notes = len(recording.notes())
    again = _arrays(record(model, PROBE, q0=Q0, qd0=QD0, steps=60, method=method))
    assert all(np.array_equal(again[k], loop[k]) for k in loop)
    assert "velocity" in recording.notes()[notes] and "loop instead" in recording.notes()[notes]
    monkeypatch.undo()
    monkeypatch.setattr(equalities.JointEquality, "violation", lambda self, qpos: qpos[:, self.qpos1] * 0.0)
    notes = len(recording.notes())
    again = _arrays(record(model, PROBE, q0=Q0, qd0=QD0, steps=60, method=method))
    assert all(np.array_equal(again[k], loop[k]) for k in loop)
    assert "read per sample instead" in recording.notes()[notes]


@pytest.mark.skipif(not HAS_NATIVE, reason="no native recorder here")
@pytest.mark.parametrize("spoil", ["position", "momentum"])
def test_the_native_recorders_positions_and_momenta_are_checked(monkeypatch, spoil):
    """The native recorder writes the points' positions and the subtree momenta the readings project (p_phi's)
    as it steps, the momenta with the numpy reading's arithmetic, so that the reading is not recomputed over
    the run; both are checked at one sample against a fresh mj_forward, and a wrong one sends the run to the
    loop, saying so."""
    case, probe, q0, qd0 = _case_probe("spherical_pendulum")
    model = compile_model(case.mjcf, integrator="Euler")
    assert [r.about for r in probe.invariants.values()] == [("bob", "pivot")]
    loop = _arrays(record(model, probe, q0=q0, qd0=qd0, steps=200, method="loop"))
    widths = []
    real_momentum = momentum._spatial_momentum
    monkeypatch.setattr(momentum, "_spatial_momentum", lambda i, v: widths.append(np.size(i[0])) or real_momentum(i, v))
    notes = len(recording.notes())
    got = _arrays(record(model, probe, q0=q0, qd0=qd0, steps=200, method="native"))
    assert recording.notes()[notes:] == () and all(np.array_equal(got[k], loop[k]) for k in loop)
    assert widths == [1], "the reading was computed in numpy over the run, not taken from the native recorder"
    real_record = native.mjh_record

    def spoiled(*args, **kwargs):
        out = real_record(*args, **kwargs)
        kwargs[spoil] *= 1 + 1e-15
        return out

    monkeypatch.setattr(native, "mjh_record", spoiled)
    again = _arrays(record(model, probe, q0=q0, qd0=qd0, steps=200, method="native"))
    assert all(np.array_equal(again[k], loop[k]) for k in loop)
    said = recording.notes()[notes]
    assert ("position of 'bob'" if spoil == "position" else "angular momentum of 'bob' about 'pivot'") in said
    assert "loop instead" in said


def _on_one_and_two_threads_and_the_loop(model, probe, q0, qd0) -> tuple[dict, dict, dict]:
    """1000 steps recorded by the batch recorder on one thread and on two (never falling back to the loop), and
    by the loop: the three runs' arrays, with the same keys."""
    notes = len(recording.notes())
    try:
        recording.set_threads(1)
        one = _arrays(record(model, probe, q0=q0, qd0=qd0, steps=1000, method="batch"))
        recording.set_threads(2)
        two = _arrays(record(model, probe, q0=q0, qd0=qd0, steps=1000, method="batch"))
    finally:
        recording.set_threads(None)
    assert recording.notes()[notes:] == (), "the batch recorder fell back to the loop"
    loop = _arrays(record(model, probe, q0=q0, qd0=qd0, steps=1000, method="loop"))
    assert one.keys() == two.keys() == loop.keys()
    return one, two, loop


@pytest.mark.skipif(not HAS_BATCH, reason="no mujoco.batch in this MuJoCo")
@pytest.mark.parametrize("name, integrator", [("slider_crank", "Euler"), ("welded_pendulum", "implicitfast"),
                                              ("atwood_tendon", "RK4")])
def test_equalities_read_beside_the_rollout_are_the_same_on_any_number_of_threads(name, integrator):
    """A connect, a weld and tendon equalities, which no recorded field gives: read after mj_forward at every
    state, on one thread after the rollout or, with two, chunk by chunk beside it (1000 steps: several
    chunks). Both equal the loop bit for bit."""
    case, probe, q0, qd0 = _case_probe(name)
    model = compile_model(case.mjcf, integrator=integrator)
    assert probe.constraints and not equalities.joint_equalities(model, probe.constraints)
    assert len(batch._even_chunk_sizes(1000)) > 2
    one, two, loop = _on_one_and_two_threads_and_the_loop(model, probe, q0, qd0)
    assert any(k.startswith("multipliers.") for k in loop)
    assert [k for k in one if not (np.array_equal(one[k], two[k]) and np.array_equal(one[k], loop[k]))] == []


@pytest.mark.skipif(not HAS_BATCH, reason="no mujoco.batch in this MuJoCo")
@pytest.mark.parametrize("name", ["pendulum", "spherical_pendulum", "hoop_plane"])
def test_rk4_recomputation_is_the_same_on_any_number_of_threads(name):
    """One thread: one rollout, then every state recomputed. Two: the rollout in chunks, each chunk
    recomputed on the other thread while the next steps (1000 steps: several chunks, with readings).
    Both equal the loop bit for bit."""
    case, probe, q0, qd0 = _case_probe(name)
    model = compile_model(case.mjcf, integrator="RK4")
    assert len(batch._chunk_sizes(1000)) > 2
    one, two, loop = _on_one_and_two_threads_and_the_loop(model, probe, q0, qd0)
    assert [k for k in one if not (np.array_equal(one[k], two[k]) and np.array_equal(one[k], loop[k]))] == []
    with pytest.raises(ValueError, match="thread count"):
        recording.set_threads(0)


@pytest.mark.parametrize("method", IN_C)
@pytest.mark.parametrize("integrator", ["Euler", "RK4"])
def test_a_trajectory_owns_its_arrays(integrator, method):
    """The recorders in C reuse their scratch arrays from run to run: a trajectory must not see the
    next run's numbers."""
    case, probe, q0, qd0 = _case_probe("spherical_pendulum")
    model = compile_model(case.mjcf, integrator=integrator)
    notes = len(recording.notes())
    first = record(model, probe, q0=q0, qd0=qd0, steps=300, method=method)
    kept = {k: v.copy() for k, v in _arrays(first).items()}
    record(model, probe, q0=[0.5, 1.0], qd0=[1.0, -3.0], steps=300, method=method)
    assert recording.notes()[notes:] == (), f"the {method} recorder fell back to the loop"
    assert [k for k, v in _arrays(first).items() if not np.array_equal(v, kept[k])] == []


def test_without_mujoco_batch_the_loop_records_and_says_so(monkeypatch):
    """MuJoCo 3.3 has no mujoco.batch: the loop records, recorder() says why (never silent), and
    asking for the batch recorder is a one-line ValueError."""
    monkeypatch.setattr(batch, "mujoco_batch", None)
    monkeypatch.setattr(native, "library", lambda: None)
    monkeypatch.setattr(native, "why_not", lambda: "no C compiler found ($CC, cc, gcc or clang)")
    assert recording.recorder().startswith("loop") and "no mujoco.batch" in recording.recorder()
    assert "no native recorder: no C compiler found" in recording.recorder()
    model = compile_model(mjcf_path("pendulum"), integrator="RK4")
    traj = record(model, PROBE, q0=Q0, qd0=QD0, steps=20)
    assert traj.is_finite() and len(traj.t) == 21
    with pytest.raises(ValueError, match=r"method 'batch' needs mujoco\.batch"):
        record(model, PROBE, q0=Q0, qd0=QD0, steps=20, method="batch")
    with pytest.raises(ValueError, match="method must be"):
        record(model, PROBE, q0=Q0, qd0=QD0, steps=20, method="fast")


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


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("integrator", ["Euler", "RK4"])
def test_divergence_is_reported_not_returned(integrator, method):
    def explode(spec):
        spec.option.gravity = [0, 0, -1e12]

    model = compile_model(mjcf_path("pendulum"), integrator=integrator, timestep=0.05, edit=explode)
    with pytest.raises(SimulationDiverged, match=r"at t = ") as info:
        record(model, PROBE, q0=Q0, qd0=QD0, steps=2000, method=method)
    assert "\n" not in str(info.value)


@pytest.mark.skipif(not IN_C, reason="neither the native recorder nor mujoco.batch here")
@pytest.mark.parametrize("integrator", ["Euler", "implicitfast", "RK4"])
@pytest.mark.parametrize("stiffness, gravity, at", [(3e7, -9.81, 0.002), (0.0, -1e12, 0.0)])
def test_both_recorders_say_when_a_run_diverged(integrator, stiffness, gravity, at):
    """The time of a divergence is that of the state the warning was raised at, MuJoCo's own "Time = ..."
    (a stiff hinge spring, k = 3e7 against unit inertia, is past every integrator's stability at 1 ms
    from the third step; a huge gravity warns at once). The batch recorder finds it from its records:
    MuJoCo resets the data in that step, and the rollout stops."""
    from harness.engine import compat

    def edit(spec):
        compat.set_stiffness(spec.joint("theta"), stiffness)
        spec.option.gravity = [0, 0, gravity]

    model = compile_model(mjcf_path("pendulum"), integrator=integrator, edit=edit)
    said = []
    for method in (*IN_C, "loop"):
        with pytest.raises(SimulationDiverged) as info:
            record(model, PROBE, q0=Q0, qd0=QD0, steps=2000, method=method)
        said.append((info.value.what, info.value.t))
    assert said == [("mjWARN_BADQACC", pytest.approx(at, abs=1e-12))] * len(said)


@pytest.mark.parametrize("method", IN_C)
@pytest.mark.parametrize("integrator", ["Euler", "RK4"])
def test_a_diverged_run_leaves_nothing_to_the_next(integrator, method):
    """The recorders in C reuse their data, batch and scratch arrays: after a run that diverged (a MuJoCo
    warning), the next run of the same model is still the loop's, bit for bit."""
    model = compile_model(mjcf_path("pendulum"), integrator=integrator)
    with pytest.raises(SimulationDiverged):
        record(model, PROBE, q0=Q0, qd0=[1e11, 0.0], steps=600, method=method)
    notes = len(recording.notes())
    got = _arrays(record(model, PROBE, q0=Q0, qd0=QD0, steps=600, method=method))
    assert recording.notes()[notes:] == (), f"the {method} recorder fell back to the loop"
    loop = _arrays(record(model, PROBE, q0=Q0, qd0=QD0, steps=600, method="loop"))
    assert [k for k in loop if not np.array_equal(got[k], loop[k])] == []


@pytest.mark.parametrize("method", METHODS)
def test_recorders_make_the_checks_mj_step_makes(method):
    """A finite qacc above mjMAXVAL (1e10) is a MuJoCo warning inside mj_step (mj_checkAcc), so both
    recorders report it as a divergence, as a user stepping with mj_step would see it."""
    from harness.engine import compat

    case, probe, q0, qd0 = _case_probe("spherical_pendulum_ball")
    # the spin about the rod has inertia 1e-12: damping 3e-2 gives |qacc(0)| ≈ 3e10
    model = compile_model(case.mjcf, integrator="Euler",
                          edit=lambda spec: compat.set_damping(spec.joint("ball"), 3e-2))
    with pytest.raises(SimulationDiverged, match="mjWARN_BADQACC"):
        record(model, probe, q0=q0, qd0=qd0, steps=50, method=method)


def test_model_mismatch_names_what_is_missing():
    model = compile_model(mjcf_path("pendulum"))
    with pytest.raises(ModelMismatch, match="no equality 'string'"):
        record(model, Probe(binding=PROBE.binding, points=("bob",), constraints=("string",)),
               q0=Q0, qd0=QD0, steps=2)
    with pytest.raises(ModelMismatch, match="no joint 'phi'"):
        record(model, Probe(binding=JointBinding(("phi", "r")), points=(), constraints=()),
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

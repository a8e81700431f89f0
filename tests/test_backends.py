"""Backends behind one interface: the C backend is the C recorders unchanged, a backend that cannot run says
so in one line (backend, feature, fix), the round-off part follows the backend's arithmetic, and MJX (where
installed) records the same quantities as the C engine at the same state, its energy and constraint rows
computed by the harness.

MJX fixes its precision when it is imported (harness/engine/backends/mjx.py), so this process runs MJX in
float64 only; float32 runs in a subprocess (the slow tests).
"""

from __future__ import annotations

import dataclasses
import importlib
import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from harness import cases
from harness.budget import trajectory as budget_trajectory
from harness.cli.commands import main
from harness.core.errors import BackendUnavailable
from harness.engine import backends
from harness.engine.compat import full_mass_matrix
from harness.engine.models import compile_model
from harness.engine.simulate import simulate

ROOT = Path(__file__).resolve().parent.parent


def _setup(name: str, **compile_options):
    case = cases.get(name)
    model = compile_model(case.mjcf, **compile_options)
    ref = case.reference(model)
    return case, model, ref, case.probe(ref.dynamics)


def test_c_backend_is_the_c_recorder_bit_for_bit():
    _, model, ref, probe = _setup("pendulum")
    direct = simulate(model, probe, q0=ref.q0(), qd0=ref.qd0(), steps=200)
    via = backends.get("c").simulate_many([backends.Request(model, ref.q0(), ref.qd0(), 200)], probe)[0]
    with backends.use("c"):
        dispatched = backends.simulate(model, probe, q0=ref.q0(), qd0=ref.qd0(), steps=200)
    for run in (via, dispatched):
        assert np.array_equal(run.positions["bob"], direct.positions["bob"])
        assert np.array_equal(run.multipliers["rod"], direct.multipliers["rod"])
        assert np.array_equal(run.invariants["energy"], direct.invariants["energy"])


def test_default_backend_is_c():
    assert backends.active().name == "c"
    assert backends.active().precision == "float64"


@pytest.mark.parametrize("spec", ["cuda", "c,foo", ""])
def test_unknown_backend_is_refused_naming_the_accepted(spec):
    out = subprocess.run([sys.executable, "-m", "harness.cli", "check", "pendulum", "--backend", spec],
                         capture_output=True, text=True, cwd=ROOT, timeout=120)
    err = out.stderr.strip()
    assert out.returncode == 2 and len(err.splitlines()) == 1 and "c, mjx, mjx-f64, warp, all" in err, err


def test_a_backend_not_installed_is_one_line_naming_the_fix(monkeypatch, capsys):
    real, real_spec = importlib.import_module, importlib.util.find_spec

    def missing(name, *args):
        if name.startswith("harness.engine.backends.") and not name.endswith(".c"):
            raise ModuleNotFoundError("No module named 'jax'", name="jax")
        return real(name, *args)

    monkeypatch.setattr(backends, "_loaded", {})
    monkeypatch.setattr(importlib, "import_module", missing)
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "jax" else real_spec(name))
    with pytest.raises(BackendUnavailable, match=r"backend 'mjx' is not installed \(jax is missing\); "
                                                 r"fix: pip install 'mjharness\[mjx\]'"):
        backends.get("mjx")
    assert main(["check", "pendulum", "--backend", "mjx-f64"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == ("mjharness: error: backend 'mjx-f64' is not installed (jax is missing); "
                   "fix: pip install 'mjharness[mjx]', or use --backend c")


def test_roundoff_part_follows_the_backends_epsilon():
    """float64 keeps the constant the C engine's budgets always had (bit for bit); float32 is the same
    count of epsilons of float32."""
    assert budget_trajectory.ROUNDOFF_EPS * float(np.finfo(np.float64).eps) == budget_trajectory.ROUNDOFF
    assert budget_trajectory.ROUNDOFF_EPS * float(np.finfo(np.float32).eps) / budget_trajectory.ROUNDOFF == 2.0**29


# ---------------------------------------------------------------- MJX (where installed)
def _mjx64():
    pytest.importorskip("jax")
    pytest.importorskip("mujoco.mjx")
    try:
        return backends.get("mjx-f64")
    except BackendUnavailable as exc:  # this process already ran MJX in float32
        pytest.skip(str(exc))


@pytest.mark.parametrize("name", ["pendulum", "atwood", "hoop_ramp_contact", "spring"])
def test_mjx_reads_what_the_c_engine_reads_at_the_same_state(name):
    """Sample 0 of a run is the fields after a forward at the initial state, on either engine: positions,
    velocities (J·q̇ from MJX's cdof), the energy the harness computes from MJX's state and mass matrix,
    the equalities' rows found in MJX's efc arrays. In float64 they agree to round-off and to the
    constraint solver's tolerance (Newton at 1e-12 here), on the model MJX runs (diagexact cleared: with
    it, atwood's string tensions differ by the regulariser's share, 10.86 vs 10.58 N)."""
    mjx64 = _mjx64()
    _, model, ref, probe = _setup(name, integrator="Euler")
    # the C engine on what MJX runs: diagexact (which MJX lacks; listed as adapted) cleared, energy kept
    model.opt.enableflags &= ~int(getattr(mujoco.mjtEnableBit, "mjENBL_DIAGEXACT", 0))  # none before 3.3.x
    c_run = simulate(model, probe, q0=ref.q0(), qd0=ref.qd0(), steps=1)
    m_run = mjx64.simulate_many([backends.Request(model, ref.q0(), ref.qd0(), 1)], probe)[0]
    scale = max(1.0, float(np.abs(c_run.invariants["energy"]).max()))
    assert abs(m_run.invariants["energy"][0] - c_run.invariants["energy"][0]) <= 1e-12 * scale
    for p in probe.points:
        assert np.allclose(m_run.positions[p][0], c_run.positions[p][0], rtol=0, atol=1e-12)
        assert np.allclose(m_run.velocities[p][0], c_run.velocities[p][0], rtol=0, atol=1e-12)
    for c in probe.constraints:
        force = np.atleast_1d(c_run.multipliers[c][0])
        assert np.allclose(np.atleast_1d(m_run.multipliers[c][0]), force, rtol=1e-8, atol=1e-9)
        assert np.allclose(np.atleast_1d(m_run.violations[c][0]), np.atleast_1d(c_run.violations[c][0]),
                           rtol=0, atol=1e-12)
    # an equality whose rows are −1 × its constraint's (Probe.signs, atwood_tendon's strings) reads negated on
    # MJX as on the C engine
    flipped = dataclasses.replace(probe, signs={c: -1.0 for c in probe.constraints})
    m_flip = mjx64.simulate_many([backends.Request(model, ref.q0(), ref.qd0(), 1)], flipped)[0]
    c_flip = simulate(model, flipped, q0=ref.q0(), qd0=ref.qd0(), steps=1)
    for c in probe.constraints:
        assert np.array_equal(m_flip.multipliers[c], -m_run.multipliers[c])
        assert np.array_equal(m_flip.violations[c], -m_run.violations[c])
        assert np.array_equal(c_flip.multipliers[c], -c_run.multipliers[c])


def test_mjx_energy_fails_on_a_wrong_mass_matrix():
    """The harness's energy is checked against MuJoCo's: a mass matrix off by 1 % moves it visibly."""
    _mjx64()
    from harness.engine.backends.mjx import energy  # lazy: needs jax, which _mjx64 skips without
    _, model, ref, probe = _setup("pendulum", integrator="Euler")
    data = mujoco.MjData(model)
    probe.binding.set_state(model, data, ref.q0(), ref.qd0())
    mujoco.mj_forward(model, data)
    full = full_mass_matrix(model, data)
    rec = {"qpos": data.qpos[None], "qvel": data.qvel[None], "xipos": data.xipos[None], "qM": full[None]}
    potential, kinetic = energy(model, rec)
    assert potential[0] == pytest.approx(data.energy[0], rel=1e-13, abs=1e-13)
    assert kinetic[0] == pytest.approx(data.energy[1], rel=1e-13)
    rec["qM"] = 1.01 * full[None]
    assert abs(energy(model, rec)[1][0] - data.energy[1]) > 1e-3 * data.energy[1]


def test_mjx_refuses_an_integrator_it_lacks_in_one_line():
    mjx64 = _mjx64()
    model = compile_model(cases.get("pendulum").mjcf, integrator="implicit")
    why = mjx64.unsupported(model)
    assert "backend 'mjx-f64'" in why and "implicit" in why and "fix:" in why and "\n" not in why
    assert mjx64.unsupported(compile_model(cases.get("pendulum").mjcf, integrator="RK4")) == ""


def test_mjx_batched_call_equals_single_calls():
    """One vmap over runs at different timesteps gives each run what it gets alone (the same arithmetic)."""
    mjx64 = _mjx64()
    _, _, ref, probe = _setup("pendulum")
    mjcf = cases.get("pendulum").mjcf
    requests = [backends.Request(compile_model(mjcf, integrator="RK4", timestep=h), ref.q0(), ref.qd0(), n)
                for h, n in ((0.002, 100), (0.001, 200))]
    together = mjx64.simulate_many(requests, probe)
    for r, run in zip(requests, together, strict=True):
        alone = mjx64.simulate_many([r], probe)[0]
        assert len(run.t) == r.steps + 1
        np.testing.assert_allclose(run.positions["bob"], alone.positions["bob"], rtol=0, atol=1e-13)


def _in_float32(code: str) -> dict:
    """Run ``code`` (which prints JSON) in a fresh process, where MJX is imported in float32."""
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=3000)
    assert out.returncode == 0, out.stderr[-2000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_mjx_float32_passes_and_a_fault_still_fails():
    """The float32 round-off part lets a correct float32 engine pass, and does not hide a fault: the
    pendulum with joint damping 1e-3 (README's fault) fails under MJX float32 as under C."""
    pytest.importorskip("jax")
    pytest.importorskip("mujoco.mjx")
    found = _in_float32(
        "import json, harness\n"
        "from harness.engine.compat import set_damping\n"
        "ok = harness.validate('pendulum', integrators=['RK4'], backend='mjx')\n"
        "bad = harness.validate('pendulum', integrators=['RK4'], backend='mjx',"
        " edit=lambda s: set_damping(s.joint('theta'), 1e-3))\n"
        "print(json.dumps({'ok': ok.passed, 'ok_failures': [c.name for c in ok.failures],"
        " 'bad': bad.passed, 'bad_failures': [c.name for c in bad.failures],"
        " 'precision': ok.settings['backend']['precision']}))\n")
    assert found["precision"] == "float32"
    assert found["ok"], found["ok_failures"]
    assert not found["bad"] and "RK4.position" in found["bad_failures"]

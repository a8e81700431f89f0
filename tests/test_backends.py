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
from harness.budget.roundoff import ROUNDOFF_EPS
from harness.cli.commands import main
from harness.core.errors import BackendUnavailable
from harness.core.options import RunOptions
from harness.engine import backends
from harness.engine.compat import full_mass_matrix
from harness.engine.models import compile_model
from harness.engine.recording import record
from harness.families import COMPARISONS, sampled
from harness.families import runs as trajectory_budget

ROOT = Path(__file__).resolve().parent.parent


def _setup(name: str, **compile_options):
    case = cases.get(name)
    model = compile_model(case.mjcf, **compile_options)
    ref = case.reference(model)
    return case, model, ref, case.probe(ref.dynamics)


def test_c_backend_is_the_c_recorder_bit_for_bit():
    _, model, ref, probe = _setup("pendulum")
    direct = record(model, probe, q0=ref.q0(), qd0=ref.qd0(), steps=200)
    via = backends.get("c").simulate_many([backends.Request(model, ref.q0(), ref.qd0(), 200)], probe)[0]
    dispatched = backends.simulate(backends.get("c"), model, probe, q0=ref.q0(), qd0=ref.qd0(), steps=200)
    for run in (via, dispatched):
        assert np.array_equal(run.positions["bob"], direct.positions["bob"])
        assert np.array_equal(run.multipliers["rod"], direct.multipliers["rod"])
        assert np.array_equal(run.invariants["energy"], direct.invariants["energy"])


def test_default_backend_is_c():
    assert RunOptions().backend == "c"
    assert backends.get(RunOptions().backend).precision == "float64"


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
    assert ROUNDOFF_EPS * float(np.finfo(np.float64).eps) == trajectory_budget.ROUNDOFF
    assert ROUNDOFF_EPS * float(np.finfo(np.float32).eps) / trajectory_budget.ROUNDOFF == 2.0**29


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
    c_run = record(model, probe, q0=ref.q0(), qd0=ref.qd0(), steps=1)
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
    c_flip = record(model, flipped, q0=ref.q0(), qd0=ref.qd0(), steps=1)
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
        " 'precision': ok.settings.backend['precision']}))\n")
    assert found["precision"] == "float32"
    assert found["ok"], found["ok_failures"]
    assert not found["bad"] and "RK4.position" in found["bad_failures"]


# ------------------------------------------------- the instantaneous layer on the active backend
def _states(name: str, count: int = 6):
    """A case's compiled model, probe, reference and its first ``count`` sampled states in MuJoCo's coordinates."""
    case, model, ref, probe = _setup(name)
    q, qd = sampled.sample_states(ref, count)
    data = mujoco.MjData(model)
    qpos, qvel = [], []
    for a, b in zip(q, qd, strict=True):
        mujoco.mj_resetData(model, data)
        probe.binding.set_state(model, data, a, b)
        qpos.append(data.qpos.copy())
        qvel.append(data.qvel.copy())
    return case, model, ref, probe, np.array(qpos), np.array(qvel)


def _instant_budgets(name: str, backend: str):
    """The instantaneous figures of case ``name`` and their budgets, evaluated on ``backend``."""
    from harness.engine.variants import ModelUnderTest
    case, model, ref, probe = _setup(name)
    ev = sampled.evaluate(ModelUnderTest(path=case.mjcf), model, probe, ref, backends.get(backend),
                          COMPARISONS.at_states)
    return ev, ev.budgets


def test_c_forward_many_carried_into_the_layer_changes_no_number():
    """The instantaneous layer's backend path (the backend's arrays written into C's MjData at the same state)
    is exact: with the C backend's own forward_many carried, every figure is bit for bit the C path's."""
    compare = sampled.combined(COMPARISONS.at_states)
    for name in ("welded_pendulum", "slider_crank", "double_pendulum"):
        if name in cases.unavailable():  # an older MuJoCo (the connect/weld loops need 3.7.0)
            continue
        _, model, ref, probe = _setup(name)
        q, qd = sampled.sample_states(ref)
        qpos, qvel = sampled.mujoco_states(model, probe, q, qd)
        fwd = backends.get("c").forward_many(model, probe, qpos, qvel)
        plain = compare(sampled._measure(model, probe, ref, q, qd, states=None, fwd=None, offset=0, backend="c"))[0]
        carried = compare(sampled._measure(model, probe, ref, q, qd, states=None, fwd=fwd, offset=0,
                                           backend="c"))[0]
        assert [d.name for d in plain] == [d.name for d in carried]
        for a, b in zip(plain, carried, strict=True):
            assert np.array_equal(a.values, b.values), (name, a.name)


def _damped(backend: backends.Backend, monkeypatch, damping: float) -> None:
    """A fault in the backend's forward alone: joint damping ``damping`` on every dof (qfrc_passive −= b qvel,
    qacc += M⁻¹(−b qvel)), as a damped model would give, while the C engine's model stays undamped."""
    original = backend.forward_many

    def faulty(model, probe, qpos, qvel):
        fwd = original(model, probe, qpos, qvel)
        extra = -damping * qvel
        return dataclasses.replace(fwd, qfrc_passive=fwd.qfrc_passive + extra,
                                   qacc=fwd.qacc + np.linalg.solve(fwd.mass, extra[..., None])[..., 0])

    monkeypatch.setattr(backend, "forward_many", faulty)


def check_figures_are_the_backends_own(backend: backends.Backend, name: str, monkeypatch) -> None:
    """A fault in ``backend``'s forward alone (:func:`_damped`, 1e-3) fails the forcing, qacc and point
    acceleration figures of double_pendulum on it (``name``), while the C engine's of the same model pass."""
    _, c_budgets = _instant_budgets("double_pendulum", "c")
    _damped(backend, monkeypatch, 1e-3)
    _, budgets = _instant_budgets("double_pendulum", name)
    for figure in ("instant.forcing", "instant.qacc", "instant.point_acceleration"):
        assert c_budgets[figure].passed, figure
        assert not budgets[figure].passed, (figure, budgets[figure].unexplained, budgets[figure].limit)


@pytest.mark.parametrize("name", ["pendulum", "double_pendulum", "atwood"])
def test_mjx_instant_figures_pass_their_budgets(name):
    """On MJX (float64 in this process) every instantaneous figure passes its budget: pendulum (a joint
    equality), double_pendulum (force, torque and accelerometer sensors, which MJX leaves at zero without
    constraint rows: computed by the harness from MJX's qacc), atwood (tendon equalities)."""
    _mjx64()
    ev, budgets = _instant_budgets(name, "mjx-f64")
    assert not ev.unavailable and not ev.perturbed  # float64: today's round-off rule, no copies
    failed = {str(k): (b.unexplained, b.limit) for k, b in budgets.items() if not b.passed}
    assert not failed, failed
    assert any(str(k).startswith("instant.sensor.") for k in budgets) or name == "atwood"


def test_mjx_instant_figures_are_mjxs_own(monkeypatch):
    """A fault in MJX's forward alone (damping 1e-3 added to its qfrc_passive and qacc) fails the forcing and
    qacc figures on MJX, while the C engine's figures of the same model pass: the figures are not C's."""
    check_figures_are_the_backends_own(_mjx64(), "mjx-f64", monkeypatch)


def test_reactions_the_backend_lacks_are_na_with_the_reason_where_rows_do_not_map(monkeypatch):
    """Where the backend hands back no reaction sensors and C's constraint rows include contacts (hoop_ramp_contact),
    the sensor and interaction figures are n/a with a one-line reason, never the C engine's values."""
    mjx64 = _mjx64()
    original = mjx64.forward_many
    monkeypatch.setattr(mjx64, "forward_many", lambda *a: dataclasses.replace(
        original(*a), sensordata=None, cfrc_int=None, cfrc_ext=None))
    from harness.families.reactions import sensor_names
    _, model, ref, probe = _setup("hoop_ramp_contact")
    ev = sampled.at_states(model, probe, ref, backends.get("mjx-f64"), COMPARISONS.at_states)
    sensors, bodies = sensor_names(model)
    expected = {f"instant.sensor.{s}" for s in sensors} | {f"instant.interaction.{b}" for b in bodies}
    assert expected and set(ev.unavailable) == expected
    assert not {str(d.name) for d in ev.deviations} & expected
    for why in ev.unavailable.values():
        assert "mjx-f64" in why and "contact" in why and "\n" not in why


_INSTANT_F32 = """
import dataclasses, json, numpy as np, mujoco
from harness import cases
from harness.engine import backends
from harness.engine.models import compile_model
from harness.engine.variants import ModelUnderTest
from harness.families import COMPARISONS
from harness.families.sampled import evaluate, sample_states
out = {}
engine = backends.get(BACKEND)
def budgets(name):
    case = cases.get(name); model = compile_model(case.mjcf); ref = case.reference(model)
    probe = case.probe(ref.dynamics)
    ev = evaluate(ModelUnderTest(path=case.mjcf), model, probe, ref, engine, COMPARISONS.at_states)
    return ev, ev.budgets, (model, ref, probe)
if True:
    for name in ("pendulum", "double_pendulum", "atwood"):
        ev, b, _ = budgets(name)
        out[name] = {"copies": len(ev.perturbed), "na": sorted(ev.unavailable),
                     "failed": [str(k) for k, v in b.items() if not v.passed],
                     "worst": max(v.unexplained / v.limit for v in b.values())}
    _, _, (model, ref, probe) = budgets("double_pendulum")
    q, qd = sample_states(ref, 4)
    data = mujoco.MjData(model); probe.binding.set_state(model, data, q[1], qd[1])
    mujoco.mj_forward(model, data)
    got = engine.forward_many(model, probe, data.qpos[None], data.qvel[None]).qacc[0]
    out["qacc_rel"] = float(np.max(np.abs(got - data.qacc)) / np.max(np.abs(data.qacc)))
    out["eps"] = engine.epsilon
    original = engine.forward_many
    def faulty(model, probe, qpos, qvel):
        fwd = original(model, probe, qpos, qvel)
        extra = -1e-3 * qvel
        return dataclasses.replace(fwd, qfrc_passive=fwd.qfrc_passive + extra,
                                   qacc=fwd.qacc + np.linalg.solve(fwd.mass, extra[..., None])[..., 0])
    engine.forward_many = faulty
    _, b, _ = budgets("double_pendulum")
    out["fault_failed"] = sorted(str(k) for k, v in b.items() if not v.passed)
    del engine.forward_many
print(json.dumps(out))
"""


def check_float32_instant(found: dict) -> None:
    """What the float32 instantaneous layer must show on a backend (MJX here, Warp in test_backend_warp.py):
    (a) every figure of pendulum, double_pendulum and atwood within its budget, with the state copies made;
    (b) the numbers are the backend's: its qacc at a sampled state is not C's bit for bit, and differs from it
    by a float32-sized amount; (c) a fault in its forward alone fails the forcing and qacc figures."""
    for name in ("pendulum", "double_pendulum", "atwood"):
        assert found[name]["copies"] == 4 and not found[name]["na"], found[name]
        assert not found[name]["failed"], (name, found[name])
    assert 0 < found["qacc_rel"] <= 300 * found["eps"], found["qacc_rel"] / found["eps"]
    assert {"instant.forcing", "instant.qacc"} <= set(found["fault_failed"]), found["fault_failed"]


@pytest.mark.slow
def test_mjx_float32_instant_figures_pass_are_mjxs_and_a_fault_fails():
    """MJX in float32 (a fresh process): :func:`check_float32_instant`."""
    pytest.importorskip("jax")
    pytest.importorskip("mujoco.mjx")
    check_float32_instant(_in_float32(_INSTANT_F32.replace("BACKEND", "'mjx'")))


def test_instant_roundoff_is_the_copies_spread_on_float32_and_unchanged_on_float64():
    """With copies, the round-off tolerance is PERTURBED_FACTOR × the largest copy difference (+ the measured
    shift of the constants in float32, + READ_ULPS ε32 × size), × the noise gain; without, today's ROUNDOFF ×
    size."""
    from harness.budget.inputs import States
    from harness.budget.roundoff import PERTURBED_FACTOR, READ_ULPS
    from harness.core.deviation import Deviation
    from harness.core.figures import FigureName
    from harness.families.sampled import ROUNDOFF
    from harness.families.sampled import budgets as instant_budgets
    name = FigureName.instant("qacc")
    base = Deviation(name, np.array([1e-7, -2e-7]), "scalar", "1", "", size=1.0)
    copies = [[dataclasses.replace(base, values=base.values + d)] for d in (np.array([0.0, 3e-7]),
                                                                                 np.array([-1e-7, 0.0]))]
    plain = instant_budgets([base])[name]
    assert plain.tolerance["roundoff"] == ROUNDOFF * base.size
    measured = instant_budgets([base], States(perturbed=copies, represented={name: 5e-8}))[name]
    assert measured.tolerance["roundoff"] == pytest.approx(
        PERTURBED_FACTOR * 3e-7 + 5e-8 + READ_ULPS * float(np.finfo(np.float32).eps), rel=1e-12)
    # an error beyond what the copies' spread allows fails, one within it passes
    for error, passes in ((1e-5, False), (1e-6, True)):
        dev = dataclasses.replace(base, values=np.array([error, 0.0]))
        spread = [[dataclasses.replace(dev, values=dev.values + c[0].values - base.values)] for c in copies]
        assert instant_budgets([dev], States(perturbed=spread))[name].passed is passes, error


_ROUNDOFF_VS_C = """
import json, numpy as np
from harness import cases
from harness.budget.roundoff import PERTURBED_FACTOR, PERTURBED_RUNS, QUANTIZATION, READ_ULPS, ulp_states
from harness.engine import backends, variants as V
from harness.engine.backends import Request
from harness.engine.models import compile_model
from harness.engine.recording import record
eps = float(np.finfo(np.float32).eps)
rows = []
for name in ("pendulum", "double_pendulum"):
    for integrator in ("RK4", "Euler"):
        case = cases.get(name); model = compile_model(case.mjcf, integrator=integrator)
        ref = case.reference(model); probe = case.probe(ref.dynamics)
        q0, qd0 = np.asarray(ref.q0(), float), np.asarray(ref.qd0(), float)
        c = record(model, probe, q0=q0, qd0=qd0, steps=STEPS)
        held = record(V.represented_model(model), probe, q0=q0.astype(np.float32).astype(float),
                      qd0=qd0.astype(np.float32).astype(float), steps=STEPS)
        moved = [record(model, probe, q0=ulp_states(q0, epsilon=eps, seed=k),
                        qd0=ulp_states(qd0, epsilon=eps, seed=PERTURBED_RUNS + k), steps=STEPS)
                 for k in range(1, PERTURBED_RUNS + 1)]
        if True:
            runs = backends.get(BACKEND).simulate_many(
                [Request(model, q0, qd0, STEPS)] + [Request(V.roundoff_copy(model, epsilon=eps, index=k), q0, qd0,
                                                            STEPS) for k in range(1, PERTURBED_RUNS + 1)], probe)
        for group in ("positions", "multipliers"):
            for key, exact in getattr(c, group).items():
                exact = np.asarray(exact); size = float(np.abs(exact).max())
                run = np.asarray(getattr(runs[0], group)[key])
                spread = max(float(np.abs(np.asarray(getattr(r, group)[key]) - run).max()) for r in runs[1:])
                shift = float(np.abs(np.asarray(getattr(held, group)[key]) - exact).max())
                quant = max(float(np.abs(np.asarray(getattr(r, group)[key]) - exact).max()) for r in moved)
                rule = PERTURBED_FACTOR * np.sqrt(2) * spread + shift + READ_ULPS * eps * size + QUANTIZATION * quant
                rows.append([name, integrator, key, float(np.abs(run - exact).max()), rule])
print(json.dumps(rows))
"""


@pytest.mark.slow
def test_the_float32_roundoff_rule_covers_mjx_float32_against_the_c_engine():
    """The derived float32 round-off part (harness/families/runs.py, for one run: PERTURBED_FACTOR √2 × the
    round-off copies' spread + the model and state held in float32 + READ_ULPS ε × size + QUANTIZATION × the
    response to a half-ulp state) against float32's real error: MJX in float64 equals the C engine to 1.7e-14
    here (the same algorithms), so MJX float32 − C is MJX's float32 round-off itself. Over 1000 steps of
    pendulum and double_pendulum, RK4 and Euler, every recorded position and multiplier: |MJX₃₂ − C| ≤ the rule
    (measured: at most 0.77 of it, the pendulum's bob under RK4; the rod's force spikes, 1.9e-3 of the tension,
    0.60 of it)."""
    pytest.importorskip("jax")
    pytest.importorskip("mujoco.mjx")
    rows = _in_float32(_ROUNDOFF_VS_C.replace("BACKEND", "'mjx'").replace("STEPS", "1000"))
    assert len(rows) >= 8
    over = [(name, integ, key, err / rule) for name, integ, key, err, rule in rows if not err <= rule]
    assert not over, over
    assert all(err > 0 for *_, err, _ in rows)  # float32 is not C bit for bit: the comparison has something to see


_STOPS = (
    "import json, harness\n"
    "out = {}\n"
    "for case, integrator, figures in (('hoop_ramp_contact', 'Euler', ['instant.sensor.hub_force']),\n"
    "                                  ('welded_pendulum', 'Euler', ['instant.sensor.top_torque', 'instant.qacc']),\n"
    "                                  ('hoop_ramp', 'RK4', ['RK4.force.normal', 'RK4.force.roll'])):\n"
    "    r = harness.validate(case, integrators=[integrator], backend=BACKEND, horizon=0.05)\n"
    "    for c in r.checks:\n"
    "        if str(c.name) in figures:\n"
    "            b = c.budget\n"
    "            out[case + ':' + str(c.name)] = {'passed': c.passed, 'measured': b.measured,\n"
    "                'stop': b.explained.get('stop', 0.0), 'unexplained': b.unexplained, 'limit': b.limit}\n"
    "print(json.dumps(out))\n")


def check_solver_stops(found: dict, *, stop_in_trajectories: bool) -> None:
    """What completing a float32 backend's stopped solves must show (harness/engine/backends/completion.py): the
    figures whose error is the stop — hoop_ramp_contact's hub force (a joint that carries nothing reads the
    solver's residual), welded_pendulum's top torque, hoop_ramp's RK4 contact forces — pass, the stop the
    bulk of what was measured where it is large; and a finding the stop does not explain stays:
    welded_pendulum's qacc (the backend's missing J̇v in a weld's a_ref: balanced forces, no residual).
    ``stop_in_trajectories``: hoop_ramp's forces are the stop's too (MJX: 1.8e-3 of the normal force; on Warp
    they are 9e-5, the stop 5e-6 of it, and only pass)."""
    hub = found["hoop_ramp_contact:instant.sensor.hub_force"]
    assert hub["passed"], hub
    assert hub["stop"] >= 0.9 * hub["measured"], hub
    top = found["welded_pendulum:instant.sensor.top_torque"]
    assert top["passed"], top
    assert top["stop"] >= 0.5 * top["measured"], top
    assert not found["welded_pendulum:instant.qacc"]["passed"], found["welded_pendulum:instant.qacc"]
    for figure in ("RK4.force.normal", "RK4.force.roll"):
        got = found[f"hoop_ramp:{figure}"]
        assert got["passed"], (figure, got)
        assert not stop_in_trajectories or got["stop"] >= 0.5 * got["measured"], (figure, got)


@pytest.mark.slow
def test_mjx_float32_solver_stops_are_explained_and_a_finding_stays():
    """MJX in float32 (a fresh process): :func:`check_solver_stops`."""
    pytest.importorskip("jax")
    pytest.importorskip("mujoco.mjx")
    check_solver_stops(_in_float32(_STOPS.replace("BACKEND", "'mjx'")), stop_in_trajectories=True)

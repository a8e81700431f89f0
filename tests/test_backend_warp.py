"""The Warp backend (MuJoCo Warp on CPU, float32): batching that changes no number, agreement with the
C engine within float32 round-off (and a broken model that does not agree), the one-line refusal of a
feature Warp lacks, and where its kernels are cached.

Skipped where ``mujoco-warp`` is not installed (the default install); CI installs it
(``.ci/run``, the accelerated-backends venv) and runs this file there. Short runs only: a Warp
step on CPU costs tens of milliseconds whatever the number of worlds.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

pytest.importorskip("mujoco_warp")

from harness import cases
from harness.core.errors import BackendUnavailable
from harness.engine import backends
from harness.engine.backends import Request
from harness.engine.backends import warp as W
from harness.engine.models import compile_model
from harness.engine.recording import record

STEPS = 40
ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def pendulum():
    case = cases.get("pendulum")
    model = compile_model(case.mjcf)
    ref = case.reference(model)
    return case, ref, case.probe(ref.dynamics)


def _request(case, ref, *, steps: int = STEPS, **compile_options) -> Request:
    return Request(compile_model(case.mjcf, **compile_options), ref.q0(), ref.qd0(), steps)


def test_runs_differing_in_per_world_fields_share_one_call_and_change_no_number(pendulum):
    """h and h/2 (a per-world field) go to Warp as one call of two worlds; another integrator (Warp
    builds its step from it) as another; each run's numbers are those of the run alone, bit for bit."""
    case, ref, probe = pendulum
    h = compile_model(case.mjcf).opt.timestep
    reqs = [_request(case, ref, integrator="RK4"), _request(case, ref, integrator="RK4", timestep=h / 2,
                                                           steps=2 * STEPS),
            _request(case, ref, integrator="Euler")]
    assert W.groups(reqs) == [[0, 1], [2]]
    together = backends.get("warp").simulate_many(reqs, probe)
    for req, batched in zip(reqs, together, strict=True):
        alone = backends.get("warp").simulate_many([req], probe)[0]
        assert len(batched.t) == req.steps + 1
        np.testing.assert_array_equal(batched.t, alone.t)
        for p in batched.positions:
            np.testing.assert_array_equal(batched.positions[p], alone.positions[p])
            np.testing.assert_array_equal(batched.velocities[p], alone.velocities[p])
        for c in batched.multipliers:
            np.testing.assert_array_equal(batched.multipliers[c], alone.multipliers[c])
        np.testing.assert_array_equal(batched.invariants["energy"], alone.invariants["energy"])
    # the h/2 world really ran at h/2: its samples are half as far apart and it ends where the h run ends
    assert together[1].t[-1] == pytest.approx(together[0].t[-1], abs=1e-12)


def _roundoff_bound(steps: int, size: float) -> float:
    """The budget's round-off part (harness/families/runs.py: ROUNDOFF_EPS machine epsilons a step,
    a random walk over the steps) in float32, for one run (noise gain 1) of a quantity of ``size``."""
    from harness.budget.roundoff import ROUNDOFF_EPS

    return ROUNDOFF_EPS * float(np.finfo(np.float32).eps) * math.sqrt(steps) * size


def test_warp_agrees_with_the_c_engine_within_float32_roundoff(pendulum):
    case, ref, probe = pendulum
    req = _request(case, ref, integrator="RK4")
    warp = backends.get("warp").simulate_many([req], probe)[0]
    c = record(req.model, probe, q0=req.q0, qd0=req.qd0, steps=req.steps)
    assert warp.source == "warp:RK4"
    length = float(np.linalg.norm(c.positions["bob"][0]))
    gap = float(np.abs(warp.positions["bob"] - c.positions["bob"]).max())
    assert 0 < gap <= _roundoff_bound(STEPS, length)  # float32 differs (> 0) by round-off only
    energy = float(np.abs(c.invariants["energy"]).max())
    assert np.abs(warp.invariants["energy"] - c.invariants["energy"]).max() <= _roundoff_bound(STEPS, energy)


def test_a_broken_model_on_warp_does_not_agree_with_the_c_engine(pendulum):
    """The same bound fails when Warp runs a model with damping the C run lacks: the comparison sees
    physics, not only round-off."""
    case, ref, probe = pendulum

    def damped(spec: mujoco.MjSpec) -> None:
        spec.joint("theta").damping = [0.5, 0, 0]

    broken = Request(compile_model(case.mjcf, integrator="RK4", edit=damped), ref.q0(), ref.qd0(), STEPS)
    warp = backends.get("warp").simulate_many([broken], probe)[0]
    req = _request(case, ref, integrator="RK4")
    c = record(req.model, probe, q0=req.q0, qd0=req.qd0, steps=req.steps)
    length = float(np.linalg.norm(c.positions["bob"][0]))
    assert np.abs(warp.positions["bob"] - c.positions["bob"]).max() > _roundoff_bound(STEPS, length)


def test_a_feature_warp_lacks_is_refused_in_one_line_naming_backend_feature_and_fix():
    model = mujoco.MjModel.from_xml_string(
        '<mujoco><option solver="PGS"/><worldbody><body><joint type="hinge"/>'
        '<geom size=".1" mass="1"/></body></worldbody></mujoco>')
    with pytest.raises(BackendUnavailable) as err:
        backends.get("warp").supports(model)
    message = str(err.value)
    assert "\n" not in message
    assert "'warp'" in message and "PGS" in message and "fix:" in message and "--backend c" in message


def test_the_kernels_are_cached_beside_the_harness_cache(tmp_path):
    """A CI that keeps $XDG_CACHE_HOME between runs keeps Warp's compiled kernels too: a fresh process
    with XDG_CACHE_HOME set puts them under it."""
    env = dict(os.environ, XDG_CACHE_HOME=str(tmp_path))
    env.pop("MJHARNESS_NO_CACHE", None)
    code = "from harness.engine.backends import warp as W; print(W.kernel_cache())"
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT, capture_output=True, text=True,
                         check=True).stdout.strip().splitlines()[-1]
    assert out == str(tmp_path / "mjharness" / "warp")


def test_warp_is_float32():
    warp = backends.get("warp")
    assert warp.precision == "float32"
    assert warp.epsilon == float(np.finfo(np.float32).eps)


@pytest.mark.slow
def test_warp_float32_passes_and_a_fault_still_fails():
    """Through every layer and budget: the pendulum on Warp (float32, its round-off in the budget) passes,
    and the same pendulum with joint damping fails on figures of Warp's own runs that the budget does
    not explain — the instantaneous layer's (Warp's forward: forcing, qacc) and the trajectory's (the energy
    it dissipates, the position).

    Horizon 0.2 s (200 RK4 steps: a Warp step costs tens of ms on CPU). Damping 0.1 N m s there takes
    6.8e-4 of the energy (measured), 190 times the float32 round-off part of its budget (3.4e-6: the
    round-off copies' spread, the constants held in float32, the reading). The rod's force is not asked to
    fail: its float32 budget includes the state's quantization (a stiff rod's k × ulp force spikes,
    harness.budget.roundoff.QUANTIZATION), 3.3e-2 of the tension at this budget's noise gain, above the 1.6e-3
    the damping moves it."""
    from harness import validate
    from harness.engine.compat import set_damping

    ok = validate("pendulum", integrators=["RK4"], backend="warp", horizon=0.2)
    assert ok.settings.backend["name"] == "warp" and ok.settings.backend["precision"] == "float32"
    assert ok.passed, [c.name for c in ok.failures]
    bad = validate("pendulum", integrators=["RK4"], backend="warp", horizon=0.2,
                   edit=lambda s: set_damping(s.joint("theta"), 0.1))
    assert not bad.passed
    failed = [c.name for c in bad.failures]
    assert {"RK4.drift.energy", "RK4.position", "instant.forcing", "instant.qacc"} <= set(failed), failed


def test_a_convergence_floor_is_explained_by_float32_roundoff_only_on_a_float32_backend():
    """An RK4 ladder whose error sits flat at 1e-6 m: in float32 (Warp) that is below the round-off of the
    run (64 ε₃₂ √N × L ≈ 7.6e-4 m for 10⁴ steps of a 1 m case), a floor and not an order; in float64 (C),
    whose round-off there is 3e-12 m, the same floor stays unexplained: a fault the verdict shows."""
    from harness.families.convergence import explained_floor, fit_order, roundoff_floor

    fit = fit_order((1e-3, 5e-4, 2.5e-4, 1.25e-4), (1e-6, 1e-6, 1e-6, 1e-6), saturation=0.1)
    assert fit.floor == pytest.approx(1e-6) and fit.n_used < 2
    c = roundoff_floor(1e4, 1.0, backends.get("c").epsilon)
    assert explained_floor(fit, {"round-off": c}) == ""
    w = roundoff_floor(1e4, 1.0, backends.get("warp").epsilon)
    assert "not measurable" in explained_floor(fit, {"round-off": w})
    assert c == pytest.approx(64 * float(np.finfo(np.float64).eps) * 100)
    assert w / c == pytest.approx(float(np.finfo(np.float32).eps) / float(np.finfo(np.float64).eps))


# ------------------------------------------------- the instantaneous layer on Warp
@pytest.mark.parametrize("name", ["pendulum", "double_pendulum", "atwood"])
def test_warp_instant_figures_pass_their_float32_budgets(name):
    """Every instantaneous figure on Warp (float32) within its budget, the round-off part from the states'
    one-ulp copies (and the model's constants in float32): pendulum (a joint equality), double_pendulum
    (force, torque and accelerometer sensors, Warp's own), atwood (tendon equalities)."""
    from tests.test_backends import _instant_budgets
    ev, budgets = _instant_budgets(name, "warp")
    assert len(ev.perturbed) == 4 and not ev.unavailable
    failed = {str(k): (b.unexplained, b.limit) for k, b in budgets.items() if not b.passed}
    assert not failed, failed


def test_warp_instant_numbers_are_warps_own(monkeypatch):
    """Warp's qacc at a sampled state is not the C engine's bit for bit, and is within a few hundred float32
    epsilons of it; a fault in Warp's forward alone (damping 1e-3 on its qfrc_passive and qacc) fails the
    forcing and qacc figures on Warp while C's figures of the same model pass."""
    from tests.test_backends import _states, check_figures_are_the_backends_own
    _, model, _, probe, qpos, qvel = _states("double_pendulum")
    warp = backends.get("warp")
    got = warp.forward_many(model, probe, qpos, qvel).qacc
    c = backends.get("c").forward_many(model, probe, qpos, qvel).qacc
    rel = float(np.max(np.abs(got - c)) / np.max(np.abs(c)))
    assert 0 < rel <= 300 * warp.epsilon, rel / warp.epsilon
    check_figures_are_the_backends_own(warp, "warp", monkeypatch)


def test_warp_forward_many_dense_mass_is_the_c_engines_layout():
    """Warp's CSR mass matrix expanded by :func:`dense_mass` is the C engine's dense one to float32 round-off
    (slider_crank: nv 4, off-diagonal entries)."""
    from tests.test_backends import _states
    _, model, _, probe, qpos, qvel = _states("slider_crank", 3)
    got = backends.get("warp").forward_many(model, probe, qpos, qvel).mass
    c = backends.get("c").forward_many(model, probe, qpos, qvel).mass
    assert np.max(np.abs(got - c)) <= 1e-5 * np.max(np.abs(c))
    assert np.count_nonzero(np.abs(c[0] - np.diag(np.diag(c[0]))) > 1e-6)  # off-diagonal terms exist


def test_a_tendon_equalitys_multiplier_on_warp_carries_the_probes_sign():
    """atwood_tendon's strings are tendon equalities whose efc rows are −1 × the analytic constraint's
    (Probe.signs): Warp's recorded multipliers take that sign as the C recorders do (they did not: the
    strings' force figures failed at 1.0 of the force scale, every sign flipped, and no physics moved)."""
    case = cases.get("atwood_tendon")
    model = compile_model(case.mjcf, integrator="Euler")
    ref = case.reference(model)
    probe = case.probe(ref.dynamics)
    req = Request(model, ref.q0(), ref.qd0(), 20)
    warp = backends.get("warp").simulate_many([req], probe)[0]
    c = record(model, probe, q0=req.q0, qd0=req.qd0, steps=req.steps)
    assert any(probe.sign(s) < 0 for s in probe.constraints)
    for string in probe.constraints:
        lam_c, lam_w = np.asarray(c.multipliers[string]), np.asarray(warp.multipliers[string])
        assert np.sign(lam_w[5:]).tolist() == np.sign(lam_c[5:]).tolist(), string
        assert np.max(np.abs(lam_w - lam_c)) <= 0.05 * np.max(np.abs(lam_c)), string


def test_an_accelerated_backends_cases_each_run_in_a_process_of_their_own():
    """Several cases on an accelerated backend run each in a fresh worker process (harness.pipeline.matrix
    ._run_isolated): XLA's compiles of every case in one process ran it out of memory (MJX, fifteen cases), so
    the parent never imports the backend — checked here: after two Warp cases, mujoco_warp is not in the
    parent's modules — and the results are all there, in order."""
    code = ("import sys, json\n"
            "from harness import cases\n"
            "from harness.pipeline.matrix import run_all\n"
            "from harness.core.options import RunOptions\n"
            "results, checks, _ = run_all([cases.get('pendulum'), cases.get('spring')], None,\n"
            "                             RunOptions(backend='warp', horizon=0.01), jobs=1)\n"
            "print(json.dumps([[r.case.name for r in results], 'mujoco_warp' in sys.modules,\n"
            "                  all(c.passed or c.note for cs in checks.values() for c in cs)]))\n")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, out.stderr[-2000:]
    names, imported, passed = json.loads(out.stdout.strip().splitlines()[-1])
    assert names == ["pendulum", "spring"] and not imported and passed


@pytest.mark.slow
def test_run_shows_the_c_engine_and_warp_side_by_side(tmp_path):
    """``mjharness run --backend c,warp``: one report, C's as the first backend's, and the section with every
    gated figure of each case on both backends, an error-vs-time plot per case and the findings; symmetric_top
    is there because its system holds a closure, which once broke the return from Warp's process."""
    out = subprocess.run([sys.executable, "-m", "harness", "run", "pendulum", "symmetric_top", "--backend", "c,warp",
                          "--horizon", "0.02", "--integrators", "RK4", "--no-studies", "--jobs", "1", "--quiet",
                          "--out", str(tmp_path / "r")], cwd=ROOT, capture_output=True, text=True, timeout=1200)
    assert out.returncode in (0, 1), out.stderr[-2000:]
    assert "Traceback" not in out.stderr
    page = (tmp_path / "r" / "backends.html").read_text()  # a page of its own, linked from the overview
    assert "href='backends.html'" in (tmp_path / "r" / "report.html").read_text()
    assert "Backends side by side" in page and "<th>c</th><th>warp</th>" in page
    for case in ("pendulum", "symmetric_top"):
        assert f"<h3>{case}</h3><img alt='{case} error vs time per backend'" in page
    doc = json.loads((tmp_path / "r" / "report.json").read_text())
    side = doc["backends"]
    assert [(b["name"], sorted(b["checks"])) for b in side["backends"]] == [
        ("c", ["pendulum", "symmetric_top"]), ("warp", ["pendulum", "symmetric_top"])]
    # the same gated figures on both, but the second opinions', which judge MuJoCo's C engine alone
    # (harness/families/peers.py; measured wherever Pinocchio is installed, as the test extra installs it)
    c_checks, warp_checks = (set(b["checks"]["pendulum"]) for b in side["backends"])
    assert c_checks - {k for k in c_checks if k.startswith("instant.peer.")} == warp_checks


@pytest.mark.slow
def test_warp_solver_stops_are_explained_and_a_finding_stays():
    """MuJoCo Warp (float32, a fresh process): :func:`tests.test_backends.check_solver_stops`."""
    from tests.test_backends import _STOPS, check_solver_stops
    out = subprocess.run([sys.executable, "-c", _STOPS.replace("BACKEND", "'warp'")], cwd=ROOT, capture_output=True,
                         text=True, timeout=1800)
    assert out.returncode == 0, out.stderr[-2000:]
    check_solver_stops(json.loads(out.stdout.strip().splitlines()[-1]), stop_in_trajectories=False)

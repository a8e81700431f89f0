"""Runs on a Ray cluster (``--executor ray``): the local pool's results bit for bit, a killed worker rerun, a
task lost for good named in one line (a row where the command has rows), Ctrl-C stopping the cluster's tasks
(harness/pipeline/cluster.py). The cluster is a head node on loopback that the tests start and stop."""

from __future__ import annotations

import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from harness.cli.commands import main as main_cli
from harness.outputs.jsondoc import dumps
from harness.pipeline.executor import Executor
from tests.raycluster import AUTH, processes

CASES = ("pendulum", "spring")


def _as_from_a_terminal() -> None:
    """Ctrl-C as a command started from a terminal gets it: delivered, Python's handler. A child inherits its
    parent's blocked signals and ignored ones, and by the time the slow suite reaches these tests something in
    the pytest process has SIGINT blocked (the Ctrl-C test's command then ran to its verdict, exit 1, in CI)."""
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _mjharness(*args: str, **kwargs) -> subprocess.Popen:
    env = {**os.environ, **AUTH, "PYTHONUNBUFFERED": "1"}
    env.pop("RAY_ADDRESS", None)
    return subprocess.Popen([sys.executable, "-m", "harness.cli.entry", *args], env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, preexec_fn=_as_from_a_terminal,
                            **kwargs)


def _done(process: subprocess.Popen, timeout: float = 300) -> tuple[int, str, str]:
    out, err = process.communicate(timeout=timeout)
    return process.returncode, out, err


def _kill_task(tag: str, *, times: int, timeout: float = 120) -> int:
    """SIGKILL the worker running the task whose name holds ``tag``, ``times`` times over (each rerun's
    worker); the kills made."""
    kills, deadline = 0, time.monotonic() + timeout
    while kills < times and time.monotonic() < deadline:
        running = processes(f"ray::mjharness:{tag}")
        for pid in running:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                continue
            kills += 1
            time.sleep(0.5)  # the rerun gets a new worker
            break
        else:
            time.sleep(0.02)
    return kills


@pytest.fixture(scope="module")
def cluster(ray_address) -> str:
    return ray_address


@pytest.fixture(scope="module")
def local_text() -> str:
    code, out, err = _done(_mjharness("check", *CASES, "--json", "--jobs", "2"))
    assert code == 0, err
    return out


@pytest.fixture(scope="module")
def local_json(local_text) -> dict:
    return json.loads(local_text)


@pytest.mark.slow
def test_check_on_a_cluster_is_the_local_pools_bit_for_bit(cluster, local_text):
    """Every figure is written with all its digits (repr), so equal documents are equal figures, bit for bit."""
    code, out, err = _done(_mjharness("check", *CASES, "--json", "--executor", "ray", "--ray-address", cluster))
    assert code == 0, err
    assert out == local_text


@pytest.mark.slow
def test_the_comparison_sees_one_figure_moved(local_text, local_json):
    """The comparison above can fail: one figure's last bit moved is a different document."""
    moved = json.loads(local_text)
    check = moved["cases"]["pendulum"]["checks"]["Euler.drift.energy"]["budget"]
    check["measured"] = math.nextafter(check["measured"], math.inf)
    assert dumps(moved) != local_text
    assert dumps(local_json) == local_text


@pytest.mark.slow
def test_a_worker_killed_mid_task_is_rerun_with_the_same_figures(cluster, local_json):
    process = _mjharness("check", *CASES, "--json", "--executor", "ray", "--ray-address", cluster)
    kills = _kill_task("pendulum", times=1)
    code, out, err = _done(process)
    assert kills == 1
    assert code == 0, err
    assert json.loads(out) == local_json


@pytest.mark.slow
def test_stdout_is_the_json_alone_after_workers_died(cluster, local_text):
    """Ray's driver prints "(raylet) A worker died …" to stdout, log_to_driver or not, the last of them often
    after the run's results are in (at b7c7390 it followed the document on stdout): it goes to stderr, and stdout
    is check's document, byte for byte the local pool's, after the task's worker was killed on all but its last
    try."""
    process = _mjharness("check", *CASES, "--json", "--executor", "ray", "--ray-address", cluster)
    kills = _kill_task("pendulum", times=pool_retries())
    code, out, err = _done(process)
    assert (kills, code) == (pool_retries(), 0), err[-2000:]
    assert "A worker died or was killed" in err  # Ray said so, on stderr
    assert out == local_text, out[-500:]


OWN = "examples/arm.xml"


def _without_seconds(text: str) -> dict:
    """check --json without what the run's parts took (a tree's "seconds": the clock, not a figure)."""
    doc = json.loads(text)
    for case in doc["cases"].values():
        tree = case["settings"].get("tree") or {}
        assert isinstance(tree.pop("seconds", None), dict)
    return doc


@pytest.mark.slow
def test_a_users_own_model_runs_on_the_cluster_with_the_local_runs_figures(cluster):
    """``check --mjcf`` of a model judged against its own tree is one task on the cluster, the model's files
    carried there; its document is the local run's, the path the user gave included."""
    code, local, err = _done(_mjharness("check", "--json", "--mjcf", OWN, "--jobs", "1"))
    assert code == 0, err
    process = _mjharness("check", "--json", "--mjcf", OWN, "--executor", "ray", "--ray-address", cluster)
    seen = []
    while process.poll() is None and not seen:
        seen = processes("ray::mjharness:arm (examples/arm.xml")  # the task ran on the cluster, named so
        time.sleep(0.02)
    code, out, err = _done(process)
    assert code == 0, err
    assert seen, "no task of the model ran on the cluster"
    on_ray = _without_seconds(out)
    assert on_ray["cases"]["arm"]["settings"]["mjcf"] == OWN
    assert on_ray == _without_seconds(local)


@pytest.mark.slow
def test_a_users_own_model_reports_on_the_cluster_as_locally(cluster, tmp_path):
    """``run --mjcf`` on the cluster writes the local run's report.json (the clock's seconds aside) and summary."""
    outs = {}
    for name, extra in (("local", ()), ("ray", ("--executor", "ray", "--ray-address", cluster))):
        outs[name] = tmp_path / name
        code, _, err = _done(_mjharness("run", "--mjcf", OWN, "--quiet", "--out", str(outs[name]), *extra))
        assert code == 0, err[-2000:]
    local, ray = (outs[n] / "report.json" for n in ("local", "ray"))
    assert _without_seconds(ray.read_text()) == _without_seconds(local.read_text())
    assert (outs["ray"] / "summary.md").read_bytes() == (outs["local"] / "summary.md").read_bytes()


CURRENT = """
import sys, ray
from harness.pipeline import cluster
from harness.pipeline.executor import Executor
cluster.connect(Executor("ray"))
print(ray._private.worker.global_worker.node.gcs_address)
cluster.shutdown()
"""


@pytest.mark.slow
def test_without_an_address_a_run_starts_and_stops_a_cluster_of_its_own(cluster):
    """Ray's ``ray.init()`` joins the cluster ``ray start`` last wrote in Ray's temporary folder: a run without
    an address starts its own instead (the session's cluster written there, as ``ray start`` writes it), and
    leaves none of its processes behind."""
    import tempfile

    folder = Path(tempfile.mkdtemp(prefix="mjh-", dir="/tmp"))  # short: Ray's socket paths must fit 107 bytes
    try:
        (folder / "ray").mkdir()
        (folder / "ray" / "ray_current_cluster").write_text(cluster)
        env = {**os.environ, **AUTH, "RAY_TMPDIR": str(folder)}
        env.pop("RAY_ADDRESS", None)
        done = subprocess.run([sys.executable, "-c", CURRENT], env=env, capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr[-2000:]
        started = done.stdout.split()[-1]
        assert started.rpartition(":")[2] != cluster.rpartition(":")[2], (started, cluster)
        deadline = time.monotonic() + 15
        while processes(str(folder)) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert processes(str(folder)) == []
    finally:
        for pid in processes(str(folder)):
            os.kill(pid, signal.SIGKILL)
        shutil.rmtree(folder, ignore_errors=True)


@pytest.mark.slow
def test_a_cluster_with_rays_default_authentication_is_used(tmp_path):
    """``ray start --head`` where ``~/.ray/auth_token`` exists (RAY_AUTH_MODE unset: Ray's default) requires the
    token: a run given its address uses it and gets the local pool's figures; a run without it is one line
    saying where the token goes. A home folder of the test's own holds the token."""
    pytest.importorskip("ray")
    from tests.raycluster import loopback_cluster

    home, stranger = tmp_path / "home", tmp_path / "stranger"
    (home / ".ray").mkdir(parents=True)
    stranger.mkdir()
    (home / ".ray" / "auth_token").write_text("a1" * 32)
    # no PYTHONPATH, as a user's cluster has none: the harness reaches its workers as the job's py_modules (in
    # Ray's session folder), and the document still names the harness's models as this machine has them
    env = {k: v for k, v in os.environ.items() if k not in ("RAY_AUTH_MODE", "RAY_ADDRESS", "PYTHONPATH")}
    env |= {"HOME": str(home), "RAY_USAGE_STATS_ENABLED": "0", "PYTHONUNBUFFERED": "1",
            "XDG_CACHE_HOME": os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")}  # the derivations
    check = [sys.executable, "-m", "harness.cli.entry", "check", "spring", "--json"]
    root = Path(__file__).resolve().parents[1]  # the driver's harness: this checkout's, found from its folder
    local = subprocess.run(check, env=env, capture_output=True, text=True, timeout=300, cwd=root)
    assert local.returncode == 0, local.stderr[-2000:]
    with loopback_cluster(environ=env) as address:
        ray = [*check, "--executor", "ray", "--ray-address", address]
        done = subprocess.run(ray, env=env, capture_output=True, text=True, timeout=300, cwd=root)
        assert done.returncode == 0, done.stderr[-2000:]
        assert done.stdout == local.stdout
        refused = subprocess.run(ray, env=env | {"HOME": str(stranger)}, capture_output=True, text=True,
                                 timeout=300, cwd=root)
    assert refused.returncode == 2
    lines = [line for line in refused.stderr.splitlines() if line.startswith("mjharness:")]
    assert len(lines) == 1 and "needs its token here too: in ~/.ray/auth_token or RAY_AUTH_TOKEN" in lines[0], lines
    assert "Traceback" not in refused.stderr


@pytest.mark.slow
def test_a_task_lost_for_good_is_one_line_naming_case_release_and_backend(cluster):
    import mujoco

    process = _mjharness("check", "pendulum", "--executor", "ray", "--ray-address", cluster)
    kills = _kill_task("pendulum", times=pool_retries() + 1)
    code, _, err = _done(process)
    assert kills == pool_retries() + 1
    assert code == 2
    lines = [line for line in err.splitlines() if line.startswith("mjharness:")]
    assert lines == [f"mjharness: error: pendulum (MuJoCo {mujoco.__version__}, backend c): its Ray task failed "
                     f"for good: its worker died on every try ({pool_retries() + 1}); fix: check the cluster's "
                     "nodes, or run with --executor local"], err
    assert "Traceback" not in err


def pool_retries() -> int:
    from harness.pipeline import cluster

    return cluster.RETRIES


LOST = """
import json, math, os, sys
from harness.pipeline import cluster, pool
from harness.pipeline.executor import Executor, TaskLost
calls = [(os._exit, (3,)), (math.sqrt, (4.0,))]
at = Executor("ray", sys.argv[1])
rows = pool.run_tasks(calls, 2, executor=at, failed=lambda i, why: f"call {i} lost: {why}", labels=["dies", "sqrt"])
try:
    pool.run_tasks(calls, 2, executor=at, labels=["dies", "sqrt"])
    raised = ""
except TaskLost as exc:
    raised = str(exc)
cluster.shutdown()
print(json.dumps([rows, raised]))
"""


@pytest.mark.slow
def test_a_lost_call_takes_failed_s_answer_in_its_place(cluster):
    """A call whose worker dies on every try (os._exit ends it) is ``failed(i, reason)``'s row, in order;
    without ``failed``, TaskLost names it in one line."""
    env = {**os.environ, **AUTH}
    done = subprocess.run([sys.executable, "-c", LOST, cluster], env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    rows, raised = json.loads(done.stdout.splitlines()[-1])
    tries = pool_retries() + 1
    assert rows == [f"call 0 lost: its worker died on every try ({tries})", 2.0]
    assert raised == f"dies: its Ray task failed for good: its worker died on every try ({tries})"


@pytest.mark.slow
def test_ctrl_c_stops_the_clusters_tasks(cluster):
    # a horizon of 60 s (the cases' is 5): tasks of many seconds, still running when the signal comes (the whole
    # default check on a warm cache once ended before it)
    process = _mjharness("check", "pendulum", "spring", "--horizon", "60", "--executor", "ray", "--ray-address",
                         cluster, "--jobs", "2")
    deadline = time.monotonic() + 120
    while not processes("ray::mjharness:") and time.monotonic() < deadline:
        time.sleep(0.05)
    assert processes("ray::mjharness:"), "no task started"
    process.send_signal(signal.SIGINT)
    code, _, err = _done(process, timeout=60)
    assert code == 130, err[-2000:]
    assert [line for line in err.splitlines() if line.startswith("mjharness:")] == ["mjharness: interrupted"]
    deadline = time.monotonic() + 15
    while processes("ray::mjharness:") and time.monotonic() < deadline:
        time.sleep(0.1)
    assert processes("ray::mjharness:") == []


# ---- without a cluster (fast) -------------------------------------------------------------------------------
@pytest.mark.parametrize(("args", "line"), [
    (["--ray-address", "127.0.0.1:6379"], "mjharness: error: --ray-address needs --executor ray"),
    (["--executor", "ray", "--ray-address", "nohost"],
     "mjharness: error: Ray address 'nohost' is not HOST:PORT; accepted: the address `ray start --head` printed "
     "(HOST:PORT), or none (no --ray-address, no RAY_ADDRESS) for a local cluster"),
])
def test_a_bad_executor_is_one_line(args, line, capsys):
    pytest.importorskip("ray")
    assert main_cli(["check", "spring", *args]) == 2
    assert capsys.readouterr().err.strip() == line


def test_a_cluster_nobody_answers_at_is_one_line_at_once(capsys):
    """Ray itself would retry for minutes; the address is tried first (a closed port on loopback)."""
    pytest.importorskip("ray")
    start = time.monotonic()
    assert main_cli(["check", "spring", "--executor", "ray", "--ray-address", "127.0.0.1:1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("mjharness: error: no Ray cluster answers at 127.0.0.1:1 (")
    assert "\n" not in err
    assert time.monotonic() - start < 30


def test_a_users_own_model_goes_to_the_cluster_asked_for(capsys):
    """``check --mjcf`` with --executor ray runs on the cluster, never here: at b7c7390 it ran locally and exited
    0 with nobody at the address."""
    pytest.importorskip("ray")
    assert main_cli(["check", "--mjcf", "examples/arm.xml", "--json", "--executor", "ray", "--ray-address",
                     "127.0.0.1:1"]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.strip().startswith("mjharness: error: no Ray cluster answers at 127.0.0.1:1 (")


def test_without_ray_the_executor_names_the_extra(monkeypatch, capsys):
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "ray" else real(name, *a))
    assert main_cli(["check", "spring", "--executor", "ray"]) == 2
    assert capsys.readouterr().err.strip() == ("mjharness: error: --executor ray: Ray is not installed; fix: pip "
                                               "install 'mjharness[ray]'")


def test_a_zoo_model_whose_task_is_lost_is_its_row_not_a_gap(monkeypatch):
    """Where the cluster loses a model's task for good, the zoo has that model's row (crashed, saying so)."""
    from harness import zoo

    models, skipped = zoo.discover()
    if not models:
        pytest.skip("no zoo package installed (pip install 'mjharness[zoo]')")
    chosen = zoo.select(["dm_control/pendulum"], models, skipped)

    def lose_every_call(calls, workers, *, failed, **_):
        return [failed(i, "its worker died on every try (4)") for i in range(len(calls))]

    monkeypatch.setattr(zoo, "run_tasks", lose_every_call)
    run = zoo.run(chosen, faults=True, executor=Executor("ray"))
    assert [(r.model, r.verdict, r.reason) for r in run.results] == [
        ("dm_control/pendulum", zoo.CRASHED, "its Ray task failed for good: its worker died on every try (4)")]
    assert {c.crashed for c in run.faults} == {"its Ray task failed for good: its worker died on every try (4)"}
    assert run.exit_code == 2

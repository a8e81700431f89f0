"""A Ray cluster on loopback for the tests: ``ray start --head`` in a temporary folder of its own, started by
a fixture and stopped with every process it made (found by that folder), whatever else runs Ray here.

Token authentication is off (``RAY_AUTH_MODE=disabled``) for the cluster and for every driver the tests
start or are: the cluster listens on loopback alone, and Ray turns authentication on for ``ray start``
wherever ``~/.ray/auth_token`` exists. The test of a cluster with Ray's default authentication starts one
with ``environ`` of its own (a home folder holding a token, ``RAY_AUTH_MODE`` unset)."""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

AUTH = {"RAY_AUTH_MODE": "disabled", "RAY_USAGE_STATS_ENABLED": "0"}


def processes(tag: str) -> list[int]:
    """Every process whose command line holds ``tag`` (a cluster's folder, a task's name)."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                line = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
            except OSError:
                continue
            if tag in line and int(entry.name) != os.getpid():
                found.append(int(entry.name))
    return found


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextlib.contextmanager
def loopback_cluster(cpus: int = 2, *, environ: dict[str, str] | None = None) -> Iterator[str]:
    """A head node on 127.0.0.1 with ``cpus`` CPUs, started in ``environ`` (default: this process's, with
    :data:`AUTH`); yields its address; stops it (every process of its folder) on leaving."""
    ray = Path(sys.executable).with_name("ray")
    folder = tempfile.mkdtemp(prefix="mjh-ray-", dir="/tmp")  # short: Ray's socket paths must fit 107 bytes
    port = _free_port()
    env = {**os.environ, **AUTH} if environ is None else environ
    head = subprocess.Popen([str(ray), "start", "--head", "--block", "--node-ip-address", "127.0.0.1", "--port",
                             str(port), "--num-cpus", str(cpus), "--include-dashboard", "false",
                             "--disable-usage-stats", "--temp-dir", folder],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    address = f"127.0.0.1:{port}"
    try:
        # a cluster with Ray's default authentication wants the token its folder's home holds
        _wait_up(address, env if "RAY_AUTH_MODE" in env else env | {"RAY_AUTH_MODE": "token"})
        yield address
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(head.pid, signal.SIGTERM)
        deadline = time.monotonic() + 10
        while processes(folder) and time.monotonic() < deadline:
            time.sleep(0.2)
        for pid in [*processes(folder), head.pid]:
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        head.wait(10)


def _wait_up(address: str, env: dict) -> None:
    probe = "import ray, sys; ray.init(address=sys.argv[1], logging_level='ERROR'); ray.shutdown()"
    deadline = time.monotonic() + 60
    while True:
        done = subprocess.run([sys.executable, "-c", probe, address], env=env, capture_output=True, text=True)
        if done.returncode == 0:
            return
        if time.monotonic() > deadline:
            raise RuntimeError(f"the loopback Ray cluster at {address} did not come up: {done.stderr[-300:]}")
        time.sleep(0.5)

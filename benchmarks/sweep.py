"""The sweep's wall time on the local pool and on a Ray cluster of this machine (issue 35 point 5).

    python benchmarks/sweep.py                                   # 2 zoo models x 3.3.0, 4.0.0 x c, 3 rounds each
    python benchmarks/sweep.py --models acrobot pendulum --releases 3.3.0..4.0.0 --repeat 3 \\
        --out benchmarks/results_sweep.txt

Runs ``mjharness sweep MODELS --releases ... --backends c`` as a fresh process per round, alternating the local
pool (``--executor local``) and a Ray cluster on loopback that this script starts once (``ray start --head``,
every CPU) and stops at the end, so both pay the same machine's load. The releases' environments are built
before the first round (one untimed local sweep), so the rounds time the cells, not the builds. Reports each
executor's median wall time, the Ray / local ratio, and whether every round's sweep.json is the same as the
first local one's (everything but what the run cost and where it ran: ``harness.versions.sweep_report``).
On one machine Ray can only add its workers' start and the tasks' scheduling: what it buys is the path to
more machines, with the same figures.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from harness.versions.sweep_report import comparable, differences


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _sweep(argv: list[str], out: Path, env: dict[str, str]) -> tuple[float, dict]:
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "harness", "sweep", *argv, "--out", str(out)], env=env,
                          capture_output=True, text=True, check=False)
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"sweep exited {done.returncode}: {(done.stderr or done.stdout).strip().splitlines()[-1:]}")
    return seconds, json.loads((out / "sweep.json").read_text())


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--models", nargs="+", default=["dm_control/pendulum", "dm_control/acrobot"])
    p.add_argument("--releases", nargs="+", default=["3.3.0", "4.0.0"])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--out", type=Path, help="write the figures here as well")
    args = p.parse_args()
    argv = [*args.models, "--releases", *args.releases, "--backends", "c"]
    ray = shutil.which("ray", path=str(Path(sys.executable).parent)) or "ray"
    env = {**os.environ, "RAY_AUTH_MODE": "disabled", "RAY_USAGE_STATS_ENABLED": "0"}
    address = f"127.0.0.1:{_free_port()}"
    times: dict[str, list[float]] = {"local": [], "ray": []}
    mismatches: list[str] = []
    with tempfile.TemporaryDirectory() as scratch:
        tmp = Path(scratch)
        _sweep(argv, tmp / "warm", env)  # builds the environments: untimed
        subprocess.run([ray, "start", "--head", "--node-ip-address", "127.0.0.1", "--port", address.split(":")[1],
                        "--num-cpus", str(os.cpu_count() or 1), "--include-dashboard", "false",
                        "--temp-dir", str(tmp / "ray")], check=True, capture_output=True, env=env)
        try:
            first = None
            for i in range(args.repeat):
                for kind, extra in (("local", []), ("ray", ["--executor", "ray", "--ray-address", address])):
                    seconds, doc = _sweep([*argv, *extra], tmp / f"{kind}{i}", env)
                    times[kind].append(seconds)
                    first = first or comparable(doc)
                    mismatches += [f"{kind} round {i + 1}: {d}" for d in differences(first, comparable(doc))]
                    print(f"round {i + 1} {kind}: {seconds:.1f} s", flush=True)
        finally:
            subprocess.run([ray, "stop", "--force"], capture_output=True, env=env, check=False)
    local, on_ray = statistics.median(times["local"]), statistics.median(times["ray"])
    cells = len(first["cells"]) if first else 0
    lines = [f"The sweep's wall time, local pool vs a Ray cluster on this machine ({os.cpu_count()} CPUs), "
             f"{time.strftime('%Y-%m-%d')}",
             f"  command: python benchmarks/sweep.py --models {' '.join(args.models)} --releases "
             f"{' '.join(args.releases)} --repeat {args.repeat}",
             f"  sweep: mjharness sweep {' '.join(argv)} ({cells} cells; environments built before, untimed)",
             f"  local pool (--executor local):        median {local:.1f} s of {args.repeat} "
             f"({', '.join(f'{t:.1f}' for t in times['local'])})",
             f"  Ray on loopback (--executor ray):     median {on_ray:.1f} s of {args.repeat} "
             f"({', '.join(f'{t:.1f}' for t in times['ray'])})",
             f"  Ray / local: {on_ray / local:.2f}",
             "  every round's sweep.json identical to the first (figures bit for bit): "
             + ("yes" if not mismatches else f"NO: {mismatches[:3]}")]
    text = "\n".join(lines) + "\n"
    print(text, end="")
    if args.out is not None:
        args.out.write_text(text)


if __name__ == "__main__":
    main()

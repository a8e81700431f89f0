"""What the tree reference costs: a model's whole case-free ``check`` cold, the reference's share of it, and
one evaluation of the equations of motion against the number of degrees of freedom.

    python benchmarks/tree.py [--repeat 3] [--out benchmarks/results_tree.txt]

Part 1 runs ``mjharness check --mjcf MODEL`` in a fresh process per model (nothing cached: a tree case has no
derivation), ``--repeat`` times, and reports the median wall time; the reference's share is the process's own
timings (``check --json``: horizon choice + reference solve) over its wall time. Part 2 times
``TreeDynamics.accelerations`` (M, F and the constraint solve at one state) on chains of n links, median of
many calls, and fits the growth exponent t ∝ n^k. Models: our 7-DoF arm (benchmarks/models/arm7.xml) and, where
installed, dm_control's acrobot, walker and humanoid.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

import mujoco
import numpy as np

HERE = Path(__file__).resolve().parent


def _models() -> dict[str, Path]:
    out = {"arm7": HERE / "models" / "arm7.xml"}
    spec = importlib.util.find_spec("dm_control")
    if spec is not None and spec.origin:
        suite = Path(spec.origin).parent / "suite"
        out |= {f"dm_control/{n}": suite / f"{n}.xml" for n in ("acrobot", "walker", "humanoid")}
    return out


def check_cold(path: Path, repeat: int) -> dict[str, float]:
    walls, shares = [], []
    for _ in range(repeat):
        start = time.perf_counter()
        done = subprocess.run([sys.executable, "-m", "harness.cli", "check", "--mjcf", str(path), "--json"],
                              capture_output=True, text=True, timeout=1800)
        walls.append(time.perf_counter() - start)
        doc = json.loads(done.stdout)
        case = next(iter(doc["cases"].values()))
        seconds = case["settings"]["tree"]["seconds"]
        shares.append((seconds["horizon"] + seconds["reference"]) / walls[-1])
        failed = [c["name"] for c in case["checks"] if not c.get("passed", True)] if isinstance(case["checks"], list) \
            else []
        verdict = "PASS" if doc["passed"] else f"FAIL {', '.join(failed[:3])}"
    model = mujoco.MjModel.from_xml_path(str(path))
    return {"nv": model.nv, "wall": statistics.median(walls), "min": min(walls), "max": max(walls),
            "share": statistics.median(shares), "verdict": verdict}


def chain(n: int) -> str:
    """A chain of n capsule links on alternating hinge axes (a spatial arm of any length)."""
    body = "<site name='tip' pos='0.2 0 0'/>"
    for k in reversed(range(n)):
        axis = ("0 0 1", "0 1 0", "1 0 0")[k % 3]
        body = (f"<body name='l{k}' pos='{0.2 if k else 0} 0 0'><joint name='j{k}' axis='{axis}' damping='0.1'/>"
                f"<geom type='capsule' fromto='0 0 0 0.2 0 0' size='0.03'/>{body}</body>")
    return f"<mujoco><worldbody>{body}</worldbody></mujoco>"


def per_dof(sizes: tuple[int, ...] = (2, 4, 8, 16, 32)) -> tuple[list[tuple[int, float]], float]:
    from analytic.tree import TreeDynamics
    from harness.reference.tree import prepare, read_tree

    rows = []
    for n in sizes:
        spec = mujoco.MjSpec.from_string(chain(n))
        prepare(spec)
        dyn = TreeDynamics.of(read_tree(spec.compile()))
        q, qd = np.full(n, 0.3), np.full(n, 0.5)
        dyn.accelerations(q, qd)
        times = []
        for _ in range(7):
            start = time.perf_counter()
            for _ in range(20):
                dyn.accelerations(q, qd)
            times.append((time.perf_counter() - start) / 20)
        rows.append((n, statistics.median(times)))
    slope = float(np.polyfit(np.log([r[0] for r in rows]), np.log([r[1] for r in rows]), 1)[0])
    return rows, slope


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--out", type=Path)
    args = p.parse_args()
    lines = [f"mujoco {mujoco.__version__}; median of {args.repeat} cold processes each", "",
             "part 1: case-free check, whole process", f"{'model':22} {'nv':>3} {'median s':>9} {'min':>7} {'max':>7} "
             f"{'reference share':>15}  verdict"]
    for name, path in _models().items():
        r = check_cold(path, args.repeat)
        lines.append(f"{name:22} {r['nv']:>3} {r['wall']:9.1f} {r['min']:7.1f} {r['max']:7.1f} {r['share']:15.0%}  "
                     f"{r['verdict']}")
        print(lines[-1], flush=True)
    rows, slope = per_dof()
    lines += ["", "part 2: one TreeDynamics.accelerations (M, F, solve) on an n-link chain, median",
              *(f"  n = {n:3d}: {t * 1e3:7.2f} ms" for n, t in rows), f"  growth: t ∝ n^{slope:.2f}"]
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        args.out.write_text(text)


if __name__ == "__main__":
    main()

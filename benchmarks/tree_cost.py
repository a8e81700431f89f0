"""What the tree reference costs per degree of freedom, and what a large model's whole check costs (issue 29).

    python benchmarks/tree_cost.py                     # part 2 only: one M+F evaluation against n (seconds)
    python benchmarks/tree_cost.py --check humanoid humanoid_CMU dog   # and part 1 for these dm_control models

Part 1 runs ``mjharness check --mjcf MODEL --json`` in a fresh process per model and reports its wall time, the
reference's share (``settings.tree.seconds``: the chaos horizon's solve plus the reference's own, over the wall
time), the exit status and the deciding figure (the failure furthest over its limit, else the check closest to it).

Part 2 times one ``TreeDynamics.mass_and_forcing`` (M and F at one state: forward kinematics at the n + 2 complex
configurations, T and ∂T/∂q̇ there, M at the real one) on models of 2 … 85 dof, median of repeated calls in this
one process, both wall and CPU time (the machine is shared: CPU time is the steadier), and reports evaluations per
second, each model's time relative to the smallest one's, and the growth exponent k of t ∝ n^k fitted over them.
Set ``OPENBLAS_NUM_THREADS=1`` on a loaded machine: a threaded BLAS on 85 × 85 products waits on busy cores.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import statistics
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
PER_DOF = ("acrobot", "arm7", "manipulator", "humanoid", "humanoid_CMU", "dog")
"""2, 7, 14, 27, 62 and 85 dof: dm_control's models where installed, our 7-DoF arm."""


def _suite() -> Path | None:
    spec = importlib.util.find_spec("dm_control")
    return Path(spec.origin).parent / "suite" if spec is not None and spec.origin else None


def model_path(name: str) -> Path | None:
    if name == "arm7":
        return HERE / "models" / "arm7.xml"
    suite = _suite()
    return suite / f"{name}.xml" if suite is not None and (suite / f"{name}.xml").exists() else None


def _judged(check: dict) -> tuple[float, float]:
    """What a check is judged by and its limit: a budget's unexplained residual, else the figure itself."""
    budget = check.get("budget")
    if budget:
        return abs(budget.get("unexplained", float("nan"))), budget.get("limit", float("nan"))
    return abs(check.get("value", float("nan"))), check.get("threshold", float("nan"))


def _ratio(check: dict) -> float:
    judged, limit = _judged(check)
    return judged / limit if isinstance(limit, int | float) and limit > 0 else float("nan")


def deciding(doc: dict) -> str:
    """The deciding figure of a ``check --json`` run (as the zoo names it): the failure furthest over its limit,
    else the check closest to it, by its unexplained residual where it has a budget."""
    case = next(iter(doc["cases"].values()))
    checks = [(name, c) for name, c in case["checks"].items() if c.get("status") in ("pass", "fail")]
    failed = [x for x in checks if x[1]["status"] == "fail"]
    pool = failed or checks
    if not pool:
        return "no judged check"
    name, c = max(pool, key=lambda x: -1.0 if np.isnan(_ratio(x[1])) else _ratio(x[1]))
    judged, limit = _judged(c)
    head = "worst failure" if failed else "closest"
    what = "unexplained" if c.get("budget") else "figure"
    return f"{head}: {name}: {what} {judged:.2g} vs limit {limit:.2g} (measured {c.get('value'):.3g})"


def check_cold(path: Path, *, timeout: float) -> dict[str, object]:
    """One whole case-free check in a fresh process: wall seconds, the reference's share, exit, deciding figure."""
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "harness", "check", "--mjcf", str(path), "--json", "--jobs", "1"],
                          capture_output=True, text=True, timeout=timeout, cwd=ROOT)
    wall = time.perf_counter() - start
    try:
        doc = json.loads(done.stdout)
    except json.JSONDecodeError:
        return {"wall": wall, "share": float("nan"), "exit": done.returncode,
                "deciding": (done.stderr.strip().splitlines() or ["no output"])[-1]}
    case = next(iter(doc["cases"].values()))
    seconds = case["settings"]["tree"]["seconds"]
    return {"wall": wall, "share": (seconds["horizon"] + seconds["reference"]) / wall,
            "horizon": seconds["horizon"], "reference": seconds["reference"], "exit": done.returncode,
            "deciding": deciding(doc)}


def evaluation_cost(path: Path, *, calls: int = 5, repeat: int = 7) -> dict[str, float]:
    """Median wall and CPU seconds of one M+F evaluation at a random state of the model's own tree."""
    from analytic.tree import TreeDynamics
    from harness.engine.models import compile_model
    from harness.reference.tree import isolate, prepare, read_tree

    def edit(spec) -> None:
        prepare(spec)
        isolate(spec)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # dog.xml's deprecated settotalmass
        dyn = TreeDynamics.of(read_tree(compile_model(path, edit=edit)))
    rng = np.random.default_rng(0)
    q, qd = rng.normal(scale=0.3, size=dyn.n), rng.normal(size=dyn.n)
    dyn.mass_and_forcing(q, qd)
    walls, cpus = [], []
    for _ in range(repeat):
        wall, cpu = time.perf_counter(), time.process_time()
        for _ in range(calls):
            dyn.mass_and_forcing(q, qd)
        walls.append((time.perf_counter() - wall) / calls)
        cpus.append((time.process_time() - cpu) / calls)
    return {"n": dyn.n, "bodies": len(dyn.tree.bodies), "wall": statistics.median(walls),
            "cpu": statistics.median(cpus)}


def per_dof(names: tuple[str, ...] = PER_DOF) -> list[str]:
    rows = [(name, evaluation_cost(path)) for name in names if (path := model_path(name)) is not None]
    if not rows:
        return ["no model found (dm_control is not installed)"]
    base = rows[0][1]["cpu"]
    lines = [f"{'model':14} {'n':>3} {'bodies':>6} {'wall ms':>8} {'cpu ms':>7} {'evals/s':>8} {'x smallest':>10}"]
    lines += [f"{name:14} {r['n']:>3} {r['bodies']:>6} {r['wall'] * 1e3:8.2f} {r['cpu'] * 1e3:7.2f} "
              f"{1 / r['cpu']:8.0f} {r['cpu'] / base:10.1f}" for name, r in rows]
    big = [r for _, r in rows if r["n"] >= 7]
    if len(big) >= 2:
        k = float(np.polyfit(np.log([r["n"] for r in big]), np.log([r["cpu"] for r in big]), 1)[0])
        lines.append(f"growth over n >= 7 (CPU time): t ∝ n^{k:.2f}")
    return lines


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--check", nargs="*", default=(), metavar="MODEL",
                   help="also run the whole check of these dm_control models (or arm7), one cold process each")
    p.add_argument("--timeout", type=float, default=1800.0)
    args = p.parse_args()
    sys.path.insert(0, str(ROOT))
    print("part 2: one M+F evaluation of the tree dynamics, median of 7 x 5 calls", flush=True)
    print("\n".join(per_dof()), flush=True)
    if args.check:
        print("\npart 1: the whole case-free check, one cold process each", flush=True)
        print(f"{'model':14} {'wall s':>7} {'horizon s':>9} {'ref s':>6} {'ref share':>9} {'exit':>4}  deciding",
              flush=True)
    for name in args.check:
        path = model_path(name)
        if path is None:
            print(f"{name:14} not found")
            continue
        r = check_cold(path, timeout=args.timeout)
        nan = float("nan")
        print(f"{name:14} {r['wall']:7.1f} {r.get('horizon', nan):9.1f} {r.get('reference', nan):6.1f} "
              f"{r['share']:9.0%} {r['exit']:>4}  {r['deciding']}", flush=True)


if __name__ == "__main__":
    main()

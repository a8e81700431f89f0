"""The tree reference's cost against the number of degrees of freedom (issue 43 point 6): the cost model the
up-front bound on a model's reference rests on (:mod:`harness.core.bounds`, ``reference_estimate``).

    OPENBLAS_NUM_THREADS=1 python benchmarks/tree_scale.py [--out benchmarks/results_tree_scale.txt]

On chains of n capsule links (``benchmarks/tree.py``'s ``chain``), in this one process:

1. one evaluation of the tree's accelerations (M, the bias forces and the qacc solve at one state), median of
   repeated calls, for n up to 300; each as a ratio to n = 2's, and the exponent k of t ∝ n^k fitted over them;
2. the reference as ``check --mjcf`` solves it (``from_mjcf`` with the horizon given, then its reference over 1 s
   of simulated time, the solution cache off): right-hand-side evaluations per simulated second and the solve's
   seconds, and the solve's seconds over (evaluations × one evaluation's seconds): the share of a solve the
   evaluations are;
3. the same evaluations per simulated second on the small zoo models where installed (dm_control, Gymnasium): the
   slowest motions, whose fewest is the bound's floor (``EVALUATIONS_PER_SECOND``).

The bound estimates a solve as evaluations × one evaluation measured on the model itself, the evaluations at least
the fewest per simulated second seen here.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import mujoco
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

from tree import chain  # noqa: E402

EVAL_SIZES = (2, 4, 8, 16, 32, 64, 128, 300)
SOLVE_SIZES = (2, 4, 8, 16)
ZOO = ("dm_control/pendulum", "dm_control/cartpole", "dm_control/point_mass", "dm_control/acrobot",
       "gymnasium/inverted_pendulum", "gymnasium/reacher", "gymnasium/swimmer")


def one_evaluation(n: int, repeat: int = 5) -> float:
    """Median seconds of one ``TreeDynamics.accelerations`` on an n-link chain."""
    from analytic.tree import TreeDynamics
    from harness.reference.tree import prepare, read_tree

    spec = mujoco.MjSpec.from_string(chain(n))
    prepare(spec)
    dyn = TreeDynamics.of(read_tree(spec.compile()))
    q, qd = np.full(n, 0.3), np.full(n, 0.5)
    dyn.accelerations(q, qd)
    calls = max(1, int(0.5 / max(_timed(lambda: dyn.accelerations(q, qd)), 1e-6)))
    return statistics.median(_timed(lambda: dyn.accelerations(q, qd), calls) for _ in range(repeat))


def _timed(fn, calls: int = 1) -> float:
    start = time.perf_counter()
    for _ in range(calls):
        fn()
    return (time.perf_counter() - start) / calls


def one_solve(n: int, folder: Path) -> tuple[int, float]:
    """(right-hand-side evaluations, seconds) of the n-link chain's reference over 1 s, as check --mjcf solves it."""
    path = folder / f"chain{n}.xml"
    path.write_text(chain(n))
    return solved(path)


def solved(path: Path) -> tuple[int, float]:
    """(right-hand-side evaluations, seconds) of the model's reference over 1 s, as check --mjcf solves it."""
    from harness.cases.own import from_mjcf
    from harness.engine.models import compile_model

    case = from_mjcf(path, horizon=1.0)
    model = compile_model(path, edit=case.prepare)
    start = time.perf_counter()
    ref = case.reference(model, t_end=1.0)
    return ref.solution.nfev, time.perf_counter() - start


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path)
    args = p.parse_args()
    os.environ["XDG_CACHE_HOME"] = tempfile.mkdtemp()  # no stored solution: every solve is made here
    lines = [f"mujoco {mujoco.__version__}, numpy {np.__version__}, OPENBLAS_NUM_THREADS="
             f"{os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}; one process, chains of n capsule links", "",
             "part 1: one evaluation of the tree's accelerations (M, bias forces, qacc), median",
             f"  {'n':>4} {'ms':>10} {'× n=2':>9}"]
    evals = []
    for n in EVAL_SIZES:
        evals.append((n, one_evaluation(n)))
        lines.append(f"  {n:>4} {evals[-1][1] * 1e3:10.3f} {evals[-1][1] / evals[0][1]:9.1f}")
        print(lines[-1], flush=True)
    big = [(n, t) for n, t in evals if n >= 16]
    slope = float(np.polyfit(np.log([n for n, _ in big]), np.log([t for _, t in big]), 1)[0])
    lines += [f"  growth over n ≥ 16: t ∝ n^{slope:.2f}", "",
              "part 2: the reference over 1 s of simulated time (from_mjcf's start, horizon given), cache off",
              f"  {'n':>4} {'evaluations':>11} {'solve s':>9} {'× n=2':>8} {'solve / (evals × one)':>22}"]
    per = dict(evals)
    with tempfile.TemporaryDirectory() as folder:
        solves = []
        for n in SOLVE_SIZES:
            nfev, seconds = one_solve(n, Path(folder))
            solves.append((n, nfev, seconds))
            lines.append(f"  {n:>4} {nfev:>11} {seconds:9.2f} {seconds / solves[0][2]:8.1f} "
                         f"{seconds / (nfev * per[n]):22.2f}")
            print(lines[-1], flush=True)
    lines.append(f"  fewest evaluations per simulated second: {min(s[1] for s in solves)}")
    from harness import zoo

    models, _ = zoo.discover()
    found = {m.name: m for m in models}
    lines += ["", "part 3: the reference over 1 s of the small zoo models (installed ones), cache off",
              f"  {'model':28} {'nv':>3} {'evaluations':>11} {'solve s':>8}"]
    fewest = []
    for name in ZOO:
        if name not in found:
            lines.append(f"  {name:28} not installed")
            continue
        nfev, seconds = solved(found[name].path)
        fewest.append(nfev)
        lines.append(f"  {name:28} {zoo._nv(found[name].path):>3} {nfev:>11} {seconds:8.2f}")
        print(lines[-1], flush=True)
    if fewest:
        lines.append(f"  fewest evaluations per simulated second: {min(fewest)} (the bound's floor: "
                     "harness.core.bounds.EVALUATIONS_PER_SECOND, rounded down)")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        args.out.write_text(text)


if __name__ == "__main__":
    main()

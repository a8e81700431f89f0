"""What the error budget costs: ``mjharness check`` on all default cases, this tree against a base revision.

Run from the repository root (a git checkout)::

    python benchmarks/budget_cost.py                    # 5 pairs against BASE, 2 workers
    python benchmarks/budget_cost.py --base main --pairs 7 --jobs 1

The base revision is checked out into a temporary git worktree and run from
there (``PYTHONPATH`` puts its ``harness``, ``analytic`` and ``mjcf`` first),
with the same interpreter and packages. Each side has its own derivation cache,
warmed by one untimed run, so both are timed as a user's second run is. The
two commands then run in turn, A B A B …, and the ratio is taken pair by pair,
so that it holds while the machine's speed drifts; the median ratio is the
figure (issue 14's target: at most 2).

BASE defaults to the last commit before the error budget (issue 14): the
limits then were measured figures × 2–3 and no variant runs were made.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BASE = "5c67283"  # the last commit before the error budget


def _run(tree: Path, cache: Path, jobs: int) -> float:
    env = {**os.environ, "PYTHONPATH": str(tree), "XDG_CACHE_HOME": str(cache)}
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "harness.cli", "check", "--jobs", str(jobs)],
                          cwd=tree, env=env, capture_output=True, text=True)
    elapsed = time.perf_counter() - start
    if done.returncode not in (0, 1):
        raise SystemExit(f"check in {tree} exited {done.returncode}: {done.stderr.strip()[-500:]}")
    return elapsed


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--base", default=BASE, help=f"the revision to compare with (default {BASE})")
    parser.add_argument("--pairs", type=int, default=5, help="timed A/B pairs (default 5)")
    parser.add_argument("--jobs", type=int, default=2, help="worker processes of each check (default 2)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="mjharness-bench-") as tmp:
        base = Path(tmp) / "base"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(base), args.base],
                       check=True, capture_output=True)
        try:
            caches = {"this": Path(tmp) / "cache-this", "base": Path(tmp) / "cache-base"}
            trees = {"this": ROOT, "base": base}
            for side in trees:  # warm: derivations cached, as a user's second run
                _run(trees[side], caches[side], args.jobs)
            times: dict[str, list[float]] = {"this": [], "base": []}
            for _ in range(args.pairs):
                for side in ("this", "base"):
                    times[side].append(_run(trees[side], caches[side], args.jobs))
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(base)], capture_output=True)
    ratios = [a / b for a, b in zip(times["this"], times["base"], strict=True)]
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"mjharness check, all default cases, --jobs {args.jobs}: this tree vs {args.base}, {args.pairs} pairs "
          f"(load average {load:.2f})")
    for side in ("this", "base"):
        t = times[side]
        print(f"  {side:5s} wall s: min {min(t):.2f}  median {statistics.median(t):.2f}  max {max(t):.2f}")
    print(f"  ratio this/base: min {min(ratios):.2f}  median {statistics.median(ratios):.2f}  max {max(ratios):.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Issue 31's check figures: ``mjharness check`` on all default cases, cold and warm, 1 and 2 workers, this
tree against a base revision, in one run.

Run from the repository root (a git checkout)::

    python benchmarks/fast_feedback.py                   # 3 rounds against BASE
    python benchmarks/fast_feedback.py --base main --rounds 5

The base revision is exported (``git archive``) into a temporary folder and run from there (``PYTHONPATH``
puts its ``harness``, ``analytic`` and ``mjcf`` first), with the same interpreter and packages. A round
runs, for each side in turn: ``check --jobs 2`` with an empty cache (cold: a fresh install's first run),
then ``check --jobs 1`` and ``check --jobs 2`` with that cache filled (warm). Python writes and reads its
bytecode cache as on a user's machine (``PYTHONDONTWRITEBYTECODE`` is unset for the runs). The figure of each is the
median over rounds, so that it holds while the machine's speed drifts; the speed-up from 1 to 2 workers is
the median of the per-round ratios. Targets (issue 31): cold <= 20 s, warm <= 5 s, speed-up >= 1.7.

BASE defaults to the commit the issue measured (82fbb63; its figures: docs/findings/speed.md).
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
BASE = "82fbb63"


def _check(tree: Path, cache: Path, jobs: int) -> float:
    env = {**os.environ, "PYTHONPATH": str(tree), "XDG_CACHE_HOME": str(cache)}
    env.pop("MJHARNESS_NO_CACHE", None)
    env.pop("MJHARNESS_NO_PREBUILT", None)
    # Python's own bytecode cache, as on a user's machine (pip compiles it at install; a source tree writes it on
    # first import): a shell that sets PYTHONDONTWRITEBYTECODE would make every process compile every module
    # again (in each of the three processes a run with 2 jobs starts)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "harness.cli", "check", "--quiet", "--jobs", str(jobs)],
                          cwd=tree, env=env, capture_output=True, text=True)
    elapsed = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"check in {tree} exited {done.returncode}: {done.stderr.strip()[-500:]}")
    return elapsed


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--base", default=BASE, help=f"the revision to compare with (default {BASE})")
    parser.add_argument("--rounds", type=int, default=3, help="rounds (default 3)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="mjharness-bench-") as tmp:
        base = Path(tmp) / "base"
        base.mkdir()
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", args.base], check=True, capture_output=True)
        subprocess.run(["tar", "-x", "-C", str(base)], input=archive.stdout, check=True)
        trees = {"this": ROOT, "base": base}
        times: dict[tuple[str, str], list[float]] = {}
        loads = []
        for r in range(args.rounds):
            for side, tree in trees.items():
                cache = Path(tmp) / f"cache-{side}-{r}"
                loads.append(os.getloadavg()[0])
                times.setdefault((side, "cold, 2 jobs"), []).append(_check(tree, cache, 2))
                times.setdefault((side, "warm, 1 job"), []).append(_check(tree, cache, 1))
                times.setdefault((side, "warm, 2 jobs"), []).append(_check(tree, cache, 2))
    print(f"mjharness check, all default cases: this tree vs {args.base}, {args.rounds} rounds, {os.cpu_count()} CPUs "
          f"(load average during the runs: {min(loads):.2f}-{max(loads):.2f})")
    for side in trees:
        cells = [f"{what} {statistics.median(times[side, what]):6.2f} s" for what in
                 ("cold, 2 jobs", "warm, 1 job", "warm, 2 jobs")]
        speedup = statistics.median(a / b for a, b in zip(times[side, "warm, 1 job"], times[side, "warm, 2 jobs"],
                                                          strict=True))
        print(f"  {side:5s} median: {';  '.join(cells)};  1 -> 2 jobs warm {speedup:.2f}x")
    for what in ("cold, 2 jobs", "warm, 2 jobs"):
        ratio = statistics.median(a / b for a, b in zip(times["this", what], times["base", what], strict=True))
        print(f"  this/base, {what}: median ratio {ratio:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

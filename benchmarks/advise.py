"""Issue 47's speed figure: ``mjharness advise`` on a 7-DoF arm within 60 s on the 2-core machine, beside
``mjharness check`` on the same model in the same run (the ratio holds while the machine's speed drifts).

Run from the repository root::

    python benchmarks/advise.py                                # KUKA iiwa 14 and the Panda, 3 rounds
    python benchmarks/advise.py --rounds 1 --model path/to/arm.xml

Each round runs, per model, ``check --mjcf MODEL --quiet`` and then ``advise --mjcf MODEL --require
position=1e-3``, each cold (an empty cache folder: a first run on a fresh machine) and each as its own
process; the figure is the median over rounds of the wall time, and of the per-round ratio advise / check.
Writes the table to stdout (benchmarks/results_advise.txt holds the last one measured).
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
MENAGERIE = ROOT.parent / "shared" / "models" / "menagerie"
MODELS = (MENAGERIE / "kuka_iiwa_14" / "iiwa14.xml", MENAGERIE / "franka_emika_panda" / "scene.xml")
TARGET = 60.0


def _timed(args: list[str]) -> tuple[float, int, str]:
    with tempfile.TemporaryDirectory(prefix="mjharness-advise-") as cache:
        env = {**os.environ, "XDG_CACHE_HOME": cache, "PYTHONPATH": str(ROOT)}
        start = time.perf_counter()
        done = subprocess.run([sys.executable, "-m", "harness", *args], cwd=ROOT, env=env, capture_output=True,
                              text=True)
        return time.perf_counter() - start, done.returncode, done.stdout


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rounds", type=int, default=3, help="rounds (default 3)")
    parser.add_argument("--model", action="append", type=Path, help="a model (repeatable; default: the arms)")
    args = parser.parse_args()
    models = args.model or [m for m in MODELS if m.exists()]
    if not models:
        raise SystemExit(f"no model: {MENAGERIE} is absent; give --model")
    rows = []
    for model in models:
        checks, advises, ratios, said = [], [], [], ""
        for _ in range(args.rounds):
            check, _, _ = _timed(["check", "--mjcf", str(model), "--quiet"])
            advise, code, out = _timed(["advise", "--mjcf", str(model), "--require", "position=1e-3"])
            if code not in (0, 3):
                raise SystemExit(f"advise on {model} exited {code}")
            said = next((line for line in out.splitlines() if line.startswith(("Recommended", "No recommendation"))),
                        "")
            checks.append(check)
            advises.append(advise)
            ratios.append(advise / check)
        rows.append((model, statistics.median(checks), statistics.median(advises), statistics.median(ratios),
                     min(advises), max(advises), said))
    print(f"advise --require position=1e-3, cold cache, {args.rounds} round(s), target <= {TARGET:g} s")
    print("| model | check (s) | advise (s, median) | min–max | advise / check | within target | answer |")
    print("|---|---|---|---|---|---|---|")
    for model, check, advise, ratio, low, high, said in rows:
        print(f"| {model.parent.name}/{model.name} | {check:.1f} | {advise:.1f} | {low:.1f}–{high:.1f} | {ratio:.1f} | "
              f"{'yes' if advise <= TARGET else 'NO'} | {said[:110]} |")
    return 0 if all(r[2] <= TARGET for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())

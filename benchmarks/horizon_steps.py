"""The steps of each model's chaos-horizon reference solve (the basis of ``harness.cases.own.HORIZON_STEPS``).

For every model of the zoo (dm_control's and Gymnasium's) and every robot of ``../shared/models/menagerie``: the
solver, its steps over the span it solved, and whether HORIZON_STEPS cut the horizon. Run from the repository root:

    python benchmarks/horizon_steps.py > benchmarks/results_horizon_steps.txt
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from harness import zoo
from harness.cases import own
from harness.core.errors import ModelError, RunTooLong
from harness.engine.models import compile_model
from harness.reference.solutions import build_reference

ROBOTS = Path(__file__).resolve().parents[2] / "shared" / "models" / "menagerie"


def main() -> None:
    models, _skipped = zoo.discover()
    paths = [(m.name, m.path) for m in models]
    if ROBOTS.is_dir():
        found, _ = zoo.folder_models(ROBOTS)
        paths += [(m.name, m.path) for m in found]
    print(f"HORIZON_STEPS = {own.HORIZON_STEPS}, HORIZON_CAP = {own.HORIZON_CAP} s")
    print("| model | nv | solver | steps | span solved (s) | horizon (s) | cut | seconds |")
    print("|---|---|---|---|---|---|---|---|")
    for name, path in paths:
        clock = time.perf_counter()
        try:
            case = own.from_mjcf(path)
        except (ModelError, RunTooLong) as exc:
            print(f"| {name} | | refused: {str(exc)[:80]} | | | | | |", flush=True)
            continue
        model = compile_model(case.mjcf, edit=case.prepare)
        nominal = build_reference(case.system, model, q0=case.q0, qd0=case.qd0, horizon=case.horizon,
                                  t_end=own.HORIZON_CAP, tree=case.tree, reach=own.HORIZON_STEPS)
        sol = nominal.solution
        cut = "cost" in (case.tree.horizon_note or "")
        print(f"| {name} | {model.nv} | {sol.method} | {len(sol._dense.h)} | {sol.t_end:.3g} | {case.horizon:g} | "
              f"{'yes' if cut else 'no'} | {time.perf_counter() - clock:.1f} |", flush=True)


if __name__ == "__main__":
    sys.exit(main())

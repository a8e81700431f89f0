"""``mjharness baseline``: write or compare the regression baseline."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from harness.cli.common import EXIT_FAIL, EXIT_OK, Command, selected_cases
from harness.cli.options import add_selection
from harness.outputs import baseline
from harness.outputs.diff import load_run
from harness.outputs.files import check_output
from harness.outputs.table import checks_table
from harness.pipeline.entry import Judging, evaluate

__all__ = ["COMMAND"]


def _args_baseline(p: argparse.ArgumentParser) -> None:
    add_selection(p, mjcf=False)
    mode = p.add_mutually_exclusive_group(required=True)
    mode.add_argument("--write", type=Path, metavar="PATH",
                      help="run the cases and write their gated figures: a directory gets one file per case "
                           "(naming cases updates only those), a .json file all cases in one")
    mode.add_argument("--compare", type=Path, metavar="PATH",
                      help="run the cases and fail (exit 1) where a figure regressed against PATH")


def cmd_baseline(args: argparse.Namespace) -> int:
    selected = selected_cases(args)
    if args.write is not None:
        check_output(baseline.output_dir(args.write))
        partial = bool(args.cases or args.case)
        old = load_run(args.write) if partial and baseline.exists(args.write) else None
        done = evaluate(selected, judging=Judging(config=args.config), jobs=args.jobs, figures_only=True,
                        requirements=False)
        results, checks = done.results, done.checks
        failing = [c for cs in checks.values() for c in cs if not c.passed and not c.known]  # a known defect is
        # what this MuJoCo does, documented: a baseline of this version records it
        if failing:
            print(checks_table(checks))
            print(f"mjharness: refusing to write a baseline while {len(failing)} check(s) fail", file=sys.stderr)
            return EXIT_FAIL
        new = baseline.baseline_doc(results, checks)
        baseline.write(args.write, new, old)
        count = sum(len(c["figures"]) for c in new["cases"].values())
        print(f"wrote {args.write}: {', '.join(new['cases'])} ({count} gated figures)")
        return EXIT_OK
    reference = load_run(args.compare)
    mismatch = baseline.version_mismatch(reference, source=str(args.compare))
    if mismatch:  # a baseline is per MuJoCo version: refuse before any work
        raise ValueError(mismatch)
    done = evaluate(selected, judging=Judging(config=args.config), jobs=args.jobs, figures_only=True,
                    requirements=False)
    results, checks = done.results, done.checks
    findings = [f for r in results for f in baseline.compare(
        reference, r.case.name, r.figures, checks[r.case.name], source=str(args.compare))]
    for f in findings:
        print(f.message)
    print(f"{len(findings)} regression(s) or missing entries against {args.compare} "
          f"(rule: new > {baseline.FACTOR:g} × max(old, {baseline.FLOOR:g} × limit))")
    return EXIT_FAIL if findings else EXIT_OK


COMMAND = Command("write or compare the regression baseline", _args_baseline, cmd_baseline,
                  "write or compare the regression baseline (reports/baseline/)")

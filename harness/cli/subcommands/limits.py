"""``mjharness limits``: each case's limits with their basis."""

from __future__ import annotations

import argparse

from harness import cases
from harness.cli.common import EXIT_OK, Command
from harness.cli.options import add_cases, add_jobs, add_systems
from harness.outputs.files import check_output, write_atomic
from harness.pipeline import limits as limits_data
from harness.pipeline.entry import evaluate

__all__ = ["COMMAND"]


def _args_limits(p: argparse.ArgumentParser) -> None:
    add_cases(p)
    add_systems(p)
    p.add_argument("--write", action="store_true",
                   help="run the cases that have no limits file and write one by the default rule (the "
                        "figures it gates, each judged by its budget or its theory limit); files that exist "
                        "are left as they are")
    add_jobs(p)


def cmd_limits(args: argparse.Namespace) -> int:
    selected = cases.select(args.cases)
    if not args.write:
        shipped = limits_data.load_limits()
        for case in selected:
            entry = shipped.cases.get(case.name)
            print(f"{case.name} ({limits_data.limits_path(case.mjcf)}): "
                  + (f"{len(entry.limits)} gated figures" if entry else "no limits file"))
            for name, lim in (entry.limits.items() if entry else ()):
                value = "" if lim.value is None else f"{lim.value:.3e}"
                print(f"  {name:42s} {value:>10s}  {lim.describe()}")
        return EXIT_OK
    missing = [case for case in selected if not limits_data.limits_path(case.mjcf).is_file()]
    for case in missing:  # every file must be writable before the work
        check_output(limits_data.limits_path(case.mjcf).parent)
    if not missing:
        print("every case named has its limits file; budgets are computed for each run, so there is nothing "
              "to rewrite (edit a file to gate another figure)")
        return EXIT_OK
    results = evaluate(missing, jobs=args.jobs, figures_only=True, requirements=False).results
    files = {}
    for r in results:
        constrained = bool(r.case.dynamics().constraint_names)
        new = limits_data.default_limits(r.case.name, [f.name for f in r.figures], constrained=constrained)
        files[limits_data.limits_path(r.case.mjcf)] = limits_data.format_case_limits(new)
    for path in write_atomic(files):
        print(f"wrote {path}")
    return EXIT_OK


COMMAND = Command("each case's limits with their basis", _args_limits, cmd_limits,
                  "list each case's limits with their basis; --write writes the file of a case that has none, by the "
                  "default rule (nothing measured)")

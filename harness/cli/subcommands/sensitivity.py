"""``mjharness sensitivity``: the smallest size of each fault each case detects."""

from __future__ import annotations

import argparse

import mujoco

from harness import cases
from harness.cli.common import EXIT_OK, Command, executor_of, progress_printer
from harness.cli.options import add_cases, add_executor, add_jobs, add_systems
from harness.pipeline.pool import cpus, run_tasks

__all__ = ["COMMAND"]


def _args_sensitivity(p: argparse.ArgumentParser) -> None:
    add_cases(p)
    add_systems(p)
    p.add_argument("--faults", type=lambda text: text.split(","), metavar="NAME,...",
                   help="the faults to size (default: every fault of the catalog)")
    add_jobs(p)
    add_executor(p)


def cmd_sensitivity(args: argparse.Namespace) -> int:
    from harness.outputs.studies.sensitivity import table  # lazy: only the fault commands load the catalog
    from harness.studies import faults  # lazy: as above
    from harness.studies import sensitivity as study  # lazy: as above

    selected = cases.select(args.cases)
    chosen = [faults.by_name(name) for name in args.faults] if args.faults else list(faults.FAULTS)
    unknown = [f.name for f in chosen if f.kind != "fault"]
    if unknown:
        raise ValueError(f"--faults names settings, not faults: {', '.join(unknown)}; faults: "
                         f"{', '.join(f.name for f in faults.FAULTS)}")
    calls = [(study.sensitivity_named, (case.name, fault.name, coarse)) for case in selected for fault in chosen
             for coarse in (False, True)]
    rows = run_tasks(calls, args.jobs or cpus(), on_done=progress_printer(len(calls)), executor=executor_of(args),
                     labels=[f"sensitivity {case} {fault} (MuJoCo {mujoco.__version__}, backend c)"
                             for _, (case, fault, _) in calls])
    print(table(rows))
    return EXIT_OK


COMMAND = Command("the smallest size of each fault each case detects", _args_sensitivity, cmd_sensitivity,
                  "the smallest size of each fault each case detects, at the shipped settings and at 2 × the timestep "
                  "with MuJoCo's default softness (dozens of runs per case: minutes)")

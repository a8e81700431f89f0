"""``mjharness faults``: the fault catalog judged: settings must pass, faults fail."""

from __future__ import annotations

import argparse

import mujoco

from harness import cases
from harness.cli.common import EXIT_FAIL, EXIT_OK, Command, executor_of, progress_printer
from harness.cli.options import add_cases, add_executor, add_jobs, add_systems
from harness.pipeline.pool import cpus, run_tasks

__all__ = ["COMMAND"]


def _args_faults(p: argparse.ArgumentParser) -> None:
    add_cases(p)
    add_systems(p)
    p.add_argument("--coarse", action="store_true",
                   help="also judge each fault at 2 × the timestep with MuJoCo's default softness, at its coarse size")
    add_jobs(p)
    add_executor(p)


def cmd_faults(args: argparse.Namespace) -> int:
    from harness.outputs.studies.sensitivity import trials_table  # lazy: only the fault commands load the catalog
    from harness.studies import faults  # lazy: as above
    from harness.studies import sensitivity as study  # lazy: as above

    selected = cases.select(args.cases)
    calls = [(study.trial_named, (case.name, change.name, False)) for case in selected for change in faults.SETTINGS]
    calls += [(study.trial_named, (case.name, fault.name, coarse)) for case in selected for fault in faults.FAULTS
              for coarse in ((False, True) if args.coarse else (False,))]
    rows = run_tasks(calls, args.jobs or cpus(), on_done=progress_printer(len(calls)), executor=executor_of(args),
                     labels=[f"faults {case} {change} (MuJoCo {mujoco.__version__}, backend c)"
                             for _, (case, change, _) in calls])
    print(trials_table(rows))
    judged = [r for r in rows if r.verdict != "n/a"]
    unexpected = [r for r in judged if not r.as_expected]
    print(f"{len(judged) - len(unexpected)} of {len(judged)} as expected (settings pass, faults fail)"
          + (f"; unexpected: {', '.join(f'{r.case} {r.change} ({r.setting})' for r in unexpected)}"
             if unexpected else ""))
    return EXIT_FAIL if unexpected else EXIT_OK


COMMAND = Command("the fault catalog judged: settings must pass, faults fail", _args_faults, cmd_faults,
                  "every legitimate setting and every fault of the catalog (harness/studies/faults.py) on each case, "
                  "judged as check --mjcf judges a variant: the verdict, the check that decided and its budget (exit 1 "
                  "if a setting fails or a fault passes)")

"""``mjharness diff``: what changed between two runs, figure by figure."""

from __future__ import annotations

import argparse
from pathlib import Path

from harness.cli.common import EXIT_FAIL, EXIT_OK, Command
from harness.outputs.diff import diff_runs, format_diff, load_run, select

__all__ = ["COMMAND"]


def _args_diff(p: argparse.ArgumentParser) -> None:
    p.add_argument("old", type=Path, metavar="OLD", help="report.json, check --json output or a baseline "
                                                         "(file or directory) before")
    p.add_argument("new", type=Path, metavar="NEW", help="the same after")
    p.add_argument("--all", action="store_true", help="list every figure, unchanged ones and those whose "
                                                      "new/old prints as 1 too")
    p.add_argument("--case", action="append", default=[], metavar="NAME", help="only this case (repeatable)")
    p.add_argument("--figure", action="append", default=[], metavar="PATTERN",
                   help="only the figures matching this name or glob pattern, e.g. RK4.position or 'RK4.*' "
                        "(repeatable)")
    p.add_argument("--exact", action="store_true",
                   help="exit 1 unless every figure and verdict of both runs is identical")


def cmd_diff(args: argparse.Namespace) -> int:
    diff = select(diff_runs(load_run(args.old), load_run(args.new)), cases=args.case, figures=args.figure)
    print(format_diff(diff, show_all=args.all), end="")
    return EXIT_FAIL if args.exact and not diff.identical else EXIT_OK


COMMAND = Command("what changed between two runs, figure by figure", _args_diff, cmd_diff,
                  "what changed between two runs' JSON (report.json, check --json, a baseline), figure by figure; "
                  "flipped verdicts first, then by the size of the change; --case and --figure select rows")

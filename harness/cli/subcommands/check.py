"""``mjharness check``: the CI gate: every gated figure judged by its budget, no report."""

from __future__ import annotations

import argparse
import contextlib
import math
import sys

from harness.cli.common import (
    Command,
    case_lines,
    check_junit,
    command_exit_code,
    executor_of,
    inertials_of,
    judging_of,
    junit_files,
    limits_of,
    opinions_of,
    peers_of,
    print_checks,
    run_options,
    selected_cases,
    trees_of,
)
from harness.cli.options import (
    add_executor,
    add_json,
    add_junit,
    add_quiet,
    add_run_options,
    add_selection,
    parse_number,
)
from harness.outputs.files import write_atomic
from harness.outputs.jsondoc import dumps, json_doc
from harness.pipeline.entry import evaluate

__all__ = ["COMMAND", "args_check"]


def args_check(p: argparse.ArgumentParser) -> None:
    add_selection(p)
    add_junit(p)
    add_json(p)
    p.add_argument("--perturb", type=_tiny, metavar="SIZE",
                   help="move every initial coordinate and velocity x by SIZE × max(|x|, 1) (round-off: SIZE within "
                        "±1e-6, e.g. 1e-15 or =-1e-15 in float64, 5e-7 on a float32 backend): how far each figure "
                        "moves at round-off, its run-to-run noise (mjharness versions measures it so)")
    add_quiet(p)
    add_run_options(p)
    add_executor(p)


def _tiny(text: str) -> float:
    value = parse_number(text)
    if not (math.isfinite(value) and 0 < abs(value) <= 1e-6):  # float32's round-off (MJX) is 1.2e-7
        raise argparse.ArgumentTypeError(f"must be a nonzero number within ±1e-6 (round-off sized), got {text!r}")
    return value


def cmd_check(args: argparse.Namespace) -> int:
    check_junit(args.junit)
    selected = selected_cases(args)  # first: a model too large for its reference is refused before anything runs
    opinions = opinions_of(args)
    # with --json, stdout is the document alone: what a library prints meanwhile goes to stderr (mujoco-mjx
    # prints "Failed to import warp" to stdout when it is imported without Warp)
    with contextlib.redirect_stdout(sys.stderr) if args.json else contextlib.nullcontext():
        done = evaluate(selected, options=run_options(args, selected), judging=judging_of(args), jobs=args.jobs,
                        figures_only=True, executor=executor_of(args), **case_lines(args))
    results, limits, outcome = done.results, done.limits, done.outcome
    inertials = inertials_of(args, selected, limits)
    write_atomic(junit_files(args.junit, outcome))
    if args.json:
        appendix = ({"opinions": opinions.as_dict()} if opinions.as_dict() else {}) | {
            "inertials": inertials.as_dict()}
        sys.stdout.write(dumps(json_doc(results, outcome, appendix=appendix)))
    else:
        print_checks(outcome, quiet=args.quiet, verbose=args.verbose, trees=trees_of(results),
                     limits=limits_of(results), peers=peers_of(results),
                     opinions=[*opinions.lines(quiet=args.quiet), *inertials.lines(quiet=args.quiet)])
    return command_exit_code(outcome, opinions, inertials, json=args.json)


COMMAND = Command("the CI gate: every gated figure judged by its budget, no report", args_check, cmd_check,
                  "the CI gate: run the cases and judge every gated figure by its error budget or its limit (exit 0 "
                  "pass, 1 fail, 2 bad input, 3 a --require not met); draws nothing")

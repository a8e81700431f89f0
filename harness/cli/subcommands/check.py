"""``mjharness check``: the CI gate: every gated figure judged by its budget, no report."""

from __future__ import annotations

import argparse
import contextlib
import math
import sys

from harness.cli.common import (
    Command,
    _case_lines,
    _check_junit,
    _executor,
    _exit_code,
    _inertials,
    _judging,
    _junit,
    _limits,
    _opinions,
    _options,
    _peers,
    _print_checks,
    _selected,
    _trees,
)
from harness.cli.options import (
    _add_executor,
    _add_json,
    _add_junit,
    _add_quiet,
    _add_run_options,
    _add_selection,
    _number,
)
from harness.outputs.files import write_atomic
from harness.outputs.jsondoc import dumps, json_doc
from harness.pipeline.entry import evaluate

__all__ = ["COMMAND"]


def _args_check(p: argparse.ArgumentParser) -> None:
    _add_selection(p)
    _add_junit(p)
    _add_json(p)
    p.add_argument("--perturb", type=_tiny, metavar="SIZE",
                   help="move every initial coordinate and velocity x by SIZE × max(|x|, 1) (round-off: SIZE within "
                        "±1e-6, e.g. 1e-15 or =-1e-15 in float64, 5e-7 on a float32 backend): how far each figure "
                        "moves at round-off, its run-to-run noise (mjharness versions measures it so)")
    _add_quiet(p)
    _add_run_options(p)
    _add_executor(p)


def _tiny(text: str) -> float:
    value = _number(text)
    if not (math.isfinite(value) and 0 < abs(value) <= 1e-6):  # float32's round-off (MJX) is 1.2e-7
        raise argparse.ArgumentTypeError(f"must be a nonzero number within ±1e-6 (round-off sized), got {text!r}")
    return value


def cmd_check(args: argparse.Namespace) -> int:
    _check_junit(args.junit)
    selected = _selected(args)  # first: a model too large for its reference is refused before anything runs
    opinions = _opinions(args)
    # with --json, stdout is the document alone: what a library prints meanwhile goes to stderr (mujoco-mjx
    # prints "Failed to import warp" to stdout when it is imported without Warp)
    with contextlib.redirect_stdout(sys.stderr) if args.json else contextlib.nullcontext():
        done = evaluate(selected, options=_options(args, selected), judging=_judging(args), jobs=args.jobs,
                        figures_only=True, executor=_executor(args), **_case_lines(args))
    results, limits, outcome = done.results, done.limits, done.outcome
    inertials = _inertials(args, selected, limits)
    write_atomic(_junit(args.junit, outcome))
    if args.json:
        appendix = ({"opinions": opinions.as_dict()} if opinions.as_dict() else {}) | {
            "inertials": inertials.as_dict()}
        sys.stdout.write(dumps(json_doc(results, outcome, appendix=appendix)))
    else:
        _print_checks(outcome, quiet=args.quiet, verbose=args.verbose, trees=_trees(results), limits=_limits(results),
                      peers=_peers(results), opinions=[*opinions.lines(quiet=args.quiet),
                                                       *inertials.lines(quiet=args.quiet)])
    return _exit_code(outcome, opinions, inertials, json=args.json)


COMMAND = Command("the CI gate: every gated figure judged by its budget, no report", _args_check, cmd_check,
                  "the CI gate: run the cases and judge every gated figure by its error budget or its limit (exit 0 "
                  "pass, 1 fail, 2 bad input, 3 a --require not met); draws nothing")

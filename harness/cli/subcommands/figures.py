"""``mjharness figures``: every figure: what it measures, its unit, its limit's basis."""

from __future__ import annotations

import argparse

from harness import cases
from harness.cli.common import EXIT_OK, Command
from harness.cli.options import add_cases, add_config, add_jobs, add_systems
from harness.core.tables import terminal_width, wrap
from harness.pipeline.entry import Judging, evaluate

__all__ = ["COMMAND"]


def _args_figures(p: argparse.ArgumentParser) -> None:
    add_cases(p)
    add_systems(p)
    add_config(p)
    add_jobs(p)


def cmd_figures(args: argparse.Namespace) -> int:
    """Every figure a case measures, with its unit, what it measures and its limit with the basis. The
    descriptions are those the code that measures the figures gives them, so the cases run (as ``check``
    does: seconds, no report)."""
    done = evaluate(cases.select(args.cases), judging=Judging(config=args.config), jobs=args.jobs,
                    figures_only=True, requirements=False)
    results, limits = done.results, done.limits
    width = terminal_width()
    print("\n".join(wrap("unit 1 = relative to the case's scale (m·g for forces, m·g·l for energy); a "
                         "budget-gated figure passes when what its budget does not explain is within the limit "
                         "the budget computes, a figure with a fixed limit when it is finite and ≤ it", width,
                         more="")))
    for r in results:  # per figure: its name, unit and what it measures; below, its limit and basis
        print("\n" + "\n".join(wrap(f"{r.case.name} — {r.case.description}", width, more="  ")))
        for f in r.figures:
            lim = limits.limit(r.case.name, f.name)
            gate = ("not gated" if lim is None else lim.describe() if lim.value is None
                    else f"limit {lim.value:.3g}: {lim.describe()}")
            print("\n".join([*wrap(f"{f.name} [{f.unit}]: {f.description}", width, "  ", "  "),
                             *wrap(gate, width, "      ", "  ")]))
    return EXIT_OK


COMMAND = Command("every figure: what it measures, its unit, its limit's basis", _args_figures, cmd_figures,
                  "every figure each case measures: what it measures, its unit, and its limit with the basis (budget, "
                  "theory, or your config); runs the cases as check does")

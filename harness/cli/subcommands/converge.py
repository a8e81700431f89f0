"""``mjharness converge``: convergence orders and constraint studies (layer 4)."""

from __future__ import annotations

import argparse

from harness import cases
from harness.cli.common import EXIT_FAIL, EXIT_OK, Command
from harness.cli.options import add_backend, add_cases, add_html, add_systems
from harness.engine import backends
from harness.outputs.files import check_output, prepare_output, write_atomic

__all__ = ["COMMAND"]


def _args_converge(p: argparse.ArgumentParser) -> None:
    add_cases(p)
    add_systems(p)
    p.add_argument("--fast", action="store_true", help="the 3-timestep subset `check` gates (T ≤ 0.5 s)")
    p.add_argument("--softness", action="store_true", help="also sweep solref/solimp of the equality cases")
    p.add_argument("--solvers", action="store_true", help="also compare Newton, CG and PGS on the constrained cases")
    add_html(p)
    add_backend(p)


def cmd_converge(args: argparse.Namespace) -> int:
    from harness.outputs.studies import draw, html_page, text  # lazy: the studies' plots load matplotlib
    from harness.studies import run_studies  # lazy: only this command runs them

    if args.html is not None:
        check_output(args.html.parent)
    chosen = backends.expand(args.backend)
    if len(chosen) > 1:
        raise ValueError(f"--backend {args.backend}: one backend per run for now ({', '.join(chosen)} asked); "
                         "run once per backend")
    backends.check_installed(chosen[0])  # not installed: one line naming the fix, before any work
    studies = run_studies(cases.select(args.cases), fast=args.fast, with_softness=args.softness,
                          with_solvers=args.solvers, progress=True, engine=backends.get(chosen[0]))
    print(text(studies))
    if args.html is not None:
        prepare_output(args.html.parent)
        write_atomic({args.html: html_page(studies, draw(studies))})
    return EXIT_OK if studies.passed else EXIT_FAIL


COMMAND = Command("convergence orders and constraint studies (layer 4)", _args_converge, cmd_converge,
                  "convergence order per integrator vs the documented one (exit 1 if one falls short); --softness, "
                  "--solvers: constraint studies")

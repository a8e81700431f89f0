"""``mjharness advise``: which integrator and timestep meet your accuracy, verified."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from harness import cases
from harness.cases.own import from_mjcf
from harness.cli.common import EXIT_OK, Command
from harness.cli.options import add_horizon, add_html, add_integrators, add_json, add_model, add_systems
from harness.core.escape import terminal
from harness.core.options import RunOptions
from harness.core.progress import heartbeat
from harness.families import figure_names
from harness.outputs.files import check_output, prepare_output, write_atomic
from harness.outputs.jsondoc import dumps
from harness.pipeline import require
from harness.pipeline.outcome import EXIT_UNFIT

__all__ = ["COMMAND"]


def _args_advise(p: argparse.ArgumentParser) -> None:
    p.add_argument("cases", nargs="?", default=None, metavar="CASE",
                   help="a shipped case (or one of --systems); none with --mjcf: your model against its own tree")
    add_systems(p)
    add_model(p, variant=False)
    p.add_argument("--require", action="append", default=[], metavar="MEASURE=VALUE", required=True,
                   help="the accuracy you need (e.g. position=1e-3,force=1e-2 or drift.energy=1e-4; comma-separated "
                        "or repeated, at least one): the recommendation is the cheapest setting that meets every one, "
                        "verified")
    add_integrators(p)
    add_horizon(p)
    add_json(p)
    add_html(p)
    p.add_argument("--png", type=Path, metavar="FILE", help="also write the plot: error against timestep per "
                                                            "integrator, stability limits, the requirement and "
                                                            "the recommendation")


def cmd_advise(args: argparse.Namespace) -> int:
    from harness.outputs import advice as shown  # lazy: its plot loads matplotlib
    from harness.studies.advice import advise  # lazy: only this command runs it

    for path in (args.html, args.png):
        if path is not None:
            check_output(path.parent)
    requirements = require.parse(args.require)
    if (args.cases is None) == (args.mjcf is None):
        raise ValueError("advise needs one model: a case name, or --mjcf FILE (not both); known cases: "
                         + ", ".join(cases.names()))
    if args.mjcf is None and (args.keyframe or args.ctrl):
        raise ValueError("--keyframe and --ctrl apply to a model judged against its own tree: --mjcf FILE, no case")
    case = from_mjcf(args.mjcf, keyframe=args.keyframe, ctrl=args.ctrl, horizon=args.horizon) \
        if args.mjcf is not None else cases.get(args.cases)
    require.check_possible(requirements, figure_names(case))
    options = RunOptions(horizon=args.horizon if args.mjcf is None else None)
    with heartbeat(f"advise {case.name}"):
        found = advise(case, requirements, options=options, integrators=args.integrators)
    files: dict[Path, str | bytes] = {}
    png = shown.plot(found) if args.png is not None or args.html is not None else b""
    if args.png is not None:
        files[args.png] = png
    if args.html is not None:
        files[args.html] = shown.html_page([found], [png])
    if files:
        for path in files:
            prepare_output(path.parent)
        write_atomic(files)
    if args.json:
        sys.stdout.write(dumps(shown.as_dict(found)))
    else:
        print("\n".join(terminal(line) for line in shown.text(found).split("\n")))
        if files:
            print("wrote " + ", ".join(terminal(str(p)) for p in files))
    return EXIT_OK if found.recommended is not None else EXIT_UNFIT


COMMAND = Command("which integrator and timestep meet your accuracy, verified", _args_advise, cmd_advise,
                  "every integrator's error against the reference over a ladder of timesteps (with error bars), its "
                  "largest stable timestep (the linearization's, confirmed by runs just below and above) and its cost "
                  "on this machine; then the cheapest (integrator, timestep) that meets every --require, verified by "
                  "checking the model at that setting (exit 0), or why none does (exit 3)")

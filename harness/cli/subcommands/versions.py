"""``mjharness versions``: what changed between MuJoCo releases (an environment each)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import NoReturn

from harness import cases
from harness.cli.common import EXIT_FAIL, EXIT_OK, Command, backend_refusals, executor_of
from harness.cli.options import OneLineParser, add_executor, add_jobs, add_out, parse_positive
from harness.cli.subcommands.check import args_check
from harness.engine import backends
from harness.outputs.files import check_output, check_report_folder, prepare_output, with_manifest, write_atomic
from harness.outputs.jsondoc import dumps
from harness.pipeline.pool import cpus

__all__ = ["COMMAND"]


def _args_versions(p: argparse.ArgumentParser) -> None:
    p.add_argument("releases", nargs="+", metavar="RELEASE",
                   help="MuJoCo releases to compare (3.17.0 4.0.0), or a range LO..HI: every release the package "
                        "index offers from LO to HI (3.3.0..4.0.0); 3.3.0 and later")
    p.add_argument("--bisect", metavar="CASE:FIGURE|verdicts",
                   help="find the first release of the range at which this figure moved beyond its noise (or any "
                        "verdict flipped), installing only the releases the bisection needs")
    add_out(p, Path("mjharness-versions"), "versions.html, versions.json and versions.txt")
    p.add_argument("--backend", metavar="NAME",
                   help="install the backend's packages in every environment and run the check with --backend NAME")
    p.add_argument("--with", dest="extras", action="append", default=[], metavar="REQUIREMENT", type=_requirement,
                   help="an extra package for every environment ('{version}' is the MuJoCo release, e.g. "
                        "'mujoco-mjx=={version}'; repeatable)")
    p.add_argument("--parallel", type=parse_positive, metavar="N",
                   help="releases run at once (default: as many as CPUs, here "
                        f"{cpus()}; one with --bisect)")
    add_jobs(p)
    p.add_argument("--no-plots", dest="plots", action="store_false", help="versions.html without the plots")
    add_executor(p)


def _requirement(text: str) -> str:
    """A package requirement for ``uv pip install``: never an option (``-e``, ``--index-url``: it would be taken as
    one, and could install from anywhere)."""
    if not text.strip() or text.lstrip().startswith("-"):
        raise argparse.ArgumentTypeError(f"{text!r} is not a package requirement (it would reach the installer as an "
                                         "option); accepted: a requirement such as 'mujoco-mjx=={version}'")
    return text


def cmd_versions(args: argparse.Namespace) -> int:
    from harness.versions import bisect as bisection  # lazy: only this command builds environments
    from harness.versions import changes_report as report  # lazy: as above
    from harness.versions import envs, releases, session  # lazy: as above
    from harness.versions.runs import CheckCommand, check_environ, noise_runs  # lazy: as above

    check_report_folder(args.out, force=args.force_out)  # before any environment is built
    check_args = list(getattr(args, "check_args", []))
    extras = list(args.extras)
    if args.backend is not None:
        if args.backend not in envs.BACKENDS:
            raise ValueError(f"unknown backend {args.backend!r} for versions; accepted: "
                             f"{', '.join(envs.BACKENDS)} (one backend per run)")
        check_args += ["--backend", args.backend]
    checked = _check_options(check_args)
    target = bisection.parse_target(args.bisect) if args.bisect else None
    if target is not None and target.case is not None:
        cases.select([target.case])  # an unknown case: one line naming the known ones
        if not (checked.cases or checked.case):
            check_args += ["--case", target.case]  # only the case the figure belongs to
    executor = executor_of(args)
    if executor.kind == "ray" and target is not None:
        raise ValueError("--bisect runs one release after another (each depends on the last): use it without "
                         "--executor ray")
    chosen = releases.parse_selection(args.releases)
    refused = backend_refusals(args.backend, chosen)
    added = {r: envs.backend_packages(args.backend, r) for r in chosen if r not in refused} if args.backend else {}
    check_output(args.out)
    parallel = 1 if target is not None else (args.parallel or min(len(chosen), cpus()))
    jobs = args.jobs or max(1, cpus() // parallel)
    root = envs.source_root()
    builder = envs.Builder(uv=envs.find_uv(), root=envs.envs_root(), source=root)
    command = CheckCommand(args=tuple(check_args), jobs=jobs, cwd=Path.cwd(), environ=check_environ())
    digest = envs.source_hash(root)
    noise = noise_runs(backends.PRECISION[args.backend or "c"])  # moves that survive the backend's arithmetic

    def done(run) -> None:
        if sys.stderr.isatty():
            state = "ran" if run.ok else f"failed: {run.error}"
            print(f"MuJoCo {run.release}: {state} ({run.env_seconds + run.check_seconds:.0f} s)", file=sys.stderr)

    if target is not None:
        comparison = session.bisect_releases(builder, chosen, digest, command, target, extras=extras,
                                             pinned=envs.pins(), refused=refused, added=added,
                                             noise=noise, on_done=done)
    else:
        comparison = session.compare_releases(builder, chosen, digest, command, extras=extras, pinned=envs.pins(),
                                              parallel=parallel, refused=refused, added=added,
                                              noise=noise, on_done=done, executor=executor)
    summary = report.text(comparison)
    prepare_output(args.out)
    write_atomic(with_manifest(args.out, {args.out / "versions.txt": summary,
                                          args.out / "versions.json": dumps(report.json_doc(comparison)),
                                          args.out / "versions.html": report.html_page(comparison,
                                                                                       plots=args.plots)}))
    print(summary, end="")
    print(f"wrote {args.out / 'versions.html'}, {args.out / 'versions.json'}, {args.out / 'versions.txt'}")
    stopped = comparison.bisection is not None and comparison.bisection.errors
    return EXIT_FAIL if comparison.errors or stopped else EXIT_OK


def _check_options(check_args: Sequence[str]) -> argparse.Namespace:
    """The check options ``versions`` passes through (after ``--``), parsed as ``check`` parses them here,
    so a mistake is one line before anything is installed."""
    if "--json" in check_args:
        raise ValueError("the check options after -- need no --json: versions always reads the check's JSON")
    if any(a == "--perturb" or a.startswith("--perturb=") for a in check_args):
        raise ValueError("the check options after -- may not set --perturb: versions sets it for the noise runs")
    parser = _CheckOptions(prog="mjharness versions ... --", add_help=False)
    args_check(parser)
    return parser.parse_args(list(check_args))


class _CheckOptions(OneLineParser):
    def error(self, message: str) -> NoReturn:  # raised, not printed: the command's one line names it
        raise ValueError(f"the check options after -- are not ones `mjharness check` takes here: {message}")


COMMAND = Command("what changed between MuJoCo releases (an environment each)", _args_versions, cmd_versions,
                  "run the check in one isolated environment per MuJoCo release (built with uv, cached) and report "
                  "what changed from release to release: verdict flips (known defects included), figures that moved "
                  "beyond their noise, figures that appeared or vanished. Options for the check go after --, e.g. "
                  "mjharness versions 3.17.0 4.0.0 -- --case pendulum --mjcf my.xml, or -- --mjcf robot.xml for a "
                  "model of your own. Exit 1 where a release could not be run.")

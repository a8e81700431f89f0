"""``mjharness sweep``: models × MuJoCo releases × backends: a verdict table."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from harness.cli.common import EXIT_FAIL, EXIT_OK, Command, backend_refusals, executor_of
from harness.cli.options import add_executor, add_integrators, add_jobs, add_out, parse_seconds
from harness.outputs.files import check_output, check_report_folder, prepare_output, with_manifest, write_atomic
from harness.outputs.jsondoc import dumps
from harness.pipeline.pool import cpus

__all__ = ["COMMAND"]


def _args_sweep(p: argparse.ArgumentParser) -> None:
    p.add_argument("models", nargs="+", metavar="MODEL",
                   help="zoo models (dm_control/acrobot, or a stem: acrobot), MJCF files (robot.xml), or shipped "
                        "cases (case:pendulum)")
    p.add_argument("--releases", nargs="+", required=True, metavar="RELEASE",
                   help="MuJoCo releases (3.17.0 4.0.0) or a range LO..HI: every release the package index offers "
                        "from LO to HI (3.3.0..4.0.0); 3.3.0 and later")
    p.add_argument("--backends", type=_backend_list, default=("c",), metavar="NAMES",
                   help="comma-separated backends, each cell run with check --backend NAME (default: c; "
                        "mjx where the index has mujoco-mjx of the release, else the cell is n/a)")
    add_integrators(p)
    p.add_argument("--timeout", type=parse_seconds, metavar="SECONDS",
                   help="stop each cell's check after so long (the cell: error)")
    add_out(p, Path("mjharness-sweep"), "sweep.md and sweep.json")
    add_jobs(p)
    add_executor(p)


def _backend_list(text: str) -> tuple[str, ...]:
    """``c,mjx``: the sweep's backends, each once."""
    from harness.versions import envs  # lazy: only the sweep needs it

    names = tuple(dict.fromkeys(n.strip() for n in text.split(",") if n.strip()))
    unknown = [n for n in names if n not in envs.BACKENDS]
    if unknown or not names:
        raise argparse.ArgumentTypeError(f"unknown backend(s) {', '.join(unknown) or 'none'}; accepted: "
                                         f"{', '.join(envs.BACKENDS)} (comma-separated)")
    return names


def cmd_sweep(args: argparse.Namespace) -> int:
    from harness import zoo  # lazy: only the zoo's commands read the zoo
    from harness.versions import envs, releases, sweep  # lazy: only this command builds environments
    from harness.versions import sweep_report as report  # lazy: as above

    check_report_folder(args.out, force=args.force_out)  # before any environment is built
    executor = executor_of(args)
    models = zoo.sweep_models(args.models)
    chosen = releases.parse_selection(args.releases)
    refused = {(r, b): why for b in args.backends for r, why in backend_refusals(b, chosen, every=True).items()}
    check_output(args.out)
    root = envs.source_root()
    builder = envs.Builder(uv=envs.find_uv(), root=envs.envs_root(), source=root)
    shipped = envs.Shipped.of(builder, envs.source_hash(root))  # built once here, carried by every task
    tasks = sweep.plan(models, chosen, args.backends, shipped=shipped, root=envs.envs_root(), pinned=envs.pins(),
                       packages=lambda b, r: envs.backend_packages(b, r), refused=refused,
                       integrators=args.integrators or (), timeout=args.timeout)
    command = " ".join(["mjharness", *sys.argv[1:]]) if sys.argv[1:2] == ["sweep"] else "mjharness sweep"
    result = sweep.run(tasks, workers=args.jobs or cpus(), executor=executor, command=command,
                       on_done=lambda cell: print(cell.line(), flush=True))
    prepare_output(args.out)
    paths = write_atomic(with_manifest(args.out, {args.out / "sweep.md": report.markdown(result),
                                                  args.out / "sweep.json": dumps(report.json_doc(result))}))
    print(report.text(result) + f"wrote {', '.join(str(p) for p in paths)}", flush=True)
    return EXIT_FAIL if result.errors else EXIT_OK


COMMAND = Command("models × MuJoCo releases × backends: a verdict table", _args_sweep, cmd_sweep,
                  "run check on every model (zoo names, MJCF files, case:NAME) in every MuJoCo release's own "
                  "environment on every backend, one task per cell (--executor ray: a Ray task each), and write "
                  "sweep.md and sweep.json: per model a row per backend of verdicts by release, with the first release "
                  "at which the verdict, and at which a figure (bit for bit), changed. Exit 1 where a cell could not "
                  "be run (its line names the model, release and backend)")

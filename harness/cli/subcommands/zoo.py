"""``mjharness zoo``: models nobody here wrote, each against its own tree."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from harness.cli.common import Command, executor_of
from harness.cli.options import add_executor, add_integrators, add_jobs, add_out, parse_positive, parse_seconds
from harness.outputs.files import check_report_folder, prepare_output, with_manifest, write_atomic
from harness.outputs.jsondoc import dumps
from harness.pipeline.pool import cpus

__all__ = ["COMMAND"]


def _args_zoo(p: argparse.ArgumentParser) -> None:
    p.add_argument("models", nargs="*", metavar="MODEL",
                   help="zoo models (dm_control/acrobot, or a stem: acrobot; default: every model installed); "
                        "with --folder, that folder's entries (robot/scene, or a stem)")
    p.add_argument("--folder", type=Path, metavar="DIR",
                   help="judge every MJCF entry of DIR instead, a folder of robots laid out like MuJoCo Menagerie's: "
                        "every .xml file under it whose root is <mujoco> and that no other <include>s (scene.xml, "
                        "not the robot.xml it includes)")
    add_out(p, Path("reports/zoo"), "zoo.md and zoo.json")
    p.add_argument("--faults", action="store_true",
                   help="also find the smallest size of each engine-side fault (inertia, damping, axis tilt) caught")
    p.add_argument("--injection", action="store_true",
                   help="also find the smallest energy injection (energy from no force) each model's balance catches")
    p.add_argument("--fault-max-nv", type=parse_positive, metavar="N",
                   help="size the faults and injections on models of ≤ N dofs only")
    add_integrators(p)
    p.add_argument("--timeout", type=parse_seconds, metavar="SECONDS",
                   help="stop each model's verdict, and each model's fault study, after so long (unfinished)")
    add_jobs(p)
    add_executor(p)


def cmd_zoo(args: argparse.Namespace) -> int:
    from harness import zoo  # lazy: only this command reads the zoo
    from harness.outputs.studies.engine_faults import cell as fault_cell  # lazy: as above
    from harness.outputs.studies.injection import cell as injection_cell  # lazy: as above

    check_report_folder(args.out, force=args.force_out)
    if args.folder is not None:
        models, passed = zoo.folder_models(args.folder)
        skipped: tuple = ()
        for line in passed:
            print(f"passed over: {line}", flush=True)
    else:
        models, skipped = zoo.discover()
    chosen = zoo.select(args.models, models, skipped)
    for s in skipped:
        print(f"skipped: {s.line()}", flush=True)
    if not chosen:
        raise ValueError("no zoo model is installed; " + "; ".join(s.pip for s in skipped))

    def done(result) -> None:  # one line per model (and per model's faults) as it ends, terminal or not
        if isinstance(result, zoo.ZooResult):
            lines = [result.line()]
        elif isinstance(result, zoo.Injection):
            lines = [f"{result.model}: injection on {result.joint or '-'}: {injection_cell(result)}"]
        elif all(c.size is None and not c.crashed and not c.unfinished for c in result):  # refused: no fault to size
            lines = [f"{result[0].model}: faults n/a ({result[0].note})"]
        else:
            lines = [f"{c.model}: fault {c.fault} on {c.target}: {fault_cell(c)}" for c in result]
        print("\n".join(lines), flush=True)

    run = zoo.run(chosen, jobs=args.jobs or cpus(), integrators=args.integrators, faults=args.faults,
                  fault_max_nv=args.fault_max_nv, injection=args.injection, skipped=skipped, on_done=done,
                  timeout=args.timeout, executor=executor_of(args), found=args.folder is None,
                  command=" ".join(["mjharness", *sys.argv[1:]]) if sys.argv[1:2] == ["zoo"] else "mjharness zoo")
    prepare_output(args.out)
    paths = write_atomic(with_manifest(args.out, {args.out / "zoo.md": zoo.zoo_markdown(run),
                                                  args.out / "zoo.json": dumps(zoo.zoo_json(run))}))
    short = run.faults_short()
    print(f"{len(run.results)} models in {run.seconds:.0f} s: "
          + ", ".join(f"{sum(r.verdict == v for r in run.results)} {v}"
                      for v in ("pass", "fail", "refused", "crashed", "unfinished"))
          + "".join(f"; fault {f} {why}" for f, why in short.items())
          + f"; wrote {', '.join(str(p) for p in paths)}")
    return run.exit_code


COMMAND = Command("models nobody here wrote, each against its own tree", _args_zoo, cmd_zoo,
                  "judge every MuJoCo model that the installed dm_control and Gymnasium ship (pip install "
                  "'mjharness[zoo]') as check --mjcf FILE does, one line per model as it ends, and write zoo.md and "
                  "zoo.json; --faults also sizes engine-side faults. A failing model is a finding about the model or "
                  "MuJoCo, in the report: exit 0 when every model ran to a verdict (pass, finding or refusal) and each "
                  "fault is caught on at least 3 models, 1 when a fault is caught on fewer or a model stopped at "
                  "--timeout, 2 when a model crashed (a bug of the harness) or on bad input")

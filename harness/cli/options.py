"""The options several commands take, each declared here once, the types that read their values, and the parser
class that makes argparse's errors one line (exit 2)."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import NoReturn

from harness.cases import sources
from harness.cli.common import EXIT_USAGE
from harness.engine import backends
from harness.engine.integrators import available_integrators
from harness.outputs.files import FORCE
from harness.pipeline.executor import EXECUTORS
from harness.pipeline.pool import cpus

__all__ = ["OneLineParser", "add_backend", "add_cases", "add_config", "add_executor", "add_horizon", "add_html",
           "add_integrators", "add_jobs", "add_json", "add_junit", "add_model", "add_out", "add_quiet",
           "add_run_options", "add_selection", "add_systems", "parse_number", "parse_positive", "parse_seconds"]


class OneLineParser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # one line, exit 2 (argparse's own code)
        self.exit(EXIT_USAGE, f"mjharness: error: {message}\n")


def add_quiet(p: argparse.ArgumentParser) -> None:
    g = p.add_mutually_exclusive_group()
    g.add_argument("--quiet", "-q", action="store_true", help="print the failures and the verdict line only")
    g.add_argument("--verbose", "-v", action="store_true",
                   help="also print every check as a table: its figure, budget parts, limit and verdict")


def add_run_options(p: argparse.ArgumentParser) -> None:
    """How the cases run and what decides the exit code (run, check)."""
    g = p.add_argument_group("how the cases run (default: as shipped)")
    g.add_argument("--timestep", type=parse_seconds, metavar="SECONDS", help="run every model at this timestep")
    add_horizon(g)
    add_integrators(g)
    g.add_argument("--q0", type=_state, metavar="NAME=VALUE,...",
                   help="initial coordinates (the case's names; needs one case); the rest as the case has them, "
                        "then brought onto the constraints")
    g.add_argument("--qd0", type=_state, metavar="NAME=VALUE,...", help="initial velocities, as --q0")
    add_backend(g)
    g = p.add_argument_group("a second opinion on the model (needs pip install 'mjharness[pin]')")
    g.add_argument("--urdf", type=Path, metavar="FILE",
                   help="the robot's URDF, compared with the MJCF (--mjcf, or the one case's) body by body and joint "
                        "by joint: mass, centre of mass, inertia, axes, limits, M(q) and gravity torques; a "
                        "difference over tolerance fails (exit 1)")
    g.add_argument("--urdf-map", type=Path, metavar="FILE",
                   help='TOML renaming the URDF\'s names to the MJCF\'s: [bodies] link = "body", [joints] a = "b"')
    g = p.add_argument_group("verdict")
    g.add_argument("--require", action="append", default=[], metavar="MEASURE=VALUE",
                   help="the accuracy you need, judged on each model's own integrator (e.g. "
                        "position=1e-3,drift.energy=1e-4 or force=1e-3; comma-separated or repeated): exit 3 where "
                        "the checks pass and it is not met")
    g.add_argument("--accept-known-defects", action="store_true",
                   help="let a failure that shows the signature of a documented defect of this MuJoCo (shown as "
                        "FAIL, known defect) not fail the exit code")


def add_backend(g) -> None:
    g.add_argument("--backend", type=_backend, default="c", metavar="|".join([*backends.BACKENDS, "all"]),
                   help="the engine every run goes to (default c: MuJoCo's C engine; mjx float32 and mjx-f64 need "
                        "pip install 'mjharness[mjx]')")


def _backend(text: str) -> str:
    try:
        backends.expand(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def parse_number(text: str) -> float:
    """``text`` as a float; nan where it is none (the caller's range check then refuses it)."""
    try:
        return float(text)
    except ValueError:
        return math.nan


def parse_seconds(text: str) -> float:
    value = parse_number(text)
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a positive number of seconds, got {text!r}")
    return value


def _folder(text: str) -> Path:
    """A folder argument: an empty one names no folder (it would mean the current one, silently)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("names no folder (an empty path would mean the current folder); give a "
                                         "folder, e.g. mjharness-report")
    return Path(text)


def _names(text: str) -> tuple[str, ...]:
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    unknown = [n for n in names if n not in available_integrators()]
    if not names or unknown:
        raise argparse.ArgumentTypeError(f"unknown integrator(s) {', '.join(unknown) or repr(text)}; this MuJoCo "
                                         f"offers {', '.join(available_integrators())}")
    return names


def _state(text: str) -> dict[str, float]:
    out = {}
    for item in text.split(","):
        name, sep, value = item.partition("=")
        number = parse_number(value)
        if not sep or not name.strip() or not math.isfinite(number):
            raise argparse.ArgumentTypeError(f"expected NAME=VALUE,... with finite numbers, got {item!r}")
        out[name.strip()] = number
    return out


def add_systems(p: argparse.ArgumentParser) -> None:
    p.add_argument("--systems", action="append", type=_systems_directory, metavar="DIR",
                   help="also discover the cases of your own systems in DIR: NAME.py (the analytic system), "
                        "NAME.xml (its MJCF), NAME.limits.toml (repeatable; installed packages' come through the "
                        f"entry point group {sources.GROUP})")


def _systems_directory(text: str) -> Path:
    try:
        sources.directory_source(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return Path(text)


def add_selection(p: argparse.ArgumentParser, *, mjcf: bool = True) -> None:
    add_cases(p)
    p.add_argument("--case", action="append", metavar="NAME", help="a case name (same as CASE; repeatable)")
    add_systems(p)
    add_config(p)
    add_jobs(p)
    if mjcf:
        add_model(p)


def add_cases(p: argparse.ArgumentParser) -> None:
    """The cases named on the command line, positionally (``args.cases``)."""
    p.add_argument("cases", nargs="*", metavar="CASE", help="case names (default: all)")


def add_config(p: argparse.ArgumentParser) -> None:
    p.add_argument("--config", type=Path, metavar="FILE",
                   help="TOML: limits of your own ([thresholds.CASE] \"FIGURE\" = LIMIT, over the shipped ones: "
                        "basis 'user'), requirements ([require] QUANTITY = SIZE) and accept_known_defects = true")


def add_jobs(p: argparse.ArgumentParser) -> None:
    """--jobs: how many worker processes share a command's runs on this machine (cases, tasks, cells, a release's
    check), each command's work shared among them."""
    p.add_argument("--jobs", "-j", type=parse_positive, metavar="N",
                   help=f"worker processes (default: one per CPU, here {cpus()}, shared by what runs at once); "
                        "the results do not depend on N")


def add_model(p: argparse.ArgumentParser, *, variant: bool = True) -> None:
    """--mjcf, --keyframe and --ctrl: a model of one's own; ``variant``: with one case, a variant of its model."""
    p.add_argument("--mjcf", type=Path, metavar="PATH",
                   help="validate this MJCF: with no case, any model against its own kinematic tree" + (
                        "; with one case, your variant of that case's model against the case's reference and limits"
                        if variant else ""))
    p.add_argument("--keyframe", metavar="NAME", help="with --mjcf and no case: start at this keyframe "
                                                      "(default: qpos0, every joint set moving)")
    p.add_argument("--ctrl", type=_state, metavar="NAME=VALUE,...",
                   help="with --mjcf and no case: actuator controls by name (default: the keyframe's, else 0)")


def add_horizon(p: argparse.ArgumentParser | argparse._ArgumentGroup) -> None:
    p.add_argument("--horizon", type=parse_seconds, metavar="SECONDS", help="simulate this long (default: the case's)")


def add_integrators(p: argparse.ArgumentParser | argparse._ArgumentGroup) -> None:
    p.add_argument("--integrators", type=_names, metavar="NAMES",
                   help=f"run only these, comma-separated (default: every one: {', '.join(available_integrators())})")


def add_json(p: argparse.ArgumentParser) -> None:
    p.add_argument("--json", action="store_true", help="print the outcome as JSON instead of the text")


def add_html(p: argparse.ArgumentParser) -> None:
    p.add_argument("--html", type=Path, metavar="FILE", help="also write the text and the plots as one HTML page")


def add_executor(p: argparse.ArgumentParser) -> None:
    p.add_argument("--executor", choices=EXECUTORS, default="local",
                   help="where the runs go: local (worker processes on this machine, the default) or ray (a Ray "
                        "task each, pip install 'mjharness[ray]'); the results do not depend on it")
    p.add_argument("--ray-address", metavar="HOST:PORT",
                   help="with --executor ray: the cluster to use (default: $RAY_ADDRESS, else a local cluster "
                        "started and stopped by this command)")


def parse_positive(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text!r}")
    return value


def add_junit(p: argparse.ArgumentParser) -> None:
    p.add_argument("--junit", type=Path, metavar="FILE", help="also write JUnit XML (one testcase per check)")


def add_out(p: argparse.ArgumentParser, default: Path, what: str) -> None:
    """--out and --force-out, as every command that writes a folder of files takes them: a new or empty folder, or
    one an earlier run wrote (its manifest: :func:`harness.outputs.files.check_report_folder`)."""
    p.add_argument("--out", type=_folder, default=default, metavar="DIR",
                   help=f"where to write {what} (default: ./{default}); a new or empty folder, or one an earlier "
                   "mjharness run wrote: only the files it wrote there (its manifest) are replaced or removed")
    p.add_argument(FORCE, dest="force_out", action="store_true",
                   help="write into --out even if it is not yours or holds other files (those are never removed; "
                   "a file of the output's own name is replaced)")

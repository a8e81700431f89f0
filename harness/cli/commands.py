"""``mjharness``: the command table, the parser, and every error turned into one line and an exit code.

Exit codes (:data:`~harness.cli.common.EXIT_CODES`, printed by ``--help`` and a bare ``mjharness``): 0 all checks
pass, 1 a check fails (a run that diverged fails its checks with the reason; for ``baseline --compare``, a
figure regressed), 2 bad usage or input (unknown case, invalid MJCF or config, a model that does not
fit its case, unwritable output). User mistakes give one line on stderr, never a traceback, and never a
half-written file; so does a bug of ours (an unexpected exception: "internal error", exit 2, with the hint
to report it); a numerical failure of our own solvers (a singular linear solve, a reference solve that cannot
go on) is neither: one line, exit 4. ``diff`` is informational: 0 unless its input is bad (2). A command whose stdout is
closed (``| head -1``) stops quietly with 141 (128 + SIGPIPE); one interrupted exits 130 (Ctrl-C) or
143 (SIGTERM), and marks stale the report files it would have written.

Each subcommand is a module of :mod:`harness.cli.subcommands` exposing its ``COMMAND``: a function adding its
arguments and a ``cmd_NAME(args) -> int`` doing the work; :data:`COMMANDS` lists them in the order ``--help``
shows. The commands that draw (``run``, ``converge``, ``audit``) import the report and studies, which load
matplotlib and sympy, when they run; the gate (``check``) never loads them.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import signal
import sys
import textwrap
import traceback
import warnings
from collections.abc import Sequence
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

from numpy.linalg import LinAlgError

from analytic.dop853 import IntegrationError
from analytic.solvers import TooManySteps
from harness.cases import sources
from harness.cli.common import EXIT_CODES, EXIT_NUMERIC, EXIT_USAGE, Command
from harness.cli.options import OneLineParser
from harness.cli.subcommands import (
    advise,
    audit,
    baseline,
    check,
    converge,
    diff,
    faults,
    figures,
    limits,
    run,
    sensitivity,
    sweep,
    versions,
    zoo,
)
from harness.cli.subcommands import list as list_  # the command's name; `list` stays the builtin
from harness.core import VERSION
from harness.core.errors import SimulationDiverged
from harness.core.escape import terminal
from harness.core.lifetime import Terminated, exit_code, sigterm_as_interrupt
from harness.engine import messages
from harness.outputs.files import STALE, mark_stale, ours
from harness.pipeline.executor import TaskLost

__all__ = ["COMMANDS", "main"]

INTERRUPTED = (128 + signal.SIGINT, 128 + signal.SIGTERM)  # Ctrl-C, SIGTERM
EXIT_PIPE = 128 + signal.SIGPIPE  # stdout's reader went away: what a shell reports for a tool SIGPIPE stopped
TRACEBACK_VARIABLE = "MJHARNESS_TRACEBACK"  # set to 1: an internal error prints its traceback after its line


COMMANDS: dict[str, Command] = {
    "list": list_.COMMAND,
    "run": run.COMMAND,
    "check": check.COMMAND,
    "figures": figures.COMMAND,
    "diff": diff.COMMAND,
    "versions": versions.COMMAND,
    "sweep": sweep.COMMAND,
    "baseline": baseline.COMMAND,
    "limits": limits.COMMAND,
    "converge": converge.COMMAND,
    "faults": faults.COMMAND,
    "sensitivity": sensitivity.COMMAND,
    "zoo": zoo.COMMAND,
    "advise": advise.COMMAND,
    "audit": audit.COMMAND,
}


def _exit_codes_text() -> str:
    return "exit codes:\n" + "\n".join(textwrap.fill(text, width=96, initial_indent=f"  {code}  ",
                                                      subsequent_indent=" " * 5) for code, text in EXIT_CODES.items())


class _Help(argparse.RawDescriptionHelpFormatter):
    """argparse's help with the commands listed one a line, without the ``{list,run,...}`` line above them."""

    def _format_action(self, action: argparse.Action) -> str:
        if isinstance(action, argparse._SubParsersAction):
            return "".join(self._format_action(a) for a in action._get_subactions())
        return super()._format_action(action)


def _parser() -> argparse.ArgumentParser:
    p = OneLineParser(prog="mjharness", description="Validate MuJoCo against analytical mechanics.",
                epilog=_exit_codes_text() + "\n\n'mjharness COMMAND --help' gives each command's options.",
                formatter_class=_Help)
    p.add_argument("--version", action="version", version=_version())
    sub = p.add_subparsers(dest="command", required=True, parser_class=OneLineParser, title="commands",
                           metavar="COMMAND")
    for name, command in COMMANDS.items():
        command.add_arguments(sub.add_parser(name, help=command.help, description=command.description
                                             or command.help))
    return p


def _version() -> str:
    import mujoco  # lazy: already imported by harness.cases; named here for its version

    return f"mjharness {VERSION} (MuJoCo {mujoco.__version__}, Python {sys.version.split()[0]})"


def _discard_stdout() -> None:
    """Send what is left of stdout (Python's buffer, written at exit) to /dev/null: its reader is gone."""
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):  # not a file (captured, replaced)
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, fd)
    os.close(devnull)


def _outputs(args: argparse.Namespace) -> list[Path]:
    """The report files the command writes: those a failed or interrupted run marks stale."""
    # run: only the files an earlier run wrote into --out, unchanged since (nothing of the user's is renamed)
    paths = [p for p in ours(args.out) if not p.name.endswith(STALE)] if args.command == "run" else []
    return paths + [p for p in (getattr(args, "junit", None), getattr(args, "html", None)) if p is not None]


def main(argv: Sequence[str] | None = None) -> int:
    parser = _parser()
    if not (sys.argv[1:] if argv is None else list(argv)):  # a bare `mjharness`: what it can do
        parser.print_help()
        return EXIT_USAGE
    argv = list(sys.argv[1:] if argv is None else argv)
    check_args: list[str] = []
    if argv[0] == "versions" and "--" in argv:  # the check's own options, passed through as given
        cut = argv.index("--")
        argv, check_args = argv[:cut], argv[cut + 1:]
    args = parser.parse_args(argv)
    args.check_args = check_args
    messages.keep()  # MuJoCo's own warnings: read from its counters, never printed before our one line
    with warnings.catch_warnings():  # nor Python's: a MuJoCo fallback is in the run's settings ("compat")
        warnings.simplefilter("ignore")
        code = _main(args)
    if code == EXIT_USAGE or code in INTERRUPTED:  # no earlier report may pass for this run's
        mark_stale(_outputs(args))
    return code


def _main(args: argparse.Namespace) -> int:
    """The command, its errors as one line on stderr and their exit code."""
    try:
        with sigterm_as_interrupt():
            sources.use(getattr(args, "systems", None) or ())  # the cases of --systems DIR, discovered as the others
            code = COMMANDS[args.command].run(args)
            sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's exit
            return code
    except BrokenPipeError:  # the reader went away (`| head -1`): stop quietly, as Unix tools do
        _discard_stdout()
        return EXIT_PIPE
    except BrokenProcessPool:  # a worker killed under it (the system's out-of-memory killer, a crash)
        _error("mjharness: error: a worker process died while running the cases (killed by the system: out of "
              "memory?); fix: fewer workers (-j 1) or fewer cases at once")
    except TaskLost as exc:  # a Ray task the cluster could not run (harness.pipeline.cluster)
        _error(f"mjharness: error: {exc}; fix: check the cluster's nodes, or run with --executor local")
    except SimulationDiverged as exc:
        _error(f"mjharness: error: simulation diverged: {exc}")
    except TooManySteps as exc:  # a bound passed: refused up front, with the estimate
        _error(f"mjharness: error: the reference cannot be computed for this model: {exc}")
    except (IntegrationError, LinAlgError) as exc:  # our own solvers failed (LinAlgError is a ValueError: first)
        _error(f"mjharness: internal failure: a numerical solve of the harness failed: {type(exc).__name__}: "
               f"{' '.join(str(exc).split())} (not your input; {TRACEBACK_VARIABLE}=1 prints the traceback)")
        if os.environ.get(TRACEBACK_VARIABLE, "").strip() not in ("", "0"):
            traceback.print_exc()
        return EXIT_NUMERIC
    except ValueError as exc:  # ConfigError, ModelError, ModelMismatch and every input check
        _error(f"mjharness: error: {' '.join(str(exc).split())}")
    except OSError as exc:
        _error(f"mjharness: error: {exc.strerror or exc}: {exc.filename or ''}".rstrip(": "))
    except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM (harness.core.lifetime.Terminated)
        _error("mjharness: terminated (SIGTERM)" if isinstance(exc, Terminated) else "mjharness: interrupted")
        return exit_code(exc)
    except MemoryError:
        _error("mjharness: error: out of memory; fix: a longer --timestep, a shorter --horizon, fewer cases or "
              "workers (-j 1)")
    except Exception as exc:  # a bug of ours: still one line, and no report passes for the run
        _error(f"mjharness: internal error: {type(exc).__name__}: {' '.join(str(exc).split())} (a bug in mjharness, "
              f"not in your input: please report it with the command line; {TRACEBACK_VARIABLE}=1 prints the "
              "traceback)")
        if os.environ.get(TRACEBACK_VARIABLE, "").strip() not in ("", "0"):
            traceback.print_exc()
    finally:
        _disconnect()
    return EXIT_USAGE


def _error(line: str) -> None:
    """An error line on stderr, its names from files, models and the command line made visible
    (:func:`harness.core.escape.terminal`: an ESC or BEL in a name never reaches the terminal as such)."""
    print(terminal(line), file=sys.stderr)


def _disconnect() -> None:
    """Leave the Ray cluster a command used (a local one it started stops): the command exits without the
    interpreter's teardown (:func:`harness.cli.entry.exit_now`), which would otherwise do it."""
    cluster = sys.modules.get("harness.pipeline.cluster")
    if cluster is not None:
        with contextlib.suppress(Exception):  # the run's own outcome stands whatever the disconnection says
            cluster.shutdown()


if __name__ == "__main__":  # the command itself is harness.cli.entry:entry (python -m harness.cli.entry)
    sys.exit(main())

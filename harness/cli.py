"""``mjharness``: a thin argparse layer over pure functions.

Exit codes: 0 all checks pass, 1 a check fails (or, for ``baseline
--compare``, a figure regressed), 2 bad usage or input (unknown case, invalid
MJCF or config, a model that does not fit its case, unwritable output,
diverging simulation). User mistakes give one line on stderr, never a
traceback, and never a half-written file. ``diff`` is informational: 0 unless
its input is bad (2).

Each subcommand is one entry in ``COMMANDS``: a function adding its arguments
and a ``cmd_NAME(args) -> int`` doing the work.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from harness import cases, runner
from harness.pool import cpus
from harness.simulate import SimulationDiverged
from harness.verdict import Check

EXIT_OK, EXIT_FAIL, EXIT_USAGE = 0, 1, 2


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2 (argparse's own code)
        self.exit(EXIT_USAGE, f"mjharness: error: {message}\n")


# --------------------------------------------------------------- helpers
def _selected(args: argparse.Namespace) -> tuple[cases.Case, ...]:
    """Cases named positionally or with --case (all when none); --mjcf needs exactly one."""
    names = [*args.cases, *(args.case or [])]
    selected = cases.select(names)
    if getattr(args, "mjcf", None) is not None and len(selected) != 1:
        raise ValueError(f"--mjcf validates one model against one case; name it with --case NAME "
                         f"(known cases: {', '.join(cases.names())})")
    return selected


def _table(checks: dict[str, list[Check]]) -> str:
    from harness.report import ratio, ratio_text

    rows = [(c.case, c.name, f"{c.value:.3e}", f"{c.threshold:.3e}", c.unit, ratio_text(ratio(c)),
             f"{c.status}: {c.note or c.known}" if c.note or c.known else c.status)
            for cs in checks.values() for c in cs]
    header = ("case", "check", "figure", "threshold", "unit", "used", "verdict")
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    lines = ["  ".join(v.ljust(w) for v, w in zip(r, widths, strict=True)).rstrip() for r in [header, *rows]]
    failed = sum(not c.passed for cs in checks.values() for c in cs)
    total = sum(len(cs) for cs in checks.values())
    na = sum(bool(c.note) for cs in checks.values() for c in cs)
    known = sum(bool(c.known) for cs in checks.values() for c in cs)
    lines.append(f"{total - failed - na - known} passed, {failed} failed"
                 + (f", {na} n/a (not in this MuJoCo)" if na else "")
                 + (f", {known} known defect(s) of this MuJoCo" if known else ""))
    return "\n".join(lines)


def _exit(checks: dict[str, list[Check]]) -> int:
    return EXIT_OK if all(c.passed for cs in checks.values() for c in cs) else EXIT_FAIL


def _add_selection(p: argparse.ArgumentParser, *, mjcf: bool = True) -> None:
    p.add_argument("cases", nargs="*", metavar="CASE", help="case names (default: all)")
    p.add_argument("--case", action="append", metavar="NAME", help="a case name (same as CASE; repeatable)")
    p.add_argument("--config", type=Path, metavar="FILE", help="TOML overriding [tool.mjharness] thresholds")
    p.add_argument("--jobs", "-j", type=_positive, metavar="N",
                   help=f"worker processes for the cases (default: one per CPU, here {cpus()}); "
                        "the results do not depend on N")
    if mjcf:
        p.add_argument("--mjcf", type=Path, metavar="PATH",
                       help="validate this MJCF (your variant of the case's model) against the case's "
                            "reference and thresholds; needs exactly one case")


def _positive(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text!r}")
    return value


# ----------------------------------------------------------- subcommands
def _args_list(p: argparse.ArgumentParser) -> None:
    pass


def cmd_list(args: argparse.Namespace) -> int:
    tags = {c.name: f"[{','.join(sorted(c.tags))}]" for c in cases.CASES}
    width, tag_width = max(map(len, tags)), max(map(len, tags.values()))
    for c in cases.CASES:
        print(f"{c.name.ljust(width)}  {tags[c.name].ljust(tag_width)}  {c.description}")
    return EXIT_OK


def _add_junit(p: argparse.ArgumentParser) -> None:
    p.add_argument("--junit", type=Path, metavar="FILE", help="also write JUnit XML (one testcase per check)")


def _check_junit(path: Path | None) -> None:
    """Refuse an unusable --junit path before any work is done."""
    from harness.report import check_output

    if path is not None:
        if path.is_dir():
            raise ValueError(f"--junit {str(path)!r} is a directory; give a file name")
        check_output(path.parent)


def _write_junit(path: Path | None, checks: dict[str, list[Check]]) -> list[Path]:
    if path is None:
        return []
    from harness.junit import junit_xml
    from harness.report import prepare_output, write_atomic

    prepare_output(path.parent)
    return write_atomic({path: junit_xml(checks)})


def _args_run(p: argparse.ArgumentParser) -> None:
    _add_selection(p)
    p.add_argument("--out", type=Path, default=Path("mjharness-report"), metavar="DIR",
                   help="output directory (default: ./mjharness-report)")
    p.add_argument("--no-studies", dest="studies", action="store_false",
                   help="skip layer 4 (convergence, softness, solver and contact studies) and the seed audit")
    _add_junit(p)


def cmd_run(args: argparse.Namespace) -> int:
    from harness.report import check_output, write_report

    start = time.perf_counter()
    check_output(args.out)  # fail before minutes of work, not after
    _check_junit(args.junit)
    selected = _selected(args)
    results, checks, config = runner.run_all(selected, args.config, args.mjcf, jobs=args.jobs)
    extras, appendix, plots = runner.report_parts(selected, results, jobs=args.jobs,
                                            studies=args.studies and args.mjcf is None)
    paths = write_report(args.out, results, checks, config_source=config.source, extras=extras,
                         appendix=appendix, plots=plots)
    paths += _write_junit(args.junit, checks)
    print(_table(checks))
    print(f"wrote {', '.join(str(p) for p in paths)} in {time.perf_counter() - start:.1f} s")
    return _exit(checks)


def _args_check(p: argparse.ArgumentParser) -> None:
    _add_selection(p)
    _add_junit(p)
    p.add_argument("--json", action="store_true", help="print the run as JSON (report.json schema) "
                                                       "instead of the table")


def cmd_check(args: argparse.Namespace) -> int:
    from harness.report import dumps, json_doc

    _check_junit(args.junit)
    results, checks, _ = runner.run_all(_selected(args), args.config, args.mjcf, jobs=args.jobs,
                                        figures_only=True)
    _write_junit(args.junit, checks)
    if args.json:
        sys.stdout.write(dumps(json_doc(results, checks)))
    else:
        print(_table(checks))
    return _exit(checks)


def _args_diff(p: argparse.ArgumentParser) -> None:
    p.add_argument("old", type=Path, metavar="OLD.json", help="report.json (or baseline, or check --json) before")
    p.add_argument("new", type=Path, metavar="NEW.json", help="the same after")
    p.add_argument("--all", action="store_true", help="list unchanged figures too")


def cmd_diff(args: argparse.Namespace) -> int:
    from harness.diff import diff_runs, format_diff, load_run

    old, new = load_run(args.old), load_run(args.new)
    print(format_diff(diff_runs(old, new), show_all=args.all), end="")
    return EXIT_OK


def _args_baseline(p: argparse.ArgumentParser) -> None:
    _add_selection(p, mjcf=False)
    mode = p.add_mutually_exclusive_group(required=True)
    mode.add_argument("--write", type=Path, metavar="FILE",
                      help="run the cases and write their gated figures (naming cases updates only those)")
    mode.add_argument("--compare", type=Path, metavar="FILE",
                      help="run the cases and fail (exit 1) where a figure regressed against FILE")


def cmd_baseline(args: argparse.Namespace) -> int:
    from harness import baseline
    from harness.diff import load_run
    from harness.report import check_output, dumps, prepare_output, write_atomic

    selected = _selected(args)
    if args.write is not None:
        check_output(args.write.parent)
        old = load_run(args.write) if args.write.exists() and (args.cases or args.case) else None
        results, checks, _ = runner.run_all(selected, args.config, jobs=args.jobs, figures_only=True)
        failing = [c for cs in checks.values() for c in cs if not c.passed]
        if failing:
            print(_table(checks))
            print(f"mjharness: refusing to write a baseline while {len(failing)} check(s) fail", file=sys.stderr)
            return EXIT_FAIL
        doc = baseline.merge(old, baseline.baseline_doc(results, checks))
        prepare_output(args.write.parent)
        write_atomic({args.write: dumps(doc)})
        count = sum(len(c["figures"]) for c in doc["cases"].values())
        print(f"wrote {args.write}: {len(doc['cases'])} case(s), {count} gated figures")
        return EXIT_OK
    reference = load_run(args.compare)
    mismatch = baseline.version_mismatch(reference, source=str(args.compare))
    if mismatch:  # a baseline is per MuJoCo version: refuse before any work
        raise ValueError(mismatch)
    results, checks, config = runner.run_all(selected, args.config, jobs=args.jobs, figures_only=True)
    findings = [f for r in results for f in baseline.compare(
        reference, r.case.name, r.figures, config.for_case(r.case.name), source=str(args.compare))]
    for f in findings:
        print(f.message)
    print(f"{len(findings)} regression(s) or missing entries against {args.compare} "
          f"(rule: new > {baseline.FACTOR:g} × max(old, {baseline.FLOOR:g} × threshold))")
    return EXIT_FAIL if findings else EXIT_OK


def _args_converge(p: argparse.ArgumentParser) -> None:
    p.add_argument("cases", nargs="*", metavar="CASE", help="case names (default: all)")
    p.add_argument("--fast", action="store_true", help="the 3-timestep subset `check` gates (T ≤ 0.5 s)")
    p.add_argument("--softness", action="store_true", help="also sweep solref/solimp of the equality cases")
    p.add_argument("--solvers", action="store_true", help="also compare Newton, CG and PGS on the constrained cases")
    p.add_argument("--html", type=Path, metavar="FILE", help="also write the tables and plots as one HTML page")


def cmd_converge(args: argparse.Namespace) -> int:
    from harness.report import check_output, prepare_output, write_atomic
    from harness.studies import html_page, run_studies, text

    if args.html is not None:
        check_output(args.html.parent)
    studies = run_studies(cases.select(args.cases), fast=args.fast, with_softness=args.softness,
                          with_solvers=args.solvers, progress=True)
    print(text(studies))
    if args.html is not None:
        prepare_output(args.html.parent)
        write_atomic({args.html: html_page(studies)})
    return EXIT_OK if studies.passed else EXIT_FAIL


def _args_audit(p: argparse.ArgumentParser) -> None:
    p.add_argument("--json", action="store_true", help="print the verdicts as JSON instead of the table")


def cmd_audit(args: argparse.Namespace) -> int:
    from harness import audit
    from harness.report import dumps

    rows = audit.audit()
    if args.json:
        sys.stdout.write(dumps(audit.json_rows(rows)))
    else:
        print(audit.format_table(rows))
    return EXIT_OK


@dataclass(frozen=True)
class Command:
    help: str
    add_arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], int]


COMMANDS: dict[str, Command] = {
    "list": Command("list the cases", _args_list, cmd_list),
    "run": Command("run cases and write the report (report.html, report.json, summary.md)", _args_run, cmd_run),
    "check": Command("CI gate: figures vs thresholds (exit 0 pass, 1 fail, 2 bad input)", _args_check, cmd_check),
    "diff": Command("what changed between two runs' JSON, figure by figure", _args_diff, cmd_diff),
    "baseline": Command("write or compare the regression baseline (reports/baseline.json)",
                        _args_baseline, cmd_baseline),
    "converge": Command("convergence order per integrator vs the documented one (exit 1 if one falls "
                        "short); --softness, --solvers: constraint studies", _args_converge, cmd_converge),
    "audit": Command("the seed documents' claims: confirmed, refuted (with the correction) or ambiguous",
                     _args_audit, cmd_audit),
}


def _parser() -> argparse.ArgumentParser:
    p = _Parser(prog="mjharness", description="Validate MuJoCo against analytical mechanics.")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name, command in COMMANDS.items():
        command.add_arguments(sub.add_parser(name, help=command.help, description=command.help))
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        return COMMANDS[args.command].run(args)
    except SimulationDiverged as exc:
        print(f"mjharness: error: simulation diverged: {exc}", file=sys.stderr)
    except ValueError as exc:  # ConfigError, ModelError, ModelMismatch and every input check
        print(f"mjharness: error: {' '.join(str(exc).split())}", file=sys.stderr)
    except OSError as exc:
        print(f"mjharness: error: {exc.strerror or exc}: {exc.filename or ''}".rstrip(": "), file=sys.stderr)
    except KeyboardInterrupt:
        print("mjharness: interrupted", file=sys.stderr)
        return 130
    return EXIT_USAGE


if __name__ == "__main__":  # the command itself is harness.command:entry (python -m harness.command)
    sys.exit(main())

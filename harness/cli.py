"""``mjharness``: a thin argparse layer over pure functions.

Exit codes: 0 all checks pass, 1 a check fails, 2 bad usage or input
(unknown case, invalid MJCF or config, unwritable output, diverging
simulation). User mistakes give one line on stderr, never a traceback.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from harness import cases
from harness.config import ConfigError, load_config
from harness.models import ModelError
from harness.simulate import SimulationDiverged
from harness.verdict import Check, verdict

EXIT_OK, EXIT_FAIL, EXIT_USAGE = 0, 1, 2


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2 (argparse's own code)
        self.exit(EXIT_USAGE, f"mjharness: error: {message}\n")


def _parser() -> argparse.ArgumentParser:
    p = _Parser(prog="mjharness", description="Validate MuJoCo against analytical mechanics.")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    sub.add_parser("list", help="list the cases")
    for name, text in [("run", "run cases and write the report"), ("check", "CI gate: figures vs thresholds")]:
        sp = sub.add_parser(name, help=text)
        sp.add_argument("cases", nargs="*", metavar="CASE", help="case names (default: all)")
        sp.add_argument("--config", type=Path, help="TOML overriding [tool.mjharness] thresholds")
        if name == "run":
            sp.add_argument("--out", type=Path, default=Path("mjharness-report"),
                            help="output directory (default: ./mjharness-report)")
    return p


def _run_all(names: Sequence[str], config_path: Path | None):
    from harness.pipeline import run_case

    config = load_config(config_path)
    selected = cases.select(names)
    results, checks = [], {}
    for case in selected:
        print(f"running {case.name} ...", file=sys.stderr, flush=True)
        result = run_case(case)
        results.append(result)
        checks[case.name] = verdict(case.name, result.figures, config.for_case(case.name))
    return results, checks


def _print_table(checks: dict[str, list[Check]]) -> None:
    rows = [(c.case, c.name, f"{c.value:.3e}", f"{c.threshold:.3e}", c.unit,
             "pass" if c.passed else "FAIL") for cs in checks.values() for c in cs]
    header = ("case", "check", "figure", "threshold", "unit", "verdict")
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    for r in [header, *rows]:
        print("  ".join(v.ljust(w) for v, w in zip(r, widths, strict=True)).rstrip())
    failed = sum(not c.passed for cs in checks.values() for c in cs)
    total = sum(len(cs) for cs in checks.values())
    print(f"{total - failed} passed, {failed} failed")


def cmd_list() -> int:
    width = max(len(n) for n in cases.names())
    for c in cases.CASES:
        print(f"{c.name.ljust(width)}  [{','.join(sorted(c.tags))}]  {c.description}")
    return EXIT_OK


def cmd_run(args: argparse.Namespace) -> int:
    from harness.report import prepare_output, write_report

    start = time.perf_counter()
    prepare_output(args.out)  # fail before minutes of work, not after
    results, checks = _run_all(args.cases, args.config)
    paths = write_report(args.out, results, checks)
    _print_table(checks)
    print(f"wrote {', '.join(str(p) for p in paths)} in {time.perf_counter() - start:.1f} s")
    return EXIT_OK if all(c.passed for cs in checks.values() for c in cs) else EXIT_FAIL


def cmd_check(args: argparse.Namespace) -> int:
    _, checks = _run_all(args.cases, args.config)
    _print_table(checks)
    return EXIT_OK if all(c.passed for cs in checks.values() for c in cs) else EXIT_FAIL


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        if args.command == "list":
            return cmd_list()
        if args.command == "run":
            return cmd_run(args)
        return cmd_check(args)
    except (ConfigError, ModelError) as exc:
        print(f"mjharness: error: {exc}", file=sys.stderr)
    except SimulationDiverged as exc:
        print(f"mjharness: error: simulation diverged: {exc}", file=sys.stderr)
    except ValueError as exc:
        print(f"mjharness: error: {exc}", file=sys.stderr)
    return EXIT_USAGE


if __name__ == "__main__":
    sys.exit(main())

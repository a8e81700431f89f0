"""The CLI: exit codes 0 / 1 / 2, one-line errors, complete reports or none; and the config it reads.

Exit-code matrix (each row is a test below):

    list                                          0
    check CASE                                    0   (table; --json; --junit FILE)
    check CASE --config tighter.toml              1   (table; --json; --junit FILE with <failure>)
    run CASE --out DIR [--junit FILE]             0   report.html + report.json + summary.md, deterministic
    check --case CASE --mjcf copy.xml             0   same figures as the shipped model
    check --case CASE --mjcf heavier.xml          0   another mass is another model: its reference is its own
    run --case CASE --mjcf damped.xml             1   a fault (joint damping): report written, failures in it
    run/check: unknown case, bad config, missing / invalid MJCF, a model that does not fit,
      --mjcf with 0 or 2 cases, unwritable --out or --junit                        2, nothing written
    run/check: a diverging model                  1   each check of a diverged run fails with the
                                                      reason (tests/test_bad_input.py)
    diff OLD NEW (changes, flips)                 0;  missing / non-JSON / not a run   2
    baseline --write FILE / --compare FILE        0;  regression or missing case        1;  no mode  2

Most in-process tests reuse the session's shipped pendulum run (``cached_runs``); a
few go through a real subprocess to pin "no traceback" and the process exit code.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from harness import cases
from harness.budget import PARTS
from harness.cli.commands import COMMANDS, main
from harness.core.errors import ConfigError
from harness.core.options import RunOptions
from harness.pipeline import matrix
from harness.pipeline import run as pipeline
from harness.pipeline.limits import case_limits, load_limits
from harness.pipeline.verdict import judge
from harness.studies.faults import by_name
from tests.conftest import PEER_CHECKS, PROGRESS_LINE, shipped_run, without_progress

CASE = "pendulum"
MJCF = Path(__file__).resolve().parent.parent / "mjcf" / f"{CASE}.xml"


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "harness.cli", *args], capture_output=True,
                          text=True, timeout=300)




@pytest.fixture
def strict(tmp_path):
    path = tmp_path / "strict.toml"
    path.write_text(f'[thresholds.{CASE}]\n"RK4.position" = 1e-12\n')
    return path


def _variant(tmp_path: Path, old: str, new: str) -> Path:
    text = MJCF.read_text()
    assert old in text
    path = tmp_path / "variant.xml"
    path.write_text(text.replace(old, new))
    return path


def _one_line_error(err: str, needle: str) -> None:
    err = without_progress(err)  # the lines of the cases that finished before it
    assert needle in err, err
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) == 1, err


# --------------------------------------------------------------- list, check
def test_every_subcommand_is_one_function_in_a_module_of_its_own():
    assert set(COMMANDS) >= {"list", "run", "check", "diff", "baseline"}
    assert all(c.run.__name__ == f"cmd_{name}" for name, c in COMMANDS.items())
    assert all(c.run.__module__ == c.add_arguments.__module__ == f"harness.cli.subcommands.{name}"
               for name, c in COMMANDS.items())


NAMESAKES = {  # a flag of several commands that means something else in one of them, with what
    "--backend": "versions: the backend whose packages every environment installs (one, no 'all')",
    "--require": "advise: required, the accuracy its recommendation must meet",
    "--timeout": "sweep: the cell is an error; zoo: the model unfinished",
    "--write": "baseline: a PATH to write; limits: a switch",
    "--faults": "sensitivity: the faults to size; zoo: a switch",
    "--case": "diff: the rows shown, not the cases run",
    "--mjcf": "advise: a model of one's own only, no case's variant",
    "--out": "what each command writes there, and its default folder",
    "cases": "advise: one case or none",
    "models": "sweep: zoo models, MJCF files or case:NAME, one at least; zoo: its models or --folder's entries",
}


def test_an_option_several_commands_take_says_the_same_in_each():
    """Every option is declared once (harness/cli/options.py): wherever two commands take it, its help, type,
    default and metavar are the same, but for the namesakes above, each its own command's."""
    from harness.cli.commands import _parser

    parser = _parser()
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices
    seen: dict[str, dict[tuple, list[str]]] = {}
    for name, sub in commands.items():
        for action in sub._actions:
            flag = max(action.option_strings, key=len) if action.option_strings else action.dest
            said = (action.help, action.type, repr(action.default), action.metavar, action.nargs)
            seen.setdefault(flag, {}).setdefault(said, []).append(name)
    shared = {flag for flag, ways in seen.items() if sum(map(len, ways.values())) > 1}
    assert {"--jobs", "cases", "--mjcf", "--quiet", "--integrators", "--json", "--executor"} <= shared
    differ = {flag: list(ways.values()) for flag, ways in seen.items() if len(ways) > 1 and flag not in NAMESAKES}
    assert not differ, differ
    assert set(NAMESAKES) <= shared  # each a namesake still


def test_list_names_every_case(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    assert all(name in out for name in cases.names())


@pytest.mark.parametrize("columns", [None, 100, 60, 30])
def test_list_fits_the_width_and_says_every_description_and_tag(columns, capsys, monkeypatch):
    """Not a terminal (capsys) and no COLUMNS: 100 columns; COLUMNS: its width. Each case's name starts a line,
    its description and tags wrapped beside or below it, none lost."""
    if columns is None:
        monkeypatch.delenv("COLUMNS", raising=False)
    else:
        monkeypatch.setenv("COLUMNS", str(columns))
    assert main(["list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert max(map(len, lines)) <= (columns or 100), lines
    flat = "".join("".join(lines).split())  # a word longer than a narrow line is broken: compare without spaces
    for c in cases.all_cases():
        assert any(line.split()[:1] == [c.name] for line in lines)
        assert "".join(f"{c.name} {c.description} [{','.join(sorted(c.tags))}]".split()) in flat


def test_the_width_is_the_terminals_or_100_columns(monkeypatch):
    import shutil

    from harness.core import tables as table

    class Terminal:
        def isatty(self) -> bool:
            return True

    monkeypatch.delenv("COLUMNS", raising=False)
    assert table.terminal_width() == 100  # capsys's stdout is not a terminal
    monkeypatch.setattr(sys, "stdout", Terminal())
    monkeypatch.setattr(shutil, "get_terminal_size", lambda fallback=(80, 24): os.terminal_size((132, 50)))
    assert table.terminal_width() == 132
    monkeypatch.setenv("COLUMNS", "72")  # shutil reads COLUMNS first; here the stub stands for it
    monkeypatch.setattr(shutil, "get_terminal_size", lambda fallback=(80, 24): os.terminal_size((72, 50)))
    assert table.terminal_width() == 72


@pytest.mark.parametrize("columns", [100, 72, 40])
def test_check_fits_the_terminal_passing_or_failing(columns, tmp_path, capsys, monkeypatch, cached_runs):
    """Every line check prints fits the width, a failing variant's budget lines too (the verdict line stays one
    line, whatever its length, for what parses it; these are shorter); a line per case in the default view."""
    monkeypatch.setenv("COLUMNS", str(columns))
    assert main(["check", CASE, "spring", "atwood"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert max(map(len, lines[:-1])) <= columns, lines
    if columns >= 72:  # one line per case, then the verdict
        assert len(lines) == 5 and all(PROGRESS_LINE.fullmatch(ln) for ln in lines[:3]) and lines[3] == ""
    # (an older MuJoCo appends its n/a and engine findings to the verdict)
    assert lines[-1].startswith("PASS — ") and " checks of 3 case(s) within what their budgets explain" in lines[-1]
    damped = _variant(tmp_path, 'axis="0 -1 0" damping="0"', 'axis="0 -1 0" damping="0.01"')
    assert main(["check", "--case", CASE, "--mjcf", str(damped), "--integrators", "RK4,Euler"]) == 1
    lines = capsys.readouterr().out.splitlines()
    assert lines[-1].startswith("FAIL — ") and f"in 1 of 1 case(s): {CASE} (" in lines[-1]
    assert max(map(len, lines[:-1])) <= columns, lines
    assert sum(ln.startswith("FAIL ") for ln in lines[:-1]) == int(lines[-1].split()[2])  # each failure


def test_verbose_shows_every_check_and_the_default_only_the_failures(strict, capsys, cached_runs):
    assert main(["check", CASE, "spring", "--config", str(strict)]) == 1
    default = capsys.readouterr().out.splitlines()
    assert main(["check", CASE, "spring", "--config", str(strict), "-v"]) == 1
    verbose = capsys.readouterr().out.splitlines()
    limits = load_limits(strict)
    checks = [c for name in (CASE, "spring") for c in judge(shipped_run(name), limits.for_case(name))]
    for c in checks:  # a row each in the verbose table: case, check, its figures, its verdict last
        (row,) = [ln for ln in verbose if ln.split()[:2] == [c.case, c.name]]
        assert row.split()[-1] == ("n/a" if c.note else "pass" if c.passed else "FAIL") or c.note, row
        assert any(ln.startswith(f"FAIL {c.case} {c.name} [") for ln in default) is (not c.passed)
    assert sum(ln.startswith("case ") for ln in verbose) == 3  # the cases' lines and the table's header
    assert sum(ln.startswith("case ") for ln in default) == 2 and default[-1] == verbose[-1]
    assert len(default) == 2 + 1 + 2 + 1 + 1  # two cases' lines, the failure's two, the verdict


def test_check_lines_stream_in_a_log_in_the_order_the_cases_finish(tmp_path):
    """Not a terminal (a CI log): the cases' lines come on stdout as the cases finish, before the verdict,
    each flushed (a child of a pipe reads them while the run goes on), nothing on stderr."""
    proc = subprocess.Popen([sys.executable, "-m", "harness.cli", "check", "spring", CASE, "-j", "1"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    first = proc.stdout.readline()  # read while the second case runs: flushed, not held until the end
    still_running = proc.poll() is None
    out, err = proc.communicate(timeout=300)
    lines = [first.rstrip("\n"), *out.splitlines()]
    assert proc.returncode == 0 and err == "", err
    assert PROGRESS_LINE.fullmatch(lines[0]) and PROGRESS_LINE.fullmatch(lines[1]), lines
    order = [ln.split()[1].rstrip(":") for ln in lines[:2]]
    assert sorted(order) == sorted(["spring", CASE]) and lines[2] == "" and lines[3].startswith("PASS — ")
    assert still_running  # the first case's line was read while the second ran


def test_check_verbose_prints_each_figure_beside_its_limit(capsys, config, cached_runs):
    """--verbose: a row per check. A theory limit is printed as the limits file states it; a budget's limit
    is the one its budget computed for this run, beside the figure measured and the unexplained residual."""
    assert main(["check", CASE, "--verbose"]) == 0
    lines = capsys.readouterr().out.splitlines()
    result = shipped_run(CASE)
    limits = case_limits(config, result.case, result.judged_names)  # the limits file's and the second opinions'
    checks = {c.name: c for c in judge(result, limits)}
    for name, limit in limits.items():
        (line,) = [ln for ln in lines if ln.split()[1:2] == [name]]
        if checks[name].note:  # an integrator this MuJoCo lacks
            assert "n/a" in line
            continue
        if limit.basis == "theory":
            assert f"{limit.value:.3e}" in line
        else:
            budget = checks[name].budget
            assert all(f"{x:.3e}" in line for x in (budget.measured, budget.unexplained, budget.limit)), line
        assert line.split()[-1] == "pass"
    na = sum(bool(c.note) for c in checks.values())
    assert any(ln.startswith(f"{len(checks) - na} passed, 0 failed") for ln in lines)


def test_version_names_the_package_and_mujoco(capsys):
    import mujoco

    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith("mjharness 0.1.0 ") and f"MuJoCo {mujoco.__version__}" in out


@pytest.mark.parametrize("argv", [[], ["--help"]])
def test_bare_command_and_help_list_each_command_on_one_line_and_the_exit_codes(argv, capsys):
    if argv:
        with pytest.raises(SystemExit) as exc:
            main(argv)
        code = exc.value.code
    else:
        code = main(argv)
    assert code == (0 if argv else 2)  # a bare command did nothing: a usage error, with the help shown
    out = capsys.readouterr().out
    lines = out.splitlines()
    for name, command in COMMANDS.items():
        assert any(line.split() == [name, *command.help.split()] for line in lines), (name, out)
    assert "{" not in out  # no argparse {list,run,...} choice list
    codes = lines[lines.index("exit codes:") + 1:]
    assert [c.split()[0] for c in codes if c.startswith("  ") and not c.startswith("   ")][:3] == ["0", "1", "2"]


def test_check_prints_a_line_per_case_then_the_failures_with_their_budget_then_the_verdict(strict, capsys,
                                                                                          cached_runs):
    """By default no row per check: the case's line, the failed check with its budget (measured, the parts
    explained, unexplained beside the limit, how far over) and the verdict last."""
    assert main(["check", CASE, "--config", str(strict)]) == 1
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[-1].startswith("FAIL — 1 of ") and f"in 1 of 1 case(s): {CASE} (1)" in lines[-1]
    check = next(c for c in judge(shipped_run(CASE), load_limits(strict).for_case(CASE)) if not c.passed)
    b = check.budget
    assert check.name == "RK4.position" and b is None  # a user's fixed limit: the figure beside it
    assert PROGRESS_LINE.fullmatch(lines[0]) and f"case {CASE}: " in lines[0] and " 1 fail, worst " in lines[0]
    assert lines[1] == "" and lines[-2] == ""
    assert lines[2:-2] == [f"FAIL {CASE} RK4.position [m]: {check.value / 1e-12:.3g}× over its limit",
                           f"    measured {check.value:.3e} > fixed limit 1.000e-12"]


def test_a_failure_shows_its_budget_by_default(tmp_path, capsys):
    """A fault (joint damping) fails budget-judged checks: each failure's lines give the figure measured, the
    unexplained residual beside the limit its budget computed and the parts the budget explains."""
    damped = _variant(tmp_path, 'axis="0 -1 0" damping="0"', 'axis="0 -1 0" damping="0.01"')
    assert main(["check", "--case", CASE, "--mjcf", str(damped), "--integrators", "RK4"]) == 1
    out = capsys.readouterr().out
    lines = out.splitlines()
    checks = judge(pipeline.run_case(cases.get(CASE), RunOptions(mjcf=damped, integrators=("RK4",))),
                   load_limits().for_case(CASE))
    failed = [c for c in checks if not c.passed and c.budget is not None]
    assert failed and lines[-1].startswith(f"FAIL — {sum(not c.passed for c in checks)} of ")
    for c in failed:
        b = c.budget
        k = lines.index(f"FAIL {CASE} {c.name} [{c.unit}]: {b.unexplained / b.limit:.3g}× over its limit")
        assert lines[k + 1] == f"    measured {b.measured:.3e}, unexplained {b.unexplained:.3e} > limit {b.limit:.3e}"
        assert lines[k + 2] == "    explained: " + ", ".join(f"{p} {b.explained[p]:.2e}" for p in PARTS
                                                          if p in b.explained)
    assert max(map(len, lines[:-1])) <= 100  # not a terminal: 100 columns (the verdict line stays whole)


@pytest.mark.parametrize("tight", [False, True])
def test_quiet_prints_the_failures_and_the_verdict_only(tight, strict, capsys, cached_runs):
    assert main(["check", CASE, "--quiet", *(["--config", str(strict)] if tight else [])]) == int(tight)
    lines = capsys.readouterr().out.strip().splitlines()
    if tight:  # the failure (its line and its figure beside the limit), then the verdict
        assert len(lines) == 4 and lines[0].startswith(f"FAIL {CASE} RK4.position [m]: ") and lines[2] == ""
        assert lines[1].startswith("    measured ") and lines[3].startswith("FAIL")
    else:
        assert len(lines) == 1 and lines[0].startswith("PASS — ") and "checks of 1 case(s) within" in lines[0]


@pytest.mark.parametrize("require, tight, code, last", [
    ("position=1", False, 0, "REQUIREMENTS MET — position ≤ 1"),
    ("position=1e-15", False, 3, "REQUIREMENTS NOT MET — position ≤ 1e-15: pendulum RK4.position "),
    ("position=1e-15", True, 1, "REQUIREMENTS NOT MET"),  # a failed check decides the exit code
])
def test_require_judges_the_models_own_integrator_and_exits_3_when_unmet(require, tight, code, last, strict,
                                                                        capsys, cached_runs):
    """Fitness for purpose is a second verdict: the pendulum runs RK4 (its file's integrator), so a
    position requirement is judged on RK4.position alone; unmet where every check passes is exit 3."""
    args = ["check", CASE, "--quiet", "--require", require, *(["--config", str(strict)] if tight else [])]
    assert main(args) == code
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[-1].startswith(last) and lines[-2].startswith("FAIL" if tight else "PASS")


def test_a_requirement_no_figure_answers_is_bad_input(capsys, cached_runs):
    assert main(["check", CASE, "--require", "posture=1e-3"]) == 2
    _one_line_error(capsys.readouterr().err, "requirement 'posture' matches no figure")


def test_figures_lists_every_figure_with_its_unit_meaning_and_limit_basis(capsys, cached_runs):
    assert main(["figures", CASE]) == 0
    out = capsys.readouterr().out
    limits = load_limits()
    run = shipped_run(CASE)
    lines = out.splitlines()
    assert max(map(len, lines)) <= 100  # not a terminal: 100 columns, the long texts wrapped
    for f in run.figures:  # "  NAME [unit]: what it measures", its continuation lines at 4, then the basis at 6
        (k,) = [i for i, line in enumerate(lines) if line.split()[:1] == [f"{f.name}"]]
        n = next(i for i in range(k + 1, len(lines)) if lines[i].startswith("      "))
        assert " ".join(" ".join(lines[k:n]).split()) == " ".join(f"{f.name} [{f.unit}]: {f.description}".split())
        lim = limits.limit(CASE, f.name)
        end = next((i for i in range(n, len(lines)) if not lines[i].startswith("      ")), len(lines))
        basis = " ".join(" ".join(lines[n:end]).split())
        if lim is None:
            assert basis == "not gated"
        elif lim.basis == "budget":  # no number: the budget computes the limit for each run
            assert basis.startswith("budget:") and "limit" not in basis.split(":")[0], basis
        else:
            assert basis.startswith(f"limit {lim.value:.3g}: {lim.basis}: ") and lim.reason in basis
    bases = {limits.limit(CASE, f.name).basis for f in run.figures if limits.limit(CASE, f.name)}
    assert bases == {"budget", "theory"}  # the pendulum has both kinds: both were shown


def test_figures_fit_100_columns_when_not_a_terminal(capsys, monkeypatch, cached_runs):
    monkeypatch.delenv("COLUMNS", raising=False)
    chosen = [n for n in ("atwood_tendon", "hoop_ramp_contact", "torque_free_body") if n in cases.names()]
    assert main(["figures", *chosen]) == 0  # (atwood_tendon needs a newer MuJoCo than 3.3)
    lines = capsys.readouterr().out.splitlines()
    assert max(map(len, lines)) <= 100 and sum(ln.startswith("hoop_ramp_contact — ") for ln in lines) == 1


def test_check_fails_with_exit_1_when_a_threshold_is_tightened(strict):
    proc = _run("check", CASE, "--config", str(strict))
    assert proc.returncode == 1
    assert "FAIL" in proc.stdout and "Traceback" not in proc.stderr
    # no progress bar, terminal or not: the finished case's line comes first on stdout, its one failure told
    assert proc.stderr == ""
    line = re.fullmatch(rf"case {CASE}: +(\d+) checks, +(\d+) fail, worst (\S+)× its limit \(\d+\.\d s\)",
                        proc.stdout.splitlines()[0])
    assert line is not None, proc.stdout
    assert int(line[1]) > int(line[2]) == 1 and float(line[3]) > 1  # the one tightened figure


@pytest.mark.parametrize("tight, code", [(False, 0), (True, 1)])
def test_check_json_is_the_only_stdout(capsys, cached_runs, strict, tight, code):
    assert main(["check", CASE, "--json", *(["--config", str(strict)] if tight else [])]) == code
    doc = json.loads(capsys.readouterr().out)
    assert doc["passed"] is (not tight)
    assert doc["cases"][CASE]["checks"]["RK4.position"]["passed"] is (not tight)
    assert "RK4.velocity" in doc["cases"][CASE]["figures"]


def test_check_json_keeps_what_a_library_prints_off_stdout(capsys, cached_runs, monkeypatch):
    """mujoco-mjx prints to stdout when imported without Warp; versions reads check --json's stdout as the
    document, so what is printed during the run goes to stderr."""
    from harness.pipeline import matrix

    inner = matrix.run_case

    def noisy(case, options=None):
        print("Failed to import warp: No module named 'warp'")  # as mujoco/mjx/warp/__init__.py does
        return inner(case, options)

    monkeypatch.setattr(matrix, "run_case", noisy)
    assert main(["check", CASE, "--json", "--jobs", "1"]) == 0
    out, err = capsys.readouterr()
    assert json.loads(out)["passed"] and "Failed to import warp" in err


@pytest.mark.parametrize("tight, code", [(False, 0), (True, 1)])
def test_check_junit(tmp_path, cached_runs, strict, tight, code, capsys):
    junit = tmp_path / "ci" / "junit.xml"
    assert main(["check", CASE, "--junit", str(junit), *(["--config", str(strict)] if tight else [])]) == code
    root = ET.parse(junit).getroot()
    cases_ = root.findall("./testsuite/testcase")
    assert len(cases_) == len(load_limits().for_case(CASE)) + PEER_CHECKS
    failures = [tc.get("name") for tc in cases_ if tc.find("failure") is not None]
    assert failures == (["RK4.position"] if tight else [])
    lines = capsys.readouterr().out.splitlines()  # the JUnit besides what check prints, not instead
    assert lines[0].startswith(f"case {CASE}: ") and lines[-1].startswith("FAIL — " if tight else "PASS — ")


def test_progress_is_a_bar_on_a_terminal_and_lines_in_a_log(monkeypatch, capsys):
    """A terminal gets tqdm's bar; a log (stderr not a terminal) a plain line when a case finishes and
    PROGRESS_INTERVAL has passed since the last one (none for a short run, none after the last case)."""
    from harness.pipeline import matrix as runner

    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    bar = runner.progress([1], "x")
    assert not bar.disable
    bar.close()
    monkeypatch.setattr(sys.stderr, "isatty", lambda: False)
    capsys.readouterr()
    assert list(runner.progress(["a", "b", "c"], "x")) == ["a", "b", "c"]
    assert capsys.readouterr().err == ""  # quicker than the interval: nothing
    monkeypatch.setattr(runner, "PROGRESS_INTERVAL", 0.0)
    log = runner.progress(["a", "b", "c"], "mjharness")
    for name in log:
        log.set_postfix_str(name)
    assert capsys.readouterr().err.splitlines() == ["mjharness: 1 of 3 cases done after 0 s (a)",
                                                    "mjharness: 2 of 3 cases done after 0 s (b)"]


def test_a_long_check_prints_progress_lines_in_a_log(monkeypatch, capsys, cached_runs):
    """In a log, check says each case as it finishes (the per-case lines), and nothing twice: the periodic progress
    line is for runs without lines of their own (faults, sensitivity)."""
    from harness.pipeline import matrix as runner

    monkeypatch.setattr(runner, "PROGRESS_INTERVAL", 0.0)
    assert main(["check", CASE, "spring", "-j", "1", "-q"]) == 0
    lines = capsys.readouterr().err.splitlines()
    expected = [f"case pendulum:  {40 + PEER_CHECKS} checks,  0 fail",
                f"case spring:    {24 + PEER_CHECKS} checks,  0 fail"]
    assert [re.sub(r", worst .*", "", ln) for ln in lines] == expected, lines
    assert all(PROGRESS_LINE.fullmatch(ln) for ln in lines)


# ------------------------------------------------------------------- errors
@pytest.mark.parametrize("args, needle", [
    (["check", "nosuchcase"], "known cases: atwood"),
    (["run", "nosuchcase"], "known cases: atwood"),
    (["check", "pendulm"], "unknown case 'pendulm'; did you mean 'pendulum'? known cases: atwood"),
    (["frobnicate"], "invalid choice"),
    (["check", CASE, "--config", "/nonexistent.toml"], "cannot read config"),
    (["baseline", CASE], "one of the arguments --write --compare is required"),
    (["diff", "/nonexistent/old.json", "/nonexistent/new.json"], "cannot read"),
])
def test_bad_usage_exits_2_with_one_line(args, needle):
    proc = _run(*args)
    assert proc.returncode == 2
    _one_line_error(proc.stderr, needle)


@pytest.mark.parametrize("text, needle", [
    ("[thresholds.pendulum]\n\"RK4.position\" = -1\n", "positive number"),
    ("[thresholds.pendulum]\n\"RK4.position\" = true\n", "positive number"),
    ("[thresholds.pendulum]\n\"RK4.position\" = \"1e-3\"\n", "positive number"),
    ("[thresholds.pendulum]\n\"RK4.position\" = inf\n", "positive number"),
    ("[thresholds.pendulum]\nRK4.position = 1e-3\n", 'quote dotted figure names, e.g. "RK4.position"'),
    ("[thresholds.pendulum]\n\"RK4.nonsense\" = 1\n", "unmeasured figure"),
    ("[thresholds.nosuchcase]\n\"RK4.position\" = 1\n", "unknown case"),
    ("[thresholds.pendulm]\n\"RK4.position\" = 1\n", "unknown case 'pendulm' in thresholds; did you mean 'pendulum'?"),
    ("thresholds = 3\n", "must be a table of cases"),
    ("[colours]\nred = 1\n", "unknown key"),
    ("[tool.black]\nline-length = 1\n", "no [tool.mjharness] table"),
    ("this is = not [toml", "not valid TOML"),
])
def test_bad_config_exits_2(tmp_path, text, needle, capsys, cached_runs):
    cfg = tmp_path / "bad.toml"
    cfg.write_text(text)
    assert main(["check", CASE, "--config", str(cfg)]) == 2
    _one_line_error(capsys.readouterr().err, needle)


def test_config_overrides_key_by_key(tmp_path):
    cfg = tmp_path / "override.toml"
    cfg.write_text('[tool.mjharness.thresholds.pendulum]\n"RK4.position" = 5e-7\n')  # pyproject style works too
    merged, config = load_limits(cfg), load_limits()
    assert config.for_case(CASE)["RK4.position"].basis == "budget"
    overridden = merged.for_case(CASE)["RK4.position"]
    assert (overridden.basis, overridden.value) == ("user", 5e-7) and str(cfg) in overridden.reason
    others = {k: v for k, v in merged.for_case(CASE).items() if k != "RK4.position"}
    assert others == {k: v for k, v in config.for_case(CASE).items() if k != "RK4.position"}
    assert str(cfg) in merged.source


def test_non_utf8_config_is_a_config_error(tmp_path):
    cfg = tmp_path / "latin1.toml"
    cfg.write_bytes(b"# \xe9\n")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_limits(cfg)


@pytest.mark.parametrize("make, needle", [
    (lambda tmp: tmp / "missing.xml", "no such file"),
    (lambda tmp: _variant(tmp, "</mujoco>", ""), "invalid MJCF"),
    (lambda tmp: _variant(tmp, 'name="theta"', 'name="angle"'), "model has no joint 'theta'"),
    (lambda tmp: _variant(tmp, '<joint name="rod"', '<joint name="stick"'), "model has no equality 'rod'"),
])
def test_bad_model_exits_2_and_writes_nothing(tmp_path, make, needle, capsys):
    out = tmp_path / "report"
    assert main(["run", "--case", CASE, "--mjcf", str(make(tmp_path)), "--out", str(out)]) == 2
    _one_line_error(capsys.readouterr().err, needle)
    assert not out.exists()


def test_mjcf_with_cases_needs_exactly_one(tmp_path, capsys):
    """With cases, --mjcf judges one model against one case; with none it is the model's own tree
    (tests/test_own_model.py)."""
    assert main(["check", CASE, "spring", "--mjcf", str(MJCF)]) == 2
    _one_line_error(capsys.readouterr().err, "--mjcf with cases judges one model against one case")


def test_unwritable_output_exits_2_and_writes_nothing(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    proc = _run("run", CASE, "--out", str(blocker / "sub"))
    assert proc.returncode == 2
    _one_line_error(proc.stderr, "output directory")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


@pytest.mark.parametrize("where", ["under_file", "directory"])
def test_unwritable_junit_exits_2_before_running(tmp_path, where, capsys, monkeypatch):
    monkeypatch.setattr(matrix, "run_case", lambda *a, **k: pytest.fail("ran before checking --junit"))
    blocker = tmp_path / "file"
    blocker.write_text("x")
    target = blocker / "junit.xml" if where == "under_file" else tmp_path
    assert main(["check", CASE, "--junit", str(target)]) == 2
    assert "Traceback" not in capsys.readouterr().err


# --------------------------------------------------------------------- run
def test_run_writes_complete_deterministic_report(tmp_path, cached_runs, capsys):
    out1, out2 = tmp_path / "a", tmp_path / "b"
    assert main(["run", CASE, "--out", str(out1), "--junit", str(tmp_path / "junit.xml")]) == 0
    assert main(["run", CASE, "--out", str(out2)]) == 0
    assert ET.parse(tmp_path / "junit.xml").getroot().get("failures") == "0"
    names = sorted(p.relative_to(out1).as_posix() for p in out1.rglob("*") if p.is_file())
    assert names == [".mjharness-manifest.json", "audit.html", f"cases/{CASE}.html", "inertia.html", "report.html",
                     "report.json", "studies.html", "summary.md"]
    for name in names:
        assert (out1 / name).read_bytes() == (out2 / name).read_bytes(), name
    doc = json.loads((out1 / "report.json").read_text())
    assert doc["cases"][CASE]["checks"]["RK4.position"]["passed"] is True
    overview, page = (out1 / "report.html").read_text(), (out1 / "cases" / f"{CASE}.html").read_text()
    assert all("http://" not in p and "https://" not in p for p in (overview, page))  # self-contained
    assert page.count("data:image/png;base64,") >= 4 and "<img" not in overview
    assert f"href='cases/{CASE}.html'" in overview
    out = capsys.readouterr().out.strip().splitlines()
    # what was written (wrapped to the width: continuation lines indented), then the verdict last
    wrote = max(i for i, line in enumerate(out) if line.startswith("wrote in "))
    assert all(not line or line.startswith(" ") for line in out[wrote + 1:-1]) and out[-1].startswith("PASS — ")
    written = " ".join(" ".join(out[wrote:-1]).split())  # the wrapping's line breaks and indents folded
    assert all(name in written for name in ("report.html", "report.json", "summary.md", "1 case page(s) in"))
    assert main(["run", CASE, "--out", str(out2), "--quiet", "--no-studies"]) == 0  # the verdict: the same
    assert capsys.readouterr().out.strip().splitlines() == [out[-1]]


def test_run_user_variant_against_the_case(tmp_path, capsys, config):
    """--mjcf: a copy of the shipped model gives the shipped figures; a 2 % heavier bob is another,
    consistent model, judged against its own reference (0), with the mass shown as what differs; a
    damped hinge is a fault the reference has no term for (1), and the report still says which model
    was validated and what failed."""
    copy = tmp_path / "copy.xml"
    copy.write_text(MJCF.read_text())
    assert main(["check", "--case", CASE, "--mjcf", str(copy), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    shipped = {f.name: f.value for f in shipped_run(CASE).figures}
    assert {k: v["value"] for k, v in doc["cases"][CASE]["figures"].items()} == shipped
    assert doc["cases"][CASE]["settings"]["mjcf"] == str(copy)
    assert "changed" not in doc["cases"][CASE]["settings"]

    heavy = _variant(tmp_path, 'mass="1" diaginertia', 'mass="1.02" diaginertia')
    assert main(["check", "--case", CASE, "--mjcf", str(heavy), "--json", "--integrators", "RK4"]) == 0
    settings = json.loads(capsys.readouterr().out)["cases"][CASE]["settings"]
    assert settings["params"]["m"] == 1.02 and settings["changed"]["param.m"] == {"shipped": 1.0, "tested": 1.02}

    damping = by_name("damping").sizes[0]  # the fault catalog's size at the shipped settings
    damped = _variant(tmp_path, 'axis="0 -1 0" damping="0"', f'axis="0 -1 0" damping="{damping!r}"')
    out = tmp_path / "report"
    assert main(["run", "--case", CASE, "--mjcf", str(damped), "--out", str(out), "--integrators", "RK4",
                 "--no-studies"]) == 1
    doc = json.loads((out / "report.json").read_text())
    assert doc["passed"] is False and doc["cases"][CASE]["settings"]["mjcf"] == str(damped)
    assert doc["cases"][CASE]["checks"]["RK4.position"]["passed"] is False
    assert "variant.xml" in (out / "cases" / f"{CASE}.html").read_text()
    # the overview says what differs from the shipped model, the damping that made it fail included
    differs = (out / "report.html").read_text().split("What differs from the shipped model</h2>")[1]
    assert "variant.xml" in differs and "<td>mjcf: joint &#x27;theta&#x27; damping</td>" in differs
    assert "FAIL" in capsys.readouterr().out


# -------------------------------------------------------------------- diff
def test_diff_exits_0_and_flags_flips(tmp_path, cached_runs, strict, capsys):
    old, new = tmp_path / "old.json", tmp_path / "new.json"
    assert main(["check", CASE, "--json"]) == 0
    old.write_text(capsys.readouterr().out)
    assert main(["check", CASE, "--json", "--config", str(strict)]) == 1
    new.write_text(capsys.readouterr().out)
    assert main(["diff", str(old), str(old)]) == 0
    assert "0 verdict(s) flipped" in capsys.readouterr().out
    assert main(["diff", str(old), str(new)]) == 0
    out = capsys.readouterr().out
    assert "FLIPPED pendulum RK4.position: pass -> FAIL" in out and "1 pass -> FAIL" in out


@pytest.mark.parametrize("content, needle", [
    ("{oops", "is not JSON"),
    ('{"versions": {}}', "is not an mjharness run"),
])
def test_diff_of_bad_file_exits_2(tmp_path, content, needle, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text(content)
    assert main(["diff", str(bad), str(bad)]) == 2
    _one_line_error(capsys.readouterr().err, needle)


# ---------------------------------------------------------------- baseline
def test_baseline_write_then_compare(tmp_path, cached_runs, capsys):
    path = tmp_path / "baseline.json"
    assert main(["baseline", CASE, "--write", str(path)]) == 0
    doc = json.loads(path.read_text())
    assert set(doc["cases"]) == {CASE} and doc["kind"] == "baseline"
    assert main(["baseline", CASE, "--compare", str(path)]) == 0
    assert "0 regression(s)" in capsys.readouterr().out

    entry = doc["cases"][CASE]["figures"]["RK4.position"]
    entry["value"] /= 3  # the baseline was 3× better than today: today regressed
    path.write_text(json.dumps(doc))
    assert main(["baseline", CASE, "--compare", str(path)]) == 1
    out = capsys.readouterr().out
    assert "pendulum RK4.position regressed" in out and f"mjharness baseline --write {path}" in out


def test_baseline_compare_fails_on_a_case_missing_from_it(tmp_path, cached_runs, capsys):
    path = tmp_path / "baseline.json"
    path.write_text(json.dumps({"schema": 1, "cases": {}}))
    assert main(["baseline", CASE, "--compare", str(path)]) == 1
    assert "case 'pendulum' is not in the baseline" in capsys.readouterr().out


def test_baseline_refuses_to_record_failing_checks(tmp_path, cached_runs, strict, capsys):
    path = tmp_path / "baseline.json"
    assert main(["baseline", CASE, "--write", str(path), "--config", str(strict)]) == 1
    assert not path.exists()
    assert "refusing to write a baseline" in capsys.readouterr().err

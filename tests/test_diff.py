"""``mjharness diff``: rows by the size of their change, rows that tell nothing hidden (``--all`` shows them),
``--case``/``--figure`` selections, and a known defect's status as a verdict of its own."""

from __future__ import annotations

import json

import pytest

from harness.cli.commands import main
from harness.outputs.diff import diff_runs, format_diff, select


def _doc(values: dict[tuple[str, str], float], statuses: dict[tuple[str, str], str] | None = None) -> dict:
    cases: dict = {}
    for (case, figure), v in values.items():
        cases.setdefault(case, {"figures": {}, "checks": {}})["figures"][figure] = {"value": v}
    for (case, figure), s in (statuses or {}).items():
        cases[case]["checks"][figure] = {"value": values[(case, figure)], "threshold": 1.0, "status": s,
                                         "passed": s in ("pass", "n/a")}
    return {"schema": 2, "versions": {"mujoco": "x"}, "cases": cases}


OLD = _doc({("ball", "RK4.position"): 1e-6, ("ball", "converge.RK4.order_shortfall"): 1.99,
            ("ball", "Euler.position"): 3e-3, ("ramp", "RK4.position"): 1e-8, ("ramp", "Euler.velocity"): 2e-8,
            ("ramp", "instant.qacc"): 5e-5},
           {("ball", "converge.RK4.order_shortfall"): "FAIL (known defect)", ("ball", "RK4.position"): "pass"})
NEW = _doc({("ball", "RK4.position"): 1.5e-11, ("ball", "converge.RK4.order_shortfall"): 0.0,
            ("ball", "Euler.position"): 3e-3 * (1 + 1e-9), ("ramp", "RK4.position"): 1.5e-8,
            ("ramp", "Euler.velocity"): 2e-8, ("ramp", "instant.qacc"): 5e-5 * 1.0004},
           {("ball", "converge.RK4.order_shortfall"): "pass", ("ball", "RK4.position"): "pass"})


def _table(text: str) -> list[str]:
    """The figure column of the table's rows, in order."""
    lines = text.splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith("case "))
    return [ln.split()[1] for ln in lines[start + 1:-1]]


def test_rows_go_flips_first_then_by_the_factor_of_their_change_and_roundoff_is_hidden():
    text = format_diff(diff_runs(OLD, NEW))
    assert _table(text) == ["converge.RK4.order_shortfall", "RK4.position", "RK4.position"]
    assert text.startswith("FLIPPED ball converge.RK4.order_shortfall: FAIL (known defect) -> pass")
    assert "(2 of them by less than new/old shows, hidden)" in text  # 1 + 1e-9 and × 1.0004: printed as 1
    every = _table(format_diff(diff_runs(OLD, NEW), show_all=True))
    assert len(every) == 6 and every[:3] == ["converge.RK4.order_shortfall", "RK4.position", "RK4.position"]


def test_a_failure_becoming_a_known_defect_is_a_flip():
    key = ("ball", "converge.RK4.order_shortfall")
    old = _doc({key: 1.99}, {key: "FAIL"})
    new = _doc({key: 1.99}, {key: "FAIL (known defect)"})
    assert [r.figure for r in diff_runs(old, new).flipped] == [key[1]]


def test_case_and_figure_select_rows_and_unknown_ones_are_refused():
    d = select(diff_runs(OLD, NEW), cases=["ramp"], figures=["RK4.*", "instant.qacc"])
    assert [(r.case, r.figure) for r in d.rows] == [("ramp", "RK4.position"), ("ramp", "instant.qacc")]
    with pytest.raises(ValueError, match="--case nope: not in either run; the runs have ball, ramp"):
        select(diff_runs(OLD, NEW), cases=["nope"])
    with pytest.raises(ValueError, match=r"--figure implicit\.\*: matches no figure"):
        select(diff_runs(OLD, NEW), figures=["implicit.*"])


def test_the_command_takes_the_selections(tmp_path, capsys):
    old, new = tmp_path / "old.json", tmp_path / "new.json"
    old.write_text(json.dumps(OLD))
    new.write_text(json.dumps(NEW))
    assert main(["diff", str(old), str(new), "--case", "ball", "--figure", "RK4.*"]) == 0
    assert _table(capsys.readouterr().out) == ["RK4.position"]
    assert main(["diff", str(old), str(new), "--figure", "nothing"]) == 2
    assert "matches no figure" in capsys.readouterr().err

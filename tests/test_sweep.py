"""``mjharness sweep`` without environments: the first changes along a row, the identity comparison of two
sweeps, a task lost for good as one line, and bad input as one line (the sweep for real, on the local pool and
on a Ray cluster: tests/test_sweep_ray.py)."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import pytest

from harness.cli.commands import main
from harness.outputs.jsondoc import dumps
from harness.versions import sweep
from harness.versions import sweep_report as report
from harness.versions.envs import EnvSpec, Shipped
from harness.versions.releases import Release


def cell(release: str, verdict: str = "pass", **figures: float) -> sweep.Cell:
    return sweep.Cell("m", release, "c", verdict, figures={f"m:{k}": v for k, v in figures.items()})


def test_first_changes_are_bit_exact_and_step_over_cells_without_a_verdict():
    one_ulp = math.nextafter(1.0, 2.0)
    row = [cell("3.3.0", a=1.0, b=2.0), cell("3.4.0", "error"), cell("3.5.0", a=1.0, b=2.0),
           cell("3.6.0", "n/a"), cell("3.7.0", "fail", a=one_ulp, b=2.0, c=3.0)]
    found = sweep.first_change(row)
    assert (found.verdict, found.was, found.now) == ("3.7.0", "pass", "fail")
    assert (found.figure, found.changed, found.appeared, found.compared) == ("3.7.0", 1, 1, 2)
    assert found.largest == pytest.approx(2.0 ** -52) and found.largest_figure == "m:a"
    same = sweep.first_change([cell("3.3.0", a=math.nan), cell("4.0.0", a=math.nan)])
    assert (same.verdict, same.figure) == ("", "")  # nan is nan: no change


def _sweep(cells) -> sweep.Sweep:
    return sweep.Sweep(("m",), tuple(dict.fromkeys(c.release for c in cells)), ("c",), tuple(cells))


def test_the_identity_comparison_finds_a_figure_one_ulp_apart_and_ignores_what_a_run_cost():
    cells = [cell("3.3.0", a=0.1), cell("4.0.0", a=0.2)]
    doc = json.loads(dumps(report.json_doc(_sweep(cells))))
    cheaper = [sweep.Cell(**{**vars(c), "seconds": 9.0, "host": "elsewhere"}) for c in cells]
    again = json.loads(dumps(report.json_doc(_sweep(cheaper))))
    assert report.differences(report.comparable(doc), report.comparable(again)) == []
    planted = [cells[0], cell("4.0.0", a=math.nextafter(0.2, 1.0))]
    moved = json.loads(dumps(report.json_doc(_sweep(planted))))
    found = report.differences(report.comparable(doc), report.comparable(moved))
    assert found[0] == "/cells[1]/figures/m:a: 0.2 vs 0.20000000000000004", found


def test_a_task_lost_for_good_is_one_line_naming_model_release_and_backend(monkeypatch):
    shipped = Shipped("0" * 16, "mjharness-0-py3-none-any.whl", b"")
    models = (sweep.Model("dm_control/pendulum", "zoo", "/nowhere/pendulum.xml"),)
    tasks = sweep.plan(models, [Release("3.3.0"), Release("4.0.0")], ["c", "mjx"], shipped=shipped,
                       root=Path("/nowhere"), refused={(Release("4.0.0"), "mjx"): "no mujoco-mjx 4.0.0"})

    def fake_run_tasks(calls, workers, *, on_done=None, executor=None, failed=None, labels=None):
        assert labels == [t.label for t in tasks]
        out = [sweep.Cell(t.model.name, str(t.spec.release), t.backend, "pass") for t in tasks]
        out[1] = failed(1, "worker died 4 times (SIGKILL)")
        out[3] = sweep.run_task(tasks[3])  # refused: n/a, nothing built
        return out

    monkeypatch.setattr(sweep, "run_tasks", fake_run_tasks)
    result = sweep.run(tasks, workers=2)
    assert [c.verdict for c in result.cells] == ["pass", "error", "pass", "n/a"]
    line = "dm_control/pendulum on MuJoCo 4.0.0 (c): error: the task was lost: worker died 4 times (SIGKILL)"
    assert [c.line() for c in result.errors] == [line]
    page = report.markdown(result)
    assert f"- {line}\n" in page and "| dm_control/pendulum | c | pass | error |" in page
    assert "| dm_control/pendulum | mjx | pass | n/a |" in page


def test_on_a_cluster_each_models_files_go_with_its_tasks_once(tmp_path, monkeypatch):
    """A file's model carried to the node (harness/pipeline/carry.py), packed once for all its tasks: the node's
    check is told its copy, which stands where this machine's file is gone."""
    import tempfile

    from harness.pipeline.carry import Carried
    from harness.pipeline.executor import Executor

    model = tmp_path / "own.xml"
    model.write_text('<mujoco><worldbody><body><joint/><geom size=".1"/></body></worldbody></mujoco>')
    shipped = Shipped("0" * 16, "x.whl", b"")
    models = (sweep.Model("own.xml", "file", str(model)), sweep.Model("case:pendulum", "case"))
    tasks = sweep.plan(models, [Release("3.3.0"), Release("4.0.0")], ["c"], shipped=shipped, root=tmp_path)
    seen = []

    def fake_run_tasks(calls, workers, *, on_done=None, executor=None, failed=None, labels=None):
        seen.extend(calls)
        return [sweep.Cell(t.model.name, str(t.spec.release), t.backend, "pass") for t in tasks]

    monkeypatch.setattr(sweep, "run_tasks", fake_run_tasks)
    sweep.run(tasks, workers=2, executor=Executor("ray"))
    carried = [args[1] for _, args in seen[:2]]
    assert all(isinstance(c, Carried) for c in carried) and carried[0] is carried[1]
    assert [len(args) for _, args in seen[2:]] == [1, 1]  # a case has no files to carry
    model.unlink()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    node = dataclasses.replace(tasks[0].model, carried=carried[0])
    flag, here = node.check_args()
    assert flag == "--mjcf" and Path(here).is_relative_to(tmp_path) and Path(here).is_file()
    seen.clear()
    sweep.run(tasks, workers=2)  # on this machine nothing is carried
    assert [len(args) for _, args in seen] == [1, 1, 1, 1]


def test_a_refused_spec_is_an_n_a_cell_without_building():
    shipped = Shipped("0" * 16, "x.whl", b"")
    task = sweep.Task(sweep.Model("case:pendulum", "case"), "mjx", EnvSpec(Release("4.0.0"), refused="no mjx"),
                      shipped, Path("/nowhere"))
    assert sweep.run_task(task).line() == "case:pendulum on MuJoCo 4.0.0 (mjx): n/a: no mjx"


@pytest.mark.parametrize(("argv", "says"), [
    (["sweep", "acrobot", "--releases", "3.3.0", "4.0.0", "--backends", "c,warp"], "unknown backend(s) warp"),
    (["sweep", "no_such_model", "--releases", "3.3.0", "4.0.0"], "unknown zoo model 'no_such_model'"),
    (["sweep", "case:no_such_case", "--releases", "3.3.0", "4.0.0"], "no_such_case"),
    (["sweep", "missing.xml", "--releases", "3.3.0", "4.0.0"], "MJCF file 'missing.xml' does not exist"),
])
def test_bad_input_is_one_line_and_exit_2(argv, says, capsys):
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's own refusal of an option's value
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err
    assert says in err and err.count("\n") == 1, err

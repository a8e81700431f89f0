"""``run --out`` (and ``versions``, ``sweep``, ``zoo --out``) removes only what an earlier run wrote there (issue
45, point 3).

- A folder holding files no run wrote (a user's ``cases/*.html``, ``audit.html``) is refused before any work,
  and nothing in it is touched (not even renamed ``.stale``); with ``--force-out`` the report is written
  beside them and they stay as they were.
- A ``cases`` folder that is a link (to HTML outside ``--out``) is refused, even with ``--force-out``.
- ``--out ""`` (the current folder, silently) and a dangling ``--out`` link are refused before the run.
- A folder that is not the user's is refused unless forced.
- The manifest lists what a run wrote, with hashes; a later run removes only those of its pages that are
  unchanged since, never a page the user edited.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import pytest

from harness.cli import commands as cli
from harness.outputs import files
from harness.pipeline import entry


def _tree(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.fixture
def no_run(monkeypatch):
    """The run itself must never start: every refusal comes before any work."""
    def refused(*args, **kwargs):
        raise AssertionError("the run started before its arguments were judged")

    monkeypatch.setattr(entry, "run_all", refused)  # every command runs its cases through the one entry


def _run(out, *extra) -> int:
    return cli.main(["run", "pendulum", "--no-studies", "--quiet", "--out", str(out), *extra])


def test_a_folder_holding_the_users_pages_is_refused_and_left_alone(tmp_path, no_run, capsys):
    out = tmp_path / "R"
    (out / "cases").mkdir(parents=True)
    (out / "cases" / "mine.html").write_text("the user's")
    (out / "audit.html").write_text("the user's too")
    (out / "report.html").write_text("a report the user wrote")
    before = _tree(out)
    assert _run(out) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "--force-out" in err and "cases/mine.html" in err
    assert _tree(out) == before  # nothing removed, replaced or renamed .stale


def test_a_linked_cases_folder_is_refused_even_when_forced(tmp_path, no_run, capsys):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "precious.html").write_text("outside --out")
    out = tmp_path / "R"
    out.mkdir()
    (out / "cases").symlink_to(elsewhere)
    for extra in ((), ("--force-out",)):
        assert _run(out, *extra) == 2
        assert "link" in capsys.readouterr().err
    assert (elsewhere / "precious.html").read_text() == "outside --out"


@pytest.mark.parametrize("command", [["run", "pendulum"], ["versions", "3.3.0"], ["sweep", "m", "--releases", "3.3.0"],
                                     ["zoo"]])
def test_an_empty_out_is_refused(tmp_path, no_run, capsys, monkeypatch, command):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "mine.html").write_text("x")
    with pytest.raises(SystemExit) as exc:
        cli.main([*command, "--out", ""])
    assert exc.value.code == 2 and "names no folder" in capsys.readouterr().err
    assert [p.name for p in tmp_path.iterdir()] == ["mine.html"]


def test_a_dangling_out_link_is_refused_before_the_run(tmp_path, no_run, capsys):
    (tmp_path / "R").symlink_to(tmp_path / "gone")
    assert _run(tmp_path / "R") == 2
    assert "does not exist" in capsys.readouterr().err


@pytest.mark.skipif(os.geteuid() != 0, reason="giving a folder to another user needs root")
def test_a_folder_of_another_user_is_refused_unless_forced(tmp_path):
    out = tmp_path / "R"
    out.mkdir()
    os.chown(out, 65534, 65534)
    with pytest.raises(ValueError, match="not your folder"):
        files.check_report_folder(out)
    assert files.check_report_folder(out, force=True) == out


def test_only_pages_an_earlier_run_wrote_unchanged_are_removed(tmp_path):
    out = tmp_path / "R"
    first = {out / "report.html": "r", out / "cases" / "a.html": "a", out / "cases" / "b.html": "b"}
    files.write_atomic(files.with_manifest(out, first))
    listed = json.loads((out / files.MANIFEST).read_text())["files"]
    assert listed["cases/a.html"] == hashlib.sha256(b"a").hexdigest() and set(listed) == {
        "report.html", "cases/a.html", "cases/b.html"}
    assert files.check_report_folder(out) == out  # a folder of its own run's files: accepted
    (out / "cases" / "b.html").write_text("edited by the user")
    (out / "cases" / "c.html").write_text("the user's own")
    second = {out / "report.html": "r2"}
    gone = files.superseded(out, second)
    assert gone == [out / "cases" / "a.html"]
    files.write_atomic(files.with_manifest(out, second), remove=gone)
    assert not (out / "cases" / "a.html").exists()
    assert (out / "cases" / "b.html").read_text() == "edited by the user"
    assert (out / "cases" / "c.html").read_text() == "the user's own"


def test_a_failed_run_marks_stale_only_its_own_files(tmp_path, capsys):
    out = tmp_path / "R"
    files.write_atomic(files.with_manifest(out, {out / "report.html": "ours"}))
    (out / "summary.md").write_text("the user's")
    assert cli.main(["run", "no-such-case", "--out", str(out), "--force-out"]) == 2
    assert (out / "report.html.stale").read_text() == "ours"
    assert (out / "summary.md").read_text() == "the user's"


def test_a_manifest_naming_files_outside_the_folder_is_ignored(tmp_path):
    outside = tmp_path / "outside.html"
    outside.write_text("x")
    out = tmp_path / "R"
    out.mkdir()
    digest = hashlib.sha256(b"x").hexdigest()
    (out / files.MANIFEST).write_text(json.dumps({"files": {"../outside.html": digest, str(outside): digest}}))
    assert files.ours(out) == [] and files.report_pages(out) == []


@pytest.mark.parametrize("command", [["versions", "4.0.0"], ["sweep", "dm_control/acrobot", "--releases", "4.0.0"],
                                     ["zoo", "dm_control/acrobot"]])
def test_every_command_that_writes_a_folder_refuses_one_holding_the_users_files(command, tmp_path, capsys):
    """versions, sweep and zoo wrote their files over a user's of the same name: each now judges --out as run does,
    before any environment is built or model judged, and the user's files stay as they were."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "zoo.md").write_text("mine")
    (out / "sweep.md").write_text("mine")
    (out / "versions.txt").write_text("mine")
    before = _tree(out)
    assert cli.main([*command, "--out", str(out)]) == 2
    assert "holds files no earlier mjharness run wrote there" in capsys.readouterr().err
    assert _tree(out) == before


def test_a_zoo_table_beside_a_report_keeps_both_the_runs_own(tmp_path):
    """A zoo --folder written into a report's folder, then the report again: neither refuses the other's files,
    and a user's file beside them is still refused."""
    root = tmp_path / "robots" / "acme"
    root.mkdir(parents=True)
    root.joinpath("scene.xml").write_text(
        "<mujoco model='acme'><worldbody><body><joint axis='0 1 0' damping='0.1'/>"
        "<geom type='capsule' fromto='0 0 0 0.3 0 0' size='0.03'/></body></worldbody></mujoco>")
    out = tmp_path / "out"
    assert _run(out) == 0
    assert cli.main(["zoo", "--folder", str(tmp_path / "robots"), "--integrators", "RK4", "--out", str(out)]) == 0
    assert _run(out) == 0
    assert (out / "zoo.md").is_file() and (out / "report.html").is_file()
    (out / "notes.txt").write_text("mine")
    assert _run(out) == 2 and (out / "notes.txt").read_text() == "mine"

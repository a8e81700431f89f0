"""The CLI: exit codes 0 / 1 / 2, one-line errors, complete reports or none."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from harness.cli import main

CASE = "pendulum"


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "harness.cli", *args], capture_output=True,
                          text=True, timeout=300)


def test_list_names_every_case(capsys):
    from harness import cases

    assert main(["list"]) == 0
    out = capsys.readouterr().out
    assert all(name in out for name in cases.names())


def test_check_passes_and_prints_each_figure_beside_its_threshold(capsys, config):
    assert main(["check", CASE]) == 0
    out = capsys.readouterr().out
    for name, limit in config.for_case(CASE).items():
        assert any(name in line and f"{limit:.3e}" in line for line in out.splitlines())
    assert "0 failed" in out


def test_check_fails_with_exit_1_when_a_threshold_is_tightened(tmp_path):
    strict = tmp_path / "strict.toml"
    strict.write_text(f'[thresholds.{CASE}]\n"RK4.position" = 1e-12\n')
    proc = _run("check", CASE, "--config", str(strict))
    assert proc.returncode == 1
    assert "FAIL" in proc.stdout and "Traceback" not in proc.stderr


@pytest.mark.parametrize("args, needle", [
    (["check", "nosuchcase"], "known cases"),
    (["run", "nosuchcase"], "known cases"),
    (["frobnicate"], "invalid choice"),
    (["check", CASE, "--config", "/nonexistent.toml"], "cannot read config"),
])
def test_bad_usage_exits_2_with_one_line(args, needle):
    proc = _run(*args)
    assert proc.returncode == 2
    assert needle in proc.stderr
    assert "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("text, needle", [
    ("[thresholds.pendulum]\n\"RK4.position\" = -1\n", "positive number"),
    ("[thresholds.pendulum]\n\"RK4.nonsense\" = 1\n", "unmeasured figure"),
    ("[thresholds.nosuchcase]\n\"RK4.position\" = 1\n", "unknown case"),
    ("[colours]\nred = 1\n", "unknown key"),
    ("this is = not [toml", "not valid TOML"),
])
def test_bad_config_exits_2(tmp_path, text, needle):
    cfg = tmp_path / "bad.toml"
    cfg.write_text(text)
    proc = _run("check", CASE, "--config", str(cfg))
    assert proc.returncode == 2, proc.stdout
    assert needle in proc.stderr and "Traceback" not in proc.stderr


def test_run_writes_complete_deterministic_report(tmp_path):
    out1, out2 = tmp_path / "a", tmp_path / "b"
    assert main(["run", CASE, "--out", str(out1)]) == 0
    assert main(["run", CASE, "--out", str(out2)]) == 0
    names = sorted(p.name for p in out1.iterdir())
    assert names == ["report.html", "report.json", "summary.md"]
    for name in names:
        assert (out1 / name).read_bytes() == (out2 / name).read_bytes(), name
    doc = json.loads((out1 / "report.json").read_text())
    assert doc["cases"][CASE]["checks"]["RK4.position"]["passed"] is True
    page = (out1 / "report.html").read_text()
    assert "http://" not in page and "https://" not in page  # self-contained
    assert page.count("data:image/png;base64,") >= 4


def test_unwritable_output_exits_2_and_writes_nothing(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    proc = _run("run", CASE, "--out", str(blocker / "sub"))
    assert proc.returncode == 2 and "output directory" in proc.stderr

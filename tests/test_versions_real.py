"""``mjharness versions`` for real: two MuJoCo releases from the package index, each in an environment uv
builds, on the case whose physics changed between them (slow: minutes cold, the downloads included).

MuJoCo 4.0.0 fixed RK4 on ball joints (changelog 4.0.0: the Runge-Kutta-Munthe-Kaas correction; before
it, orientations converge at 2nd order). On ``spherical_pendulum_ball`` the tool must find, on its own:
the known defect's check flipping to pass at 4.0.0, and the RK4 figures falling by decades beyond their
noise; and it must not report the Euler-family figures, which the fix does not touch, as moved.

Skipped, with the reason printed, only when the package index cannot be reached.
"""

from __future__ import annotations

import json

import pytest

from harness.cli.commands import main
from harness.versions import envs, releases

pytestmark = pytest.mark.slow
CASE = "spherical_pendulum_ball"


def test_two_real_releases_show_the_rk4_ball_joint_fix_and_nothing_else(tmp_path, monkeypatch, capsys):
    try:
        offered = releases.pip_index_versions()
    except ValueError as exc:
        pytest.skip(f"the package index cannot be reached: {exc}")
    assert {"3.3.0", "4.0.0"} <= set(offered)
    monkeypatch.setattr(envs, "envs_root", lambda: tmp_path / "envs")  # built here, not in the user's cache
    out = tmp_path / "out"
    code = main(["versions", "3.3.0", "4.0.0", "--out", str(out), "--no-plots", "--", "--case", CASE])
    text = capsys.readouterr().out
    assert code == 0, text
    doc = json.loads((out / "versions.json").read_text())
    assert [r["versions"]["mujoco"] for r in doc["runs"]] == ["3.3.0", "4.0.0"]  # each environment's own MuJoCo
    flips = [(c["figure"], c["status_old"], c["status_new"]) for c in doc["changes"] if c["kind"] == "flip"]
    assert flips == [("converge.RK4.order_shortfall", "FAIL (known defect)", "pass")]
    moved = {c["figure"]: c for c in doc["changes"] if c["kind"] == "moved"}
    assert moved["RK4.position"]["release"] == "4.0.0" and moved["RK4.position"]["size_decades"] > 4
    assert not [f for f in moved if f.startswith(("Euler.", "implicitfast.", "instant."))], sorted(moved)
    assert f"{CASE} converge.RK4.order_shortfall: FAIL (known defect) -> pass" in text

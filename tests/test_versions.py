"""``mjharness versions``: the machinery on fake environments (tests/fake_uv.py stands in for uv and for each
environment's check; no network, no second MuJoCo), the noise rule on both sides of its factor, the
bisection's economy, and ``check --perturb`` on a real case.

The one real run (two MuJoCo releases from the package index) is tests/test_versions_real.py.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from harness.cli.commands import main
from harness.core.options import RunOptions
from harness.versions import changes, envs, releases
from harness.versions.bisect import Target, bisect, differs, parse_target
from harness.versions.changes import NOISE_FACTOR, ULP_FLOOR, Snapshot, compare, moved, noise
from harness.versions.envs import Builder, EnvSpec
from harness.versions.releases import Release, parse_selection, releases_between
from harness.versions.runs import CheckCommand, run_releases

FAKE = Path(__file__).with_name("fake_uv.py")
BALL = "spherical_pendulum_ball"
INDEX = ["4.0.0", "3.17.0", "3.9.0", "3.8.1", "3.4.0", "3.3.1", "3.3.0", "3.2.7", "3.4.0rc1", "2.3.1.post1"]


# ------------------------------------------------------------------ releases
def test_a_range_is_every_final_release_the_index_offers_between_its_ends():
    got = releases_between("3.3.0", "3.9.0", index=lambda: INDEX)
    assert [str(r) for r in got] == ["3.3.0", "3.3.1", "3.4.0", "3.8.1", "3.9.0"]  # no rc, nothing outside
    assert [str(r) for r in parse_selection(["4.0.0", "3.3.0..3.3.1", "3.3.1"], index=lambda: INDEX)] == \
        ["3.3.0", "3.3.1", "4.0.0"]


@pytest.mark.parametrize("tokens, needle", [
    (["3.3.0..3.5.0"], "offers no MuJoCo 3.5.0"),
    (["3.9.0..3.3.0"], "runs backwards"),
    (["3.2.7", "4.0.0"], "older than the oldest"),
    (["4.0.0"], "at least two"),
    (["4.0"], "not a MuJoCo release number"),
])
def test_bad_selections_are_one_line_errors(tokens, needle):
    with pytest.raises(ValueError, match=needle):
        parse_selection(tokens, index=lambda: INDEX)


def test_the_index_is_read_from_pips_answer(monkeypatch):
    class Done:
        returncode, stderr = 0, ""
        stdout = "mujoco (4.0.0)\nAvailable versions: 4.0.0, 3.17.0, 3.3.0\n  INSTALLED: 4.0.0\n"

    monkeypatch.setattr(releases.subprocess, "run", lambda *a, **k: Done())
    assert releases.pip_index_versions() == ["4.0.0", "3.17.0", "3.3.0"]
    Done.stdout, Done.stderr = "", "ERROR: Could not find a version that satisfies the requirement mujoco"
    with pytest.raises(ValueError, match=r"cannot ask the package index.*Could not find"):
        releases.pip_index_versions()


def test_releases_order_by_number_not_text():
    assert Release("3.10.0") > Release("3.9.0") and sorted([Release("3.17.0"), Release("3.3.7")])[0] == Release("3.3.7")


# ------------------------------------------------------------------ noise and changes
def _doc(values: dict, statuses: dict | None = None) -> dict:
    cases: dict = {}
    for (case, figure), v in values.items():
        entry = cases.setdefault(case, {"figures": {}, "checks": {}})
        entry["figures"][figure] = {"value": v}
    for (case, figure), s in (statuses or {}).items():
        cases.setdefault(case, {"figures": {}, "checks": {}})["checks"][figure] = {"status": s, "passed": s == "pass"}
    return {"schema": 2, "cases": cases}


def _snap(release: str, values: dict, noises: dict, statuses: dict | None = None) -> Snapshot:
    doc = _doc(values, statuses)
    perturbed = [_doc({k: v + noises.get(k, 0.0) for k, v in values.items()}),
                 _doc({k: v - noises.get(k, 0.0) / 2 for k, v in values.items()})]
    return changes.snapshot(Release(release), doc, perturbed)


K = ("pendulum", "RK4.position")


def test_noise_is_the_largest_move_of_the_perturbed_runs_with_a_floor_of_a_few_ulps():
    snap = _snap("3.3.0", {K: 1.0, ("a", "RK4.velocity"): 2.0}, {K: 3e-9})
    assert snap.noise[K] == pytest.approx(3e-9)  # +3e-9 and -1.5e-9: the larger
    assert snap.noise[("a", "RK4.velocity")] == ULP_FLOOR * 2.0  # identical when perturbed: the floor
    lacking = noise(_doc({K: 1.0}), [_doc({})])
    assert math.isinf(lacking[K])  # a perturbed run without the figure: no noise can be claimed


@pytest.mark.parametrize("multiple, counted", [(NOISE_FACTOR / 2, False), (NOISE_FACTOR * 2, True)])
def test_a_change_counts_only_beyond_the_factor_times_the_noise(multiple, counted):
    """Both sides of the rule: half the factor (the largest move measured among unaffected figures, 3.5 ×,
    is below it) is noise; twice the factor is a change."""
    n = 1e-9
    a = _snap("3.3.0", {K: 1e-6}, {K: n})
    b = _snap("3.4.0", {K: 1e-6 + multiple * n}, {K: n / 3})
    found = compare(a, b)
    assert (len(found) == 1) is counted
    if counted:
        assert found[0].kind == "moved" and found[0].noise == pytest.approx(n)  # the larger of the two
        assert found[0].in_noise == pytest.approx(multiple, rel=1e-6)


def test_a_change_of_a_few_ulps_of_a_figure_noise_cannot_move_is_not_a_change():
    a = _snap("3.3.0", {K: 0.1}, {})
    b = _snap("3.4.0", {K: 0.1 * (1 + 2e-16)}, {})
    assert compare(a, b) == []
    assert moved(0.1, 0.1 * (1 + 1e-12), ULP_FLOOR * 0.1, ULP_FLOOR * 0.1)  # far above the floor: a change
    assert moved(math.nan, 1.0, 1.0, 1.0) and not moved(math.nan, math.nan, 1.0, 1.0)


def test_a_known_defect_fixed_is_a_flip_and_an_integrator_arriving_is_appeared():
    order = ("ball", "converge.RK4.order_shortfall")
    disc = ("ball", "discrete.position")
    a = _snap("3.17.0", {order: 1.99, disc: 1.0}, {}, {order: "FAIL (known defect)", disc: "n/a"})
    b = _snap("4.0.0", {order: 0.0, disc: 1.0}, {}, {order: "pass", disc: "pass"})
    kinds = {(c.figure, c.kind) for c in compare(a, b)}
    assert kinds == {(order[1], "flip"), (disc[1], "appeared")}
    c = _snap("4.1.0", {order: 0.0}, {}, {order: "FAIL"})
    assert [x.kind for x in compare(b, c) if x.figure == order[1]] == ["flip"]  # pass -> FAIL
    assert [x.kind for x in compare(b, c) if x.figure == disc[1]] == ["vanished"]


def test_changes_are_sorted_flips_first_then_by_the_factor_of_the_change():
    keys = [("c", f"RK4.f{i}") for i in range(3)]
    a = _snap("3.3.0", {keys[0]: 1.0, keys[1]: 1.0, keys[2]: 1.0}, {}, {keys[2]: "pass"})
    b = _snap("3.4.0", {keys[0]: 1.5, keys[1]: 1e-5, keys[2]: 1.0}, {}, {keys[2]: "FAIL"})
    c = _snap("3.5.0", {keys[0]: 1.5, keys[1]: 1e-5, keys[2]: 0.0}, {}, {keys[2]: "FAIL"})
    found = changes.changes([a, b, c])
    assert [(x.figure, x.kind, str(x.release)) for x in found] == [
        ("RK4.f2", "flip", "3.4.0"), ("RK4.f2", "moved", "3.5.0"), ("RK4.f1", "moved", "3.4.0"),
        ("RK4.f0", "moved", "3.4.0")]
    assert math.isinf(found[1].size) and found[2].size == pytest.approx(5)


# ------------------------------------------------------------------ bisection
def _line(n: int, at: int) -> list[Snapshot]:
    """n releases; the figure drops 100-fold from the ``at``-th on; noise 1e-12."""
    return [_snap(f"3.{i}.0", {K: 1e-6 if i < at else 1e-8}, {K: 1e-12}) for i in range(3, 3 + n)]


@pytest.mark.parametrize("n, at", [(24, 3 + 17), (24, 3 + 1), (24, 3 + 23), (2, 4), (9, 3 + 5)])
def test_bisection_finds_the_first_release_running_about_log2_of_them(n, at):
    snaps = _line(n, at)
    by = {s.release: s for s in snaps}
    result = bisect(Target(*K), [s.release for s in snaps], lambda r: by[r])
    assert result.first == Release(f"3.{at}.0") and result.before == Release(f"3.{at - 1}.0")
    assert len(result.visited) <= 2 + math.ceil(math.log2(n - 1))
    assert "first changed at MuJoCo" in result.text()


def test_bisection_reports_no_change_and_stops_on_a_release_that_cannot_run():
    snaps = [_snap(f"3.{i}.0", {K: 1e-6}, {K: 1e-12}) for i in range(3, 8)]
    by = {s.release: s for s in snaps}
    result = bisect(Target(*K), list(by), lambda r: by[r])
    assert result.first is None and len(result.visited) == 2 and "no change" in result.text()
    flipped = [_snap(f"3.{i}.0", {K: 1.0}, {}, {K: "pass" if i < 6 else "FAIL"}) for i in range(3, 9)]
    by = {s.release: s for s in flipped}
    assert bisect(Target(), list(by), lambda r: by[r]).first == Release("3.6.0")  # any verdict
    broken = bisect(Target(), list(by), lambda r: "no wheel" if r == Release("3.5.0") else by[r])
    assert broken.errors == ((Release("3.5.0"), "no wheel"),) and "stopped" in broken.text()


def test_bisect_target_parsing():
    assert parse_target("verdicts") == Target() and parse_target("pendulum:RK4.position") == Target(*K)
    with pytest.raises(ValueError, match="CASE:FIGURE"):
        parse_target("RK4.position")
    assert differs(Target(*K), _snap("3.3.0", {}, {}), _snap("3.4.0", {K: 1.0}, {}))  # appeared


# ------------------------------------------------------------------ environments (fake uv)
@pytest.fixture
def fake(tmp_path, monkeypatch):
    """A fake uv on PATH-free terms (its path given to the builder), its logs, and a world of figures."""
    uv = tmp_path / "uv"
    uv.write_text(f"#!/bin/sh\nexec {sys.executable} {FAKE} \"$@\"\n")
    uv.chmod(0o755)
    for var, name in (("FAKE_UV_LOG", "uv.log"), ("FAKE_CHECK_LOG", "check.log"), ("FAKE_WORLD", "world.json")):
        monkeypatch.setenv(var, str(tmp_path / name))
        (tmp_path / name).touch()
    source = tmp_path / "src"
    for package in envs.SOURCE_PACKAGES:
        (source / package).mkdir(parents=True)
        (source / package / "__init__.py").write_text(f"# {package}\n")
    (source / "pyproject.toml").write_text("[project]\nname = 'mjharness'\n")
    world = {
        "values": {"spherical_pendulum_ball/RK4.position": {"3.3.0": 1e-6, "3.4.0": 1e-6, "4.0.0": 1.5e-11},
                   "spherical_pendulum_ball/converge.RK4.order_shortfall": {"3.3.0": 1.99, "3.4.0": 1.99, "4.0.0": 0.0},
                   "spherical_pendulum_ball/discrete.position": {"3.4.0": 0.01, "4.0.0": 0.01},
                   "pendulum/RK4.position": {"3.3.0": 6.5e-8, "3.4.0": 6.5e-8 + 2e-21, "4.0.0": 6.5e-8 + 3e-21}},
        "status": {"spherical_pendulum_ball/converge.RK4.order_shortfall": {"3.3.0": "FAIL (known defect)",
                                                          "3.4.0": "FAIL (known defect)", "4.0.0": "pass"},
                   "spherical_pendulum_ball/RK4.position": {"3.3.0": "pass", "3.4.0": "pass", "4.0.0": "pass"}},
        "noise": {"spherical_pendulum_ball/RK4.position": 1e-13, "pendulum/RK4.position": 1e-21},
    }
    (tmp_path / "world.json").write_text(json.dumps(world))
    return {"uv": str(uv), "root": tmp_path / "envs", "source": source, "tmp": tmp_path}


def _calls(path: Path) -> list:
    return [json.loads(line) for line in path.read_text().splitlines()]


def _run(fake, release_texts, *, args=(), parallel=2, extras=()):
    builder = Builder(uv=fake["uv"], root=fake["root"], source=fake["source"])
    specs = [EnvSpec(Release(r), tuple(extras), ("numpy==2.4.6",)) for r in release_texts]
    command = CheckCommand(args=tuple(args), jobs=1, cwd=fake["tmp"])
    digest = envs.source_hash(fake["source"])
    return run_releases(builder, specs, digest, command, parallel=parallel)


def test_environments_are_built_once_and_reused_and_rebuilt_only_in_the_harness(fake):
    runs = _run(fake, ["3.3.0", "4.0.0"], extras=("mujoco-mjx=={version}",))
    assert all(r.ok and r.env_built for r in runs)
    uv_calls = _calls(fake["tmp"] / "uv.log")
    assert sum(c[0] == "build" for c in uv_calls) == 1  # one wheel for both
    assert sum(c[0] == "venv" for c in uv_calls) == 2
    installs = [c for c in uv_calls if c[:2] == ["pip", "install"]]
    assert {tuple(c[-3:]) for c in installs} == {("mujoco==3.3.0", "numpy==2.4.6", "mujoco-mjx==3.3.0"),
                                                 ("mujoco==4.0.0", "numpy==2.4.6", "mujoco-mjx==4.0.0")}
    again = _run(fake, ["3.3.0", "4.0.0"], extras=("mujoco-mjx=={version}",))
    assert all(r.ok and not r.env_built for r in again)
    assert len(_calls(fake["tmp"] / "uv.log")) == len(uv_calls)  # nothing built, nothing installed
    (fake["source"] / "harness" / "__init__.py").write_text("# changed\n")
    third = _run(fake, ["3.3.0"], extras=("mujoco-mjx=={version}",))
    new = _calls(fake["tmp"] / "uv.log")[len(uv_calls):]
    assert third[0].ok and not third[0].env_built
    # the harness reinstalled, with what its new source depends on, the environment's release and pins held
    assert [c[0] for c in new] == ["build", "pip"] and "--reinstall-package" in new[1]
    assert tuple(new[1][-3:]) == ("mujoco==3.3.0", "numpy==2.4.6", "mujoco-mjx==3.3.0")


def test_each_release_runs_the_check_as_asked_and_twice_perturbed(fake):
    runs = _run(fake, ["3.3.0", "4.0.0"], args=("--case", "spherical_pendulum_ball", "--mjcf", "my.xml"))
    calls = _calls(fake["tmp"] / "check.log")
    assert len(calls) == 6 and {c["cwd"] for c in calls} == {str(fake["tmp"])}
    for c in calls:
        assert c["argv"][:6] == ["-P", "-m", "harness", "check", "--json", "--jobs"]
        assert c["argv"][7:11] == ["--case", "spherical_pendulum_ball", "--mjcf", "my.xml"]
    assert sorted(a for c in calls for a in c["argv"] if a.startswith("--perturb")) == \
        ["--perturb=-1e-15"] * 2 + ["--perturb=1e-15"] * 2
    assert set(runs[0].noise) == {1e-15, -1e-15}


def test_a_release_that_cannot_be_installed_or_checked_is_an_error_line_not_a_crash(fake, monkeypatch):
    monkeypatch.setenv("FAKE_UV_FAIL", "3.4.0")
    world = json.loads((fake["tmp"] / "world.json").read_text())
    world["exit"] = {"4.0.0": 2}
    world["crash"] = ["3.3.0"]
    (fake["tmp"] / "world.json").write_text(json.dumps(world))
    runs = _run(fake, ["3.3.0", "3.4.0", "4.0.0"])
    assert [r.ok for r in runs] == [False, False, False]
    assert runs[0].error == ("check --json on MuJoCo 3.3.0 exited 1 with no run document: TypeError: mj_fullM(): "
                             "incompatible function arguments")
    assert "no wheel for mujoco==3.4.0" in runs[1].error
    assert "exited 2: mjharness: error: unknown case 'nope'" in runs[2].error
    monkeypatch.delenv("FAKE_UV_FAIL")
    retry = _run(fake, ["3.4.0"])
    assert retry[0].ok and retry[0].env_built  # the half-built folder had no "complete" marker: built again


# ------------------------------------------------------------------ the command
@pytest.fixture
def command(fake, monkeypatch):
    monkeypatch.setattr(envs, "find_uv", lambda: fake["uv"])
    monkeypatch.setattr(envs, "source_root", lambda: fake["source"])
    monkeypatch.setattr(envs, "envs_root", lambda: fake["root"])
    index = {"mujoco": ["4.0.0", "3.4.0", "3.3.0"], "mujoco-mjx": ["3.3.0", "3.3.0rc1"]}  # no mjx 3.4.0, 4.0.0
    monkeypatch.setattr(releases, "pip_index_versions", lambda package="mujoco": index[package])
    monkeypatch.chdir(fake["tmp"])
    return fake


def test_versions_reports_the_flip_the_move_and_the_arrival_and_not_the_roundoff(command, capsys):
    out = command["tmp"] / "out"
    code = main(["versions", "3.3.0..4.0.0", "--out", str(out), "--", "--case", BALL, "--case", "pendulum"])
    text = capsys.readouterr().out
    assert code == 0, text
    assert "3 of 3 release(s) run (3.3.0, 3.4.0, 4.0.0)" in text
    assert (f"1 verdict flip(s):\n  4.0.0 (since 3.4.0)  {BALL} converge.RK4.order_shortfall: FAIL (known defect) "
            "-> pass") in text
    assert "4.0.0 (since 3.4.0)  spherical_pendulum_ball RK4.position: 1e-06 -> 1.5e-11" in text
    assert "appeared: 1 figure(s) of discrete in 1 case(s) (spherical_pendulum_ball)" in text
    doc = json.loads((out / "versions.json").read_text())
    assert not any(c["case"] == "pendulum" for c in doc["changes"])  # 2e-21 and 1e-21 against a noise of 1e-21
    assert doc["releases"] == ["3.3.0", "3.4.0", "4.0.0"]
    assert doc["figures"]["pendulum"]["RK4.position"]["values"][1] == pytest.approx(6.5e-8)
    assert {c["kind"] for c in doc["changes"]} == {"flip", "moved", "appeared"}
    page = (out / "versions.html").read_text()
    assert f"{BALL} RK4.position" in page and page.count("<img") == 2  # the two changed figures, plotted
    assert (out / "versions.txt").read_text() == text.split("wrote ")[0]


def test_versions_bisects_installing_only_what_it_needs(command, capsys):
    out = command["tmp"] / "out"
    code = main(["versions", "3.3.0..4.0.0", "--bisect", "spherical_pendulum_ball:RK4.position", "--out", str(out)])
    text = capsys.readouterr().out
    assert code == 0 and f"bisect {BALL} RK4.position: first changed at MuJoCo 4.0.0 (after 3.4.0)" in text
    checks = _calls(command["tmp"] / "check.log")
    assert {tuple(c["argv"][7:9]) for c in checks} == {("--case", "spherical_pendulum_ball")}  # only the figure's case


@pytest.mark.parametrize("argv, needle", [
    (["versions", "3.3.0", "4.0.0", "--", "--bogus"], "not ones `mjharness check` takes here"),
    (["versions", "3.3.0", "4.0.0", "--", "--json"], "need no --json"),
    (["versions", "3.3.0", "4.0.0", "--backend", "bullet"], "unknown backend 'bullet' for versions; accepted: c, "
                                                            "mjx, mjx-f64"),
    (["versions", "3.4.0", "4.0.0", "--backend", "mjx"], "the package index has no mujoco-mjx of 3.4.0, 4.0.0 (it "
                                                         "offers 3.3.0)"),
    (["versions", "3.3.0", "4.0.0", "--bisect", "nope:RK4.position"], "unknown case"),
    (["versions", "3.3.0..3.5.0"], "offers no MuJoCo 3.5.0"),
])
def test_versions_refuses_bad_input_in_one_line_before_installing(command, capsys, argv, needle):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert needle in err and len(err.strip().splitlines()) == 1
    assert not (command["tmp"] / "uv.log").read_text()  # nothing built


def test_versions_backend_installs_its_packages_passes_the_flag_and_refuses_a_release_without_them(command,
                                                                                                  capsys):
    """``--backend mjx``: mujoco-mjx of the release and jax reach uv, ``--backend mjx`` reaches every check
    (the run as asked and the noise runs), and 4.0.0, of which the index has no mujoco-mjx, is one line of
    the report with nothing built for it (a pre-release of mujoco-mjx is no release of MuJoCo's number)."""
    out = command["tmp"] / "out"
    code = main(["versions", "3.3.0", "4.0.0", "--backend", "mjx", "--parallel", "1", "--out", str(out),
                 "--", "--case", "pendulum"])
    text = capsys.readouterr().out
    assert code == 1, text  # a release could not be run
    installs = [c for c in _calls(command["tmp"] / "uv.log") if c[:2] == ["pip", "install"]]
    assert [c[c.index("mujoco==3.3.0"):] for c in installs] == [["mujoco==3.3.0", *envs.pins(), "mujoco-mjx==3.3.0",
                                                                 "jax<0.8"]]
    assert not any("mujoco==4.0.0" in a for c in _calls(command["tmp"] / "uv.log") for a in c)  # nothing for 4.0.0
    checks = _calls(command["tmp"] / "check.log")
    assert len(checks) == 3 and {c["release"] for c in checks} == {"3.3.0"}
    assert all(c["argv"][7:11] == ["--case", "pendulum", "--backend", "mjx"] for c in checks), checks
    assert ("\nMuJoCo 4.0.0 could not be run: the package index has no mujoco-mjx 4.0.0 (it offers 3.3.0), which "
            "backend 'mjx' needs at the same release\n") in text
    assert "1 of 2 release(s) run" in text
    assert "extra packages: mujoco-mjx==3.3.0 jax<0.8\n" in text  # nothing of 4.0.0's
    # MJX steps in float32: its noise runs move the state by float32's round-off, not float64's
    assert sorted(a for c in checks for a in c["argv"] if a.startswith("--perturb")) == \
        ["--perturb=-5e-07", "--perturb=5e-07"]
    assert "moved by +5e-07, -5e-07 × max(|x|, 1)" in text
    assert json.loads((out / "versions.json").read_text())["noise"]["perturbations"] == [5e-7, -5e-7]


@pytest.mark.parametrize("backend, release, packages", [
    ("mjx", "3.6.0", ("mujoco-mjx==3.6.0", "jax<0.8")),  # calls jnp.clip(a_min=), which the newest jax lacks
    ("mjx-f64", "3.7.0", ("mujoco-mjx==3.7.0", "jax")),
    ("mjx", "3.17.0", ("mujoco-mjx==3.17.0", "jax")),
    ("c", "3.17.0", ()),
])
def test_a_backends_packages_follow_the_release(backend, release, packages):
    assert envs.backend_packages(backend, Release(release)) == packages


# ------------------------------------------------------------------ check --perturb, for real
def test_perturb_moves_figures_at_roundoff_and_no_further():
    from harness import cases
    from harness.families.bench import perturbed
    from harness.pipeline.run import run_case

    case = cases.get("spring")
    moved_case = perturbed(case, 1e-15)
    assert all(moved_case.q0[k] == v + 1e-15 * max(abs(v), 1) for k, v in case.q0.items())
    base = {f.name: f.value for f in run_case(case, RunOptions(integrators=["RK4"])).figures}
    other = {f.name: f.value for f in run_case(case, RunOptions(integrators=["RK4"], perturb=1e-15)).figures}
    assert base.keys() == other.keys()
    assert any(base[k] != other[k] for k in base)  # the rounding falls differently...
    for k in base:  # ...and moves no figure beyond the reference's own tolerance (rtol 1e-12) on a motion of
        assert abs(base[k] - other[k]) <= 1e-12 * max(abs(base[k]), 1.0), k  # unit scale (0.1 m, 1 m/s here)
    with pytest.raises(ValueError, match="nonzero finite"):
        perturbed(case, 0.0)


@pytest.mark.parametrize("size", ["0", "2e-6", "nan", "x"])
def test_check_perturb_takes_only_a_roundoff_sized_move(size, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["check", "spring", f"--perturb={size}"])
    assert exc.value.code == 2 and "nonzero number within ±1e-6" in capsys.readouterr().err


def test_the_noise_runs_move_the_state_by_a_few_units_of_the_backends_own_round_off():
    """A float32 backend casts the initial state to float32: a 1e-15 move vanishes there (every perturbed
    run the same bits, every noise its floor), 5e-7 (≈ 4.2 units of 2⁻²³) does not."""
    from harness.versions.runs import noise_runs

    assert noise_runs("float64") == (1e-15, -1e-15) and noise_runs("float32") == (5e-7, -5e-7)
    x = np.linspace(0.1, 3.0, 50)
    assert np.array_equal(np.float32(x * (1 + 1e-15)), np.float32(x))
    assert not np.any(np.float32(x * (1 + 5e-7)) == np.float32(x))
    assert 4 <= 5e-7 / np.finfo(np.float32).eps <= 5
    with pytest.raises(ValueError, match="unknown precision 'float16'; accepted: float64, float32"):
        noise_runs("float16")


# ------------------------------------------------------------ a regular install
def test_versions_builds_the_harness_from_a_regular_install(tmp_path):
    """After README's ``pip install .`` (no pyproject.toml beside the packages) ``versions`` refused: "installs
    the harness from its source tree … run it from a checkout". From a regular install it now makes a source
    tree of what is installed, with a pyproject.toml from the installed metadata, and builds with uv (the real
    one) a wheel holding exactly the installed files, the same entry points, so each environment gets the
    same harness."""
    import importlib.util
    import os
    import subprocess
    import zipfile

    root = Path(__file__).resolve().parent.parent
    venv = tmp_path / "venv"
    # pip install . into the venv: with this environment's pip where it has one (--python: installed there as the
    # venv's own pip would, without the seconds of bootstrapping one), else with the venv's own
    ours = importlib.util.find_spec("pip") is not None
    subprocess.run([sys.executable, "-m", "venv", *(["--without-pip"] if ours else []), str(venv)], check=True)
    installer = [sys.executable, "-m", "pip", "--python", str(venv / "bin" / "python")] if ours else \
        [str(venv / "bin" / "python"), "-m", "pip"]
    pip = subprocess.run([*installer, "install", "--quiet", "--no-deps", str(root)], capture_output=True, text=True,
                         timeout=600)
    if pip.returncode != 0:
        pytest.skip(f"pip cannot make a regular install here (no index?): {pip.stderr.strip().splitlines()[-1:]}")
    script = ("import sys; from harness.versions import envs; root = envs.source_root(); "
              "print(root); print(envs.Builder(uv=sys.argv[1], root=envs.envs_root(), "
              "source=root).wheel(envs.source_hash(root)))")
    uv = envs.find_uv()
    uv_cache = subprocess.run([uv, "cache", "dir"], capture_output=True, text=True, check=True).stdout.strip()
    environ = {**os.environ, "XDG_CACHE_HOME": str(tmp_path / "cache"), "UV_CACHE_DIR": uv_cache}  # uv's own cache
    environ.pop("PYTHONPATH", None)  # the installed copy, not a checkout
    done = subprocess.run([str(venv / "bin" / "python"), "-P", "-c", script, uv], capture_output=True,
                          text=True, timeout=600, cwd=tmp_path, env=environ)
    assert done.returncode == 0, done.stderr
    tree, wheel = (Path(line) for line in done.stdout.split())
    assert tree.is_relative_to(tmp_path / "cache" / "mjharness" / "versions" / "installed-source")
    site = next((venv / "lib").glob("python*/site-packages"))
    record = next(site.glob("mjharness-*.dist-info")) / "RECORD"
    installed = {line.split(",")[0] for line in record.read_text().splitlines()
                 if ".dist-info/" not in line and "__pycache__" not in line and not line.startswith("..")}
    with zipfile.ZipFile(wheel) as built:
        files = {n for n in built.namelist() if ".dist-info/" not in n}
        points = next(built.read(n).decode() for n in built.namelist() if n.endswith("entry_points.txt"))
    assert files == installed and any(f.endswith("mjcf/pendulum.xml") for f in files)
    assert "mjharness = harness.cli.entry:entry" in points and "mjharness = harness.pytest_plugin" in points


@pytest.mark.slow
def test_versions_judges_a_users_own_model_on_each_release(tmp_path, capsys):
    """Issue 30: ``versions … -- --mjcf FILE`` on a model no case describes (the case-free path: its own tree's
    reference on every release), here the 7-DoF arm of benchmarks/, on the oldest supported MuJoCo and 4.0.0:
    both run, the figures of the arm compared, and the integrator 4.0 added shown as arrived."""
    arm = Path(__file__).resolve().parent.parent / "benchmarks" / "models" / "arm7.xml"
    out = tmp_path / "out"
    code = main(["versions", "3.3.0", "4.0.0", "--out", str(out), "--no-plots", "--", "--mjcf", str(arm)])
    text = capsys.readouterr().out
    assert code == 0, text
    assert "2 of 2 release(s) run (3.3.0, 4.0.0)" in text and f"check options: --mjcf {arm}" in text
    doc = json.loads((out / "versions.json").read_text())
    assert list(doc["figures"]) == ["arm7"] and doc["releases"] == ["3.3.0", "4.0.0"]
    assert "appeared: 6 figure(s) of discrete in 1 case(s) (arm7)" in text

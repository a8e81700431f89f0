"""Limits as data: every case's limits ship with its model, each with its basis, and are found by every
kind of install; a user's config adds fixed limits (basis user) and requirements; ``mjharness limits
--write`` writes the file of a case that has none, by the default rule, and measures nothing into it."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from harness import cases
from harness.cli.commands import main
from harness.core.errors import ConfigError
from harness.pipeline import limits as lim
from harness.pipeline import matrix
from tests.conftest import shipped_run

ROOT = Path(__file__).resolve().parent.parent


THEORY = ("converge.", "reference.")  # the figures theory bounds whatever the case: an order, the reference


@pytest.mark.parametrize("name", cases.names())
def test_every_case_ships_its_limits_each_with_its_basis(name):
    """Every gated figure is judged by its budget (no number: the budget computes the limit for each run)
    or by a theory bound with its reason; nothing measured is stored in a limit."""
    case = cases.get(name)
    path = lim.limits_path(case.mjcf)
    assert path.is_file() and path.parent == case.mjcf.parent
    assert "measured" not in path.read_text().split("[limits]")[1]  # no measured number, no margin
    shipped = lim.read_case_limits(name, path)
    assert shipped.limits, f"{path} gates nothing"
    for figure, limit in shipped.limits.items():
        assert limit.basis in ("budget", "theory"), figure
        if limit.basis == "theory":
            assert figure.startswith(THEORY) and limit.reason and limit.value > 0, figure
        else:
            assert limit.value is None and not figure.startswith(THEORY), figure
    assert lim.load_limits().for_case(name) == dict(shipped.limits)


def test_no_limit_is_typed_into_pyproject():
    text = (ROOT / "pyproject.toml").read_text()
    assert "thresholds" not in text and "share/mjharness" not in text


def test_a_limits_file_reads_back_what_was_written(tmp_path):
    original = lim.CaseLimits("c", {
        "RK4.position": lim.Limit("budget"),
        "instant.forcing": lim.Limit("budget"),
        "converge.RK4.order_shortfall": lim.Limit("theory", 0.3, 'the fit\'s bias; "quoted" \\ and a backslash'),
    }, notes=("a note",))
    path = tmp_path / "c.limits.toml"
    path.write_text(lim.format_case_limits(original))
    assert lim.read_case_limits("c", path) == original


@pytest.mark.parametrize("text, needle", [
    ("[limits]\n'RK4' = { basis = 'budget' }", "malformed figure name"),
    ("[limits]\n'RK4.position' = { value = 1.0, basis = 'guess' }", "basis budget or theory"),
    ("[limits]\n'RK4.position' = { value = 1.0, basis = 'measured' }", "basis budget or theory"),
    ("[limits]\n'RK4.position' = { value = 1.0, basis = 'user' }", "basis budget or theory"),  # config only
    ("[limits]\n'RK4.position' = { value = 1e-7, basis = 'budget' }", "a budget limit has no value"),
    ("[limits]\n'RK4.position' = { value = -1.0, basis = 'theory', reason = 'r' }", "positive number"),
    ("[limits]\n'RK4.position' = { value = 1.0, basis = 'theory' }", "must say what bound it is"),
    ("[limits]\n'RK4.position' = { basis = 'budget', measured = 1.0 }", "unknown key"),
    ("[limits]\n'RK4.position' = 1e-7", "must be a table"),
    ("notes = []", r"no \[limits\] table"),
    ("notes = 'one'\n[limits]", "notes must be a list of strings"),
    ("[limits", "not valid TOML"),
])
def test_a_malformed_limits_file_is_a_one_line_error_naming_it(tmp_path, text, needle):
    path = tmp_path / "c.limits.toml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=needle) as err:
        lim.read_case_limits("c", path)
    assert str(path) in str(err.value) and "\n" not in str(err.value)


def test_a_new_case_gets_the_default_rule():
    """Gated: every instantaneous figure, per integrator the position, drifts, forces and conserved momenta,
    every convergence order, the reference's distance from the ODE (its residual where it has constraints);
    not the position at the horizon nor the velocity. A convergence order and the reference by theory, the
    rest by budget."""
    names = ["RK4.position", "RK4.position_final", "RK4.velocity", "RK4.drift.energy", "RK4.p_phi",
             "RK4.force.rod", "instant.kinematics", "converge.RK4.order_shortfall", "reference.residual",
             "reference.ode_vs_dae"]
    new = lim.default_limits("c", names, constrained=False)
    assert set(new.limits) == {"RK4.position", "RK4.drift.energy", "RK4.p_phi", "RK4.force.rod",
                               "instant.kinematics", "converge.RK4.order_shortfall", "reference.ode_vs_dae"}
    assert {k for k, v in new.limits.items() if v.basis == "theory"} == {"converge.RK4.order_shortfall",
                                                                         "reference.ode_vs_dae"}
    assert new.limits["converge.RK4.order_shortfall"].value == 0.3  # the fit's floor bias, ≤ 0.14, with margin
    assert new.limits["RK4.position"] == lim.Limit("budget")
    constrained = lim.default_limits("c", ["reference.residual"], constrained=True)
    assert constrained.limits["reference.residual"].basis == "theory"


def test_a_config_overrides_as_user_limits_and_states_requirements(tmp_path):
    config = tmp_path / "mine.toml"
    config.write_text('accept_known_defects = true\n[thresholds.pendulum]\n"RK4.position" = 1e-6\n'
                      '[require]\nposition = 1e-3\n"drift.energy" = 1e-4\n')
    loaded = lim.load_limits(config)
    limit = loaded.limit("pendulum", "RK4.position")
    assert (limit.basis, limit.value) == ("user", 1e-6) and str(config) in limit.reason
    assert loaded.limit("pendulum", "RK4.drift.energy") == lim.Limit("budget")  # the rest as shipped
    assert [(r.measure, r.value) for r in loaded.requirements] == [("position", 1e-3), ("drift.energy", 1e-4)]
    assert loaded.accept_known_defects is True and lim.load_limits().accept_known_defects is False
    for text, needle in [("accept_known_defects = 1\n", "must be true or false"),
                         ("[require]\nposition = 0\n", "position must be a positive number"),
                         ("require = 3\n", "'require' must be a table")]:
        config.write_text(text)
        with pytest.raises(ConfigError, match=needle):
            lim.load_limits(config)


def test_limits_lists_each_limit_with_its_basis(capsys, config):
    assert main(["limits", "pendulum"]) == 0
    lines = capsys.readouterr().out.splitlines()
    shipped = config.cases["pendulum"].limits
    assert lines[0].endswith(f"{len(shipped)} gated figures")
    for name, limit in shipped.items():
        (line,) = [ln for ln in lines if ln.split()[:1] == [name]]
        if limit.basis == "theory":
            assert f"{limit.value:.3e}" in line and "theory: " in line
        else:
            assert "budget: " in line and "e-" not in line.split("budget")[0]  # no number for a budget


def test_limits_write_writes_only_a_missing_file_and_measures_nothing_into_it(tmp_path, capsys, monkeypatch):
    """Every case has its file: --write leaves them as they are. A case without one gets one by the default
    rule, from a run's figure names only: budgets and theory bounds, no measured number."""
    before = {c.name: lim.limits_path(c.mjcf).read_bytes() for c in cases.all_cases()}
    assert main(["limits", "--write"]) == 0
    assert "nothing to rewrite" in capsys.readouterr().out
    assert {c.name: lim.limits_path(c.mjcf).read_bytes() for c in cases.all_cases()} == before

    real = lim.limits_path
    moved = tmp_path / "pendulum.limits.toml"
    monkeypatch.setattr(lim, "limits_path", lambda model: moved if Path(model).stem == "pendulum" else real(model))
    monkeypatch.setattr(matrix, "run_case", lambda case, options=None: shipped_run(case.name))
    assert main(["limits", "--write", "pendulum", "spring"]) == 0
    assert capsys.readouterr().out.strip() == f"wrote {moved}"
    written = lim.read_case_limits("pendulum", moved)
    assert written.limits and all(v.value is None for v in written.limits.values() if v.basis == "budget")
    assert "measured" not in moved.read_text().split("[limits]")[1]
    gated = {f.name for f in shipped_run("pendulum").figures} & set(written.limits)
    assert gated == set(written.limits) and "RK4.position" in gated and "RK4.velocity" not in gated


def _run(python: str, *args: str, **env: str) -> subprocess.CompletedProcess:
    return subprocess.run([python, *args], capture_output=True, text=True, check=False, cwd="/",
                          env={k: v for k, v in {**os.environ, **env}.items() if v is not None})


OURS = ("harness", "analytic", "mjcf", "mjharness")


def _dependencies_only(site_packages: str, tmp_path: Path) -> str:
    """A folder of links to the venv's packages without ours: PYTHONPATH comes before the user site, so
    where the venv holds a regular install of mjharness (CI's), the venv's copy would be found instead."""
    deps = tmp_path / "deps"
    deps.mkdir()
    for entry in Path(site_packages).iterdir():
        if not entry.name.startswith(OURS) and not entry.name.startswith("__editable__"):
            (deps / entry.name).symlink_to(entry)
    return str(deps)


FIND = ("from harness.pipeline.limits import load_limits, limits_path; from harness import cases; "
        "print(limits_path(cases.get('pendulum').mjcf)); print(len(load_limits().for_case('pendulum')))")


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["regular", "user"])
def test_an_installed_package_finds_its_limits(tmp_path, kind):
    """A regular (non-editable) and a --user install carry the limits as package data, beside the models
    (the limits used to ship as data-files under sys.prefix, which a --user install never found). pip
    builds the package as it would for a user (build isolation: it fetches setuptools)."""
    site_packages = next(p for p in sys.path if p.endswith("site-packages"))  # this venv's: numpy, mujoco, …
    if kind == "regular":
        python, pip, target = sys.executable, [], ["--target", str(tmp_path / "site")]
        env = {"PYTHONPATH": str(tmp_path / "site")}
    else:  # a venv has no user site: install for, and run, the interpreter the venv was made from
        python = str(Path(sys.base_prefix) / "bin" / Path(sys.executable).name)
        pip, target = ["--python", python], ["--user"]
        env = {"PYTHONUSERBASE": str(tmp_path / "user"), "PYTHONPATH": _dependencies_only(site_packages, tmp_path),
               "PYTHONNOUSERSITE": None}
    install = _run(sys.executable, "-m", "pip", *pip, "install", "--quiet", "--no-deps", *target, str(ROOT),
                   PIP_USER=None, **env)
    assert install.returncode == 0, install.stderr
    found = _run(python, "-c", FIND, **env)
    assert found.returncode == 0, found.stderr
    path, count = found.stdout.split()
    assert path.startswith(str(tmp_path)) and Path(path).is_file() and int(count) > 0

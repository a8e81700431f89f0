"""Limits as data: every case's limits ship with its model, each with its basis, and are found by every
kind of install; ``mjharness limits --write`` rewrites the measured ones and nothing else."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from harness import cases
from harness.core.errors import ConfigError
from harness.core.figures import Figure
from harness.pipeline import limits as lim

ROOT = Path(__file__).resolve().parent.parent


def _fig(name: str, value: float) -> Figure:
    return Figure(name, value, "1", "")


@pytest.mark.parametrize("name", cases.names())
def test_every_case_ships_its_limits_each_with_its_basis(name):
    case = cases.get(name)
    path = lim.limits_path(case.mjcf)
    assert path.is_file() and path.parent == case.mjcf.parent
    shipped = lim.read_case_limits(name, path)
    assert shipped.limits, f"{path} gates nothing"
    for figure, limit in shipped.limits.items():
        assert limit.basis in ("theory", "measured"), figure
        if limit.basis == "theory":
            assert limit.reason, f"{figure}: a theory limit must say what bound it is"
        else:  # Limit() itself refuses a value below measured × margin
            assert limit.value >= limit.measured * limit.margin * (1 - 1e-9)
    assert lim.load_limits().for_case(name) == {k: v.value for k, v in shipped.limits.items()}


def test_no_limit_is_typed_into_pyproject():
    text = (ROOT / "pyproject.toml").read_text()
    assert "thresholds" not in text and "share/mjharness" not in text


def test_a_limits_file_reads_back_what_was_written(tmp_path):
    original = lim.CaseLimits("c", {
        "RK4.position": lim.Limit(4e-8, "measured", "why", measured=1.3e-8, margin=3.0),
        "instant.forcing": lim.Limit(1e-12, "theory", 'round-off; "quoted" \\ and a backslash'),
    }, notes=("a note",))
    path = tmp_path / "c.limits.toml"
    path.write_text(lim.format_case_limits(original))
    assert lim.read_case_limits("c", path) == original


@pytest.mark.parametrize("text, needle", [
    ("[limits]\n'RK4' = { value = 1.0, basis = 'theory' }", "malformed figure name"),
    ("[limits]\n'RK4.position' = { value = 1.0, basis = 'guess' }", "basis theory or measured"),
    ("[limits]\n'RK4.position' = { value = -1.0, basis = 'theory' }", "positive number"),
    ("[limits]\n'RK4.position' = { value = 1.0, basis = 'measured', measured = 1.0, margin = 3.0 }",
     "≥ measured × margin"),
    ("[limits]\n'RK4.position' = { value = 1.0, basis = 'theory', typo = 1 }", "unknown key"),
    ("notes = []", r"no \[limits\] table"),
    ("[limits", "not valid TOML"),
])
def test_a_malformed_limits_file_is_a_one_line_error_naming_it(tmp_path, text, needle):
    path = tmp_path / "c.limits.toml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=needle) as err:
        lim.read_case_limits("c", path)
    assert str(path) in str(err.value) and "\n" not in str(err.value)


def test_rewriting_changes_measured_limits_only():
    old = lim.CaseLimits("c", {
        "RK4.position": lim.Limit(4e-8, "measured", "kept", measured=1.3e-8, margin=3.0),
        "instant.forcing": lim.Limit(1e-12, "theory", "round-off"),
        "discrete.position": lim.Limit(1e-3, "measured", "", measured=4e-4, margin=2.5),
    }, notes=("n",))
    new = lim.remeasured("c", old, [_fig("RK4.position", 2e-8), _fig("instant.forcing", 5e-13)],
                         constrained=False, skip=["discrete.position"])
    assert new.limits["RK4.position"] == lim.Limit(6e-8, "measured", "kept", measured=2e-8, margin=3.0)
    assert new.limits["instant.forcing"] == old.limits["instant.forcing"]  # theory: untouched
    assert new.limits["discrete.position"] == old.limits["discrete.position"]  # not measured here: kept
    assert new.notes == ("n",)
    with pytest.raises(ValueError, match="was not measured"):
        lim.remeasured("c", old, [_fig("instant.forcing", 1.0)], constrained=False)


def test_a_new_case_gets_the_default_rule():
    figures = [_fig("RK4.position", 1e-7), _fig("RK4.position_final", 1e-8), _fig("RK4.velocity", 1e-6),
               _fig("RK4.drift.energy", 1e-10), _fig("RK4.p_phi", 2e-11), _fig("instant.kinematics", 2e-16),
               _fig("converge.RK4.order_shortfall", 0.02), _fig("reference.residual", 0.0),
               _fig("reference.ode_vs_dae", 1e-12)]
    new = lim.remeasured("c", None, figures, constrained=False)
    assert set(new.limits) == {"RK4.position", "RK4.drift.energy", "RK4.p_phi", "instant.kinematics",
                               "converge.RK4.order_shortfall", "reference.ode_vs_dae"}
    assert new.limits["RK4.position"].value == 3e-7 and new.limits["RK4.position"].margin == lim.DEFAULT_MARGIN
    assert new.limits["instant.kinematics"].value == lim.ROUNDOFF_FLOOR  # 6e-16 would be round-off noise
    assert new.limits["converge.RK4.order_shortfall"].basis == "theory"
    assert new.limits["converge.RK4.order_shortfall"].value == 0.3
    constrained = lim.remeasured("c", None, [_fig("reference.residual", 1e-13)], constrained=True)
    assert "reference.residual" in constrained.limits


@pytest.mark.parametrize("value, expected", [(2.002e-3, 2.1e-3), (3e-3, 3e-3), (1.2000000000000002e-4, 1.2e-4),
                                             (9.8e-9, 9.8e-9), (9.81e-9, 9.9e-9)])
def test_limits_round_up_to_two_digits(value, expected):
    assert lim.round_up(value) == expected


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

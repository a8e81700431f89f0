"""The type check CI runs (``.ci/run``'s mypy stage, configured in pyproject's ``[tool.mypy]``) stays a check:
it covers every package, silences only third-party modules that ship no hints, by name, and every ``# type:
ignore`` in the package names the error it silences. (CI's stage runs mypy itself; this pins what it runs.)"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("harness", "analytic", "mjcf")
SILENCING = ("ignore_errors", "ignore_missing_imports", "follow_imports", "disable_error_code")


def _mypy() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["mypy"]


def test_mypy_checks_every_package_and_silences_nothing_globally():
    config = _mypy()
    assert sorted(config["packages"]) == sorted(PACKAGES)
    assert not set(config) & set(SILENCING), "a global setting that silences errors"
    assert config.get("warn_unused_ignores") is True  # an ignore that no longer silences anything is reported


def test_only_third_party_modules_skip_their_imports():
    for override in _mypy().get("overrides", []):
        assert set(override) <= {"module", "ignore_missing_imports"}, override
        modules = override["module"] if isinstance(override["module"], list) else [override["module"]]
        ours = [m for m in modules if m.split(".")[0] in PACKAGES]
        assert not ours, f"our own modules must be checked, not skipped: {ours}"


def test_ci_runs_mypy_in_its_venv_after_ruff():
    script = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    ruff, mypy = script.index("stage ruff"), script.index("stage mypy")
    assert ruff < mypy < script.index("stage tests")
    assert ".ci-venv/bin/python -m mypy\n" in script[mypy:]
    extra = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]["optional-dependencies"]
    assert any(re.match(r"mypy\b", d) for d in extra["test"]), "CI's venv installs the test extra"


def test_every_ignore_names_its_error_code():
    bare = [f"{path.relative_to(ROOT)}:{n}" for package in PACKAGES for path in sorted((ROOT / package).rglob("*.py"))
            for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
            if re.search(r"#\s*type:\s*ignore(?!\[)", line)]
    assert not bare, f"a blanket '# type: ignore' (name the error code: ignore[CODE]): {bare}"

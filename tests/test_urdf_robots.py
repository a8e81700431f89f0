"""Real robots' URDFs against MuJoCo's own import of them, and Pinocchio's MJCF parser over the zoo and the shipped
cases: what docs/findings/urdf.md reports (slow: `pytest -m slow tests/test_urdf_robots.py`)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

pytest.importorskip("pinocchio")
ROOT = Path(__file__).resolve().parents[1]
spec = importlib.util.spec_from_file_location("urdf_robots", ROOT / "benchmarks" / "urdf_robots.py")
robots = importlib.util.module_from_spec(spec)
spec.loader.exec_module(robots)


@pytest.mark.slow
def test_the_findings_table_is_what_the_robots_give():
    names = [name for name, _ in robots.robots()]
    if len(names) < 3:
        pytest.skip("needs pip install 'mjharness[robots]'")
    page = (ROOT / "docs" / "findings" / "urdf.md").read_text()
    for row in robots.urdf_rows()[2:]:
        assert row in page, row


@pytest.mark.slow
def test_the_parser_table_is_what_the_parser_gives():
    page = (ROOT / "docs" / "findings" / "urdf.md").read_text()
    for row in robots.parser_rows()[2:]:
        if row.startswith("| mjcf/"):
            assert row in page, row

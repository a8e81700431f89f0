"""The backends side by side (``mjharness run --backend c,mjx,warp``): each backend's run comes back from its
own process with its cases, the report shows every gated figure per backend with an error-vs-time plot per
case, and a finding is a figure a backend fails where the C engine passes it — not one both fail.

The accelerated backends themselves are exercised end to end in tests/test_backend_warp.py (slow); here the
second backend is the C engine again, or a copy of its checks with one figure broken, so these run anywhere.
"""

from __future__ import annotations

import dataclasses
import json

import pytest

from harness import cases
from harness.core.options import RunOptions
from harness.outputs.backends import BackendRun, findings, side_by_side_html, side_by_side_json
from harness.pipeline.entry import evaluate_backends

SHORT = RunOptions(horizon=0.02, integrators=("RK4",))


@pytest.fixture(scope="module")
def pair():
    """symmetric_top (its system holds a closure, which does not pickle) and pendulum, each run on 'c' in a
    backend process of its own, as ``run --backend all`` runs every backend."""
    selected = [cases.get("symmetric_top"), cases.get("pendulum")]
    return selected, evaluate_backends(selected, None, SHORT, ["c"])


def test_each_backends_run_comes_back_with_its_cases_references_and_runs(pair):
    selected, out = pair
    [(name, results, checks)] = out
    assert name == "c"
    assert [r.case.name for r in results] == [c.name for c in selected]
    assert set(checks) == {c.name for c in selected}
    for r in results:
        assert r.reference is not None and sorted(r.simulations) == ["RK4"]


def _broken(run: BackendRun, case: str, figure: str, *, name: str) -> BackendRun:
    """``run`` renamed, with ``figure`` of ``case`` at ten times its limit."""
    def breaking(check):
        if str(check.name) != figure:
            return check
        return dataclasses.replace(check, budget=dataclasses.replace(check.budget,
                                                                     unexplained=10 * check.budget.limit))
    checks = {c: [breaking(k) for k in ks] if c == case else list(ks) for c, ks in run.checks.items()}
    return BackendRun(name, "float32", run.results, checks)


def _runs(pair) -> tuple[BackendRun, str]:
    _, [(name, results, checks)] = pair
    c_run = BackendRun(name, "float64", results, checks)
    figure = next(str(k.name) for k in checks["pendulum"] if k.budget is not None and k.passed
                  and str(k.name).startswith("RK4."))
    return c_run, figure


def test_a_backend_failing_what_c_passes_is_a_finding_and_what_both_fail_is_not(pair):
    c_run, figure = _runs(pair)
    assert findings([c_run, c_run]) == []
    found = findings([c_run, _broken(c_run, "pendulum", figure, name="warp")])
    assert [(f.backend, f.case, f.figure, f.reference_verdict) for f in found] == [
        ("warp", "pendulum", figure, "pass")]
    both = _broken(c_run, "pendulum", figure, name="c")
    assert findings([both, _broken(c_run, "pendulum", figure, name="warp")]) == []


def test_the_section_shows_every_figure_per_backend_a_plot_per_case_and_the_findings(pair):
    c_run, figure = _runs(pair)
    warp = _broken(c_run, "pendulum", figure, name="warp")
    page = side_by_side_html([c_run, warp])
    assert "Backends side by side" in page and "<th>c</th><th>warp</th>" in page
    for case, checks in c_run.checks.items():
        assert f"<h3>{case}</h3><img alt='{case} error vs time per backend'" in page
        for k in checks:
            assert f"<tr><td>{k.name}</td>" in page
    failing_on_c = sum(not k.passed and not k.note for ks in c_run.checks.values() for k in ks)  # 3.3.0's RK4 defect
    assert page.count(" FAIL</td>") == 2 * failing_on_c + 1
    assert f"warp: pendulum {figure} measured" in page and "(C engine: pass)" in page
    doc = json.loads(json.dumps(side_by_side_json([c_run, warp])))
    assert [b["name"] for b in doc["backends"]] == ["c", "warp"]
    assert doc["backends"][1]["checks"]["pendulum"][figure]["verdict"] == "FAIL"
    assert [(f["backend"], f["figure"]) for f in doc["findings"]] == [("warp", figure)]
    clean = side_by_side_html([c_run, c_run])
    assert "None: every backend's figures lie within their budgets" in clean

"""An own model's report speaks of it (issue 43 point 7): named after the model, no shipped model or shipped limits
where there is no case, the first screen saying what was examined and what was not, a diverged run's cause said
once (harness/cases/own.py ``model_name``, harness/outputs/report.py)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from harness.cases.own import from_mjcf, model_name
from harness.core.checks import Check
from harness.core.options import RunOptions
from harness.outputs import report
from harness.pipeline.limits import case_limits, load_limits
from harness.pipeline.run import run_case
from harness.pipeline.verdict import judge

ARM = ("<mujoco{model}><worldbody><body name='link'><joint name='hinge' axis='0 1 0' damping='0.1'/>"
       "<geom type='capsule' fromto='0 0 0 0.3 0 0' size='0.03'/><geom type='sphere' size='0.05' pos='0.3 0 0' "
       "contype='1'/></body><geom type='plane' size='1 1 0.1' pos='0 0 -1'/></worldbody></mujoco>")


def _file(folder: Path, name: str, model: str | None) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(ARM.format(model="" if model is None else f" model='{model}'"))
    return path


def test_an_own_model_is_named_after_its_model_attribute_else_its_folder_never_scene(tmp_path):
    assert model_name(_file(tmp_path / "franka_emika_panda", "scene.xml", "panda scene")) == "panda scene"
    assert model_name(_file(tmp_path / "acme_arm", "scene.xml", None)) == "acme_arm"  # MuJoCo's default name
    assert model_name(_file(tmp_path / "acme_arm", "scene_left.xml", "scene")) == "acme_arm"
    assert model_name(_file(tmp_path / "acme_arm", "arm.xml", None)) == "arm"
    assert model_name(_file(tmp_path / "acme_arm", "arm2.xml", "MuJoCo Model")) == "arm2"
    assert model_name(_file(tmp_path / "acme_arm", "arm3.xml", "two\n  lines\tand a tab")) == "two lines and a tab"


@pytest.fixture(scope="module")
def own_pages(tmp_path_factory):
    """The report of a one-link arm of one's own (a contact it has is not in the reference), RK4 only, briefly."""
    path = _file(tmp_path_factory.mktemp("own") / "acme_arm", "scene.xml", None)
    case = from_mjcf(path, horizon=0.05)
    result = run_case(case, RunOptions(integrators=("RK4",)))
    checks = judge(result, case_limits(load_limits(), case, result.judged_names))
    pages = report.render_pages([result], {case.name: checks}, stills={}, plots={case.name: "<p>plots</p>"},
                                config_source=load_limits().source)
    return case, result, checks, pages


def test_the_report_of_an_own_model_speaks_of_it(own_pages):
    case, _, _, pages = own_pages
    overview, page = pages[report.OVERVIEW], pages[report.case_page(case.name)]
    assert case.name == "acme_arm" and "acme_arm.html" in report.case_page(case.name)
    for html in (overview, page):
        assert "shipped model" not in html and "shipped limits" not in html and ">shipped<" not in html
        assert "Limits from each figure" in html and "default (a model of one" in html
    assert "What the comparison changed in the model" in page and "<th>as written</th>" in page  # contacts off
    assert "contacts" not in case.description  # said once, in what was examined


def test_the_first_screen_says_what_was_examined_and_what_was_not(own_pages):
    case, _, checks, pages = own_pages
    page = pages[report.case_page(case.name)]
    for html, before in ((pages[report.OVERVIEW], "class='toc'"), (page, "class='model'")):
        scope = html.split("<div class='scope'>")[1].split("</div>")[0]
        assert html.index("<div class='scope'>") < html.index(before)  # above the contents / the model
        assert "<b>acme_arm</b> (scene.xml" in scope and "Examined</b>: gravity" in scope
        assert "Not in the reference</b>" in scope and "contacts" in scope
        assert f"Checks run</b>: {len(checks)} (" in scope and "on RK4 over 0.05 s" in scope


def test_a_diverged_run_is_listed_once_with_its_cause(own_pages):
    case, result, checks, _ = own_pages
    why = "diverged: mjWARN_BADQACC at t = 0.01 s (h·|λ| outside the stability region)"
    diverged = [Check(case.name, f"RK4.{q}", math.nan, math.nan, "m", diverged=why) for q in ("position", "velocity")]
    pages = report.render_pages([result], {case.name: [*checks, *diverged]}, stills={},
                                plots={case.name: "<p>plots</p>"})
    page, overview = pages[report.case_page(case.name)], pages[report.OVERVIEW]
    table = page.split("id='checks'")[1].split("</section>")[0]
    assert table.count(why) == 1 and "FAIL (2 checks, one run)" in table
    summary = overview.split("id='summary'")[1].split("</section>")[0]
    assert summary.count(why) == 1 and "RK4.position, RK4.velocity: " in summary

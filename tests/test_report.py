"""The report and its companions as pure functions of one shipped pendulum run.

HTML (self-contained pages: an overview without images, a page per case with its model still, sympy's
equations, plots and settings, the studies' and the audit's pages; every link resolves, no raw Python repr
shows), Markdown, JSON, JUnit, diff, and the regression baseline — plus the baseline check of every registry
case against reports/baseline.json.
"""

from __future__ import annotations

import copy
import dataclasses
import html
import json
import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import pytest

from harness.budget import PARTS
from harness.core.checks import Check, closest
from harness.core.figures import Figure
from harness.core.findings import Finding
from harness.outputs import baseline, files, jsondoc, report
from harness.outputs.diff import diff_runs, format_diff, load_run
from harness.outputs.equations import equations, png_data_uri
from harness.outputs.junit import junit_xml
from harness.outputs.page import Page
from harness.outputs.plots import section_plots
from harness.outputs.stills import Request, stills
from harness.outputs.studies import contact as contact_out
from harness.outputs.table import verdict_line
from harness.pipeline.outcome import Outcome, outcome_of
from harness.pipeline.require import Requirement
from harness.pipeline.verdict import judge
from harness.reference.derivations import derivation
from harness.studies import contact
from tests.conftest import case_ids, shipped_run
from tests.pages import broken_links, python_reprs, visible_text

CASE = "pendulum"
ROOT = Path(__file__).resolve().parent.parent
PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def run(config):
    result = shipped_run(CASE)
    return [result], {CASE: judge(result, config.for_case(CASE))}


@pytest.fixture(scope="module")
def model_stills(run):
    return report.model_stills(run[0])


@pytest.fixture(scope="module")
def plots(run):
    return {CASE: section_plots(run[0][0])}


@pytest.fixture(scope="module")
def pages(run, model_stills, plots):
    """The report's pages by path: the overview and the pendulum's page."""
    return report.render_pages(*run, stills=model_stills, config_source="pyproject.toml", plots=plots)


@pytest.fixture(scope="module")
def page(pages):
    """The pendulum's page: its checks, plots, equations, model and settings."""
    return pages[report.case_page(CASE)]


@pytest.fixture(scope="module")
def overview(pages):
    return pages[report.OVERVIEW]


def _contact_study() -> contact.StudyResult:
    """A contact study of two settings, as contact_study returns one (its rendering is what is tested here)."""
    row = {"cone": "elliptic", "impratio": 10.0, "noslip_iterations": 0, "softness": "shipped", "slip_max": 1e-3,
           "slip_late": 2e-4, "penetration": 1e-5, "force_error": 3e-3, "position": 4e-4, "drift.energy": 1e-6}
    return contact.StudyResult(case="hoop_plane", integrator="RK4", timestep=1e-3,
                               shipped={"cone": "elliptic", "impratio": 10.0, "noslip_iterations": 0},
                               rows=(row, {**row, "cone": "pyramidal", "impratio": 1.0, "slip_late": 3e-3}))


@pytest.fixture(scope="module")
def audit_rows():
    from harness.audit.registry import all_claims  # lazy: sympy and the claims, for the tests that need them
    from harness.audit.verdicts import audit  # lazy: as above

    return audit([c for c in all_claims() if c.id == "000.atwood.lambda2"])


@pytest.fixture(scope="module")
def written(tmp_path_factory, run, model_stills, plots, audit_rows):
    """The report as `mjharness run` writes it: its pages (the studies' with a contact study, the audit's with
    one claim), report.json and summary.md with the audit."""
    from harness.outputs.audit import html_section, json_rows  # lazy: as above

    out = tmp_path_factory.mktemp("written") / "report"
    study = _contact_study()
    drawn = {("contact", study.case): contact_out.plot(study)}
    extra = [Page(files.STUDIES_PAGE, "Studies", "the studies", (contact_out.html_section([study], drawn),)),
             Page(files.AUDIT_PAGE, "Seed audit", "the audit", (html_section(audit_rows),))]
    report.write_report(out, *run, stills=model_stills, plots=plots, pages=extra,
                        appendix={"audit": json_rows(audit_rows)})
    return out


def _unbroken(html: str) -> str:
    """``html`` without its line-break opportunities (<wbr>: a check's name may break after a dot)."""
    return html.replace("<wbr>", "")


def _failing(checks, name="RK4.position"):
    """``checks`` with one budget check failed as a fault fails it: an unexplained residual 10 × the limit
    its budget allows (the figure measured and the explained parts as they were)."""
    def broken(c):
        budget = dataclasses.replace(c.budget, unexplained=10 * c.budget.limit)
        return dataclasses.replace(c, budget=budget)
    return {case: [broken(c) if c.name == name else c for c in cs] for case, cs in checks.items()}


# ------------------------------------------------------------------ HTML
def test_page_is_self_contained(page):
    assert "http://" not in page and "https://" not in page
    assert "<script" not in page and "<link" not in page
    assert page.count("data:image/png;base64,") >= 4 + len(equations(derivation("pendulum")))


def test_page_has_every_section(page, overview, run):
    for heading in ("Equations of motion", "Gated checks", "Plots", "Other figures", "Settings used"):
        assert f">{heading}" in page, heading
    for heading in ("Summary", "Failed checks, with their budgets", "What differs from the shipped model"):
        assert f">{heading}" in overview, heading
    for shown in (page, overview):
        assert f"mujoco {mujoco.__version__}" in shown and "mjharness 0.1.0" in shown
    assert "<p class='banner pass'>PASS — " in overview
    assert "checks of 1 case(s) within what their budgets explain" in overview
    shown = _unbroken(page)
    for c in run[1][CASE]:
        assert f"<td class='name'>{c.name}</td>" in shown
        if c.note:  # n/a (an integrator this MuJoCo lacks): no limit, the reason in its verdict cell
            row = shown.split(f"<td class='name'>{c.name}</td>")[1].split("</tr>")[0]
            assert f"<td class='verdict'>n/a: {html.escape(c.note, quote=True)}</td>" in row, row
            continue
        assert f"{c.threshold:.3e}" in page
        if c.budget is not None:  # the figure, what nothing explains, and its limit, side by side
            row = shown.split(f"<td class='name'>{c.name}</td>")[1].split("</tr>")[0]
            assert [f"{x:.3e}" in row for x in (c.budget.measured, c.budget.unexplained, c.budget.limit)] == [True] * 3
    for header in ("measured", "integration", "unexplained", "limit", "used", "verdict", "meaning"):
        assert f"<th>{header}</th>" in page, header
    assert "timestep</td><td>0.001 s" in page
    # the shipped model as shipped: nothing differs and nothing was required; an engine function found
    # to disagree (mj_jacDot before MuJoCo 3.3.1) is named where the run found one
    assert "What differs from the shipped model" not in page and "Fitness for purpose" not in page
    assert "Nothing: every case ran its shipped model at its shipped settings." in overview
    assert "None: every check is within what its budget explains." in overview
    assert ("Engine finding" in page) == bool(run[0][0].findings)
    assert all(f.function in page for f in run[0][0].findings)


def test_the_verdict_line_counts_what_was_judged_and_names_where_it_failed():
    ok = Check("a", "RK4.position", 1.0, 2.0, "m")
    na = Check("a", "Euler.position", math.nan, 2.0, "m", note="not in this MuJoCo")
    known = Check("b", "RK4.force.rod", 3.0, 2.0, "1", known="a documented defect; observed order 2.00")
    bad = Check("b", "RK4.position", 3.0, 2.0, "m")
    assert verdict_line({"a": [ok, ok]}).startswith("PASS — all 2 checks of 1 case(s) within")
    line = verdict_line({"a": [ok, na]})
    assert line.startswith("PASS — 1 of 2 checks of 1 case(s) within") and "1 n/a" in line
    # a known defect is a failure: named with its reason (not its evidence), and accepted only on request
    line = verdict_line({"a": [ok, na], "b": [known]})
    assert line.startswith("FAIL — 1 of 3 checks fail, in 1 of 2 case(s): b (1)") and "1 n/a" in line
    assert "known defect" in line and "a documented defect" in line and "observed order" not in line
    assert "--accept-known-defects" in line
    accepted = verdict_line(Outcome(checks={"a": [ok, na], "b": [known]}, accept_known_defects=True))
    assert accepted.startswith("FAIL, known defects accepted (exit 0) — 1 of 3 checks fail")
    # a failure that is not a known defect is not accepted, whatever the flag
    mixed = Outcome(checks={"b": [known, bad]}, accept_known_defects=True)
    assert verdict_line(mixed).startswith("FAIL — 2 of 2") and mixed.exit_code == 1
    line = verdict_line({"a": [ok, Check("a", "RK4.velocity", 9.0, 2.0, "m")], "b": [bad, bad]})
    assert line.startswith("FAIL — 3 of 4 checks fail, in 2 of 2 case(s): a (1), b (2)")
    assert "known" not in line and "n/a" not in line


def test_page_shows_sympy_equations_with_readable_symbols(page):
    eqs = equations(derivation("pendulum"))
    assert [e.label for e in eqs] == ["kinetic energy", "potential energy", "constraint rod",
                                      "equation for theta", "equation for r"]
    tex = " ".join(e.latex for e in eqs)
    assert r"\ddot{\theta}" in tex and r"\dot{r}" in tex and r"\lambda_{\mathrm{rod}}" in tex
    assert "_ddot" not in tex and "lambda_rod" not in tex
    for e in eqs:
        assert png_data_uri(e.latex) is not None, e.latex
        assert f"alt='{e.latex}'" in page.replace("&#x27;", "'")


def test_unparseable_latex_falls_back_to_none():
    assert png_data_uri(r"\frac{a}{") is None


def test_model_still_is_a_png_or_a_visible_note(model_stills, page):
    still = model_stills[CASE]
    if still.png is not None:
        assert still.png.startswith(PNG) and still.backend
        assert "at the initial state (rendered headless" in page
    else:  # no GL on this machine: the page says so instead of crashing
        assert still.note and "class='note'" in page


def test_gl_failure_is_a_note_not_a_crash(monkeypatch, run):
    monkeypatch.setenv("MUJOCO_GL", "no-such-backend")
    got = report.model_stills(run[0])[CASE]
    assert got.png is None and "no headless OpenGL backend worked" in got.note
    section = report.section_model(run[0][0], got)
    assert "class='note'" in section and "no headless OpenGL backend worked" in section


def test_unreadable_model_is_a_note_for_that_model_only(tmp_path):
    bad = tmp_path / "bad.xml"
    bad.write_text("<mujoco><worldbody>")
    good = Request(CASE, str(ROOT / "mjcf" / "pendulum.xml"), ("theta", "r"))
    got = stills([Request("atwood", str(bad), ("z1", "z2", "theta")), good])
    assert got["atwood"].png is None and got["atwood"].note
    if got[CASE].png is None:
        pytest.skip(f"no OpenGL here: {got[CASE].note}")


def test_identical_inputs_give_identical_pages(run, pages):
    """Rendering again, model still and plots included (re-rendered, the still in a fresh child), gives the
    same bytes."""
    again = report.render_pages(*run, config_source="pyproject.toml")
    assert again == pages


def test_failures_are_flagged_in_banner_summary_and_table(run):
    results, checks = run
    checks = _failing(checks)
    assert "FAIL — 1 of" in report.section_banner(results, checks)
    assert "RK4.position: " in report.section_summary(results, checks)
    section = report.section_case(results[0], checks[CASE], None, plots="")
    assert "<tr class='fail'><td class='name'>RK4.position</td>" in _unbroken(section)
    assert "model image not rendered" in section


def test_a_changed_model_its_findings_and_its_fitness_have_their_sections(run):
    """What differs from the shipped model (the reference is built from it), the engine functions found to
    disagree, and the requirements judged on the model's own integrator: each shown where there is one."""
    results, checks = run
    finding = Finding("mj_jacDot", 2.5e-3, "1", "max |J̇ q̇ error|", "wrong for a slide under a hinge")
    settings = dataclasses.replace(results[0].settings, changed={"param.m": {"shipped": 1.0, "tested": 1.02}})
    result = dataclasses.replace(results[0], findings=(finding,), settings=settings)
    outcome = outcome_of([result], checks, requirements=[Requirement("position", 1e-15)])
    (fitness,) = outcome.fitness[CASE]  # the pendulum's own integrator is RK4: one position figure
    assert str(fitness.figure) == "RK4.position" and not fitness.met
    section = report.section_case(result, checks[CASE], None, plots="", fitness=outcome.fitness[CASE])
    differs = section.split("What differs from the shipped model")[1]
    assert "<td>param.m</td><td class='num'>1</td><td class='num'>1.02</td>" in differs
    overview = report.section_differences([result])  # and on the overview, linked to the case's part
    assert "<td>param.m</td><td class='num'>1</td><td class='num'>1.02</td>" in overview
    assert f"href='{report.case_page(CASE)}#differences'" in overview and "id='differences'" in section
    assert "Engine finding" in section and "mj_jacDot" in section and "2.500e-03" in section
    assert "Fitness for purpose" in section and "NOT MET" in section
    banner = report.section_banner([result], outcome)
    assert "<p class='banner pass'>PASS — " in banner and "<p class='banner fail'>REQUIREMENTS NOT MET" in banner
    md = report.render_markdown([result], outcome)
    assert "## Engine findings" in md and "## Requirements not met" in md and "| pendulum | RK4.position |" in md


def test_closest_to_its_limit_is_the_tightest_passing_check_not_the_worst_failure(run):
    """A failing case's failures have their own column; "closest to its limit" is the headroom left."""
    results, checks = run
    broken = _failing(checks)
    tightest = closest([c for c in broken[CASE] if c.passed])
    row = report.section_summary(results, broken).split("<tr class='fail'>")[1]
    closest_cell = row.split("</td>")[3]
    assert tightest.name in closest_cell and "RK4.position" not in closest_cell
    md_row = next(line for line in report.render_markdown(results, broken).splitlines()
                  if line.startswith(f"| {CASE} | **FAIL**"))
    assert tightest.name in md_row and "RK4.position" not in md_row


def test_the_gated_checks_table_is_driven_by_its_list_of_columns(run):
    """Adding a column (issue 14 adds several) is one more entry: a header and a cell in every row."""
    results, checks = run
    extra = report.Column("headroom", lambda c, r: f"{c.threshold / max(c.value, 1e-300):.1f}×", "num")
    table = report._checks_table(results[0], checks[CASE], (*report.CHECK_COLUMNS, extra))
    rows = table.split("<tr")[1:]
    assert "<th>headroom</th>" in rows[0]
    # a budget part's column is shown where some check has that part: the pendulum's budgets have
    # integration, softness (its rod) and floors (its point mass), no margin part (no contact), no solver part
    # (Newton converges) and no stop part (the C engine is float64)
    present = {p for c in checks[CASE] if c.budget is not None for p in c.budget.explained}
    assert present == {"integration", "softness", "floors"}
    assert all(f"<th>{p}</th>" not in rows[0] for p in ("margin", "solver", "stop"))
    assert all(f"<th>{p}</th>" in rows[0] for p in present)
    shown = len(report.CHECK_COLUMNS) - len(set(PARTS) - present) + 1  # the parts present, and the new one
    data = [r for r in rows if "class='group'" not in r][1:]
    assert len(data) == len(checks[CASE]) and all(r.count("<td") == shown for r in data)
    assert all(f"colspan='{shown}'" in r for r in rows if "class='group'" in r)


# -------------------------------------------------------------- the pages
def test_the_overview_is_short_and_has_no_images_the_case_page_has_them(overview, page):
    """The overview opens fast: no image at all, and a size that keeps the full run's overview under 2 MB.
    The bound: a one-case overview within 2 MB / (number of cases in the registry), so the overview of every
    case together (its fixed part counted once, not once a case) stays under 2 MB as long as each case adds
    no more than one case's share."""
    assert "<img" not in overview and "data:image" not in overview
    # measured on the full default run (15 cases): 11 kB, no image (the single page it replaced: 10.4 MB)
    assert len(overview.encode()) <= 2_000_000 / len(case_ids())
    assert page.count("<img") >= 4 and "data:image/png;base64," in page  # the depth is on the case's page


def test_the_overview_lists_every_failure_with_its_budget(run):
    """Every failed check, a budget's (figure, explained parts, unexplained, limit) and a diverged run's (its
    reason), on the overview, under its case linked to the case's table."""
    results, checks = run
    broken = _failing(_failing(checks), "instant.qacc")
    diverged = Check(CASE, "implicit.velocity", math.nan, math.nan, "m", diverged="diverged: mjWARN_BADQACC at t = 0 s")
    broken = {CASE: [*broken[CASE], diverged]}
    overview = report.render_pages(results, broken, stills={}, plots={CASE: "<p>plots</p>"})[report.OVERVIEW]
    failures = _unbroken(overview.split("id='failures'")[1].split("</section>")[0])
    failed = [c for c in broken[CASE] if not c.passed]
    assert len(failed) == 3 and f"href='{report.case_page(CASE)}#checks'" in failures
    assert "3 of " in failures and failures.count("<tr class='fail'>") == 3
    for c in failed:
        row = failures.split(f"<td class='name'>{c.name}</td>")[1].split("</tr>")[0]
        if c.budget is not None:
            assert all(f"{x:.3e}" in row for x in (c.budget.measured, c.budget.unexplained, c.budget.limit)), row
            assert all(f"{x:.2e}" in row for x in c.budget.explained.values()), row
        else:
            assert c.diverged in row


def test_every_link_of_every_page_reaches_a_written_page_and_anchor(written):
    """The overview links each case's page, the studies and the audit; each page links back; nothing points
    at a page or an anchor that was not written."""
    assert broken_links(written) == {}
    overview = (written / report.OVERVIEW).read_text(encoding="utf-8")
    for target in (report.case_page(CASE), files.STUDIES_PAGE, files.AUDIT_PAGE):
        assert f"href='{target}'" in overview, target
    case = (written / report.case_page(CASE)).read_text(encoding="utf-8")
    assert f"href='../{report.OVERVIEW}'" in case and f"href='../{files.STUDIES_PAGE}'" in case


def test_no_page_shows_a_raw_python_repr(written):
    """A dict, list, tuple, object, numpy scalar, dataclass or enum printed with str() reads as Python, not
    as a report: none may reach the visible text of any page or summary.md."""
    shown = {p.relative_to(written).as_posix(): visible_text(p.read_text(encoding="utf-8"))
             for p in written.rglob("*.html")}
    shown["summary.md"] = (written / "summary.md").read_text(encoding="utf-8")
    assert set(shown) >= {report.OVERVIEW, report.case_page(CASE), files.STUDIES_PAGE, files.AUDIT_PAGE}
    found = {name: python_reprs(text) for name, text in shown.items() if python_reprs(text)}
    assert found == {}


@pytest.mark.parametrize("text", [
    "Shipped settings: {'cone': 'elliptic', 'impratio': 10.0}", "pairs [('a', 1)]", "names ['a', 'b']",
    "('theta', 'r') projected", "<harness.cases.Case object at 0x7f00aa>", "value np.float64(0.5)",
    "Check(case='pendulum', name=", "<mjtCone.mjCONE_ELLIPTIC: 1>", "mappingproxy({})"])
def test_the_repr_scan_finds_each_kind(text):
    assert python_reprs(visible_text(f"<p>{html.escape(text)}</p>")) != []


def test_the_repr_scan_passes_what_the_report_writes():
    text = ("f(q) = 0, M q̈ = F + Jᵀλ, [numeric] 1.0e-05 / 2.0e-09 (agrees), cone = elliptic, "
            "max(0, documented order 1 − observed 0.98), λ₂ = (m_p + 2m₁)/(m₁ + m₂) m₂ g, RK4.position (40%)")
    assert python_reprs(visible_text(f"<style>a{{b:c}}</style><p>{text}</p><img alt=\"{{'x': 1}}\">")) == []


def test_case_pages_have_one_file_name_each_whatever_the_name():
    assert report.case_page("pendulum") == "cases/pendulum.html"
    names = ["a b", "a_b", "a~20b", "../x", "é", "a.b"]
    pages = [report.case_page(n) for n in names]
    assert len(set(pages)) == len(names)
    assert all(p.startswith("cases/") and "/" not in p.removeprefix("cases/") and ".." not in p for p in pages)


def test_an_earlier_reports_pages_go_with_the_new_set_and_stay_when_it_fails(tmp_path, run, monkeypatch):
    """A case page or the studies' page of an earlier run that this run has not is removed as the new set is
    written; a run that fails to write leaves the earlier report whole, those pages included."""
    out = tmp_path / "out"
    (out / files.CASE_PAGES).mkdir(parents=True)
    old = {out / files.CASE_PAGES / "gone.html": "old case", out / files.STUDIES_PAGE: "old studies",
           out / report.OVERVIEW: "old overview"}
    files.write_atomic(files.with_manifest(out, old))  # an earlier run's, listed in its manifest
    fake = {report.OVERVIEW: "<html>new</html>", report.case_page(CASE): "<html>case</html>"}
    monkeypatch.setattr(report, "render_pages", lambda *_a, **_k: fake)
    (out / "summary.md").mkdir()  # in the way of the new set: nothing of it may land
    with pytest.raises(ValueError, match=r"summary\.md"):
        report.write_report(out, *run, stills={})
    assert {p: p.read_text() for p in old} == old and not (out / report.case_page(CASE)).exists()
    (out / "summary.md").rmdir()
    report.write_report(out, *run, stills={})
    assert sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()) == [
        files.MANIFEST, report.case_page(CASE), "report.html", "report.json", "summary.md"]


def test_write_atomic_removes_with_the_set_or_not_at_all(tmp_path):
    keep, gone = tmp_path / "keep.txt", tmp_path / "gone.txt"
    keep.write_text("old")
    gone.write_text("old")
    (tmp_path / "dir").mkdir()
    with pytest.raises(ValueError):
        files.write_atomic({keep: "new", tmp_path / "sub" / "new.txt": "new", tmp_path / "dir": "x"}, remove=[gone])
    assert (keep.read_text(), gone.read_text()) == ("old", "old") and not (tmp_path / "sub").exists()
    files.write_atomic({keep: "new", tmp_path / "sub" / "new.txt": "new"}, remove=[gone])
    assert keep.read_text() == (tmp_path / "sub" / "new.txt").read_text() == "new" and not gone.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dir", "keep.txt", "sub"]


# ------------------------------------------------------- Markdown, JSON
def test_markdown_summary_for_ci(run):
    results, checks = run
    md = report.render_markdown(results, checks)
    assert md.startswith("# mjharness summary\n") and "**PASS — " in md and "Failed checks" not in md
    md = report.render_markdown(results, _failing(checks))
    assert "**FAIL — 1 of" in md and "## Failed checks" in md
    c = next(c for c in _failing(checks)[CASE] if c.name == "RK4.position")
    (row,) = [line for line in md.splitlines() if line.startswith("| pendulum | RK4.position |")
              and "**FAIL**" not in line]  # the failed checks' table, not the list of every check
    assert f"unexplained {c.budget.unexplained:.3e} > limit {c.budget.limit:.3e}" in row


def test_summary_md_carries_the_seed_audit_from_the_report_appendix(tmp_path, run, monkeypatch):
    """write_report hands report.json's "audit" entry to summary.md (a hand-made entry: the audit's own
    rendering is tested in tests/test_audit.py)."""
    results, checks = run
    entry = {"counts": {"claims": 2, "of": 2, "confirmed": 1, "refuted": 1, "ambiguous": 0, "errors": 0,
                        "transcription slips": 1},
             "claims": {"x.ok": {"verdict": "confirmed", "cause": "", "lines": "3", "corrected": "", "readings": []},
                        "x.bad": {"verdict": "refuted", "cause": "transcription slip", "lines": "7",
                                  "corrected": "λ₂ = g m₂", "readings": []}}}
    monkeypatch.setattr(report, "render_pages", lambda *_a, **_k: {report.OVERVIEW: "<html></html>"})
    report.write_report(tmp_path / "out", results, checks, stills={}, appendix={"audit": entry})
    md = (tmp_path / "out" / "summary.md").read_text(encoding="utf-8")
    assert "## Seed audit" in md and "2 claims: 1 confirmed, 1 refuted (0 errors, 1 transcription slips)" in md
    assert "| x.bad | 7 | refuted (transcription slip) | λ₂ = g m₂ |" in md and "x.ok" not in md
    assert "Seed audit" not in report.render_markdown(results, checks)  # no audit entry, no section


def test_every_key_report_json_writes_is_documented(run):
    """docs/report-json.md names every key of the document: top level, a case, a check, the audit and a
    claim (the audit of one claim stands for all: every claim has the same keys)."""
    from harness.audit.registry import all_claims  # lazy: sympy and the claims, for this test only
    from harness.audit.verdicts import audit  # lazy: as above
    from harness.outputs.audit import json_rows  # lazy: as above

    doc_text = (ROOT / "docs" / "report-json.md").read_text(encoding="utf-8")
    documented = {
        name for pair in re.findall(r"`([A-Za-z0-9_ ]+)`|\"([A-Za-z0-9_ ]+)\"", doc_text) for name in pair if name}
    results, checks = run
    # every optional part present: a requirement (fitness), an engine finding, and checks that are n/a,
    # a known defect and a diverged run
    finding = Finding("mj_jacDot", 1e-3, "1", "max |J̇ q̇ error|", "fixed upstream")
    changed = {"changed": {"param.m": {"shipped": 1.0, "tested": 1.02}}, "projected": ("r = l",)}
    result = dataclasses.replace(results[0], findings=(finding,), settings=dataclasses.replace(results[0].settings,
                                                                                               **changed))
    extra = [Check(CASE, "X.position", math.nan, math.nan, "", note="not in this MuJoCo"),
             Check(CASE, "Y.position", 1.0, 0.5, "m", known="a documented defect"),
             Check(CASE, "Z.position", math.nan, math.nan, "", diverged="diverged: mjWARN_BADQACC at t = 1 s")]
    outcome = outcome_of([result], {CASE: [*checks[CASE], *extra]}, requirements=[Requirement("position", 1.0)])
    doc = jsondoc.json_doc([result], outcome)
    case = doc["cases"][CASE]
    assert {"requirements", "gate"} <= set(doc) and {"fitness", "findings"} <= set(case)
    rows = json_rows(audit([c for c in all_claims() if c.id == "000.atwood.lambda2"]))
    claim = rows["claims"]["000.atwood.lambda2"]
    check_keys = {k for c in case["checks"].values() for k in c}
    assert {"budget", "note", "known_defect", "diverged"} <= check_keys
    budget = case["checks"]["RK4.position"]["budget"]
    keys = {*doc, "audit", "contact_study", *doc["gate"], *doc["requirements"], *case, *check_keys, *budget,
            *budget["explained"], *budget["tolerance"], *case["fitness"][0], *case["findings"][0], *case["settings"],
            *rows, *rows["counts"], *claim, *claim["symbolic"], *claim["numeric"], *rows["not_checkable"][0]}
    keys -= {k for k in case["settings"] if k.startswith(("equality.", "pair."))}  # documented as patterns
    assert keys - documented == set()


def test_json_has_every_figure_and_is_strict_json(run):
    results, checks = run
    text = jsondoc.render_json(results, checks)

    def reject(name):
        raise AssertionError(f"non-standard JSON constant {name}")

    doc = json.loads(text, parse_constant=reject)
    entry = doc["cases"][CASE]
    assert doc["schema"] == jsondoc.SCHEMA and doc["passed"] is True
    assert set(entry["figures"]) == {f.name for f in results[0].figures}
    assert entry["checks"]["RK4.position"]["threshold"] == checks[CASE][
        [c.name for c in checks[CASE]].index("RK4.position")].threshold
    nan_doc = json.loads(jsondoc.dumps({"x": math.nan, "y": [math.inf]}), parse_constant=reject)
    assert nan_doc == {"x": "nan", "y": ["inf"]}


def test_write_report_is_all_or_nothing(tmp_path, run, monkeypatch):
    results, checks = run

    def boom(*_args, **_kw):
        raise RuntimeError("rendering failed")

    monkeypatch.setattr(report, "render_pages", lambda *_a, **_k: {report.OVERVIEW: "<html></html>"})
    monkeypatch.setattr(report, "render_markdown", boom)
    with pytest.raises(RuntimeError):
        report.write_report(tmp_path / "out", results, checks, stills={})
    assert not (tmp_path / "out").exists()


def test_write_atomic_leaves_no_temporaries_and_readable_files(tmp_path):
    paths = files.write_atomic({tmp_path / "a.txt": "a", tmp_path / "b.txt": "b"})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "b.txt"] == [p.name for p in paths]
    assert (tmp_path / "a.txt").stat().st_mode & 0o444 == 0o444


def test_output_that_cannot_be_a_directory_is_refused_before_anything_is_created(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(ValueError, match="is not a directory"):
        files.check_output(blocker / "sub" / "dir")
    assert files.check_output(tmp_path / "new" / "dir") == tmp_path / "new" / "dir"
    assert not (tmp_path / "new").exists()


# ------------------------------------------------------------------ JUnit
def test_junit_has_one_testcase_per_check_and_failures_carry_figure_budget_and_limit(run):
    checks = _failing(run[1])
    root = ET.fromstring(junit_xml(checks))
    cases = root.findall("./testsuite/testcase")
    assert len(cases) == len(checks[CASE]) and root.get("failures") == "1"
    failed = [tc for tc in cases if tc.find("failure") is not None]
    assert [tc.get("name") for tc in failed] == ["RK4.position"]
    c = next(c for c in checks[CASE] if c.name == "RK4.position")
    failure = failed[0].find("failure")
    message = failure.get("message")
    assert failure.get("type") == "Unexplained"
    for number in (c.value, c.budget.unexplained, c.budget.limit, *c.budget.explained.values()):
        assert f"{number:.6e}" in message
    assert junit_xml(checks) == junit_xml(checks)


def test_junit_a_known_defect_fails_unless_accepted_when_it_is_skipped_with_its_reason():
    ok = Check("a", "RK4.position", 1.0, 2.0, "m")
    known = Check("a", "Euler.position", 3.0, 2.0, "m", known="a documented defect")
    bad = Check("a", "implicit.position", 3.0, 2.0, "m")
    root = ET.fromstring(junit_xml({"a": [ok, known, bad]}))
    assert (root.get("failures"), root.find("testsuite").get("skipped")) == ("2", "0")
    kinds = {tc.get("name"): tc.find("failure") for tc in root.iter("testcase")}
    assert kinds["RK4.position"] is None and kinds["Euler.position"].get("type") == "KnownDefect"
    assert "a documented defect" in kinds["Euler.position"].get("message")
    assert kinds["implicit.position"].get("type") == "ThresholdExceeded"  # a fixed limit, no budget
    root = ET.fromstring(junit_xml({"a": [ok, known, bad]}, accept_known_defects=True))
    assert (root.get("failures"), root.find("testsuite").get("skipped")) == ("1", "1")
    skipped = next(tc for tc in root.iter("testcase") if tc.get("name") == "Euler.position").find("skipped")
    assert skipped is not None and "a documented defect" in skipped.get("message")


# ------------------------------------------------------------------- diff
def test_diff_of_a_run_with_itself_is_empty(run):
    doc = jsondoc.json_doc(*run)
    d = diff_runs(doc, doc)
    assert not d.flipped and not any(r.changed for r in d.rows)
    assert "0 changed" in format_diff(d) and "0 verdict(s) flipped" in format_diff(d)


def test_diff_reports_ratio_and_highlights_flipped_verdicts(run):
    old = json.loads(jsondoc.render_json(*run))
    new = copy.deepcopy(old)
    entry = new["cases"][CASE]
    entry["figures"]["RK4.position"]["value"] *= 4
    entry["checks"]["RK4.position"]["passed"] = False
    entry["figures"]["Euler.velocity"]["value"] /= 2
    new["versions"]["mujoco"] = "9.9.9"
    d = diff_runs(old, new)
    rows = {r.figure: r for r in d.rows if r.changed}
    assert set(rows) == {"RK4.position", "Euler.velocity"}
    assert rows["RK4.position"].ratio == pytest.approx(4) and rows["RK4.position"].flipped
    assert rows["Euler.velocity"].ratio == pytest.approx(0.5) and not rows["Euler.velocity"].flipped
    text = format_diff(d)
    assert f"mujoco: {mujoco.__version__} -> 9.9.9" in text
    assert "FLIPPED pendulum RK4.position: pass -> FAIL" in text
    assert any("RK4.position" in ln and "<< FLIPPED" in ln and "pass -> FAIL" in ln for ln in text.splitlines())
    assert "1 pass -> FAIL" in text
    assert len(format_diff(d, show_all=True).splitlines()) > len(text.splitlines())


@pytest.mark.parametrize("content, needle", [
    (None, "cannot read"),
    ("{not json", "is not JSON"),
    ('{"cases": {"pendulum": {"checks": {}}}}', "is not an mjharness run"),
    ("[1, 2]", "is not an mjharness run"),
])
def test_diff_inputs_are_validated(tmp_path, content, needle):
    path = tmp_path / "run.json"
    if content is not None:
        path.write_text(content)
    with pytest.raises(ValueError, match=needle):
        load_run(path)


# --------------------------------------------------------------- baseline
def _fig(name, value):
    return Figure(name, value, "m", "")


@pytest.mark.parametrize("old, new, threshold, regressed", [
    (1e-3, 1.9e-3, 4e-3, False),    # within 2×
    (1e-3, 2.1e-3, 4e-3, True),     # beyond 2×, although under the threshold
    (1e-3, 5e-4, 4e-3, False),      # improved
    (1e-16, 3e-16, 1e-12, False),   # roundoff wobble under the floor (2 % of the threshold)
    (1e-16, 3e-14, 1e-12, True),    # 300× growth from roundoff: above the floor
    (1e-3, math.nan, 4e-3, True),   # not finite
])
def test_regression_rule(old, new, threshold, regressed):
    base = {"cases": {"c": {"figures": {"RK4.x": {"value": old}}}}}
    found = baseline.compare(base, "c", [_fig("RK4.x", new)], {"RK4.x": threshold})
    assert bool(found) == regressed
    if regressed:
        assert baseline.REFRESH in found[0].message and "regressed" in found[0].message


def test_missing_case_or_figure_names_the_refresh_command():
    found = baseline.compare({"cases": {}}, "c", [_fig("RK4.x", 1.0)], {"RK4.x": 2.0})
    assert len(found) == 1 and "not in the baseline" in found[0].message
    assert "mjharness baseline --write reports/baseline" in found[0].message
    found = baseline.compare({"cases": {"c": {"figures": {}}}}, "c", [_fig("RK4.x", 1.0)], {"RK4.x": 2.0})
    assert "1 gated figure(s) not in the baseline" in found[0].message and "(RK4.x)" in found[0].message
    assert baseline.REFRESH in found[0].message


def test_baseline_doc_keeps_gated_figures_and_no_machine_paths(run):
    doc = baseline.baseline_doc(*run)
    entry = doc["cases"][CASE]
    # every gated figure this MuJoCo measures (an n/a check, of an integrator it lacks, has none)
    assert set(entry["figures"]) == {c.name for c in run[1][CASE] if c.status != "n/a"}
    assert entry["settings"]["mjcf"] == "pendulum.xml"
    merged = baseline.merge({"cases": {"other": {"figures": {}}}}, doc)
    assert set(merged["cases"]) == {"other", CASE}


@pytest.fixture(scope="module")
def committed_baseline():
    return load_run(ROOT / baseline.DEFAULT_PATH)


@pytest.mark.parametrize("name", case_ids())
def test_no_gated_figure_regressed_against_the_committed_baseline(name, config, committed_baseline):
    """Fails when a figure is > 2× its committed value (see harness/outputs/baseline.py for why 2×), or when
    the case or a gated figure is missing from reports/baseline/ (refresh command in the message).
    Only on the MuJoCo version the baseline was recorded with: a baseline is per version."""
    if why := baseline.version_mismatch(committed_baseline):
        pytest.skip(why)
    result = shipped_run(name)
    found = baseline.compare(committed_baseline, name, result.figures, judge(result, config.for_case(name)),
                             source=baseline.DEFAULT_PATH)
    assert not found, "\n".join(f.message for f in found)


def test_a_baseline_judges_only_runs_on_its_own_mujoco_version(committed_baseline):
    assert committed_baseline["versions"]["mujoco"]  # recorded, so the regression test knows
    same = {"versions": {"mujoco": mujoco.__version__}, "cases": {}}
    assert baseline.version_mismatch(same) == "" and baseline.version_mismatch({"cases": {}}) == ""
    why = baseline.version_mismatch({"versions": {"mujoco": "0.9.9"}, "cases": {}}, source="b.json")
    assert why.startswith("b.json was recorded with MuJoCo 0.9.9, this is MuJoCo " + mujoco.__version__)
    assert "per MuJoCo version" in why and "mjharness diff" in why
    with pytest.raises(ValueError, match="mix versions"):  # a partial refresh on another version
        baseline.merge({"versions": {"mujoco": "0.9.9"}, "cases": {}}, {**same, "cases": {"c": {}}})
    assert baseline.merge(same, {**same, "cases": {"c": {}}})["cases"] == {"c": {}}


def test_checks_this_mujoco_cannot_measure_are_na_not_failures(run, monkeypatch):
    """A gate for an integrator an older MuJoCo lacks: n/a in the table, never 'closest to its limit',
    and skipped by the baseline comparison."""
    results, checks = run
    tightest = closest(checks[CASE]).name
    na = [dataclasses.replace(c, value=math.nan, unit="", note="integrator X is not in MuJoCo 3.3")
          if c.name == tightest else c for c in checks[CASE]]
    section = report.section_case(results[0], na, None, plots="")
    assert f"<tr class='na'><td class='name'>{tightest}</td>" in _unbroken(section) and "n/a: integrator X" in section
    assert closest(na).name != tightest
    assert f"{tightest} <span" not in report.section_summary(results, {CASE: na})
    monkeypatch.setattr(baseline, "unavailable_reason", lambda name: "absent" if name == "X.position" else "")
    assert baseline.compare({"cases": {"c": {"figures": {}}}}, "c", [], {"X.position": 1.0}) == []

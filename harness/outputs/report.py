"""Reports: self-contained HTML pages and a Markdown summary (the JSON: :mod:`.jsondoc`).

A builder collects independent sections; each section is a function of one
CaseResult (plus its checks) returning HTML. Images (plots, the derived
equations, a still of each model) are PNGs embedded as data URIs and there is
no script or stylesheet from the network, so every page opens offline. Nothing
time-dependent is written, so identical inputs give byte-identical files.
The pages are written together or not at all (:mod:`.files`), so a failed run
never leaves a half-written report.

The pages (:func:`render_pages`), so that the first one opens fast whatever the
number of cases:

- the overview, report.html, without images: verdict banner, the table of
  contents (read from the page's own sections, :mod:`.page`), how to read it,
  summary table (one row per case, linked to its page), every failed check
  with its budget, what differs from the shipped model in each case, engine
  findings and requirements where there are any, and the other pages;
- a page per case, cases/NAME.html (:func:`case_page`): model still and
  equations of motion, what differs, gated checks grouped by layer (the
  columns of :data:`CHECK_COLUMNS`), plots, figures measured but not gated,
  settings;
- the studies and the seed audit, each a page of its own (:class:`.page.Page`).

Every page is laid out for a window 1000 px wide and up: nothing overflows it,
numbers never break across lines, and plots and formulas are shown at the size
they are drawn (tests/test_browser.py checks it in Chromium).
"""

from __future__ import annotations

import base64
import dataclasses
import functools
import html
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from harness.audit.notation import latex_text
from harness.budget import PARTS
from harness.core import VERSION as __version__
from harness.core.checks import Check
from harness.core.checks import closest as closest_check
from harness.core.escape import markdown_cell
from harness.engine.models import compile_model
from harness.outputs.equations import equations, png_data_uri
from harness.outputs.files import (
    CASE_PAGES,
    PAGES,
    REPORT_FILES,
    prepare_output,
    superseded,
    with_manifest,
    write_atomic,
)
from harness.outputs.formulas import text_html
from harness.outputs.jsondoc import render_json, versions
from harness.outputs.page import Page, table_of_contents, unbroken_numbers
from harness.outputs.plots import section_plots, shipped_integrator
from harness.outputs.stills import Request, Still, stills
from harness.outputs.table import fitness_line, fmt_value, parts_shown, ratio, ratio_text, verdict_line
from harness.pipeline.limits import SHIPPED_SOURCE
from harness.pipeline.outcome import Outcome
from harness.pipeline.require import Fitness
from harness.pipeline.run import CaseResult
from harness.reference.derivations import derivation
from harness.reference.tree import TREE

__all__ = ["render_markdown", "report_files", "section_case", "write_report"]


def _esc(value: object) -> str:
    return html.escape(str(value), quote=True)


def _setting(value: object) -> str:
    if isinstance(value, Mapping):
        return ", ".join(f"{k} = {_setting(v)}" for k, v in value.items())
    if isinstance(value, list | tuple):
        return " ".join(_setting(v) for v in value)
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


OVERVIEW = REPORT_FILES[0]


def case_page(name: str) -> str:
    """Where a case's page lies, relative to the output directory: ``cases/NAME.html``, each character of NAME
    but ASCII letters, digits, ``_`` and ``-`` written as ``~XX`` (its UTF-8 bytes in hex), so that any name is
    one file name and no two names the same one."""
    safe = "".join(ch if ch.isascii() and (ch.isalnum() or ch in "_-") else
                   "".join(f"~{b:02x}" for b in ch.encode()) for ch in name)
    return f"{CASE_PAGES}/{safe}.html"


# -------------------------------------------------------------- sections
def _outcome(outcome: Outcome | Mapping[str, Sequence[Check]]) -> Outcome:
    return outcome if isinstance(outcome, Outcome) else Outcome(checks=outcome)


def section_banner(results: Sequence[CaseResult], outcome: Outcome | Mapping[str, Sequence[Check]]) -> str:
    """The verdict line, as the command line prints it last, and the requirements' line where stated."""
    outcome = _outcome(outcome)
    judged = dataclasses.replace(outcome, checks={r.case.name: outcome.checks[r.case.name] for r in results})
    banner = (f"<p class='banner {'pass' if judged.passed else 'fail'}'>{_esc(verdict_line(judged))}</p>")
    fitness = fitness_line(judged)
    if fitness:
        banner += f"<p class='banner {'pass' if judged.fit else 'fail'}'>{_esc(fitness)}</p>"
    return banner


_HOW_TO_READ = """
<details class='howto' open><summary>How to read this report (one minute)</summary><ul>
<li>Every <b>check</b> is one <b>measured</b> figure — how far MuJoCo is from the analytic reference — and
its <b>error budget</b>: the part the model's own settings explain (<b>integration</b> error at its timestep,
from a run at h/2; constraint <b>softness</b>, from runs with solimp's 1 − d changed, extrapolated to the
rigid limit; the point masses' inertia <b>floors</b>; a constraint <b>solver</b> stopped short), and what
nothing explains: <b>unexplained</b>. A check passes when the unexplained part is within its <b>limit</b>,
the accuracy of those estimates themselves (and float round-off, the reference's tolerance, the solver's
convergence). <b>used</b> is unexplained ÷ limit: 40% means 2.5× headroom. Another timestep or softness
moves the explained parts, not the verdict; a fault (damping, armature, a wrong coefficient) is
unexplained.</li>
<li>A few checks have a fixed limit from theory (a convergence order's shortfall, the reference's own
accuracy), kept with their basis in <code>mjcf/CASE.limits.toml</code> (<code>mjharness limits CASE</code>
lists them). <b>FAIL (known defect)</b> is a failure that shows the signature of a documented defect of
this MuJoCo version; it fails the run unless <code>--accept-known-defects</code> is given.</li>
<li>Figure names are <code>LAYER.QUANTITY[.DETAIL]</code>: <code>instant.*</code> compares MuJoCo and the
analytic equations at sampled states without integrating (a failure there is in the model);
<code>reference.*</code> judges our own solution; <code>INTEGRATOR.*</code> (RK4, Euler, …) compares a MuJoCo run
over the case's horizon with the reference; <code>converge.*</code> compares the observed order of accuracy
with the documented one. Errors are maxima over the horizon; “1” means relative to the case's scale (m·g for
forces, m·g·l for energy).</li>
<li>Constraint forces follow M q̈ = F + Jᵀλ, which is MuJoCo's <code>qfrc_constraint = Jᵀ efc_force</code>.</li>
</ul></details>
"""


def section_summary(results: Sequence[CaseResult], outcome: Outcome | Mapping[str, Sequence[Check]]) -> str:
    """One row per case, its name linked to its page: verdict, checks passed, the passing check closest to
    its limit (the headroom left; the failures have their own column), the failures."""
    checks = _outcome(outcome).checks
    rows = []
    for r in results:
        cs = checks[r.case.name]
        failed = [c for c in cs if not c.passed]
        verdict = "PASS" if not failed else "FAIL"
        tight = closest_check([c for c in cs if c.passed and not c.known])
        closest = (f"{_esc(tight.name)} <span class='dim'>({ratio_text(ratio(tight))})</span>"
                   if tight else "no passing gates" if cs else "no gates")
        why: dict[str, list[str]] = {}  # a cause shared by several checks (a run that diverged) said once
        for c in failed:
            why.setdefault(_failure_text(c) if c.diverged else f"{c.name}\0{_failure_text(c)}", []).append(str(c.name))
        fails = "<br>".join(f"{_esc(', '.join(names))}: {_esc(text.rpartition(chr(0))[2])}"
                            for text, names in why.items())
        rows.append(f"<tr class='{verdict.lower()}'><td><a href='{_esc(case_page(r.case.name))}'>"
                    f"{_esc(r.case.name)}</a></td>"
                    f"<td class='verdict'>{verdict}</td><td>{len(cs) - len(failed)}/{len(cs)}</td>"
                    f"<td>{closest}</td><td>{fails}</td></tr>")
    return ("<section id='summary'><h2>Summary</h2><p class='dim'>Each case's checks, plots, equations and "
            "model are on its own page: follow its name.</p><table class='summary'><tr><th>case</th><th>verdict</th>"
            "<th>checks passed</th><th>closest to its limit among those passing (used)</th>"
            f"<th>failed: why</th></tr>{''.join(rows)}</table></section>")


def _failure_text(c: Check) -> str:
    """Why a check failed, in one line: what could not be measured, or what is unexplained beside its
    limit (and the known defect it shows)."""
    if c.diverged:
        return c.diverged
    if c.budget is not None:
        text = f"unexplained {fmt_value(c.budget.unexplained)} > limit {fmt_value(c.budget.limit)} {c.unit}"
    else:
        text = f"{fmt_value(c.value)} > limit {fmt_value(c.threshold)} {c.unit}"
    return f"{text} (known defect: {c.known})" if c.known else text


def _bar(r: float) -> str:
    if np.isnan(r):
        return "n/a"
    width = 100.0 if not np.isfinite(r) else min(100.0, 100.0 * r)
    return (f"<span class='bar'><span class='{'over' if not r <= 1 else 'ok'}' "
            f"style='width:{width:.0f}%'></span></span>{ratio_text(r)}")


def _group_title(group: str, result: CaseResult) -> str:
    if group == "instant":
        return "Layer 2 — instantaneous dynamics at sampled states (no time integration)"
    if group == "reference":
        return "Reference quality — our own DAE/ODE solution"
    if group == "converge":
        return "Layer 4 — observed convergence order vs the documented one (error vs timestep)"
    if group not in result.simulations:
        return group
    shipped = " (the model's own integrator)" if group == shipped_integrator(result) else ""
    return f"MuJoCo {group}{shipped} — {_setting(result.settings.horizon)} s against the reference"


def _status(c: Check) -> str:
    """PASS / FAIL, FAIL (known defect: the reason, harness.engine.compat), or n/a with the reason."""
    if c.note:
        return f"n/a: {c.note}"
    if c.diverged:
        return f"FAIL, {c.diverged}"
    return f"FAIL (known defect: {c.known})" if c.known else c.status.upper()


def _meaning(result: CaseResult, check: Check) -> str:
    return next((f.description for f in result.figures if f.name == check.name), "")


@dataclass(frozen=True)
class Column:
    """A column of the gated-checks table: its header, its cell's HTML for one check of a case, and the
    cell's CSS class (``num`` keeps a number on one line and right-aligned)."""

    header: str
    cell: Callable[[Check, CaseResult], str]
    css: str = ""


def _measured(c: Check) -> str:
    return "—" if c.diverged or c.note else fmt_value(c.value)


def _part(name: str) -> Callable[[Check, CaseResult], str]:
    def cell(c: Check, r: CaseResult) -> str:
        value = None if c.budget is None else c.budget.explained.get(name)
        return "" if value is None else f"{value:.2e}"
    return cell


def _unexplained(c: Check) -> str:
    return "" if c.budget is None or c.diverged else fmt_value(c.budget.unexplained)


def _limit(c: Check) -> str:
    return "—" if c.note or c.diverged else fmt_value(c.threshold)


CHECK_COLUMNS: tuple[Column, ...] = (
    Column("check", lambda c, r: _esc(c.name).replace(".", ".<wbr>"), "name"),  # breaks after a dot only
    Column("measured", lambda c, r: _measured(c), "num"),
    *(Column(f"{part}", _part(part), "num part") for part in PARTS),
    Column("unexplained", lambda c, r: _unexplained(c), "num"),
    Column("limit", lambda c, r: _limit(c), "num"),
    Column("unit", lambda c, r: _esc(c.unit)),
    Column("used", lambda c, r: _bar(ratio(c)), "used"),
    Column("verdict", lambda c, r: _esc(_status(c)), "verdict"),
    Column("meaning", lambda c, r: _esc(_meaning(r, c)), "dim meaning"),
)
"""The gated-checks table, left to right: a new column is one more entry. The budget's parts
(harness.budget.PARTS, in their order) appear where some check of the case has them; for a check with
a fixed limit the measured figure is what the limit applies to."""


def _columns(checks: Sequence[Check], columns: Sequence[Column]) -> list[Column]:
    """``columns`` less the budget parts no check of ``checks`` has."""
    shown = set(parts_shown(checks))
    return [col for col in columns if "part" not in col.css.split() or col.header in shown]


def _checks_table(result: CaseResult, checks: Sequence[Check], columns: Sequence[Column] = CHECK_COLUMNS) -> str:
    groups: dict[str, list[Check]] = {}
    for c in checks:
        groups.setdefault(c.name.group, []).append(c)
    return _table([(_esc(_group_title(group, result)), result, cs) for group, cs in groups.items()],
                  _columns(checks, columns))


def _table(groups: Sequence[tuple[str, CaseResult, Sequence[Check]]], columns: Sequence[Column]) -> str:
    """A checks table: per group, a row with its title (HTML) across the table, then a row per check."""
    body = []
    for title, result, cs in groups:
        body.append(f"<tr class='group'><td colspan='{len(columns)}'>{title}</td></tr>")
        diverged: dict[str, list[Check]] = {}  # a run that diverged: its checks in one row, its cause said once
        for c in cs:
            if c.diverged:
                diverged.setdefault(c.diverged, []).append(c)
        for c in cs:
            if c.diverged and len(diverged.get(c.diverged, ())) > 1:
                same = diverged.pop(c.diverged)
                names = ", ".join(_esc(d.name).replace(".", ".<wbr>") for d in same)
                body.append(f"<tr class='fail'><td class='name'>{names}</td><td colspan='{len(columns) - 1}'>"
                            f"FAIL ({len(same)} checks, one run): {_esc(c.diverged)}</td></tr>")
                continue
            if c.diverged and c.diverged not in diverged:
                continue  # listed with the others of its run
            body.append(f"<tr class='{'na' if c.note else 'pass' if c.passed else 'fail'}'>"
                        + "".join(f"<td class='{col.css}'>{col.cell(c, result)}</td>" if col.css else
                                  f"<td>{col.cell(c, result)}</td>" for col in columns) + "</tr>")
    head = "".join(f"<th>{_esc(col.header)}</th>" for col in columns)
    return f"<table class='checks'><tr>{head}</tr>{''.join(body)}</table>"


def section_failures(results: Sequence[CaseResult], outcome: Outcome | Mapping[str, Sequence[Check]]) -> str:
    """Every failed check of the run with its budget, in the case pages' columns, under its case (linked to
    the case's table), or that none failed."""
    checks = _outcome(outcome).checks
    failed = [(r, [c for c in checks[r.case.name] if not c.passed]) for r in results]
    groups = [(f"<a href='{_esc(case_page(r.case.name))}#checks'>{_esc(r.case.name)}</a>: {len(cs)} of "
               f"{len(checks[r.case.name])} checks fail", r, cs) for r, cs in failed if cs]
    body = (_table(groups, _columns([c for _, cs in failed for c in cs], CHECK_COLUMNS)) if groups
            else "<p>None: every check is within what its budget explains.</p>")
    return f"<section id='failures'><h2>Failed checks, with their budgets</h2>{body}</section>"


def section_model(result: CaseResult, still: Still | None) -> str:
    """The model still (or why there is none) beside the derived equations of motion."""
    if still is not None and still.png is not None:
        uri = "data:image/png;base64," + base64.b64encode(still.png).decode("ascii")
        image = (f"<figure><img class='still' src='{uri}' alt='{_esc(result.case.name)} model at its initial state'>"
                 f"<figcaption>{_esc(Path(result.settings.mjcf).name)} at the initial "
                 f"state (rendered headless, MUJOCO_GL={_esc(still.backend)}; joints drawn: a hinge as an "
                 f"arrow on its axis, a ball as a sphere)</figcaption></figure>")
    else:
        note = still.note if still is not None else "model image not rendered"
        image = f"<p class='note'>{_esc(note)}</p>"
    return f"<div class='model'><div>{image}</div>{equations_html(result.case.system)}</div>"


@functools.cache
def equations_html(system: str) -> str:
    """The system's equations of motion as typeset images, once per system (a system's cases share
    them; sympy's simplification and mathtext are costly); for a model's own tree, what they are."""
    if system == TREE:
        return ("<dl class='eqs'><dt>equations of motion</dt><dd>Lagrange's equations of the model's own kinematic "
                "tree: T and V from our forward kinematics of the compiled model, every derivative by complex step "
                "(docs/design.md, \"Any model\"); numeric, so not typeset</dd></dl>")
    rows = []
    for eq in equations(derivation(system)):
        uri = png_data_uri(eq.shown)
        shown = (f"<img class='eq' src='{uri}' alt='{_esc(eq.latex)}'>" if uri
                 else f"<span class='formula'>{text_html(latex_text(eq.latex))}</span>")
        rows.append(f"<dt>{_esc(eq.label)}</dt><dd>{shown}</dd>")
    return ("<div><h3>Equations of motion (derived by sympy)</h3>"
            "<p class='dim'>Lagrange's equations M q̈ − F − Jᵀλ = 0, one per coordinate, with the "
            "constraints f(q) = 0. The LaTeX of each line is the image's alt text.</p>"
            f"<dl class='eqs'>{''.join(rows)}</dl></div>")


_UNITS = {"timestep": "s", "horizon": "s", "tolerance": ""}


OWN_CHANGES = ("What the comparison changed in the model", "as written", "as compared")
"""A model of one's own has no shipped model: what its section of changes is called instead, and its columns."""
OWN_CHANGES_NOTE = ("Each force the reference does not model was switched off for the comparison (What was "
                    "examined); these are those edits, attribute by attribute, and any setting the run changed.")


def _differences(result: CaseResult) -> str:
    """The case page's part on what the model run differs in from the shipped one (for a model of one's own, what
    the comparison changed in it): '' where nothing."""
    table = _difference_table(result)
    if not table:
        return ""
    if result.settings.tree is not None:
        return (f"<section id='differences'><h3>{OWN_CHANGES[0]}</h3><p class='dim'>{OWN_CHANGES_NOTE}</p>"
                f"{table}</section>")
    return (f"<section id='differences'><h3>What differs from the shipped model</h3><p class='dim'>The reference "
            f"is built from the model run: these parameters are its own.</p>{table}</section>")


def section_differences(results: Sequence[CaseResult]) -> str:
    """Per case, every way the model run differs from the shipped one (each attribute written otherwise, its
    damping as any other; its parameters; its settings), or that none does; '' where every model is one's own,
    which has no shipped model (its case page lists what the comparison changed in it)."""
    results = [r for r in results if r.settings.tree is None]
    if not results:
        return ""
    parts = [f"<h3><a href='{_esc(case_page(r.case.name))}#differences'>{_esc(r.case.name)}</a> <span class='dim'>"
             f"({_esc(Path(r.settings.mjcf).name)})</span></h3>{table}"
             for r in results if (table := _difference_table(r))]
    body = ("<p class='dim'>The reference of each is built from the model run: these parameters are its "
            f"own.</p>{''.join(parts)}" if parts else "<p>Nothing: every case ran its shipped model at its "
                                                        "shipped settings.</p>")
    return f"<section id='differences'><h2>What differs from the shipped model</h2>{body}</section>"


def _difference_table(result: CaseResult) -> str:
    """What the model run differs in from the shipped one (its parameters the reference was built with,
    its settings) and how the initial state was brought onto its constraints: '' where nothing."""
    changed = result.settings.changed
    projected = result.settings.projected
    if not changed and not projected:
        return ""
    rows = "".join(f"<tr><td>{_esc(k)}</td><td class='num'>{_esc(_setting(v.get('shipped')))}</td>"
                   f"<td class='num'>{_esc(_setting(v.get('tested')))}</td></tr>" for k, v in changed.items())
    before, after = ("shipped", "this run") if result.settings.tree is None else OWN_CHANGES[1:]
    table = (f"<table class='settings'><tr><th>parameter or setting</th><th>{before}</th><th>{after}</th></tr>"
             f"{rows}</table>") if rows else ""
    moved = (f"<p class='dim'>Initial state brought onto the constraints of these parameters: "
             f"{_esc('; '.join(projected))}.</p>") if projected else ""
    return f"{table}{moved}"


COVERED = ("gravity, every body's mass and inertia, the joints (their kind, anchor, axis and ref), armature, joint "
           "springs and damping, gravity compensation, actuators at the control given, equality constraints")
"""What the reference derived from a model's own tree covers (harness.reference.tree)."""


def _grouped(names: Sequence[str]) -> str:
    """Names, those of two or more sharing a first word written once under it ("actuator: a1, a2")."""
    kinds: dict[str, list[str]] = {}
    for name in names:
        kind, _, rest = name.partition(" ")
        kinds.setdefault(kind, []).append(rest or kind)
    out = []
    for name in names:
        kind = name.partition(" ")[0]
        members = kinds.pop(kind, None)
        if members is None:
            continue  # written with the first of its kind
        out.append(name if len(members) < 2 else f"{kind} {', '.join(members)}")
    return "; ".join(out)


def scope(result: CaseResult, checks: Sequence[Check]) -> str:
    """For a model judged against its own tree, the first screen's account of what was examined: the model, what
    its reference covers, what it does not (switched off for the comparison, judged by the balance alone), the
    checks run and on which integrators; '' for a shipped case."""
    tree: Mapping[str, Any] | None = result.settings.tree
    if not tree:
        return ""
    gaps = list((tree.get("not examined") or {}).keys())
    na = sum(bool(c.note) for c in checks)
    failed = sum(not c.passed for c in checks)
    not_examined = (f"<b>Not in the reference</b> (switched off for the comparison; the model as it is judged by its "
                    f"work–energy balance only): {_esc(_grouped(gaps))}." if gaps else
                    "<b>Not in the reference</b>: nothing this model has.")
    return (f"<div class='scope'><p><b>{_esc(result.case.name)}</b> ({_esc(Path(result.settings.mjcf).name)}, "
            f"{len(result.settings.q0)} coordinates) judged against its own kinematic tree. <b>Examined</b>: "
            f"{COVERED}. {not_examined} <b>Checks run</b>: {len(checks)} ({len(checks) - failed - na} pass, "
            f"{failed} fail, {na} n/a) on {_esc(', '.join(result.settings.integrators))} over "
            f"{_setting(result.settings.horizon)} s.</p></div>")


def _examined(result: CaseResult) -> str:
    """For a model judged against its own tree: what the reference covers, what it does not (switched off for the
    comparison), how the model as it is was judged instead, how the horizon was chosen, and the reference's solver
    and tolerance; '' for a shipped case."""
    tree: Mapping[str, Any] | None = result.settings.tree
    if not tree:
        return ""
    gaps = tree.get("not examined") or {}
    covered = f"<p>Checked against the reference derived from the model's own tree: {COVERED}.</p>"
    if gaps:
        rows = "".join(f"<li><b>{_esc(k)}</b>: {_esc(v)}</li>" for k, v in gaps.items())
        covered += (f"<p>Not in the reference, so switched off for that comparison:</p><ul>{rows}</ul>"
                    "<p>The model as it is, with these acting, is judged by the work–energy balance "
                    "(<code>INTEGRATOR.balance</code>: its energy change against the work of every force MuJoCo "
                    "applied).</p>")
    solved = "".join(f"<p class='dim'>{label}: {_esc(tree[key])}.</p>" for key, label in
                     (("reference solver", "The reference's solver"), ("reference tolerance", "Its tolerance"))
                     if tree.get(key))
    return (f"<section id='examined'><h3>What was examined</h3>{covered}<p class='dim'>"
            f"{_esc(tree.get('horizon', ''))}.</p>{solved}</section>")


def _stability(result: CaseResult) -> str:
    """Each explicit integrator against its stability region at the model's step, the model's own first (where one
    is beyond, its figures are n/a: :mod:`harness.families.stability`); '' where none was assessed."""
    if not result.stability:
        return ""
    items = "".join(f"<li>{'<b>' if s.beyond else ''}{_esc(s.statement())}{'</b>' if s.beyond else ''}</li>"
                    for s in result.stability.values())
    return f"<section id='stability'><h3>Stability at the model's step</h3><ul>{items}</ul></section>"


def _findings(result: CaseResult) -> str:
    """Engine functions that disagree with what they should compute, found while measuring: '' if none."""
    if not result.findings:
        return ""
    items = "".join(f"<li><b>{_esc(f.function)}</b>: {_esc(f.measure)} = {fmt_value(f.value)} {_esc(f.unit)}. "
                    f"{_esc(f.detail)}.</li>" for f in result.findings)
    return (f"<div class='note'><b>Engine finding{'s' * (len(result.findings) > 1)}</b> (the harness "
            f"corrects for it to take its own measurement):<ul>{items}</ul></div>")


def section_findings(results: Sequence[CaseResult]) -> str:
    """The engine functions found to disagree with what they should compute, per case: '' where none."""
    found = "".join(f"<h3><a href='{_esc(case_page(r.case.name))}'>{_esc(r.case.name)}</a></h3>{_findings(r)}"
                    for r in results if r.findings)
    return f"<section id='findings'><h2>Engine findings</h2>{found}</section>" if found else ""


def section_requirements(results: Sequence[CaseResult], outcome: Outcome) -> str:
    """The requirements stated for the run, judged on each case's own integrator: '' where none was."""
    tables = "".join(f"<h3><a href='{_esc(case_page(r.case.name))}#fitness'>{_esc(r.case.name)}</a></h3>"
                     f"{_fitness_table(fit, heading=False)}"
                     for r in results if (fit := outcome.fitness.get(r.case.name, ())))
    return (f"<section id='requirements'><h2>Fitness for purpose (each model's own integrator)</h2>{tables}"
            "</section>") if tables else ""


def section_pages(pages: Sequence[Page]) -> str:
    """The report's other pages (the studies, the seed audit), linked: '' where there are none."""
    items = "".join(f"<li><a href='{_esc(p.name)}'>{_esc(p.title)}</a>: {_esc(p.about)}</li>" for p in pages)
    return f"<section id='pages'><h2>Other pages</h2><ul>{items}</ul></section>" if items else ""


def _fitness_table(fitness: Sequence[Fitness], *, heading: bool = True) -> str:
    if not fitness:
        return ""
    rows = "".join(f"<tr class='{'pass' if f.met else 'fail'}'><td class='name'>{_esc(f.figure)}</td>"
                   f"<td class='num'>{fmt_value(f.value)}</td><td class='num'>{f.requirement.value:g}</td>"
                   f"<td>{_esc(f.unit)}</td><td class='verdict'>{'met' if f.met else 'NOT MET'}</td></tr>"
                   for f in fitness)
    table = ("<table class='checks'><tr><th>figure</th><th>measured</th><th>required</th><th>unit</th>"
             f"<th>verdict</th></tr>{rows}</table>")
    return (f"<section id='fitness'><h3>Fitness for purpose (the model's own integrator)</h3>{table}</section>"
            if heading else table)


def section_case(result: CaseResult, checks: Sequence[Check], still: Still | None, *, plots: str,
                 fitness: Sequence[Fitness] = ()) -> str:
    """One case: model and equations, what differs from the shipped model, engine findings, fitness
    for the stated requirements, gated checks, plots (already drawn: :func:`section_plots`), the rest."""
    c = result.case
    fitness_table = _fitness_table(fitness)
    failed = sum(not ch.passed for ch in checks)
    verdict = "PASS" if not failed else "FAIL"
    gated = {ch.name for ch in checks}
    info = "".join(f"<tr><td>{_esc(f.name)}</td><td class='num'>{fmt_value(f.value)}</td>"
                   f"<td>{_esc(f.unit)}</td><td class='dim'>{_esc(f.description)}</td></tr>"
                   for f in result.figures if f.name not in gated)
    settings = "".join(f"<tr><td>{_esc(k)}</td><td>{_esc(_setting(v))} {_UNITS.get(k, '')}</td></tr>"
                       for k, v in result.settings.as_dict().items()
                       if k not in ("changed", "projected", "tree", "stability"))
    return (f"<section id='case'><h2>{_esc(c.name)} <span class='badge {verdict.lower()}'>"
            f"{verdict} {len(checks) - failed}/{len(checks)}</span></h2>{scope(result, checks)}"
            f"<p>{_esc(c.description)}</p>{section_model(result, still)}{_examined(result)}{_stability(result)}"
            f"{_differences(result)}"
            f"{_findings(result)}{fitness_table}"
            f"<section id='checks'><h3>Gated checks</h3>{_checks_table(result, checks)}</section>"
            f"<section id='plots'><h3>Plots</h3><div class='plots'>{plots}</div></section>"
            f"<section id='figures'><details class='more'><summary><h3>Other figures (measured, not gated)</h3> "
            f"<span class='dim'>{len(result.figures) - len(gated & {f.name for f in result.figures})} figures"
            f"</span></summary><table class='info'><tr><th>figure</th><th>value</th>"
            f"<th>unit</th><th>meaning</th></tr>{info}</table></details></section>"
            f"<section id='settings'><details class='more'><summary><h3>Settings used</h3> <span class='dim'>"
            f"timestep, integrator, solver, softness, parameters, the file run</span></summary>"
            f"<table class='settings'>{settings}</table></details></section></section>")


_STYLE = """
*{box-sizing:border-box}
body{font-family:system-ui,-apple-system,"Segoe UI",sans-serif;max-width:1180px;margin:0 auto;padding:.6em 16px 3em;
color:#222;line-height:1.4;font-size:15px}
h1{margin:.3em 0 .2em} h2{border-bottom:2px solid #ddd;padding-bottom:.15em;margin-top:1.8em;scroll-margin-top:.5em}
h3{margin:1.2em 0 .35em} section{scroll-margin-top:.5em}
p,li,dd,td{overflow-wrap:break-word}
table{border-collapse:collapse;margin:.4em 0;font-size:.86em;max-width:100%}
td,th{border:1px solid #d4d4d4;padding:2px 7px;text-align:left;vertical-align:middle}
th{background:#f3f3f3} td.num{font-family:ui-monospace,monospace;text-align:right;white-space:nowrap}
.nb{white-space:nowrap}
.scope{background:#f6f8fb;border:1px solid #dde3ec;border-radius:4px;padding:0 .8em;margin:.5em 0}
tr.fail td{background:#fde4e4} td.verdict{font-weight:bold} tr.pass td.verdict{color:#17701d}
tr.fail td.verdict{color:#b00000} tr.na td{color:#888} tr.group td{background:#eef2f7;font-weight:bold}
tr.shipped td{font-weight:bold} tr.ambiguous td{background:#fff6d5}
table.checks{width:100%;font-size:.82em} table.checks td,table.checks th{padding:2px 4px}
table.checks td.name{overflow-wrap:normal} table.checks td.meaning{min-width:9em}
table.info td:first-child,table.settings td:first-child{white-space:nowrap}
.dim{color:#666} .note{background:#fff6d6;border:1px solid #e7c75a;padding:.6em;border-radius:4px}
.banner{font-size:1.25em;font-weight:bold;padding:.5em .8em;border-radius:5px;margin:.6em 0}
.banner.pass{background:#e3f4e4;color:#17701d;border:1px solid #9ad09e}
.banner.fail{background:#fde4e4;color:#b00000;border:1px solid #e8a0a0}
.badge{font-size:.6em;padding:2px 8px;border-radius:10px;vertical-align:middle}
.badge.pass{background:#e3f4e4;color:#17701d} .badge.fail{background:#fde4e4;color:#b00000}
.bar{display:inline-block;width:40px;height:9px;background:#eee;margin-right:4px;vertical-align:middle}
.bar span{display:block;height:100%} .bar .ok{background:#6aa86f} .bar .over{background:#d33}
td.used{white-space:nowrap;font-family:ui-monospace,monospace}
.model{display:grid;grid-template-columns:minmax(0,380px) minmax(0,1fr);gap:24px;align-items:start}
.model figure{margin:0} .model img.still{width:100%;border:1px solid #ccc;display:block}
figcaption{font-size:.8em;color:#666} .model h3{margin-top:0}
dl.eqs{margin:0} dl.eqs dt{font-size:.8em;color:#666;margin-top:.45em} dl.eqs dd{margin:0 0 0 .5em}
img.eq,img.formula{max-width:100%;display:block}
.plots{display:flex;flex-wrap:wrap;align-items:flex-start;gap:8px 10px} .plots img{max-width:100%;display:block}
section img{max-width:100%}
.howto{background:#f7f9fc;border:1px solid #dde3ec;padding:.4em .8em;border-radius:5px;margin:.6em 0}
.howto summary{font-weight:bold;cursor:pointer} .howto li{margin:.25em 0}
nav.pages{font-size:.9em;margin:.3em 0} nav.pages a{white-space:nowrap}
nav.toc{border:1px solid #dde3ec;border-radius:5px;padding:.2em .9em .5em;margin:.6em 0;background:#fbfcfe}
nav.toc h2{font-size:1.1em;border:none;margin:.4em 0 .2em} nav.toc ol{margin:0;padding-left:1.4em}
nav.toc li{margin:.12em 0} nav.toc ul{display:flex;flex-wrap:wrap;gap:0 1.1em;list-style:none;padding:0;margin:0}
nav.toc ul li{font-size:.9em}
a.to-contents{position:fixed;right:14px;bottom:14px;background:#fff;border:1px solid #bbb;border-radius:14px;
padding:3px 10px;font-size:.85em;text-decoration:none;box-shadow:0 1px 3px rgba(0,0,0,.15)}
.claims{display:grid;gap:10px} .claim{border:1px solid #e0c2c2;border-left:5px solid #c33;border-radius:4px;
padding:.2em .8em .5em;background:#fffafa}
.claim.ambiguous{border-color:#e9d9a0;border-left-color:#d6a800;background:#fffdf3}
.claim p{margin:.35em 0} .claim .verdict{font-weight:bold;margin:0 .5em}
.claim dl{display:grid;grid-template-columns:6.5em minmax(0,1fr);gap:.3em .9em;margin:.3em 0}
.claim dt{color:#666;font-size:.88em} .claim dd{margin:0}
table.audit td:nth-child(4){font-family:ui-monospace,monospace;font-size:.95em}
details.more{margin:1em 0} details.more summary{cursor:pointer} details.more summary h3{display:inline}
footer{margin-top:2em;font-size:.8em;color:#666}
@media (max-width:860px){.model{grid-template-columns:minmax(0,1fr)}}
"""


def model_stills(results: Sequence[CaseResult]) -> dict[str, Still]:
    """A still of each case's model (the file actually run), rendered in a child process."""
    return stills([Request(case=r.case.name, mjcf=r.settings.mjcf,
                           coordinates=tuple(r.settings.q0) if r.case.tree is not None
                           else tuple(q.name for q in derivation(r.case.system).system.q),
                           qpos=_start_qpos(r) if r.case.tree is not None else ())
                   for r in results])


def _start_qpos(result: CaseResult) -> tuple[float, ...]:
    """MuJoCo's qpos at a tree case's start, through its binding (the render child knows no such case)."""
    model = compile_model(result.case.mjcf, edit=result.case.prepare)
    data = mujoco.MjData(model)
    q0 = result.settings.q0
    binding = result.case.binding
    assert binding is not None  # a tree case is bound by its tree
    binding(tuple(q0)).set_state(model, data, list(q0.values()), [0.0] * len(q0))
    return tuple(float(x) for x in data.qpos)


OWN_LIMITS = "each figure's default (a model of one's own has no limits file: mjharness figures gives each basis)"


def render_pages(results: Sequence[CaseResult], outcome: Outcome | Mapping[str, Sequence[Check]], *,
                 stills: Mapping[str, Still] | None = None, config_source: str | None = None,
                 pages: Sequence[Page] = (), plots: Mapping[str, str] | None = None,
                 banners: Sequence[tuple[str, bool]] = ()) -> dict[str, str]:
    """Every page of the report by its path relative to the output directory: the overview
    (:data:`OVERVIEW`), a page per case (:func:`case_page`) and ``pages`` (the studies, the seed audit).
    ``banners``: further (line, passed) under the verdict on the first screen (the inertia audit's).
    ``stills`` defaults to rendering each model now (see harness.render); ``plots``, each case's
    :func:`section_plots` by case name, are drawn now where not given."""
    if bad := [p.name for p in pages if p.name not in PAGES]:
        raise ValueError(f"pages {bad} are not pages of the report ({', '.join(PAGES)})")
    with ThreadPoolExecutor(max_workers=1) as pool:  # the stills render in a child process meanwhile
        pending = pool.submit(model_stills, results) if stills is None else None
        plots = {r.case.name: (plots or {}).get(r.case.name) or section_plots(r) for r in results}
        for system in dict.fromkeys(r.case.system for r in results):
            equations_html(system)  # typeset while the stills render
        shown = pending.result() if pending is not None else stills or {}
    outcome = _outcome(outcome)
    if config_source == SHIPPED_SOURCE and all(r.settings.tree is not None for r in results):
        config_source = OWN_LIMITS  # no case, so no limits file: every figure's default
    source = f" Limits from {_esc(config_source)}." if config_source else ""
    overview = (section_summary(results, outcome) + section_failures(results, outcome)
                + section_differences(results) + section_findings(results) + section_requirements(results, outcome)
                + section_pages(pages))
    scopes = "".join(scope(r, outcome.checks[r.case.name]) for r in results)
    out = {OVERVIEW: _document("mjharness report", overview, pages=pages, source=source,
                               top=section_banner(results, outcome) + "".join(
                                   f"<p class='banner {'pass' if ok else 'fail'}'>{_esc(text)}</p>"
                                   for text, ok in banners) + scopes, howto=True)}
    names = [case_page(r.case.name) for r in results]
    for k, r in enumerate(results):
        body = section_case(r, outcome.checks[r.case.name], shown.get(r.case.name), plots=plots[r.case.name],
                            fitness=outcome.fitness.get(r.case.name, ()))
        neighbours = [(f"← {results[k - 1].case.name}", names[k - 1])] if k else []
        neighbours += [(f"{results[k + 1].case.name} →", names[k + 1])] if k + 1 < len(results) else []
        out[names[k]] = _document(f"mjharness report: {r.case.name}", body, pages=pages, source=source,
                                  root="../", neighbours=neighbours)
    for page in pages:
        out[page.name] = _document(f"mjharness report: {page.title.lower()}", "".join(page.sections), pages=pages,
                                   source=source)
    return out


def _document(title: str, body: str, *, pages: Sequence[Page], source: str, root: str = "", top: str = "",
              howto: bool = False, neighbours: Sequence[tuple[str, str]] = ()) -> str:
    """One page of the report: its title, the versions, the links to the other pages (``root``: the way
    from this page to the output directory), ``top`` (the verdict), its own contents, how to read it (open
    on the overview, folded elsewhere), ``body`` and the footer."""
    ver = ", ".join(f"{k} {v}" for k, v in versions().items())
    links = [("overview", OVERVIEW), *((p.title, p.name) for p in pages), *neighbours]
    nav = " · ".join(f"<a href='{_esc(root + href)}'>{_esc(text)}</a>" for text, href in links)
    howto_box = _HOW_TO_READ if howto else _HOW_TO_READ.replace("<details class='howto' open>",
                                                               "<details class='howto'>")
    page = (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            f"<meta name='viewport' content='width=device-width, initial-scale=1'><title>{_esc(title)}</title>"
            f"<style>{_STYLE}</style></head><body><h1>{_esc(title)}</h1>"
            f"<p class='dim'>MuJoCo checked against analytical mechanics. Versions: {_esc(ver)}.{source}</p>"
            f"<nav class='pages'>{nav}</nav>{top}{table_of_contents(body)}{howto_box}{body}"
            f"<footer>Generated by mjharness {_esc(__version__)}; the same figures are in report.json, "
            f"a summary in summary.md.</footer></body></html>\n")
    return unbroken_numbers(page)


def render_markdown(results: Sequence[CaseResult], outcome: Outcome | Mapping[str, Sequence[Check]], *,
                    audit: Mapping[str, object] | None = None) -> str:
    """A CI job summary: the verdict (and the requirements'), one row per case, the failures with their
    budgets, the engine findings, every check folded away; then the seed audit's counts and flagged
    claims where ``audit`` (report.json's "audit" entry) is given."""
    outcome = _outcome(outcome)
    judged = dataclasses.replace(outcome, checks={r.case.name: outcome.checks[r.case.name] for r in results})
    checks = judged.checks
    failed = [c for r in results for c in checks[r.case.name] if not c.passed]
    head = [f"**{verdict_line(judged)}**"]
    if fitness_line(judged):
        head.append(f"**{fitness_line(judged)}**")
    lines = ["# mjharness summary", "", *head, "",
             "| case | verdict | checks passed | closest to its limit among those passing (used) |",
             "|---|---|---|---|"]
    for r in results:
        cs = checks[r.case.name]
        bad = sum(not c.passed for c in cs)
        tight = closest_check([c for c in cs if c.passed and not c.known])  # the failures are listed below
        closest = f"{tight.name} ({ratio_text(ratio(tight))})" if tight else "no passing gates" if cs else "no gates"
        lines.append(f"| {markdown_cell(r.case.name)} | {'pass' if not bad else '**FAIL**'} | "
                     f"{len(cs) - bad}/{len(cs)} | {markdown_cell(closest)} |")
    if failed:
        lines += ["", "## Failed checks", "", "| case | check | measured | why |", "|---|---|---|---|"]
        lines += [f"| {markdown_cell(c.case)} | {markdown_cell(c.name)} | {_measured(c)} {c.unit} | "
                  f"{markdown_cell(_failure_text(c))} |" for c in failed]
    limited = [(r.case.name, s.statement()) for r in results for s in r.stability.values() if s.beyond]
    if limited:  # the model's own integrator first; their figures are n/a
        lines += ["", "## Beyond a stability limit (the method's, not MuJoCo's defect: figures n/a)", ""]
        lines += [f"- {markdown_cell(case)}: {markdown_cell(text)}" for case, text in limited]
    findings = [(r.case.name, f) for r in results for f in r.findings]
    if findings:
        lines += ["", "## Engine findings", ""]
        lines += [f"- {markdown_cell(case)}: **{markdown_cell(f.function)}** — {markdown_cell(f.measure)} = "
                  f"{fmt_value(f.value)} {f.unit}. {markdown_cell(f.detail)}." for case, f in findings]
    unmet = judged.unmet
    if unmet:
        lines += ["", "## Requirements not met", "", "| case | figure | measured | required | unit |",
                  "|---|---|---|---|---|"]
        lines += [f"| {markdown_cell(f.case)} | {markdown_cell(f.figure)} | {fmt_value(f.value)} | "
                  f"{f.requirement.value:g} | {f.unit} |" for f in unmet]
    lines += ["", "<details><summary>Every check</summary>", "",
              "| case | check | measured | explained | unexplained | limit | used | verdict |",
              "|---|---|---|---|---|---|---|---|"]
    for r in results:
        for c in checks[r.case.name]:
            explained = "" if c.budget is None else ", ".join(f"{k} {v:.2e}" for k, v in c.budget.explained.items())
            lines.append(f"| {markdown_cell(r.case.name)} | {markdown_cell(c.name)} | {_measured(c)} | "
                         f"{markdown_cell(explained)} | {_unexplained(c)} | {_limit(c)} | {ratio_text(ratio(c))} | "
                         f"{c.status if c.passed else '**' + c.status + '**'}"
                         f"{', ' + markdown_cell(c.reason) if c.reason and not c.passed else ''} |")
    lines += ["", "</details>"]
    return "\n".join(lines) + "\n" + (audit_markdown(audit) if audit else "")


def audit_markdown(audit: Mapping[str, object]) -> str:
    """summary.md's part of the seed audit, from its JSON (harness.outputs.audit.json_rows): the counts and
    the refuted, slip and ambiguous claims with their corrected forms or readings."""
    c: Mapping = audit["counts"]  # type: ignore[assignment]
    claims: Mapping[str, Mapping] = audit["claims"]  # type: ignore[assignment]
    scope = "" if c["claims"] == c.get("of", c["claims"]) else f" (of {c['of']}: those about the systems run here)"
    lines = ["", "## Seed audit", "",
             f"{c['claims']} claims{scope}: {c['confirmed']} confirmed, {c['refuted']} refuted ({c['errors']} "
             f"errors, {c['transcription slips']} transcription slips), {c['ambiguous']} ambiguous", ""]
    flagged = {k: v for k, v in claims.items() if v["verdict"] != "confirmed"}
    if flagged:
        lines += ["| claim | line | verdict | corrected (document's notation) or readings |", "|---|---|---|---|"]
        for cid, v in flagged.items():
            fix = v["corrected"] or "; ".join(f"{x['label']}: {x['formula']}" for x in v["readings"])
            verdict = v["verdict"] + (f" ({v['cause']})" if v["cause"] else "")
            lines.append(f"| {cid} | {v['lines']} | {verdict} | {str(fix).replace('|', '∣')} |")
    return "\n".join(lines) + "\n"


def report_files(out: Path | str, results: Sequence[CaseResult], outcome: Outcome | Mapping[str, Sequence[Check]], *,
                 stills: Mapping[str, Still] | None = None, config_source: str | None = None,
                 pages: Sequence[Page] = (), appendix: Mapping[str, object] | None = None,
                 plots: Mapping[str, str] | None = None, banners: Sequence[tuple[str, bool]] = ()) -> dict[Path, str]:
    """The report's pages (:func:`render_pages`), report.json and summary.md in ``out``, rendered, by path.
    ``pages``/``appendix``: the further pages and JSON entries; ``plots``: each case's plots, already drawn;
    ``banners``: further first-screen lines (:func:`render_pages`)."""
    html_pages = render_pages(results, outcome, stills=stills, config_source=config_source, pages=pages, plots=plots,
                              banners=banners)
    texts = (render_json(results, outcome, appendix=appendix),
             render_markdown(results, outcome, audit=(appendix or {}).get("audit")))  # type: ignore[arg-type]
    return ({Path(out) / name: text for name, text in html_pages.items()}
            | {Path(out) / name: text for name, text in zip(REPORT_FILES[1:], texts, strict=True)})


def write_report(out: Path | str, results: Sequence[CaseResult], outcome: Outcome | Mapping[str, Sequence[Check]],
                 **options) -> list[Path]:
    """Write :func:`report_files` into ``out``: all rendered before anything is written, then the set
    replaced as a whole or not at all, an earlier report's pages this one has not removed with it
    (:func:`harness.outputs.files.write_atomic`)."""
    files = report_files(out, results, outcome, **options)
    prepare_output(out)
    return write_atomic(with_manifest(out, files), remove=superseded(out, files))

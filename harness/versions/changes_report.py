"""What ``mjharness versions`` shows: a text summary for the terminal, versions.html (per changed figure its
history over the releases as a table and a plot) and versions.json (every figure of every release, with
its noise and status, and every change).
"""

from __future__ import annotations

import html
import math
from collections import defaultdict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from harness.core.figures import FigureName
from harness.core.plotting import HALF_WIDTH, png_bytes, png_data_uri, pyplot
from harness.outputs.page import unbroken_numbers
from harness.versions.bisect import Bisection
from harness.versions.changes import NOISE_FACTOR, ULP_FLOOR, Change, History, Snapshot, history
from harness.versions.runs import NOISE_RUNS, ReleaseRun

__all__ = ["Comparison", "html_page", "json_doc", "text"]

SCHEMA = 1
TEXT_ROWS = 40  # rows of each list on the terminal; every row is in versions.html and versions.json

def noise_method(perturbations: Sequence[float] = NOISE_RUNS) -> str:
    """How the noise was measured, with the moves the runs used."""
    return (f"each figure's noise at a release is the most it moved when that release's check was rerun with "
            f"every initial coordinate and velocity moved by {', '.join(f'{p:+g}' for p in perturbations)} × "
            f"max(|x|, 1) (check --perturb), at least {ULP_FLOOR:.2g} × its size; a figure moved between two "
            f"releases when the change exceeds {NOISE_FACTOR:g} × the larger of their noises")


NOISE_METHOD = noise_method()


@dataclass(frozen=True)
class Comparison:
    """Everything one ``mjharness versions`` found: the runs (oldest first), the snapshots of those that ran,
    the changes (sorted), the check's options, and a bisection where one was asked."""

    runs: tuple[ReleaseRun, ...]
    snapshots: tuple[Snapshot, ...]
    changes: tuple[Change, ...]
    check_args: tuple[str, ...] = ()
    extras: tuple[str, ...] = ()
    seconds: float = 0.0
    bisection: Bisection | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)
    perturbations: tuple[float, ...] = NOISE_RUNS

    @property
    def errors(self) -> list[ReleaseRun]:
        return [r for r in self.runs if not r.ok]

    def changed_keys(self) -> list[tuple[str, str]]:
        """The figures with a flip or a move, in the order of their largest change."""
        return list(dict.fromkeys((c.case, c.figure) for c in self.changes if c.kind in ("flip", "moved")))


def _num(v: float | None) -> str:
    return "—" if v is None else f"{v:.4g}"


def _ratio(c: Change) -> str:
    r = c.ratio
    if r is None:
        return ""
    if math.isinf(r) or math.isnan(r):
        return f"×{r}"
    return f"×{r:.3g}"


def _line(c: Change) -> str:
    where = f"{c.release} (since {c.since})"
    what = f"{c.case} {c.figure}"
    if c.kind == "flip":
        return f"{where}  {what}: {c.status_old} -> {c.status_new}  ({_num(c.old)} -> {_num(c.new)})"
    noise = f", {c.in_noise:.3g} × noise" if c.in_noise is not None else ""
    return f"{where}  {what}: {_num(c.old)} -> {_num(c.new)}  {_ratio(c)}{noise}"


def _groups(changes: Sequence[Change]) -> list[str]:
    """Appeared and vanished figures, grouped by release and by integrator (or layer)."""
    groups: dict[tuple, list[Change]] = defaultdict(list)
    for c in changes:
        name = FigureName(c.figure)
        groups[(c.release, c.since, c.kind, name.integrator or name.layer)].append(c)
    out = []
    for (release, since, kind, group), members in sorted(groups.items()):
        cases = sorted({c.case for c in members})
        out.append(f"{release} (since {since})  {kind}: {len(members)} figure(s) of {group} in {len(cases)} "
                   f"case(s) ({', '.join(cases)})")
    return out


def text(comparison: Comparison) -> str:
    """The terminal summary: the releases run, the noise rule, then flips, moved figures (largest first),
    figures that appeared or vanished, and the releases that could not be run."""
    runs = comparison.runs
    ok = [r for r in runs if r.ok]
    built = sum(r.env_built for r in runs)
    reused = sum(not r.env_built and (r.ok or r.check_seconds > 0) for r in runs)
    lines = [f"MuJoCo {runs[0].release} .. {runs[-1].release}: {len(ok)} of {len(runs)} release(s) run "
             f"({', '.join(str(r.release) for r in runs)}); environments built {built}, reused {reused}; "
             f"{comparison.seconds:.0f} s",
             f"noise: {noise_method(comparison.perturbations)}"]
    if comparison.check_args:
        lines.append(f"check options: {' '.join(comparison.check_args)}")
    if comparison.extras:
        lines.append(f"extra packages: {' '.join(comparison.extras)}")
    flips = [c for c in comparison.changes if c.kind == "flip"]
    moved = [c for c in comparison.changes if c.kind == "moved"]
    sided = [c for c in comparison.changes if c.kind in ("appeared", "vanished")]
    for title, rows in ((f"{len(flips)} verdict flip(s)", [_line(c) for c in flips]),
                        (f"{len(moved)} figure change(s) beyond noise, largest first", [_line(c) for c in moved]),
                        (f"{len(sided)} figure(s) appeared or vanished", _groups(sided))):
        lines.append("")
        lines.append(title + (":" if rows else ""))
        lines += [f"  {r}" for r in rows[:TEXT_ROWS]]
        if len(rows) > TEXT_ROWS:
            lines.append(f"  ... {len(rows) - TEXT_ROWS} more in versions.html / versions.json")
    for r in comparison.errors:
        lines.append(f"\nMuJoCo {r.release} could not be run: {r.error}")
    for note in comparison.notes:
        lines.append(f"\n{note}")
    if comparison.bisection is not None:
        lines.append("\n" + comparison.bisection.text().rstrip())
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------ JSON
def json_doc(comparison: Comparison) -> dict:
    """versions.json: the releases and how each ran, the noise rule, every change, and every figure's
    history (value, noise, status per release; null where a release lacks it)."""
    snaps = comparison.snapshots
    keys = list(dict.fromkeys(k for s in snaps for k in [*s.figures, *s.statuses]))
    figures: dict[str, dict[str, object]] = defaultdict(dict)
    for key in keys:
        h = history(snaps, key)
        figures[key[0]][key[1]] = {"values": [p.value for p in h.points], "noise": [p.noise for p in h.points],
                                   "status": [p.status for p in h.points]}
    doc: dict = {
        "schema": SCHEMA, "kind": "mjharness-versions",
        "releases": [str(s.release) for s in snaps],
        "check_options": list(comparison.check_args), "extra_packages": list(comparison.extras),
        "noise": {"method": noise_method(comparison.perturbations), "perturbations": list(comparison.perturbations),
                  "factor": NOISE_FACTOR,
                  "ulp_floor": ULP_FLOOR},
        "runs": [{"release": str(r.release), "ran": r.ok, "error": r.error, "environment_built": r.env_built,
                  "environment_seconds": round(r.env_seconds, 2), "check_seconds": round(r.check_seconds, 2),
                  "versions": dict((r.doc or {}).get("versions", {}))} for r in comparison.runs],
        "seconds": round(comparison.seconds, 1),
        "changes": [c.as_dict() for c in comparison.changes],
        "figures": figures,
    }
    if comparison.bisection is not None:
        doc["bisect"] = comparison.bisection.as_dict()
    return doc


# ------------------------------------------------------------------ HTML
_STYLE = """
body { font-family: system-ui, sans-serif; max-width: 1000px; margin: 1em auto; color: #222; }
table { border-collapse: collapse; margin: .5em 0; font-size: 13px; }
td, th { border: 1px solid #ccc; padding: 2px 6px; text-align: left; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
tr.changed td { background: #fff3cd; }
.nb { white-space: nowrap; }
pre { white-space: pre-wrap; font-size: 12px; }
section { border-top: 1px solid #ddd; margin-top: 1.2em; }
.flip { color: #a00; font-weight: bold; }
img { display: block; max-width: 100%; }
"""


def _plot(h: History, marks: Sequence[str]) -> str:
    """The figure (and its noise) against the release, log scale where every value is positive; the
    releases where it changed marked."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(HALF_WIDTH, 2.6))
    labels = [str(p.release) for p in h.points]
    xs = list(range(len(labels)))
    vals = [p.value if p.value is not None and math.isfinite(p.value) else math.nan for p in h.points]
    noise = [p.noise if p.noise is not None and math.isfinite(p.noise) else math.nan for p in h.points]
    ax.plot(xs, vals, "o-", color="tab:blue", label="figure")
    ax.plot(xs, noise, "s:", color="tab:gray", label="noise")
    finite = [v for v in vals + noise if math.isfinite(v)]
    if finite and all(v > 0 for v in finite):
        ax.set_yscale("log")
    for k, label in enumerate(labels):
        if label in marks:
            ax.axvline(k - 0.5, color="tab:red", linestyle="--", linewidth=1)
    ax.set_xticks(xs, labels, rotation=60, ha="right", fontsize=7)
    ax.set_title(f"{h.case} {h.figure}")
    ax.legend(loc="best")
    alt = html.escape(f"{h.case} {h.figure} over the releases", quote=True)
    return f"<img alt='{alt}' src='{png_data_uri(png_bytes(fig))}'>"


def _history_table(h: History, marks: Sequence[str]) -> str:
    rows = []
    for p in h.points:
        cls = " class='changed'" if str(p.release) in marks else ""
        rows.append(f"<tr{cls}><td>{p.release}</td><td class='num'>{_num(p.value)}</td>"
                    f"<td class='num'>{_num(p.noise)}</td><td>{html.escape(p.status or '')}</td></tr>")
    return ("<table><tr><th>MuJoCo</th><th>value</th><th>noise</th><th>verdict</th></tr>" + "".join(rows)
            + "</table>")


def _change_rows(changes: Sequence[Change]) -> str:
    rows = []
    for c in changes:
        verdict = (f"<span class='flip'>{html.escape(c.status_old or '')} → {html.escape(c.status_new or '')}</span>"
                   if c.kind == "flip" else html.escape(c.status_new or ""))
        rows.append(f"<tr><td>{c.kind}</td><td>{c.release} (since {c.since})</td><td>{html.escape(c.case)}</td>"
                    f"<td>{html.escape(c.figure)}</td><td class='num'>{_num(c.old)}</td><td class='num'>{_num(c.new)}"
                    f"</td><td class='num'>{html.escape(_ratio(c))}</td><td class='num'>"
                    f"{'' if c.in_noise is None else f'{c.in_noise:.3g}'}</td><td>{verdict}</td></tr>")
    return ("<table><tr><th>change</th><th>at</th><th>case</th><th>figure</th><th>old</th><th>new</th>"
            "<th>new/old</th><th>change / noise</th><th>verdict</th></tr>" + "".join(rows) + "</table>")


def html_page(comparison: Comparison, *, plots: bool = True) -> str:
    """versions.html: the summary, every change in one table, then per changed figure its history."""
    snaps = comparison.snapshots
    summary = html.escape(text(comparison))
    by_key: Mapping[tuple[str, str], list[Change]] = defaultdict(list)
    for c in comparison.changes:
        by_key[(c.case, c.figure)].append(c)
    sections = []
    for n, key in enumerate(comparison.changed_keys()):
        h = history(snaps, key)
        marks = [str(c.release) for c in by_key[key]]
        plot = _plot(h, marks) if plots else ""
        sections.append(f"<section id='f{n}'><h3>{html.escape(key[0])} {html.escape(key[1])}</h3>"
                        f"{_change_rows(by_key[key])}<div style='display:flex;gap:12px;align-items:flex-start'>"
                        f"{_history_table(h, marks)}{plot}</div></section>")
    sided = [c for c in comparison.changes if c.kind in ("appeared", "vanished")]
    judged = [c for c in comparison.changes if c.kind in ("flip", "moved")]
    body = (f"<h1>mjharness versions: MuJoCo {comparison.runs[0].release} .. {comparison.runs[-1].release}</h1>"
            f"<pre>{summary}</pre><h2>Every change</h2>{_change_rows(judged) if judged else '<p>None.</p>'}"
            f"<h2>History of each changed figure</h2>"
            f"{''.join(sections) or '<p>No figure changed beyond its noise.</p>'}"
            f"<h2>Figures that appeared or vanished</h2>{_change_rows(sided) if sided else '<p>None.</p>'}")
    page = (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>mjharness versions</title>"
            f"<style>{_STYLE}</style></head><body>{body}</body></html>\n")
    return unbroken_numbers(page)

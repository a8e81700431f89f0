"""The report's inertia page (:mod:`harness.inertia`): a section per model audited, its bodies as a table, and
for each body with a finding or warning its declared and geometry-implied inertia ellipsoids drawn over its
geometry in three orthogonal projections; and the one-line summary per model the overview shows on its first
screen.

An inertia is drawn as its equivalent ellipsoid: the uniform solid ellipsoid of the same mass and second moment
(semi-axes √(5 λᵢ/m) along Σ's principal axes, about the centre of mass). The geometry-implied one is the
uniformly filled hull's, about the hull's centroid. An ellipsoid sticking out of the drawn hull is what the
upper bound says in numbers.
"""

from __future__ import annotations

import html

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from harness.core.plotting import FULL_WIDTH, png_bytes, png_data_uri, pyplot
from harness.inertia.audit import BodyAudit
from harness.inertia.bounds import second_moment
from harness.inertia.models import Inertials
from harness.outputs.files import INERTIA_PAGE
from harness.outputs.page import Page

__all__ = ["inertia_banners", "inertia_page"]

_VIEWS = ((0, 1, "top (x, y)"), (0, 2, "front (x, z)"), (1, 2, "side (y, z)"))


def _ellipse(plt_axes, centre: np.ndarray, sigma_per_kg: np.ndarray, i: int, j: int, **style) -> None:
    """The projection onto axes (i, j) of the equivalent ellipsoid of second moment ``sigma_per_kg`` (per kg)."""
    shape = 5 * sigma_per_kg  # the ellipsoid {x: xᵀ shape⁻¹ x ≤ 1} has second moment shape / 5 per unit mass
    sub = shape[np.ix_([i, j], [i, j])]
    values, vectors = np.linalg.eigh(sub)
    t = np.linspace(0, 2 * np.pi, 121)
    circle = np.vstack([np.cos(t), np.sin(t)]) * np.sqrt(np.clip(values, 0, None))[:, None]
    pts = vectors @ circle + centre[[i, j]][:, None]
    plt_axes.plot(pts[0], pts[1], **style)


def body_figure(body: BodyAudit) -> bytes:
    """Three projections of ``body``'s hull with its declared and geometry-implied inertia ellipsoids (PNG)."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(FULL_WIDTH, FULL_WIDTH / 3.2))
    hull = body.hull
    for ax, (i, j, title) in zip(axes, _VIEWS, strict=True):
        if hull is not None:
            flat = hull.vertices[:, [i, j]]
            try:
                outline = flat[ConvexHull(flat).vertices]
                ax.fill(outline[:, 0], outline[:, 1], color="0.85", label="geometry (hull)")
            except QhullError:
                ax.plot(flat[:, 0], flat[:, 1], ".", color="0.6", label="geometry (hull)")
            implied = second_moment(hull.inertia) / hull.volume
            _ellipse(ax, hull.centroid, implied, i, j, color="tab:blue", ls="--", label="implied by the geometry")
        _ellipse(ax, body.com, body.sigma / body.mass, i, j, color="tab:red", label="declared")
        ax.plot(*body.com[[i, j]], "+", color="tab:red", ms=9)
        ax.set_title(title)
        ax.set_aspect("equal", adjustable="datalim")
        ax.tick_params(labelsize=7)
    axes[0].legend(loc="upper left", fontsize=7)
    fig.suptitle(f"{body.body}: inertia ellipsoids over the body's geometry (body frame, m)", fontsize=9)
    return png_bytes(fig)


def _cell(x: float | None, fmt: str = ".3g") -> str:
    return "—" if x is None else format(x, fmt)


def model_section(inertials_index: int, audit) -> str:
    """One model's section: its summary, a table of its bodies, the pictures of the bodies with something said."""
    rows = "".join(
        f"<tr class='{'fail' if b.failing else ''}'><td>{html.escape(b.body)}</td><td>{b.mass:.4g}</td>"
        f"<td>{html.escape(b.kind + (' (accepted)' if b.accepted else ''))}</td><td>{_cell(b.upper)}</td>"
        f"<td>{_cell(b.lower)}</td><td>{'—' if b.outside is None else f'{b.outside * 1e3:.3g}'}</td>"
        f"<td>{_cell(b.implied)}</td><td>{html.escape(' or '.join(b.causes))}</td>"
        f"<td>{html.escape(b.effect.text()) if b.effect else ''}</td></tr>" for b in audit.bodies)
    table = ("<table><tr><th>body</th><th>mass (kg)</th><th>category</th><th>upper bound ratio</th>"
             "<th>lower bound ratio</th><th>centre of mass outside (mm)</th><th>tr Σ ÷ filled hull's</th>"
             "<th>likely cause</th><th>effect</th></tr>" + rows + "</table>")
    said = [b for b in audit.bodies if b.kind in ("finding", "warning", "inert")]
    pictures = "".join(
        f"<figure><img alt='{html.escape(b.body)}: inertia ellipsoids' src='{png_data_uri(body_figure(b))}'>"
        f"<figcaption>{html.escape(b.line())}</figcaption></figure>" for b in said)
    status = "fail" if audit.failed else "pass"
    return (f"<section id='inertia-{inertials_index}'><h2>{html.escape(audit.model)}</h2>"
            f"<p class='banner {status}'>{html.escape(audit.summary(timed=False))}</p>{table}{pictures}</section>")


_ABOUT = ("<section id='inertia-about'><h2>What this page checks</h2><p>Each body's inertial (mass, centre of "
          "mass, inertia) against the body's own geometry (every geom of the body, visual and collision): the "
          "second moment along every direction at most the mass times the geometry's farthest extent squared; "
          "the inertia at least the densest element's ball's (22,600 kg/m³); the centre of mass inside the "
          "hull. A wrong mass that is still physically possible passes. docs/inertia.md gives the bounds' "
          "basis.</p></section>")


def inertia_page(inertials: Inertials) -> list[Page]:
    """The report's inertia page (none where no model was audited)."""
    if not inertials.audits and not inertials.skipped:
        return []
    sections = [_ABOUT, *(model_section(k, a) for k, a in enumerate(inertials.audits))]
    sections += [f"<p>Inertials of {html.escape(n)} not audited: {html.escape(w)}</p>" for n, w in inertials.skipped]
    return [Page(INERTIA_PAGE, "Inertials", "each body's inertial against its own geometry, drawn where a bound "
                 "fails", tuple(sections))]


def inertia_banners(inertials: Inertials) -> list[tuple[str, bool]]:
    """The overview's first-screen line(s), each with whether it passes: each model's one-line summary where
    two models or fewer were audited, else one line for all (the failing models named)."""
    audits = inertials.audits
    if len(audits) <= 2:
        return [(a.summary(timed=False), not a.failed) for a in audits]
    failing = [a for a in audits if a.failed]
    count = sum(b.failing for a in audits for b in a.bodies)
    said = (f"{count} finding(s) in {', '.join(a.model for a in failing)}: FAIL" if failing else
            "no finding: PASS")
    return [(f"Inertials of {len(audits)} models against their geometry (the inertia page): {said}", not failing)]

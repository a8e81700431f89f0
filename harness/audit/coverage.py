"""Which lines of the two seed documents hold which claims, and why the other lines hold none.

The documents are read line by line (copies, byte for byte, in
``harness/audit/documents``; each file's name carries the start of its
sha256). Every non-blank line is split into units — its displayed formulas and
its sentences (:func:`units`) — and every unit must be covered by a
:class:`Passage`: one that lists the claims made there, or says why it holds
none (a heading, a definition, prose that announces the next display). A
passage with no anchors covers every unit of its lines; one with anchors covers
the units that contain one of them. tests/test_audit.py checks that every unit
of both documents is covered, that every anchor is found where its passage
says, and that every claim is placed, so no passage can be skipped silently.
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass
from importlib import resources

__all__ = ["lines_text", "not_checkable", "summary"]

DOCUMENTS = ("000_53d3a09bcd5afa0f.txt", "001_c29a5107db08e1d9.txt")

_ENVIRONMENT = r"\\begin\{(?:equation\*?|gather\*)\}.*?\\end\{(?:equation\*?|gather\*)\}"
_DISPLAY = re.compile(r"\$\$.*?\$\$|\\\[.*?\\\]|" + _ENVIRONMENT, re.S)
_SENTENCE = re.compile(r"(?:(?<=[.;?!])|(?<=[.;?!]\$))\s+(?=[A-Z•*\-$\\])")


@dataclass(frozen=True)
class Passage:
    """Lines ``first``–``last`` of a document: the claims they hold, or why they hold none (``reason``;
    a passage with claims may also give one for what in it is not a claim)."""

    first: int
    last: int
    claims: tuple[str, ...] = ()
    reason: str = ""
    anchors: tuple[str, ...] = ()


def P(lines: int | tuple[int, int], *claims: str, reason: str = "", anchors: tuple[str, ...] = ()) -> Passage:
    first, last = (lines, lines) if isinstance(lines, int) else lines
    return Passage(first, last, tuple(claims), reason, anchors)


HEADING = "section heading"
ANNOUNCES = "prose announcing the displays that follow"

LECTURE15: tuple[Passage, ...] = (
    P(1, reason="title: lecture number and date"),
    P(3, reason=HEADING),
    P(5, reason="the system and its coordinates, defined (which vertical θ is measured from is decided in "
                "000.spherical.V)"),
    P(6, "000.spherical.coordinates"),
    P(7, "000.spherical.T_components"),
    P(9, "000.spherical.T_components", "000.spherical.T",
      reason="'−T' is the converted list bullet before T, not a minus sign"),
    P(11, "000.spherical.V"),
    P(12, "000.spherical.conservative"),
    P((14, 15), "000.spherical.L", reason="line 14 is a lone bullet"),
    P(17, reason=ANNOUNCES),
    P(19, "000.spherical.dL_dthetadot"),
    P(21, "000.spherical.ddt_dL_dthetadot"),
    P(23, "000.spherical.dL_dtheta"),
    P(25, "000.spherical.dL_dphidot"),
    P(27, "000.spherical.ddt_dL_dphidot"),
    P(29, "000.spherical.dL_dphi"),
    P(31, reason=ANNOUNCES),
    P(33, "000.spherical.eom_theta"),
    P(35, "000.spherical.eom_phi"),
    P((37, 39), "000.spherical.cyclic"),
    P(41, "000.spherical.cyclic"),
    P(42, "000.spherical.p_phi"),
    P(43, "000.spherical.cyclic",
      reason="'∂L/∂q̇_k is a generalized momentum' is a definition (Goldstein §2.6, p_k = ∂L/∂q̇_k); 'it is a "
             "constant' repeats line 42"),
    P(45, reason=HEADING),
    P(47, reason="the system (a hoop on a ramp, x and ϕ) defined"),
    P(48, "000.hoop_ramp.dof"),
    P(49, "000.hoop_ramp.rolling", "000.hoop_ramp.integrated"),
    P(50, "000.hoop_ramp.integrable", "000.hoop_plane.nonholonomic"),
    P(51, "000.hoop_ramp.substitute"),
    P(52, reason="the system (a hoop on a plane, heading θ) defined"),
    P(54, "000.hoop_plane.rolling_x", "000.hoop_plane.rolling_y"),
    P(56, "000.hoop_plane.dof"),
    P(57, "000.hoop_plane.nonholonomic"),
    P(58, "000.hoop_plane.dof", "000.hoop_plane.nonholonomic"),
    P(59, reason="definition of holonomic (integrable, φ(x, ϕ) = 0) and non-holonomic constraints; it agrees with "
                 "Goldstein §1.3 and decides 000.general.inequality against line 61"),
    P(61, "000.general.inequality"),
    P(62, "000.general.holonomic_where"),
    P(63, "000.general.nonholonomic_how"),
    P(64, "000.general.dalembert"),
    P(65, "000.general.independent_rows"),
    P(66, reason=ANNOUNCES),
    P(67, "000.general.multiply"),
    P(69, "000.general.sum"),
    P(71, "000.general.choose_lambda",
      reason="which coordinates are called dependent is a choice of labels, possible because the rows are "
             "independent (000.general.independent_rows)"),
    P((73, 75), "000.general.choose_lambda"),
    P((77, 78), "000.general.remaining"),
    P(80, "000.general.remaining"),
    P(81, "000.general.all_coordinates"),
    P(82, "000.general.count"),
    P(83, reason="definition: the general form of m constraints, Σ_k Ξ_jk dq_k + Ξ_jt dt = 0"),
    P(84, "000.general.velocity_form"),
    P(85, reason="terminology: constraints linear in the differentials are in Pfaffian form (the standard name)"),
    P(87, reason=HEADING),
    P(89, "000.atwood.T", reason="the system defined: two masses, a pulley with its mass on the rim"),
    P(90, reason="definitions: heights z₁, z₂, pulley angle θ, z₃ = aθ (the frame of the Atwood claims)"),
    P(91, "000.atwood.dof"),
    P(93, "000.atwood.positions", "000.atwood.constraint1", "000.atwood.constraint2", "000.atwood.Xi",
      "000.atwood.T", "000.atwood.V"),
    P(95, reason=ANNOUNCES),
    P(97, "000.atwood.dL_dz1dot", "000.atwood.ddt_dL_dz1dot", "000.atwood.dL_dz1"),
    P(98, "000.atwood.dL_dz2dot", "000.atwood.ddt_dL_dz2dot", "000.atwood.dL_dz2"),
    P(99, "000.atwood.dL_dz3dot", "000.atwood.ddt_dL_dz3dot", "000.atwood.dL_dz3"),
    P(100, "000.atwood.conservative"),
    P(102, reason=ANNOUNCES),
    P(104, "000.atwood.eom1"),
    P(106, "000.atwood.eom2", "000.atwood.eom3"),
    P(107, reason=ANNOUNCES),
    P(108, "000.atwood.constraint_eq1", "000.atwood.constraint_eq2"),
    P(110, "000.atwood.z1ddot", "000.atwood.z2ddot", "000.atwood.z3ddot"),
    P(112, "000.atwood.lambda1"),
    P(114, "000.atwood.lambda2"),
    P(116, "000.atwood.effective_g"),
    P(117, "000.atwood.tensions"),
    P(118, "000.general.multiplier_meaning"),
)

SIMULATIONS: tuple[Passage, ...] = (
    P((1, 5), reason="title and table of contents"),
    P(7, reason=HEADING),
    P(9, reason="definitions: the action S = ∫L dt, L ≡ T − U, q and q̇", anchors=(
        "The action is defined as", r"L(q,\dot{q}, t)dt", r"where \(L \equiv T-U\)", "This is an integral over")),
    P(9, "001.action.least", anchors=("The principle of least action states", r"\[\delta S = 0.\]")),
    P(12, reason=HEADING),
    P(14, "001.action.least", reason="'minimize' and 'the true path that minimizes S' repeat line 9's claim",
      anchors=("In order to minimize such an integral", "Suppose $q(t)$ defines the true path")),
    P(14, "001.cov.endpoints", reason="the variation δq with δq(t₁) = δq(t₂) = 0 is defined here",
      anchors=("path in phase space", "We add another function")),
    P(14, reason="definition of δS", anchors=("The resulting change in action is", r"S(q+\delta q")),
    P(14, "001.cov.expansion", anchors=("expand $S$ in its derivates", r"\frac{\partial S}{\partial q}")),
    P(14, "001.cov.first_variation", anchors=("Plugging this into the integral form yields",
                                              r"\frac{\partial L}{\partial \dot{q}}\frac{d}{dt}")),
    P(14, "001.cov.by_parts", anchors=("Applying integration by parts", r"\bigg\rvert")),
    P(14, "001.cov.boundary", anchors=("The boundary term from the integral",)),
    P(14, "001.cov.stationary_integral", anchors=("Therefore,", r"\right)\delta q dt = 0")),
    P(14, "001.cov.euler_lagrange", anchors=("because the integral must be 0",
                                             r"\[\frac{d}{dt}\frac{\partial L}{\partial \dot{q}}")),
    P(14, reason="prose: the multi-dimensional case is left to the reader (its result is equation (1))",
      anchors=("Extending the calculation",)),
    P(14, "001.cov.eq1", anchors=("Doing so yields", r"\partial \dot{q_i}}")),
    P(17, reason=HEADING),
    P(19, reason="prose", anchors=("The most classic example",)),
    P(19, "001.spring.T", "001.spring.U", anchors=("In this case, we have", r"T = \frac{1}{2}m\dot q ^2")),
    P(19, "001.spring.L", anchors=("Therefore,", "L = T - U")),
    P(19, "001.spring.eom", "001.spring.omega", anchors=("Plugging this into (1)", r"m\ddot{q} + kq = 0")),
    P(19, "001.spring.solution", anchors=("The solution here is as expected", r"c_1 \sin(\omega t)")),
    P(22, reason=HEADING),
    P(24, reason="definition of a holonomic constraint, f(q₁, …, q_N, t) = 0 (Goldstein §1.3, eq. 1.37)",
      anchors=("A holonomic constraint can be written",)),
    P(24, "001.general.inequality", anchors=("A nonholonomic constraint is any",)),
    P(24, "001.general.multipliers", anchors=("Holonomic constraints can be incorporated",)),
    P(24, "001.constraints.augmented_action", anchors=("We first rewrite the action integral",
                                                       r"L+\sum_{j=1}^{m}\lambda_j f_j")),
    P(24, reason="notation: f_i names the i-th constraint while the sums run over j and i counts coordinates (an "
                 "index clash in words, no formula)", anchors=("where $f_i$ is the",)),
    P(24, "001.constraints.delta_S", anchors=("Applying the variations to the coordinates",
                                              r"\delta S = \int_{t_1}^{t_2} \sum_{i=1}^N")),
    P(24, "001.constraints.independent_terms", anchors=("This requires each term",)),
    P(24, "001.general.lambda_sign", anchors=("This provides us the Euler-Lagrange equation",
                                              r"\begin{equation} \frac{d}{dt}")),
    P(24, "001.pendulum.L", anchors=("A simple example can be demonstrated", r"mgr(1-\cos \theta)")),
    P(24, reason="prose: r is kept as a coordinate on purpose", anchors=("intentionally not substituting",)),
    P(24, "001.pendulum.constraint", anchors=("subject to the constraint", "r - l = 0.")),
    P(24, "001.pendulum.lambda_arbitrary", "001.pendulum.el_r", "001.pendulum.el_theta",
      anchors=("the sign on $\\lambda$ is arbitrary", r"\lambda \frac{\partial}{\partial r}")),
    P(24, "001.pendulum.eom_r", "001.pendulum.eom_theta",
      anchors=("Substituting in the Lagrangian", r"mr\dot \theta^2 + mg(1-\cos\theta) = \lambda")),
    P(24, "001.pendulum.small_angle_lambda", "001.pendulum.small_angle_eom",
      anchors=("Applying the small angle approximation", r"ml\dot \theta^2 = \lambda")),
    P(24, "001.pendulum.force_magnitude", "001.pendulum.small_angle_eom", anchors=("The first equation tells us",)),
)

COVERAGE: dict[str, tuple[Passage, ...]] = {DOCUMENTS[0]: LECTURE15, DOCUMENTS[1]: SIMULATIONS}


@functools.cache
def text(document: str) -> str:
    """The document as shipped with the package."""
    if document not in DOCUMENTS:
        raise ValueError(f"unknown document {document!r}; known: {', '.join(DOCUMENTS)}")
    return (resources.files("harness.audit") / "documents" / document).read_text(encoding="utf-8")


def units(line: str) -> list[str]:
    """A line's displayed formulas and sentences, in order; punctuation-only pieces dropped."""
    out: list[str] = []
    pos = 0
    for m in _DISPLAY.finditer(line):
        out += _SENTENCE.split(line[pos:m.start()])
        out.append(m.group(0))
        pos = m.end()
    out += _SENTENCE.split(line[pos:])
    return [u.strip() for u in out if re.search(r"[A-Za-z0-9]", u)]


def uncovered(document: str) -> list[tuple[int, str]]:
    """(line, unit) for every unit of the document that no passage covers (empty when all are)."""
    lines = text(document).splitlines()
    missing = []
    for number, line in enumerate(lines, 1):
        here = [p for p in COVERAGE[document] if p.first <= number <= p.last]
        for unit in units(line):
            if not any(not p.anchors or any(a in unit for a in p.anchors) for p in here):
                missing.append((number, unit))
    return missing


def misplaced_anchors(document: str) -> list[tuple[int, str]]:
    """(first line, anchor) for every anchor not found in its passage's lines."""
    lines = text(document).splitlines()
    return [(p.first, a) for p in COVERAGE[document] for a in p.anchors
            if a not in "\n".join(lines[p.first - 1:p.last])]


def _placed() -> dict[str, list[int]]:
    out: dict[str, list[int]] = {}
    for passages in COVERAGE.values():
        for p in passages:
            for cid in p.claims:
                lines = out.setdefault(cid, [])
                if p.first not in lines:
                    lines.append(p.first)
    return out


def lines_text(claim_id: str, default: str | None = None) -> str:
    """The document lines that hold ``claim_id`` ("33", "9, 14", "73–75"); ``default`` for a claim that is not
    in the documents (a test's variant), ValueError without one."""
    spans = []
    for passages in COVERAGE.values():
        for p in passages:
            if claim_id in p.claims:
                span = str(p.first) if p.first == p.last else f"{p.first}–{p.last}"
                if span not in spans:
                    spans.append(span)
    if not spans and default is not None:
        return default
    if not spans:
        raise ValueError(f"claim {claim_id!r} is not placed in the coverage list (harness/audit/coverage.py)")
    return ", ".join(spans)


def placed_claims() -> set[str]:
    return set(_placed())


def not_checkable() -> list[dict[str, object]]:
    """Every passage's reason for what it holds that is not a claim, by document and lines."""
    return [{"document": doc, "lines": f"{p.first}" if p.first == p.last else f"{p.first}–{p.last}",
             "claims": list(p.claims), "reason": p.reason}
            for doc, passages in COVERAGE.items() for p in passages if p.reason]


def summary() -> list[str]:
    """One line a document: its non-blank lines, passages, those with claims and those without."""
    out = []
    for doc, passages in COVERAGE.items():
        nonblank = sum(bool(line.strip()) for line in text(doc).splitlines())
        with_claims = [p for p in passages if p.claims]
        ids = {c for p in passages for c in p.claims}
        out.append(f"{doc}: {nonblank} non-blank lines, {len(units_of(doc))} units, {len(passages)} passages: "
                   f"{len(with_claims)} with claims ({len(ids)} claims), {len(passages) - len(with_claims)} not "
                   "checkable (headings, definitions, prose), every unit covered"
                   if not uncovered(doc) else f"{doc}: UNCOVERED units {uncovered(doc)}")
    return out


def units_of(document: str) -> list[tuple[int, str]]:
    return [(n, u) for n, line in enumerate(text(document).splitlines(), 1) for u in units(line)]

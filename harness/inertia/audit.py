"""Is the model itself physical? Each body's inertial (MuJoCo's compiled mass, centre of mass and inertia) held
against the body's own geometry (:mod:`harness.inertia.geometry`) by the bounds of :mod:`harness.inertia.bounds`.

Every body with mass falls in one category:

- ``finding``: a bound fails (the second moment exceeds the hull's allowance, the inertia is smaller than the
  densest ball's, the centre of mass lies outside the hull, or the mean density over the hull exceeds the
  densest element's); a finding fails the check (exit 1) unless the config accepts it (:func:`accepted`);
- ``warning``: within the bounds but far from what the geometry implies at its mass (tr Σ over
  :data:`IMPLAUSIBLE` times from the uniformly filled hull's); printed, never failing;
- ``inert``: a bound fails, but the nearest realizable inertial changes neither the gravity torques nor M(q)
  (both within :data:`INERT` of their scales over the sampled states): no joint lets the dynamics feel it (a
  body on slides only, a body welded to the world). Printed as a warning, never failing;
- ``point mass``: every principal moment at most :data:`POINT_MASS` × m L² (L the geometry's largest extent
  from the centre of mass): an idealised point mass, the convention the harness's budget uses for the textbook
  systems' bobs (harness.budget.floors); the lower bound is not applied to it (an ideal point is
  denser than any element by definition), the others are;
- ``no geometry``: mass on a body without a geom: only the lower bound applies (nothing says where the mass
  may lie: MJCF lets a body carry an inertial without drawing it, a motor's rotor, a sensor's housing);
- ``ok``.

A finding names the likely cause where one fits exactly (:func:`causes`) and what it does to the dynamics
(:func:`effect`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import mujoco
import numpy as np

from harness.engine.compat import full_mass_matrix
from harness.inertia import bounds
from harness.inertia.bounds import Shape
from harness.inertia.geometry import Solid, body_geoms, solid
from harness.opinions.structure import sample_states

__all__ = ["DENSITY_MARGIN", "BodyAudit", "ModelAudit", "audit_model"]

POINT_MASS = 1e-6  # principal moments ≤ this × m L²: the harness's point-mass floor (harness.budget.floors)
IMPLAUSIBLE = 10.0  # tr Σ this many times above or below the filled hull's: a warning
DENSITY_MARGIN = 1.25  # the tessellated hull's volume falls short of the exact hull's by ≤ 6.1 % (a sphere's; tests pin
# it), so its mean density over-reads by ≤ 6.5 %: a quarter is margin enough
INERT = 1e-9  # relative change of gravity torques and M(q) below which a violation is inert: float64 round-off
# in M(q) is ~1e-16 × nv, and a simulation cannot show a change a million times larger than that
STATES = 6  # sampled configurations besides qpos0 for the effects, seeded as the URDF comparison's
UNITS = ((1e-3, "mass", "grams written as kilograms"), (1e3, "mass", "1000× too small: tonnes for kilograms"),
         (1e-6, "inertia", "kg·mm² written as kg·m²"), (1e6, "inertia", "10⁶× too small"),
         (1e-9, "inertia", "g·mm² written as kg·m²"), (1e-3, "inertia", "g·m² written as kg·m²"),
         (1e3, "inertia", "1000× too small"))  # factor that makes it fit, which number, the slip it undoes


@dataclass(frozen=True)
class Effect:
    """What replacing a body's inertial by the nearest realizable one does over the sampled states: the largest
    change of a gravity torque (N·m or N, on ``joint``) against the largest gravity torque, the largest change
    of an entry of M(q) against its largest diagonal entry, and the largest change of an entry relative to its
    own scale, |ΔMᵢⱼ| / √(MᵢᵢMⱼⱼ) (what tells a hub's few grams from a shoulder)."""

    torque: float
    joint: str
    torque_scale: float
    inertia: float
    inertia_scale: float
    relative: float = 0.0

    def text(self) -> str:
        rel_t = self.torque / self.torque_scale if self.torque_scale > 0 else 0.0
        rel_m = self.inertia / self.inertia_scale if self.inertia_scale > 0 else 0.0
        return (f"replaced by the nearest realizable inertial: gravity torque changes by up to {self.torque:.3g}"
                f"{' on ' + self.joint if self.joint else ''} ({100 * rel_t:.3g} % of the largest), "
                f"M(q) by up to {self.inertia:.3g} ({100 * rel_m:.3g} % of its largest diagonal entry; "
                f"{100 * self.relative:.3g} % of an entry's own scale √(MᵢᵢMⱼⱼ))")

    @property
    def negligible(self) -> bool:
        """Whether the dynamics cannot feel the change (both under :data:`INERT` of their scales)."""
        return self.torque <= INERT * self.torque_scale and self.inertia <= INERT * self.inertia_scale

    def as_dict(self) -> dict:
        return {"gravity_torque": self.torque, "joint": self.joint, "gravity_torque_scale": self.torque_scale,
                "mass_matrix": self.inertia, "mass_matrix_scale": self.inertia_scale,
                "mass_matrix_relative": self.relative}


@dataclass(frozen=True)
class BodyAudit:
    """One body's audit: its inertial (body frame: centre of mass ``com``, second moment ``sigma``), the bounds'
    ratios (over 1: violated; ``outside`` in m, > 0 outside), the mean density over the hull, the ratio of tr Σ to
    the filled hull's, the category, what fails, the likely causes, the effect, and a config's acceptance."""

    body: str
    mass: float
    kind: str
    com: np.ndarray
    sigma: np.ndarray
    upper: float | None = None
    direction: np.ndarray | None = None
    lower: float = 0.0
    outside: float | None = None
    density: float | None = None
    implied: float | None = None
    problems: tuple[str, ...] = ()
    causes: tuple[str, ...] = ()
    effect: Effect | None = None
    accepted: str = ""
    hull: Solid | None = field(default=None, repr=False)

    @property
    def failing(self) -> bool:
        return self.kind == "finding" and not self.accepted

    def line(self) -> str:
        """The one line the CLI prints for a finding or warning."""
        what = "; ".join(self.problems)
        cause = f"; likely cause: {' or '.join(self.causes)}" if self.causes else ""
        effect = f"; {self.effect.text()}" if self.effect else ""
        tag = {"finding": "FINDING", "warning": "warning", "inert": "warning (inert: no joint feels it)"}.get(
            self.kind, self.kind)
        accepted = f" (accepted by the config: {self.accepted})" if self.accepted else ""
        return f"{tag}{accepted} — body {self.body!r} ({self.mass:.4g} kg): {what}{cause}{effect}"

    def as_dict(self) -> dict:
        return {"body": self.body, "mass": self.mass, "kind": self.kind, "upper_ratio": self.upper,
                "lower_ratio": self.lower, "com_outside_m": self.outside, "density": self.density,
                "implied_ratio": self.implied, "problems": list(self.problems), "causes": list(self.causes),
                "effect": self.effect.as_dict() if self.effect else None, "accepted": self.accepted or None}


@dataclass(frozen=True)
class ModelAudit:
    """Every body with mass of one model, and the seconds the audit took."""

    model: str
    bodies: tuple[BodyAudit, ...]
    seconds: float

    @property
    def findings(self) -> tuple[BodyAudit, ...]:
        return tuple(b for b in self.bodies if b.kind == "finding")

    @property
    def warnings(self) -> tuple[BodyAudit, ...]:
        return tuple(b for b in self.bodies if b.kind == "warning")

    @property
    def failed(self) -> bool:
        return any(b.failing for b in self.bodies)

    def summary(self, *, timed: bool = True) -> str:
        """One line: how many bodies, findings (accepted ones counted apart), warnings, and the worst ratio;
        ``timed``: with the audit's milliseconds (the terminal's line; a report's bytes must not vary run to run)."""
        counts = {k: sum(b.kind == k for b in self.bodies) for k in ("finding", "warning", "inert", "point mass",
                                                                       "no geometry")}
        accepted = sum(bool(b.accepted) for b in self.findings)
        head = (f"Inertials of {self.model} against their geometry: {len(self.bodies)} bodies with mass, "
                f"{counts['finding']} finding(s){f' ({accepted} accepted by the config)' if accepted else ''}, "
                f"{counts['warning']} warning(s)")
        extra = [f"{counts[k]} {k}" for k in ("inert", "point mass", "no geometry") if counts[k]]
        verdict = "FAIL" if self.failed else "PASS"
        took = f" ({self.seconds * 1e3:.0f} ms)" if timed else ""
        return f"{head}{', ' + ', '.join(extra) if extra else ''}{took}: {verdict}"

    def lines(self, *, quiet: bool = False) -> list[str]:
        """The section the CLI prints; ``quiet``: only where a finding fails, the summary and the findings."""
        if quiet and not self.failed:
            return []
        shown = [b for b in self.bodies if b.kind == "finding" or (b.kind in ("warning", "inert") and not quiet)]
        return [self.summary(), *("  " + b.line() for b in shown)]

    def as_dict(self) -> dict:
        """The JSON entry: no clock (check --json and report.json are the same bytes run to run, locally or on a
        cluster); the terminal's line says how long the audit took."""
        return {"model": self.model, "failed": self.failed, "bodies": [b.as_dict() for b in self.bodies]}


def _body_inertial(model: mujoco.MjModel, b: int) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, centre of mass, inertia about it) of body ``b`` in its body frame."""
    flat = np.zeros(9)
    mujoco.mju_quat2Mat(flat, model.body_iquat[b])
    rot = flat.reshape(3, 3)
    inertia = rot @ np.diag(model.body_inertia[b]) @ rot.T
    return float(model.body_mass[b]), model.body_ipos[b].copy(), inertia


def _placeholder(inertia: np.ndarray) -> str:
    """'isotropic' or 'round values' where the declared inertia looks typed in rather than computed ('')."""
    eig = np.linalg.eigvalsh(inertia)
    if eig.max() > 0 and eig.max() - eig.min() <= 1e-9 * eig.max():
        return "a placeholder (isotropic inertia)"
    entries = [abs(v) for v in np.diag(inertia) if v != 0]

    def _round(v: float) -> bool:
        mant = v / 10 ** math.floor(math.log10(v))
        return abs(mant - round(mant)) < 1e-9

    if entries and all(_round(v) for v in entries) and len(set(np.round(entries, 15))) < len(entries):
        return "a placeholder (repeated round values)"
    return ""


def causes(mass: float, c: np.ndarray, inertia: np.ndarray, shape: Shape, hull: Solid | None) -> list[str]:
    """The causes that fit a failing inertial exactly: each names a rewrite of the declared numbers that makes them
    realizable (the inertia about the body frame's origin, a rotation, a unit) or a pattern (a placeholder; a
    centre of mass in no geom)."""
    out = []
    sigma = bounds.second_moment(inertia)
    about_com = inertia - mass * (float(c @ c) * np.eye(3) - np.outer(c, c))  # declared about the origin
    if float(c @ c) > 0 and bounds.realizable(mass, c, bounds.second_moment(about_com), shape):
        out.append("the inertia about the body frame's origin rather than the centre of mass (parallel axis)")
    if shape.geoms and _rotation_fits(mass, c, sigma, shape, hull):
        out.append("principal axes swapped or rotated")
    for factor, what, text in UNITS:
        m2, s2 = (mass * factor, sigma) if what == "mass" else (mass, sigma * factor)
        if bounds.realizable(m2, c, s2, shape):
            out.append(f"a unit slip: {what} ×{factor:g} fits ({text})")
            break
    if placeholder := _placeholder(inertia):
        out.append(placeholder)
    if shape.geoms and not any(g.contains(c) for g in shape.geoms):
        out.append("mass for geometry the body does not have (centre of mass outside every geom)")
    return out


def _rotation_fits(mass: float, c: np.ndarray, sigma: np.ndarray, shape: Shape, hull: Solid | None) -> bool:
    """Whether turning Σ onto the body axes or the filled hull's principal axes, in some order, makes it fit."""
    values, _ = np.linalg.eigh(sigma)
    frames = [np.eye(3)]
    if hull is not None:
        frames.append(np.linalg.eigh(bounds.second_moment(hull.inertia))[1])
    for frame in frames:
        for order in ((0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)):
            turned = frame @ np.diag(values[list(order)]) @ frame.T
            if bounds.realizable(mass, c, turned, shape):
                return True
    return False


def nearest_realizable(mass: float, c: np.ndarray, sigma: np.ndarray, shape: Shape,
                       hull: Solid | None) -> tuple[np.ndarray, np.ndarray]:
    """The realizable (c, Σ) nearest the declared along the simplest path: c moved towards the hull's centroid
    until inside, Σ scaled up to the densest ball's trace then down to the hull's allowance."""
    if shape.geoms and bounds.com_outside(c, shape) > 0:
        centre = hull.centroid if hull is not None else np.mean([g.pos for g in shape.geoms], axis=0)
        lo, hi = 0.0, 1.0  # fraction of the way from c to the centre: bisection on "inside"
        for _ in range(40):
            mid = (lo + hi) / 2
            lo, hi = (lo, mid) if bounds.com_outside(c + mid * (centre - c), shape) <= 0 else (mid, hi)
        c = c + hi * (centre - c)
    low = bounds.lower_ratio(mass, sigma)
    if low > 1 and math.isfinite(low):
        sigma = sigma * low
    if shape.geoms:
        up = bounds.upper_ratio(mass, c, sigma, shape)[0]
        if up > 1:
            sigma = sigma / up
    return c, sigma


def effect(model: mujoco.MjModel, body: int, c: np.ndarray, sigma: np.ndarray,
           states: Sequence[np.ndarray]) -> Effect:
    """The change in the gravity torques and M(q) over ``states`` when body ``body`` has centre of mass ``c`` and
    second moment ``sigma`` instead of its own (MuJoCo's ``qfrc_bias`` at zero velocity and ``mj_fullM`` of the
    two inertials: a measure of the finding's size, not a reference). The model is changed in place and restored."""
    values, vectors = np.linalg.eigh(bounds.inertia_of(sigma))
    if np.linalg.det(vectors) < 0:
        vectors[:, 0] *= -1
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, vectors.flatten())
    own = model.body_ipos[body].copy(), model.body_iquat[body].copy(), model.body_inertia[body].copy()
    same = int(model.body_sameframe[body])  # MuJoCo skips body_ipos/iquat where the frames coincide
    simple = model.body_simple.copy(), model.dof_simplenum.copy()  # and reads a simple body's M from dof_M0
    model.body_simple[:], model.dof_simplenum[:] = 0, 0  # the general path, for both inertials alike
    d = mujoco.MjData(model)
    before: list[tuple[np.ndarray, np.ndarray]] = []
    after: list[tuple[np.ndarray, np.ndarray]] = []
    try:
        for fields, out in ((own, before), ((c, quat, values), after)):  # the model's own, then the replacement
            model.body_ipos[body], model.body_iquat[body], model.body_inertia[body] = fields
            model.body_sameframe[body] = same if fields is own else 0
            for qpos in states:
                d.qpos[:], d.qvel[:] = qpos, 0
                mujoco.mj_forward(model, d)
                out.append((d.qfrc_bias.copy(), full_mass_matrix(model, d)))
    finally:
        model.body_ipos[body], model.body_iquat[body], model.body_inertia[body] = own
        model.body_sameframe[body] = same
        model.body_simple[:], model.dof_simplenum[:] = simple
    dt, dm, gscale, mscale, where, rel = 0.0, 0.0, 0.0, 0.0, -1, 0.0
    for (ga, ma), (gb, mb) in zip(before, after, strict=True):
        g = np.abs(ga - gb)
        if g.size and g.max() > dt:
            dt, where = float(g.max()), int(np.argmax(g))
        gscale = max(gscale, float(np.abs(ga).max(initial=0)))
        dm = max(dm, float(np.abs(ma - mb).max(initial=0)))
        mscale = max(mscale, float(np.diag(ma).max(initial=0)))
        own = np.sqrt(np.outer(np.diag(ma), np.diag(ma)))
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = max(rel, float(np.nan_to_num(np.abs(ma - mb) / own, posinf=0.0).max(initial=0)))
    joint = ""
    if where >= 0:
        joint = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, int(model.dof_jntid[where])) or \
            f"dof {where}"
    return Effect(dt, joint, gscale, dm, mscale, rel)


def audit_body(model: mujoco.MjModel, b: int, *, meshes: dict[int, np.ndarray] | None = None) -> BodyAudit:
    """The audit of body ``b`` (no effect: :func:`audit_model` adds it to the findings)."""
    name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"body {b}"
    mass, c, inertia = _body_inertial(model, b)
    sigma = bounds.second_moment(inertia)
    geoms = body_geoms(model, b, meshes=meshes)
    shape = Shape.of(geoms)
    lower = bounds.lower_ratio(mass, sigma)
    if not geoms:
        found = (f"inertia {lower:.3g}× too small for any material (tr Σ below the densest ball's "
                 f"{bounds.densest_ball(mass):.3g} kg·m²)",) if lower > 1 else ()
        kind = "finding" if found else "no geometry"
        return BodyAudit(name, mass, kind, c, sigma, lower=lower, problems=found,
                         causes=tuple(causes(mass, c, inertia, shape, None)) if found else ())
    hull = solid(geoms)
    upper, direction = bounds.upper_ratio(mass, c, sigma, shape)
    outside = bounds.com_outside(c, shape)
    assert shape.ext is not None  # the shape of some geoms has their extent (Shape.of)
    size = float(shape.ext.width(c).max())
    density = mass / hull.volume if hull is not None else None
    implied = None
    if hull is not None:
        implied = float(np.trace(sigma) / np.trace(bounds.second_moment(hull.inertia * mass / hull.volume)))
    point = np.linalg.eigvalsh(inertia).max() <= POINT_MASS * mass * size ** 2
    problems = []
    if upper > 1:
        problems.append(f"second moment {upper:.3g}× what the geometry allows along "
                        f"({', '.join(f'{x:.2f}' for x in direction)}) even with all the mass on its farthest "
                        "points")
    if lower > 1 and not point:
        problems.append(f"inertia {lower:.3g}× too small for any material (tr Σ below the densest ball's "
                        f"{bounds.densest_ball(mass):.3g} kg·m²)")
    if outside > 0:
        problems.append(f"centre of mass {outside * 1e3:.3g} mm outside the geometry's hull")
    if hull is not None and density is not None and density > bounds.DENSEST * DENSITY_MARGIN:  # (a hull's)
        problems.append(f"mean density {density:.3g} kg/m³ over the hull's {hull.volume:.3g} m³, above the "
                        f"densest element's {bounds.DENSEST:.0f}")
    if problems:
        return BodyAudit(name, mass, "finding", c, sigma, upper, direction, lower, outside, density, implied,
                         tuple(problems), tuple(causes(mass, c, inertia, shape, hull)), hull=hull)
    if point:
        return BodyAudit(name, mass, "point mass", c, sigma, upper, direction, lower, outside, density, implied,
                         hull=hull)
    if implied is not None and not 1 / IMPLAUSIBLE <= implied <= IMPLAUSIBLE:
        why = (f"tr Σ {implied:.3g}× the geometry's filled uniformly at this mass (within the bounds: "
               f"upper {upper:.2g}, lower {lower:.2g})",)
        return BodyAudit(name, mass, "warning", c, sigma, upper, direction, lower, outside, density, implied,
                         why, tuple(causes(mass, c, inertia, shape, hull)), hull=hull)
    return BodyAudit(name, mass, "ok", c, sigma, upper, direction, lower, outside, density, implied, hull=hull)


def audit_model(model: mujoco.MjModel, *, name: str = "the model", accept: Mapping[str, str] | None = None,
                partial: Mapping[str, str] | None = None) -> ModelAudit:
    """The audit of every body with mass of ``model``; ``accept`` (body → reason, from the config) accepts a
    body's finding; ``partial`` (body → why) names the bodies whose geometry is known to be incomplete (a URDF's
    mesh MuJoCo cannot read), whose findings that need the geometry are warnings; each finding carries its
    effect on the dynamics."""
    start = time.perf_counter()
    accept = dict(accept or {})
    meshes: dict[int, np.ndarray] = {}
    out = []
    states = None
    for b in range(1, model.nbody):
        if model.body_mass[b] <= 0:
            continue
        audit = audit_body(model, b, meshes=meshes)
        if audit.kind == "finding" and audit.body in (partial or {}) and audit.lower <= 1:
            audit = _with(audit, kind="warning", problems=(*audit.problems, f"geometry partial: "
                                                           f"{(partial or {})[audit.body]}"))
        if audit.kind == "finding":
            states = states if states is not None else sample_states(model, list(range(model.njnt)), STATES, 0)
            shape = Shape.of(body_geoms(model, b, meshes=meshes))
            c, sigma = nearest_realizable(audit.mass, audit.com, audit.sigma, shape, audit.hull)
            change = effect(model, b, c, sigma, states)
            audit = _with(audit, effect=change, accepted=accept.get(audit.body, ""),
                          kind="inert" if change.negligible else "finding")
        out.append(audit)
    return ModelAudit(name, tuple(out), time.perf_counter() - start)


def _with(audit: BodyAudit, **changes) -> BodyAudit:
    return replace(audit, **changes)

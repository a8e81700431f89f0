"""The reactions family: MuJoCo's force, torque and accelerometer sensors and ``cfrc_int`` against the
analytic reactions, at the sampled states (:mod:`harness.families.sampled`).

Every reaction sensor a model has (:func:`harness.engine.sensors.sensors`) is compared at its site,
so adding a sensor to an MJCF file is all a case needs. The analytic side is
:mod:`analytic.reactions`, Newton–Euler of the subtree, from the reference's own q̈ and λ at the
state:

- ``force`` / ``torque`` at a site on body B: the wrench by B's parent on B's subtree (the bodies
  below B in MuJoCo's tree, each an analytic body of the same name; a massless MuJoCo body may have
  none), the moment about the site, less the external loads the case's wiring declares
  (:class:`harness.engine.sensors.Load`: the forces MuJoCo counts in ``cfrc_ext``, a spatial
  tendon's pull, a connect's pin force, a weld's force and moment — the moment through MuJoCo's
  frame at the state, :func:`harness.engine.sensors.weld_moment_map` —, a contact at MuJoCo's contact
  point); where a subtree body is loaded from outside its joints with no load declared (a contact the
  model under test makes: a force the analytic system lacks) the figure cannot be measured, and fails
  with that reason;
- ``cfrc_int`` of every body with a force or torque sensor: the same wrench, its moment about
  MuJoCo's c-frame origin (figure ``instant.interaction.BODY``);
- ``accelerometer`` at a site: the site's proper acceleration a − g (0 − g on the world body; the
  analytic point named like the site, else the analytic body whose centre of mass the site marks; a
  site elsewhere is not compared: its figure is n/a, with why).

Figures ``instant.sensor.NAME``: max over states of |MuJoCo (rotated to the world) − analytic|, for
a force over the case's force scale, a torque over force × length, an acceleration over the largest
analytic |a − g|; ``instant.interaction.BODY``: the force and the moment / length together, over the
force scale. Where the site's position enters (a moment's point, a load's line) it is MuJoCo's at
the state, which the analytic side sets: kinematics, checked by ``instant.kinematics``; so is a
weld's frame (its torquescale is the model's, which the analytic system reads too).

Budget: the sampled states' (:mod:`harness.families.sampled`), as the instantaneous family's. Every figure
is gated; one the backend's arrays cannot give is n/a with why, one the model makes unmeasurable fails with why.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import mujoco
import numpy as np

from analytic.dynamics import Dynamics
from analytic.reactions import Load as AnalyticLoad
from analytic.reactions import proper_acceleration, subtree_wrench
from harness.cases import Case
from harness.core.checks import Limit
from harness.core.deviation import Deviation
from harness.core.figures import FigureName
from harness.engine import sensors as S
from harness.families.bench import Bench, Measured
from harness.families.sampled import Sample
from harness.reference.tree import TREE

__all__ = ["NAME", "compare", "gated", "measure", "names", "owns", "sensor_names", "theory_limit"]

NAME = "reactions"


def owns(name: FigureName) -> bool:
    return name.layer == "instant" and name.quantity in ("sensor", "interaction")


def names(case: Case, model: mujoco.MjModel) -> set[FigureName]:
    reading, wrenched = sensor_names(model)
    return {FigureName.instant("sensor", s) for s in reading} | {FigureName.instant("interaction", b) for b in wrenched}


def gated(name: FigureName, *, constrained: bool) -> bool:
    return True


def theory_limit(name: FigureName) -> Limit | None:
    return None


UNLOADED = 1e-9
"""A subtree body counts as loaded from outside its joints where |cfrc_ext| exceeds this × the force scale."""


def _accelerometer_point(model: mujoco.MjModel, dyn: Dynamics, sensor: S.Sensor, site_pos: np.ndarray,
                         coms: Sequence[Mapping[str, np.ndarray]], length: float) -> tuple[str, int, str]:
    """Where the analytic side reads an accelerometer's acceleration: ``("static", -1)``, ``("point", i)`` or
    ``("body", i)``, and '' ; or ("", -1, why) where neither applies (the site is elsewhere: the figure is
    n/a, with why)."""
    if model.body(sensor.body).id == 0:
        return "static", -1, ""
    if sensor.site in dyn.point_names:
        return "point", dyn.point_names.index(sensor.site), ""
    at_com = max(float(np.linalg.norm(p - c[sensor.name])) for p, c in zip(site_pos, coms, strict=True))
    if sensor.body in dyn.body_names and at_com <= 1e-12 * length:
        return "body", dyn.body_names.index(sensor.body), ""
    return "", -1, (f"not compared: accelerometer {sensor.name!r} is at site {sensor.site!r}, neither an analytic "
                    f"point nor at the centre of mass of an analytic body ({sensor.body!r}, {at_com:.3g} m from "
                    "its centre of mass); a site named as a point of the system, or at its body's centre of mass, "
                    "is compared")


def reaction_deviations(model: mujoco.MjModel, dyn: Dynamics, rec: S.Recorder, q: np.ndarray, qd: np.ndarray,
                        qdd: np.ndarray, lam: np.ndarray, *, force_scale: float, length: float,
                        strict: bool = True) -> tuple[list[Deviation], dict[str, str], dict[str, str]]:
    """The figures of the module docstring from the states (q, q̇) with the reference's q̈ and λ, and
    MuJoCo's records at the same states; then the figures not compared, each with why (n/a: an
    accelerometer at a site the analytic system has no acceleration for), and the figures that cannot be
    measured, each with why (they fail: a body in the sensor's subtree loaded from outside its joints
    with no load declared — a contact the model under test makes, an unmodelled force). Without ``strict`` (a
    model judged against its own tree, which declares no loads: its constraints' pulls are not modelled here)
    such a figure is not compared (n/a) instead."""
    if not rec:
        return [], {}, {}
    gravity = np.asarray(model.opt.gravity, dtype=float)
    n = len(q)
    site_pos = {s: np.array([row[i] for row in rec.rows["site"]]) for i, s in enumerate(rec.sites)}
    blocks = dyn.blocks

    def undeclared(tree: Sequence[str]) -> str:
        """Why the subtree's wrench cannot be compared: a body MuJoCo loads from outside its joints with no
        load declared ('' where none)."""
        loaded = {ld.body for ld in rec.loads}
        for b in tree:
            worst = max(row[b] for row in rec.rows["external"])
            if b not in loaded and worst > UNLOADED * force_scale:
                return (f"not measurable: body {b!r} in the sensor's subtree is loaded from outside its joints "
                        f"(|cfrc_ext| up to {worst:.3g} N: a contact, connect, weld or spatial tendon) and the case "
                        "declares no load for it (Wiring(loads=...)): a force the subtree's wrench cannot account for")
        return ""

    def loads_on(tree: Sequence[str]) -> list[AnalyticLoad]:
        out = []
        for ld in rec.loads:
            if ld.body in tree:
                rows = blocks[ld.constraint]
                direction = np.array([row[ld.slide] for row in rec.rows["axis"]]) if ld.slide else ld.direction
                moment = None
                if direction is not None:
                    force = lam[:, rows.start, None] * np.asarray(direction)
                elif ld.constraint in rec.welds:  # force rows, then the moment rows through MuJoCo's frame
                    force = lam[:, rows.start:rows.start + 3]
                    maps = np.array([row[ld.constraint] for row in rec.rows["moment"]])
                    moment = ld.sign * np.einsum("nij,nj->ni", maps, lam[:, rows.start + 3:rows.start + 6])
                else:
                    force = lam[:, rows]
                out.append(AnalyticLoad(force=ld.sign * force, at=rec.load_point(ld, site_pos), moment=moment))
        return out

    def massive(tree: Sequence[str]) -> list[str]:
        return [b for b in tree if b in dyn.body_names]

    out = []
    skipped: dict[str, str] = {}
    failing: dict[str, str] = {}
    readings = np.array(rec.rows["reading"]).reshape(n, len(rec.sensors), 3)
    for k, sensor in enumerate(rec.sensors):
        got = readings[:, k]
        name = FigureName.instant("sensor", sensor.name)
        if sensor.kind == "accelerometer":
            kind, i, why = _accelerometer_point(model, dyn, sensor, site_pos[sensor.site],
                                                rec.rows["com"], length)
            if why:
                skipped[str(name)] = why
                continue
            if kind == "static":
                acc = np.zeros((n, 3))
            elif kind == "point":
                acc = dyn.point_accelerations(q, qd, qdd)[:, i]
            else:
                acc = dyn.body_accelerations(q, qd, qdd)[:, i]
            expected = proper_acceleration(acc, gravity)
            scale = float(np.max(np.linalg.norm(expected, axis=-1)))
            out.append(Deviation(FigureName.instant("sensor", sensor.name), got - expected, "vector", "1",
                                 f"max |accelerometer {sensor.name!r} − (a − g)| at site {sensor.site!r} (world "
                                 f"frame) / max |a − g| ({scale:.4g} m/s²)", scale=scale or 1.0))
            continue
        tree = rec.subtrees[sensor.body]
        why = undeclared(tree)
        if why:
            (failing if strict else skipped)[str(name)] = why
            continue
        force, torque = subtree_wrench(dyn, massive(tree), q, qd, qdd, gravity=gravity, about=site_pos[sensor.site],
                                       loads=loads_on(tree))
        expected, scale, what = (force, force_scale, "F") if sensor.kind == "force" else \
            (torque, force_scale * length, "τ about the site")
        out.append(Deviation(FigureName.instant("sensor", sensor.name), got - expected, "vector", "1",
                             f"max |{sensor.kind} sensor {sensor.name!r} − {what} by the parent on the subtree of "
                             f"{sensor.body!r}| (world frame) / {scale:.4g}", scale=scale,
                             size=max(float(np.max(np.linalg.norm(expected, axis=-1))) / scale, 1.0)))
    interactions = np.array(rec.rows["interaction"]).reshape(n, len(rec.wrenched), 9)
    for k, body in enumerate(rec.wrenched):
        tree = rec.subtrees[body]
        why = undeclared(tree)
        if why:
            (failing if strict else skipped)[str(FigureName.instant("interaction", body))] = why
            continue
        got_force, got_torque, about = interactions[:, k, :3], interactions[:, k, 3:6], interactions[:, k, 6:]
        force, torque = subtree_wrench(dyn, massive(tree), q, qd, qdd, gravity=gravity, about=about,
                                       loads=loads_on(tree))
        values = np.stack([got_force - force, (got_torque - torque) / length], axis=1)
        size = float(np.max(np.linalg.norm(np.stack([force, torque / length], axis=1), axis=-1))) / force_scale
        out.append(Deviation(FigureName.instant("interaction", body), values, "vector", "1",
                             f"max |cfrc_int of {body!r} − (F, τ/L) by the parent on its subtree| / force scale "
                             f"({force_scale:.4g} N)", scale=force_scale, size=max(size, 1.0)))
    return out, skipped, failing


def sensor_names(model: mujoco.MjModel) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(sensor names, bodies with a force or torque sensor): the detail of every figure of this module."""
    found = S.sensors(model)
    return tuple(s.name for s in found), tuple(dict.fromkeys(s.body for s in found
                                                             if s.kind in ("force", "torque") and not s.unjudged))


def compare(sample: Sample) -> tuple[list[Deviation], dict[str, str], dict[str, str]]:
    """This family's figures at the sampled states; where the backend's arrays cannot give the reactions, every
    one of them n/a with why."""
    if sample.unavailable:
        sensors, bodies = sensor_names(sample.model)
        missing = [FigureName.instant("sensor", s) for s in sensors] + \
            [FigureName.instant("interaction", b) for b in bodies]
        return [], {str(name): f"not available on backend {sample.backend!r}: {sample.unavailable}"
                    for name in missing}, {}
    qdd, lam = sample.accelerations
    ref = sample.reference
    found, skipped, failing = reaction_deviations(sample.model, sample.dynamics, sample.reactions, sample.q, sample.qd,
                                                  qdd, lam, force_scale=ref.scales.force, length=ref.scales.length,
                                                  strict=ref.system != TREE)
    opaque = {str(FigureName.instant("sensor", s.name)): f"not judged: {s.unjudged}" for s in S.sensors(sample.model)
              if s.unjudged}
    return found, {**skipped, **opaque}, failing


def measure(bench: Bench) -> Measured:
    return bench.measured_at_states(owns)

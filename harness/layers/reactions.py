"""Layer 2, reactions: MuJoCo's force, torque and accelerometer sensors and ``cfrc_int`` against the
analytic reactions, at the instantaneous layer's sampled states.

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
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import mujoco
import numpy as np

from analytic.dynamics import Dynamics
from analytic.reactions import Load as AnalyticLoad
from analytic.reactions import proper_acceleration, subtree_wrench
from harness.core.deviation import Deviation
from harness.core.errors import ModelMismatch
from harness.core.figures import FigureName
from harness.engine import sensors as S

UNLOADED = 1e-9
"""A subtree body counts as loaded from outside its joints where |cfrc_ext| exceeds this × the force scale."""


class Recorder:
    """MuJoCo's side, state by state: call :meth:`record` after each ``mj_forward``."""

    def __init__(self, model: mujoco.MjModel, dyn: Dynamics, loads: Sequence[S.Load]) -> None:
        self.sensors = S.sensors(model)
        self.loads = tuple(loads)
        self.wrenched = tuple(dict.fromkeys(s.body for s in self.sensors if s.kind != "accelerometer"))
        self.subtrees = {b: S.subtree(model, b) for b in self.wrenched}
        for body, tree in self.subtrees.items():
            if not dyn.body_names:
                raise ModelMismatch(f"body {body!r} carries a force or torque sensor, but the analytic system "
                                    "declares no bodies (LagrangianSystem(bodies=...))")
            missing = [b for b in tree if model.body(b).mass[0] > 0 and b not in dyn.body_names]
            if missing:
                raise ModelMismatch(f"sensor subtree of body {body!r} has bodies {missing} with mass that the analytic "
                                    f"system does not declare; its bodies: {list(dyn.body_names)}")
        for load in self.loads:
            _check_load(model, dyn, load)
        self.sites = tuple(dict.fromkeys([*(s.site for s in self.sensors), *(ld.site for ld in self.loads
                                                                            if ld.site)]))
        # the welds among the loads' constraints: their moment map is MuJoCo's frame at each state
        self.welds = tuple(dict.fromkeys(ld.constraint for ld in self.loads if ld.direction is None and not ld.slide
                                         and dyn.blocks[ld.constraint].stop - dyn.blocks[ld.constraint].start == 6))
        for name in self.welds:
            eq = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_EQUALITY, name)
            if eq < 0 or int(model.eq_type[eq]) != int(mujoco.mjtEq.mjEQ_WELD):
                found = "none" if eq < 0 else mujoco.mjtEq(int(model.eq_type[eq])).name
                raise ModelMismatch(f"load on constraint {name!r}: its 6 rows are read as a weld's force and moment, "
                                    f"but the model's equality {name!r} is {found}; accepted: a weld")
        self.rows: dict[str, list] = {k: [] for k in ("reading", "site", "interaction", "external", "com",
                                                       "contact", "axis", "moment")}

    def __bool__(self) -> bool:
        return bool(self.sensors)

    def record(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        self.rows["reading"].append([S.world_reading(model, data, s) for s in self.sensors])
        self.rows["site"].append([data.site_xpos[model.site(s).id].copy() for s in self.sites])
        self.rows["interaction"].append([np.concatenate(S.interaction(model, data, b)) for b in self.wrenched])
        self.rows["external"].append({b: S.external_force(model, data, b) for tree in self.subtrees.values()
                                      for b in tree})
        self.rows["com"].append({s.name: data.xipos[model.body(s.body).id].copy() for s in self.sensors})
        # where the geom has no active contact MuJoCo applies no force there, while the system's multiplier
        # still pulls: the force figure fails whatever the point, and the moment is taken at the geom's centre
        points = {ld.contact: S.contact_point(model, data, ld.contact) for ld in self.loads if ld.contact}
        self.rows["contact"].append({g: data.geom_xpos[model.geom(g).id].copy() if pt is None else pt
                                     for g, pt in points.items()})
        self.rows["axis"].append({ld.slide: data.xaxis[model.joint(ld.slide).id].copy() for ld in self.loads
                                  if ld.slide})
        self.rows["moment"].append({w: S.weld_moment_map(model, data, w) for w in self.welds})

    def load_point(self, load: S.Load, site_pos: Mapping[str, np.ndarray]) -> np.ndarray:
        """Where ``load`` acts at each state (n, 3): its site's position, or its contact's point."""
        return site_pos[load.site] if load.site else np.array([row[load.contact] for row in self.rows["contact"]])


def _check_load(model: mujoco.MjModel, dyn: Dynamics, load: S.Load) -> None:
    """ModelMismatch, in one line, for a load the comparison cannot apply (:class:`harness.engine.sensors.Load`)."""
    where = f"load {load.constraint!r} on {load.body!r}"
    if load.constraint not in dyn.constraint_names:
        raise ModelMismatch(f"load on {load.body!r} names constraint {load.constraint!r}; the system's: "
                            f"{list(dyn.constraint_names)}")
    rows = dyn.blocks[load.constraint]
    one_row = load.direction is not None or bool(load.slide)
    if load.direction is not None and load.slide:
        raise ModelMismatch(f"{where} gives both a direction and slide {load.slide!r}; accepted: one of them")
    if not one_row and rows.stop - rows.start not in (3, 6):
        raise ModelMismatch(f"{where}: constraint {load.constraint!r} has {rows.stop - rows.start} rows; accepted: "
                            "a direction for a one-row constraint (or a slide: its world axis), none for a "
                            "connect's 3 rows (a world force) or a weld's 6 (a world force and a moment)")
    if load.sign not in (1.0, -1.0):
        raise ModelMismatch(f"{where} has sign {load.sign!r}; accepted: +1 or -1")
    if bool(load.site) == bool(load.contact):
        raise ModelMismatch(f"{where} needs exactly one of site and contact (a geom), got site={load.site!r}, "
                            f"contact={load.contact!r}")
    if load.slide:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, load.slide)
        if jid < 0 or int(model.jnt_type[jid]) != int(mujoco.mjtJoint.mjJNT_SLIDE):
            raise ModelMismatch(f"{where}: {load.slide!r} is not a slide joint of the model; accepted: a slide, "
                                "whose world axis is the force's direction")
    if load.contact:
        gid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, load.contact)
        if gid < 0 or model.body(int(model.geom_bodyid[gid])).name != load.body:
            raise ModelMismatch(f"{where}: {load.contact!r} is not a geom of body {load.body!r}; accepted: a geom "
                                "of the loaded body, at whose contact the force acts")


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


def reaction_deviations(model: mujoco.MjModel, dyn: Dynamics, rec: Recorder, q: np.ndarray, qd: np.ndarray,
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
    return tuple(s.name for s in found), tuple(dict.fromkeys(s.body for s in found if s.kind != "accelerometer"))

"""MuJoCo's reaction sensors as users read them: ``force``, ``torque``, ``accelerometer`` and ``cfrc_int``.

All of them are computed in ``mj_rnePostConstraint`` (called by ``mj_forward``'s
sensor stage when such a sensor exists), a code path separate from
``efc_force``: a recursive Newton–Euler pass with the final accelerations, in
which ``cfrc_int`` of a body is the wrench its parent exerts on its subtree
through the joint(s) between them, and ``cfrc_ext`` the forces that do not pass
through a joint — applied forces, contacts, connect and weld equalities and, on
MuJoCo ≥ 4.0, spatial tendons (APIreference, ``mj_rnePostConstraint``).
Joint and fixed-tendon forces (a joint equality, a fixed tendon's equality) act
in joint space and are attributed to the joints.

- ``force`` / ``torque`` at a site: ``cfrc_int`` of the site's body, the force
  and its moment about the site, by the parent on the child, in the site frame;
- ``accelerometer``: the site's linear acceleration less gravity (a − g: +g
  upward at rest), in the site frame.

:func:`world_reading` rotates a reading into the world frame (``site_xmat``),
where the harness compares it: a frame is a convention, the vector is the
physics. A site on the world body is static. Only sensors that MuJoCo reports
unaltered are judged: one with a ``cutoff`` (its reading clipped), a delay or
history (a reading from the past), not on a site, and every ``user`` or plugin
sensor (computed by code the reference cannot see) keeps its figure, n/a with
why (:attr:`Sensor.unjudged`); none of them refuses the model. A sensor's
``noise`` is not applied by the engine (MuJoCo stores it for the user:
``sensor_noise`` is read by nothing in its engine), so a noisy sensor is judged.
An unnamed sensor is named ``sensorN`` (N its index) and a dot in a name (which
would split its figure's name) becomes ``_``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from analytic.dynamics import Dynamics
from harness.core.errors import ModelMismatch
from harness.engine.readings.momentum import subtree as body_subtree

__all__ = ["Load", "Recorder", "Sensor", "sensors", "weld_moment_map"]

KINDS: dict[int, str] = {
    int(mujoco.mjtSensor.mjSENS_FORCE): "force",
    int(mujoco.mjtSensor.mjSENS_TORQUE): "torque",
    int(mujoco.mjtSensor.mjSENS_ACCELEROMETER): "accelerometer",
}


@dataclass(frozen=True)
class Sensor:
    """One reaction sensor: its name, kind (``force``, ``torque``, ``accelerometer``), site, the site's
    body and where its three numbers start in ``sensordata``."""

    name: str
    kind: str
    site: str
    body: str
    adr: int
    unjudged: str = ""
    """Why the reference cannot judge its reading ('' where it can): its figure is then n/a with this reason."""


@dataclass(frozen=True)
class Load:
    """An external force that a constraint applies to a body, declared by a case's wiring where MuJoCo
    counts it in ``cfrc_ext`` (a spatial tendon's pull, a connect, a contact), acting at the world
    position of ``site`` (for a one-row constraint any site on the line of action: the moment depends
    only on the line) or, for a contact, at the contact point of geom ``contact``.

    One row (``direction`` or ``slide`` given): the force is the constraint's multiplier times the world
    unit ``direction``, or times the world axis of the slide joint ``slide`` at the state (read from the
    model, as a rolling system writes each contact multiplier: the contact force along one of its
    slides). A ``connect`` (neither): its three rows are the world components of anchor1 − anchor2 and
    M q̈ = F + Jᵀλ, so λ itself is the world force on the body of ``site1`` at its anchor and −λ the
    force on the body of ``site2``: ``sign`` +1 or −1 says which. A ``weld`` (neither, 6 rows): its first
    three rows as a connect's, and its orientation rows' λ_τ a moment besides, τ = M λ_τ on the body of
    site1 and −τ on the body of site2 (M per state: :func:`weld_moment_map`; ``sign`` again says which).

    A contact's point (``contact``: a geom of ``body``) is where MuJoCo applies the contact force at the
    state, ``data.contact.pos`` of the active contact on that geom (the mean where several are), as a
    site's position is MuJoCo's at the state (:mod:`harness.families.reactions`). MuJoCo puts it midway
    between the surfaces, half the penetration p inside the ideal touching point along the normal: a
    shift along the normal moves only the moment of the tangential force, by p/2 × |f_t|. At the
    instantaneous layer's states (on the constraint manifold) p is round-off, and so is that shift, far below
    the figures' limits; along a trajectory p is the soft contact's penetration, and the analytic point's
    position is then no better known (the sizes on the shipped contact cases: docs/design.md, "Reactions as
    users read them"). A
    body-fixed site could not mark it (the contact point moves over a rolling rim). At a state where
    the geom has no active contact (a model whose geometry misses the system's surface) MuJoCo applies
    no force while the multiplier still pulls, so the force figure fails whatever the point; the moment
    is then taken at the geom's centre."""

    constraint: str
    body: str
    site: str = ""
    direction: tuple[float, float, float] | None = None
    sign: float = 1.0
    slide: str = ""
    contact: str = ""


def contact_point(model: mujoco.MjModel, data: mujoco.MjData, geom: str) -> np.ndarray | None:
    """The world position of the active contact on ``geom`` after ``mj_forward`` (the mean of several),
    None where it has none (excluded contacts, ``efc_address < 0``, carry no force)."""
    gid = model.geom(geom).id
    found = [data.contact[i].pos.copy() for i in range(data.ncon)
             if data.contact[i].efc_address >= 0 and gid in (data.contact[i].geom1, data.contact[i].geom2)]
    return np.mean(found, axis=0) if found else None


def weld_moment_map(model: mujoco.MjModel, data: mujoco.MjData, name: str) -> np.ndarray:
    """M (3×3) with τ = M λ_τ: the world moment that the orientation rows of the weld ``name`` exert on
    its first body (−τ on its second), from their multipliers λ_τ (``efc_force`` rows 3–5), after
    ``mj_forward``.

    MuJoCo's rows (engine_core_constraint.c, mjEQ_WELD) are s·vec(q̄₂ ⊗ q₁), s the ``torquescale``
    (``eq_data[10]``), q₁ and q₂ the world orientations of the weld's two frames (site semantics: the
    sites'; body semantics: body1's ⊗ ``relpose`` and body2's), with the Jacobian (s/2)·vec(q̄₂ ⊗ (0,
    ω₁ − ω₂) ⊗ q₁). By virtual work, λ_τ·δrows = τ·(δφ₁ − δφ₂) with vec((0, u) ⊗ r) = r_w u + u × r_v
    for r = q̄₂ ⊗ q₁ and u = R₂ᵀ δφ, so

        τ = (s/2) R₂ (r_w λ_τ + r_v × λ_τ),        M = (s/2) R₂ (r_w I + [r_v]×)

    — (s/2) R₂ where the weld holds (r = 1): λ_τ is the moment in frame 2 times 2/s. MuJoCo ≥ 3.14
    adds exactly this to ``cfrc_ext`` (before, λ_τ itself as a world torque: changelog 3.14.0, bug fix 8);
    ``tests/test_welded_pendulum.py`` pins it against ``cfrc_ext`` and ``qfrc_constraint``.
    ModelMismatch where ``name`` is not a weld."""
    eq = model.equality(name).id
    if int(model.eq_type[eq]) != int(mujoco.mjtEq.mjEQ_WELD):
        raise ModelMismatch(f"equality {name!r} is of type {mujoco.mjtEq(int(model.eq_type[eq])).name}; a load "
                            "with a moment is accepted on a weld (mjEQ_WELD) only")
    obj = (int(model.eq_obj1id[eq]), int(model.eq_obj2id[eq]))
    frames = []
    for k, o in enumerate(obj):
        if int(model.eq_objtype[eq]) == int(mujoco.mjtObj.mjOBJ_SITE):
            local, body = model.site_quat[o], int(model.site_bodyid[o])
        else:  # body semantics: the relative pose rides on body1
            local, body = (model.eq_data[eq][6:10] if k == 0 else np.array([1.0, 0.0, 0.0, 0.0])), o
        frame = np.zeros(4)
        mujoco.mju_mulQuat(frame, data.xquat[body], np.asarray(local, dtype=float))
        frames.append(frame)
    conj, relative, rotation = np.zeros(4), np.zeros(4), np.zeros(9)
    mujoco.mju_negQuat(conj, frames[1])
    mujoco.mju_mulQuat(relative, conj, frames[0])
    mujoco.mju_quat2Mat(rotation, frames[1])
    w, (x, y, z) = relative[0], relative[1:]
    spin = np.array([[w, -z, y], [z, w, -x], [-y, x, w]])  # r_w I + [r_v]×
    return 0.5 * float(model.eq_data[eq][10]) * rotation.reshape(3, 3) @ spin


def sensors(model: mujoco.MjModel) -> tuple[Sensor, ...]:
    """Every force, torque, accelerometer, user and plugin sensor of ``model``, those the reference cannot judge with
    why (:attr:`Sensor.unjudged`)."""
    out = []
    for i in range(model.nsensor):
        kind = KINDS.get(int(model.sensor_type[i])) or OPAQUE.get(int(model.sensor_type[i]))
        if kind is None:
            continue
        name = (model.sensor(i).name or f"sensor{i}").replace(".", "_")
        why = unjudged(model, i)
        site = int(model.sensor_objid[i]) if int(model.sensor_objtype[i]) == int(mujoco.mjtObj.mjOBJ_SITE) else -1
        out.append(Sensor(name=name, kind=kind, site=model.site(site).name if site >= 0 else "",
                          body=model.body(int(model.site_bodyid[site])).name if site >= 0 else "",
                          adr=int(model.sensor_adr[i]), unjudged=why))
    return tuple(out)


OPAQUE: dict[int, str] = {int(mujoco.mjtSensor.mjSENS_USER): "user", int(mujoco.mjtSensor.mjSENS_PLUGIN): "plugin"}
"""Sensors whose reading is computed by code outside the model (a callback, a plugin): never judged."""


def unjudged(model: mujoco.MjModel, i: int) -> str:
    """Why the reference cannot judge sensor ``i``'s reading ('' where it can)."""
    kind = int(model.sensor_type[i])
    if kind in OPAQUE:
        return f"a {OPAQUE[kind]} sensor: its reading is computed by code the reference cannot see"
    if model.sensor_cutoff[i] > 0:
        return f"its reading is clipped to ±cutoff {model.sensor_cutoff[i]:g}, which the reference does not model"
    for attr in ("sensor_delay", "sensor_history"):  # MuJoCo >= 3.4: readings from the past
        if hasattr(model, attr) and np.any(np.asarray(getattr(model, attr)[i]) > 0):
            return f"it has a {attr.removeprefix('sensor_')}: its reading is from the past, not the state"
    if int(model.sensor_objtype[i]) != int(mujoco.mjtObj.mjOBJ_SITE):
        return "it is not mounted on a site"
    return ""


def world_reading(model: mujoco.MjModel, data: mujoco.MjData, sensor: Sensor) -> np.ndarray:
    """The sensor's three numbers rotated from its site's frame into the world's, after ``mj_forward``."""
    rotation = data.site_xmat[model.site(sensor.site).id].reshape(3, 3)
    return rotation @ data.sensordata[sensor.adr:sensor.adr + 3]


def subtree(model: mujoco.MjModel, body: str) -> tuple[str, ...]:
    """The bodies of ``body``'s subtree (itself and every descendant), by name, in body order
    (:func:`harness.engine.readings.momentum.subtree`'s, by name)."""
    return tuple(model.body(b).name for b in body_subtree(model, model.body(body).id))


def interaction(model: mujoco.MjModel, data: mujoco.MjData, body: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``cfrc_int`` of ``body`` as (force, moment, about): world vectors, the moment about the point
    ``about`` (the subtree centre of mass of its tree's root, the origin of MuJoCo's c-frame)."""
    b = model.body(body).id
    wrench = data.cfrc_int[b]
    return wrench[3:].copy(), wrench[:3].copy(), data.subtree_com[int(model.body_rootid[b])].copy()


def external_force(model: mujoco.MjModel, data: mujoco.MjData, body: str) -> float:
    """|cfrc_ext| of ``body`` (force and moment together): what MuJoCo counts as acting on it from outside
    its joints."""
    return float(np.linalg.norm(data.cfrc_ext[model.body(body).id]))


class Recorder:
    """MuJoCo's side of the reactions, state by state: every reaction sensor's reading, the sites, the sensed
    bodies' ``cfrc_int`` and their subtrees' external forces, and where each declared load acts; call :meth:`record`
    after each ``mj_forward``. Checked against the analytic system ``dyn`` it is compared with: every body with mass
    in a sensor's subtree must be one of its bodies, and every load one it can apply."""

    def __init__(self, model: mujoco.MjModel, dyn: Dynamics, loads: Sequence[Load]) -> None:
        self.sensors = tuple(s for s in sensors(model) if not s.unjudged)
        self.loads = tuple(loads)
        self.wrenched = tuple(dict.fromkeys(s.body for s in self.sensors if s.kind != "accelerometer"))
        self.subtrees = {b: subtree(model, b) for b in self.wrenched}
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
        self.rows["reading"].append([world_reading(model, data, s) for s in self.sensors])
        self.rows["site"].append([data.site_xpos[model.site(s).id].copy() for s in self.sites])
        self.rows["interaction"].append([np.concatenate(interaction(model, data, b)) for b in self.wrenched])
        self.rows["external"].append({b: external_force(model, data, b) for tree in self.subtrees.values()
                                      for b in tree})
        self.rows["com"].append({s.name: data.xipos[model.body(s.body).id].copy() for s in self.sensors})
        # where the geom has no active contact MuJoCo applies no force there, while the system's multiplier
        # still pulls: the force figure fails whatever the point, and the moment is taken at the geom's centre
        points = {ld.contact: contact_point(model, data, ld.contact) for ld in self.loads if ld.contact}
        self.rows["contact"].append({g: data.geom_xpos[model.geom(g).id].copy() if pt is None else pt
                                     for g, pt in points.items()})
        self.rows["axis"].append({ld.slide: data.xaxis[model.joint(ld.slide).id].copy() for ld in self.loads
                                  if ld.slide})
        self.rows["moment"].append({w: weld_moment_map(model, data, w) for w in self.welds})

    def load_point(self, load: Load, site_pos: Mapping[str, np.ndarray]) -> np.ndarray:
        """Where ``load`` acts at each state (n, 3): its site's position, or its contact's point."""
        return site_pos[load.site] if load.site else np.array([row[load.contact] for row in self.rows["contact"]])


def _check_load(model: mujoco.MjModel, dyn: Dynamics, load: Load) -> None:
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

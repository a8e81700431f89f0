"""A Pinocchio model against MuJoCo's compiled model, body by body and joint by joint: the comparison the URDF
opinion (:mod:`harness.opinions.urdf`) and the MJCF-parser opinion (:mod:`harness.opinions.parser`) share.

The two sides split a robot differently: MuJoCo keeps a URDF's fixed-joint children as bodies without joints
(unless ``fusestatic`` fuses them), Pinocchio merges them into their parent joint's inertia. So both are compared
per *moving body*: a body with at least one joint together with everything welded to it (mass summed, centre of
mass and inertia combined about the combined centre of mass), named after the body that carries the joint. The
common frame is the world frame at the reference configuration (MuJoCo's ``qpos0``; Pinocchio's ``q`` at the
same pose). Then M(q) and the gravity torques are compared at a few configurations sampled within the joints'
limits (MuJoCo's ``mj_fullM`` and ``qfrc_bias`` at zero velocity, armature left out: a URDF cannot state it).
Each difference over its tolerance (:data:`TOLERANCES`, each with its basis) is named with the torque it causes
at the worst sampled state.

Conventions: Pinocchio's quaternions are xyzw, MuJoCo's wxyz; a free joint's linear velocity is world-frame in
MuJoCo's qvel, local in Pinocchio's v (angular local in both), so a free joint's rows are mapped by
``blockdiag(R, 1)``. Pinocchio is optional and imported lazily (:func:`pinocchio_available`).
"""

from __future__ import annotations

import contextlib
import importlib.util
import os
import tempfile
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, replace

import mujoco
import numpy as np

from harness.engine.compat import full_mass_matrix

__all__ = ["PIN_EXTRA", "Comparison", "captured_stderr", "compare", "pinocchio_available", "sample_states"]

PIN_EXTRA = "pip install 'mjharness[pin]'"

# Tolerances, each relative to the scale named beside it, and their basis. Two files describing the same robot
# agree to float64 round-off (~1e-15) where both hold the same decimal text; a file written by a converter holds
# about six significant digits (MuJoCo's own MJCF writer prints %g: 5e-7 relative per number), so:
TOLERANCES = {
    "mass": 1e-6,           # x the larger mass: one number at six significant digits (5e-7) with margin
    "centre of mass": 1e-5,  # m, x max(1 m, |c|): a chain of link offsets each at six digits (5e-7 m each)
    "inertia": 1e-5,        # x the tensor's largest entry: six-digit diagonal (5e-7) turned by a six-digit
                            # quaternion (a rotation off by up to ~1e-6 rad moves entries by ~2e-6 of the largest)
    "axis": 1e-5,           # unit vector: six-digit axis turned through the chain's six-digit rotations
    "axis position": 1e-5,  # m, x max(1 m, |p|): as the centre of mass
    "limit": 1e-5,          # rad or m, x max(1, |limit|): six-digit text, and MuJoCo's degrees-to-radians
    "M(q)": 1e-5,           # x the largest diagonal entry over the states: products of the quantities above
    "gravity torque": 1e-5,  # x the largest |torque| over the states: as M(q)
}
STATES = 6  # sampled configurations besides the reference one; seeded, so a run is reproducible
_UNBOUNDED = 1e10  # a Pinocchio limit at or beyond this is "no limit"


@contextlib.contextmanager
def captured_stderr() -> Iterator[list[str]]:
    """The C-level stderr (urdfdom prints its parse errors there) captured into the list yielded, not shown."""
    lines: list[str] = []
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        saved = os.dup(2)
        os.dup2(tmp.fileno(), 2)
        try:
            yield lines
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            lines += tmp.read().decode(errors="replace").splitlines()


def pinocchio_available() -> bool:
    """Whether Pinocchio (the ``pin`` package, module ``pinocchio``) can be imported here."""
    return importlib.util.find_spec("pinocchio") is not None


@dataclass(frozen=True)
class Difference:
    """One quantity over its tolerance: ``element`` is a body or a joint (``kind``), ``a`` the Pinocchio side's
    value (the URDF's, or Pinocchio's parser's), ``b`` MuJoCo's compiled model's, ``size`` how far apart in
    ``unit``; ``torque`` the largest gravity torque this difference alone changes at the sampled states (a body's
    inertia swapped for the other side's; N·m on a hinge, N on a slide), ``on`` the joint it lands on, ``inertia``
    the largest change of an entry of M(q) it makes; None where not attributed."""

    kind: str
    element: str
    quantity: str
    a: str
    b: str
    size: float
    tolerance: float
    unit: str
    torque: float | None = None
    on: str | None = None
    inertia: float | None = None

    def line(self, a: str, b: str) -> str:
        effect = ""
        if self.torque is not None and self.on:
            effect = (f"; alone it changes the gravity torque on {self.on} by up to {self.torque:.3g} (N·m or N) "
                      f"and an entry of M(q) by up to {self.inertia:.3g}")
        unit = f" {self.unit}" if self.unit else ""
        return (f"{self.kind} {self.element}: {self.quantity}: {a} {self.a}, {b} {self.b} "
                f"(off by {self.size:.3g}{unit}, tolerance {self.tolerance:.3g}){effect}")

    def as_dict(self) -> dict:
        return {"kind": self.kind, "element": self.element, "quantity": self.quantity, "a": self.a, "b": self.b,
                "size": self.size, "tolerance": self.tolerance, "unit": self.unit, "torque": self.torque,
                "on": self.on, "inertia": self.inertia}


@dataclass(frozen=True)
class Comparison:
    """The outcome of :func:`compare`: the differences over tolerance, the names matched (Pinocchio's → MuJoCo's
    moving bodies), the elements one side has and the other lacks, and notes (what was not compared)."""

    differences: tuple[Difference, ...]
    bodies: tuple[tuple[str, str], ...]
    joints: int
    states: int
    only_a: tuple[str, ...] = ()
    only_b: tuple[str, ...] = ()
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def passed(self) -> bool:
        return not self.differences and not self.only_a and not self.only_b

    def as_dict(self) -> dict:
        return {"passed": self.passed, "bodies": [list(p) for p in self.bodies], "joints": self.joints,
                "states": self.states, "differences": [d.as_dict() for d in self.differences],
                "only_pinocchio": list(self.only_a), "only_mujoco": list(self.only_b), "notes": list(self.notes),
                "tolerances": dict(TOLERANCES)}


# --------------------------------------------------------------- the two sides, as moving bodies
@dataclass(frozen=True)
class _Body:
    name: str
    mass: float
    com: np.ndarray       # world frame, reference configuration
    inertia: np.ndarray   # world frame, about com
    joints: tuple[str, ...]


@dataclass(frozen=True)
class _Dof:
    joint: str
    kind: str                     # hinge, slide, ball, free
    axis: np.ndarray | None       # world frame, unit (hinge, slide)
    point: np.ndarray | None      # a point on a hinge's axis, world frame
    limits: tuple[float, float] | None


def _combine(parts: list[tuple[float, np.ndarray, np.ndarray]]) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, centre of mass and inertia about it of rigidly joined parts, each (mass, com, inertia about com)."""
    mass = sum(m for m, _, _ in parts)
    com = sum(m * c for m, c, _ in parts) / mass if mass > 0 else parts[0][1]
    inertia = np.zeros((3, 3))
    for m, c, i in parts:
        d = c - com
        inertia += i + m * (d @ d * np.eye(3) - np.outer(d, d))
    return mass, np.asarray(com, float), inertia


def _mj_name(m: mujoco.MjModel, obj: mujoco.mjtObj, i: int, what: str) -> str:
    return mujoco.mj_id2name(m, obj, i) or f"{what} #{i}"


def mujoco_bodies(m: mujoco.MjModel) -> tuple[dict[str, _Body], dict[str, int]]:
    """MuJoCo's moving bodies at ``qpos0`` (each body with joints, with its welded descendants), and each one's
    body id."""
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    owner = [0] * m.nbody
    for b in range(1, m.nbody):
        owner[b] = b if m.body_jntnum[b] > 0 else owner[m.body_parentid[b]]
    groups: dict[int, list[int]] = {}
    for b in range(1, m.nbody):
        if owner[b]:
            groups.setdefault(owner[b], []).append(b)
    out, ids = {}, {}
    for b, members in groups.items():
        parts = []
        for k in members:
            r = d.ximat[k].reshape(3, 3)
            parts.append((float(m.body_mass[k]), d.xipos[k].copy(), r @ np.diag(m.body_inertia[k]) @ r.T))
        mass, com, inertia = _combine(parts)
        name = _mj_name(m, mujoco.mjtObj.mjOBJ_BODY, b, "body")
        joints = tuple(_mj_name(m, mujoco.mjtObj.mjOBJ_JOINT, j, "joint")
                       for j in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b]))
        out[name], ids[name] = _Body(name, mass, com, inertia, joints), b
    return out, ids


def _mj_dofs(m: mujoco.MjModel, d: mujoco.MjData, b: int, origin: np.ndarray) -> list[_Dof]:
    """The joints of MuJoCo body ``b`` at ``qpos0``, one entry per joint, limits counted from ``origin``."""
    out = []
    for j in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b]):
        kind = {0: "free", 1: "ball", 2: "slide", 3: "hinge"}[int(m.jnt_type[j])]
        axis = d.xaxis[j].copy() if kind in ("hinge", "slide") else None
        limits = None
        if kind in ("hinge", "slide") and m.jnt_limited[j]:
            q0 = origin[m.jnt_qposadr[j]]
            limits = (float(m.jnt_range[j][0] - q0), float(m.jnt_range[j][1] - q0))
        out.append(_Dof(_mj_name(m, mujoco.mjtObj.mjOBJ_JOINT, j, "joint"), kind, axis,
                        d.xanchor[j].copy() if kind == "hinge" else None, limits))
    return out


def _pin_body_name(pm, i: int) -> str | None:
    """The body (link) a Pinocchio joint carries: the first BODY frame on it."""
    import pinocchio as pin  # lazy: Pinocchio is optional (the pin extra)

    for f in pm.frames:
        if f.parentJoint == i and f.type == pin.FrameType.BODY:
            return f.name
    return None


def _pin_dofs(pm, pd, i: int) -> list[_Dof]:
    """Pinocchio joint ``i``'s degrees of freedom as MuJoCo joints: free or ball as one, else one per dof
    (a composite joint's parts, an unbounded revolute's angle), read from its motion subspace in the world."""
    import pinocchio as pin  # lazy: Pinocchio is optional (the pin extra)

    joint = pm.joints[i]
    short = joint.shortname()
    if "FreeFlyer" in short:
        return [_Dof(pm.names[i], "free", None, None, None)]
    if "Spherical" in short and "ZYX" not in short:
        return [_Dof(pm.names[i], "ball", None, None, None)]
    s = np.asarray(pd.joints[i].S).reshape(6, -1)  # (linear; angular) per dof, the joint's frame
    placement = pd.oMi[i]
    out = []
    for k in range(joint.nv):
        motion = placement.act(pin.Motion(s[:, k]))  # world frame, at the world's origin
        w, v = np.asarray(motion.angular), np.asarray(motion.linear)
        limits = None
        if joint.nq == joint.nv:
            lo, hi = pm.lowerPositionLimit[joint.idx_q + k], pm.upperPositionLimit[joint.idx_q + k]
            if abs(lo) < _UNBOUNDED and abs(hi) < _UNBOUNDED:
                limits = (float(lo), float(hi))
        if np.linalg.norm(w) > 0.5:
            axis = w / np.linalg.norm(w)
            point = np.cross(axis, v)  # v = p × w at the origin: the foot of the axis from the origin is w × v
            out.append(_Dof(pm.names[i], "hinge", axis, point, limits))
        else:
            out.append(_Dof(pm.names[i], "slide", v / np.linalg.norm(v), None, limits))
    return out


# --------------------------------------------------------------- configurations on both sides
@dataclass(frozen=True)
class _Pair:
    """A matched moving body: Pinocchio joint ``i``, MuJoCo body ``b`` and their joints."""

    name: str
    i: int
    b: int
    mj_joints: tuple[int, ...]


def _pin_q(pm, m: mujoco.MjModel, pairs: list[_Pair], qpos: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """Pinocchio's q of MuJoCo's ``qpos``: a hinge's or slide's angle counted from ``origin``."""
    import pinocchio as pin  # lazy: Pinocchio is optional (the pin extra)

    q = pin.neutral(pm)
    for p in pairs:
        joint = pm.joints[p.i]
        short = joint.shortname()
        j0 = p.mj_joints[0]
        a = m.jnt_qposadr[j0]
        if "FreeFlyer" in short:
            pose = pin.SE3(pin.Quaternion(*qpos[a + 3:a + 7]).matrix(), qpos[a:a + 3].copy())
            q[joint.idx_q:joint.idx_q + 7] = pin.SE3ToXYZQUAT(pm.jointPlacements[p.i].inverse() * pose)
        elif "Spherical" in short:
            w, x, y, z = qpos[a:a + 4]
            q[joint.idx_q:joint.idx_q + 4] = (x, y, z, w)
        elif joint.nq == 2 * joint.nv == 2:  # unbounded revolute: cos, sin
            t = qpos[a] - origin[a]
            q[joint.idx_q:joint.idx_q + 2] = (np.cos(t), np.sin(t))
        else:
            for k, j in enumerate(p.mj_joints[:joint.nq]):
                a = m.jnt_qposadr[j]
                q[joint.idx_q + k] = qpos[a] - origin[a]
    return q


def _samples(m: mujoco.MjModel, pairs: list[_Pair], count: int, seed: int) -> list[np.ndarray]:
    """``qpos0`` and ``count`` configurations drawn within the matched joints' ranges (:func:`sample_states`)."""
    return sample_states(m, [j for p in pairs for j in p.mj_joints], count, seed)


def sample_states(m: mujoco.MjModel, joints: list[int], count: int, seed: int) -> list[np.ndarray]:
    """``qpos0`` and ``count`` configurations with ``joints`` drawn within their ranges (hinges without a range
    within ±π of qpos0, slides within ±0.5 m, ball and free joints at random orientations), seeded."""
    rng = np.random.default_rng(seed)
    out = [m.qpos0.copy()]
    for _ in range(count):
        qpos = m.qpos0.copy()
        for j in joints:
            a, kind = m.jnt_qposadr[j], int(m.jnt_type[j])
            if kind in (0, 1):
                quat = rng.normal(size=4)
                qpos[a + 3 * (kind == 0):a + 3 * (kind == 0) + 4] = quat / np.linalg.norm(quat)
                if kind == 0:
                    qpos[a:a + 3] += rng.uniform(-1, 1, 3)
            elif m.jnt_limited[j]:
                qpos[a] = rng.uniform(*m.jnt_range[j])
            else:
                qpos[a] += rng.uniform(-1, 1) * (np.pi if kind == 3 else 0.5)
        out.append(qpos)
    return out


def _dof_map(pm, m: mujoco.MjModel, pairs: list[_Pair]) -> tuple[list[int], list[int], list[str], list[int]]:
    """Matched dof indices: Pinocchio's, MuJoCo's, the MuJoCo joint each belongs to, and the free joints'
    first positions in these lists (their linear rows need the rotation)."""
    pin_v: list[int] = []
    mj_v: list[int] = []
    names: list[str] = []
    free: list[int] = []
    for p in pairs:
        joint = pm.joints[p.i]
        mj = [d for j in p.mj_joints for d in range(m.jnt_dofadr[j], m.jnt_dofadr[j] + _nv(m, j))]
        if len(mj) != joint.nv:
            continue
        if "FreeFlyer" in joint.shortname():
            free.append(len(pin_v))
        pin_v += list(range(joint.idx_v, joint.idx_v + joint.nv))
        mj_v += mj
        names += [_mj_name(m, mujoco.mjtObj.mjOBJ_JOINT, int(m.dof_jntid[d]), "joint") for d in mj]
    return pin_v, mj_v, names, free


def _nv(m: mujoco.MjModel, j: int) -> int:
    return {0: 6, 1: 3, 2: 1, 3: 1}[int(m.jnt_type[j])]


@dataclass(frozen=True)
class _Dynamics:
    M: np.ndarray  # per state, Pinocchio's dof order over the matched dofs
    g: np.ndarray


def _pin_dynamics(pm, qs: list[np.ndarray], pin_v: list[int]) -> _Dynamics:
    import pinocchio as pin  # lazy: Pinocchio is optional (the pin extra)

    pd = pm.createData()
    ms, gs = [], []
    for q in qs:
        full = np.array(pin.crba(pm, pd, q))
        full = np.triu(full) + np.triu(full, 1).T
        full -= np.diag(np.asarray(pm.armature, float))  # armature: a URDF cannot state it
        ms.append(full[np.ix_(pin_v, pin_v)])
        gs.append(np.array(pin.computeGeneralizedGravity(pm, pd, q))[pin_v])
    return _Dynamics(np.array(ms), np.array(gs))


def _mj_dynamics(m: mujoco.MjModel, qposes: list[np.ndarray], mj_v: list[int], free: list[int]) -> _Dynamics:
    """MuJoCo's M (armature left out) and gravity torque (qfrc_bias at zero velocity) over the matched dofs, in
    Pinocchio's velocity coordinates: a free joint's linear rows turned from the world into its body frame."""
    d = mujoco.MjData(m)
    ms, gs = [], []
    for qpos in qposes:
        d.qpos[:], d.qvel[:] = qpos, 0
        mujoco.mj_forward(m, d)
        full = full_mass_matrix(m, d)
        t = np.eye(len(mj_v))
        for k in free:
            jnt = int(m.dof_jntid[mj_v[k]])
            a = m.jnt_qposadr[jnt]
            r = np.zeros(9)
            mujoco.mju_quat2Mat(r, qpos[a + 3:a + 7])
            t[k:k + 3, k:k + 3] = r.reshape(3, 3)  # qvel = T v: world linear velocity = R × local
        mm = full[np.ix_(mj_v, mj_v)] - np.diag(m.dof_armature[mj_v])
        ms.append(t.T @ mm @ t)
        gs.append(t.T @ d.qfrc_bias[mj_v])
    return _Dynamics(np.array(ms), np.array(gs))


# --------------------------------------------------------------- the comparison
def _fmt(x: np.ndarray | float) -> str:
    if np.ndim(x) == 0:
        return f"{float(x):.6g}"
    return "(" + ", ".join(f"{float(v):.6g}" for v in np.ravel(x)) + ")"


_ENTRIES = ("xx", "xy", "xz", "yx", "yy", "yz", "zx", "zy", "zz")


def compare(pm, m: mujoco.MjModel, *, bodies: Mapping[str, str] | None = None,
            joints: Mapping[str, str] | None = None, joint_names: bool = True, absolute: bool = False,
            states: int = STATES, seed: int = 0) -> Comparison:
    """Pinocchio model ``pm`` against MuJoCo model ``m``, per moving body matched by name (``bodies`` renames
    Pinocchio's to MuJoCo's), their joints matched by name (``joints`` renames; with ``joint_names`` False, by
    order within the body), then M(q) and gravity torques at ``states`` seeded configurations. A hinge's or
    slide's q on Pinocchio's side is MuJoCo's qpos less ``qpos0`` (a URDF's zero is the pose as written, which
    MuJoCo's ``ref`` moves), or with ``absolute`` MuJoCo's qpos itself (Pinocchio's MJCF parser keeps ``ref``
    as MuJoCo does). Gravity on the Pinocchio side is MuJoCo's ``opt.gravity`` (a URDF does not state it)."""
    import pinocchio as pin  # lazy: Pinocchio is optional (the pin extra)

    bodies, joints = dict(bodies or {}), dict(joints or {})
    pm = pm.copy()
    pm.gravity = pin.Motion(np.array(m.opt.gravity, float), np.zeros(3))
    mj_bodies, mj_ids = mujoco_bodies(m)
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    pairs: list[_Pair] = []
    only_a = []
    for i in range(1, pm.njoints):
        name = _pin_body_name(pm, i)
        if name is None:  # a joint without a body of its own (a chain's intermediate joint): the next carries it
            continue
        target = bodies.get(name, name)
        if target not in mj_bodies:
            only_a.append(f"body {name}")
            continue
        b = mj_ids[target]
        pairs.append(_Pair(target, i, b, tuple(range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b]))))
    only_b = [f"body {n}" for n in mj_bodies if n not in {p.name for p in pairs}]

    origin = np.zeros(m.nq) if absolute else m.qpos0.copy()
    q_ref = _pin_q(pm, m, pairs, m.qpos0, origin)
    pd = pm.createData()
    pin.forwardKinematics(pm, pd, q_ref)
    diffs: list[Difference] = []
    swaps: list[tuple[int, int, int, pin.Inertia]] = []  # (first, end) of a body's differences, its joint, MuJoCo's
    njoints = 0
    for p in pairs:
        placement = pd.oMi[p.i]
        r, t = np.asarray(placement.rotation), np.asarray(placement.translation)
        y = pm.inertias[p.i]
        a = _Body(p.name, float(y.mass), r @ np.asarray(y.lever) + t, r @ np.asarray(y.inertia) @ r.T, ())
        bb = mj_bodies[p.name]
        label = p.name if _pin_body_name(pm, p.i) == p.name else f"{_pin_body_name(pm, p.i)} / {p.name}"
        before = len(diffs)
        diffs += _body_differences(label, a, bb)
        if len(diffs) > before:  # the MuJoCo body in Pinocchio's joint frame, to attribute its torque
            swaps.append((before, len(diffs), p.i, pin.Inertia(bb.mass, r.T @ (bb.com - t), r.T @ bb.inertia @ r)))
        a_dofs = _pin_dofs(pm, pd, p.i)
        b_dofs = _mj_dofs(m, d, p.b, origin)
        if [x.kind for x in a_dofs] != [x.kind for x in b_dofs]:
            diffs.append(Difference("body", label, "joints", ", ".join(f"{x.joint} ({x.kind})" for x in a_dofs),
                                    ", ".join(f"{x.joint} ({x.kind})" for x in b_dofs), float("inf"), 0, ""))
            continue
        for x, y_ in zip(a_dofs, b_dofs, strict=True):
            njoints += 1
            if joint_names and x.kind != "free" and joints.get(x.joint, x.joint) != y_.joint:  # URDF: unnamed
                only_a.append(f"joint {x.joint} (body {p.name})")
                only_b.append(f"joint {y_.joint} (body {p.name})")
                continue
            diffs += _joint_differences(y_.joint if x.joint == y_.joint or not joint_names
                                        else f"{x.joint} / {y_.joint}", x, y_)
    if only_a or only_b:
        return Comparison(tuple(diffs), tuple((pm.names[p.i], p.name) for p in pairs), njoints, 0,
                          tuple(only_a), tuple(only_b))
    diffs = _attribute(pm, m, pairs, diffs, swaps, states, seed, origin)
    return Comparison(tuple(diffs), tuple((_pin_body_name(pm, p.i) or "", p.name) for p in pairs), njoints,
                      states + 1)


def _body_differences(label: str, a: _Body, b: _Body) -> list[Difference]:
    out = []
    tol = TOLERANCES["mass"] * max(a.mass, b.mass)
    if abs(a.mass - b.mass) > tol:
        out.append(Difference("body", label, "mass", _fmt(a.mass), _fmt(b.mass), abs(a.mass - b.mass), tol, "kg"))
    size = float(np.linalg.norm(a.com - b.com))
    tol = TOLERANCES["centre of mass"] * max(1.0, float(np.linalg.norm(a.com)))
    if size > tol:
        out.append(Difference("body", label, "centre of mass (world frame, reference pose)", _fmt(a.com),
                              _fmt(b.com), size, tol, "m"))
    delta = np.abs(a.inertia - b.inertia)
    tol = TOLERANCES["inertia"] * max(np.abs(a.inertia).max(), np.abs(b.inertia).max(), 1e-300)
    if delta.max() > tol:
        k = int(np.argmax(delta))
        out.append(Difference("body", label, f"inertia I{_ENTRIES[k]} (world frame, about the centre of mass)",
                              _fmt(a.inertia.flat[k]), _fmt(b.inertia.flat[k]), float(delta.max()), tol, "kg·m²"))
    return out


def _joint_differences(label: str, a: _Dof, b: _Dof) -> list[Difference]:
    out = []
    if a.axis is not None and b.axis is not None:
        size = float(np.linalg.norm(a.axis - b.axis))
        if size > TOLERANCES["axis"]:
            out.append(Difference("joint", label, "axis (world frame, reference pose)", _fmt(a.axis), _fmt(b.axis),
                                  size, TOLERANCES["axis"], ""))
        elif a.point is not None and b.point is not None:
            # the distance between the two axis lines (parallel here): a point of one, off the other
            off = b.point - a.point
            size = float(np.linalg.norm(off - (off @ b.axis) * b.axis))
            tol = TOLERANCES["axis position"] * max(1.0, float(np.linalg.norm(b.point)))
            if size > tol:
                out.append(Difference("joint", label, "axis position (a point on it, world frame)", _fmt(a.point),
                                      _fmt(b.point), size, tol, "m"))
    if (a.limits is None) != (b.limits is None):
        out.append(Difference("joint", label, "limits", _fmt(np.array(a.limits)) if a.limits else "none",
                              _fmt(np.array(b.limits)) if b.limits else "none", float("inf"), 0, "rad or m"))
    elif a.limits is not None and b.limits is not None:
        size = max(abs(a.limits[0] - b.limits[0]), abs(a.limits[1] - b.limits[1]))
        tol = TOLERANCES["limit"] * max(1.0, *map(abs, a.limits))
        if size > tol:
            out.append(Difference("joint", label, "limits", _fmt(np.array(a.limits)), _fmt(np.array(b.limits)),
                                  size, tol, "rad or m"))
    return out


def _attribute(pm, m: mujoco.MjModel, pairs: list[_Pair], diffs: list[Difference], swaps: list, states: int,
               seed: int, origin: np.ndarray) -> list[Difference]:
    """M(q) and gravity torques at the sampled states, per joint (a difference over tolerance each), and the
    gravity torque each body difference causes alone: Pinocchio's model with that body's inertia swapped for
    MuJoCo's, at the state where it changes most."""
    qposes = _samples(m, pairs, states, seed)
    qs = [_pin_q(pm, m, pairs, qpos, origin) for qpos in qposes]
    pin_v, mj_v, names, free = _dof_map(pm, m, pairs)
    if not pin_v:
        return diffs
    a = _pin_dynamics(pm, qs, pin_v)
    b = _mj_dynamics(m, qposes, mj_v, free)
    out = list(diffs)
    # the body differences, each with the torque it causes (one swap per body, shared by its quantities)
    for first, end, i, inertia in swaps:
        swapped = pm.copy()
        swapped.inertias[i] = inertia
        changed = _pin_dynamics(swapped, qs, pin_v)
        delta = np.abs(changed.g - a.g)
        k = np.unravel_index(int(np.argmax(delta)), delta.shape)
        for n in range(first, end):
            out[n] = replace(out[n], torque=float(delta[k]), on=names[k[1]],
                             inertia=float(np.abs(changed.M - a.M).max()))
    # M(q) and gravity torques, per MuJoCo joint
    g_scale = max(np.abs(a.g).max(), np.abs(b.g).max())
    m_scale = max(np.abs(np.diagonal(a.M, axis1=1, axis2=2)).max(), np.abs(np.diagonal(b.M, axis1=1, axis2=2)).max())
    for joint in dict.fromkeys(names):
        cols = [k for k, n in enumerate(names) if n == joint]
        kind = int(m.jnt_type[m.dof_jntid[mj_v[cols[0]]]])
        torque, inertia = {3: ("N·m", "kg·m²"), 2: ("N", "kg")}.get(kind, ("N·m or N", "kg·m² or kg"))
        dg = np.abs(a.g[:, cols] - b.g[:, cols])
        s = int(np.argmax(dg.max(axis=1)))
        tol = TOLERANCES["gravity torque"] * g_scale
        if dg.max() > tol:
            out.append(Difference("joint", joint, f"gravity torque (worst of {len(qs)} states: state {s})",
                                  _fmt(a.g[s, cols]), _fmt(b.g[s, cols]), float(dg.max()), tol, torque))
        dm = np.abs(a.M[:, cols, :] - b.M[:, cols, :])
        s = int(np.argmax(dm.reshape(len(qs), -1).max(axis=1)))
        tol = TOLERANCES["M(q)"] * m_scale
        if dm.max() > tol:
            row = int(np.unravel_index(int(np.argmax(dm[s])), dm[s].shape)[0])
            out.append(Difference("joint", joint, f"M(q) row (worst of {len(qs)} states: state {s})",
                                  _fmt(a.M[s, cols[row]]), _fmt(b.M[s, cols[row]]), float(dm.max()), tol,
                                  inertia))
    return out

"""MuJoCo-side readings for rolling contacts: contact forces as multipliers, and slip.

Contact forces. ``mj_contactForce(model, data, i, f)`` gives contact i's force
in its contact frame, whose axes are the *rows* of ``contact.frame`` (normal
first, then the two tangents); the normal points from ``geom1`` to ``geom2``
and f is the force geom1 exerts on geom2 (normal component ≥ 0, pushing
apart). In world coordinates the force on geom2 is ``frameᵀ f[:3]`` and the
force on geom1 its negative (pinned in tests/test_hoop_ramp.py against
``qfrc_constraint``). Contacts MuJoCo excluded (``efc_address < 0``) carry none.

The rolling systems write each contact multiplier as one world component of
the contact force on the hoop, along the axis of one of its slides (the
system modules say which), so a multiplier is read as "contact force on the
hoop's geom, along slide J's world axis". That component is the generalized
constraint force ``qfrc_constraint`` = Jᵀ f at the slide's dof: a slide's
Jacobian column is its axis at every point of the bodies it moves, so Jᵀ f
there sums every constraint force on those bodies along the axis, which is
the contact's force alone when nothing else can push them along it (no limit
or friction loss on the slide, no equality on the bodies it moves, no other
colliding geom among them; :func:`slide_force` raises
:class:`~harness.core.errors.UnmodelledElement` for a model where something
could: an element the analytic system lacks, so a failed verdict). Read that
way it is recorded with the run, at no cost per sample; it equals the sum over
contacts of ``mj_contactForce`` above to
rounding (pinned in tests/test_hoop_ramp.py and tests/test_hoop_plane.py).

What a contact can be checked against. MuJoCo's soft contact answers to its
own state: a normal row pushes with the penetration, a friction row asks
J q̈ = −b J q̇ (no position term) and omits J̇ q̇. So at a sampled state of ideal
rolling the contact force equals the analytic multiplier only where J̇ q̇ = 0
and the contact is already active (a straight rolling line, with a pair margin
so that exact touching counts): there ``instant.qacc`` is gated. A turning
hoop gets its lateral force only from a steady slip v θ̇ · timeconst / 2, so
its instantaneous qacc misses the centripetal part entirely and only its
trajectories, forces after ``Case.settle`` and slip are gated.

Slip. The analytic constraint rows evaluated on MuJoCo's state: J q̇ + b for
the rolling rows is the slip velocity (ẋ − a φ̇ on the ramp), f(q) for a
holonomic row its violation (creep x − aφ, or the contact's s − a), with q
and q̇ read from the same-named joints and the parameters from the model.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Literal

import mujoco
import numpy as np

from harness.core.errors import UnmodelledElement
from harness.engine.readings import Reading
from harness.engine.readings.momentum import subtree
from harness.reference.derivations import dynamics_of

__all__ = ["analytic_residual", "contact_force", "fit_circle", "slide_force"]

ResidualLevel = Literal["position", "velocity"]


def contact_force(model: mujoco.MjModel, data: mujoco.MjData, geom: str | int) -> np.ndarray:
    """Net world force, shape (3,), of every active contact on ``geom`` (name or id), after ``mj_forward``."""
    gid = geom if isinstance(geom, int) else model.geom(geom).id
    total = np.zeros(3)
    local = np.zeros(6)
    for i in range(data.ncon):
        con = data.contact[i]
        if con.efc_address < 0 or gid not in (con.geom1, con.geom2):
            continue
        mujoco.mj_contactForce(model, data, i, local)
        world = con.frame.reshape(3, 3).T @ local[:3]
        total += world if con.geom2 == gid else -world
    return total


def _other_pushers(model: mujoco.MjModel, geom: int, joint: int) -> list[str]:
    """What besides contacts on ``geom`` could push the bodies ``joint`` moves along its axis."""
    moved = set(subtree(model, int(model.jnt_bodyid[joint])))
    dof = int(model.jnt_dofadr[joint])
    name = model.joint(joint).name
    found = []
    if model.jnt_limited[joint]:
        found.append(f"a limit on slide {name!r}")
    if model.dof_frictionloss[dof] > 0:
        found.append(f"friction loss on slide {name!r}")
    for i in range(model.neq):
        kind = int(model.eq_type[i])
        objs = [int(model.eq_obj1id[i]), int(model.eq_obj2id[i])]
        if kind == int(mujoco.mjtEq.mjEQ_JOINT):
            touches = joint in objs
        elif kind in (int(mujoco.mjtEq.mjEQ_CONNECT), int(mujoco.mjtEq.mjEQ_WELD)):
            touches = bool(moved & set(objs)) or int(model.eq_objtype[i]) == int(mujoco.mjtObj.mjOBJ_SITE)
        else:
            touches = True
        if touches:
            found.append(f"equality {model.equality(i).name or i!r}")
    if np.any(model.tendon_limited) or np.any(model.tendon_frictionloss > 0):
        found.append("a limited or frictional tendon")
    others = {g for g in range(model.ngeom) if g != geom and int(model.geom_bodyid[g]) in moved}
    colliding = {g for g in others if model.geom_contype[g] or model.geom_conaffinity[g]}
    colliding |= {int(g) for pair in (model.pair_geom1, model.pair_geom2) for g in pair if int(g) in others}
    found += [f"colliding geom {model.geom(g).name or g!r}" for g in sorted(colliding)]
    return found


def slide_force(*, geom: str, joint: str) -> Reading:
    """A reading of the contact force on ``geom`` along the world axis of the slide ``joint`` (N):
    ``qfrc_constraint`` at the slide's dof (see the module docstring for why that is the contact force,
    and when it would not be, which raises UnmodelledElement)."""
    checked: dict[str, Any] = {}

    def evaluate(model: mujoco.MjModel, rec: Mapping[str, np.ndarray]) -> np.ndarray:
        if checked.get("model") is not model:
            jid = model.joint(joint).id
            if model.jnt_type[jid] != mujoco.mjtJoint.mjJNT_SLIDE:
                raise ValueError(f"joint {joint!r} must be a slide, got "
                                 f"{mujoco.mjtJoint(model.jnt_type[jid]).name}")
            gid = model.geom(geom).id
            if int(model.geom_bodyid[gid]) not in subtree(model, int(model.jnt_bodyid[jid])):
                raise ValueError(f"slide {joint!r} does not move geom {geom!r}")
            others = _other_pushers(model, gid, jid)
            if others:
                raise UnmodelledElement(f"the model has {', '.join(others)}, which the analytic system has not "
                                        f"and which would be read as contact force on {geom!r} along slide "
                                        f"{joint!r} (qfrc_constraint there)")
            checked.update(model=model, dof=int(model.jnt_dofadr[jid]))
        return rec["qfrc_constraint"][:, checked["dof"]]  # the recorder copies what it keeps

    return Reading(fields=("qfrc_constraint",), evaluate=evaluate,
                   description=f"contact force on geom {geom!r} along slide {joint!r} (N)")


def analytic_residual(*, system: str, constraints: Sequence[str], level: ResidualLevel) -> Reading:
    """A reading of |residual| of the analytic ``constraints`` at MuJoCo's state.

    ``level="velocity"``: J q̇ + b (slip velocity for rolling rows);
    ``level="position"``: f(q) (0 for Pfaffian rows). Several rows give the
    Euclidean norm (the slip speed of a planar contact). The rows come from
    the system's derivation with the parameters of the model being read.
    """
    if level not in ("position", "velocity"):
        raise ValueError(f"level must be 'position' or 'velocity', got {level!r}")
    if not constraints:
        raise ValueError("constraints must name at least one constraint")
    bound: dict[str, Any] = {}

    def bind(model: mujoco.MjModel) -> None:
        dyn = dynamics_of(system, model)
        names = list(dyn.constraint_names)
        unknown = sorted(set(constraints) - set(names))
        if unknown:
            raise ValueError(f"system {system!r} has no constraint(s) {unknown}; it has {names}")
        bound.update(model=model, dyn=dyn, rows=[names.index(c) for c in constraints],
                     qpos=[model.joint(n).qposadr[0] for n in dyn.coordinates],
                     qvel=[model.joint(n).dofadr[0] for n in dyn.coordinates])

    def evaluate(model: mujoco.MjModel, rec: Mapping[str, np.ndarray]) -> np.ndarray:
        if bound.get("model") is not model:
            bind(model)
        dyn = bound["dyn"]
        q, qd = rec["qpos"][:, bound["qpos"]], rec["qvel"][:, bound["qvel"]]
        values = dyn.velocity_residual(q, qd) if level == "velocity" else dyn.position_residual(q)
        return np.linalg.norm(values[:, bound["rows"]], axis=1)

    return Reading(fields=(), evaluate=evaluate,
                   description=f"|{level} residual of {list(constraints)}| of system {system!r} at MuJoCo's state")


def fit_circle(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre (2,) and radius of the least-squares circle through planar ``points`` (N, 2).

    The algebraic (Kåsa) fit: x² + y² = 2 c·p + (r² − |c|²) is linear in c and
    r² − |c|², exact for points on a circle, so it turns a rolling hoop's path
    into the two numbers its analytic motion predicts (centre, radius a φ̇ / θ̇).
    """
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 3:
        raise ValueError(f"points must have shape (N >= 3, 2), got {pts.shape}")
    lhs = np.column_stack([2 * pts, np.ones(len(pts))])
    (cx, cy, k), *_ = np.linalg.lstsq(lhs, np.sum(pts**2, axis=1), rcond=None)
    centre = np.array([cx, cy])
    return centre, float(np.sqrt(k + centre @ centre))

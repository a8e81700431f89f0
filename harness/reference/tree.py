"""The tree reference of any model: its kinematic tree read from the compiled ``MjModel``.

What is read is the model's description only — body frames, inertias, joint
kinds, anchors, axes, ``ref``, springs, damping, armature, gravity
compensation, equality constraints, actuator gains at a given control with
their gear, ``forcerange`` and ``ctrlrange`` and the joints' ``actuatorfrcrange``,
and the disable flags that switch any of them off — never MuJoCo's dynamics
(``mj_fullM``, ``qfrc_bias``, ``qacc``): the equations are derived from this
description by :mod:`analytic.tree`.

Each MuJoCo feature is stated once, in :data:`FEATURES`: what of it is read,
what is not covered and why (listed, per kind, by :func:`uncovered`: contacts,
joint limits, dry friction, fluid forces, spatial tendons, activation
dynamics, …) and how it is switched off (:func:`isolate`); what the reference
cannot read at all is refused by :func:`refusal` (flex, plugins, a model with
nothing that moves).
Where the reference motion crosses a clamp's switch is located by
:func:`switches`, and what that does to an integrator's order is
:data:`SWITCHED_ORDER`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import mujoco
import numpy as np

from analytic.systems import Motion, Scales
from analytic.tree import Actuator, Body, Equality, ForceLimit, Joint, Point, TendonLimit, Tree, TreeDynamics
from analytic.tree.model import BALL, FREE, HINGE, SLIDE
from analytic.tree.terms import Spring, Term
from harness.core.errors import ModelError

__all__ = ["FEATURES", "SWITCHED_ORDER", "TREE", "Feature", "TreeEdit", "TreeSystem", "charts", "isolate", "motion",
           "prepare", "read_tree", "refusal", "start_state", "switch_note", "switched_orders", "switches",
           "tree_scales", "uncovered"]

TREE = "tree"
"""The system name of every case whose reference is its model's own tree (no hand-derived module)."""

_KINDS = {int(mujoco.mjtJoint.mjJNT_HINGE): HINGE, int(mujoco.mjtJoint.mjJNT_SLIDE): SLIDE,
          int(mujoco.mjtJoint.mjJNT_BALL): BALL, int(mujoco.mjtJoint.mjJNT_FREE): FREE}
_DSBL = mujoco.mjtDisableBit
_SPRUNG = (HINGE, SLIDE)
"""The joint kinds whose spring :func:`read_tree` reads (the others' are a gap of ``FEATURES``): one tuple, so
what is read and what is listed as not covered cannot disagree."""


def prepare(spec: mujoco.MjSpec) -> None:
    """What a user's model needs to be read by name, changing none of its physics: the energy flag
    (MuJoCo then records the energy the invariants compare) and a name for every unnamed body, joint,
    site and equality (``body3``, ``joint5``, …; the harness reads points and constraints by name)."""
    spec.option.enableflags |= int(mujoco.mjtEnableBit.mjENBL_ENERGY)
    for kind, elements in (("body", spec.bodies), ("joint", spec.joints), ("site", spec.sites),
                           ("equality", spec.equalities)):
        taken = {e.name for e in elements if e.name}
        for i, element in enumerate(elements):
            if kind == "body" and i == 0:
                continue  # the world
            if not element.name:
                name, k = f"{kind}{i}", i
                while name in taken:
                    k += 1
                    name = f"{kind}{k}"
                element.name = name
                taken.add(name)


def refusal(model: mujoco.MjModel) -> str:
    """Why the tree reference cannot describe ``model`` at all ('' where it can)."""
    if model.nv == 0:
        return "the model has no degrees of freedom (no joint moves anything); accepted: a model with joints"
    if model.nflex:
        return "the model has flex elements, which the tree reference cannot read; accepted: rigid bodies"
    if model.nplugin:
        return "the model uses engine plugins (e.g. SDF collisions, elasticity), which the tree reference cannot " \
               "read; accepted: a model without <plugin>"
    for i in range(model.neq):
        if int(model.eq_type[i]) not in (int(mujoco.mjtEq.mjEQ_CONNECT), int(mujoco.mjtEq.mjEQ_WELD),
                                         int(mujoco.mjtEq.mjEQ_JOINT), int(mujoco.mjtEq.mjEQ_TENDON)):
            kind = mujoco.mjtEq(int(model.eq_type[i])).name
            return f"equality {model.equality(i).name!r} is {kind}; accepted: connect, weld, joint, tendon"
        if int(model.eq_type[i]) == int(mujoco.mjtEq.mjEQ_WELD) and model.eq_active0[i] and not model.eq_data[i, 10]:
            return (f"weld {model.equality(i).name!r} has torquescale 0 (its 3 orientation rows are zero, which the "
                    "reference's multipliers cannot be solved for); accepted: torquescale > 0, or a connect")
    return ""


def _disabled(model: mujoco.MjModel, bit: mujoco.mjtDisableBit) -> bool:
    return bool(int(model.opt.disableflags) & int(bit))


def _tendon_limited(model: mujoco.MjModel, t: int) -> bool:
    """Whether tendon ``t`` has an actuatorfrcrange (MuJoCo 3.3.0 has none: never)."""
    limited = getattr(model, "tendon_actfrclimited", None)
    return limited is not None and bool(limited[t])


def _fixed_tendon(model: mujoco.MjModel, t: int) -> np.ndarray | None:
    """The coefficients over the dofs of fixed tendon ``t`` (length = Σ coef qpos), None for a spatial one."""
    coef = np.zeros(model.nv)
    for w in range(int(model.tendon_adr[t]), int(model.tendon_adr[t]) + int(model.tendon_num[t])):
        if int(model.wrap_type[w]) != int(mujoco.mjtWrap.mjWRAP_JOINT):
            return None
        jid = int(model.wrap_objid[w])
        if int(model.jnt_type[jid]) not in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            return None
        coef[int(model.jnt_dofadr[jid])] += float(model.wrap_prm[w])
    return coef


def _may_collide(model: mujoco.MjModel) -> bool:
    """Whether two geoms of different bodies pass MuJoCo's contype/conaffinity filter (a parent and its
    child are filtered unless filterparent is disabled), i.e. whether any contact can arise."""
    body = np.asarray(model.geom_bodyid)
    weld = np.asarray(model.body_weldid)[body]
    parent = np.asarray(model.body_weldid)[np.asarray(model.body_parentid)[np.asarray(model.body_weldid)[body]]]
    ctype, caff = np.asarray(model.geom_contype), np.asarray(model.geom_conaffinity)
    compatible = ((ctype[:, None] & caff[None, :]) | (caff[:, None] & ctype[None, :])) != 0
    different = weld[:, None] != weld[None, :]
    if not _disabled(model, _DSBL.mjDSBL_FILTERPARENT):
        related = (parent[:, None] == weld[None, :]) | (weld[:, None] == parent[None, :])
        different &= ~related | (weld[:, None] == 0) | (weld[None, :] == 0)
    return bool(np.any(compatible & different))


def _actuator_gap(model: mujoco.MjModel, a: int) -> str:
    """Why actuator ``a``'s force is not in the tree reference ('' where it is: an affine force on a hinge, slide or
    fixed tendon, its gear in the moment, clamped to its forcerange and, summed, to its joints' actuatorfrcrange, and
    scaled with the others on its tendon by the tendon's actuatorfrcrange — unless one of those is not modelled: its
    force, which isolating cannot remove from the tendon's sum, sets the scale)."""
    why = _own_gap(model, a)
    if why or not _acting(model, a) or int(model.actuator_trntype[a]) != int(mujoco.mjtTrn.mjTRN_TENDON):
        return why
    tendon = int(model.actuator_trnid[a, 0])
    if _tendon_limited(model, tendon):
        for other in range(model.nu):
            if other != a and int(model.actuator_trntype[other]) == int(mujoco.mjtTrn.mjTRN_TENDON) \
                    and int(model.actuator_trnid[other, 0]) == tendon and _acting(model, other) \
                    and _own_gap(model, other):
                return (f"its tendon's actuatorfrcrange scales it with actuator {model.actuator(other).name!r}, "
                        "which the reference does not model")
    return ""


def _own_gap(model: mujoco.MjModel, a: int) -> str:
    """Why actuator ``a``'s own force law is not in the tree reference ('' where it is)."""
    if not _acting(model, a):
        return ""
    if int(model.actuator_dyntype[a]) != int(mujoco.mjtDyn.mjDYN_NONE):
        return "activation dynamics (the force follows an internal state, not the control)"
    if int(model.actuator_gaintype[a]) not in (int(mujoco.mjtGain.mjGAIN_FIXED), int(mujoco.mjtGain.mjGAIN_AFFINE)):
        return f"gain type {mujoco.mjtGain(int(model.actuator_gaintype[a])).name}"
    if int(model.actuator_biastype[a]) not in (int(mujoco.mjtBias.mjBIAS_NONE), int(mujoco.mjtBias.mjBIAS_AFFINE)):
        return f"bias type {mujoco.mjtBias(int(model.actuator_biastype[a])).name}"
    if _moment(model, a) is None:
        return "a transmission other than a hinge, slide or fixed tendon"
    if hasattr(model, "actuator_ctrlnum") and int(model.actuator_ctrlnum[a]) != 1:
        return f"{int(model.actuator_ctrlnum[a])} control inputs (a multi-input actuator)"
    if hasattr(model, "actuator_delay") and model.actuator_delay[a]:
        return "a delayed control (read from the control history)"
    if hasattr(model, "actuator_damping") and np.any(model.actuator_damping[a]):
        return "damping of the actuator"
    if hasattr(model, "actuator_dampingpoly") and np.any(model.actuator_dampingpoly[a]):
        return "polynomial damping of the actuator"
    if hasattr(model, "actuator_armature") and np.any(model.actuator_armature[a]):
        return "actuator armature"
    return ""


def _acting(model: mujoco.MjModel, a: int) -> bool:
    """Whether actuator ``a`` applies a force: actuation on and its group not disabled (``disableactuator``)."""
    if _disabled(model, _DSBL.mjDSBL_ACTUATION):
        return False
    group = int(model.actuator_group[a])
    return not (0 <= group < 31 and int(model.opt.disableactuator) & (1 << group))


def _moment(model: mujoco.MjModel, a: int) -> np.ndarray | None:
    """Actuator ``a``'s moment over the dofs (length = moment · qpos), None for another transmission."""
    trn = int(model.actuator_trntype[a])
    target = int(model.actuator_trnid[a, 0])
    gear = float(model.actuator_gear[a, 0])
    if trn == int(mujoco.mjtTrn.mjTRN_JOINT):
        if int(model.jnt_type[target]) not in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            return None
        moment = np.zeros(model.nv)
        moment[int(model.jnt_dofadr[target])] = gear
        return moment
    if trn == int(mujoco.mjtTrn.mjTRN_TENDON):
        coef = _fixed_tendon(model, target)
        return None if coef is None else gear * coef
    return None


# ---- what the tree reference covers: one table, from which uncovered and isolate are derived -------------------
Gap = tuple[str, str, int]
"""One element of a compiled model with a feature the reference does not model: its key in :func:`uncovered`, why
it matters, and its index among its kind's elements (-1 for a model-wide feature)."""


@dataclass(frozen=True)
class Feature:
    """One MuJoCo feature and how the tree reference treats it, stated once: what of it :func:`read_tree` reads
    (``read``: the fields of :mod:`analytic.tree`'s types it fills; ``terms``: what it adds to joint j's potential,
    :mod:`analytic.tree.terms`, which :func:`read_tree` puts on the joint), where a compiled model has what is not
    covered (``gaps``, listed by :func:`uncovered`), and how :func:`isolate` switches that off in a spec
    (``switch_off``, given the indices ``gaps`` found; a model-wide switch is set whether or not the model has
    the feature). A feature with gaps and no ``switch_off`` is left acting in the comparison."""

    name: str
    read: tuple[str, ...] = ()
    terms: Callable[[mujoco.MjModel, int], tuple[Term, ...]] | None = None
    gaps: Callable[[mujoco.MjModel], Iterator[Gap]] | None = None
    switch_off: Callable[[mujoco.MjSpec, Sequence[int]], None] | None = None


def _model_wide(key: str, why: str, has: Callable[[mujoco.MjModel], bool]) -> Callable[[mujoco.MjModel], Iterator[Gap]]:
    def gaps(model: mujoco.MjModel) -> Iterator[Gap]:
        if has(model):
            yield key, why, -1
    return gaps


def _disabling(bit: mujoco.mjtDisableBit) -> Callable[[mujoco.MjSpec, Sequence[int]], None]:
    def switch_off(spec: mujoco.MjSpec, found: Sequence[int]) -> None:
        spec.option.disableflags |= int(bit)
    return switch_off


def _contacts_on(model: mujoco.MjModel) -> bool:
    on = not _disabled(model, _DSBL.mjDSBL_CONTACT) and not _disabled(model, _DSBL.mjDSBL_CONSTRAINT)
    return on and bool(model.npair or _may_collide(model))


def _fluid(model: mujoco.MjModel) -> bool:
    return bool(model.opt.density > 0 or model.opt.viscosity > 0 or np.any(model.opt.wind)
                or np.any(model.geom_fluid[:, 0]))


def _still_air(spec: mujoco.MjSpec, found: Sequence[int]) -> None:
    spec.option.density = 0.0
    spec.option.viscosity = 0.0
    spec.option.wind = [0.0, 0.0, 0.0]
    for geom in spec.geoms:
        geom.fluid_ellipsoid = 0.0


def _tendon_gaps(model: mujoco.MjModel) -> Iterator[Gap]:
    for t in range(model.ntendon):
        key = f"tendon {model.tendon(t).name or f'tendon{t}'}"
        if _fixed_tendon(model, t) is None:
            yield key, "a spatial tendon's force", t
        elif model.tendon_stiffness[t] or np.any(model.tendon_damping[t]) or model.tendon_limited[t] \
                or model.tendon_frictionloss[t] or getattr(model, "tendon_armature", np.zeros(model.ntendon))[t]:
            yield key, "a fixed tendon's spring, damping, limit, friction or armature", t


def _slack(spec: mujoco.MjSpec, found: Sequence[int]) -> None:
    """The tendons ``found`` without spring, damping, friction, armature or limit (their length stays read)."""
    for t in found:
        tendon = spec.tendons[t]
        for attribute in ("stiffness", "damping", "frictionloss", "armature"):
            if hasattr(tendon, attribute):  # a scalar on MuJoCo 3, MuJoCo 4's polynomial (a, b, c) where it is one
                setattr(tendon, attribute, np.zeros_like(np.asarray(getattr(tendon, attribute), dtype=float)))
        tendon.limited = 0


def _actuator_gaps(model: mujoco.MjModel) -> Iterator[Gap]:
    for a in range(model.nu):
        why = _actuator_gap(model, a)
        if why:
            yield f"actuator {model.actuator(a).name or a}", why, a


def _ungeared(spec: mujoco.MjSpec, found: Sequence[int]) -> None:
    """The actuators ``found`` with gear 0: they apply no force (their controls and states stay)."""
    for a in found:
        spec.actuators[a].gear = [0.0] * 6


def _springs_on(model: mujoco.MjModel) -> bool:
    """Whether MuJoCo applies joint springs: MuJoCo 3.3's one flag for every passive force, later their own."""
    every = hasattr(_DSBL, "mjDSBL_PASSIVE") and _disabled(model, _DSBL.mjDSBL_PASSIVE)
    return not every and not (hasattr(_DSBL, "mjDSBL_SPRING") and _disabled(model, _DSBL.mjDSBL_SPRING))


def _stiffness_poly(model: mujoco.MjModel, j: int) -> tuple[float, ...]:
    """Joint ``j``'s spring coefficients beyond the linear one (MuJoCo ≥ 3.7's ``jnt_stiffnesspoly``: x², x³, …;
    none before): every one the model holds, so that a longer polynomial is read whole, less trailing zeros (a
    linear spring's record is ``Spring(k, springref)``, as before polynomials)."""
    poly = [float(p) for p in np.atleast_1d(getattr(model, "jnt_stiffnesspoly", np.zeros((model.njnt, 0)))[j])]
    while poly and not poly[-1]:
        poly.pop()
    return tuple(poly)


def _springs(model: mujoco.MjModel, j: int) -> tuple[Term, ...]:
    """A hinge or slide's spring about its ``qpos_spring``, polynomial where the model's is (nothing where springs
    are off: stiffness 0, no polynomial)."""
    if _KINDS[int(model.jnt_type[j])] not in _SPRUNG:
        return ()
    on = _springs_on(model)
    return (Spring(stiffness=float(model.jnt_stiffness[j]) if on else 0.0,
                   springref=float(model.qpos_spring[model.jnt_qposadr[j]]),
                   poly=_stiffness_poly(model, j) if on else ()),)


def _spring_gaps(model: mujoco.MjModel) -> Iterator[Gap]:
    for j in range(model.njnt):
        why = ""
        if _KINDS[int(model.jnt_type[j])] not in _SPRUNG:
            if any(_stiffness_poly(model, j)):
                why = "a ball or free joint's polynomial spring (stiffnesspoly)"
            elif model.jnt_stiffness[j]:
                why = "a ball or free joint's spring"
        if hasattr(model, "jnt_springyield") and np.any(model.jnt_springyield[j]):
            why = "a spring that yields (springyield)"
        if why:
            yield f"joint {model.joint(j).name} spring", why, j


FEATURES: tuple[Feature, ...] = (
    Feature("bodies", read=("Body.pos", "Body.quat", "Body.ipos", "Body.iquat", "Body.mass", "Body.inertia",
                            "Tree.points", "Tree.size")),
    Feature("joints: hinge, slide, ball and free", read=("Joint.kind", "Joint.pos", "Joint.axis", "Joint.ref",
                                                         "Joint.armature", "Joint.chart")),
    Feature("joint damping", read=("Joint.damping",)),
    Feature("gravity and gravity compensation", read=("Tree.gravity", "Body.gravcomp", "Joint.gravcomp")),
    Feature("equality constraints: connect, weld, joint, tendon", read=("Tree.equalities",)),
    Feature("contacts", gaps=_model_wide("contacts", "geoms may collide; contact forces are not in the tree reference",
                                         _contacts_on), switch_off=_disabling(_DSBL.mjDSBL_CONTACT)),
    Feature("joint limits", gaps=_model_wide(
        "joint limits", "limited joints: a limit's force acts only when reached",
        lambda m: bool(np.any(m.jnt_limited)) and not _disabled(m, _DSBL.mjDSBL_LIMIT)),
        switch_off=_disabling(_DSBL.mjDSBL_LIMIT)),
    Feature("dry friction", gaps=_model_wide(
        "dry friction", "joint frictionloss (a dry-friction constraint)",
        lambda m: bool(np.any(m.dof_frictionloss > 0)) and not _disabled(m, _DSBL.mjDSBL_FRICTIONLOSS)),
        switch_off=_disabling(_DSBL.mjDSBL_FRICTIONLOSS)),
    Feature("fluid forces", gaps=_model_wide(
        "fluid forces", "density, viscosity, wind or a geom's fluidshape: fluid forces", _fluid),
        switch_off=_still_air),
    Feature("tendons: fixed ones' lengths; spatial ones, fixed ones' springs, damping, limits, friction, armature",
            read=("Equality.y", "Equality.x", "Actuator.moment", "TendonLimit.lo", "TendonLimit.hi"),
            gaps=_tendon_gaps, switch_off=_slack),
    Feature("actuators: affine force on a hinge, slide or fixed tendon, its clamps; any other",
            read=("Tree.actuators", "Tree.limits", "Tree.tendon_limits"), gaps=_actuator_gaps,
            switch_off=_ungeared),
    Feature("joint springs: hinge and slide, polynomial too; ball and free, yielding",
            read=("Joint.terms",), terms=_springs, gaps=_spring_gaps),
)
"""Every MuJoCo feature the tree reference reads or leaves out, in the order :func:`uncovered` lists them: leaving
a feature out is one entry here; modelling a joint feature, its entry's ``terms`` and its term
(:mod:`analytic.tree.terms`)."""


def uncovered(model: mujoco.MjModel) -> dict[str, str]:
    """Forces in ``model`` that the tree reference does not model, by kind, each with why it matters and
    what is checked instead (:data:`FEATURES`' gaps). Empty: every force MuJoCo applies is in the reference."""
    return {key: why for feature in FEATURES if feature.gaps for key, why, _ in feature.gaps(model)}


def isolate(spec: mujoco.MjSpec) -> None:
    """Switch off, in ``spec``, every force the tree reference does not model that :data:`FEATURES` says how to:
    contacts, joint limits, dry friction, fluid forces; spatial and damped tendons' forces; actuators whose force
    it does not model. Everything it does model is left as it is."""
    model = spec.compile()
    for feature in FEATURES:
        if feature.switch_off is not None:
            feature.switch_off(spec, [i for _, _, i in feature.gaps(model)] if feature.gaps else [])


def charts(model: mujoco.MjModel, qpos: np.ndarray) -> dict[int, np.ndarray]:
    """Each ball and free joint's chart R₀: its orientation at ``qpos`` (θ = 0 there)."""
    out = {}
    for j in range(model.njnt):
        kind = int(model.jnt_type[j])
        adr = int(model.jnt_qposadr[j])
        if kind == int(mujoco.mjtJoint.mjJNT_BALL):
            quat = np.asarray(qpos[adr:adr + 4], dtype=float)
        elif kind == int(mujoco.mjtJoint.mjJNT_FREE):
            quat = np.asarray(qpos[adr + 3:adr + 7], dtype=float)
        else:
            continue
        out[j] = quat / math.sqrt(float(quat @ quat))
    return out


def read_tree(model: mujoco.MjModel, *, chart: Mapping[int, np.ndarray] | None = None,
              ctrl: np.ndarray | None = None) -> Tree:
    """The tree of ``model``: every moving body (welded ones merged into nothing: a body with no joints
    rides on its parent), as :class:`analytic.tree.Tree`. ModelError where :func:`refusal` says why not."""
    why = refusal(model)
    if why:
        raise ModelError(why)
    chart = chart or {}
    # MuJoCo 3.3's one flag for every passive force (springs, dampers, gravity compensation), later two
    every = hasattr(_DSBL, "mjDSBL_PASSIVE") and _disabled(model, _DSBL.mjDSBL_PASSIVE)
    springs = _springs_on(model)
    damper = not every and not (hasattr(_DSBL, "mjDSBL_DAMPER") and _disabled(model, _DSBL.mjDSBL_DAMPER))
    # gravity compensation is computed unless both are off (mj_passive); on a joint with actuatorgravcomp it is added
    # to the actuators' force instead, which nothing applies where actuation is off or there are no actuators
    actuating = model.nu > 0 and not _disabled(model, _DSBL.mjDSBL_ACTUATION)
    gravity = np.zeros(3) if _disabled(model, _DSBL.mjDSBL_GRAVITY) else np.array(model.opt.gravity, dtype=float)
    bodies = []
    for b in range(1, model.nbody):
        mocap = int(model.body_mocapid[b]) >= 0
        bodies.append(Body(
            name=model.body(b).name, parent=int(model.body_parentid[b]) - 1,
            pos=np.array(model.body_pos[b], dtype=float), quat=np.array(model.body_quat[b], dtype=float),
            ipos=np.array(model.body_ipos[b], dtype=float), iquat=np.array(model.body_iquat[b], dtype=float),
            mass=float(model.body_mass[b]), inertia=np.array(model.body_inertia[b], dtype=float),
            joints=() if mocap else tuple(range(int(model.body_jntadr[b]),
                                                int(model.body_jntadr[b]) + int(model.body_jntnum[b]))),
            gravcomp=float(model.body_gravcomp[b]) if springs or damper else 0.0))
    joints = []
    for j in range(model.njnt):
        kind = _KINDS[int(model.jnt_type[j])]
        dof = int(model.jnt_dofadr[j])
        damping = np.atleast_1d(model.dof_damping[dof]).astype(float)
        poly = np.asarray(model.dof_dampingpoly[dof], dtype=float) if hasattr(model, "dof_dampingpoly") \
            else np.zeros(2)
        joints.append(Joint(
            name=model.joint(j).name, kind=kind, body=int(model.jnt_bodyid[j]) - 1, dof=dof,
            pos=np.array(model.jnt_pos[j], dtype=float), axis=np.array(model.jnt_axis[j], dtype=float),
            ref=float(model.qpos0[model.jnt_qposadr[j]]) if kind in (HINGE, SLIDE) else 0.0,
            terms=tuple(term for feature in FEATURES if feature.terms for term in feature.terms(model, j)),
            damping=(float(damping[0]), float(poly[0]), float(poly[1])) if damper else (0.0, 0.0, 0.0),
            armature=float(model.dof_armature[dof]),
            chart=np.asarray(chart.get(j, (1.0, 0.0, 0.0, 0.0)), dtype=float),
            gravcomp=("actuator" if actuating else "off") if model.jnt_actgravcomp[j] else "passive"))
    points = _points(model)
    equalities = () if _disabled(model, _DSBL.mjDSBL_EQUALITY) or _disabled(model, _DSBL.mjDSBL_CONSTRAINT) \
        else tuple(e for i in range(model.neq) if (e := _equality(model, i)) is not None)
    actuators = tuple(_actuator(model, a, 0.0 if ctrl is None else float(ctrl[a])) for a in range(model.nu)
                      if _acting(model, a) and not _actuator_gap(model, a))
    # MuJoCo clamps a joint's total actuator force whether or not an actuator acts (gravcomp may be all of it)
    limits = () if not actuating else tuple(
        ForceLimit(name=model.joint(j).name, dof=int(model.jnt_dofadr[j]), lo=float(model.jnt_actfrcrange[j, 0]),
                   hi=float(model.jnt_actfrcrange[j, 1]))
        for j in range(model.njnt) if model.jnt_actfrclimited[j]
        and int(model.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)))
    # a tendon's actuatorfrcrange scales the forces of the actuators on it (indices into ``actuators``)
    kept = [a for a in range(model.nu) if _acting(model, a) and not _actuator_gap(model, a)]
    tendon_limits = tuple(
        TendonLimit(name=model.tendon(t).name or f"tendon{t}", actuators=members,
                    lo=float(model.tendon_actfrcrange[t, 0]), hi=float(model.tendon_actfrcrange[t, 1]))
        for t in range(model.ntendon) if _tendon_limited(model, t)
        and (members := tuple(i for i, a in enumerate(kept) if int(model.actuator_trntype[a])
                              == int(mujoco.mjtTrn.mjTRN_TENDON) and int(model.actuator_trnid[a, 0]) == t)))
    return Tree(bodies=tuple(bodies), joints=tuple(joints), gravity=gravity, points=points,
                equalities=equalities, actuators=actuators, limits=limits, tendon_limits=tendon_limits,
                size=float(model.stat.meansize))


def _points(model: mujoco.MjModel) -> tuple[Point, ...]:
    """The points the trajectories compare: every named site, and the centre of mass of every body with
    mass whose name no site takes (the harness reads a name as a site first)."""
    sites = [Point(name=model.site(s).name, body=int(model.site_bodyid[s]) - 1,
                   pos=np.array(model.site_pos[s], dtype=float))
             for s in range(model.nsite) if model.site(s).name and int(model.site_bodyid[s]) > 0]
    taken = {p.name for p in sites}
    coms = [Point(name=model.body(b).name, body=b - 1, pos=np.array(model.body_ipos[b], dtype=float))
            for b in range(1, model.nbody) if model.body_mass[b] > 0 and model.body(b).name
            and model.body(b).name not in taken and _moves(model, b)]
    return (*coms, *sites)


def _moves(model: mujoco.MjModel, b: int) -> bool:
    while b > 0:
        if model.body_jntnum[b]:
            return True
        b = int(model.body_parentid[b])
    return False


def _site_or_body(model: mujoco.MjModel, i: int, which: int) -> tuple[int, np.ndarray]:
    """(tree body index, offset in its frame) of equality ``i``'s object ``which`` (1 or 2), for a body's
    anchor read from eq_data elsewhere, or a site's own position."""
    obj = int(model.eq_obj1id[i] if which == 1 else model.eq_obj2id[i])
    if int(model.eq_objtype[i]) == int(mujoco.mjtObj.mjOBJ_SITE):
        return int(model.site_bodyid[obj]) - 1, np.array(model.site_pos[obj], dtype=float)
    return obj - 1, np.zeros(3)


def _equality(model: mujoco.MjModel, i: int) -> Equality | None:
    if not model.eq_active0[i]:
        return None
    name = model.equality(i).name
    kind = int(model.eq_type[i])
    data = np.array(model.eq_data[i], dtype=float)
    sites = int(model.eq_objtype[i]) == int(mujoco.mjtObj.mjOBJ_SITE)
    if kind == int(mujoco.mjtEq.mjEQ_CONNECT):
        b1, s1 = _site_or_body(model, i, 1)
        b2, s2 = _site_or_body(model, i, 2)
        a1, a2 = (s1, s2) if sites else (data[0:3], data[3:6])
        return Equality(name=name, kind="connect", body1=b1, body2=b2, anchor1=a1, anchor2=a2)
    if kind == int(mujoco.mjtEq.mjEQ_WELD):
        b1, s1 = _site_or_body(model, i, 1)
        b2, s2 = _site_or_body(model, i, 2)
        norm = float(np.linalg.norm(data[6:10]))
        relquat = data[6:10] / norm if norm > 0 else np.array([1.0, 0.0, 0.0, 0.0])
        # eq_data: anchor on body2 (its frame), the matching point on body1 (its frame), body2's orientation
        # in body1's frame; with sites, the sites themselves (and their frames' relative orientation)
        a1, a2 = (s1, s2) if sites else (data[3:6], data[0:3])
        identity = np.array([1.0, 0.0, 0.0, 0.0])
        f1, f2 = (np.array(model.site_quat[int(model.eq_obj1id[i])], dtype=float),
                  np.array(model.site_quat[int(model.eq_obj2id[i])], dtype=float)) if sites else (identity, identity)
        return Equality(name=name, kind="weld", body1=b1, body2=b2, anchor1=a1, anchor2=a2, relquat=relquat,
                        torquescale=float(data[10]), frame1=f1, frame2=f2)
    if kind == int(mujoco.mjtEq.mjEQ_JOINT):
        j1, j2 = int(model.eq_obj1id[i]), int(model.eq_obj2id[i])
        y = np.zeros(model.nv)
        y[int(model.jnt_dofadr[j1])] = 1.0
        x = None
        if j2 >= 0:
            x = np.zeros(model.nv)
            x[int(model.jnt_dofadr[j2])] = 1.0
        return Equality(name=name, kind="joint", y=y, x=x, y0=float(model.qpos0[model.jnt_qposadr[j1]]),
                        x0=float(model.qpos0[model.jnt_qposadr[j2]]) if j2 >= 0 else 0.0,
                        poly=tuple(float(v) for v in data[:5]))
    t1, t2 = int(model.eq_obj1id[i]), int(model.eq_obj2id[i])
    coef1 = _fixed_tendon(model, t1)
    x = _fixed_tendon(model, t2) if t2 >= 0 else None
    if coef1 is None or (t2 >= 0 and x is None):
        raise ModelError(f"equality {name!r} couples a spatial tendon; accepted: fixed tendons (joint wraps)")
    return Equality(name=name, kind="tendon", y=coef1, x=x, y0=float(model.tendon_length0[t1]),
                    x0=float(model.tendon_length0[t2]) if t2 >= 0 else 0.0, poly=tuple(float(v) for v in data[:5]))


def _actuator(model: mujoco.MjModel, a: int, ctrl: float) -> Actuator:
    if model.actuator_ctrllimited[a] and not _disabled(model, _DSBL.mjDSBL_CLAMPCTRL):
        lo, hi = model.actuator_ctrlrange[a]
        ctrl = min(max(ctrl, float(lo)), float(hi))
    gain = model.actuator_gainprm[a, :3] if int(model.actuator_gaintype[a]) == int(mujoco.mjtGain.mjGAIN_AFFINE) \
        else np.array([model.actuator_gainprm[a, 0], 0.0, 0.0])
    bias = model.actuator_biasprm[a, :3] if int(model.actuator_biastype[a]) == int(mujoco.mjtBias.mjBIAS_AFFINE) \
        else np.zeros(3)
    forcerange = (float(model.actuator_forcerange[a, 0]), float(model.actuator_forcerange[a, 1])) \
        if model.actuator_forcelimited[a] else None
    moment = _moment(model, a)
    assert moment is not None  # the actuators read are those with a linear transmission (_actuator_gap)
    return Actuator(name=model.actuator(a).name or f"actuator{a}", moment=moment,
                    gain=(float(gain[0]), float(gain[1]), float(gain[2])),
                    bias=(float(bias[0]), float(bias[1]), float(bias[2])), ctrl=ctrl, forcerange=forcerange)


@dataclass(frozen=True)
class TreeEdit:
    """A tree case's edit of its model (picklable, for workers): :func:`prepare`, then :func:`isolate` where
    ``isolating``, then each nonzero control ``ctrl`` (by actuator, already clamped to its range) baked into its
    actuator's affine bias — (g₀ + g₁ l + g₂ l̇) c + b₀ + b₁ l + b₂ l̇ is the bias b + c g at ctrl 0 — so that the
    engine, whose runs keep ctrl at 0, and the reference read one and the same model."""

    isolating: bool = False
    ctrl: tuple[float, ...] = ()

    def __call__(self, spec: mujoco.MjSpec) -> None:
        prepare(spec)
        if self.isolating:
            isolate(spec)
        for actuator, c in zip(spec.actuators, self.ctrl, strict=False):
            if not c:
                continue
            gain = np.array(actuator.gainprm[:3], dtype=float)
            if actuator.gaintype != mujoco.mjtGain.mjGAIN_AFFINE:
                gain[1:] = 0.0
            bias = np.array(actuator.biasprm[:3], dtype=float) \
                if actuator.biastype == mujoco.mjtBias.mjBIAS_AFFINE else np.zeros(3)
            params = np.array(actuator.biasprm, dtype=float)
            params[:3] = bias + c * gain
            actuator.biastype = mujoco.mjtBias.mjBIAS_AFFINE
            actuator.biasprm = params


# ---- a tree case's system: what a hand-derived system module gives, for any model --------------------------
@dataclass(frozen=True)
class TreeSystem:
    """The reference side of a case whose system is its model's tree: charts fixed at the start's
    orientations (so every variant of the model is read in the same coordinates) and the control."""

    charts: tuple[tuple[int, tuple[float, ...]], ...] = ()
    ctrl: tuple[float, ...] = ()
    uncovered: tuple[tuple[str, str], ...] = ()
    horizon_note: str = ""
    horizon_seconds: float = 0.0
    source: str | None = None

    @property
    def edit(self) -> Callable[[mujoco.MjSpec], None]:
        """What every compile of the model gets first: :func:`prepare`, :func:`isolate` where the model has forces
        the tree reference does not model, and the controls baked into the actuators' bias (:class:`TreeEdit`)."""
        return TreeEdit(isolating=bool(self.uncovered), ctrl=self.ctrl)

    @cached_property
    def _chart(self) -> dict[int, np.ndarray]:
        return {j: np.array(q) for j, q in self.charts}

    def tree(self, model: mujoco.MjModel) -> Tree:
        """The tree the reference is read from: ``model``'s own, or, where ``source`` names another file, that
        file's (the engine then runs ``model``: how a fault made on the engine's side alone is injected). The
        controls are in the model's actuator bias (:class:`TreeEdit`), read at ctrl 0."""
        if self.source is not None:
            model = _compiled_source(self.source, self.edit)
        return read_tree(model, chart=self._chart)

    def dynamics(self, model: mujoco.MjModel) -> TreeDynamics:
        return TreeDynamics.of(self.tree(model))

    def params_from_model(self, model: mujoco.MjModel) -> dict[str, float]:
        return self.tree(model).params()

    def scales(self, model: mujoco.MjModel) -> Scales:
        return tree_scales(self.tree(model))


@functools.cache
def _compiled_source(path: str, edit: Callable[[mujoco.MjSpec], None]) -> mujoco.MjModel:
    spec = mujoco.MjSpec.from_file(path)
    edit(spec)
    return spec.compile()


def tree_scales(tree: Tree, *, excursion: float = 0.0) -> Scales:
    """The scales of a tree: its total mass moving over its size (the largest distance of a point from
    the first body's frame at the reference configuration; at least the bodies' mean size, MuJoCo's
    ``stat.meansize``, where that layout gives none, as for a lone point mass at its frame's origin; and at least
    ``excursion``, the farthest a point moves in the motion judged) under gravity (9.81 m/s² where gravity is off,
    to keep a scale)."""
    dyn = TreeDynamics.of(tree)
    q = np.zeros(tree.n)
    coms = dyn.body_coms(q)
    pts = np.concatenate([coms, dyn.points(q)], axis=0) if tree.points else coms
    origin = tree.bodies[0].pos
    length = max(float(np.max(np.linalg.norm(pts - origin, axis=-1), initial=0.0)), tree.size, excursion, 1e-3)
    g = float(np.linalg.norm(tree.gravity)) or 9.81
    mass = max(sum(b.mass for b in tree.bodies), 1e-9)
    return Scales.gravity(mass=mass, g=g, length=length)


def start_state(model: mujoco.MjModel, qpos: np.ndarray, qvel: np.ndarray
                ) -> tuple[dict[str, float], dict[str, float]]:
    """The analytic (q0, q̇0) of MuJoCo's (qpos, qvel), in the charts centred at ``qpos`` (θ = 0 there)."""
    tree = read_tree(model, chart=charts(model, qpos))
    q0: dict[str, float] = {}
    qd0: dict[str, float] = {}
    for j, joint in enumerate(tree.joints):
        adr = int(model.jnt_qposadr[j])
        dof = int(model.jnt_dofadr[j])
        names = joint.coordinates
        if joint.kind in (HINGE, SLIDE):
            q0[names[0]], qd0[names[0]] = float(qpos[adr]), float(qvel[dof])
        elif joint.kind == BALL:
            for k in range(3):
                q0[names[k]], qd0[names[k]] = 0.0, float(qvel[dof + k])
        else:
            for k in range(3):
                q0[names[k]], qd0[names[k]] = float(qpos[adr + k]), float(qvel[dof + k])
                q0[names[3 + k]], qd0[names[3 + k]] = 0.0, float(qvel[dof + 3 + k])
    return q0, qd0


def motion(model: mujoco.MjModel, qpos: np.ndarray, qvel: np.ndarray, *, horizon: float,
           description: str) -> Motion:
    q0, qd0 = start_state(model, qpos, qvel)
    return Motion(description=description, q0=q0, qd0=qd0, horizon=horizon, tags=frozenset({"tree"}))



# ---- the clamps' switching instants ------------------------------------------------------------------------
SWITCH_SAMPLES = 2001
"""The samples over the horizon at which each clamp's argument is read to find where it crosses an end of its range
(a clamp that enters and leaves its range between two samples, within horizon/2000, is missed)."""
SWITCHED_ORDER = 3
"""The order an integrator keeps over a motion that crosses a clamp's switch. A clamp is continuous but its slope in
the state jumps, so q̈ is continuous across the switch and q⃛ jumps: the one step that straddles each switch makes a
local error O(h³) × the jump (its Taylor expansion breaks at the third derivative), whose coefficient depends on where
in the step the switch falls (not an expansion in h: Richardson does not remove it). A method of order p > 3 (RK4)
then errs at order 3; one of order ≤ 3 (Euler, implicit) keeps its own."""


def switches(dynamics: Any, state: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]], t_end: float
             ) -> tuple[tuple[str, float], ...]:
    """Where the reference motion crosses a clamp's switch: (clamp, instant) in time order, each instant located by
    bisection on the reference's dense output ``state`` to round-off, for ``dynamics`` with clamps (a tree's
    :attr:`~analytic.tree.TreeDynamics.clamp_ranges`; none for any other system)."""
    ranges = getattr(dynamics, "clamp_ranges", ())
    if not ranges:
        return ()
    lo = np.array([r[1] for r in ranges], dtype=float)
    hi = np.array([r[2] for r in ranges], dtype=float)

    def margins(t: np.ndarray) -> np.ndarray:  # (len(t), 2, clamps): past the low end, short of the high end
        args = dynamics.clamp_arguments(*state(t))
        return np.stack([args - lo, hi - args], axis=1)

    t = np.linspace(0.0, t_end, SWITCH_SAMPLES)
    g = margins(t)
    found = []
    for i, side, k in zip(*np.nonzero(np.signbit(g[:-1]) != np.signbit(g[1:])), strict=True):
        a, b = float(t[i]), float(t[i + 1])
        sign = bool(np.signbit(g[i, side, k]))
        for _ in range(60):  # to round-off in t
            mid = 0.5 * (a + b)
            if mid in (a, b):
                break
            if bool(np.signbit(margins(np.array([mid]))[0, side, k])) == sign:
                a = mid
            else:
                b = mid
        found.append((ranges[k][0], 0.5 * (a + b)))
    return tuple(sorted(found, key=lambda item: item[1]))


def switched_orders(orders: Mapping[str, int], crossed: tuple[tuple[str, float], ...]) -> dict[str, int]:
    """Each integrator's order over a motion that crosses the clamps' switches ``crossed``: its documented order,
    at most :data:`SWITCHED_ORDER` where any switch is crossed."""
    return {name: min(p, SWITCHED_ORDER) if crossed else p for name, p in orders.items()}


def switch_note(crossed: tuple[tuple[str, float], ...]) -> str:
    """What the budget says of a motion that crosses clamps' switches ('' where none)."""
    if not crossed:
        return ""
    first = ", ".join(f"{name} at t = {t:.6g} s" for name, t in crossed[:3])
    more = f" and {len(crossed) - 3} more" if len(crossed) > 3 else ""
    return (f"the motion crosses {len(crossed)} clamp switch(es) ({first}{more}; located on the reference): each "
            f"integrator is judged at its documented order, at most {SWITCHED_ORDER} (a step straddling a switch "
            f"errs O(h³)), and its integration estimate's own error measured from h/4")

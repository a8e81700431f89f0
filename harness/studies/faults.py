"""The changes a user makes to a case's model: legitimate settings, which must pass, and faults, which must fail.

Both are generic over the registry: each is a spec edit (or a run option) that
applies to any case whose model has what it changes, so a new case is covered
without code of its own. They are what the error budget is judged by
(``tests/test_budget_matrix.py``, through the command line a user runs) and
what the sensitivity study measures (:mod:`harness.studies.sensitivity`).

A **setting** changes how the physics is simulated, or the physics in a way
the reference reads back from the model (a parameter): the verdict must stay
PASS, with the figures' larger sizes shown in their budgets. A **fault**
changes the physics in a way the analytic system does not have — a
dissipation, an inertia, a constraint that is not the one modelled — and the
verdict must be FAIL. A change the reference reads back (a mass, a length,
gravity) cannot be a fault: it is a different, consistent model, and is
judged as one.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import mujoco
import numpy as np

from harness.cases import Case
from harness.engine.compat import set_damping, set_stiffness
from harness.engine.integrators import available_integrators
from harness.engine.models import compile_model
from harness.engine.variants import point_masses, scale_inertia

__all__ = ["COARSE", "FAULTS", "SETTINGS", "Change", "by_name"]

SpecEdit = Callable[[mujoco.MjSpec], None]
Kind = Literal["setting", "fault"]

DEFAULT_SOLREF = (0.02, 1.0)
DEFAULT_SOLIMP = (0.9, 0.95, 0.001, 0.5, 2.0)
"""MuJoCo's default solref and solimp (XMLreference.rst, "solref", "solimp")."""


@dataclass(frozen=True)
class Change:
    """One change of a case's model.

    Attributes:
        name: its id (``damping``, ``timestep×2``).
        kind: ``setting`` (must pass) or ``fault`` (must fail).
        description: what it does, with ``{size}`` where it takes one.
        unit: the unit of its size ('' where it has none).
        make: (case, shipped model, size) → the spec edit; None for a change that is only a run option.
        applies: (case, shipped model) → '' where the change applies, else why not.
        timestep: the factor on the model's timestep it runs at (a run option, ``--timestep``).
        sizes: for a fault, the size at the shipped settings and at the coarse setting (2 × timestep,
            MuJoCo's default softness) it must be caught at.
    """

    name: str
    kind: Kind
    description: str
    unit: str = ""
    make: Callable[[Case, mujoco.MjModel, float], SpecEdit] | None = None
    applies: Callable[[Case, mujoco.MjModel], str] = lambda case, model: ""
    timestep: float = 1.0
    sizes: tuple[float, float] = (math.nan, math.nan)

    def edit(self, case: Case, size: float = math.nan) -> SpecEdit | None:
        """The spec edit for ``case`` at ``size`` (None where the change is a run option only)."""
        return None if self.make is None else self.make(case, compile_model(case.mjcf), size)

    def reason_not(self, case: Case) -> str:
        """'' where the change applies to ``case``, else why not."""
        return self.applies(case, compile_model(case.mjcf))

    def describe(self, size: float = math.nan) -> str:
        return self.description.format(size=f"{size:g}{' ' + self.unit if self.unit else ''}")


# ---------------------------------------------------------------- helpers
def _moving_joints(spec: mujoco.MjSpec) -> list:
    """Every joint, free joints included: damping, friction loss or armature on a free joint is a drag,
    a dry friction or a fictitious inertia on a free-flying body (torque_free_body), as much a fault as
    on a hinge."""
    return list(spec.joints)


def _has(what: str) -> Callable[[Case, mujoco.MjModel], str]:
    tests = {
        "equality": lambda m: m.neq > 0 and any(int(t) == int(mujoco.mjtEq.mjEQ_JOINT) for t in m.eq_type),
        "pair": lambda m: m.npair > 0,
        "soft": lambda m: m.neq > 0 or m.npair > 0,
        "stiffness": lambda m: bool(np.any(m.jnt_stiffness > 0)),
        "gravity": lambda m: bool(np.any(m.opt.gravity != 0)),
        "hinge_or_slide": lambda m: bool(np.any((m.jnt_type == mujoco.mjtJoint.mjJNT_HINGE)
                                                | (m.jnt_type == mujoco.mjtJoint.mjJNT_SLIDE))),
    }
    why = {"equality": "no joint equality", "pair": "no contact pair", "soft": "no equality or contact pair",
           "stiffness": "no joint stiffness", "gravity": "no gravity",
           "hinge_or_slide": "no hinge or slide joint"}

    def applies(case: Case, model: mujoco.MjModel) -> str:
        return "" if tests[what](model) else why[what]
    return applies


def _point_mass_bodies(case: Case, model: mujoco.MjModel) -> tuple[str, ...]:
    """The point masses that can rotate (a hinge, ball or free joint on the body or an ancestor): extra
    rotational inertia on a point mass that only translates changes nothing."""
    rotating = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_BALL), int(mujoco.mjtJoint.mjJNT_FREE))

    def rotates(body: int) -> bool:
        while body > 0:
            start, count = int(model.body_jntadr[body]), int(model.body_jntnum[body])
            if any(int(model.jnt_type[j]) in rotating for j in range(start, start + count)):
                return True
            body = int(model.body_parentid[body])
        return False

    return tuple(b for b in point_masses(model, case.reference(model).scales.length) if rotates(model.body(b).id))


# ---------------------------------------------------------------- settings
def _integrator(name: str) -> Callable[[Case, mujoco.MjModel, float], SpecEdit]:
    def make(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
        def edit(spec: mujoco.MjSpec) -> None:
            spec.option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{name.upper()}")
        return edit
    return make


def _default_softness(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
    def edit(spec: mujoco.MjSpec) -> None:
        for element in (*spec.equalities, *spec.pairs):
            element.solref = list(DEFAULT_SOLREF)
            element.solimp = list(DEFAULT_SOLIMP)
    return edit


def _solver(name: str, tolerance: float | None = None) -> Callable[[Case, mujoco.MjModel, float], SpecEdit]:
    def make(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
        def edit(spec: mujoco.MjSpec) -> None:
            spec.option.solver = getattr(mujoco.mjtSolver, f"mjSOL_{name.upper()}")
            if tolerance is not None:
                spec.option.tolerance = tolerance
        return edit
    return make


def _option(name: str, value: object) -> Callable[[Case, mujoco.MjModel, float], SpecEdit]:
    """``<option name=value>``: one of the settings MuJoCo documents as changing how the constraints are solved
    (computation/index.rst, "Solver"; XMLreference.rst, "option"), not what they are."""
    def make(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
        def edit(spec: mujoco.MjSpec) -> None:
            setattr(spec.option, name, value)
        return edit
    return make


def _disable(flag: str) -> Callable[[Case, mujoco.MjModel, float], SpecEdit]:
    """``<flag NAME="disable">`` (XMLreference.rst, "option/flag")."""
    def make(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
        def edit(spec: mujoco.MjSpec) -> None:
            spec.option.disableflags |= int(getattr(mujoco.mjtDisableBit, f"mjDSBL_{flag}"))
        return edit
    return make


def _toggle_enabled(flag: str) -> Callable[[Case, mujoco.MjModel, float], SpecEdit]:
    """``<flag NAME=...>`` the other way from the model's (XMLreference.rst, "option/flag")."""
    def make(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
        def edit(spec: mujoco.MjSpec) -> None:
            spec.option.enableflags ^= int(getattr(mujoco.mjtEnableBit, f"mjENBL_{flag}"))
        return edit
    return make


def _flag_exists(name: str) -> Callable[[Case, mujoco.MjModel], str]:
    kind = mujoco.mjtEnableBit if name.startswith("mjENBL") else mujoco.mjtDisableBit

    def applies(case: Case, model: mujoco.MjModel) -> str:
        return "" if hasattr(kind, name) else f"no {name} in MuJoCo {mujoco.__version__}"
    return applies


def _island_toggled(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
    """Island discovery the other way: a disable flag since MuJoCo 3.3.6 (on by default there, its changelog), an
    enable flag before; how the constraint problem is split and solved, not what it is."""
    def edit(spec: mujoco.MjSpec) -> None:
        if hasattr(mujoco.mjtDisableBit, "mjDSBL_ISLAND"):
            spec.option.disableflags ^= int(mujoco.mjtDisableBit.mjDSBL_ISLAND)
        else:
            spec.option.enableflags ^= int(mujoco.mjtEnableBit.mjENBL_ISLAND)
    return edit


def _other_jacobian(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
    """The other layout of the constraint Jacobian (XMLreference.rst, "option/jacobian"): the same matrix stored
    another way, a numerical method only."""
    sparse = bool(mujoco.mj_isSparse(model))

    def edit(spec: mujoco.MjSpec) -> None:
        spec.option.jacobian = mujoco.mjtJacobian.mjJAC_DENSE if sparse else mujoco.mjtJacobian.mjJAC_SPARSE
    return edit


def _solreffriction(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
    """Each pair's friction rows at a solref of their own (XMLreference.rst, "pair/solreffriction"): how those
    rows are regularized, 2 × the shipped normal time constant."""
    def edit(spec: mujoco.MjSpec) -> None:
        for pair in spec.pairs:
            pair.solreffriction = [0.004, 1.0]
    return edit


def _refsafe_off(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
    """refsafe off (XMLreference.rst, "flag/refsafe"): solref's time constant no longer raised to 2h; at the
    model's own step (every case's stiff rows sit at 2h) nothing changes, above it the regularization would."""
    def edit(spec: mujoco.MjSpec) -> None:
        spec.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_REFSAFE)
    return edit


def _other_cone(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
    """The other friction cone (XMLreference.rst, "option/cone"): another approximation of one friction law,
    the same forces wherever the contact sticks inside the cone."""
    elliptic = int(model.opt.cone) == int(mujoco.mjtCone.mjCONE_ELLIPTIC)

    def edit(spec: mujoco.MjSpec) -> None:
        spec.option.cone = mujoco.mjtCone.mjCONE_PYRAMIDAL if elliptic else mujoco.mjtCone.mjCONE_ELLIPTIC
    return edit


def _impratio(factor: float) -> Callable[[Case, mujoco.MjModel, float], SpecEdit]:
    """``impratio`` × ``factor``: how stiff the friction rows are against the normal one (XMLreference.rst,
    "option/impratio"): how the contact is regularized, not the friction law."""
    def make(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
        def edit(spec: mujoco.MjSpec) -> None:
            spec.option.impratio = float(model.opt.impratio) * factor
        return edit
    return make


def _no_warmstart(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
    def edit(spec: mujoco.MjSpec) -> None:
        spec.option.disableflags = int(spec.option.disableflags) | int(mujoco.mjtDisableBit.mjDSBL_WARMSTART)
    return edit


def _masses(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
    """Every body's mass and rotational inertia × 2: the same system, twice as heavy."""
    def edit(spec: mujoco.MjSpec) -> None:
        for body in spec.bodies[1:]:
            body.mass = 2.0 * body.mass
            scale_inertia(body, 2.0)
    return edit


def _gravity(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
    def edit(spec: mujoco.MjSpec) -> None:
        g = np.asarray(spec.option.gravity, dtype=float)
        spec.option.gravity = g * (9.0 / float(np.linalg.norm(g)))
    return edit


LENGTH_FACTOR = 1.5


def _scale_polycoef(eq, joint_types: dict[str, int], k: float) -> None:
    """A joint equality q1 = c0 + c1 q2 (+ …) with every length × k: a slide's coordinate is a length,
    a hinge's an angle, so c0 scales with q1's kind and c1 with q1's over q2's."""
    slide = int(mujoco.mjtJoint.mjJNT_SLIDE)
    one = k if joint_types.get(eq.name1) == slide else 1.0
    two = k if eq.name2 and joint_types.get(eq.name2) == slide else 1.0
    data = [float(x) for x in eq.data]
    data[0] *= one
    for p in range(1, 5):
        data[p] *= one / two**p
    eq.data = data


def _lengths(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
    """Every length of the model × 1.5 (positions, sizes, slide coordinates, inertias ∝ L²): the same
    system, larger; the reference reads the lengths it needs back from the model."""
    k = LENGTH_FACTOR

    def edit(spec: mujoco.MjSpec) -> None:
        types = {j.name: int(j.type) for j in spec.joints}
        for body in spec.bodies[1:]:
            body.pos = np.asarray(body.pos) * k
            body.ipos = np.asarray(body.ipos) * k
            full = [float(x) for x in body.fullinertia]
            if np.isfinite(full[0]):
                body.fullinertia = [k * k * x for x in full]
            else:
                body.inertia = [k * k * float(x) for x in body.inertia]
        for frame in spec.frames:
            frame.pos = np.asarray(frame.pos) * k
        for geom in spec.geoms:
            geom.pos = np.asarray(geom.pos) * k
            geom.size = np.asarray(geom.size) * k
        for site in spec.sites:
            site.pos = np.asarray(site.pos) * k
        for joint in spec.joints:
            joint.pos = np.asarray(joint.pos) * k
            if joint.type == mujoco.mjtJoint.mjJNT_SLIDE:
                joint.ref = joint.ref * k
                joint.springref = joint.springref * k
                joint.range = np.asarray(joint.range) * k
        for eq in spec.equalities:
            if eq.type == mujoco.mjtEq.mjEQ_JOINT:
                _scale_polycoef(eq, types, k)
            elif eq.type == mujoco.mjtEq.mjEQ_CONNECT:
                data = [float(x) for x in eq.data]
                eq.data = [k * x for x in data[:6]] + data[6:]
        for pair in spec.pairs:
            pair.margin = pair.margin * k
    return edit


def _stiffness(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
    def edit(spec: mujoco.MjSpec) -> None:
        for joint in spec.joints:
            stiffness = float(np.atleast_1d(joint.stiffness)[0])
            if stiffness > 0:
                set_stiffness(joint, 2.0 * stiffness)
    return edit


def _slope(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
    """The frame ``slope`` tilted 10° less steeply (its euler angle about y)."""
    def edit(spec: mujoco.MjSpec) -> None:
        for frame in spec.frames:
            if frame.name == "slope":
                euler = np.asarray(frame.alt.euler, dtype=float)
                frame.alt.euler = euler - np.array([0.0, 10.0 if spec.compiler.degree else math.radians(10), 0.0])
    return edit


def _has_slope(case: Case, model: mujoco.MjModel) -> str:
    spec = mujoco.MjSpec.from_file(str(case.mjcf))
    return "" if any(f.name == "slope" for f in spec.frames) else "no frame 'slope'"


# ---------------------------------------------------------------- faults
def _damping(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
    def edit(spec: mujoco.MjSpec) -> None:
        for joint in _moving_joints(spec):
            set_damping(joint, size)
    return edit


def _armature(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
    def edit(spec: mujoco.MjSpec) -> None:
        for joint in _moving_joints(spec):
            joint.armature = size
    return edit


def _frictionloss(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
    def edit(spec: mujoco.MjSpec) -> None:
        for joint in _moving_joints(spec):
            joint.frictionloss = size
    return edit


def _inertia(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
    bodies = _point_mass_bodies(case, model)

    def edit(spec: mujoco.MjSpec) -> None:
        for name in bodies:
            body = spec.body(name)
            body.inertia = [float(x) + size for x in body.inertia]
    return edit


def _has_point_mass(case: Case, model: mujoco.MjModel) -> str:
    return "" if _point_mass_bodies(case, model) else "no point mass that rotates"


def _gravity_does_work(case: Case, model: mujoco.MjModel) -> str:
    """'' where gravity has a component along some joint's motion (qfrc_bias at rest ≠ 0), so that
    compensating it changes the dynamics."""
    data = mujoco.MjData(model)
    ref = case.reference(model)
    case.probe(ref.dynamics).binding.set_state(model, data, ref.q0(), 0.0 * ref.qd0())
    mujoco.mj_forward(model, data)
    return "" if np.any(np.abs(data.qfrc_bias) > 1e-12) else "gravity does no work along any joint"


def _equality(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
    """The last joint equality off by ``size`` (relative): its gain c1 where it couples two joints,
    else its offset c0 by ``size`` × the case's length. Only one: a system may read a parameter from an
    equality (the Atwood pulley's radius from ``string1``), and changing that one alone is a model of
    another size, not a fault."""
    length = case.reference(model).scales.length

    def edit(spec: mujoco.MjSpec) -> None:
        joints = [e for e in spec.equalities if e.type == mujoco.mjtEq.mjEQ_JOINT]
        eq = joints[-1]
        data = [float(x) for x in eq.data]
        if eq.name2:
            data[1] *= 1.0 + size
        else:
            data[0] += size * length
        eq.data = data
    return edit


def _axis_tilt(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
    """Every hinge and slide axis turned by ``size`` rad towards a direction perpendicular to it: a joint
    mounted out of true. The analytic system has the axes of the seed, so the joints' points move on other
    circles and lines (kinematics) and gravity acts on them otherwise (forcing)."""
    def edit(spec: mujoco.MjSpec) -> None:
        for joint in _moving_joints(spec):
            if joint.type not in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
                continue  # a ball joint has no axis
            axis = np.asarray(joint.axis, dtype=float)
            axis /= np.linalg.norm(axis)
            helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
            normal = np.cross(axis, helper)
            normal /= np.linalg.norm(normal)
            joint.axis = math.cos(size) * axis + math.sin(size) * normal
    return edit


def _equality_offset(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
    """Every joint equality's offset c0 moved by ``size`` × the case's length: MuJoCo holds its joints
    elsewhere than the constraint the reference starts on and keeps, so it pulls the state onto its own
    (violation) and moves otherwise from there."""
    length = case.reference(model).scales.length

    def edit(spec: mujoco.MjSpec) -> None:
        for eq in spec.equalities:
            if eq.type == mujoco.mjtEq.mjEQ_JOINT:
                eq.data = [float(eq.data[0]) + size * length, *(float(x) for x in eq.data[1:])]
    return edit


def _gravcomp(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
    def edit(spec: mujoco.MjSpec) -> None:
        for body in spec.bodies[1:]:
            body.gravcomp = size
    return edit


def _joint_limit(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
    """Every hinge and slide named like a coordinate that moves limited to 90 % of the extent its motion
    reaches, so each limit is hit. Every one, not one: a limit on a joint whose inverse weight at qpos0
    is a point mass's floor (a spherical pendulum's azimuth, hanging straight down) acts with
    R ∝ 1/floor, that is not at all."""
    ref = case.reference(model)
    t = np.linspace(0.0, case.horizon, 2001)
    q, _ = ref.solution.state(t)
    spans = {c: (float(np.min(q[:, i])), float(np.max(q[:, i]))) for i, c in enumerate(ref.dynamics.coordinates)}
    names = {model.joint(j).name for j in range(model.njnt)
             if int(model.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))}
    moving = {c: span for c, span in spans.items() if c in names and span[1] - span[0] > 1e-6}
    if not moving:
        raise ValueError(f"case {case.name!r}: no hinge or slide named like a coordinate moves")

    def edit(spec: mujoco.MjSpec) -> None:
        for name, (lo, hi) in moving.items():
            joint = spec.joint(name)
            joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
            unit = math.degrees(1.0) if joint.type == mujoco.mjtJoint.mjJNT_HINGE and spec.compiler.degree else 1.0
            joint.range = [unit * (lo - 1.0), unit * (lo + 0.9 * (hi - lo))]
    return edit


def _friction(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
    """Every contact pair's sliding friction × (1 − ``size``): the fault's size is the share of the
    friction removed, so that a larger size is a larger fault (a rolling hoop slides once what is left
    is below what rolling needs: μ ≥ v θ̇/g on the plane, tan α / 2 on the ramp)."""
    def edit(spec: mujoco.MjSpec) -> None:
        for pair in spec.pairs:
            mu = (1.0 - size) * float(pair.friction[0])
            pair.friction = [mu, mu, 0.0, 0.0, 0.0]
    return edit


WIND = 10.0
"""The speed (m/s, along x) of the ``wind`` fault's fluid: a breeze."""


def _fluid(option: str) -> Callable[[Case, mujoco.MjModel, float], SpecEdit]:
    """A fluid MuJoCo applies to every body (XMLreference.rst, "option"): ``density`` or ``viscosity`` at
    ``size``, still (a drag on the motion), or ``wind``: density ``size`` moving at :data:`WIND` along x (a
    push the motion does not cause). The analytic systems are in vacuum: any fluid force is a fault."""
    def make(case: Case, model: mujoco.MjModel, size: float) -> SpecEdit:
        def edit(spec: mujoco.MjSpec) -> None:
            if option == "wind":
                spec.option.density = size
                spec.option.wind = [WIND, 0.0, 0.0]
            else:
                setattr(spec.option, option, size)
        return edit
    return make


def _timestep(factor: float) -> Change:
    return Change(f"timestep×{factor:g}", "setting", f"the model's timestep × {factor:g}", timestep=factor)


SETTINGS: tuple[Change, ...] = (
    _timestep(0.25), _timestep(2.0), _timestep(4.0),
    *(Change(f"integrator={name}", "setting", f"the model's own integrator set to {name}", make=_integrator(name))
      for name in available_integrators()),
    Change("default-softness", "setting", "every equality and contact pair at MuJoCo's default solref "
           f"{DEFAULT_SOLREF} and solimp {DEFAULT_SOLIMP}", make=_default_softness, applies=_has("soft")),
    Change("solver=CG", "setting", "the CG solver", make=_solver("CG")),
    Change("solver=PGS", "setting", "the PGS solver", make=_solver("PGS")),
    Change("tolerance=1e-8", "setting", "the solver's tolerance 1e-8", make=_solver("Newton", 1e-8)),
    Change("noslip=10", "setting", "10 noslip iterations after the main solver", make=_option("noslip_iterations", 10)),
    Change("warmstart-off", "setting", "the solver not warm-started", make=_no_warmstart),
    Change("iterations=1000", "setting", "the solver's iteration cap 1000", make=_option("iterations", 1000)),
    Change("other-jacobian", "setting", "the other constraint Jacobian layout (sparse for dense, and back)",
           make=_other_jacobian),
    Change("ls_tolerance=1e-3", "setting", "the solver's line search stopped at tolerance 1e-3",
           make=_option("ls_tolerance", 1e-3)),
    Change("solreffriction", "setting", "the contact pairs' friction rows at their own solref (0.004 1)",
           make=_solreffriction, applies=_has("pair")),
    Change("island-toggled", "setting", "constraint island discovery the other way (on for off, and back)",
           make=_island_toggled),
    Change("diagexact-toggled", "setting", "the regularizer from A's exact diagonal or its approximation, the "
           "other one", make=_toggle_enabled("DIAGEXACT"), applies=_flag_exists("mjENBL_DIAGEXACT")),
    Change("eulerdamp-off", "setting", "Euler without its implicit joint damping", make=_disable("EULERDAMP")),
    Change("refsafe-off", "setting", "the refsafe flag off: time constants as written at every timestep",
           make=_refsafe_off, applies=_has("soft")),
    Change("other-cone", "setting", "the other friction cone (pyramidal for elliptic, and back)", make=_other_cone,
           applies=_has("pair")),
    Change("impratio×10", "setting", "the friction rows' impedance ratio × 10 (impratio)", make=_impratio(10.0),
           applies=_has("pair")),
    Change("masses×2", "setting", "every body twice as heavy (mass and inertia)", make=_masses),
    Change("lengths×1.5", "setting", f"every length × {LENGTH_FACTOR:g}", make=_lengths),
    Change("gravity=9.0", "setting", "gravity 9.0 m/s² instead of 9.81", make=_gravity, applies=_has("gravity")),
    Change("stiffness×2", "setting", "every joint stiffness × 2", make=_stiffness, applies=_has("stiffness")),
    Change("slope-10°", "setting", "the slope 10° less steep", make=_slope, applies=_has_slope),
)

FAULTS: tuple[Change, ...] = (
    Change("damping", "fault", "joint damping {size} on every joint", "SI", make=_damping, sizes=(1e-3, 1e-2)),
    Change("frictionloss", "fault", "joint frictionloss {size} on every joint", "SI", make=_frictionloss,
           sizes=(1e-3, 1e-2)),
    Change("armature", "fault", "joint armature {size} on every joint", "SI", make=_armature, sizes=(1e-3, 1e-2)),
    Change("point-mass-inertia", "fault", "rotational inertia {size} added to every point mass", "kg m²",
           make=_inertia, applies=_has_point_mass, sizes=(1e-3, 1e-2)),
    Change("equality-coefficient", "fault", "the last joint equality's coefficient off by {size} (relative)",
           make=_equality, applies=_has("equality"), sizes=(5e-3, 1e-2)),
    Change("axis-tilt", "fault", "every hinge and slide axis tilted by {size}", "rad", make=_axis_tilt,
           applies=_has("hinge_or_slide"), sizes=(1e-3, 1e-2)),
    Change("equality-offset", "fault", "every joint equality's offset moved by {size} of the case's length",
           make=_equality_offset, applies=_has("equality"), sizes=(1e-3, 1e-2)),
    Change("gravcomp", "fault", "gravity compensation {size} on every body", make=_gravcomp,
           applies=_gravity_does_work, sizes=(1e-2, 1e-2)),
    Change("joint-limit", "fault", "joint limits the motion reaches", make=_joint_limit,
           applies=_has("hinge_or_slide"), sizes=(1.0, 1.0)),
    Change("drag", "fault", "a fluid of density {size} (still: drag)", "kg/m³", make=_fluid("density"),
           sizes=(10.0, 10.0)),
    Change("viscosity", "fault", "a fluid of viscosity {size} (still)", "Pa s", make=_fluid("viscosity"),
           sizes=(1e-5, 1e-5)),
    Change("wind", "fault", f"a {WIND:g} m/s wind along x, of density {{size}}", "kg/m³", make=_fluid("wind"),
           sizes=(10.0, 10.0)),
    Change("low-friction", "fault", "contact friction less {size} of it (relative), too little to roll",
           make=_friction, applies=_has("pair"), sizes=(0.99, 0.99)),
)

COARSE = Change("coarse", "setting", "2 × the timestep and MuJoCo's default softness", make=_default_softness,
                timestep=2.0)
"""The coarse setting faults are judged at too (with their second size)."""


def by_name(name: str) -> Change:
    for change in (*SETTINGS, *FAULTS, COARSE):
        if change.name == name:
            return change
    raise ValueError(f"unknown change {name!r}; known: {', '.join(c.name for c in (*SETTINGS, *FAULTS))}")



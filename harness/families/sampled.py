"""The sampled states: MuJoCo evaluated at states on the constraint manifold, no time integration, and the
budget of every figure compared there.

States are taken on the constraint manifold: along the reference, each also with its velocity rescaled
(which keeps J q̇ = 0 for homogeneous rows), so both slow and fast states are covered
(:func:`sample_states`). At each the engine's dynamics come from one batched ``forward_many``
(:meth:`harness.engine.backends.Backend.forward_many`) and are written into the C engine's ``MjData`` at the
same state; the C engine supplies only the geometry, in float64 (point positions, the Jacobians J and J̇,
site frames, an equality's ``efc_J``: kinematics). So on MJX or Warp every figure but the kinematics is that
backend's number; on the C backend nothing is carried and every number is ``mj_forward``'s. What is recorded
there (:class:`Sample`) — mass matrix, forcing, qacc, the generalized constraint force, point positions and
accelerations, kinetic energy, each equality's ``efc_force``, the reaction sensors — is compared with the
analytic side by the families that compare at states (:mod:`harness.families.instant`,
:mod:`harness.families.reactions`), each its own figures.

The budget. Nothing is integrated, so no integration error enters; two settings of the model still move
the figures (:mod:`harness.engine.variants`): the constraints' impedance and the point masses' inertia
floors. The same states are evaluated on the model as it is (A), with every ε = 1 − d × s (C: s = 1/2, or
2 at the stiffest ε; :func:`~harness.engine.variants.softness_factor`) and with the floors doubled (D), and
state by state

- softness = A − (the levels A, C (and C₂, ε × s²; or the near-rigid 2fε and fε) extrapolated to ε → 0, as
  the runs' budget does, :mod:`harness.families.runs`): at a consistent state (f = 0, J q̇ = 0) a soft
  equality's force is −(A + R)⁻¹Rλ off the rigid one and its acceleration follows, with R = (1 − d)/d · Â
  (computation/index.rst, "Soft constraints"): linear in 1 − d up to relative terms O(1 − d);
- floors = D − A: linear in the inertia;
- ideal = A − softness − floors,

each reduced as the figure is (each part's evaluations, estimate and tolerance are its module's in
:mod:`harness.budget`: :func:`evaluate` has each part make its own and hands them back under its name, the
registry's parts iterated by :func:`budgets`). The tolerances: 1/4 of the softness part (the O(1 − d) terms for
1 − d up to 1/4), 1/10 of the floors', float round-off (:data:`ROUNDOFF` × the quantity's size: the analytic side is a
closed-form evaluation and one KKT solve, MuJoCo's a forward pass) and the constraint solver's tolerance
(:data:`~harness.budget.convergence.SOLVER` × tolerance × size), both × the noise gain of the extrapolation (Σ|w| of
the evaluations' weights).

On a float32 backend (MJX, MuJoCo Warp) the round-off part is measured instead of assumed: the backend also
evaluates the same states on :data:`~harness.budget.roundoff.PERTURBED_RUNS` round-off copies of the model
(masses an ulp or two away: the same motion, every rounding different,
:func:`harness.engine.variants.roundoff_copy`), and the round-off tolerance is
:data:`~harness.budget.roundoff.PERTURBED_FACTOR` × the largest difference between a copy's figure and the figure
(× the same noise gain): the basis is :data:`~harness.budget.roundoff.PERTURBED_FACTOR`'s. To it is added what no
copy moves: the model's constants and the state held in float32 (each off by up to ½ε relative; a
state-independent figure such as the Atwood machine's forcing (m₁ − m₂)g shows the same shift in every copy,
and a coordinate held by a soft equality, off by half an ulp, draws the constraint's force k ½ε L), measured
as the figure's shift on the C engine in float64 when both are rounded
(:func:`harness.engine.variants.represented_model`), and each number's own reading,
:data:`~harness.budget.roundoff.READ_ULPS` × ε × its size. A figure with no copies (``instant.kinematics``: the C
engine's float64 geometry on every backend) and every figure on a float64 backend keep :data:`ROUNDOFF`.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import cast

import mujoco
import numpy as np

from analytic.dynamics import Constrained, Dynamics
from analytic.solvers import project
from harness.budget import registry
from harness.budget.convergence import SOLVER
from harness.budget.inputs import States
from harness.budget.part import Evaluating
from harness.budget.roundoff import PERTURBED_FACTOR, PERTURBED_RUNS, READ_ULPS
from harness.core.budget import Budget
from harness.core.deviation import Deviation
from harness.core.figures import FigureName
from harness.engine import variants as V
from harness.engine.backends import Backend, Forward, computes_reactions
from harness.engine.backends.completion import completed_forward
from harness.engine.bindings import velocity_map
from harness.engine.compat import full_mass_matrix, jac_dot
from harness.engine.constraints import equality_block, equality_jacobian, equality_rows
from harness.engine.points import point_jacobian, point_source
from harness.engine.probe import Probe
from harness.engine.sensors import Recorder
from harness.reference.solutions import Reference

__all__ = ["DEFAULT_SAMPLES", "ROUNDOFF", "Compare", "Evaluation", "Sample", "at_states", "budgets", "evaluate",
           "has_contacts", "mujoco_states", "point_acceleration", "pull_back", "sample_states"]

DEFAULT_SAMPLES = 24
STATE_TOLERANCE = 1e-14


def sample_states(ref: Reference, count: int = DEFAULT_SAMPLES, seed: int = 0
                  ) -> tuple[np.ndarray, np.ndarray]:
    """``count`` states (q, q̇) on the manifold, deterministic for a seed: along the reference, each
    also with its velocity rescaled, every one projected onto the constraints to round-off
    (:func:`analytic.solvers.project`). The reference's own residual (within
    :data:`harness.families.reference.RESIDUAL_LIMIT`, far above round-off) would otherwise meet MuJoCo's
    constraint feedback −b v − k r, which no softness setting removes."""
    if count < 2:
        raise ValueError(f"count must be >= 2, got {count}")
    # the same states for every evaluation of a run (the model as it is, each variant, the engine findings): made
    # once per solution, count and seed, each caller given its own copy
    key = (id(ref.solution), count, seed)
    found = _SAMPLED.get(key)
    if found is not None and found[0]() is ref.solution:
        return found[1].copy(), found[2].copy()
    q, qd = _sampled(ref, count, seed)
    if len(_SAMPLED) >= _SAMPLED_MAX:
        del _SAMPLED[next(iter(_SAMPLED))]
    _SAMPLED[key] = (weakref.ref(ref.solution), q, qd)
    return q.copy(), qd.copy()


_SAMPLED: dict[tuple[int, int, int], tuple[weakref.ref, np.ndarray, np.ndarray]] = {}
_SAMPLED_MAX = 64


def _sampled(ref: Reference, count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`sample_states`, made."""
    half = count // 2
    t = np.linspace(0.0, ref.solution.t_end, half)
    q, qd = ref.solution.state(t)
    scale = np.random.default_rng(seed).uniform(-2.0, 2.0, size=(count - half, 1))
    idx = np.arange(count - half) % half
    states = [project(ref.dynamics, qi, qdi, tol=STATE_TOLERANCE, polish=True)
              for qi, qdi in zip(np.vstack([q, q[idx]]), np.vstack([qd, qd[idx] * scale]), strict=True)]
    return np.array([s[0] for s in states]), np.array([s[1] for s in states])


def point_acceleration(model: mujoco.MjModel, data: mujoco.MjData, point: str) -> np.ndarray:
    """World linear acceleration of a named point (a site, or a body's centre of mass:
    :func:`harness.engine.points.point_source`) after ``mj_forward``: J qacc + J̇ qvel, with J from
    ``mj_jac`` and J̇ from ``mj_jacDot`` at the point's position on its body."""
    source = point_source(model, point)
    jacp = point_jacobian(model, data, source)
    # mj_jacDot, corrected on MuJoCo 3.3.0 (a finding)
    jacp_dot = jac_dot(model, data, source.position(data), source.body)
    return jacp @ data.qacc + jacp_dot @ data.qvel


def pull_back(dof: np.ndarray, mass: np.ndarray, qacc: np.ndarray) -> np.ndarray:
    """The analytic q̈ that MuJoCo's ``qacc`` (less Ḃ q̇) stands for, with qvel = ``dof`` q̇.

    Where nv = n, ``dof`` is invertible and q̈ solves dof q̈ = qacc (least squares, exact to round-off).
    Where nv > n, MuJoCo has degrees of freedom the analytic system does not (a ball joint's twist
    about a point mass's rod): the part of qacc outside the range of ``dof`` is their motion, set by
    the floor inertia the analytic system does not have, and not an error. The pull-back is then the
    one the equations of motion make, weighted by the kinetic energy, q̈ = (BᵀM B)⁻¹ BᵀM qacc (the
    d'Alembert projection: Bᵀ(M_mj qacc − f) = 0 on the analytic coordinates), which lets no
    M-orthogonal motion of the extra dofs in. An unweighted least squares would let the twist's
    acceleration, O(|q̈|) on the spherical pendulum's ball joint, leak into q̈_φ.
    """
    if dof.shape[0] == dof.shape[1]:
        return np.linalg.lstsq(dof, qacc, rcond=None)[0]
    weighted = dof.T @ mass
    return np.linalg.solve(weighted @ dof, weighted @ qacc)


def mujoco_states(model: mujoco.MjModel, probe: Probe, q: np.ndarray, qd: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """MuJoCo's coordinates (qpos, qvel) of the analytic states (rows of ``q``, ``qd``), written by the case's
    binding: what a backend's ``forward_many`` takes."""
    data = mujoco.MjData(model)
    qpos, qvel = np.empty((len(q), model.nq)), np.empty((len(q), model.nv))
    for i in range(len(q)):
        mujoco.mj_resetData(model, data)
        probe.binding.set_state(model, data, q[i], qd[i])
        qpos[i], qvel[i] = data.qpos, data.qvel
    return qpos, qvel


@dataclass
class Sample:
    """MuJoCo's side at the sampled states (the engine's dynamics carried into the C engine's geometry) beside
    the analytic side, evaluated once and shared by every family that compares here.

    Attributes:
        model, probe, reference: what the figures are compared on (the model evaluated, or for its copy with
            its constants rounded to float32, the model's own), and against what.
        q, qd: the sampled analytic states (a row each).
        backend: the engine's name.
        got: MuJoCo's side per state: ``mass``, ``forcing``, ``qacc``, ``gen`` (through the binding's dof map,
            where it has one), ``pts``, ``acc`` (the named points' positions and world accelerations), ``kinetic``.
        force: each named equality's ``efc_force`` rows per state (in the analytic multiplier's sign).
        block_gen: each equality of several rows: Dᵀ J_mjᵀ efc_force per state.
        reactions: the reaction sensors' recording (:class:`harness.engine.sensors.Recorder`).
        unavailable: why the reactions cannot be had from the backend's arrays at these states, or "".
        dynamics: the analytic dynamics evaluated (the reference's, or for round-off copies a memo of them).
    """

    model: mujoco.MjModel
    probe: Probe
    reference: Reference
    q: np.ndarray
    qd: np.ndarray
    backend: str
    got: dict[str, list]
    force: dict[str, list]
    block_gen: dict[str, list]
    reactions: Recorder
    unavailable: str
    dynamics: Dynamics

    @cached_property
    def solved(self) -> Constrained:
        """The analytic KKT solution at the states: q̈, λ, and which multipliers are unique."""
        return self.dynamics.constrained(self.q, self.qd)

    @property
    def accelerations(self) -> tuple[np.ndarray, np.ndarray]:
        """The analytic q̈ and λ at the states."""
        return self.solved.qdd, self.solved.lam

    @property
    def coordinates(self) -> bool:
        """Whether the binding maps MuJoCo's velocities onto the analytic ones (a dof matrix or a velocity map):
        then M, F, q̈ and the generalized constraint force are compared too."""
        return self.probe.binding.dof_matrix(self.model) is not None or self.mapped

    @property
    def mapped(self) -> bool:
        """Whether the binding's map is state-dependent (:func:`harness.engine.bindings.velocity_map`)."""
        return getattr(self.probe.binding, "velocity_map", None) is not None


Compare = Callable[[Sample], tuple[list[Deviation], dict[str, str], dict[str, str]]]
"""A family's comparison at the sampled states: its figures as deviations (a row per state), the figures it cannot
measure on this backend (n/a, with why) and those the model makes unmeasurable (failing, with why)."""


@dataclass(frozen=True)
class Evaluation:
    """Every figure compared at the sampled states, on the bench's engine, with its budget.

    Attributes:
        deviations: one per figure, a row per sampled state.
        budgets: each figure's error budget, by name.
        perturbed: on a float32 backend, the same figures from the backend's forward of each of the
            :data:`~harness.budget.roundoff.PERTURBED_RUNS` round-off copies of the model (masses an ulp or two away,
            :func:`harness.engine.variants.roundoff_copy`: the same motion, every rounding different) at the same
            states: their spread is the round-off of the backend's arithmetic. Figures read from the C engine's
            float64 geometry alone (``instant.kinematics``) are left out. On the C backend, the float64 copies'
            where the model has constraints.
        represented: on a float32 backend, each figure's shift when the model's constants and the state are
            held in float32 (:func:`harness.engine.variants.represented_model`, the C engine in float64 at the
            states rounded to float32), reduced as the figure is: what no copy moves; empty on a float64 backend.
        unavailable: figures the backend's arrays cannot give at these states, or that are not compared (an
            accelerometer at a site the analytic system has no acceleration for), each with the one-line reason.
        failing: figures that cannot be measured because of what the model does (a body in a sensor's subtree
            loaded from outside its joints), each with the reason its check fails with.
        completed: on a float32 backend, the figures with the backend's stopped constraint solve completed in
            float64 at every state where the stop is its precision's (:mod:`harness.engine.backends.completion`):
            the difference from ``deviations`` is what the solver's stop left in each figure; None on float64.
        completion_note: where the completion was not applied, one line; else "".
    """

    deviations: list[Deviation]
    budgets: Mapping[FigureName, Budget] = field(default_factory=dict)
    perturbed: tuple[list[Deviation], ...] = ()
    represented: dict[FigureName, float] = field(default_factory=dict)
    unavailable: dict[str, str] = field(default_factory=dict)
    failing: dict[str, str] = field(default_factory=dict)
    completed: list[Deviation] | None = None
    completion_note: str = ""


def _rows_of(model: mujoco.MjModel, data: mujoco.MjData, probe: Probe) -> bool:
    """Whether every constraint row of the C engine at this state is a row of an equality the probe names
    (then the backend's rows map one to one onto C's: :attr:`~harness.engine.backends.Forward.equality`)."""
    named = {mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_EQUALITY, c) for c in probe.constraints}
    types_, ids = data.efc_type[:data.nefc], data.efc_id[:data.nefc]
    return bool(np.all(types_ == mujoco.mjtConstraint.mjCNSTR_EQUALITY)) and set(ids.tolist()) <= named


def _carry(model: mujoco.MjModel, data: mujoco.MjData, probe: Probe, fwd: Forward, k: int) -> str:
    """Write the backend's dynamics at state ``k`` into ``data`` (the C engine's MjData after ``mj_forward``
    at the same state, whose kinematics stay: geometry in float64): qacc, the forces, the named equalities'
    ``efc_force`` rows, and the reaction sensors and ``cfrc_int``/``cfrc_ext`` — the backend's own, or, where it
    does not compute them, the C engine's ``mj_rnePostConstraint`` and ``mj_sensorAcc`` run on the backend's
    qacc and constraint forces (exact where C's constraint rows are the named equalities' alone). Returns why
    the reactions cannot be had from the backend's arrays at this state, or ""."""
    data.qacc[:] = fwd.qacc[k]
    data.qfrc_bias[:] = fwd.qfrc_bias[k]
    data.qfrc_passive[:] = fwd.qfrc_passive[k]
    data.qfrc_actuator[:] = fwd.actuator(k)
    data.qfrc_constraint[:] = fwd.qfrc_constraint[k]
    for c in probe.constraints:
        data.efc_force[equality_rows(model, data, c)] = fwd.equality[c][k]
    if not computes_reactions(model):
        return ""
    if fwd.sensordata is not None and fwd.cfrc_int is not None and fwd.cfrc_ext is not None:
        data.sensordata[:] = fwd.sensordata[k]
        data.cfrc_int[:] = fwd.cfrc_int[k]
        data.cfrc_ext[:] = fwd.cfrc_ext[k]
        return ""
    if not _rows_of(model, data, probe):
        return ("the backend does not compute the reaction sensors and cfrc_int here, and the C engine's "
                "constraint rows include contact or limit rows, whose order in the backend's arrays differs: "
                "they cannot be computed from the backend's constraint forces")
    mujoco.mj_rnePostConstraint(model, data)  # cacc, cfrc_int, cfrc_ext from the backend's qacc and efc_force
    mujoco.mj_sensorAcc(model, data)  # the acceleration-stage sensors from them (flg_rnepost is already set)
    return ""


def _measure(model: mujoco.MjModel, probe: Probe, ref: Reference, q: np.ndarray, qd: np.ndarray, *,
             states: tuple[np.ndarray, np.ndarray] | None, fwd: Forward | None, offset: int, backend: str,
             dynamics: Dynamics | None = None, compared_on: mujoco.MjModel | None = None) -> Sample:
    """The engine's side at each state: the C engine's ``mj_forward`` at (q, q̇) (through the binding), or at
    MuJoCo's coordinates ``states`` (qpos, qvel), carrying the backend's dynamics ``fwd`` (rows ``offset``..)
    where the backend is not C; beside the analytic side, ``dynamics`` (default: the reference's), compared on
    ``compared_on`` (default: ``model``; the model's own where ``model`` is its copy with constants rounded)."""
    dyn = ref.dynamics
    constant = probe.binding.dof_matrix(model) is not None
    mapped = getattr(probe.binding, "velocity_map", None) is not None
    coordinates = constant or mapped
    data = mujoco.MjData(model)
    got: dict[str, list] = {k: [] for k in ("mass", "forcing", "qacc", "gen", "pts", "acc", "kinetic")}
    got_lam: dict[str, list] = {c: [] for c in probe.constraints}
    got_block_gen: dict[str, list] = {c: [] for c in probe.constraints}
    reactions = Recorder(model, dyn, probe.loads)
    unavailable = ""
    for i in range(len(q)):
        mujoco.mj_resetData(model, data)
        if states is None:
            probe.binding.set_state(model, data, q[i], qd[i])
        else:
            data.qpos[:], data.qvel[:] = states[0][i], states[1][i]
        mujoco.mj_forward(model, data)
        if fwd is None:
            full = full_mass_matrix(model, data)
        else:
            unavailable = unavailable or _carry(model, data, probe, fwd, offset + i)
            full = fwd.mass[offset + i]
        got["kinetic"].append(0.5 * data.qvel @ full @ data.qvel)
        got["pts"].append([point_source(model, p).position(data).copy() for p in dyn.point_names])
        got["acc"].append([point_acceleration(model, data, p) for p in dyn.point_names])
        if reactions and not unavailable:
            reactions.record(model, data)
        if coordinates:
            mapping = velocity_map(probe.binding, model, q[i], qd[i])
            assert mapping is not None  # coordinates: the binding has a dof matrix or a velocity map
            dof, rate = mapping
            qacc = data.qacc if rate is None else data.qacc - rate  # B q̈ = qacc − Ḃ q̇
            smooth = data.qfrc_passive + data.qfrc_actuator - data.qfrc_bias  # every force but the constraints'
            bias = smooth if rate is None else smooth - full @ rate
            got["mass"].append(dof.T @ full @ dof)
            got["forcing"].append(dof.T @ bias)
            got["qacc"].append(pull_back(dof, full, qacc))
            got["gen"].append(dof.T @ data.qfrc_constraint)
        for c in probe.constraints:
            force = equality_block(model, data, c)[0]
            got_lam[c].append(probe.sign(c) * force)
            if coordinates and force.size > 1:
                got_block_gen[c].append(dof.T @ (equality_jacobian(model, data, c).T @ force))
    return Sample(model=compared_on if compared_on is not None else model, probe=probe, reference=ref, q=q, qd=qd,
                  backend=backend, got=got, force=got_lam,
                  block_gen=got_block_gen, reactions=reactions, unavailable=unavailable,
                  dynamics=dyn if dynamics is None else dynamics)


def has_contacts(model: mujoco.MjModel) -> bool:
    """Whether ``model`` can make contacts: explicit pairs, or collision on with geoms that may collide."""
    off = int(mujoco.mjtDisableBit.mjDSBL_CONTACT) | int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    if model.opt.disableflags & off:
        return False
    return bool(model.npair) or bool(np.any((model.geom_contype != 0) | (model.geom_conaffinity != 0)))


def at_states(model: mujoco.MjModel, probe: Probe, ref: Reference, engine: Backend, compares: Sequence[Compare], *,
              count: int = DEFAULT_SAMPLES, perturbed: bool = False) -> Evaluation:
    """Every figure the families' ``compares`` make at :func:`sample_states` (in order), on ``engine``, without
    budgets.

    The dynamics are the engine's, from one batched ``forward_many`` at every sampled state: the mass matrix,
    the forcing qfrc_passive − qfrc_bias, qacc, the equalities' efc_force, qfrc_constraint, the kinetic energy
    ½ qvelᵀ M qvel with the engine's M, the point accelerations J qacc + J̇ qvel with the engine's qacc, and
    the reaction sensors and ``cfrc_int`` (the engine's own, or computed in float64 from its qacc and
    constraint forces where it does not compute them; not available, with the reason, where its rows cannot
    be mapped). The geometry is the C engine's in float64 at the same qpos (``mj_forward``).

    ``perturbed``: on a float32 engine, also the engine's forward of the model's round-off copies
    (:func:`harness.engine.variants.roundoff_copy`) at the same states (:attr:`Evaluation.perturbed`);
    on the C engine, the float64 copies' where the model has constraints (equalities, :func:`has_contacts`)."""
    probe.validate(model)
    compare = combined(compares)
    dyn = ref.dynamics
    q, qd = sample_states(ref, count)
    fwd, copies = None, None
    if engine.name != "c":
        qpos, qvel = mujoco_states(model, probe, q, qd)
        fwd = engine.forward_many(model, probe, np.asarray(qpos, float), np.asarray(qvel, float))
        if perturbed and engine.epsilon > float(np.finfo(np.float64).eps):
            copies = [engine.forward_many(V.roundoff_copy(model, epsilon=engine.epsilon, index=k), probe,
                                          np.asarray(qpos, float), np.asarray(qvel, float))
                      for k in range(1, PERTURBED_RUNS + 1)]
    measured = _measure(model, probe, ref, q, qd, states=None, fwd=fwd, offset=0, backend=engine.name)
    deviations, unavailable, failing = compare(measured)
    if perturbed and engine.name == "c" and (model.neq > 0 or has_contacts(model)):
        # float64 too: a constraint solve amplifies round-off by its conditioning (a contact's friction rows by
        # impratio; redundant rows, as slider_crank's, by 1/(1 − d)), which the assumed ROUNDOFF does not bound;
        # the copies measure it
        epsilon = float(np.finfo(np.float64).eps)
        c_copies = [V.roundoff_copy(model, epsilon=epsilon, index=k) for k in range(1, PERTURBED_RUNS + 1)]
        # the analytic side at the same states: evaluated for the first copy, reused after (a Dynamics by its methods)
        same = cast(Dynamics, _Reused(dyn))
        others = [[d for d in compare(_measure(copy, probe, ref, q, qd, states=None, fwd=None, offset=0, backend="c",
                                               dynamics=same))[0]
                   if d.name != FigureName.instant("kinematics")] for copy in c_copies]
        return Evaluation(deviations=deviations, perturbed=tuple(others), unavailable=unavailable, failing=failing)
    completed, completion_note = None, ""
    if fwd is not None and engine.epsilon > float(np.finfo(np.float64).eps):
        completion = completed_forward(model, fwd, engine.epsilon,
                                       lambda data, k: probe.binding.set_state(model, data, q[k], qd[k]))
        again = _measure(model, probe, ref, q, qd, states=None, fwd=completion.forward, offset=0,
                         backend=engine.name)
        completed = compare(again)[0]
        completion_note = completion.note()
    others, represented = [], {}
    if copies is not None:
        as_c = compare(_measure(model, probe, ref, q, qd, states=None, fwd=None, offset=0, backend="c"))[0]
        rounded = V.represented_model(model, np.float32)
        # the engine's side on the rounded model at the rounded states; the analytic side (and the gravity it
        # reads) the model's own at the exact states
        states = (qpos.astype(np.float32).astype(float), qvel.astype(np.float32).astype(float))
        in_float32 = compare(_measure(rounded, probe, ref, q, qd, states=states, fwd=None, offset=0, backend="c",
                                      compared_on=model))[0]
        represented = {a.name: a.magnitude(b.values - a.values) for a, b in zip(as_c, in_float32, strict=True)
                       if a.name != FigureName.instant("kinematics")}
        for again_fwd in copies:
            again = _measure(model, probe, ref, q, qd, states=None, fwd=again_fwd, offset=0, backend=engine.name)
            others.append([d for d in compare(again)[0] if d.name != FigureName.instant("kinematics")])
    return Evaluation(deviations=deviations, perturbed=tuple(others), represented=represented,
                      unavailable=unavailable, failing=failing, completed=completed,
                      completion_note=completion_note)


def combined(compares: Sequence[Compare]) -> Compare:
    """The families' comparisons as one: their figures in order, their n/a and failing figures merged."""
    def compare(sample: Sample) -> tuple[list[Deviation], dict[str, str], dict[str, str]]:
        deviations: list[Deviation] = []
        unavailable: dict[str, str] = {}
        failing: dict[str, str] = {}
        for one in compares:
            found, skipped, failed = one(sample)
            deviations += found
            unavailable |= skipped
            failing |= failed
        return deviations, unavailable, failing

    return compare


def evaluate(mut: V.ModelUnderTest, model: mujoco.MjModel, probe: Probe, ref: Reference, engine: Backend,
             compares: Sequence[Compare], *, integrator: str | None = None, conditioning: float = 1.0) -> Evaluation:
    """Every figure the families compare at the sampled states of ``model`` (compiled from ``mut`` with
    ``integrator``), with its budget: the same states evaluated on the variants — softer, heavier floors,
    wider margins, and with the constraints solved exactly where the model's own solver does not converge —,
    every evaluation on ``engine``, each made by its part (:attr:`harness.budget.part.Part.states`). On a float32
    engine the variants are taken completed too, so their differences are the settings', not where each stop fell.
    ``conditioning``: n · cond(M) of a model judged against its own tree, whose solved figures' round-off grows
    with it (:data:`CONDITIONED`)."""
    found = at_states(model, probe, ref, engine, compares, perturbed=True)
    variants = V.Variants.of(model, ref.scales.length, floors=mut.floors)
    exact = V.exact_solver(model)

    def at(variant: V.SpecEdit | None) -> list[Deviation]:
        got = at_states(mut.compile(integrator=integrator, variant=V.compose(exact, variant)), probe, ref, engine,
                        compares)
        return got.completed if got.completed is not None else got.deviations

    # each part's own evaluations, handed back under its name (harness.budget.part.Part.states)
    evaluating = Evaluating(model=model, at=at, variants=variants, exact=exact, completed=found.completed)
    own = {p.name: made for p in registry.ALL if p.states is not None and (made := p.states(evaluating)) is not None}
    made = budgets(found.deviations, States(own=own, perturbed=found.perturbed, represented=found.represented),
                   conditioning=conditioning,
                   solver_tolerance=V.CONVERGED_TOLERANCE if exact is not None else variants.solver_tolerance,
                   notes=(*variants.notes, *((found.completion_note,) if found.completion_note else ())),
                   epsilon=engine.epsilon)
    return Evaluation(deviations=found.deviations, budgets=made, perturbed=found.perturbed,
                      represented=found.represented, unavailable=found.unavailable, failing=found.failing,
                      completed=found.completed, completion_note=found.completion_note)


class _Reused:
    """``dynamics`` whose methods, called again with the same arguments (the same array objects, held here so
    that their ids stay theirs), return their first result: the analytic side of the instantaneous figures
    at the sampled states is the same for every round-off copy of the model, and only MuJoCo's side differs.
    The results are shared, so a caller must not write into them (none does)."""

    def __init__(self, dynamics) -> None:
        self._dynamics = dynamics
        self._results: dict[tuple, tuple[tuple, object]] = {}

    def __getattr__(self, name: str):
        found = getattr(self._dynamics, name)
        if not callable(found):
            return found

        def reused(*args, **kwargs):
            key = (name, tuple(id(a) for a in args), tuple(sorted((k, id(v)) for k, v in kwargs.items())))
            if key not in self._results:
                self._results[key] = ((args, kwargs), found(*args, **kwargs))
            return self._results[key][1]

        return reused


# ----------------------------------------------------------------- the budget
ROUNDOFF = 1e4 * float(np.finfo(float).eps)
"""Round-off of one evaluation, relative to the quantity's size: 1e4 ε (~2e-12). Its basis is measured: the
largest at the shipped settings (kinetic energy, mass matrix, forcing), with a margin that covers an ill-conditioned
mass matrix (condition number up to 1e4): docs/findings/bases.md, ROUNDOFF."""


UNSOLVED = ("kinematics", "kinetic_energy", "mass_matrix", "forcing")
"""The instantaneous figures no linear solve enters (positions, M, F); every other one is M⁻¹ of something on both
sides (q̈, the point accelerations, the constraint forces, the reactions)."""
CONDITIONED = 32.0
"""A solve of M x = b errs by about n ε cond(M) relative (n the size), and both sides solve (the reference its KKT
system, MuJoCo its factorization): where CONDITIONED × n × cond(M) × ε (n · cond(M) is ``conditioning``) exceeds
:data:`ROUNDOFF`, it is the round-off tolerance of the solved figures. Its basis is measured: qacc's error on a
light link (dm_control's swimmer) in units of n cond(M) ε, × a margin (docs/findings/bases.md, CONDITIONED). Applied
to models judged against their own tree (their cond(M) is not known in advance); the shipped cases keep ROUNDOFF, with
which their limits and fault tests were measured (on some of them this bound would exceed ROUNDOFF: not adopted there
until their fault matrix is re-run with it)."""
FLOAT64 = float(np.finfo(float).eps)


def budgets(as_is: Sequence[Deviation], states: States | None = None, *, solver_tolerance: float = 0.0,
            notes: Sequence[str] = (), epsilon: float = float(np.finfo(np.float32).eps), conditioning: float = 1.0
            ) -> dict[FigureName, Budget]:
    """Every figure's budget from the model's deviations at the sampled states (A) and the variants evaluated at the
    same states, each part's own in ``states`` (:class:`~harness.budget.inputs.States`: by the part's name, as its
    module makes and reads them, with the round-off copies' figures); ``solver_tolerance``: the constraint solver's
    (0 without constraints); ``epsilon``: the machine epsilon of the backend's arithmetic; ``conditioning``: n ·
    cond(M) of a model judged against its own tree (:data:`CONDITIONED`). The noise gain of the extrapolation (Σ|w|
    of the evaluations' weights) is each part's :attr:`~harness.budget.part.Part.states_gain` in turn, from A's 1."""
    states = States() if states is None else states
    noise = 1.0
    for part in registry.ALL:
        if part.states_gain is not None and part.name in states.own:
            noise = part.states_gain(states.own[part.name], noise)
    copies: dict[FigureName, list[np.ndarray]] = {}
    for group in states.perturbed:
        for d in group:
            copies.setdefault(d.name, []).append(d.values)
    out = {}
    for dev in as_is:
        found = registry.at_states(states, dev)  # each part's estimate at the states
        parts = found.explained
        ideal = dev.values - sum(parts.values()) if parts else dev.values
        explained = {part: dev.magnitude(values) for part, values in parts.items()}
        # float64: noise × ROUNDOFF × size, in that order (the C backend's limits bit for bit as before)
        solved = dev.name.quantity not in UNSOLVED  # passes through M⁻¹: its round-off grows with cond(M)
        roundoff = noise * max(ROUNDOFF, CONDITIONED * conditioning * FLOAT64 if solved else 0.0) * dev.size
        if dev.name in copies:
            spread = noise * (PERTURBED_FACTOR * max(dev.magnitude(c - dev.values) for c in copies[dev.name])
                              + states.represented.get(dev.name, 0.0) + READ_ULPS * epsilon * dev.size)
            # float32: the copies' spread is the round-off; float64 (a constraint solve): the larger of the two
            roundoff = spread if epsilon > FLOAT64 else max(roundoff, spread)
        tolerance = {**registry.tolerances(found, explained, runs=False),
                     "roundoff": roundoff,
                     "convergence": noise * SOLVER * solver_tolerance * dev.size}
        out[dev.name] = Budget(measured=dev.magnitude(), explained=explained, unexplained=dev.magnitude(ideal),
                               tolerance=tolerance, notes=(*notes, *found.notes))
    return out


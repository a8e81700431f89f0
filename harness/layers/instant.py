"""Layer 2: instantaneous dynamics at sampled states, no time integration.

At each state the analytic M(q), F(q, q̇), q̈ and λ are compared with MuJoCo's
``mj_fullM``, ``qfrc_passive − qfrc_bias``, ``qacc`` and the equality's
``efc_force``. A fault shows up here before any trajectory is run, and the
figure that fails says where it is (inertia, forces, or the constraint).

Those are the active backend's (:func:`harness.engine.backends.active`): one
batched ``forward_many`` at every sampled state hands back its dynamics, which
are written into the C engine's ``MjData`` at the same state; the C engine
supplies only the geometry, in float64 (point positions, the Jacobians J and
J̇, site frames, an equality's ``efc_J``: kinematics, which
``instant.kinematics`` checks). So on MJX or Warp every figure below except
``instant.kinematics`` is that backend's number; on the C backend nothing is
carried and every number is ``mj_forward``'s, as it always was
(:func:`instant_evaluation`).

A constraint may be a block of rows (a ``connect`` equality has three): its
``force.NAME`` figure compares every row with its multiplier (the worst row
decides), and a block of several rows also gets ``generalized_force.NAME``,
its own Jᵀλ against D ᵀ J_mjᵀ efc_force over its rows — the force on the
coordinates, which does not depend on how the rows are scaled or ordered.

Those four go through the binding's constant dof matrix D (qvel = D q̇), or its
state-dependent velocity map B(q) (qvel = B(q) q̇, a ball or free joint's local
angular velocity; :func:`harness.engine.bindings.velocity_map`), with
qacc = B q̈ + Ḃ q̇ (Ḃ q̇ by complex step, exact to round-off): mass matrix
Bᵀ M_mj B vs M(q); forcing Bᵀ(qfrc_passive − qfrc_bias − M_mj Ḃ q̇) vs F (Kane's
generalized inertia and active forces: the velocity-dependent part of B moves
into the forcing); q̈ pulled back from qacc − Ḃ q̇ (:func:`pull_back`); the
generalized constraint force Bᵀ qfrc_constraint vs Jᵀλ. A binding with
neither gets only the observable figures, which every case has:
the kinetic energy ½ qvelᵀ M_mj qvel vs ½ q̇ᵀ M q̇ (inertia along the sampled
velocities) and the world acceleration of every named point,
J_mj qacc + J̇_mj qvel vs (∂x/∂q) q̈ + q̇ᵀ(∂²x/∂q²)q̇ (inertia and forces together).

At the same states every force, torque and accelerometer sensor of the model,
and ``cfrc_int`` of each sensed body, is compared with Newton–Euler of the
subtree below its site (:mod:`harness.layers.reactions`).

States are taken on the constraint manifold: along the reference, each also
with its velocity rescaled (which keeps J q̇ = 0 for homogeneous rows), so
both slow and fast states are covered.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, field

import mujoco
import numpy as np

from analytic.solvers import project
from harness.core.budget import PERTURBED_RUNS
from harness.core.deviation import Deviation
from harness.core.figures import Figure, FigureName
from harness.core.findings import Finding
from harness.engine import variants as V
from harness.engine.backends import Forward, active, computes_reactions, forward_many
from harness.engine.backends.completion import completed_forward
from harness.engine.bindings import velocity_map
from harness.engine.compat import JAC_DOT_DEFECT, full_mass_matrix, jac_dot, jac_dot_missing
from harness.engine.constraints import equality_block, equality_jacobian, equality_rows
from harness.engine.points import point_jacobian, point_source
from harness.engine.probe import Probe
from harness.layers.reactions import Recorder, reaction_deviations, sensor_names
from harness.reference.solutions import Reference
from harness.reference.tree import TREE

DEFAULT_SAMPLES = 24
STATE_TOLERANCE = 1e-14


def sample_states(ref: Reference, count: int = DEFAULT_SAMPLES, seed: int = 0
                  ) -> tuple[np.ndarray, np.ndarray]:
    """``count`` states (q, q̇) on the manifold, deterministic for a seed: along the reference, each
    also with its velocity rescaled, every one projected onto the constraints to round-off
    (:func:`analytic.solvers.project`). The reference's own residual (up to 1e-10) would otherwise
    meet MuJoCo's constraint feedback −b v − k r, which no softness setting removes."""
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


ROUNDOFF_QUANTITY = 1e-9
"""An analytic quantity whose largest value over the states is below this × its physical scale is zero up to
round-off (a body nothing pushes: its acceleration is 1e-17 m/s²); a figure relative to it would divide round-off by
round-off, so it is taken relative to the physical scale instead."""


def _scale(expected: np.ndarray, *, vector: bool = False, physical: float = 0.0) -> float:
    """What a relative figure divides by: the largest entry (vector norm) of the analytic quantity; its physical
    scale where the quantity is zero up to round-off (:data:`ROUNDOFF_QUANTITY`); 1 where it is 0 and no scale is
    given (the figure is then absolute)."""
    if not expected.size:
        return 1.0
    largest = float(np.max(np.linalg.norm(expected, axis=-1) if vector else np.abs(expected)))
    if physical > 0 and largest < ROUNDOFF_QUANTITY * physical:
        return physical
    return largest if largest > 0 else 1.0


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


@dataclass(frozen=True)
class InstantEvaluation:
    """The instantaneous layer on the active backend.

    Attributes:
        deviations: one per figure, a row per sampled state (:func:`instant_deviations`).
        perturbed: on a float32 backend, the same figures from the backend's forward of each of the
            :data:`PERTURBED_RUNS` round-off copies of the model (masses an ulp or two away,
            :func:`harness.engine.variants.roundoff_copy`: the same motion, every rounding different) at the same
            states: their spread is the round-off of the backend's arithmetic
            (:func:`harness.budget.instant.instant_budgets`). Figures
            read from the C engine's float64 geometry alone (``instant.kinematics``) are left out. Empty on a
            float64 backend.
        represented: on a float32 backend, each figure's shift when the model's constants and the state are
            held in float32 (:func:`harness.engine.variants.represented_model`, the C engine in float64 at the
            states rounded to float32), reduced as the figure is: what no copy moves (atwood's forcing
            (m₁ − m₂)g), and the soft constraints' response to the state's own rounding (a coordinate held by
            an equality, off by half an ulp); empty on a float64 backend.
        unavailable: figures the backend's arrays cannot give at these states, or that are not compared (an
            accelerometer at a site the analytic system has no acceleration for), each with the one-line reason.
        failing: figures that cannot be measured because of what the model does (a body in a sensor's subtree
            loaded from outside its joints: :func:`harness.layers.reactions.reaction_deviations`), each with the
            reason its check fails with.
        completed: on a float32 backend, the figures with the backend's stopped constraint solve completed in
            float64 at every state where the stop is its precision's (:mod:`harness.engine.backends.completion`): the
            difference from ``deviations`` is what the solver's stop left in each figure; None on a float64
            backend.
        completion_note: where the completion was not applied, one line; else "".
    """

    deviations: list[Deviation]
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


def _measure(model: mujoco.MjModel, probe: Probe, dyn, q: np.ndarray, qd: np.ndarray, *,
             states: tuple[np.ndarray, np.ndarray] | None, fwd: Forward | None, offset: int):
    """The engine's side at each state: the C engine's ``mj_forward`` at (q, q̇) (through the binding), or at
    MuJoCo's coordinates ``states`` (qpos, qvel), carrying the backend's dynamics ``fwd`` (rows ``offset``..)
    where the backend is not C."""
    constant = probe.binding.dof_matrix(model) is not None
    mapped = getattr(probe.binding, "velocity_map", None) is not None
    coordinates = constant or mapped
    data = mujoco.MjData(model)
    got = {k: [] for k in ("mass", "forcing", "qacc", "gen", "pts", "acc", "kinetic")}
    got_lam = {c: [] for c in probe.constraints}
    got_block_gen = {c: [] for c in probe.constraints}
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
            dof, rate = velocity_map(probe.binding, model, q[i], qd[i])
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
    return got, got_lam, got_block_gen, reactions, unavailable


def instant_deviations(model: mujoco.MjModel, probe: Probe, ref: Reference, *, count: int = DEFAULT_SAMPLES
                       ) -> list[Deviation]:
    """The active backend's instantaneous dynamics against the analytic ones at :func:`sample_states`, one
    :class:`~harness.core.deviation.Deviation` per figure (a row per state): :func:`instant_evaluation`'s."""
    return instant_evaluation(model, probe, ref, count=count).deviations


def has_contacts(model: mujoco.MjModel) -> bool:
    """Whether ``model`` can make contacts: explicit pairs, or collision on with geoms that may collide."""
    off = int(mujoco.mjtDisableBit.mjDSBL_CONTACT) | int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    if model.opt.disableflags & off:
        return False
    return bool(model.npair) or bool(np.any((model.geom_contype != 0) | (model.geom_conaffinity != 0)))


def instant_evaluation(model: mujoco.MjModel, probe: Probe, ref: Reference, *, count: int = DEFAULT_SAMPLES,
                       perturbed: bool = False) -> InstantEvaluation:
    """The instantaneous figures on the active backend (:func:`harness.engine.backends.active`).

    The dynamics are the backend's, from one batched ``forward_many`` at every sampled state: the mass matrix,
    the forcing qfrc_passive − qfrc_bias, qacc, the equalities' efc_force, qfrc_constraint, the kinetic energy
    ½ qvelᵀ M qvel with the backend's M, the point accelerations J qacc + J̇ qvel with the backend's qacc, and
    the reaction sensors and ``cfrc_int`` (the backend's own, or computed in float64 from its qacc and
    constraint forces where it does not compute them; not available, with the reason, where its rows cannot
    be mapped). The geometry is the C engine's in float64 at the same qpos (``mj_forward``): point positions,
    the Jacobians J and J̇, a site's frame, efc_J of an equality's rows — kinematics, not dynamics, checked by
    ``instant.kinematics``. On the C backend everything is ``mj_forward``'s, as it always was.

    ``perturbed``: on a float32 backend, also the backend's forward of the model's round-off copies
    (:func:`harness.engine.variants.roundoff_copy`) at the same states (:attr:`InstantEvaluation.perturbed`);
    on the C backend, the float64 copies' where the model has constraints (equalities, :func:`has_contacts`)."""
    probe.validate(model)
    dyn = ref.dynamics
    q, qd = sample_states(ref, count)
    backend = active()
    fwd, copies = None, None
    if backend.name != "c":
        qpos, qvel = mujoco_states(model, probe, q, qd)
        fwd = forward_many(model, probe, qpos, qvel)
        if perturbed and backend.epsilon > float(np.finfo(np.float64).eps):
            copies = [forward_many(V.roundoff_copy(model, epsilon=backend.epsilon, index=k), probe, qpos, qvel)
                      for k in range(1, PERTURBED_RUNS + 1)]
    measured = _measure(model, probe, dyn, q, qd, states=None, fwd=fwd, offset=0)
    deviations, unavailable, failing = _deviations(model, probe, ref, q, qd, measured, backend.name)
    if perturbed and backend.name == "c" and (model.neq > 0 or has_contacts(model)):
        # float64 too: a constraint solve amplifies round-off by its conditioning (a contact's friction rows by
        # impratio; redundant rows, as slider_crank's, by 1/(1 − d)), which the assumed ROUNDOFF does not bound;
        # the copies measure it
        epsilon = float(np.finfo(np.float64).eps)
        c_copies = [V.roundoff_copy(model, epsilon=epsilon, index=k) for k in range(1, PERTURBED_RUNS + 1)]
        same = _Reused(dyn)  # the analytic side at the same states: evaluated for the first copy, reused after
        others = [[d for d in _deviations(copy, probe, ref, q, qd, _measure(copy, probe, dyn, q, qd, states=None,
                                                                             fwd=None, offset=0), "c", dyn=same)[0]
                   if d.name != FigureName.instant("kinematics")] for copy in c_copies]
        return InstantEvaluation(deviations=deviations, perturbed=tuple(others), unavailable=unavailable,
                                 failing=failing)
    completed, completion_note = None, ""
    if fwd is not None and backend.epsilon > float(np.finfo(np.float64).eps):
        completion = completed_forward(model, fwd, backend.epsilon,
                                       lambda data, k: probe.binding.set_state(model, data, q[k], qd[k]))
        again = _measure(model, probe, dyn, q, qd, states=None, fwd=completion.forward, offset=0)
        completed = _deviations(model, probe, ref, q, qd, again, backend.name)[0]
        completion_note = completion.note()
    others, represented = [], {}
    if copies is not None:
        as_c = _deviations(model, probe, ref, q, qd, _measure(model, probe, dyn, q, qd, states=None, fwd=None,
                                                              offset=0), "c")[0]
        rounded = V.represented_model(model, np.float32)
        # the engine's side on the rounded model at the rounded states; the analytic side (and the gravity it
        # reads) the model's own at the exact states
        states = (qpos.astype(np.float32).astype(float), qvel.astype(np.float32).astype(float))
        in_float32 = _deviations(model, probe, ref, q, qd, _measure(rounded, probe, dyn, q, qd, states=states,
                                                                     fwd=None, offset=0), "c")[0]
        represented = {a.name: a.magnitude(b.values - a.values) for a, b in zip(as_c, in_float32, strict=True)
                       if a.name != FigureName.instant("kinematics")}
        for again_fwd in copies:
            again = _measure(model, probe, dyn, q, qd, states=None, fwd=again_fwd, offset=0)
            others.append([d for d in _deviations(model, probe, ref, q, qd, again, backend.name)[0]
                           if d.name != FigureName.instant("kinematics")])
    return InstantEvaluation(deviations=deviations, perturbed=tuple(others), represented=represented,
                             unavailable=unavailable, failing=failing, completed=completed,
                             completion_note=completion_note)


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


def _deviations(model: mujoco.MjModel, probe: Probe, ref: Reference, q: np.ndarray, qd: np.ndarray, measured,
                backend: str, *, dyn=None) -> tuple[list[Deviation], dict[str, str], dict[str, str]]:
    """The figures from the engine's side (:func:`_measure`) against the analytic values at (q, q̇); the
    figures n/a and those failing, each with why (:attr:`InstantEvaluation.unavailable`, ``.failing``).
    ``dyn``: the reference's dynamics to evaluate (default ``ref.dynamics``; :class:`_Reused` for the copies)."""
    got, got_lam, got_block_gen, reactions, unavailable = measured
    dyn = ref.dynamics if dyn is None else dyn
    qdd, lam = dyn.accelerations(q, qd)
    mass = dyn.mass_matrix(q)
    forcing = dyn.forcing(q, qd)
    gen = np.einsum("nmk,nm->nk", dyn.jacobian(q), lam)  # Jᵀλ over every row
    pts = dyn.points(q)
    acc = dyn.point_accelerations(q, qd, qdd)
    kinetic = 0.5 * np.einsum("ni,nij,nj->n", qd, mass, qd)
    mapped = getattr(probe.binding, "velocity_map", None) is not None
    coordinates = probe.binding.dof_matrix(model) is not None or mapped
    n = len(q)
    length = ref.scales.length

    def relative(name: FigureName, got_: list, expected: np.ndarray, description: str, *,
                 vector: bool = False, physical: float = 0.0) -> Deviation:
        return Deviation(name, np.reshape(got_, expected.shape) - expected, "vector" if vector else "scalar", "1",
                         description, scale=_scale(expected, vector=vector, physical=physical))

    sc = ref.scales  # the physical scales of each relative figure: g = L (E/p)², ω₀² = (E/p)²
    rate = (sc.energy / sc.momentum) ** 2 if sc.momentum > 0 else 0.0  # 0 (no floor) where no gravity sets a scale
    physical = {"kinetic_energy": sc.energy, "point_acceleration": sc.length * rate,
                "mass_matrix": sc.energy / rate if rate > 0 else 0.0,
                "forcing": min(sc.force, sc.energy), "qacc": min(rate, sc.length * rate),
                "generalized_force": min(sc.force, sc.energy)}

    sites = any(point_source(model, p).kind == "site" for p in dyn.point_names)
    where, what = ("point position (site or body com)", "site or body com") if sites else ("body position", "body com")
    out = [
        Deviation(FigureName.instant("kinematics"), np.array(got["pts"]) - pts, "scalar", "m",
                  f"max |MuJoCo {where} − analytic point| over {n} states", size=length),
        relative(FigureName.instant("kinetic_energy"), got["kinetic"], kinetic,
                 "max |½ qvelᵀ M_mj qvel − ½ q̇ᵀ M q̇| / max ½ q̇ᵀ M q̇", physical=physical["kinetic_energy"]),
        relative(FigureName.instant("point_acceleration"), got["acc"], acc,
                 f"max |J qacc + J̇ qvel − ẍ| / max |ẍ| over named points (world acceleration of the {what})",
                 vector=True, physical=physical["point_acceleration"]),
    ]
    d = "B" if mapped else "D"  # velocity_map wins where a binding gives both (bindings.velocity_map)
    if coordinates:
        out += [
            relative(FigureName.instant("mass_matrix"), got["mass"], mass,
                     f"max |{d}ᵀ M_mj {d} − M(q)| / max |M(q)|", physical=physical["mass_matrix"]),
            relative(FigureName.instant("forcing"), got["forcing"], forcing,
                     "max |Bᵀ(qfrc_passive + qfrc_actuator − qfrc_bias − M_mj Ḃq̇) − F| / max |F|" if mapped else
                     "max |Dᵀ(qfrc_passive + qfrc_actuator − qfrc_bias) − F| / max |F|", physical=physical["forcing"]),
            relative(FigureName.instant("qacc"), got["qacc"], qdd,
                     "max |B⁺(qacc − Ḃq̇) − q̈| / max |q̈| (B⁺: pull-back, kinetic-energy weighted where nv > n)"
                     if mapped else "max |qacc − q̈| / max |q̈|", physical=physical["qacc"]),
        ]
    if probe.constraints and coordinates:
        out.append(relative(FigureName.instant("generalized_force"), got["gen"], gen,
                            f"max |{d}ᵀ qfrc_constraint − Jᵀλ| / max |Jᵀλ|", physical=physical["generalized_force"]))
    jac = dyn.jacobian(q)
    force_scale = ref.scales.force
    for c, rows in dyn.blocks.items():
        if c not in got_lam:
            continue
        size = rows.stop - rows.start
        expected = lam[:, rows]
        out.append(Deviation(FigureName.instant("force", c), np.reshape(got_lam[c], expected.shape) - expected,
                             "scalar", "1",
                             f"max |efc_force − λ_{c}|{' over its ' + str(size) + ' rows' if size > 1 else ''} / "
                             f"force scale ({force_scale:.4g} N)", scale=force_scale,
                             size=max(float(np.max(np.abs(expected), initial=0.0)) / force_scale, 1.0)))
        if got_block_gen[c]:
            block_gen = np.einsum("nmk,nm->nk", jac[:, rows], lam[:, rows])
            out.append(relative(FigureName.instant("generalized_force", c), got_block_gen[c], block_gen,
                                f"max |{d}ᵀ J_mjᵀ efc_force − Jᵀλ| over the rows of {c!r} / max |Jᵀλ|"))
    if unavailable:
        sensors, bodies = sensor_names(model)
        missing = [FigureName.instant("sensor", s) for s in sensors] + \
            [FigureName.instant("interaction", b) for b in bodies]
        return out, {str(name): f"not available on backend {backend!r}: {unavailable}" for name in missing}, {}
    sensed, skipped, failing = reaction_deviations(model, dyn, reactions, q, qd, qdd, lam, force_scale=force_scale,
                                                   length=length, strict=ref.system != TREE)
    return out + sensed, skipped, failing


def instantaneous_figures(model: mujoco.MjModel, probe: Probe, ref: Reference,
                          *, count: int = DEFAULT_SAMPLES) -> list[Figure]:
    """Compare MuJoCo's instantaneous dynamics with the analytic ones at sampled states (the figures
    of :func:`instant_deviations`)."""
    return [d.figure() for d in instant_deviations(model, probe, ref, count=count)]


def engine_findings(model: mujoco.MjModel, probe: Probe, ref: Reference, *, count: int = DEFAULT_SAMPLES
                    ) -> list[Finding]:
    """Where this layer corrects an engine function to take its measurement, how far the engine's own
    answer is off, at the same states (:class:`~harness.core.findings.Finding`): ``mj_jacDot`` on a
    MuJoCo that misses a term (:func:`harness.engine.compat.jac_dot_missing`), as the error it alone
    would make in the named points' world acceleration."""
    dyn = ref.dynamics
    q, qd = sample_states(ref, count)
    qdd, _ = dyn.accelerations(q, qd)
    expected = np.linalg.norm(dyn.point_accelerations(q, qd, qdd), axis=-1)
    data = mujoco.MjData(model)
    worst = 0.0
    for i in range(len(q)):
        mujoco.mj_resetData(model, data)
        probe.binding.set_state(model, data, q[i], qd[i])
        mujoco.mj_forward(model, data)
        for p in dyn.point_names:
            source = point_source(model, p)
            missing = jac_dot_missing(model, data, source.position(data), source.body)
            if missing is None:
                return []
            worst = max(worst, float(np.linalg.norm(missing @ data.qvel)))
    scale = float(np.max(expected)) if expected.size and np.max(expected) > 0 else 1.0
    if worst <= 0:
        return []
    return [Finding("mj_jacDot", worst / scale, "1",
                    "max |J̇ qvel| that mj_jacDot leaves out / max |ẍ| of the named points at the sampled states "
                    "(the error it alone would make in their world acceleration; the harness adds the term)",
                    JAC_DOT_DEFECT)]

"""A case for any model the user brings: its reference is the model's own kinematic tree.

``from_mjcf(path)`` needs no hand-derived system: the reference is read from
the compiled model (:mod:`harness.reference.tree`), the start is the model's
``qpos0`` (or a keyframe, or coordinates given), and the horizon is chosen
from the motion itself: the time over which a perturbation of the start of
:data:`SEED` grows by :data:`GROWTH` (past it, any error of the engine is
amplified as much as the error itself is worth: the chaos horizon), capped at
:data:`HORIZON_CAP`. Every layer and budget then runs as for a shipped case.

What the tree reference does not model (contacts, joint limits, dry friction,
fluid forces, spatial tendons, activation dynamics: :func:`uncovered`) is
switched off in every run of the comparison by :func:`isolate`, an explicit
edit listed in the settings: the verdict speaks of the model's tree dynamics,
and the report names every force it did not examine.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import cast

import mujoco
import numpy as np

from analytic import dual
from analytic.dynamics import chunk_states
from analytic.solvers import STIFF_RTOL, TooManySteps, project
from analytic.tree import TreeDynamics
from harness.cases import Case, Wiring
from harness.core import bounds, progress
from harness.core.errors import ModelError
from harness.engine.bindings import TreeBinding
from harness.engine.models import compile_model, load_spec
from harness.engine.readings.momentum import total_momentum
from harness.engine.variants import POINT_MASS
from harness.reference.solutions import TREE_MAX_STEPS, bounded_solve
from harness.reference.tree import (
    TREE,
    TreeSystem,
    charts,
    motion,
    prepare,
    refusal,
    start_state,
    tree_scales,
    uncovered,
)

__all__ = ["SPIN_FLOOR", "from_mjcf", "model_name"]

HORIZON_CAP = 1.0
"""The longest horizon chosen (s): the reference's cost grows with it, and a model's tree dynamics shows its
faults within it."""
SEED = 1e-8
"""The relative size of the perturbation of the start's velocities the chaos horizon is measured with (the perturbed
run is solved to SEED / 10: its own error stays a tenth of the separation it measures from the start; a stiff
model's, by Radau IIA, to STIFF_RTOL = SEED: its error then is that of the perturbation, still 1e-4 of the
separation GROWTH × SEED at which the horizon ends)."""
GROWTH = 1e4
"""How much the perturbation may grow before the horizon ends."""
HORIZON_STEPS = 1500
"""The most solver steps the chaos horizon's reference may take: its span is cut to what they cover (a motion whose
reference is costly, Cassie's lightly damped 375 rad/s rods, is judged over less than HORIZON_CAP, and says so).
Above the 1270 steps of the costliest solve over 1 s among the zoo and the robots (docs/findings/bases.md,
HORIZON_STEPS), so only such motions are cut."""
MIN_STEPS = 20
"""The shortest horizon chosen, in timesteps (a very chaotic motion still gets a trajectory)."""


def _start(model: mujoco.MjModel, keyframe: str | None) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
    if keyframe is None:
        return np.array(model.qpos0), np.zeros(model.nv), np.zeros(model.nu), "qpos0 at rest"
    kid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, keyframe)
    if kid < 0:
        known = [model.key(i).name for i in range(model.nkey)]
        raise ModelError(f"keyframe {keyframe!r} is not in the model; accepted: {', '.join(known) or 'none defined'}")
    return (np.array(model.key_qpos[kid]), np.array(model.key_qvel[kid]), np.array(model.key_ctrl[kid]),
            f"keyframe {keyframe!r}")


KICK_SEED = 0
"""The seed of the start's velocity pattern where the model starts at rest (deterministic: the same case every run)."""
STIFF_DAMPING = 100.0
"""A model whose fastest damped mode decays this many times faster than one timestep is stiff: its kick spares the
modes damped within a step. A factor, not 1, so that a model merely well damped keeps the kick it always had (where
dm_control's suite falls on either side of it: docs/findings/bases.md, STIFF_DAMPING)."""


def kick(model: mujoco.MjModel, case_tree: TreeSystem, qpos: np.ndarray) -> np.ndarray:
    """A start velocity that moves the model, for one that starts at rest: a fixed pseudo-random direction (each
    component 0.5–1 in size, either sign, seeded by :data:`KICK_SEED`), less its part along the mass matrix's
    floor modes, scaled so that the kinetic energy is ½ m g L (the tree's mass moving over its size under gravity;
    9.81 m/s² where gravity is off). At rest at an equilibrium a model shows no dynamics at all (every figure 0).

    Floor modes are those whose inertia is below :data:`~harness.engine.variants.POINT_MASS` × the largest (a point
    mass's spin, a link's twist about its own axis): a velocity there lives ~√(ε/m L²) seconds, far below any
    timestep, and every integrator's error would be that unresolved transient's, not the dynamics'. For the same
    reason, in a model whose damping is stiff (a mode stopped within 1/:data:`STIFF_DAMPING` of a timestep: damping
    on a light link), the kick spares every mode the damping stops within a timestep (decay rate × timestep > 1, in
    M's inner product); at its start it would also hold the reference's stiff solver to that transient's scale."""
    tree = case_tree.tree(model)
    dyn = TreeDynamics.of(tree)
    q0, _ = start_state(model, qpos, np.zeros(model.nv))
    q = np.array([q0[c] for c in dyn.coordinates])
    rng = np.random.default_rng(KICK_SEED)
    direction = rng.uniform(0.5, 1.0, size=dyn.n) * rng.choice([-1.0, 1.0], size=dyn.n)
    mass = dyn.mass_matrix(q)
    inertia, modes = np.linalg.eigh(mass)
    rates, damped = dyn.damping_modes(q)
    stopped = rates * float(model.opt.timestep)
    fast = damped[:, stopped > 1.0] if stopped[0] > STIFF_DAMPING else damped[:, :0]
    if fast.shape[1]:  # spared too: along them the kick would be gone within a timestep (see above)
        held = np.column_stack([modes[:, inertia <= POINT_MASS * inertia.max()], mass @ fast])
        direction = direction - held @ np.linalg.lstsq(held, direction, rcond=None)[0]
    else:
        real = modes[:, inertia > POINT_MASS * inertia.max()]
        direction = real @ (real.T @ direction)
    kinetic = 0.5 * float(direction @ mass @ direction)
    return direction * math.sqrt(0.5 * tree_scales(tree).energy / kinetic)


def chaos_horizon(case: Case, model: mujoco.MjModel) -> tuple[float, str]:
    """The horizon for ``case``'s motion and why: the first time a perturbation of :data:`SEED` in the start's
    velocities (in units of √(g/L)) separates a point by :data:`GROWTH` × SEED × L, capped at
    :data:`HORIZON_CAP` and at least :data:`MIN_STEPS` timesteps."""
    assert case.tree is not None  # a model of one's own, judged against its tree
    dyn = case.tree.dynamics(model)
    scales = tree_scales(dyn.tree)
    progress.stage(f"choosing the horizon: solving its tree reference over {HORIZON_CAP:g} s (at most "
                   f"{HORIZON_STEPS} steps)")
    nominal = case.reference(model, t_end=HORIZON_CAP, reach=HORIZON_STEPS)
    cap = nominal.solution.t_end
    cut = cap < HORIZON_CAP
    if cut:  # the span those steps covered, to two figures, rounded down
        unit = 10.0 ** (math.floor(math.log10(cap)) - 1)
        cap = float(f"{math.floor(cap / unit) * unit:.2g}")
    progress.stage(f"choosing the horizon: solving a perturbed start over {cap:g} s")
    q0, qd0 = nominal.q0(), nominal.qd0()
    signs = np.where(np.arange(dyn.n) % 2 == 0, 1.0, -1.0)
    kick = SEED * math.sqrt(9.81 / scales.length) * signs
    q1, qd1 = project(dyn, q0, qd0 + kick)  # the kick's part along the constraints
    try:
        moved = bounded_solve(dyn, q0=q1, qd0=qd1, t_end=cap, rtol=max(nominal.solution.rtol, SEED / 10),
                              max_steps=TREE_MAX_STEPS, tree=True)
    except TooManySteps as exc:  # the nominal solve passed its bound: this one cannot be far off it
        raise ModelError(f"the model's tree reference cannot be solved over {cap:g} s: {exc}; accepted: "
                         "a shorter --horizon") from None
    t = np.linspace(0.0, cap, 401)
    a = dyn.points(nominal.solution.state(t)[0]) if dyn.point_names else dyn.body_coms(nominal.solution.state(t)[0])
    b = dyn.points(moved.state(t)[0]) if dyn.point_names else dyn.body_coms(moved.state(t)[0])
    separation = np.max(np.linalg.norm(a - b, axis=-1), axis=-1)
    over = np.flatnonzero(separation > GROWTH * SEED * scales.length)
    floor = MIN_STEPS * float(model.opt.timestep)
    if over.size == 0 and cut:
        return max(floor, cap), (f"horizon {max(floor, cap):g} s (the reference's cost: {HORIZON_STEPS} steps of its "
                                 f"{nominal.solution.method} solve cover {nominal.solution.t_end:.3g} s of the "
                                 f"{HORIZON_CAP:g} s cap); a {SEED:g} perturbation of the start grows less than "
                                 f"×{GROWTH:g} within it")
    if over.size == 0:
        return HORIZON_CAP, (f"horizon {HORIZON_CAP:g} s (the cap): a {SEED:g} perturbation of the start grows less "
                             f"than ×{GROWTH:g} within it")
    end = float(t[over[0]])
    chosen = max(floor, float(f"{end:.2g}"))
    return chosen, (f"horizon {chosen:g} s: a {SEED:g} perturbation of the start grows ×{GROWTH:g} by {end:.3g} s "
                    "(chaos); past it an engine's error is amplified beyond what a budget can apportion")


SPIN_FLOOR = float(np.finfo(float).eps) / STIFF_RTOL
"""The smallest inertia of a mode a ball or free joint turns, relative to the largest, that the reference can solve
(2.2e-8): round-off in the forces (ε of the largest) divided by that mode's inertia is noise of ε × the ratio in q̈,
which a solve to the stiff tolerance STIFF_RTOL must stay above. Cassie's achilles rods (a spin of 3.8e-6 against
34 kg m², 1.1e-7) are above it; a point mass on a ball joint (1e-12) is not (docs/findings/bases.md)."""


def _refuse_floor_spins(model: mujoco.MjModel, qpos: np.ndarray) -> None:
    """ModelError where a ball or free joint moves a mode of the mass matrix with next to no inertia (below
    :data:`SPIN_FLOOR` of the largest: a point mass on a ball joint). The tree's rotation-vector coordinates turn
    that mode with θ, so round-off in the forces, divided by its inertia, becomes noise the reference's tolerance
    cannot meet, and the solve does not finish (a point mass on a ball joint: docs/findings/bases.md)."""
    kinds = {int(mujoco.mjtJoint.mjJNT_BALL), int(mujoco.mjtJoint.mjJNT_FREE)}
    if not any(int(t) in kinds for t in model.jnt_type):
        return
    system = TreeSystem(charts=tuple((j, tuple(float(x) for x in quat)) for j, quat in charts(model, qpos).items()))
    dyn = system.dynamics(model)
    q0, _ = start_state(model, qpos, np.zeros(model.nv))
    inertia, modes = np.linalg.eigh(dyn.mass_matrix(np.array([q0[c] for c in dyn.coordinates])))
    floor = inertia < SPIN_FLOOR * inertia.max()
    for j in range(model.njnt):
        if int(model.jnt_type[j]) not in kinds:
            continue
        dof = int(model.jnt_dofadr[j]) + (3 if int(model.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_FREE) else 0)
        if np.any(np.abs(modes[dof:dof + 3][:, floor]) > 0.5):
            name = model.joint(j).name
            raise ModelError(f"joint {name!r} turns a body with next to no rotational inertia (a mode of "
                             f"{inertia[floor].min():.1e} against {inertia.max():.1e}: a point mass on a ball or free "
                             "joint), which the tree reference cannot solve to its tolerance; accepted: rotational "
                             f"inertia above {SPIN_FLOOR:.2g} of the largest, or the point mass on a pair of hinges")


class _Slow(BaseException):
    """Raised in the timed evaluation once it has run long enough to decide the refusal."""


def _timed_evaluation(work: Callable[[], object], deadline: float) -> tuple[float, bool]:
    """The CPU seconds of ``work()`` (an evaluation of the tree's equations; the first also builds what the tree
    caches) and False, or ``deadline`` and True where it has not ended by then: it is stopped there (by SIGPROF,
    in the main thread; elsewhere it runs to its end). One evaluation of a large tree can take a minute."""
    import signal  # lazy: only the cost's timing stops a computation
    import threading  # lazy: as above

    stoppable = threading.current_thread() is threading.main_thread() and hasattr(signal, "ITIMER_PROF")
    armed, fired = [True], [False]

    def stop(_signum, _frame):  # Python runs it between bytecodes: past the evaluation's end it must do nothing
        if armed[0]:
            fired[0] = True
            raise _Slow

    clock = time.process_time()
    previous = signal.signal(signal.SIGPROF, stop) if stoppable else None
    if stoppable:
        signal.setitimer(signal.ITIMER_PROF, deadline)
    try:
        work()
        armed[0] = False
    except _Slow:
        return deadline, True
    finally:
        armed[0] = False
        if stoppable:
            signal.setitimer(signal.ITIMER_PROF, 0)
            signal.signal(signal.SIGPROF, previous)
    elapsed = time.process_time() - clock
    if stoppable and (fired[0] or elapsed >= deadline):  # the stop came where Python swallows what it raises (a
        return deadline, True                            # finalizer's frame), or not at all: it ran past anyway
    return elapsed, False


def _check_cost(model: mujoco.MjModel, system: TreeSystem, qpos: np.ndarray, span: float) -> None:
    """RunTooLong, before any solve, where the tree reference over ``span`` would pass
    :func:`~harness.core.bounds.max_reference_seconds` (:func:`~harness.core.bounds.check_reference_cost`): one
    evaluation of its accelerations is timed here, then one chunk of the exact Jacobian every tree solve takes at
    its start (:func:`analytic.solvers.explicit_steps`; its 2n dual-number columns go in chunks of equal size,
    :func:`analytic.dynamics.chunk_states`), each stopped as soon as it is long enough to refuse."""
    dyn = system.dynamics(model)
    q0, qd0 = start_state(model, qpos, np.zeros(model.nv))
    q = np.array([q0[c] for c in dyn.coordinates])
    qd = np.array([qd0[c] for c in dyn.coordinates])
    bound = bounds.max_reference_seconds()
    deadline = 1.01 * bound / (bounds.EVALUATIONS_PER_SECOND * span)
    evaluation, stopped = _timed_evaluation(lambda: dyn.accelerations(q, qd), deadline)
    bounds.check_reference_cost(evaluation=evaluation, span=span, nv=int(model.nv), stopped=stopped)
    columns = 2 * dyn.n
    per = min(chunk_states(dyn.n), columns)
    seeds = cast(np.ndarray, dual.seeded(np.concatenate([q, qd]), np.eye(columns)[:per]))  # dual numbers: as arrays
    left = bound - bounds.EVALUATIONS_PER_SECOND * span * evaluation
    chunk, late = _timed_evaluation(lambda: dyn.accelerations(seeds[..., :dyn.n], seeds[..., dyn.n:]),
                                    1.01 * left * per / columns)
    bounds.check_reference_cost(evaluation=evaluation, span=span, nv=int(model.nv),
                                jacobian=chunk * columns / per, jacobian_stopped=late)


DEFAULT_MODEL_NAME = "MuJoCo Model"
"""The ``model`` attribute MuJoCo gives a file that has none."""
GENERIC_STEMS = ("scene",)
"""File names that say what a file is, not which model: Menagerie's ``scene.xml``, ``scene_left.xml``."""


def model_name(path: Path | str) -> str:
    """What a model of one's own is called in its report and lines: its MJCF ``model`` attribute where it has one
    (Menagerie's "panda scene"), else the file's name without ``.xml``, but its folder's name where that is a
    generic one (``franka_emika_panda/scene.xml``: "franka_emika_panda"). Never "scene" alone."""
    path = Path(path)
    try:  # one line of printable characters: it lands in terminal lines, file names and pages
        written = "".join(c if c.isprintable() else "?" for c in " ".join(load_spec(path).modelname.split()))
    except ModelError:  # unreadable: from_mjcf names what is wrong with it
        written = ""
    generic = [*GENERIC_STEMS, DEFAULT_MODEL_NAME.lower()]
    if written and not any(written.lower() == g or written.lower().startswith(f"{g}_") for g in generic):
        return written
    stem = path.stem
    if any(stem.lower() == g or stem.lower().startswith(f"{g}_") for g in GENERIC_STEMS):
        return path.resolve().parent.name or stem
    return stem


def from_mjcf(path: Path | str, *, keyframe: str | None = None, ctrl: Mapping[str, float] | None = None,
              horizon: float | None = None, reference: Path | str | None = None) -> Case:
    """The case of the model at ``path`` judged against its own kinematic tree (no hand-derived system).

    ``keyframe`` starts it at a keyframe of the model (default: qpos0 at rest); ``ctrl`` sets actuator
    controls by name (default: the keyframe's, else 0); ``horizon`` replaces the chosen one. ``reference``: read
    the reference from this file instead (the same model with a fault made on the engine's side alone: what the
    fault tests inject). ModelError (one line) for a model the tree reference cannot read or a keyframe or
    actuator it lacks."""
    path = Path(path)
    with progress.heartbeat(model_name(path)):
        return _from_mjcf(path, keyframe=keyframe, ctrl=ctrl, horizon=horizon, reference=reference)


def _from_mjcf(path: Path, *, keyframe: str | None, ctrl: Mapping[str, float] | None, horizon: float | None,
               reference: Path | str | None) -> Case:
    progress.stage("reading the model")
    model = compile_model(path, edit=prepare)
    why = refusal(model)
    if why:
        raise ModelError(f"{path.name}: {why}")
    qpos, qvel, controls, start = _start(model, keyframe)
    for name, value in (ctrl or {}).items():
        aid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, name)
        if aid < 0:
            known = [model.actuator(i).name for i in range(model.nu)]
            raise ModelError(f"--ctrl names actuator {name!r}, not in the model; accepted: {', '.join(known)}")
        if not math.isfinite(value):
            raise ModelError(f"--ctrl {name}={value}: a control must be a finite number")
        controls[aid] = value
    limited = model.actuator_ctrllimited.astype(bool)  # as MuJoCo clamps them (the reference bakes them in)
    if int(model.opt.disableflags) & int(mujoco.mjtDisableBit.mjDSBL_CLAMPCTRL):  # unless its clamping is off
        limited[:] = False
    controls[limited] = np.clip(controls[limited], model.actuator_ctrlrange[limited, 0],
                                model.actuator_ctrlrange[limited, 1])
    gaps = uncovered(model)
    chart = tuple((j, tuple(float(x) for x in quat)) for j, quat in charts(model, qpos).items())
    progress.stage(f"estimating the cost of its tree reference ({model.nv} dof)")
    _check_cost(model, TreeSystem(charts=chart), qpos, horizon or HORIZON_CAP)
    progress.stage("preparing its start")
    _refuse_floor_spins(model, qpos)
    source = None
    if reference is not None:
        source = str(Path(reference).resolve())
        compile_model(source, edit=prepare)  # one line for a file that is no model, before any work
    system = TreeSystem(charts=chart, ctrl=tuple(float(c) for c in controls), uncovered=tuple(gaps.items()),
                        source=source)
    if not np.any(qvel):
        kicked = kick(model, system, qpos)
        qvel = kicked  # at θ = 0 (the charts are centred at the start) MuJoCo's qvel is q̇ itself
        start = start.replace(" at rest", "") + " with every joint set moving (kinetic energy ½ m g L)"
    binding = functools.partial(TreeBinding, charts=chart)
    # what the reference leaves out is the tree's "not examined", said once wherever it lands (report, lines)
    description = f"{path.name}: its own kinematic tree ({model.nv} dof), from {start}"
    floating = system.dynamics(compile_model(path, edit=system.edit)).free_floating
    case = Case(name=model_name(path), system=TREE, mjcf=path.resolve(),
                motion=motion(model, qpos, qvel, horizon=horizon or HORIZON_CAP, description=description),
                wiring=Wiring(binding=binding, description=description,
                              invariants=total_momentum() if floating else {}), tree=system)
    if horizon is None:
        clock = time.perf_counter()
        isolated = compile_model(path, edit=case.prepare)
        chosen, why_horizon = chaos_horizon(case, isolated)
        case = case.with_motion(horizon=chosen)
        case = dataclasses.replace(case, tree=dataclasses.replace(system, horizon_note=why_horizon,
                                                                  horizon_seconds=time.perf_counter() - clock))
    return case

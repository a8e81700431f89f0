"""A float32 backend's constraint solve, completed in float64: what its solver's stop leaves in each figure.

MJX and MuJoCo Warp solve the constraints as MuJoCo does (computation/index.rst,
"Constraint solver"): a primal Newton (or CG) iteration on the acceleration a,
minimising the cost ½(a − a₀)ᵀM(a − a₀) + s(J a − a_ref), with the forces read
off the iterate, f = F(J a − a_ref). It stops when the cost improves by less
than ``tolerance`` × tr M. In float32 the cost cannot resolve an improvement
below a few ulps of itself, so the iteration stops wherever float32 stops seeing
progress, and the iterate's residual

    r = M a + c − τ_passive − Jᵀf        (the cost's gradient)

is left unbalanced, far above float32's round-off of the forces on a stiff contact
or a weld, while the improvement one more Newton step would make, ½ rᵀH⁻¹r, is
below one ulp u = 2⁻²³ of the cost: the stop is float32's (measured on MJX float32
at the sampled states: docs/findings/backends.md). A force or torque sensor on a
body whose joint carries nothing reads exactly r (the hub of hoop_ramp_contact);
every figure built from a and f carries its share.
Where it lands depends on the iteration's path, not on the masses' last bits,
so the round-off copies (:func:`harness.engine.variants.roundoff_copy`) do not
sample it, and at a softened budget level it lands elsewhere: extrapolating the
levels to ε → 0 then reads the difference of two stops as softness.

:func:`completed_forward` takes the step the backend's solver could not: at each
state, with H = ∂r/∂a and ∂F/∂a taken at the C engine's own solution of the same
state (M less the derivative of the constraint forces Jᵀ F, the C engine's
``mj_constraintUpdate`` at the model's rows, by central differences: F is smooth
within the piece of the solution's active set, linear outside an elliptic
cone's middle zone), so the propagator is the right piece's even where the
backend's iterate sits across a row's switch,

    δa = H⁻¹ r,   a' = a − δa,   f' = f − (∂F/∂a) δa,

so that M a' + c − τ = Jᵀ f' up to float64 round-off. Only the backend's own
residual is removed: a backend whose forces are wrong but balanced (a wrong
a_ref, a missing term, a wrong damping) has r ≈ 0 and is left as it is, and
H is only the propagator (a stiff row absorbs the residual whatever its exact
regulariser: the backend's diagonal approximation against the C engine's exact
diagonal changes δf by O(1 − d) of itself). The reaction sensors and
``cfrc_int``/``cfrc_ext`` move by the C engine's ``mj_rnePostConstraint`` and
``mj_sensorAcc`` of the change, which are affine in (a, f) at a fixed state.

A state is completed only where the stop is float32's: the improvement left,
½ rᵀH⁻¹r, at most :func:`resolution` machine epsilons of the cost at the C
engine's solution (the cost is a sum of ``nv² + nefc`` rounded terms, each off
by up to u of itself; two such sums compared by the stop differ spuriously by up
to 2 (nv² + nefc) u × the cost). Beyond it the solver stopped short of what its
precision resolves: that state keeps the backend's numbers, unexplained.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace

import mujoco
import numpy as np

from harness.core.trajectory import Trajectory
from harness.engine.backends import Forward, computes_reactions
from harness.engine.constraints import equality_rows
from harness.engine.probe import Probe

__all__ = ["completed_forward", "completed_run", "resolution"]

FD_STEP = 1e-6
"""Central-difference step for H and ∂F/∂a, relative to max(1, |a|): F is smooth within a piece of the active
set (linear outside an elliptic cone's middle zone), and a piece spans the distance to the nearest change of a
row's state."""


def resolution(nv: int, nefc: int) -> float:
    """The improvement, in machine epsilons × the cost, below which a solver's stop is its precision's:
    2 (nv² + nefc) (module docstring)."""
    return 2.0 * (nv * nv + nefc)


@dataclass(frozen=True)
class Completion:
    """The backend's forward pass with its stopped solve completed at every state it may be.

    Attributes:
        forward: the completed arrays (the backend's own at states left as they are).
        kept: per state, whether the backend's numbers were kept: its stop left more improvement than its
            precision explains (:func:`resolution`), or the completion did not converge.
        improvement: per state, ½ rᵀH⁻¹r / (u × the cost): what one more Newton step would gain, in the
            precision's units (:func:`resolution` is the most a stop explains).
    """

    forward: Forward
    kept: np.ndarray
    improvement: np.ndarray

    def note(self) -> str:
        """One line on where the completion was not applied, or ""."""
        skipped = int(np.count_nonzero(self.kept))
        if not skipped:
            return ""
        return (f"solver stop: at {skipped} of {self.kept.size} states the backend's solve stopped with more "
                f"improvement left (up to {float(np.max(self.improvement[self.kept])):.3g} u × the cost, "
                "explained up to 2 (nv² + nefc)) or the completion did not converge; those states keep its numbers")


def _jar(model: mujoco.MjModel, data: mujoco.MjData, qacc: np.ndarray) -> np.ndarray:
    """J a − a_ref over the C engine's rows (``data`` after ``mj_forward``)."""
    jar = np.zeros(data.nefc)
    mujoco.mj_mulJacVec(model, data, jar, qacc)
    return jar - data.efc_aref[:data.nefc]


def _constraint_force(model: mujoco.MjModel, data: mujoco.MjData, qacc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(Jᵀ F(J a − a_ref), F(J a − a_ref)) of the C engine's rows at acceleration ``qacc`` (``data`` after
    ``mj_forward``; its efc_force, efc_state and qfrc_constraint are overwritten)."""
    mujoco.mj_constraintUpdate(model, data, _jar(model, data, qacc), None, 0)
    return data.qfrc_constraint.copy(), data.efc_force[:data.nefc].copy()


def _cost(model: mujoco.MjModel, data: mujoco.MjData, mass: np.ndarray) -> float:
    """The solver's cost at the C engine's solution: ½(a − a₀)ᵀM(a − a₀) + s(J a − a_ref)."""
    cost = np.zeros(1)
    mujoco.mj_constraintUpdate(model, data, _jar(model, data, data.qacc), cost, 0)
    gap = data.qacc - data.qacc_smooth
    return float(0.5 * gap @ mass @ gap + cost[0])


def _reactions(model: mujoco.MjModel, data: mujoco.MjData, qacc: np.ndarray, force: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(sensordata, cfrc_int, cfrc_ext) of the C engine at acceleration ``qacc`` and row forces ``force``."""
    data.qacc[:] = qacc
    data.efc_force[:data.nefc] = force
    mujoco.mj_rnePostConstraint(model, data)
    mujoco.mj_sensorAcc(model, data)
    return data.sensordata.copy(), data.cfrc_int.copy(), data.cfrc_ext.copy()


def _hessian(model: mujoco.MjModel, data: mujoco.MjData, mass: np.ndarray, qacc: np.ndarray) -> np.ndarray:
    """H = M − ∂(Jᵀ F)/∂a at ``qacc``, by central differences (:data:`FD_STEP`)."""
    hessian = np.array(mass, dtype=float)
    step = FD_STEP * max(1.0, float(np.max(np.abs(qacc))))
    for j in range(model.nv):
        up, down = qacc.copy(), qacc.copy()
        up[j] += step
        down[j] -= step
        hessian[:, j] -= (_constraint_force(model, data, up)[0] - _constraint_force(model, data, down)[0]) / (2 * step)
    return hessian


def completed_forward(model: mujoco.MjModel, fwd: Forward, epsilon: float,
                      set_state: Callable[[mujoco.MjData, int], None]) -> Completion:
    """``fwd`` (the backend's forward at N states, in precision ``epsilon``) with each state's stopped solve
    completed in float64 (module docstring); ``set_state(data, k)`` puts state k into a C ``MjData``."""
    count = fwd.qacc.shape[0]
    out = {name: getattr(fwd, name).copy() for name in ("qacc", "qfrc_constraint")}
    equality = {c: v.copy() for c, v in fwd.equality.items()}
    reactions = False
    sensordata, cfrc_int, cfrc_ext = fwd.sensordata, fwd.cfrc_int, fwd.cfrc_ext
    if computes_reactions(model) and sensordata is not None and cfrc_int is not None and cfrc_ext is not None:
        reactions = True
        sensordata, cfrc_int, cfrc_ext = sensordata.copy(), cfrc_int.copy(), cfrc_ext.copy()
    kept = np.zeros(count, dtype=bool)
    improvement = np.zeros(count)
    data = mujoco.MjData(model)
    for k in range(count):
        mujoco.mj_resetData(model, data)
        set_state(data, k)
        mujoco.mj_forward(model, data)
        mass, a = fwd.mass[k], fwd.qacc[k]
        smooth = fwd.qfrc_bias[k] - fwd.qfrc_passive[k] - fwd.actuator(k)
        residual0 = mass @ a + smooth - fwd.qfrc_constraint[k]
        if data.nefc == 0 or not np.any(residual0):
            continue
        solution = data.qacc.copy(), data.efc_force[:data.nefc].copy()
        cost = _cost(model, data, mass)
        hessian = _hessian(model, data, mass, solution[0])
        delta = np.linalg.solve(hessian, residual0)
        improvement[k] = 0.5 * float(residual0 @ delta) / (epsilon * cost) if cost > 0 else np.inf
        if not improvement[k] <= resolution(model.nv, data.nefc):
            kept[k] = True
            continue
        # the rows' response to −δa, linear in C's piece: a central difference along it
        t = FD_STEP * max(1.0, float(np.max(np.abs(solution[0])))) / max(float(np.max(np.abs(delta))), 1e-300)
        up = _constraint_force(model, data, solution[0] - t * delta)
        down = _constraint_force(model, data, solution[0] + t * delta)
        change = (up[1] - down[1]) / (2 * t)
        out["qacc"][k] = a - delta
        out["qfrc_constraint"][k] = fwd.qfrc_constraint[k] + (up[0] - down[0]) / (2 * t)
        for c in equality:
            equality[c][k] = fwd.equality[c][k] + change[equality_rows(model, data, c)]
        if reactions:
            assert sensordata is not None and cfrc_int is not None and cfrc_ext is not None  # as reactions says
            before = _reactions(model, data, solution[0], solution[1])
            after = _reactions(model, data, solution[0] - delta, solution[1] + change)
            sensordata[k] += after[0] - before[0]
            cfrc_int[k] += after[1] - before[1]
            cfrc_ext[k] += after[2] - before[2]
    forward = replace(fwd, qacc=out["qacc"], qfrc_constraint=out["qfrc_constraint"], equality=equality,
                      sensordata=sensordata, cfrc_int=cfrc_int, cfrc_ext=cfrc_ext)
    return Completion(forward=forward, kept=kept, improvement=improvement)


def completed_run(model: mujoco.MjModel, probe: Probe, run: Trajectory, *, qpos: np.ndarray, qvel: np.ndarray,
                  fields: Mapping[str, np.ndarray], equality: Mapping[str, np.ndarray], epsilon: float) -> Trajectory:
    """``run`` (a float32 backend's, of ``model``) with its ``completed`` twin: at every sample, the solve the
    backend stopped completed in float64 (:func:`completed_forward`) from the state ``qpos``, ``qvel`` and the
    backend's arrays there (``fields``: qacc, qfrc_bias, qfrc_passive, qfrc_constraint and the dense mass
    matrix ``mass``; ``equality``: each named equality's efc_force rows, unsigned, in the C engine's row order
    for it), and the named equalities' multipliers and the generalized force taken from the completed arrays.
    Contact forces read from the backend's own rows (``probe.forces``) are left as run."""
    fwd = Forward(qacc=fields["qacc"], qfrc_bias=fields["qfrc_bias"], qfrc_passive=fields["qfrc_passive"],
                  qfrc_constraint=fields["qfrc_constraint"], mass=fields["mass"],
                  equality={c: np.reshape(v, (len(qpos), -1)) for c, v in equality.items()})

    def set_state(data: mujoco.MjData, k: int) -> None:
        data.qpos[:], data.qvel[:] = qpos[k], qvel[k]

    done = completed_forward(model, fwd, epsilon, set_state).forward
    multipliers = dict(run.multipliers)
    for c in equality:
        force = probe.sign(c) * done.equality[c]
        multipliers[c] = force[:, 0] if np.ndim(run.multipliers[c]) == 1 else force
    dof = probe.binding.dof_matrix(model)
    generalized = run.generalized_force if run.generalized_force is None or dof is None \
        else done.qfrc_constraint @ dof
    twin = dataclasses.replace(run, multipliers=multipliers, generalized_force=generalized, completed=None)
    return dataclasses.replace(run, completed=twin)

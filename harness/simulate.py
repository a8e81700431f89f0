"""Run a MuJoCo model and record a Trajectory whose every sample belongs to its state.

After ``mj_step`` the derived fields describe the state *before* the step, and
after an RK4 step ``efc_force``, ``qfrc_constraint`` and ``energy`` hold the
last Runge–Kutta stage (design.md, "Conventions"). So each step here is
``mj_forward`` (derived fields of the current state), record, then the
integrator's own function — the same work ``mj_step`` does, in the same order,
bit-identical to it (pinned in tests/test_simulate.py).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import mujoco
import numpy as np

from harness.binding import Binding, ModelMismatch
from harness.cases import Reading
from harness.trajectory import Trajectory


class SimulationDiverged(RuntimeError):
    """MuJoCo produced non-finite values or raised warnings (instability)."""


def _rk4(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    mujoco.mj_RungeKutta(model, data, 4)


# The integration stage each integrator runs after mj_forward inside mj_step.
# "discrete" folds its implicit update into the constraint solve, so its
# integration stage is the plain Euler update of the step map in qacc.
_STEP_FUNCTIONS: dict[str, Callable[[mujoco.MjModel, mujoco.MjData], None]] = {
    "Euler": mujoco.mj_Euler,
    "implicit": mujoco.mj_implicit,
    "implicitfast": mujoco.mj_implicit,
    "RK4": _rk4,
    "discrete": mujoco.mj_Euler,
}


def available_integrators() -> tuple[str, ...]:
    """Integrators this MuJoCo offers (``discrete`` only where it exists)."""
    names = {i.name.removeprefix("mjINT_") for i in mujoco.mjtIntegrator.__members__.values()}
    return tuple(k for k in _STEP_FUNCTIONS if k.upper() in names)


def integrator_enum(name: str) -> mujoco.mjtIntegrator:
    if name not in available_integrators():
        raise ValueError(f"unknown integrator {name!r}; this MuJoCo offers {list(available_integrators())}")
    return getattr(mujoco.mjtIntegrator, f"mjINT_{name.upper()}")


def integrator_name(model: mujoco.MjModel) -> str:
    value = int(model.opt.integrator)
    return next(k for k in available_integrators() if int(integrator_enum(k)) == value)


@dataclass(frozen=True)
class Probe:
    """What to read from MuJoCo: points, constraints (equalities) and the dof map."""

    binding: Binding
    points: Sequence[str]
    constraints: Sequence[str]
    invariants: Mapping[str, Reading] = field(default_factory=dict)
    forces: Mapping[str, Reading] = field(default_factory=dict)
    series: Mapping[str, Reading] = field(default_factory=dict)

    def validate(self, model: mujoco.MjModel) -> None:
        self.binding.validate(model)
        for name in self.points:
            if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name) < 0:
                raise ModelMismatch(f"model has no body {name!r} for point {name!r}")
        for name in self.constraints:
            if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_EQUALITY, name) < 0:
                known = [model.equality(i).name for i in range(model.neq)]
                raise ModelMismatch(f"model has no equality {name!r} (equalities: {known})")
        if not model.opt.enableflags & mujoco.mjtEnableBit.mjENBL_ENERGY:
            raise ModelMismatch("model must enable the energy flag (<flag energy=\"enable\"/>)")


def equality_rows(model: mujoco.MjModel, data: mujoco.MjData, name: str) -> np.ndarray:
    """Indices of the efc rows of equality ``name`` (efc_type EQUALITY, efc_id its id)."""
    eq_id = model.equality(name).id
    return np.flatnonzero((data.efc_type[: data.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY)
                          & (data.efc_id[: data.nefc] == eq_id))


def equality_force(model: mujoco.MjModel, data: mujoco.MjData, name: str) -> tuple[float, float]:
    """(efc_force, efc_pos) of a one-row equality constraint."""
    rows = equality_rows(model, data, name)
    if rows.size != 1:
        raise ModelMismatch(f"equality {name!r} has {rows.size} efc rows; one is expected")
    return float(data.efc_force[rows[0]]), float(data.efc_pos[rows[0]])


def point_state(model: mujoco.MjModel, data: mujoco.MjData, body: str) -> tuple[np.ndarray, np.ndarray]:
    """World position and linear velocity of a body's centre of mass."""
    bid = model.body(body).id
    jacp = np.zeros((3, model.nv))
    mujoco.mj_jacBodyCom(model, data, jacp, None, bid)
    return data.xipos[bid].copy(), jacp @ data.qvel


def check_healthy(data: mujoco.MjData, time: float) -> None:
    """Raise SimulationDiverged on non-finite state or any MuJoCo warning."""
    if not (np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel))
            and np.all(np.isfinite(data.qacc))):
        raise SimulationDiverged(f"non-finite state at t={time:.6g} s")
    raised = [mujoco.mjtWarning(i).name for i in range(len(data.warning)) if data.warning[i].number > 0]
    if raised:
        raise SimulationDiverged(f"MuJoCo warnings {raised} at t={time:.6g} s")


def simulate(
    model: mujoco.MjModel,
    probe: Probe,
    *,
    q0: Sequence[float],
    qd0: Sequence[float],
    steps: int,
) -> Trajectory:
    """Step ``model`` with its own integrator and timestep, recording every state.

    Returns ``steps + 1`` samples, t = 0 .. steps·h. Raises SimulationDiverged
    on NaN or MuJoCo warnings, ModelMismatch if the model lacks what the probe
    reads.
    """
    if steps < 1:
        raise ValueError(f"steps must be >= 1, got {steps}")
    probe.validate(model)
    step = _STEP_FUNCTIONS[integrator_name(model)]
    data = mujoco.MjData(model)
    probe.binding.set_state(model, data, q0, qd0)
    dof = probe.binding.dof_matrix(model)
    n = steps + 1
    t = np.zeros(n)
    pos = {p: np.zeros((n, 3)) for p in probe.points}
    vel = {p: np.zeros((n, 3)) for p in probe.points}
    lam = {c: np.zeros(n) for c in probe.constraints}
    viol = {c: np.zeros(n) for c in probe.constraints}
    energy = np.zeros(n)
    extra = {name: np.zeros(n) for name in probe.invariants}
    forces = {name: np.zeros(n) for name in probe.forces}
    series = {name: np.zeros(n) for name in probe.series}
    qfrc = np.zeros((n, model.nv))
    for k in range(n):
        mujoco.mj_forward(model, data)
        check_healthy(data, data.time)
        t[k] = data.time
        for p in probe.points:
            pos[p][k], vel[p][k] = point_state(model, data, p)
        for c in probe.constraints:
            lam[c][k], viol[c][k] = equality_force(model, data, c)
        energy[k] = data.energy[0] + data.energy[1]
        for name, read in probe.invariants.items():
            extra[name][k] = read(model, data)
        for name, read in probe.forces.items():
            forces[name][k] = read(model, data)
        for name, read in probe.series.items():
            series[name][k] = read(model, data)
        qfrc[k] = data.qfrc_constraint
        if k < steps:
            step(model, data)
    return Trajectory(
        t=t, positions=pos, velocities=vel, multipliers=lam | forces,
        generalized_force=None if dof is None else qfrc @ dof, invariants={"energy": energy} | extra, violations=viol,
        source=f"mujoco:{integrator_name(model)}", series=series,
    )

"""Build and solve the analytic reference of a case, and express it as a Trajectory.

The derivation is done once per system per process; the reference is solved
once per case and reused (dense output) for every integrator and timestep.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass

import mujoco
import numpy as np

from analytic.dynamics import Dynamics
from analytic.lagrangian import Derivation, LagrangianSystem
from analytic.solvers import DEFAULT_RTOL, Solution, solve
from analytic.systems import Scales, load
from harness.cases import Case
from harness.trajectory import Trajectory


@functools.cache
def derivation(system: str) -> Derivation:
    return load(system).build().derive()


@functools.cache
def _dynamics(system: str, params: tuple[tuple[str, float], ...]) -> Dynamics:
    return Dynamics.build(derivation(system), dict(params))


def dynamics(system: str, params: Mapping[str, float]) -> Dynamics:
    """Numeric dynamics of ``system`` at ``params`` (cached)."""
    return _dynamics(system, tuple(sorted(params.items())))


@dataclass(frozen=True)
class Reference:
    """A case's reference: parameters, scales and the dense solution."""

    case: Case
    params: Mapping[str, float]
    scales: Scales
    solution: Solution

    @property
    def dynamics(self) -> Dynamics:
        return self.solution.dynamics

    def q0(self) -> np.ndarray:
        return _ordered(self.case.q0, self.dynamics.coordinates, "q0")

    def qd0(self) -> np.ndarray:
        return _ordered(self.case.qd0, self.dynamics.coordinates, "qd0")


def _ordered(values: Mapping[str, float], order: tuple[str, ...], label: str) -> np.ndarray:
    if set(values) != set(order):
        raise ValueError(f"{label} must give exactly the coordinates {order}, got {tuple(values)}")
    return np.array([values[k] for k in order], dtype=float)


def build_reference(case: Case, model: mujoco.MjModel, *, rtol: float = DEFAULT_RTOL,
                    t_end: float | None = None) -> Reference:
    """Solve the case's system with the parameters read from ``model``."""
    module = load(case.system)
    params = module.params_from_model(model)
    dyn = dynamics(case.system, params)
    q0 = _ordered(case.q0, dyn.coordinates, "q0")
    qd0 = _ordered(case.qd0, dyn.coordinates, "qd0")
    sol = solve(dyn, q0=q0, qd0=qd0, t_end=t_end or case.horizon, rtol=rtol, atol=rtol)
    return Reference(case=case, params=params, scales=module.scales(params), solution=sol)


def minimal_system(case: Case) -> LagrangianSystem | None:
    module = load(case.system)
    return module.minimal() if hasattr(module, "minimal") else None


def trajectory(ref: Reference, t: np.ndarray) -> Trajectory:
    """The reference sampled at times t, in the common schema."""
    dyn = ref.dynamics
    q, qd = ref.solution.state(t)
    _, lam = dyn.accelerations(q, qd)
    pts = dyn.points(q)
    vels = dyn.point_velocities(q, qd)
    jac = dyn.jacobian(q)
    gen = np.einsum("nmk,nm->nk", jac, lam)
    pos_res = dyn.position_residual(q)
    invariants = {"energy": dyn.energy(q, qd)}
    momenta = dyn.momenta(q, qd)
    for k, name in enumerate(dyn.coordinates):
        if name in dyn.cyclic:
            invariants[f"p_{name}"] = momenta[:, k]
    return Trajectory(
        t=np.asarray(t, dtype=float),
        positions={p: pts[:, i] for i, p in enumerate(dyn.point_names)},
        velocities={p: vels[:, i] for i, p in enumerate(dyn.point_names)},
        multipliers={c: lam[:, j] for j, c in enumerate(dyn.constraint_names)},
        generalized_force=gen,
        invariants=invariants,
        violations={c: pos_res[:, j] for j, c in enumerate(dyn.constraint_names)},
        source="reference",
    )

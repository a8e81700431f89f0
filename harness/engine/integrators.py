"""MuJoCo's integrators by name: which this MuJoCo has, the integration stage of each, and its documented order.

MuJoCo's documentation describes five (computation/index.rst, "Integrators");
an older MuJoCo lacks some (``discrete`` is new in 4.0).

The orders (:data:`EXPECTED_ORDER`) come from MuJoCo's documentation, never from a measurement
(doc/computation/index.rst, "Numerical integration" and "Integrators"):

- ``Euler``: semi-implicit Euler, v⁺ = v + h a, q⁺ = q + h v⁺ (eq_semimplicit);
  with no joint damping the implicit-damping variant reduces to it. 1st order.
- ``implicit``, ``implicitfast``: one Newton step of implicit-in-velocity
  Euler, v⁺ = v + h M̂⁻¹ M a, q⁺ = q + h v⁺ (eq_implicit_update). 1st order.
- ``discrete``: "the same implicit update inside the constraint solve"
  (eq_discrete_update), qacc "as h → 0 converges to the continuous
  acceleration", and "the specified damping ratio is recovered as h → 0":
  an Euler-type one-step method, 1st order. Absent before MuJoCo 4; where it
  is absent the study says so in its rows, table and plot.
- ``RK4``: "the fixed-step 4th-order Runge-Kutta method". 4th order.
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import mujoco

__all__ = ["DOCUMENTED_INTEGRATORS", "EXPECTED_ORDER", "STEP_FUNCTIONS", "available_integrators", "integrator_enum",
           "integrator_name"]


def _rk4(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    mujoco.mj_RungeKutta(model, data, 4)


def _discrete(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """mj_Euler without its implicit damping (``eulerdamp`` off for the call): the damping is already in
    the step map qacc holds. mj_Euler as it is solves it a second time on a damped model (arm7 at its
    first step, tests/test_recording.py)."""
    flags = model.opt.disableflags
    model.opt.disableflags = flags | int(mujoco.mjtDisableBit.mjDSBL_EULERDAMP)
    try:
        mujoco.mj_Euler(model, data)
    finally:
        model.opt.disableflags = flags


# The integration stage each integrator runs after mj_forward inside mj_step.
# "discrete" folds its implicit update into the constraint solve, so its
# integration stage is the plain Euler update of the step map in qacc.
STEP_FUNCTIONS: dict[str, Callable[[mujoco.MjModel, mujoco.MjData], None]] = {
    "Euler": mujoco.mj_Euler,
    "implicit": mujoco.mj_implicit,
    "implicitfast": mujoco.mj_implicit,
    "RK4": _rk4,
    "discrete": _discrete,
}

# Integrators MuJoCo's documentation describes, of which an older MuJoCo lacks some.
DOCUMENTED_INTEGRATORS: tuple[str, ...] = tuple(STEP_FUNCTIONS)

EXPECTED_ORDER: dict[str, int] = {"Euler": 1, "implicit": 1, "implicitfast": 1, "RK4": 4, "discrete": 1}
"""Each integrator's documented order of accuracy (the module docstring gives the passages)."""


@functools.cache
def available_integrators() -> tuple[str, ...]:
    """Integrators this MuJoCo offers (``discrete`` only where it exists)."""
    names = {i.name.removeprefix("mjINT_") for i in mujoco.mjtIntegrator.__members__.values()}
    return tuple(k for k in STEP_FUNCTIONS if k.upper() in names)


def integrator_enum(name: str) -> mujoco.mjtIntegrator:
    if name not in available_integrators():
        raise ValueError(f"unknown integrator {name!r}; this MuJoCo offers {list(available_integrators())}")
    return getattr(mujoco.mjtIntegrator, f"mjINT_{name.upper()}")


def integrator_name(model: mujoco.MjModel) -> str:
    value = int(model.opt.integrator)
    return next(k for k in available_integrators() if int(integrator_enum(k)) == value)
